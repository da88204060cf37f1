//! The interchange formats (`docs`/design notes): `imu.csv`, `turntable.csv` and result JSON.
//!
//! - `imu.csv`: a header row, then `t,dthx,dthy,dthz,dvx,dvy,dvz` (increments over the interval
//!   ending at `t`, rad and m/s) or `t,wx,wy,wz,fx,fy,fz` (rates, rad/s and m/s^2), with an
//!   optional `temp` column (deg C). Columns may come in any order; `t` is on the IMU clock.
//! - `turntable.csv`: a header row, then `t,k1,k2,k3` (turntable clock, gimbal angles in degrees,
//!   heading-bank-pitch).
//! - results: `{"parameters": [{"name", "value", "sigma", "unit"}...]}`, SI units; `sigma` is
//!   left out for a truth file.
//!
//! Bad input is refused with an [`IoError`] naming the file, the 1-based line (the header is
//! line 1) and what was expected; nothing is dropped silently. Writers use the shortest text that
//! reads back to the identical `f64`.
//!
//! The CSV files are read by hand, not with the `csv` crate (about 1.8 times as fast for the
//! same checks and messages: `docs/performance.md`, "readers"): in large blocks, lines found
//! with `memchr`, UTF-8 checked a block at a time, fields split at commas and parsed with the
//! `fast-float2` crate, which gives the `f64` that `str::parse` gives and refuses what it
//! refuses. The reader takes no more than the format allows (`docs/formats.md`): no quoting and
//! no comments, `\n` or `\r\n` line ends, fields trimmed of spaces; every line is checked (UTF-8,
//! blank lines, a line end after the last one, number of fields, numbers).

pub mod angle_records;
pub mod correction_block;
pub mod posterior;
pub mod schema;
pub mod source;
pub mod timing;

/// The shortest recording calibrated (s, first to last time stamp).
pub const MIN_RECORDING_S: f64 = 1.0;

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::io::{BufRead, Read};
use std::path::Path;
use turntable::simulate::{ImuSample, Truth, TurntableSample};

/// Errors reading or writing interchange files.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Read {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{file}: cannot write: {source}")]
    Write {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// A line does not have the expected form.
    #[error("{file}: line {line}: {message}")]
    Line {
        /// File name.
        file: String,
        /// 1-based line number (header = 1).
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// The file as a whole is unusable (e.g. it does not overlap the IMU data in time).
    #[error("{file}: {message}")]
    File {
        /// File name.
        file: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A JSON file of another kind, or of a newer layout than this program reads (the message
    /// names the file).
    #[error("{message}")]
    Stamp {
        /// What was found and what was expected, with the file.
        message: String,
    },
    /// JSON that is not a result file.
    #[error("{file}: not a result file: {source}")]
    Json {
        /// File name.
        file: String,
        /// Cause (with line and column).
        source: serde_json::Error,
    },
}

/// What the IMU file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ImuKind {
    /// `dthx..dvz`: angle increments (rad) and velocity increments (m/s) over the interval ending
    /// at `t`.
    Increments,
    /// `wx..fz`: angular rate (rad/s) and specific force (m/s^2) at `t`.
    Rates,
}

impl ImuKind {
    /// The six data columns, gyro triad first.
    pub fn columns(self) -> [&'static str; 6] {
        match self {
            ImuKind::Increments => ["dthx", "dthy", "dthz", "dvx", "dvy", "dvz"],
            ImuKind::Rates => ["wx", "wy", "wz", "fx", "fy", "fz"],
        }
    }
}

/// One IMU row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuRecord {
    /// Time on the IMU clock (s) (end of the interval for increments).
    pub t: f64,
    /// `dth` (rad) or `w` (rad/s), body axes.
    pub gyro: [f64; 3],
    /// `dv` (m/s) or `f` (m/s^2), body axes.
    pub accel: [f64; 3],
    /// Temperature (deg C), when the file has a `temp` column.
    pub temp: Option<f64>,
}

impl ImuRecord {
    /// An increments record from the truth simulator.
    pub fn from_sample(s: &ImuSample) -> Self {
        Self {
            t: s.t,
            gyro: [s.dtheta.x, s.dtheta.y, s.dtheta.z],
            accel: [s.dv.x, s.dv.y, s.dv.z],
            temp: s.temp,
        }
    }
}

/// The contents of an `imu.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuData {
    /// Increments or rates.
    pub kind: ImuKind,
    /// Rows in time order (strictly increasing `t`).
    pub records: Vec<ImuRecord>,
}

impl ImuData {
    /// Increments from the truth simulator.
    pub fn from_samples(samples: &[ImuSample]) -> Self {
        Self {
            kind: ImuKind::Increments,
            records: samples.iter().map(ImuRecord::from_sample).collect(),
        }
    }

    /// First and last time stamp, `None` without records.
    pub fn span(&self) -> Option<(f64, f64)> {
        Some((self.records.first()?.t, self.records.last()?.t))
    }
}

