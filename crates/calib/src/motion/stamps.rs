//! The time stamps of a recording as the rules of a rest's and a turn's records ask for them
//! ([`Stamps`]: how many records are stamped before a time, and at or before it; the stamp of
//! a record; the median interval), held (`[f64]`) or counted in one reading of the records
//! ([`StampCounts`]), so that a long recording's rests are put on its records without holding
//! their times; and the walk of a reading through ranges of records ([`RangeWalk`]).
//!
//! A hand-turned recording is read again for every figure rather than held
//! (`docs/performance.md`, "Memory of every command on a long run"): its rests' records are
//! ranges of record indices ([`crate::motion::rests::Rest::records`]), found on the counts,
//! and each reading visits the records of every range it needs as they come.

use crate::io::ImuRecord;
use crate::io::source::{ImuSource, read_records};
use std::ops::Range;

/// What the rules of a rest's and a turn's records need of the records' increasing time
/// stamps.
pub trait Stamps {
    /// Number of records.
    fn count(&self) -> usize;
    /// How many records are stamped before `x` (`t < x`).
    fn before(&self, x: f64) -> usize;
    /// How many records are stamped at or before `x` (`t <= x`).
    fn through(&self, x: f64) -> usize;
    /// The stamp of record `k` (0-based), where known.
    fn stamp(&self, k: usize) -> Option<f64>;
    /// The median interval ([`sins_model::timing::median_interval`]).
    fn median_interval(&self) -> f64;
}

impl Stamps for [f64] {
    fn count(&self) -> usize {
        self.len()
    }
    fn before(&self, x: f64) -> usize {
        self.partition_point(|&t| t < x)
    }
    fn through(&self, x: f64) -> usize {
        self.partition_point(|&t| t <= x)
    }
    fn stamp(&self, k: usize) -> Option<f64> {
        self.get(k).copied()
    }
    fn median_interval(&self) -> f64 {
        sins_model::timing::median_interval(self)
    }
}

impl Stamps for Vec<f64> {
    fn count(&self) -> usize {
        self.len()
    }
    fn before(&self, x: f64) -> usize {
        self.as_slice().before(x)
    }
    fn through(&self, x: f64) -> usize {
        self.as_slice().through(x)
    }
    fn stamp(&self, k: usize) -> Option<f64> {
        self.get(k).copied()
    }
    fn median_interval(&self) -> f64 {
        sins_model::timing::median_interval(self)
    }
}

/// [`Stamps`] of records read once: the counts at the times asked for when the reading was
/// made, and the stamps of the records asked for, nothing else. The same answers as the held
/// stamps for those (`tests::counts_answer_as_the_held_stamps`); a time or record not asked
/// for is answered as none (`before` and `through` 0, `stamp` `None`), which no caller meets:
/// each asks for the rests' and turns' own times.
#[derive(Clone, Debug, Default)]
pub struct StampCounts {
    n: usize,
    median: f64,
    /// The times asked for, ascending (`total_cmp`), with how many records are stamped before
    /// each and at or before it.
    at: Vec<(f64, usize, usize)>,
    /// The records asked for, ascending, with their stamps.
    stamps: Vec<(usize, f64)>,
}

impl StampCounts {
    /// The counts at `times` and the stamps of `records` from one reading of `source`
    /// (increasing stamps, as every reader of records gives them); `median` is the records'
    /// median interval, known to the caller (the detector's, [`crate::motion::detect::RateSource`]).
    pub fn read(
        source: &mut dyn ImuSource,
        times: impl IntoIterator<Item = f64>,
        records: impl IntoIterator<Item = usize>,
        median: f64,
    ) -> Result<Self, crate::io::IoError> {
        let mut at: Vec<(f64, usize, usize)> = times
            .into_iter()
            .filter(|x| !x.is_nan())
            .map(|x| (x, 0, 0))
            .collect();
        at.sort_by(|a, b| a.0.total_cmp(&b.0));
        at.dedup_by(|a, b| a.0.total_cmp(&b.0).is_eq());
        let mut wanted: Vec<usize> = records.into_iter().collect();
        wanted.sort_unstable();
        wanted.dedup();
        let mut stamps = Vec::with_capacity(wanted.len());
        // The first time each count stops growing: the index of the record that passes it.
        let (mut below, mut upto, mut next) = (0usize, 0usize, 0usize);
        let mut k = 0usize;
        read_records(source, &mut Vec::new(), &mut |r, _| {
            while below < at.len() && at[below].0 <= r.t {
                at[below].1 = k;
                below += 1;
            }
            while upto < at.len() && at[upto].0 < r.t {
                at[upto].2 = k;
                upto += 1;
            }
            if wanted.get(next) == Some(&k) {
                stamps.push((k, r.t));
                next += 1;
            }
            k += 1;
            true
        })?;
        for a in &mut at[below..] {
            a.1 = k;
        }
        for a in &mut at[upto..] {
            a.2 = k;
        }
        Ok(Self {
            n: k,
            median,
            at,
            stamps,
        })
    }

    /// The same counts with the records' median interval `median` (found by the caller when
    /// a figure needs it: [`Stamps::median_interval`]).
    pub fn with_median(self, median: f64) -> Self {
        Self { median, ..self }
    }

    fn find(&self, x: f64) -> Option<&(f64, usize, usize)> {
        let i = self.at.binary_search_by(|a| a.0.total_cmp(&x)).ok()?;
        self.at.get(i)
    }
}

