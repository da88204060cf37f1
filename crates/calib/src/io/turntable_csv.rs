//! Turntable angle CSV files: read (held or streamed) and written.

use super::csv_lines::CsvLines;
use super::csv_rows::{Rows, check_time, excerpt, header, open_reader, parse_row};
use super::{
    IoError, TURNTABLE_COLUMNS, TurntableData, TurntableRecord, file_size, format_f64, line_error,
    write_text,
};
use std::fmt::Write as _;
use std::io::Read;
use std::path::Path;

/// Parse the text of a `turntable.csv`; `file` names it in errors.
pub fn parse_turntable_csv(text: &str, file: &str) -> Result<TurntableData, IoError> {
    read_turntable(text.as_bytes(), file, text.len())
}

/// A `turntable.csv` read record by record, every record checked as it comes (numbers, time
/// order), so that a calibration need not hold the whole file ([`crate::io::angle_records`]).
pub struct TurntableReader<R: Read = Box<dyn Read>> {
    pub(super) rows: Rows<R>,
    pub(super) names: Vec<String>,
    /// Positions of `t, k1, k2, k3` among the columns.
    pub(super) cols: [usize; 4],
    /// Line of the header.
    pub(super) header_line: usize,
    pub(super) values: Vec<f64>,
    pub(super) previous: Option<f64>,
    pub(super) records_read: usize,
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
    pub(super) fn records_hint(&self, bytes: usize) -> usize {
        self.rows.records_hint(bytes)
    }
}

/// Read a `turntable.csv` of about `bytes` bytes (the records are reserved from it).
pub(super) fn read_turntable<R: Read>(
    reader: R,
    file: &str,
    bytes: usize,
) -> Result<TurntableData, IoError> {
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
pub(super) fn push_turntable_row(s: &mut String, r: &TurntableRecord) {
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
    lines: CsvLines,
}

impl TurntableCsvWriter {
    /// Create the file at `path` and write its header.
    pub fn create(path: &Path) -> Result<Self, IoError> {
        let mut header = TURNTABLE_COLUMNS.join(",");
        header.push('\n');
        Ok(Self {
            lines: CsvLines::create(path, header)?,
        })
    }

    /// Write one record.
    pub fn write(&mut self, r: &TurntableRecord) -> Result<(), IoError> {
        push_turntable_row(&mut self.lines.line, r);
        self.lines.write_record()
    }

    /// Flush the file; the number of records written.
    pub fn finish(self) -> Result<usize, IoError> {
        self.lines.finish()
    }
}

/// Write a `turntable.csv`.
pub fn write_turntable_csv(path: &Path, data: &TurntableData) -> Result<(), IoError> {
    write_text(path, &format_turntable_csv(data))
}
