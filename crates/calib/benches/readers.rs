//! The `imu.csv` reader (`calib::io::parse_imu_csv`, on the csv crate since issue 11) against
//! the hand-written line reader it replaced, kept here as the baseline, and against the bare csv
//! crate (a `StringRecord` per line and `str::parse`, no other check) as the floor.
//!
//! All three parse the same text (the paper run's 100-Hz increments, 272 700 records, 37.9 MB)
//! into rows of seven numbers with the line of each record, in one criterion group, so all run
//! in the same process on the same text; the two full readers are checked to give identical
//! records first.
//!
//! `cargo bench -p calib --bench readers`

use calib::config::RunConfig;
use calib::io::{ImuData, format_imu_csv, parse_imu_csv};
use calib::simulate::simulate_run;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

/// The bare csv crate on the same file: header width checked, every field parsed as f64, the
/// line of each record kept; none of the reader's other checks (time order, finite numbers,
/// blank lines, line end of the last line, column names).
fn parse_with_csv_crate(text: &str) -> Result<Vec<([f64; 7], u64)>, String> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(text.as_bytes());
    let header = rdr.headers().map_err(|e| e.to_string())?.clone();
    if header.len() != 7 {
        return Err(format!("header has {} columns, expected 7", header.len()));
    }
    let mut out = Vec::new();
    let mut rec = csv::StringRecord::new();
    while rdr.read_record(&mut rec).map_err(|e| e.to_string())? {
        let line = rec.position().map_or(0, |p| p.line());
        let mut row = [0.0; 7];
        for (i, f) in rec.iter().enumerate().take(7) {
            row[i] = f
                .trim()
                .parse::<f64>()
                .map_err(|e| format!("line {line}: field {}: {e}", i + 1))?;
        }
        out.push((row, line));
    }
    Ok(out)
}

