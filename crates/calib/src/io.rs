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
//! The CSV files are split into records by the `csv` crate, set up to accept no more than the
//! format allows (`docs/formats.md`): no quoting and no comments, `\n` or `\r\n` line ends,
//! fields trimmed of spaces; the checks of every line (UTF-8, blank lines, a line end after the
//! last one, number of fields, numbers) are made here, with the line numbers the csv reader's
//! positions give.

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
            records: samples
                .iter()
                .map(|s| ImuRecord {
                    t: s.t,
                    gyro: [s.dtheta.x, s.dtheta.y, s.dtheta.z],
                    accel: [s.dv.x, s.dv.y, s.dv.z],
                    temp: None,
                })
                .collect(),
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
            records: samples
                .iter()
                .map(|s| TurntableRecord {
                    t: s.t_tt,
                    k_deg: s.k_deg,
                })
                .collect(),
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

fn read_text(path: &Path) -> Result<String, IoError> {
    std::fs::read_to_string(path).map_err(|source| IoError::Read {
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

/// The reader under the csv crate: passes the bytes on and remembers how many came and the last
/// of them, so that the end of the last record can be told from the end of a line.
struct Tail<R> {
    inner: R,
    /// Bytes read so far.
    total: u64,
    /// The last byte read so far.
    last: Option<u8>,
}

impl<R: Read> Read for Tail<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if let Some(&b) = buf.get(..n).and_then(<[u8]>::last) {
            self.last = Some(b);
        }
        self.total += n as u64;
        Ok(n)
    }
}

/// One non-blank line: its number, the file's name and its fields (not trimmed).
struct Row<'a> {
    line: usize,
    file: &'a str,
    fields: &'a csv::StringRecord,
}

/// The lines of a comma-separated file read one record at a time with the csv crate, numbered
/// from 1, with the checks every line needs: valid UTF-8, no blank line before data, and a line
/// end after the last line (a last line without one is taken as a file cut off in the middle of
/// a row).
///
/// The csv reader is set up to take the file as the format defines it and nothing more: no
/// quoting (a `"` is an ordinary character, so a quoted field is refused as not a number), no
/// comments, a line end only at `\n` (a `\r` before it is trimmed off the last field with the
/// spaces; a lone `\r` is not a line end), any number of fields per line (the caller checks the
/// count and says what was expected; the csv crate's own check would also refuse a line of
/// spaces, which is a blank line here), and no trimming (fields are trimmed with [`str::trim`],
/// which knows all of Unicode's spaces). Records are read into a reused `ByteRecord` and checked
/// for UTF-8 by turning them into a `StringRecord` (an ASCII fast path, no copy), which keeps the
/// bytes of a bad record to name the byte of the line.
struct Rows<R: Read> {
    csv: csv::Reader<Tail<R>>,
    file: String,
    /// The record last read, kept to be read into again (no allocation per record).
    record: Option<csv::StringRecord>,
    /// No record has been read yet (a byte-order mark is skipped at the start of line 1).
    first: bool,
    /// First blank line not yet followed by data (blank lines at the very end are fine).
    blank: Option<usize>,
}

impl<R: Read> Rows<R> {
    fn new(reader: R, file: &str) -> Self {
        let csv = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .quoting(false)
            .terminator(csv::Terminator::Any(b'\n'))
            .buffer_capacity(1 << 16)
            .from_reader(Tail {
                inner: reader,
                total: 0,
                last: None,
            });
        Self {
            csv,
            file: file.to_string(),
            record: None,
            first: true,
            blank: None,
        }
    }