/// One turntable row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurntableRecord {
    /// Time on the turntable clock (s).
    pub t: f64,
    /// Gimbal angles (heading, bank, pitch) (deg).
    pub k_deg: [f64; 3],
}

impl TurntableRecord {
    /// A record from the truth simulator.
    pub fn from_sample(s: &TurntableSample) -> Self {
        Self {
            t: s.t_tt,
            k_deg: s.k_deg,
        }
    }
}

/// The contents of a `turntable.csv`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TurntableData {
    /// Rows in time order (strictly increasing `t`).
    pub records: Vec<TurntableRecord>,
}

impl TurntableData {
    /// Records from the truth simulator.
    pub fn from_samples(samples: &[TurntableSample]) -> Self {
        Self {
            records: samples.iter().map(TurntableRecord::from_sample).collect(),
        }
    }

    /// First and last time stamp (turntable clock), `None` without records.
    pub fn span(&self) -> Option<(f64, f64)> {
        Some((self.records.first()?.t, self.records.last()?.t))
    }
}

/// Turntable columns.
pub const TURNTABLE_COLUMNS: [&str; 4] = ["t", "k1", "k2", "k3"];

fn line_error(file: &str, line: usize, message: String) -> IoError {
    IoError::Line {
        file: file.to_string(),
        line,
        message,
    }
}

/// A result or truth JSON, bounded ([`sins_model::text::RESULT_MAX_BYTES`]).
fn read_text(path: &Path) -> Result<String, IoError> {
    sins_model::text::read_text_bounded(
        path,
        sins_model::text::RESULT_MAX_BYTES,
        "result or truth JSON",
    )
    .map_err(|source| IoError::Read {
        file: path.display().to_string(),
        source,
    })
}

fn write_text(path: &Path, text: &str) -> Result<(), IoError> {
    std::fs::write(path, text).map_err(|source| IoError::Write {
        file: path.display().to_string(),
        source,
    })
}

/// At most this many characters of a field are echoed in a message (a 10-MB field is not).
const ECHO_CHARS: usize = 60;

/// A field as a message shows it: whole if short, else its start, "..." and its length.
fn excerpt(field: &str) -> String {
    match field.char_indices().nth(ECHO_CHARS) {
        None => field.to_string(),
        Some((cut, _)) => format!("{}... ({} bytes)", &field[..cut], field.len()),
    }
}

/// Bytes asked of the file at a time; the buffer grows for a line longer than this.
const BLOCK: usize = 1 << 18;

/// The longest line of a data file: a row is at most a few hundred bytes, a header a few
/// kilobytes, but a malformed field of megabytes is read to its end so that its line is
/// named with an excerpt; past this the line is not a row at all (a file without line ends,
/// a device). A multiple of [`BLOCK`], the size the buffer doubles from.
const MAX_LINE_BYTES: usize = 1 << 26;

/// The UTF-8 byte-order mark, skipped at the start of a file.
const BOM: &[u8] = "\u{feff}".as_bytes();

/// One non-blank line: its number, the file's name and its bytes (without the line end, and
/// without a byte-order mark at the start of the file), checked to be UTF-8.
struct Row<'a> {
    line: usize,
    file: &'a str,
    bytes: &'a [u8],
}

impl Row<'_> {
    /// The line as text (it was checked to be UTF-8, so this borrows and replaces nothing).
    fn text(&self) -> std::borrow::Cow<'_, str> {
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
struct Rows<R: Read> {
    reader: R,
    file: String,
    /// Bytes read; `buf[pos..end]` are not yet taken as lines.
    buf: Vec<u8>,
    pos: usize,
    end: usize,
    /// `buf[..searched]` holds no line end after `pos` (a long line is not searched again
    /// after every read).
    searched: usize,
    /// `buf[pos..checked]` (when `checked > pos`) is known to be UTF-8: the check is made on
    /// all the bytes read at once, and again only from where it stopped.
    checked: usize,
    /// The reader has no more bytes.
    eof: bool,
    /// Number of the line last taken (0 before the first).
    line: usize,
    /// Bytes of the line last taken, its line end included.
    line_bytes: usize,
    /// First blank line not yet followed by data (blank lines at the very end are fine).
    blank: Option<usize>,
}

