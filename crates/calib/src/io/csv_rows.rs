//! The reading of CSV text in blocks: rows with their line numbers, fields trimmed and parsed,
//! the header checked, and the time column checked.

use super::{IoError, line_error};
use std::io::Read;
use std::path::Path;

/// At most this many characters of a field are echoed in a message (a 10-MB field is not).
pub(super) const ECHO_CHARS: usize = 60;

/// A field as a message shows it: whole if short, else its start, "..." and its length.
pub(super) fn excerpt(field: &str) -> String {
    match field.char_indices().nth(ECHO_CHARS) {
        None => field.to_string(),
        Some((cut, _)) => format!("{}... ({} bytes)", &field[..cut], field.len()),
    }
}

/// Bytes asked of the file at a time; the buffer grows for a line longer than this.
pub(super) const BLOCK: usize = 1 << 18;

/// The longest line of a data file: a row is at most a few hundred bytes, a header a few
/// kilobytes, but a malformed field of megabytes is read to its end so that its line is
/// named with an excerpt; past this the line is not a row at all (a file without line ends,
/// a device). A multiple of [`BLOCK`], the size the buffer doubles from.
pub(super) const MAX_LINE_BYTES: usize = 1 << 26;

/// The UTF-8 byte-order mark, skipped at the start of a file.
pub(super) const BOM: &[u8] = "\u{feff}".as_bytes();

/// One non-blank line: its number, the file's name and its bytes (without the line end, and
/// without a byte-order mark at the start of the file), checked to be UTF-8.
pub(super) struct Row<'a> {
    pub(super) line: usize,
    pub(super) file: &'a str,
    pub(super) bytes: &'a [u8],
}

impl Row<'_> {
    /// The line as text (it was checked to be UTF-8, so this borrows and replaces nothing).
    pub(super) fn text(&self) -> std::borrow::Cow<'_, str> {
        String::from_utf8_lossy(self.bytes)
    }
}

/// The lines of a comma-separated file, numbered from 1, with the checks every line needs:
/// valid UTF-8, no blank line before data, and a line end after the last line (a last line
/// without one is taken as a file cut off in the middle of a row).
///
/// Written by hand rather than on the csv crate: it reads the file in blocks of [`BLOCK`] bytes
/// into one buffer, finds the line ends with `memchr`, checks UTF-8 a block at a time (not per
/// line or field), and hands out each line as bytes of that buffer, which [`parse_row`] splits
/// at commas and parses without making text of them; the numbers in `docs/performance.md`
/// ("readers"). It takes the file as the format defines it (`docs/formats.md`) and nothing
/// more, as the csv reader was set up to: no quoting (a `"` is an ordinary character, so a
/// quoted field is refused as not a number), no comments, a line end only at `\n` (a `\r`
/// before it is trimmed off the last field with the spaces; a lone `\r` is not a line end), any
/// number of fields per line (the caller checks the count and says what was expected), and
/// fields trimmed of spaces as [`str::trim`] does (all of Unicode's spaces).
pub(super) struct Rows<R: Read> {
    pub(super) reader: R,
    pub(super) file: String,
    /// Bytes read; `buf[pos..end]` are not yet taken as lines.
    pub(super) buf: Vec<u8>,
    pub(super) pos: usize,
    pub(super) end: usize,
    /// `buf[..searched]` holds no line end after `pos` (a long line is not searched again
    /// after every read).
    pub(super) searched: usize,
    /// `buf[pos..checked]` (when `checked > pos`) is known to be UTF-8: the check is made on
    /// all the bytes read at once, and again only from where it stopped.
    pub(super) checked: usize,
    /// The reader has no more bytes.
    pub(super) eof: bool,
    /// Number of the line last taken (0 before the first).
    pub(super) line: usize,
    /// Bytes of the line last taken, its line end included.
    pub(super) line_bytes: usize,
    /// First blank line not yet followed by data (blank lines at the very end are fine).
    pub(super) blank: Option<usize>,
}

impl<R: Read> Rows<R> {
    pub(super) fn new(reader: R, file: &str) -> Self {
        Self {
            reader,
            file: file.to_string(),
            buf: vec![0; BLOCK],
            pos: 0,
            end: 0,
            searched: 0,
            checked: 0,
            eof: false,
            line: 0,
            line_bytes: 0,
            blank: None,
        }
    }

    /// The next line as a range of the buffer without its `\n`, and whether a `\n` ended it
    /// (else it is the end of the file); `None` at the end of the file.
    pub(super) fn next_line(&mut self) -> Result<Option<(usize, usize, bool)>, IoError> {
        loop {
            let from = self.searched.max(self.pos);
            let unread = self.buf.get(from..self.end).unwrap_or_default();
            if let Some(i) = memchr::memchr(b'\n', unread) {
                let (start, stop) = (self.pos, from + i);
                self.pos = stop + 1;
                return Ok(Some((start, stop, true)));
            }
            self.searched = self.end;
            if self.eof {
                if self.pos >= self.end {
                    return Ok(None);
                }
                let start = self.pos;
                self.pos = self.end;
                return Ok(Some((start, self.end, false)));
            }
            self.fill()?;
        }
    }