    /// The next non-blank line; `None` at the end of the file.
    fn next_row(&mut self) -> Result<Option<Row<'_>>, IoError> {
        let mut bytes = self
            .record
            .take()
            .map(csv::StringRecord::into_byte_record)
            .unwrap_or_default();
        loop {
            let more = self
                .csv
                .read_byte_record(&mut bytes)
                .map_err(|e| csv_error(&self.file, e))?;
            if !more {
                return Ok(None);
            }
            // The csv reader skips empty lines without a record: the record's position is where
            // reading began (the line after the previous record), the reader's where it ended.
            let start = bytes.position().map_or(1, csv::Position::line) as usize;
            let (after, tail) = (self.csv.position(), self.csv.get_ref());
            let ended = after.byte() < tail.total || tail.last == Some(b'\n');
            let line = (after.line() as usize).saturating_sub(usize::from(ended));
            // csv-core takes a byte-order mark off the start of the file when its first buffer
            // holds all of it: the bytes it consumed beyond the record and its line end tell.
            if std::mem::take(&mut self.first) && line == 1 {
                let record = bytes.as_slice().len() + bytes.len().saturating_sub(1);
                if after.byte() as usize <= record + usize::from(ended) {
                    bytes = without_bom(bytes);
                }
            }
            let record = csv::StringRecord::from_byte_record(bytes)
                .map_err(|e| not_utf8(&self.file, line, e))?;
            if line > start {
                self.blank.get_or_insert(start);
            }
            if record.len() == 1 && record.get(0).is_some_and(|f| f.trim().is_empty()) {
                self.blank.get_or_insert(line);
                bytes = record.into_byte_record();
                continue;
            }
            if let Some(b) = self.blank {
                return Err(line_error(
                    &self.file,
                    b,
                    "expected a data row, found an empty line before more data".into(),
                ));
            }
            if !ended {
                let text = record.iter().collect::<Vec<_>>().join(",");
                return Err(line_error(
                    &self.file,
                    line,
                    format!(
                        "the last line has no line end: the file looks cut off in the middle of \
                         a row (`{}`); expected every row to end with a line end",
                        excerpt(text.trim_end_matches('\r'))
                    ),
                ));
            }
            return Ok(Some(Row {
                line,
                file: &self.file,
                fields: self.record.insert(record),
            }));
        }
    }
}

/// The record with a UTF-8 byte-order mark taken off the start of its first field.
fn without_bom(bytes: csv::ByteRecord) -> csv::ByteRecord {
    let bom = "\u{feff}".as_bytes();
    match bytes.get(0).and_then(|f| f.strip_prefix(bom)) {
        None => bytes,
        Some(first) => {
            let mut out = csv::ByteRecord::new();
            out.push_field(first);
            for f in bytes.iter().skip(1) {
                out.push_field(f);
            }
            out
        }
    }
}

/// The refusal of a line that is not UTF-8, naming the byte of the line (1-based).
fn not_utf8(file: &str, line: usize, e: csv::FromUtf8Error) -> IoError {
    let (field, valid) = (e.utf8_error().field(), e.utf8_error().valid_up_to());
    let before: usize = e
        .into_byte_record()
        .iter()
        .take(field)
        .map(|f| f.len() + 1)
        .sum();
    line_error(
        file,
        line,
        format!(
            "not UTF-8 text (byte {} of the line): expected a text file of numbers",
            before + valid + 1
        ),
    )
}

/// A csv reader's error: reading failed (the others cannot happen with the reader set up as
/// [`Rows`] does; they are reported, not unwrapped).
fn csv_error(file: &str, e: csv::Error) -> IoError {
    match e.into_kind() {
        csv::ErrorKind::Io(source) => IoError::Read {
            file: file.to_string(),
            source,
        },
        other => IoError::File {
            file: file.to_string(),
            message: format!("cannot read as comma-separated text: {other:?}"),
        },
    }
}

fn open_reader(path: &Path) -> Result<Box<dyn BufRead>, IoError> {
    let f = std::fs::File::open(path).map_err(|source| IoError::Read {
        file: path.display().to_string(),
        source,
    })?;
    Ok(Box::new(std::io::BufReader::with_capacity(1 << 16, f)))
}

