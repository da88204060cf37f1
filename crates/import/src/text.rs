//! Delimited text read line by line: the wanted columns of every data row as numbers, each row
//! with its line number, every refusal naming the file, the line and what was expected.

use crate::error::ImportError;
use crate::fields::{Column, Input};
use std::io::BufRead;
use std::path::Path;

/// At most this many characters of a field are echoed in a message.
const ECHO_CHARS: usize = 60;

/// A field as a message shows it: whole if short, else its start, "..." and its length.
pub(crate) fn excerpt(field: &str) -> String {
    match field.char_indices().nth(ECHO_CHARS) {
        None => field.to_string(),
        Some((cut, _)) => format!("{}... ({} bytes)", &field[..cut], field.len()),
    }
}

/// A column the caller wants, and what it is for (named in messages, e.g. "gyro x").
pub(crate) struct Wanted<'a> {
    /// What the column holds, for messages.
    pub what: String,
    /// Where it is.
    pub column: &'a Column,
}

/// The longest line read: a row of a recording is at most a few hundred bytes, and a header
/// a few kilobytes; a line past this is not text of rows.
const MAX_LINE_BYTES: u64 = 1 << 20;

/// Lines of a text file, numbered from 1, with the checks every line needs: UTF-8, a line end
/// after the last line (a last line without one is taken as a file cut off mid-row).
struct Lines {
    reader: Box<dyn BufRead>,
    file: String,
    buf: Vec<u8>,
    line: usize,
}

impl Lines {
    /// The next line (without its line end) and its number; `None` at the end.
    fn next_line(&mut self) -> Result<Option<(usize, String)>, ImportError> {
        self.buf.clear();
        // At most one byte past the bound is read, so a file without line ends (/dev/zero, a
        // binary file) is refused at the bound instead of filling the memory.
        let n = std::io::Read::take(&mut self.reader, MAX_LINE_BYTES + 1)
            .read_until(b'\n', &mut self.buf)
            .map_err(|source| ImportError::read(&self.file, source))?;
        if n == 0 {
            return Ok(None);
        }
        self.line += 1;
        let ended = self.buf.last() == Some(&b'\n');
        if !ended && self.buf.len() as u64 > MAX_LINE_BYTES {
            return Err(ImportError::line(
                &self.file,
                self.line,
                format!(
                    "longer than the bound of {} for a line: expected a text file of rows \
                     (is it a binary file or a device?)",
                    sins_model::text::bound_text(MAX_LINE_BYTES)
                ),
            ));
        }
        let bom = "\u{feff}".as_bytes();
        let start = if self.line == 1 && self.buf.starts_with(bom) {
            bom.len()
        } else {
            0
        };
        let mut end = self.buf.len();
        while end > start && matches!(self.buf[end - 1], b'\n' | b'\r') {
            end -= 1;
        }
        let text = std::str::from_utf8(&self.buf[start..end]).map_err(|e| {
            ImportError::line(
                &self.file,
                self.line,
                format!(
                    "not UTF-8 text (byte {} of the line): expected a text file of numbers",
                    e.valid_up_to() + 1
                ),
            )
        })?;
        if !ended && !text.trim().is_empty() {
            return Err(ImportError::line(
                &self.file,
                self.line,
                format!(
                    "the last line has no line end: the file looks cut off in the middle of a \
                     row (`{}`); expected every row to end with a line end",
                    excerpt(text)
                ),
            ));
        }
        Ok(Some((self.line, text.to_string())))
    }
}

/// The data rows of a file, one at a time: the wanted columns of each as numbers, with its line
/// number. Nothing is held but the current row.
pub(crate) struct Rows {
    lines: Lines,
    input_delimiter: crate::fields::Delimiter,
    comment: Option<String>,
    skip_lines: usize,
    whats: Vec<String>,
    named: Vec<bool>,
    index: Vec<usize>,
    needed: usize,
    blank: Option<usize>,
    rows: usize,
    /// The wanted values of the current row.
    pub values: Vec<f64>,
}