impl<R: Read> Rows<R> {
    fn new(reader: R, file: &str) -> Self {
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
    fn next_line(&mut self) -> Result<Option<(usize, usize, bool)>, IoError> {
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
    fn fill(&mut self) -> Result<(), IoError> {
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
    fn check_utf8(&mut self, start: usize, stop: usize) -> Result<(), usize> {
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
    fn next_row(&mut self) -> Result<Option<Row<'_>>, IoError> {
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
    fn records_hint(&self, bytes: usize) -> usize {
        let n = bytes / self.line_bytes.max(1);
        n + n / 4
    }
}

/// Whether `str::trim` takes this byte off (the ASCII characters with Unicode's `White_Space`).
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t'..=b'\r')
}

/// A field (UTF-8) without the spaces around it, as [`str::trim`] takes them off: ASCII spaces
/// here, and when a non-ASCII character is left at either end (perhaps one of Unicode's other
/// spaces) by `str::trim` itself.
fn trim(field: &[u8]) -> &[u8] {
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

/// The size of a file in bytes, to reserve its records from (0 if unknown: nothing reserved).
pub(crate) fn file_size(path: &Path) -> usize {
    std::fs::metadata(path).map_or(0, |m| usize::try_from(m.len()).unwrap_or(usize::MAX))
}

/// A file opened for [`Rows`], which reads it in large blocks itself (a `BufReader` would only
/// copy them once more).
fn open_reader(path: &Path) -> Result<Box<dyn Read>, IoError> {
    let f = std::fs::File::open(path).map_err(|source| IoError::Read {
        file: path.display().to_string(),
        source,
    })?;
    Ok(Box::new(f))
}

/// One field as a number: trimmed, parsed with the `fast-float2` crate, which gives the same
/// `f64` as `str::parse` and refuses the same texts (`docs/performance.md`, "readers"), and
/// finite.
fn parse_field(row: &Row<'_>, name: &str, field: &[u8]) -> Result<f64, IoError> {
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
fn parse_row(row: &Row<'_>, names: &[String], out: &mut [f64]) -> Result<(), IoError> {
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
fn header<R: Read>(rows: &mut Rows<R>, expected: &str) -> Result<(usize, Vec<String>), IoError> {
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

fn check_time(file: &str, line: usize, t: f64, previous: Option<f64>) -> Result<(), IoError> {
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

/// The temperatures a `temp` column may hold (deg C): an inertial unit in a thermal chamber
/// runs from about -55 to +125 deg C (the military range); beyond -100 .. 200 a value is in
/// another unit (kelvin, Fahrenheit, raw counts) or not a temperature.
pub const TEMP_RANGE_DEG_C: std::ops::RangeInclusive<f64> = -100.0..=200.0;

const IMU_EXPECTED: &str = "t,dthx,dthy,dthz,dvx,dvy,dvz[,temp] or t,wx,wy,wz,fx,fy,fz[,temp]";

/// The kind of an `imu.csv` header and the column of `t` and each sensor value.
fn imu_columns(
    file: &str,
    hline: usize,
    names: &[String],
) -> Result<(ImuKind, [usize; 7], Option<usize>), IoError> {
    let expected = IMU_EXPECTED;
    let known = |kind: ImuKind, n: &str| kind.columns().contains(&n);
    let mut kinds = Vec::new();
    for n in names {
        let kind = if known(ImuKind::Increments, n) {
            ImuKind::Increments
        } else if known(ImuKind::Rates, n) {
            ImuKind::Rates
        } else if n == "t" || n == "temp" {
            continue;
        } else {
            return Err(line_error(
                file,
                hline,
                format!(
                    "unknown column `{}` in the header: expected {expected}",
                    excerpt(n)
                ),
            ));
        };
        if !kinds.contains(&kind) {
            kinds.push(kind);
        }
    }
    let kind = match kinds.as_slice() {
        [k] => *k,
        [] => {
            return Err(line_error(
                file,
                hline,
                format!("header has no sensor columns: expected {expected}"),
            ));
        }
        _ => {
            return Err(line_error(
                file,
                hline,
                format!("header mixes increments and rates: expected {expected}"),
            ));
        }
    };
    let index = |n: &str| names.iter().position(|x| x == n);
    let mut cols = [0usize; 7];
    for (slot, n) in cols
        .iter_mut()
        .zip(std::iter::once("t").chain(kind.columns()))
    {
        *slot = index(n).ok_or_else(|| {
            line_error(
                file,
                hline,
                format!(
                    "missing column `{n}` in the header: expected t,{}[,temp]",
                    kind.columns().join(",")
                ),
            )
        })?;
    }
    Ok((kind, cols, index("temp")))
}

/// The reading of an `imu.csv` from any reader: [`ImuReader`] over a file or a boxed reader,
/// [`parse_imu_csv`] over text in memory (copied a block at a time into the reader's buffer,
/// like a file).
struct ImuRows<R: Read> {
    rows: Rows<R>,
    names: Vec<String>,
    kind: ImuKind,
    cols: [usize; 7],
    temp: Option<usize>,
    previous: Option<f64>,
    values: Vec<f64>,
    records: usize,
    /// Line of the record last returned.
    line: usize,
}

impl<R: Read> ImuRows<R> {
    fn new(reader: R, file: &str) -> Result<Self, IoError> {
        let mut rows = Rows::new(reader, file);
        let (hline, names) = header(&mut rows, IMU_EXPECTED)?;
        let (kind, cols, temp) = imu_columns(file, hline, &names)?;
        Ok(Self {
            values: vec![0.0; names.len()],
            rows,
            names,
            kind,
            cols,
            temp,
            previous: None,
            records: 0,
            line: hline,
        })
    }

    fn next_record(&mut self) -> Result<Option<ImuRecord>, IoError> {
        let Some(row) = self.rows.next_row()? else {
            if self.records == 0 {
                return Err(line_error(
                    &self.rows.file,
                    self.line + 1,
                    "expected at least one data row after the header, found none".into(),
                ));
            }
            return Ok(None);
        };
        parse_row(&row, &self.names, &mut self.values)?;
        let v = &self.values;
        let c = &self.cols;
        let t = v[c[0]];
        check_time(row.file, row.line, t, self.previous)?;
        let temp = self.temp.map(|i| v[i]);
        if let Some(x) = temp.filter(|x| !TEMP_RANGE_DEG_C.contains(x)) {
            return Err(line_error(
                row.file,
                row.line,
                format!(
                    "temp {x}: expected a temperature in deg C within {} .. {} (the `temp` \
                     column; in kelvin or in raw counts?)",
                    TEMP_RANGE_DEG_C.start(),
                    TEMP_RANGE_DEG_C.end()
                ),
            ));
        }
        self.previous = Some(t);
        self.records += 1;
        self.line = row.line;
        Ok(Some(ImuRecord {
            t,
            gyro: [v[c[1]], v[c[2]], v[c[3]]],
            accel: [v[c[4]], v[c[5]], v[c[6]]],
            temp,
        }))
    }

    /// The records of a file of about `bytes` bytes.
    fn collect(mut self, bytes: usize) -> Result<ImuData, IoError> {
        let mut records = Vec::new();
        while let Some(r) = self.next_record()? {
            if records.is_empty() {
                records.reserve(self.rows.records_hint(bytes));
            }
            records.push(r);
        }
        Ok(ImuData {
            kind: self.kind,
            records,
        })
    }
}

/// An `imu.csv` read record by record, every record checked as it comes (numbers, time order),
/// so that a calibration never holds the whole file.
pub struct ImuReader {
    rows: ImuRows<Box<dyn Read>>,
}

impl std::fmt::Debug for ImuReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ImuReader")
            .field("file", &self.rows.rows.file)
            .field("kind", &self.rows.kind)
            .field("line", &self.rows.line)
            .finish()
    }
}

impl ImuReader {
    /// Open an `imu.csv` and read its header.
    pub fn open(path: &Path) -> Result<Self, IoError> {
        Ok(Self {
            rows: ImuRows::new(open_reader(path)?, &path.display().to_string())?,
        })
    }

    /// Read an `imu.csv` from any buffered reader; `file` names it in errors. (The reader's
    /// buffer is not needed: the bytes are read in large blocks.)
    pub fn from_reader(reader: Box<dyn BufRead>, file: &str) -> Result<Self, IoError> {
        let reader: Box<dyn Read> = reader;
        Ok(Self {
            rows: ImuRows::new(reader, file)?,
        })
    }

    /// Increments or rates.
    pub fn kind(&self) -> ImuKind {
        self.rows.kind
    }

    /// Whether the file has a `temp` column.
    pub fn has_temp(&self) -> bool {
        self.rows.temp.is_some()
    }

    /// The file name used in messages.
    pub fn file(&self) -> &str {
        &self.rows.rows.file
    }

    /// The line of the record last returned (1-based; the header is line 1).
    pub fn line(&self) -> usize {
        self.rows.line
    }

    /// About how many records a file of `bytes` bytes holds, from the length of the line last
    /// read (an allowance of a quarter for longer lines further on).
    pub(crate) fn records_hint(&self, bytes: usize) -> usize {
        self.rows.rows.records_hint(bytes)
    }

    /// The next record; `None` at the end (a file without records is refused).
    pub fn next_record(&mut self) -> Result<Option<ImuRecord>, IoError> {
        self.rows.next_record()
    }
}

/// Parse the text of an `imu.csv`; `file` names it in errors.
pub fn parse_imu_csv(text: &str, file: &str) -> Result<ImuData, IoError> {
    ImuRows::new(text.as_bytes(), file)?.collect(text.len())
}

/// Read an `imu.csv` whole (a calibration streams it instead: [`ImuReader`]).
pub fn read_imu_csv(path: &Path) -> Result<ImuData, IoError> {
    ImuReader::open(path)?.rows.collect(file_size(path))
}

/// Parse the text of a `turntable.csv`; `file` names it in errors.
pub fn parse_turntable_csv(text: &str, file: &str) -> Result<TurntableData, IoError> {
    read_turntable(text.as_bytes(), file, text.len())
}

/// A `turntable.csv` read record by record, every record checked as it comes (numbers, time
/// order), so that a calibration need not hold the whole file ([`crate::io::angle_records`]).
pub struct TurntableReader<R: Read = Box<dyn Read>> {
    rows: Rows<R>,
    names: Vec<String>,
    /// Positions of `t, k1, k2, k3` among the columns.
    cols: [usize; 4],
    /// Line of the header.
    header_line: usize,
    values: Vec<f64>,
    previous: Option<f64>,
    records_read: usize,
}

impl<R: Read> std::fmt::Debug for TurntableReader<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TurntableReader")
            .field("file", &self.rows.file)
            .field("records_read", &self.records_read)
            .finish()
    }
}

impl TurntableReader {
    /// Open a `turntable.csv` and read its header.
    pub fn open(path: &Path) -> Result<Self, IoError> {
        Self::new(open_reader(path)?, &path.display().to_string())
    }
}

impl<R: Read> TurntableReader<R> {
    /// Read a `turntable.csv` from any reader; `file` names it in errors.
    pub fn new(reader: R, file: &str) -> Result<Self, IoError> {
        let mut rows = Rows::new(reader, file);
        let expected = TURNTABLE_COLUMNS.join(",");
        let (header_line, names) = header(&mut rows, &expected)?;
        if let Some(n) = names
            .iter()
            .find(|n| !TURNTABLE_COLUMNS.contains(&n.as_str()))
        {
            return Err(line_error(
                file,
                header_line,
                format!(
                    "unknown column `{}` in the header: expected {expected}",
                    excerpt(n)
                ),
            ));
        }
        let mut cols = [0usize; 4];
        for (slot, n) in cols.iter_mut().zip(TURNTABLE_COLUMNS) {
            *slot = names.iter().position(|x| x == n).ok_or_else(|| {
                line_error(
                    file,
                    header_line,
                    format!("missing column `{n}` in the header: expected {expected}"),
                )
            })?;
        }
        Ok(Self {
            rows,
            values: vec![0.0; names.len()],
            names,
            cols,
            header_line,
            previous: None,
            records_read: 0,
        })
    }

    /// The file's name, as errors give it.
    pub fn file(&self) -> &str {
        &self.rows.file
    }

    /// The next record and its line; `None` at the end. A file without a single record is
    /// refused at its end.
    pub fn next_record(&mut self) -> Result<Option<(TurntableRecord, usize)>, IoError> {
        let Some(row) = self.rows.next_row()? else {
            if self.records_read == 0 {
                return Err(line_error(
                    &self.rows.file,
                    self.header_line + 1,
                    "expected at least one data row after the header, found none".into(),
                ));
            }
            return Ok(None);
        };
        parse_row(&row, &self.names, &mut self.values)?;
        let line = row.line;
        let v = &self.values;
        let t = v[self.cols[0]];
        check_time(&self.rows.file, line, t, self.previous)?;
        self.previous = Some(t);
        self.records_read += 1;
        let k_deg = [v[self.cols[1]], v[self.cols[2]], v[self.cols[3]]];
        Ok(Some((TurntableRecord { t, k_deg }, line)))
    }

    /// The next record's time stamp alone; `None` at the end. For a file read through once
    /// already ([`TurntableReader::next_record`] checked every field): the other fields are
    /// not parsed (a reading for the median spacing costs a third of a full one), the stamp
    /// and its order are checked as there.
    pub fn next_time(&mut self) -> Result<Option<f64>, IoError> {
        let Some(row) = self.rows.next_row()? else {
            return Ok(None);
        };
        let col = self.cols[0];
        let field = row.bytes.split(|&b| b == b',').nth(col);
        let t = match field.map(fast_float2::parse::<f64, _>) {
            Some(Ok(t)) if t.is_finite() => t,
            // Anything else is worded by the full parse.
            _ => {
                parse_row(&row, &self.names, &mut self.values)?;
                self.values[col]
            }
        };
        let line = row.line;
        check_time(&self.rows.file, line, t, self.previous)?;
        self.previous = Some(t);
        self.records_read += 1;
        Ok(Some(t))
    }

    /// An estimate of the records in `bytes` bytes of such a file, from the lines read so far.
    fn records_hint(&self, bytes: usize) -> usize {
        self.rows.records_hint(bytes)
    }
}

/// Read a `turntable.csv` of about `bytes` bytes (the records are reserved from it).
fn read_turntable<R: Read>(reader: R, file: &str, bytes: usize) -> Result<TurntableData, IoError> {
    let mut reader = TurntableReader::new(reader, file)?;
    let mut records = Vec::new();
    while let Some((r, _)) = reader.next_record()? {
        if records.is_empty() {
            records.reserve(reader.records_hint(bytes));
        }
        records.push(r);
    }
    Ok(TurntableData { records })
}

/// Read a `turntable.csv` whole (a calibration streams it instead:
/// [`crate::io::angle_records::AngleFile`]).
pub fn read_turntable_csv(path: &Path) -> Result<TurntableData, IoError> {
    read_turntable(
        open_reader(path)?,
        &path.display().to_string(),
        file_size(path),
    )
}

/// Shortest text that parses back to the identical `f64` (plain or exponent form).
pub fn format_f64(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// The text of an `imu.csv`. A `temp` column is written when any record has a temperature; then
/// every record must have one (else an error naming `file`).
pub fn format_imu_csv(data: &ImuData, file: &str) -> Result<String, IoError> {
    let has_temp = data.records.iter().any(|r| r.temp.is_some());
    let mut s = imu_csv_header(data.kind, has_temp);
    for (i, r) in data.records.iter().enumerate() {
        push_imu_row(&mut s, r, has_temp, i, file)?;
    }
    Ok(s)
}

/// The header line of an `imu.csv`.
fn imu_csv_header(kind: ImuKind, has_temp: bool) -> String {
    let mut s = String::from("t,");
    s += &kind.columns().join(",");
    if has_temp {
        s += ",temp";
    }
    s.push('\n');
    s
}

/// Append record `r` (the `i`-th, from 0) as an `imu.csv` line.
fn push_imu_row(
    s: &mut String,
    r: &ImuRecord,
    has_temp: bool,
    i: usize,
    file: &str,
) -> Result<(), IoError> {
    *s += &format_f64(r.t);
    for v in r.gyro.iter().chain(&r.accel) {
        s.push(',');
        *s += &format_f64(*v);
    }
    if has_temp {
        let Some(temp) = r.temp else {
            return Err(IoError::File {
                file: file.to_string(),
                message: format!(
                    "record {} has no temperature while others have: cannot write a \
                     `temp` column",
                    i + 1
                ),
            });
        };
        s.push(',');
        *s += &format_f64(temp);
    }
    s.push('\n');
    Ok(())
}

/// An `imu.csv` written record by record: the bytes of [`write_imu_csv`] for the same records,
/// without holding them. Whether it has a `temp` column is said at the start; then every record
/// must have a temperature.
pub struct ImuCsvWriter {
    out: std::io::BufWriter<std::fs::File>,
    file: String,
    has_temp: bool,
    records: usize,
    line: String,
}

impl ImuCsvWriter {
    /// Create the file at `path` and write its header.
    pub fn create(path: &Path, kind: ImuKind, has_temp: bool) -> Result<Self, IoError> {
        let file = path.display().to_string();
        let f = std::fs::File::create(path).map_err(|source| IoError::Write {
            file: file.clone(),
            source,
        })?;
        let mut w = Self {
            out: std::io::BufWriter::with_capacity(1 << 16, f),
            file,
            has_temp,
            records: 0,
            line: imu_csv_header(kind, has_temp),
        };
        w.flush_line()?;
        Ok(w)
    }

    fn flush_line(&mut self) -> Result<(), IoError> {
        use std::io::Write as _;
        self.out
            .write_all(self.line.as_bytes())
            .map_err(|source| IoError::Write {
                file: self.file.clone(),
                source,
            })?;
        self.line.clear();
        Ok(())
    }

    /// Write one record.
    pub fn write(&mut self, r: &ImuRecord) -> Result<(), IoError> {
        push_imu_row(&mut self.line, r, self.has_temp, self.records, &self.file)?;
        self.records += 1;
        self.flush_line()
    }

    /// Flush the file; the number of records written.
    pub fn finish(mut self) -> Result<usize, IoError> {
        use std::io::Write as _;
        self.out.flush().map_err(|source| IoError::Write {
            file: self.file.clone(),
            source,
        })?;
        Ok(self.records)
    }
}

/// Write an `imu.csv`.
pub fn write_imu_csv(path: &Path, data: &ImuData) -> Result<(), IoError> {
    let text = format_imu_csv(data, &path.display().to_string())?;
    write_text(path, &text)
}

/// The text of a `turntable.csv`.
pub fn format_turntable_csv(data: &TurntableData) -> String {
    let mut s = TURNTABLE_COLUMNS.join(",");
    s.push('\n');
    for r in &data.records {
        push_turntable_row(&mut s, r);
    }
    s
}

/// Append record `r` as a `turntable.csv` line.
fn push_turntable_row(s: &mut String, r: &TurntableRecord) {
    let _ = write!(
        s,
        "{},{},{},{}",
        format_f64(r.t),
        format_f64(r.k_deg[0]),
        format_f64(r.k_deg[1]),
        format_f64(r.k_deg[2])
    );
    s.push('\n');
}

/// A `turntable.csv` written record by record: the bytes of [`write_turntable_csv`] for the
/// same records, without holding them.
pub struct TurntableCsvWriter {
    out: std::io::BufWriter<std::fs::File>,
    file: String,
    records: usize,
    line: String,
}

impl TurntableCsvWriter {
    /// Create the file at `path` and write its header.
    pub fn create(path: &Path) -> Result<Self, IoError> {
        let file = path.display().to_string();
        let f = std::fs::File::create(path).map_err(|source| IoError::Write {
            file: file.clone(),
            source,
        })?;
        let mut line = TURNTABLE_COLUMNS.join(",");
        line.push('\n');
        let mut w = Self {
            out: std::io::BufWriter::with_capacity(1 << 16, f),
            file,
            records: 0,
            line,
        };
        w.flush_line()?;
        Ok(w)
    }

    fn flush_line(&mut self) -> Result<(), IoError> {
        use std::io::Write as _;
        self.out
            .write_all(self.line.as_bytes())
            .map_err(|source| IoError::Write {
                file: self.file.clone(),
                source,
            })?;
        self.line.clear();
        Ok(())
    }

    /// Write one record.
    pub fn write(&mut self, r: &TurntableRecord) -> Result<(), IoError> {
        push_turntable_row(&mut self.line, r);
        self.records += 1;
        self.flush_line()
    }

    /// Flush the file; the number of records written.
    pub fn finish(mut self) -> Result<usize, IoError> {
        use std::io::Write as _;
        self.out.flush().map_err(|source| IoError::Write {
            file: self.file.clone(),
            source,
        })?;
        Ok(self.records)
    }
}

/// Write a `turntable.csv`.
pub fn write_turntable_csv(path: &Path, data: &TurntableData) -> Result<(), IoError> {
    write_text(path, &format_turntable_csv(data))
}

/// Refuse a turntable file that does not overlap the IMU file in time. `imu_span` is the IMU
/// file's first and last stamp, `turntable_span_on_imu_clock` the turntable file's span mapped to
/// the IMU clock by the caller; `file` names the turntable file.
pub fn check_overlap(
    imu_span: (f64, f64),
    turntable_span_on_imu_clock: (f64, f64),
    file: &str,
) -> Result<(), IoError> {
    let (a0, a1) = imu_span;
    let (b0, b1) = turntable_span_on_imu_clock;
    if !(b0 <= a1 && b1 >= a0 && b0 <= b1 && a0 <= a1) {
        return Err(IoError::File {
            file: file.to_string(),
            message: format!(
                "the turntable data span {b0} s to {b1} s on the IMU clock and do not overlap \
                 the IMU data ({a0} s to {a1} s): expected turntable records during the IMU run \
                 (check the clock offset and the files)"
            ),
        });
    }
    // Two records, or a file cut after its first lines: the angles would be measured nowhere
    // and the refusal would blame the motion ("the angles stay constant").
    let overlap = b1.min(a1) - b0.max(a0);
    let least = MIN_RECORDING_S.min(a1 - a0);
    if overlap < least {
        return Err(IoError::File {
            file: file.to_string(),
            message: format!(
                "the turntable records overlap the IMU data for {overlap:.3} s only ({b0} s to \
                 {b1} s on the IMU clock, the IMU data {a0} s to {a1} s): expected turntable \
                 records over at least {least} s of the IMU run (a file cut short?)"
            ),
        });
    }
    Ok(())
}

/// One parameter of a result or truth file (SI units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResultParameter {
    /// Documented name, e.g. `gyro.theta.xy`.
    pub name: String,
    /// Value (SI).
    pub value: f64,
    /// Standard deviation (SI); absent in a truth file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma: Option<f64>,
    /// SI unit name.
    pub unit: String,
}

/// A result (or truth) file: `{"parameters": [...]}`, and in a calibration's result the
/// posterior `correlation` and the `correction` block (absent in older files and in truth
/// files; other keys such as `fit` are ignored when reading).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// The file's schema stamp ([`crate::io::schema`]; absent in files written before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schema: Option<crate::io::schema::Schema>,
    /// The unit the result is of (absent: not known).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<crate::config::UnitIdentity>,
    /// Parameters in state order.
    pub parameters: Vec<ResultParameter>,
    /// Correlation matrix of the parameters (rows and columns in the order of `parameters`),
    /// [`crate::io::posterior::correlation`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub correlation: Option<Vec<Vec<f64>>>,
    /// The estimated model inverted, in matrix form ([`crate::model::correction`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub correction: Option<correction_block::CorrectionBlock>,
    /// The verdict `calibrate` wrote beside them (read only: the writer of the result file
    /// writes its own), so that `apply` can refuse a calibration the data contradicted.
    #[serde(default, skip_serializing)]
    pub verdict: Option<ResultVerdict>,
    /// The temperatures of the recording and the reference the thermal terms are about, when
    /// the records had a temperature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<ResultTemperature>,
}

/// The temperature of a calibrated recording (deg C).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResultTemperature {
    /// The temperature the thermal coefficients are about, and the one at which the biases and
    /// scale factors of the result hold.
    pub reference_c: f64,
    /// Why this reference.
    pub reference_reason: String,
    /// Lowest temperature of the records (absent in a simulation's truth).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_c: Option<f64>,
    /// Highest temperature of the records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_c: Option<f64>,
}

/// The verdict of a result file: whether the data contradicted the model, and why.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
pub struct ResultVerdict {
    /// Nothing contradicted the model.
    pub fits: bool,
    /// One line per reason when something did.
    #[serde(default)]
    pub reasons: Vec<String>,
}

impl ResultFile {
    /// Value and sigma of a parameter by name.
    pub fn get(&self, name: &str) -> Option<&ResultParameter> {
        self.parameters.iter().find(|p| p.name == name)
    }
}

impl From<&Truth> for ResultFile {
    fn from(truth: &Truth) -> Self {
        Self {
            parameters: truth
                .parameters
                .iter()
                .map(|p| ResultParameter {
                    name: p.name.clone(),
                    value: p.value,
                    sigma: None,
                    unit: p.unit.clone(),
                })
                .collect(),
            correlation: None,
            correction: None,
            verdict: None,
            temperature: truth
                .temperature_reference_c
                .map(|reference_c| ResultTemperature {
                    reference_c,
                    reference_reason: "the simulation's reference temperature".into(),
                    min_c: None,
                    max_c: None,
                }),
            schema: Some(crate::io::schema::Schema::current(crate::io::schema::TRUTH)),
            unit: None,
        }
    }
}

/// Write a result file as pretty JSON.
pub fn write_result_json(path: &Path, result: &ResultFile) -> Result<(), IoError> {
    let text = serde_json::to_string_pretty(result).expect("plain data serialises");
    write_text(path, &(text + "\n"))
}

/// Write the truth of a simulated run (no sigma).
pub fn write_truth_json(path: &Path, truth: &Truth) -> Result<(), IoError> {
    write_result_json(path, &ResultFile::from(truth))
}

/// The kinds of file [`read_result_json`] reads: they all hold `parameters`.
pub const RESULT_KINDS: [&str; 3] = [
    crate::io::schema::CALIBRATION,
    crate::io::schema::TRUTH,
    crate::io::schema::DIAGNOSIS,
];

/// Read a result or truth file: every value finite and within the physical bounds of
/// [`crate::config::plausible`], each parameter named once, and its schema stamp neither of another
/// kind nor newer than this program ([`crate::io::schema::check`]).
pub fn read_result_json(path: &Path) -> Result<ResultFile, IoError> {
    let text = read_text(path)?;
    let file = path.display().to_string();
    let result: ResultFile = serde_json::from_str(&text).map_err(|source| IoError::Json {
        file: file.clone(),
        source,
    })?;
    if let Some(stamp) = &result.schema {
        let v = serde_json::to_value(stamp).expect("plain data");
        crate::io::schema::check(&file, Some(&v), &RESULT_KINDS, "a result or truth file")
            .map_err(|message| IoError::Stamp { message })?;
    }
    for (i, p) in result.parameters.iter().enumerate() {
        if result.parameters[..i].iter().any(|q| q.name == p.name) {
            return Err(IoError::File {
                file,
                message: format!(
                    "parameter `{}` is given twice: expected each name once",
                    excerpt(&p.name)
                ),
            });
        }
        if !p.value.is_finite() || p.sigma.is_some_and(|s| !s.is_finite()) {
            return Err(IoError::File {
                file,
                message: format!(
                    "parameter `{}`: expected a finite value and sigma",
                    excerpt(&p.name)
                ),
            });
        } // Physical bounds (`crate::config::plausible`): a bias of 1e308 or a 200 % scale error is a
        // typing error or a diverged fit, not a calibration to apply or a truth to compare with.
        if let Err(message) = crate::config::plausible::check(&p.name, p.value) {
            return Err(IoError::File {
                file,
                message: format!("parameter {message}"),
            });
        }
    }
    if let Some(r) = &result.correlation {
        crate::io::posterior::check_correlation(r, result.parameters.len())
            .map_err(|message| IoError::File { file, message })?;
    }
    Ok(result)
}

impl ResultFile {
    /// Refuse a parameter whose unit differs from the one the estimate uses (`expected` gives
    /// the SI unit by name; other names are not checked): values are SI, and a value in another
    /// unit would be compared as if it were.
    pub fn check_units<'a>(
        &self,
        file: &str,
        expected: impl Iterator<Item = (&'a str, &'a str)>,
    ) -> Result<(), IoError> {
        for (name, unit) in expected {
            if let Some(p) = self.get(name)
                && p.unit != unit
            {
                return Err(IoError::File {
                    file: file.to_string(),
                    message: format!(
                        "parameter `{name}` is in `{}`: expected `{unit}` (result and truth files \
                         hold SI values)",
                        excerpt(&p.unit)
                    ),
                });
            }
        }
        Ok(())
    }
}
