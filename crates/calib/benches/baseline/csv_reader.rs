//! The `imu.csv` and `turntable.csv` readers of `calib::io` on the csv crate (issue 11 up to
//! the hand-written block reader that replaced them), kept as the benchmark's baseline
//! (`benches/readers.rs`) and as the reference the new reader was compared with. Unchanged but
//! for the parts the benchmark does not use (opening files, the streaming `ImuReader`).

#![allow(dead_code)]

use calib::io::{
    ImuData, ImuKind, ImuRecord, IoError, TURNTABLE_COLUMNS, TurntableData, TurntableRecord,
};
use std::io::Read;

fn line_error(file: &str, line: usize, message: String) -> IoError {
    IoError::Line {
        file: file.to_string(),
        line,
        message,
    }
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

/// The reading of an `imu.csv` from any reader.
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

/// Parse the text of an `imu.csv`; `file` names it in errors.
pub fn parse_imu_csv(text: &str, file: &str) -> Result<ImuData, IoError> {
    ImuRows::new(text.as_bytes(), file)?.collect()
}

/// Parse the bytes of an `imu.csv` (not necessarily UTF-8); `file` names it in errors.
pub fn parse_imu_bytes(bytes: &[u8], file: &str) -> Result<ImuData, IoError> {
    ImuRows::new(bytes, file)?.collect()
}

/// Parse the bytes of a `turntable.csv` (not necessarily UTF-8); `file` names it in errors.
pub fn parse_turntable_bytes(bytes: &[u8], file: &str) -> Result<TurntableData, IoError> {
    read_turntable(bytes, file)
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
