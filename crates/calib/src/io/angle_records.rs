//! The turntable's angle records as a calibration reads them: in memory (a simulation, a parsed
//! file) or streamed from their file once per pass, like the IMU records
//! ([`crate::io::source::FileImu`]), so that memory does not grow with the run's length or the
//! angle rate.
//!
//! A calibration needs of the records, before the passes: their number, first and last stamps
//! and median spacing ([`AngleSummary`]), a sample of about two thousand for the clock check,
//! and (for a configuration that reads its program from the angles) one reading in order. The
//! passes then read them in order through a `RecordWindow`, which keeps only the records
//! near the interpolation cursor.

use crate::io::{IoError, TurntableData, TurntableReader, TurntableRecord};
use sins_model::timing::StreamedIntervalMedian;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};

/// What a calibration needs to know of the records before reading them in order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleSummary {
    /// Number of records.
    pub count: usize,
    /// First and last stamps (turntable clock, s).
    pub span: (f64, f64),
    /// Median spacing of the stamps (s; `NaN` with fewer than two records).
    pub median_interval: f64,
}

impl AngleSummary {
    fn of(records: &[TurntableRecord]) -> Self {
        Self {
            count: records.len(),
            span: span_of(records),
            median_interval: sins_model::timing::median_interval_of(records.iter().map(|r| r.t)),
        }
    }
}

/// First and last stamps (`NaN` without records).
fn span_of(records: &[TurntableRecord]) -> (f64, f64) {
    match (records.first(), records.last()) {
        (Some(a), Some(b)) => (a.t, b.t),
        _ => (f64::NAN, f64::NAN),
    }
}

/// A `turntable.csv` checked whole when opened and read again at every pass. Files of up to
/// [`AngleFile::CACHE_RECORDS`] records are kept in memory from the first reading (32 bytes a
/// record: 16 MB at most); a longer one is read again whenever it is needed (four more
/// readings for its median spacing, one per pass), so memory stays bounded whatever the
/// length of the run and the rate of the angles.
#[derive(Debug)]
pub struct AngleFile {
    path: PathBuf,
    file: String,
    summary: AngleSummary,
    cache: Option<Vec<TurntableRecord>>,
    /// Without the cache: every `2^j`-th record from the first, 2000 to 4000 of them (taken
    /// while the file is opened, for the clock check).
    sample: Vec<TurntableRecord>,
}

impl AngleFile {
    /// Records kept in memory at most (45 minutes of 1-kHz angles are 2.7 million).
    pub const CACHE_RECORDS: usize = 500_000;

    /// Open and read the file through (every record checked), keeping it in memory when short.
    pub fn open(path: &Path) -> Result<Self, IoError> {
        Self::open_with_cache(path, Self::CACHE_RECORDS)
    }

    /// [`AngleFile::open`] with at most `cache_records` records kept in memory (tests of the
    /// streamed path use a small one).
    pub fn open_with_cache(path: &Path, cache_records: usize) -> Result<Self, IoError> {
        let file = path.display().to_string();
        let mut reader = TurntableReader::open(path)?;
        let mut cache = Some(Vec::new());
        let mut count = 0usize;
        let mut span = (f64::NAN, f64::NAN);
        // The first of the median's four readings, and the clock check's sample, go with this
        // one: a long file is read four times before the passes rather than six.
        let mut median = StreamedIntervalMedian::new();
        let (mut sample, mut stride) = (Vec::new(), 1usize);
        while let Some((r, _)) = reader.next_record()? {
            if count == 0 {
                span.0 = r.t;
            }
            span.1 = r.t;
            median.push(r.t);
            if count.is_multiple_of(stride) {
                sample.push(r);
                if sample.len() == 4000 {
                    // Every other one: every (2 stride)-th record from the first.
                    sample = sample.into_iter().step_by(2).collect();
                    stride *= 2;
                }
            }
            count += 1;
            if let Some(c) = &mut cache {
                if c.len() < cache_records {
                    c.push(r);
                } else {
                    cache = None;
                }
            }
        }
        let mut out = Self {
            path: path.to_path_buf(),
            file,
            summary: AngleSummary {
                count,
                span,
                median_interval: f64::NAN,
            },
            sample: if cache.is_some() { Vec::new() } else { sample },
            cache,
        };
        out.summary.median_interval = match &out.cache {
            Some(c) => AngleSummary::of(c).median_interval,
            None => median.finish(|visit| out.for_each_time(visit))?,
        };
        Ok(out)
    }