impl Rows {
    /// Open `path` laid out as `input` says, past the skipped lines (`profile` names the
    /// profile in messages).
    pub fn open(
        path: &Path,
        input: &Input,
        wanted: &[Wanted<'_>],
        profile: &str,
    ) -> Result<Self, ImportError> {
        let mut lines = open_lines(path)?;
        let file = lines.file.clone();
        let index = column_indices(&mut lines, input, wanted)?;
        // A column named once by number and once by name is still one column.
        for (i, a) in index.iter().enumerate() {
            if let Some(j) = index[..i].iter().position(|b| b == a) {
                return Err(ImportError::line(
                    &file,
                    input.header_line.unwrap_or(1),
                    format!(
                        "the profile's {} and {} are the same field {} of the header line: \
                         expected each column to hold one quantity (check the columns in \
                         {profile})",
                        wanted[j].what,
                        wanted[i].what,
                        a + 1
                    ),
                ));
            }
        }
        let needed = index.iter().max().map_or(0, |m| m + 1);
        Ok(Self {
            lines,
            input_delimiter: input.delimiter,
            comment: input.comment.clone(),
            skip_lines: input.skip_lines,
            whats: wanted.iter().map(|w| w.what.clone()).collect(),
            named: wanted
                .iter()
                .map(|w| matches!(w.column, Column::Name(_)))
                .collect(),
            index,
            needed,
            blank: None,
            rows: 0,
            values: Vec::with_capacity(wanted.len()),
        })
    }

    /// The file's name in messages.
    pub fn file(&self) -> &str {
        &self.lines.file
    }

    /// Where wanted column `j` is, for messages: `", field 5"` for a column given by name,
    /// nothing for one given by number (the profile names it).
    pub fn place(&self, j: usize) -> String {
        if self.named[j] {
            format!(", field {}", self.index[j] + 1)
        } else {
            String::new()
        }
    }

    /// The next data row (its values in [`Rows::values`]) and its line; `None` after the last.
    /// A file without data rows is refused at its end.
    pub fn next_row(&mut self) -> Result<Option<usize>, ImportError> {
        while let Some((n, text)) = self.lines.next_line()? {
            let trimmed = text.trim_start();
            if trimmed.is_empty() {
                self.blank.get_or_insert(n);
                continue;
            }
            if let Some(c) = &self.comment
                && trimmed.starts_with(c.as_str())
            {
                continue;
            }
            let file = &self.lines.file;
            if let Some(b) = self.blank {
                return Err(ImportError::line(
                    file,
                    b,
                    "expected a data row, found an empty line before more data",
                ));
            }
            let fields: Vec<&str> = self.input_delimiter.split(&text).collect();
            if fields.len() < self.needed {
                let (w, _) = self
                    .whats
                    .iter()
                    .zip(&self.index)
                    .max_by_key(|(_, i)| **i)
                    .expect("at least one wanted column");
                return Err(ImportError::line(
                    file,
                    n,
                    format!(
                        "expected at least {} fields separated by {} (up to the {}), found {}",
                        self.needed,
                        self.input_delimiter.describe(),
                        w,
                        fields.len()
                    ),
                ));
            }
            self.values.clear();
            parse_row(
                file,
                n,
                &fields,
                &self.whats,
                &self.named,
                &self.index,
                &mut self.values,
            )?;
            self.rows += 1;
            return Ok(Some(n));
        }
        if self.rows == 0 {
            return Err(ImportError::line(
                &self.lines.file,
                self.lines.line + 1,
                format!(
                    "expected data rows after the {} skipped lines, found none",
                    self.skip_lines
                ),
            ));
        }
        Ok(None)
    }
}

/// The file's lines, from the first.
fn open_lines(path: &Path) -> Result<Lines, ImportError> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|source| ImportError::read(&file, source))?;
    Ok(Lines {
        reader: Box::new(std::io::BufReader::with_capacity(1 << 16, f)),
        file,
        buf: Vec::with_capacity(256),
        line: 0,
    })
}

/// Skip the lines before the data, and give the field index of each wanted column: numbers as
/// they are, names from the header line.
fn column_indices(
    lines: &mut Lines,
    input: &Input,
    wanted: &[Wanted<'_>],
) -> Result<Vec<usize>, ImportError> {
    let file = lines.file.clone();
    let delimiter = input.delimiter;
    let mut index: Vec<Option<usize>> = wanted
        .iter()
        .map(|w| match w.column {
            Column::Number(n) => Some(n - 1),
            Column::Name(_) => None,
        })
        .collect();
    for _ in 0..input.skip_lines {
        let Some((n, text)) = lines.next_line()? else {
            return Err(ImportError::line(
                &file,
                lines.line + 1,
                format!(
                    "the file ends within the {} lines the profile skips ([input] skip_lines): \
                     expected those lines and data rows after them",
                    input.skip_lines
                ),
            ));
        };
        if Some(n) == input.header_line {
            let names: Vec<&str> = delimiter
                .split(&text)
                .map(|s| s.trim_matches('"').trim())
                .collect();
            for (slot, w) in index.iter_mut().zip(wanted) {
                if let Column::Name(name) = w.column {
                    let at = names.iter().position(|x| x == name).ok_or_else(|| {
                        ImportError::line(
                            &file,
                            n,
                            format!(
                                "no column named `{}` on the header line (the profile's {}): \
                                 expected one of {} (separated by {})",
                                excerpt(name),
                                w.what,
                                excerpt(&names.join(", ")),
                                delimiter.describe()
                            ),
                        )
                    })?;
                    *slot = Some(at);
                }
            }
        }
    }
    Ok(index.into_iter().map(|i| i.unwrap_or(0)).collect())
}

/// The wanted fields of the data row on line `n` as numbers, appended to `values`.
fn parse_row(
    file: &str,
    n: usize,
    fields: &[&str],
    whats: &[String],
    named: &[bool],
    index: &[usize],
    values: &mut Vec<f64>,
) -> Result<(), ImportError> {
    for ((what, &named), &i) in whats.iter().zip(named).zip(index) {
        let f = fields[i];
        let place = if named {
            format!(", field {}", i + 1)
        } else {
            String::new()
        };
        let v = match f.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            Ok(_) => {
                return Err(ImportError::line(
                    file,
                    n,
                    format!(
                        "{}{place}: expected a finite number, found `{}`",
                        what,
                        excerpt(f)
                    ),
                ));
            }
            Err(_) => {
                return Err(ImportError::line(
                    file,
                    n,
                    format!("{}{place}: expected a number, found `{}`", what, excerpt(f)),
                ));
            }
        };
        values.push(v);
    }
    Ok(())
}
