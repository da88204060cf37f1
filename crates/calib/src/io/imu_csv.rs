//! IMU CSV files: read (held or streamed record by record) and written.

use super::csv_lines::CsvLines;
use super::csv_rows::{Rows, check_time, excerpt, header, open_reader, parse_row};
use super::{ImuData, ImuKind, ImuRecord, IoError, file_size, format_f64, line_error, write_text};
use std::io::{BufRead, Read};
use std::path::Path;

/// The temperatures a `temp` column may hold (deg C): an inertial unit in a thermal chamber
/// runs from about -55 to +125 deg C (the military range); beyond -100 .. 200 a value is in
/// another unit (kelvin, Fahrenheit, raw counts) or not a temperature.
pub const TEMP_RANGE_DEG_C: std::ops::RangeInclusive<f64> = -100.0..=200.0;

pub(super) const IMU_EXPECTED: &str =
    "t,dthx,dthy,dthz,dvx,dvy,dvz[,temp] or t,wx,wy,wz,fx,fy,fz[,temp]";

/// The kind of an `imu.csv` header and the column of `t` and each sensor value.
pub(super) fn imu_columns(
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
pub(super) struct ImuRows<R: Read> {
    pub(super) rows: Rows<R>,
    pub(super) names: Vec<String>,
    pub(super) kind: ImuKind,
    pub(super) cols: [usize; 7],
    pub(super) temp: Option<usize>,
    pub(super) previous: Option<f64>,
    pub(super) values: Vec<f64>,
    pub(super) records: usize,
    /// Line of the record last returned.
    pub(super) line: usize,
}

impl<R: Read> ImuRows<R> {
    pub(super) fn new(reader: R, file: &str) -> Result<Self, IoError> {
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

    pub(super) fn next_record(&mut self) -> Result<Option<ImuRecord>, IoError> {
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
    pub(super) fn collect(mut self, bytes: usize) -> Result<ImuData, IoError> {
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
    pub(super) rows: ImuRows<Box<dyn Read>>,
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
pub(super) fn imu_csv_header(kind: ImuKind, has_temp: bool) -> String {
    let mut s = String::from("t,");
    s += &kind.columns().join(",");
    if has_temp {
        s += ",temp";
    }
    s.push('\n');
    s
}

/// Append record `r` (the `i`-th, from 0) as an `imu.csv` line.
pub(super) fn push_imu_row(
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
    lines: CsvLines,
    has_temp: bool,
}

impl ImuCsvWriter {
    /// Create the file at `path` and write its header.
    pub fn create(path: &Path, kind: ImuKind, has_temp: bool) -> Result<Self, IoError> {
        Ok(Self {
            lines: CsvLines::create(path, imu_csv_header(kind, has_temp))?,
            has_temp,
        })
    }

    /// Write one record.
    pub fn write(&mut self, r: &ImuRecord) -> Result<(), IoError> {
        let w = &mut self.lines;
        push_imu_row(&mut w.line, r, self.has_temp, w.records, &w.file)?;
        w.write_record()
    }

    /// Flush the file; the number of records written.
    pub fn finish(self) -> Result<usize, IoError> {
        self.lines.finish()
    }
}

/// Write an `imu.csv`.
pub fn write_imu_csv(path: &Path, data: &ImuData) -> Result<(), IoError> {
    let text = format_imu_csv(data, &path.display().to_string())?;
    write_text(path, &text)
}