    /// Read more bytes. When the buffer is full, the part of a line not yet taken is moved to
    /// its start (a copy of less than a line per block), and the buffer doubles if that part
    /// fills it (a line longer than the buffer).
    pub(super) fn fill(&mut self) -> Result<(), IoError> {
        if self.end == self.buf.len() {
            let pos = self.pos;
            self.buf.copy_within(pos..self.end, 0);
            self.end -= pos;
            self.searched = self.searched.saturating_sub(pos);
            self.checked = self.checked.saturating_sub(pos);
            self.pos = 0;
            if self.end == self.buf.len() {
                // A line past the bound is not a row (a file without line ends, /dev/zero):
                // refused here rather than doubling the buffer until the memory is gone.
                if self.buf.len() >= MAX_LINE_BYTES {
                    return Err(line_error(
                        &self.file,
                        self.line + 1,
                        format!(
                            "longer than the bound of {} MiB for a line: expected a text file \
                             of rows (is it a binary file or a device?)",
                            MAX_LINE_BYTES >> 20
                        ),
                    ));
                }
                self.buf.resize(2 * self.buf.len().max(1), 0);
            }
        }
        loop {
            let free = self.buf.get_mut(self.end..).unwrap_or_default();
            match self.reader.read(free) {
                Ok(0) => self.eof = true,
                Ok(n) => self.end += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(source) => {
                    return Err(IoError::Read {
                        file: self.file.clone(),
                        source,
                    });
                }
            }
            return Ok(());
        }
    }

    /// Whether `buf[start..stop]` is UTF-8; if not, the offset in it of the first bad byte.
    /// All the bytes read from `start` on are checked at once, so that the lines after this
    /// one are not checked again.
    pub(super) fn check_utf8(&mut self, start: usize, stop: usize) -> Result<(), usize> {
        if stop <= self.checked {
            return Ok(());
        }
        // `checked` is never inside a character: it ends text known to be UTF-8.
        let from = self.checked.max(start);
        let bytes = self.buf.get(from..self.end).unwrap_or_default();
        self.checked = match std::str::from_utf8(bytes) {
            Ok(_) => self.end,
            Err(e) => from + e.valid_up_to(),
        };
        if stop <= self.checked {
            Ok(())
        } else {
            Err(self.checked - start)
        }
    }

    /// The next non-blank line; `None` at the end of the file.
    pub(super) fn next_row(&mut self) -> Result<Option<Row<'_>>, IoError> {
        let (line, start, stop, ended) = loop {
            let Some((mut start, stop, ended)) = self.next_line()? else {
                return Ok(None);
            };
            self.line += 1;
            self.line_bytes = stop - start + usize::from(ended);
            let line = self.line;
            if line == 1
                && self
                    .buf
                    .get(start..stop)
                    .is_some_and(|b| b.starts_with(BOM))
            {
                start += BOM.len();
            }
            if let Err(bad) = self.check_utf8(start, stop) {
                return Err(line_error(
                    &self.file,
                    line,
                    format!(
                        "not UTF-8 text (byte {} of the line): expected a text file of numbers",
                        bad + 1
                    ),
                ));
            }
            let bytes = self.buf.get(start..stop).unwrap_or_default();
            // Nothing but spaces (so no comma): a blank line.
            if trim(bytes).is_empty() {
                self.blank.get_or_insert(line);
                continue;
            }
            break (line, start, stop, ended);
        };
        if let Some(b) = self.blank {
            return Err(line_error(
                &self.file,
                b,
                "expected a data row, found an empty line before more data".into(),
            ));
        }
        let row = Row {
            line,
            file: &self.file,
            bytes: self.buf.get(start..stop).unwrap_or_default(),
        };
        if !ended {
            return Err(line_error(
                row.file,
                line,
                format!(
                    "the last line has no line end: the file looks cut off in the middle of a \
                     row (`{}`); expected every row to end with a line end",
                    excerpt(row.text().trim_end_matches('\r'))
                ),
            ));
        }
        Ok(Some(row))
    }

    /// About how many records a file of `bytes` bytes holds if its lines are as long as the
    /// last one taken, and a quarter more: the records of a whole file are reserved at once
    /// from it rather than grown by doubling, which copied them (`docs/performance.md`,
    /// "readers"); what is reserved beyond them is never touched, so it takes no memory.
    pub(super) fn records_hint(&self, bytes: usize) -> usize {
        let n = bytes / self.line_bytes.max(1);
        n + n / 4
    }
}

/// Whether `str::trim` takes this byte off (the ASCII characters with Unicode's `White_Space`).
pub(super) fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t'..=b'\r')
}