    /// Visit every record's stamp in order (one reading, the stamps alone parsed).
    fn for_each_time(&self, visit: &mut dyn FnMut(f64)) -> Result<(), IoError> {
        let mut reader = TurntableReader::open(&self.path)?;
        let mut count = 0usize;
        while let Some(t) = reader.next_time()? {
            count += 1;
            if count > self.summary.count {
                return Err(changed(self, 0));
            }
            visit(t);
        }
        if count != self.summary.count {
            return Err(changed(self, 0));
        }
        Ok(())
    }

    /// The records, for the estimation.
    pub fn records(&self) -> AngleRecords<'_> {
        AngleRecords {
            source: match &self.cache {
                Some(c) => Source::Memory(c),
                None => Source::File(self),
            },
            file: &self.file,
        }
    }

    /// Whether the records are held in memory.
    pub fn is_cached(&self) -> bool {
        self.cache.is_some()
    }
}

#[derive(Clone, Copy, Debug)]
enum Source<'a> {
    Memory(&'a [TurntableRecord]),
    File(&'a AngleFile),
}

/// Turntable angle records and the name of their file: in memory, or an [`AngleFile`] read
/// again when needed.
#[derive(Clone, Copy, Debug)]
pub struct AngleRecords<'a> {
    source: Source<'a>,
    file: &'a str,
}

impl<'a> From<(&'a TurntableData, &'a str)> for AngleRecords<'a> {
    fn from((data, file): (&'a TurntableData, &'a str)) -> Self {
        Self {
            source: Source::Memory(&data.records),
            file,
        }
    }
}

impl<'a> AngleRecords<'a> {
    /// The file's name, for messages.
    pub fn file(&self) -> &'a str {
        self.file
    }

    /// Number of records, first and last stamps and median spacing.
    pub fn summary(&self) -> AngleSummary {
        match self.source {
            Source::Memory(r) => AngleSummary::of(r),
            Source::File(f) => f.summary,
        }
    }

    /// Visit every record in order (one reading of the file when it is not in memory).
    pub fn for_each(&self, mut visit: impl FnMut(&TurntableRecord)) -> Result<(), IoError> {
        match self.source {
            Source::Memory(r) => {
                r.iter().for_each(visit);
                Ok(())
            }
            Source::File(f) => {
                let mut reader = TurntableReader::open(&f.path)?;
                let mut count = 0usize;
                while let Some((r, line)) = reader.next_record()? {
                    count += 1;
                    if count > f.summary.count {
                        return Err(changed(f, line));
                    }
                    visit(&r);
                }
                if count != f.summary.count {
                    return Err(changed(f, 0));
                }
                Ok(())
            }
        }
    }

    /// About two thousand records spread over the file, for the clock check: every
    /// `count / 2000`-th from the first when in memory; for a streamed file the 2000 to 4000
    /// taken when it was opened (every `2^j`-th).
    pub fn clock_sample(&self) -> Vec<TurntableRecord> {
        match self.source {
            Source::Memory(r) => r.iter().step_by((r.len() / 2000).max(1)).copied().collect(),
            Source::File(f) => f.sample.clone(),
        }
    }

    /// Number of records and first and last stamps (the summary without its median, which a
    /// pass does not need and records in memory would work out again).
    fn extent(&self) -> (usize, (f64, f64)) {
        match self.source {
            Source::Memory(r) => (r.len(), span_of(r)),
            Source::File(f) => (f.summary.count, f.summary.span),
        }
    }

    /// The records of one pass, read in order.
    pub(crate) fn window(&self) -> Result<RecordWindow<'a>, IoError> {
        let (count, span) = self.extent();
        Ok(RecordWindow {
            count,
            span,
            access: match self.source {
                Source::Memory(r) => Access::Slice(r),
                Source::File(f) => Access::Stream {
                    file: f,
                    reader: Box::new(TurntableReader::open(&f.path)?),
                    buf: VecDeque::with_capacity(2 * RecordWindow::KEEP),
                    base: 0,
                },
            },
            error: None,
        })
    }
}

/// A file that no longer holds what it held when it was opened.
fn changed(f: &AngleFile, line: usize) -> IoError {
    let at = if line > 0 {
        format!(" (line {line})")
    } else {
        String::new()
    };
    IoError::File {
        file: f.file.clone(),
        message: format!(
            "the file changed while the calibration read it{at}: it held {} records when \
             opened; do not write to it during a calibration",
            f.summary.count
        ),
    }
}

enum Access<'a> {
    Slice(&'a [TurntableRecord]),
    Stream {
        file: &'a AngleFile,
        reader: Box<TurntableReader>,
        /// Records `base ..= base + buf.len() - 1`.
        buf: VecDeque<TurntableRecord>,
        base: usize,
    },
}