fn bench(c: &mut Criterion) {
    let mut config = RunConfig::paper();
    config.truth.imu_rate_hz = 100.0;
    let sim = simulate_run(&config, "bench").unwrap();
    let text = format_imu_csv(&ImuData::from_samples(&sim.imu), "imu.csv").unwrap();
    let data = parse_imu_csv(&text, "imu.csv").unwrap();
    assert_eq!(hand_written::parse_imu_csv(&text, "imu.csv").unwrap(), data);
    let records = data.records.len();
    assert_eq!(parse_with_csv_crate(&text).unwrap().len(), records);
    let mut g = c.benchmark_group(format!(
        "imu.csv, {records} records, {} MB",
        text.len() / 1_000_000
    ));
    g.sample_size(10);
    g.bench_function("calib::io::parse_imu_csv (csv crate)", |b| {
        b.iter(|| black_box(parse_imu_csv(black_box(&text), "imu.csv").unwrap()))
    });
    g.bench_function("hand-written reader (before issue 11)", |b| {
        b.iter(|| black_box(hand_written::parse_imu_csv(black_box(&text), "imu.csv").unwrap()))
    });
    g.bench_function("bare csv crate (floor)", |b| {
        b.iter(|| black_box(parse_with_csv_crate(black_box(&text)).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

/// The hand-written `imu.csv` reader of `calib::io` before it moved to the csv crate (commit
/// c91f882), unchanged but for the parts the benchmark does not use (opening a file, the
/// turntable reader).
mod hand_written {
    use calib::io::{ImuData, ImuKind, ImuRecord, IoError};
    use std::io::BufRead;

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

    /// Lines of a delimited text file read one at a time, numbered from 1, with the checks every
    /// line needs: valid UTF-8, no blank line before data, and a line end after the last line (a
    /// last line without one is taken as a file cut off in the middle of a row).
    struct Lines {
        reader: Box<dyn BufRead>,
        file: String,
        buf: Vec<u8>,
        /// Number of the line in `buf`.
        line: usize,
        /// First blank line not yet followed by data (blank lines at the very end are fine).
        blank: Option<usize>,
    }

    impl Lines {
        fn new(reader: Box<dyn BufRead>, file: &str) -> Self {
            Self {
                reader,
                file: file.to_string(),
                buf: Vec::with_capacity(256),
                line: 0,
                blank: None,
            }
        }

        /// The next non-blank line and its number; `None` at the end of the file.
        fn next_line(&mut self) -> Result<Option<(usize, &str)>, IoError> {
            let (start, end) = loop {
                self.buf.clear();
                let n = self
                    .reader
                    .read_until(b'\n', &mut self.buf)
                    .map_err(|source| IoError::Read {
                        file: self.file.clone(),
                        source,
                    })?;
                if n == 0 {
                    return Ok(None);
                }
                self.line += 1;
                let ended = self.buf.last() == Some(&b'\n');
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
                let text = match std::str::from_utf8(&self.buf[start..end]) {
                    Ok(t) => t,
                    Err(e) => {
                        return Err(line_error(
                            &self.file,
                            self.line,
                            format!(
                                "not UTF-8 text (byte {} of the line): expected a text file of \
                                 numbers",
                                e.valid_up_to() + 1
                            ),
                        ));
                    }
                };
                if text.trim().is_empty() {
                    self.blank.get_or_insert(self.line);
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
                    return Err(line_error(
                        &self.file,
                        self.line,
                        format!(
                            "the last line has no line end: the file looks cut off in the middle of \
                             a row (`{}`); expected every row to end with a line end",
                            excerpt(text)
                        ),
                    ));
                }
                break (start, end);
            };
            let text = std::str::from_utf8(&self.buf[start..end]).expect("checked in the loop");
            Ok(Some((self.line, text)))
        }
    }

    /// Parse one data row into its numbers (`out`, as many as `names`).
    fn parse_row(
        file: &str,
        line: usize,
        text: &str,
        names: &[String],
        out: &mut [f64],
    ) -> Result<(), IoError> {
        let mut count = 0;
        for (k, f) in text.split(',').enumerate() {
            count = k + 1;
            if k >= names.len() {
                continue;
            }
            let f = f.trim();
            out[k] = match f.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                Ok(_) => {
                    return Err(line_error(
                        file,
                        line,
                        format!(
                            "column `{}`: expected a finite number, found `{}`",
                            names[k],
                            excerpt(f)
                        ),
                    ));
                }
                Err(_) => {
                    return Err(line_error(
                        file,
                        line,
                        format!(
                            "column `{}`: expected a number, found `{}`",
                            names[k],
                            excerpt(f)
                        ),
                    ));
                }
            };
        }
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
    fn header(lines: &mut Lines, expected: &str) -> Result<(usize, Vec<String>), IoError> {
        let file = lines.file.clone();
        let Some((n, text)) = lines.next_line()? else {
            return Err(line_error(
                &file,
                1,
                format!("empty file: expected a header row `{expected}` and data rows"),
            ));
        };
        let names: Vec<String> = text.split(',').map(|s| s.trim().to_string()).collect();
        for (i, name) in names.iter().enumerate() {
            if name.is_empty() {
                return Err(line_error(
                    &file,
                    n,
                    format!(
                        "header column {} is empty: expected a header row `{expected}`",
                        i + 1
                    ),
                ));
            }
            if names[..i].contains(name) {
                return Err(line_error(
                    &file,
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

    /// An `imu.csv` read record by record, every record checked as it comes (numbers, time order),
    /// so that a calibration never holds the whole file.
    pub struct ImuReader {
        lines: Lines,
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

    impl ImuReader {
        /// Read an `imu.csv` from any buffered reader; `file` names it in errors.
        pub fn from_reader(reader: Box<dyn BufRead>, file: &str) -> Result<Self, IoError> {
            let mut lines = Lines::new(reader, file);
            let (hline, names) = header(&mut lines, IMU_EXPECTED)?;
            let (kind, cols, temp) = imu_columns(file, hline, &names)?;
            Ok(Self {
                values: vec![0.0; names.len()],
                lines,
                names,
                kind,
                cols,
                temp,
                previous: None,
                records: 0,
                line: hline,
            })
        }

        /// Increments or rates.
        pub fn kind(&self) -> ImuKind {
            self.kind
        }

        /// The next record; `None` at the end (a file without records is refused).
        pub fn next_record(&mut self) -> Result<Option<ImuRecord>, IoError> {
            let file = self.lines.file.clone();
            let Some((n, text)) = self.lines.next_line()? else {
                if self.records == 0 {
                    return Err(line_error(
                        &file,
                        self.line + 1,
                        "expected at least one data row after the header, found none".into(),
                    ));
                }
                return Ok(None);
            };
            parse_row(&file, n, text, &self.names, &mut self.values)?;
            let v = &self.values;
            let c = &self.cols;
            let t = v[c[0]];
            check_time(&file, n, t, self.previous)?;
            self.previous = Some(t);
            self.records += 1;
            self.line = n;
            Ok(Some(ImuRecord {
                t,
                gyro: [v[c[1]], v[c[2]], v[c[3]]],
                accel: [v[c[4]], v[c[5]], v[c[6]]],
                temp: self.temp.map(|i| v[i]),
            }))
        }
    }

    /// Parse the text of an `imu.csv`; `file` names it in errors.
    pub fn parse_imu_csv(text: &str, file: &str) -> Result<ImuData, IoError> {
        let bytes = text.as_bytes().to_vec();
        collect_imu(ImuReader::from_reader(
            Box::new(std::io::Cursor::new(bytes)),
            file,
        )?)
    }

    fn collect_imu(mut reader: ImuReader) -> Result<ImuData, IoError> {
        let mut records = Vec::new();
        while let Some(r) = reader.next_record()? {
            records.push(r);
        }
        Ok(ImuData {
            kind: reader.kind(),
            records,
        })
    }
}