impl Stamps for StampCounts {
    fn count(&self) -> usize {
        self.n
    }
    fn before(&self, x: f64) -> usize {
        self.find(x).map_or(0, |a| a.1)
    }
    fn through(&self, x: f64) -> usize {
        self.find(x).map_or(0, |a| a.2)
    }
    fn stamp(&self, k: usize) -> Option<f64> {
        let i = self.stamps.binary_search_by_key(&k, |s| s.0).ok()?;
        self.stamps.get(i).map(|s| s.1)
    }
    fn median_interval(&self) -> f64 {
        self.median
    }
}

/// The ranges of records that hold each record of a reading, record by record in order: what
/// a reading that sums over many ranges at once (every rest, every motion between two) asks
/// at each record.
#[derive(Clone, Debug)]
pub struct RangeWalk<'a> {
    ranges: &'a [Range<usize>],
    /// The ranges by their first record.
    order: Vec<usize>,
    next: usize,
    active: Vec<usize>,
}

impl<'a> RangeWalk<'a> {
    /// A walk through `ranges` (any order; they may overlap; empty ones hold nothing).
    pub fn new(ranges: &'a [Range<usize>]) -> Self {
        let mut order: Vec<usize> = (0..ranges.len())
            .filter(|&i| !ranges[i].is_empty())
            .collect();
        order.sort_by_key(|&i| ranges[i].start);
        Self {
            ranges,
            order,
            next: 0,
            active: Vec::new(),
        }
    }

    /// The indices of the ranges that hold record `k`; `k` must grow from call to call.
    pub fn at(&mut self, k: usize) -> &[usize] {
        while let Some(&i) = self.order.get(self.next)
            && self.ranges[i].start <= k
        {
            self.active.push(i);
            self.next += 1;
        }
        let ranges = self.ranges;
        self.active.retain(|&i| ranges[i].end > k);
        &self.active
    }

    /// Whether no range holds a record at or after the last one asked for: a reading may stop.
    pub fn done(&self) -> bool {
        self.next == self.order.len() && self.active.is_empty()
    }
}

/// One reading of `source` through `ranges`: `visit(i, k, record, h)` for each range `i` that
/// holds record `k`, in record order, `h` the record's interval (to the stamp before; for the
/// first record `first_interval`, which the caller gives where a range holds it). The reading
/// stops after the last record any range holds.
pub fn read_ranges(
    source: &mut dyn ImuSource,
    ranges: &[Range<usize>],
    first_interval: f64,
    visit: &mut dyn FnMut(usize, usize, &ImuRecord, f64),
) -> Result<(), crate::io::IoError> {
    let mut walk = RangeWalk::new(ranges);
    if walk.done() {
        return Ok(());
    }
    let (mut k, mut previous) = (0usize, f64::NAN);
    read_records(source, &mut Vec::new(), &mut |r, _| {
        let h = if k == 0 {
            first_interval
        } else {
            r.t - previous
        };
        for &i in walk.at(k) {
            visit(i, k, r, h);
        }
        previous = r.t;
        k += 1;
        !walk.done()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::MemoryImu;
    use crate::io::{ImuData, ImuKind};

    fn data(t: &[f64]) -> ImuData {
        ImuData {
            kind: ImuKind::Rates,
            records: t
                .iter()
                .map(|&t| ImuRecord {
                    t,
                    gyro: [t, 0.0, 0.0],
                    accel: [0.0, 0.0, 9.8],
                    temp: None,
                })
                .collect(),
        }
    }

    /// Counted in one reading, the counts and stamps asked for are those of the held stamps,
    /// at stamps, between them, outside them and at the infinities.
    #[test]
    fn counts_answer_as_the_held_stamps() {
        let t: Vec<f64> = (1..=20).map(|k| f64::from(k) * 0.5).collect();
        let d = data(&t);
        let mut imu = MemoryImu::new(&d, "imu.csv");
        let times = [
            0.0,
            0.5,
            0.7,
            3.0,
            3.25,
            10.0,
            11.0,
            -1.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let counts = StampCounts::read(&mut imu, times, [0, 7, 19, 40], 0.5).unwrap();
        assert_eq!(counts.count(), t.count());
        for x in times {
            assert_eq!(counts.before(x), t.before(x), "before {x}");
            assert_eq!(counts.through(x), t.through(x), "through {x}");
        }
        for k in [0, 7, 19, 40] {
            assert_eq!(counts.stamp(k), t.stamp(k), "stamp {k}");
        }
        assert_eq!(counts.median_interval(), t.median_interval());
        // What was not asked for is not answered.
        assert_eq!(counts.stamp(3), None);
        assert_eq!(counts.before(f64::NAN), 0);
    }

    /// A reading through overlapping, empty and unordered ranges visits each range's records
    /// once, in order, with their intervals, and stops after the last.
    #[test]
    fn a_reading_visits_every_range_in_order() {
        let t: Vec<f64> = (0..30).map(|k| f64::from(k) * 0.1 + 1.0).collect();
        let d = data(&t);
        let mut imu = MemoryImu::new(&d, "imu.csv");
        let ranges = [5..9, 0..3, 7..12, 4..4, 20..21];
        let mut seen: Vec<Vec<(usize, f64)>> = vec![Vec::new(); ranges.len()];
        read_ranges(&mut imu, &ranges, 0.1, &mut |i, k, r, h| {
            assert_eq!(r.t, t[k]);
            seen[i].push((k, h));
        })
        .unwrap();
        for (i, r) in ranges.iter().enumerate() {
            let expected: Vec<(usize, f64)> = r
                .clone()
                .map(|k| (k, if k == 0 { 0.1 } else { t[k] - t[k - 1] }))
                .collect();
            assert_eq!(seen[i], expected, "range {i}");
        }
    }
}