/// Parse one data row into its numbers (`out`, as many as `names`).
fn parse_row(row: &Row<'_>, names: &[String], out: &mut [f64]) -> Result<(), IoError> {
    let (file, line) = (row.file, row.line);
    for ((f, name), slot) in row.fields.iter().zip(names).zip(out.iter_mut()) {
        let f = f.trim();
        *slot = match f.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            Ok(_) => {
                return Err(line_error(
                    file,
                    line,
                    format!(
                        "column `{name}`: expected a finite number, found `{}`",
                        excerpt(f)
                    ),
                ));
            }
            Err(_) => {
                return Err(line_error(
                    file,
                    line,
                    format!("column `{name}`: expected a number, found `{}`", excerpt(f)),
                ));
            }
        };
    }
    let count = row.fields.len();
    if count != names.len() {
        return Err(line_error(
            file,
            line,
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
    let names: Vec<String> = row.fields.iter().map(|s| s.trim().to_string()).collect();
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
/// [`parse_imu_csv`] over text in memory (without a copy).
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
        self.previous = Some(t);
        self.records += 1;
        self.line = row.line;
        Ok(Some(ImuRecord {
            t,
            gyro: [v[c[1]], v[c[2]], v[c[3]]],
            accel: [v[c[4]], v[c[5]], v[c[6]]],
            temp: self.temp.map(|i| v[i]),
        }))
    }

    fn collect(mut self) -> Result<ImuData, IoError> {
        let mut records = Vec::new();
        while let Some(r) = self.next_record()? {
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
    rows: ImuRows<Box<dyn BufRead>>,
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
        Self::from_reader(open_reader(path)?, &path.display().to_string())
    }

    /// Read an `imu.csv` from any buffered reader; `file` names it in errors.
    pub fn from_reader(reader: Box<dyn BufRead>, file: &str) -> Result<Self, IoError> {
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

    /// The next record; `None` at the end (a file without records is refused).
    pub fn next_record(&mut self) -> Result<Option<ImuRecord>, IoError> {
        self.rows.next_record()
    }
}

/// Parse the text of an `imu.csv`; `file` names it in errors.
pub fn parse_imu_csv(text: &str, file: &str) -> Result<ImuData, IoError> {
    ImuRows::new(text.as_bytes(), file)?.collect()
}

/// Read an `imu.csv` whole (a calibration streams it instead: [`ImuReader`]).
pub fn read_imu_csv(path: &Path) -> Result<ImuData, IoError> {
    ImuReader::open(path)?.rows.collect()
}

/// Parse the text of a `turntable.csv`; `file` names it in errors.
pub fn parse_turntable_csv(text: &str, file: &str) -> Result<TurntableData, IoError> {
    read_turntable(text.as_bytes(), file)
}

fn read_turntable<R: Read>(reader: R, file: &str) -> Result<TurntableData, IoError> {
    let mut rows = Rows::new(reader, file);
    let expected = TURNTABLE_COLUMNS.join(",");
    let (hline, names) = header(&mut rows, &expected)?;
    if let Some(n) = names
        .iter()
        .find(|n| !TURNTABLE_COLUMNS.contains(&n.as_str()))
    {
        return Err(line_error(
            file,
            hline,
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
                hline,
                format!("missing column `{n}` in the header: expected {expected}"),
            )
        })?;
    }
    let mut records = Vec::new();
    let mut previous = None;
    let mut v = vec![0.0; names.len()];
    while let Some(row) = rows.next_row()? {
        parse_row(&row, &names, &mut v)?;
        let t = v[cols[0]];
        check_time(file, row.line, t, previous)?;
        previous = Some(t);
        records.push(TurntableRecord {
            t,
            k_deg: [v[cols[1]], v[cols[2]], v[cols[3]]],
        });
    }
    if records.is_empty() {
        return Err(line_error(
            file,
            hline + 1,
            "expected at least one data row after the header, found none".into(),
        ));
    }
    Ok(TurntableData { records })
}

/// Read a `turntable.csv` (12 bytes of memory per record on the IMU clock's side: small next
/// to the IMU file, which is streamed).
pub fn read_turntable_csv(path: &Path) -> Result<TurntableData, IoError> {
    read_turntable(open_reader(path)?, &path.display().to_string())
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
    let mut s = String::from("t,");
    s += &data.kind.columns().join(",");
    if has_temp {
        s += ",temp";
    }
    s.push('\n');
    for (i, r) in data.records.iter().enumerate() {
        s += &format_f64(r.t);
        for v in r.gyro.iter().chain(&r.accel) {
            s.push(',');
            s += &format_f64(*v);
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
            s += &format_f64(temp);
        }
        s.push('\n');
    }
    Ok(s)
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
    s
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

/// A result (or truth) file: `{"parameters": [...]}`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// Parameters in state order.
    pub parameters: Vec<ResultParameter>,
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

/// Read a result or truth file.
pub fn read_result_json(path: &Path) -> Result<ResultFile, IoError> {
    let text = read_text(path)?;
    let file = path.display().to_string();
    let result: ResultFile = serde_json::from_str(&text).map_err(|source| IoError::Json {
        file: file.clone(),
        source,
    })?;
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
        }
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