/// A field (UTF-8) without the spaces around it, as [`str::trim`] takes them off: ASCII spaces
/// here, and when a non-ASCII character is left at either end (perhaps one of Unicode's other
/// spaces) by `str::trim` itself.
pub(super) fn trim(field: &[u8]) -> &[u8] {
    let mut f = field;
    while let [b, rest @ ..] = f
        && is_space(*b)
    {
        f = rest;
    }
    while let [rest @ .., b] = f
        && is_space(*b)
    {
        f = rest;
    }
    match (f.first(), f.last()) {
        (Some(a), Some(z)) if !a.is_ascii() || !z.is_ascii() => {
            std::str::from_utf8(field).map_or(f, |s| s.trim().as_bytes())
        }
        _ => f,
    }
}

/// A file opened for [`Rows`], which reads it in large blocks itself (a `BufReader` would only
/// copy them once more).
pub(super) fn open_reader(path: &Path) -> Result<Box<dyn Read>, IoError> {
    let f = std::fs::File::open(path).map_err(|source| IoError::Read {
        file: path.display().to_string(),
        source,
    })?;
    Ok(Box::new(f))
}

/// One field as a number: trimmed, parsed with the `fast-float2` crate, which gives the same
/// `f64` as `str::parse` and refuses the same texts (`docs/performance.md`, "readers"), and
/// finite.
pub(super) fn parse_field(row: &Row<'_>, name: &str, field: &[u8]) -> Result<f64, IoError> {
    let f = trim(field);
    let message = match fast_float2::parse::<f64, _>(f) {
        Ok(v) if v.is_finite() => return Ok(v),
        Ok(_) => "expected a finite number",
        Err(_) => "expected a number",
    };
    Err(line_error(
        row.file,
        row.line,
        format!(
            "column `{name}`: {message}, found `{}`",
            excerpt(&String::from_utf8_lossy(f))
        ),
    ))
}

/// Parse one data row into its numbers (`out`, as many as `names`). The fields are parsed in
/// order before their number is checked, so a bad number before a missing or extra field is
/// the one named.
pub(super) fn parse_row(row: &Row<'_>, names: &[String], out: &mut [f64]) -> Result<(), IoError> {
    let mut rest = Some(row.bytes);
    let mut count = 0;
    for (name, slot) in names.iter().zip(out.iter_mut()) {
        let Some(r) = rest else { break };
        count += 1;
        // The usual field, a finite number right up to the comma or the line end, is parsed in
        // place: one pass over its bytes instead of a search for the comma (a `memchr` call per
        // field, a tenth of the reading time), a trim and a parse. `parse_partial` reads the
        // longest number at the start and nothing after it, so that number is what `parse`
        // makes of the field alone; anything else (spaces, a bad or non-finite number) goes the
        // long way, which also words the message.
        if let Ok((v, n)) = fast_float2::parse_partial::<f64, _>(r)
            && v.is_finite()
        {
            match r.get(n) {
                None => {
                    (*slot, rest) = (v, None);
                    continue;
                }
                Some(b',') => {
                    (*slot, rest) = (v, r.get(n + 1..));
                    continue;
                }
                Some(_) => {}
            }
        }
        let (field, next) = match memchr::memchr(b',', r) {
            Some(i) => (r.get(..i).unwrap_or_default(), r.get(i + 1..)),
            None => (r, None),
        };
        rest = next;
        *slot = parse_field(row, name, field)?;
    }
    if let Some(r) = rest {
        count += 1 + memchr::memchr_iter(b',', r).count();
    }
    if count != names.len() {
        return Err(line_error(
            row.file,
            row.line,
            format!(
                "expected {} comma-separated fields ({}), found {count}",
                names.len(),
                names.join(",")
            ),
        ));
    }
    Ok(())
}

/// Header names, trimmed; refuses duplicates and empty names.
pub(super) fn header<R: Read>(
    rows: &mut Rows<R>,
    expected: &str,
) -> Result<(usize, Vec<String>), IoError> {
    let Some(row) = rows.next_row()? else {
        return Err(line_error(
            &rows.file,
            1,
            format!("empty file: expected a header row `{expected}` and data rows"),
        ));
    };
    let (file, n) = (row.file, row.line);
    let names: Vec<String> = row
        .text()
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    for (i, name) in names.iter().enumerate() {
        if name.is_empty() {
            return Err(line_error(
                file,
                n,
                format!(
                    "header column {} is empty: expected a header row `{expected}`",
                    i + 1
                ),
            ));
        }
        if names[..i].contains(name) {
            return Err(line_error(
                file,
                n,
                format!(
                    "header names column `{}` twice: expected `{expected}`",
                    excerpt(name)
                ),
            ));
        }
    }
    Ok((n, names))
}

pub(super) fn check_time(
    file: &str,
    line: usize,
    t: f64,
    previous: Option<f64>,
) -> Result<(), IoError> {
    if let Some(p) = previous
        && t <= p
    {
        return Err(line_error(
            file,
            line,
            format!(
                "time t = {t} is not after the previous row's t = {p}: expected strictly \
                 increasing time"
            ),
        ));
    }
    Ok(())
}
