//! The records of an `imu.csv` in rate form, read again from their source at every reading
//! ([`RateSource`]).

use crate::io::ImuKind;
use crate::io::ImuRecord;
use crate::io::source::ImuSource;

/// The records of an `imu.csv` in rate form (rate-form records as they are, increments divided
/// by their own interval, the first record by the median interval), read again from the source
/// at every reading: nothing is held but the source's own buffer (a file's, or its cache when
/// short).
pub struct RateSource<'a> {
    source: &'a mut dyn ImuSource,
    chunk: Vec<(ImuRecord, usize)>,
    /// Median interval of the records' time stamps (s), as [`crate::io::timing::median_interval`].
    pub median: f64,
    /// Number of records.
    pub records: usize,
}

impl<'a> RateSource<'a> {
    /// Records per chunk read from the source.
    const CHUNK: usize = 4096;

    /// The records of `source`; its median interval is found now, in four readings of the
    /// time stamps ([`sins_model::timing::StreamedIntervalMedian`]).
    pub fn new(source: &'a mut dyn ImuSource) -> Result<Self, String> {
        let mut me = Self {
            source,
            chunk: Vec::with_capacity(Self::CHUNK),
            median: f64::NAN,
            records: 0,
        };
        let mut median = sins_model::timing::StreamedIntervalMedian::new();
        let mut n = 0;
        me.records_of(&mut |r, _| {
            median.push(r.t);
            n += 1;
        })?;
        me.records = n;
        me.median = median.finish(|visit| me.records_of(&mut |r, _| visit(r.t)))?;
        Ok(me)
    }

    /// The file's name, for messages.
    pub fn file(&self) -> &str {
        self.source.file()
    }

    /// Increments or rates, as in the file.
    pub fn kind(&self) -> ImuKind {
        self.source.kind()
    }

    /// One reading of the records as they are in the file, with their lines.
    pub fn records_of(&mut self, visit: &mut dyn FnMut(&ImuRecord, usize)) -> Result<(), String> {
        crate::io::source::read_records(self.source, &mut self.chunk, &mut |r, line| {
            visit(r, line);
            true
        })
        .map_err(|e| e.to_string())
    }

    /// The source itself, for readings of its own kind (the records of a hand-turned
    /// recording's rests, its filter's passes) between those of the detector.
    pub fn source(&mut self) -> &mut dyn ImuSource {
        self.source
    }

    /// One reading of the records in rate form `(t, w, f)`.
    pub fn read(&mut self, visit: &mut dyn FnMut(f64, [f64; 3], [f64; 3])) -> Result<(), String> {
        let kind = self.kind();
        let median = self.median;
        let mut previous = f64::NAN;
        let mut first = true;
        self.records_of(&mut |r, _| {
            match kind {
                ImuKind::Rates => visit(r.t, r.gyro, r.accel),
                ImuKind::Increments => {
                    let dt = if first { median } else { r.t - previous };
                    visit(r.t, r.gyro.map(|x| x / dt), r.accel.map(|x| x / dt));
                }
            }
            first = false;
            previous = r.t;
        })
    }
}