/// The records of one pass: any record by its index, as long as the indices asked for move
/// forward (a few records back at most, [`RecordWindow::KEEP`]); a streamed file keeps only
/// those.
pub(crate) struct RecordWindow<'a> {
    /// Number of records.
    pub count: usize,
    /// First and last stamps (turntable clock, s).
    pub span: (f64, f64),
    access: Access<'a>,
    /// The first error of reading the file (the pass reports it when it ends).
    error: Option<IoError>,
}

impl std::fmt::Debug for RecordWindow<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordWindow")
            .field("count", &self.count)
            .field("streamed", &matches!(self.access, Access::Stream { .. }))
            .finish()
    }
}

impl RecordWindow<'_> {
    /// Records kept behind the latest one asked for.
    pub const KEEP: usize = 256;

    /// Record `i`; `None` beyond the records, or when the file cannot be read (the error is
    /// kept: [`RecordWindow::take_error`]).
    #[inline(always)]
    pub fn get(&mut self, i: usize) -> Option<TurntableRecord> {
        match &mut self.access {
            Access::Slice(r) => r.get(i).copied(),
            Access::Stream {
                file,
                reader,
                buf,
                base,
            } => {
                if i < *base {
                    // The interpolation goes back a record or two at most.
                    self.error.get_or_insert_with(|| IoError::File {
                        file: file.file.clone(),
                        message: format!(
                            "internal: angle record {i} asked for after record {} (kept from \
                             {base})",
                            *base + buf.len()
                        ),
                    });
                    return None;
                }
                while *base + buf.len() <= i {
                    if self.error.is_some() || *base + buf.len() >= self.count {
                        return None;
                    }
                    match reader.next_record() {
                        Ok(Some((r, _))) => buf.push_back(r),
                        Ok(None) => {
                            self.error = Some(changed(file, 0));
                            return None;
                        }
                        Err(e) => {
                            self.error = Some(e);
                            return None;
                        }
                    }
                    if buf.len() > 2 * Self::KEEP {
                        buf.drain(..Self::KEEP);
                        *base += Self::KEEP;
                    }
                }
                buf.get(i - *base).copied()
            }
        }
    }

    /// The first error of reading the file, if any.
    pub fn take_error(&mut self) -> Option<IoError> {
        self.error.take()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, n: usize) -> PathBuf {
        let records = (0..n)
            .map(|i| TurntableRecord {
                t: 0.001 * i as f64 + if i % 7 == 3 { 2e-5 } else { 0.0 },
                k_deg: [0.01 * i as f64, -0.5 * i as f64, 3.0],
            })
            .collect();
        let path = dir.join("tt.csv");
        crate::io::write_turntable_csv(&path, &TurntableData { records }).unwrap();
        path
    }

    /// A file read in memory and the same file streamed give the same summary, sample and
    /// records, bit for bit.
    #[test]
    fn a_streamed_file_reads_as_the_file_in_memory() {
        let dir = std::env::temp_dir().join(format!("angle-records-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = write(&dir, 10_001);
        let whole = crate::io::read_turntable_csv(&path).unwrap();
        let memory: AngleRecords = (&whole, "tt.csv").into();
        let cached = AngleFile::open(&path).unwrap();
        let streamed = AngleFile::open_with_cache(&path, 100).unwrap();
        assert!(cached.is_cached() && !streamed.is_cached());
        for f in [&cached, &streamed] {
            let r = f.records();
            let s = r.summary();
            assert_eq!(s.count, memory.summary().count);
            assert_eq!(s.span, memory.summary().span);
            assert_eq!(
                s.median_interval.to_bits(),
                memory.summary().median_interval.to_bits()
            );
            let sample = r.clock_sample();
            if f.is_cached() {
                assert_eq!(sample, memory.clock_sample());
            } else {
                // 10 001 records: halved at 4000 kept (every 2nd), again at 4000 (every 4th).
                let every_4th: Vec<_> = whole.records.iter().step_by(4).copied().collect();
                assert_eq!(sample, every_4th);
            }
            let mut w = r.window().unwrap();
            // Forward with steps back of a record, as the interpolation asks.
            let mut i = 0;
            while i + 1 < whole.records.len() {
                assert_eq!(w.get(i + 1), Some(whole.records[i + 1]));
                assert_eq!(w.get(i), Some(whole.records[i]));
                i += 3;
            }
            assert_eq!(w.get(whole.records.len()), None);
            assert!(w.take_error().is_none());
        }
        // A file cut after it was opened: the pass says so, naming the file.
        let records = &whole.records[..1000];
        crate::io::write_turntable_csv(
            &path,
            &TurntableData {
                records: records.to_vec(),
            },
        )
        .unwrap();
        let mut w = streamed.records().window().unwrap();
        assert_eq!(w.get(2000), None);
        let e = w.take_error().expect("the file changed").to_string();
        assert!(e.contains("tt.csv") && e.contains("changed"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
