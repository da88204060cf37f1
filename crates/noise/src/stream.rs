//! Both fits of several axes ([`crate::likelihood::fit_ml`] and [`crate::analyse_axis_from`] above the
//! likelihood's correlation time) from increments read again from their start, without holding
//! them: the same results to the last bit (`tests::streamed_equals_held`).
//!
//! Two readings. The first sums each interval (its mean) and the lagged products of the first
//! differences ([`likelihood::correlation_records`], a window of at most 1000 differences per
//! axis). The second forms the block means ([`Blocks`]) and the Allan sums at every octave
//! ([`allan::overlapping_allan`]) as the phase comes: the term at `k` is added when the phase
//! reaches `k + 2m`, from a window of the last `2m + 1` phase values. That window is the one
//! thing that grows: with the longest static interval (8 bytes per record of it and axis), not
//! with the recording.

use crate::allan::{self, AllanCurve};
use crate::likelihood::{
    self, BLOCKS_PER_CORRELATION, Blocks, Correlation, MIN_BLOCKS_PER_INTERVAL, MlFit,
};
use crate::{AxisNoise, NoiseError, fit};
use std::collections::VecDeque;
use std::ops::Range;

/// The two fits of one axis.
#[derive(Debug)]
pub struct AxisFits {
    /// [`likelihood::fit_ml`].
    pub ml: Result<MlFit, NoiseError>,
    /// [`crate::analyse_axis_from`] with `tau_min_s` [`BLOCKS_PER_CORRELATION`] times the
    /// likelihood's correlation time.
    pub allan: Result<AxisNoise, NoiseError>,
}

/// The fits of `axes` axes whose increments (one value per axis and record, SI) `read` visits
/// as `(record index, values)` for every one of the `len` records in order, at every call.
pub fn fit_axes_streamed<E>(
    axes: usize,
    len: usize,
    tau0_s: f64,
    intervals: &[Range<usize>],
    mut read: impl FnMut(&mut dyn FnMut(usize, &[f64])) -> Result<(), E>,
) -> Result<Vec<AxisFits>, E> {
    if let Err(e) = allan::check_intervals(len, intervals) {
        return Ok((0..axes).map(|_| refused(&e)).collect());
    }
    let mut first = FirstReading::new(axes, intervals);
    read(&mut |i, v| first.visit(i, v))?;
    first.finish();
    let correlations = first.correlations();
    let k_of: Vec<usize> = correlations.iter().map(|c| c.records).collect();
    let means = first.means();
    let block_len = block_lengths(&k_of, intervals);
    let mut second = SecondReading::new(axes, tau0_s, intervals, means, block_len);
    read(&mut |i, v| second.visit(i, v))?;
    second.finish();
    let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
    Ok((0..axes)
        .map(|a| {
            let correlation = &correlations[a];
            match first.non_finite[a] {
                _ if !(tau0_s.is_finite() && tau0_s > 0.0) => {
                    refused(&NoiseError::BadInterval0(tau0_s))
                }
                Some(record) => refused(&NoiseError::NotFinite { record }),
                None => second.axis_fits(a, longest, correlation),
            }
        })
        .collect())
}

/// Both fits of an axis refused with `e`.
fn refused(e: &NoiseError) -> AxisFits {
    AxisFits {
        ml: Err(clone_error(e)),
        allan: Err(clone_error(e)),
    }
}

/// Which interval a record is in, walked along with the records (they come in order).
struct IntervalWalk<'a> {
    intervals: &'a [Range<usize>],
    at: usize,
}

impl<'a> IntervalWalk<'a> {
    fn new(intervals: &'a [Range<usize>]) -> Self {
        Self { intervals, at: 0 }
    }

    /// The index of the interval holding record `i` (`i` not below the last one asked about).
    fn of(&mut self, i: usize) -> Option<usize> {
        while self.at < self.intervals.len() && self.intervals[self.at].end <= i {
            self.at += 1;
        }
        self.intervals
            .get(self.at)
            .filter(|r| r.start <= i)
            .map(|_| self.at)
    }
}

/// The first reading: each interval's sum (its mean), the first non-finite value, and the
/// lagged products of the first differences that [`likelihood::correlation_records`] sums, all
/// per axis. The products of an interval are kept apart until it ends: they join the totals
/// only for the lags shorter than its differences, as the held sum filters them.
struct FirstReading<'a> {
    intervals: &'a [Range<usize>],
    walk: IntervalWalk<'a>,
    current: Option<usize>,
    /// Differences summed over all intervals, and the longest lag searched.
    n_diffs: usize,
    max_lag: usize,
    /// Per axis: each interval's sum, the first non-finite record.
    sums: Vec<Vec<f64>>,
    non_finite: Vec<Option<usize>>,
    /// Per axis: the sum of squared differences, the lagged products (lag 1 ..= `max_lag`) of
    /// the intervals ended and of the current one, its last `max_lag` differences, and the last
    /// value.
    g0: Vec<f64>,
    gk: Vec<Vec<f64>>,
    gk_here: Vec<Vec<f64>>,
    diffs: Vec<VecDeque<f64>>,
    previous: Vec<f64>,
}

impl<'a> FirstReading<'a> {
    fn new(axes: usize, intervals: &'a [Range<usize>]) -> Self {
        let diff_lens: Vec<usize> = intervals
            .iter()
            .filter(|r| r.len() >= 3)
            .map(|r| r.len() - 1)
            .collect();
        let max_lag = (diff_lens.iter().copied().max().unwrap_or(0) / 10).clamp(1, 1000);
        Self {
            intervals,
            walk: IntervalWalk::new(intervals),
            current: None,
            n_diffs: diff_lens.iter().sum(),
            max_lag,
            sums: vec![vec![-0.0f64; intervals.len()]; axes],
            non_finite: vec![None; axes],
            g0: vec![-0.0f64; axes],
            gk: vec![vec![-0.0f64; max_lag + 1]; axes],
            gk_here: vec![vec![-0.0f64; max_lag + 1]; axes],
            diffs: vec![VecDeque::with_capacity(max_lag + 1); axes],
            previous: vec![0.0f64; axes],
        }
    }

    fn visit(&mut self, i: usize, v: &[f64]) {
        let v = &v[..self.g0.len()];
        for (a, x) in v.iter().enumerate() {
            if self.non_finite[a].is_none() && !x.is_finite() {
                self.non_finite[a] = Some(i);
            }
        }
        let here = self.walk.of(i);
        if here != self.current {
            self.finish();
            self.current = here;
        }
        let Some(c) = here else {
            return;
        };
        let differences = self.intervals[c].len() >= 3 && i > self.intervals[c].start;
        for (a, &x) in v.iter().enumerate() {
            self.sums[a][c] += x;
            if differences {
                self.push_difference(a, x - self.previous[a]);
            }
            self.previous[a] = x;
        }
    }

    /// A first difference `d` of axis `a`: its square and its products with the differences
    /// before it.
    fn push_difference(&mut self, a: usize, d: f64) {
        self.g0[a] += d * d;
        let ring = &mut self.diffs[a];
        for (k, &e) in ring.iter().rev().enumerate() {
            self.gk_here[a][k + 1] += e * d;
        }
        if ring.len() == self.max_lag {
            ring.pop_front();
        }
        ring.push_back(d);
    }

    /// The current interval ended (or the records did): its lagged products join the totals.
    fn finish(&mut self) {
        let Some(c) = self.current else {
            return;
        };
        let l = self.intervals[c].len();
        if l < 3 {
            return;
        }
        for a in 0..self.g0.len() {
            for k in 1..=self.max_lag {
                if l - 1 > k {
                    self.gk[a][k] += self.gk_here[a][k];
                }
                self.gk_here[a][k] = -0.0;
            }
            self.diffs[a].clear();
        }
    }

    /// The correlation of each axis, as [`likelihood::correlation_of`] finds it.
    fn correlations(&self) -> Vec<Correlation> {
        (0..self.g0.len())
            .map(|a| likelihood::correlation_from_sums(self.n_diffs, self.g0[a], &self.gk[a]))
            .collect()
    }

    /// Each axis's mean over each interval.
    fn means(&self) -> Vec<Vec<f64>> {
        self.sums
            .iter()
            .map(|sums| {
                self.intervals
                    .iter()
                    .zip(sums)
                    .map(|(r, s)| s / r.len() as f64)
                    .collect()
            })
            .collect()
    }
}

/// The block length of each axis (records), as [`likelihood::fit_ml`] chooses it from the
/// correlation length `k_of`: [`BLOCKS_PER_CORRELATION`] of them, at most a
/// [`MIN_BLOCKS_PER_INTERVAL`]th of the longest interval, and long enough for at most
/// [`likelihood::MAX_BLOCKS`] blocks.
fn block_lengths(k_of: &[usize], intervals: &[Range<usize>]) -> Vec<usize> {
    let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
    let total: usize = intervals.iter().map(|r| r.len()).sum();
    let cap = (longest / MIN_BLOCKS_PER_INTERVAL).max(1);
    k_of.iter()
        .map(|&k| {
            let min_records = (BLOCKS_PER_CORRELATION * k).min(cap);
            total
                .div_ceil(likelihood::MAX_BLOCKS)
                .max(min_records)
                .max(1)
        })
        .collect()
}

/// The second reading: the block means of every axis and the Allan sums at every octave, each
/// interval's mean removed. The Allan term at `k` is added when the phase reaches `k + 2m`,
/// from a window of the last `2m + 1` phase values.
struct SecondReading<'a> {
    intervals: &'a [Range<usize>],
    tau0_s: f64,
    walk: IntervalWalk<'a>,
    current: Option<usize>,
    /// Per axis and interval, from the first reading.
    means: Vec<Vec<f64>>,
    block_len: Vec<usize>,
    /// The averaging factors (octaves up to half the longest interval) and the phase window.
    ms: Vec<usize>,
    width: usize,
    /// Per axis: the blocks of each interval, and the block being summed.
    blocks: Vec<Vec<Vec<(f64, f64)>>>,
    block_sum: Vec<f64>,
    block_n: Vec<usize>,
    /// Per axis: the phase window and the phase now; per axis and octave the current
    /// interval's Allan sum and the total over the intervals ended.
    phase: Vec<VecDeque<f64>>,
    x_now: Vec<f64>,
    acc: Vec<Vec<f64>>,
    allan_sums: Vec<Vec<f64>>,
    /// Per octave: the Allan terms over all intervals.
    terms: Vec<usize>,
}

impl<'a> SecondReading<'a> {
    fn new(
        axes: usize,
        tau0_s: f64,
        intervals: &'a [Range<usize>],
        means: Vec<Vec<f64>>,
        block_len: Vec<usize>,
    ) -> Self {
        let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
        let mut ms = Vec::new();
        let mut m = 1;
        while 2 * m <= longest {
            ms.push(m);
            m *= 2;
        }
        let width = ms.last().map_or(1, |m| 2 * m + 1);
        Self {
            intervals,
            tau0_s,
            walk: IntervalWalk::new(intervals),
            current: None,
            means,
            block_len,
            blocks: vec![Vec::with_capacity(intervals.len()); axes],
            block_sum: vec![-0.0f64; axes],
            block_n: vec![0usize; axes],
            phase: vec![VecDeque::with_capacity(width); axes],
            x_now: vec![0.0f64; axes],
            acc: vec![vec![0.0f64; ms.len()]; axes],
            allan_sums: vec![vec![0.0f64; ms.len()]; axes],
            terms: vec![0usize; ms.len()],
            ms,
            width,
        }
    }

    fn visit(&mut self, i: usize, v: &[f64]) {
        let here = self.walk.of(i);
        if here != self.current {
            self.finish();
            if let Some(c) = here {
                self.open(c);
            }
            self.current = here;
        }
        let Some(c) = here else {
            return;
        };
        for (a, &x) in v[..self.phase.len()].iter().enumerate() {
            let centred = x - self.means[a][c];
            self.push_block(a, c, centred);
            self.push_phase(a, centred);
        }
    }

    /// Interval `c` starts: an empty block list, the phase at 0.
    fn open(&mut self, c: usize) {
        for a in 0..self.phase.len() {
            self.blocks[a].resize(c + 1, Vec::new());
            self.phase[a].clear();
            self.phase[a].push_back(0.0);
            self.x_now[a] = 0.0;
        }
    }

    /// Add a centred value of axis `a` to its block in interval `c`, and close the block when
    /// full.
    fn push_block(&mut self, a: usize, c: usize, centred: f64) {
        self.block_sum[a] += centred;
        self.block_n[a] += 1;
        if self.block_n[a] == self.block_len[a] {
            self.close_block(a, c);
        }
    }

    /// The block being summed on axis `a` as a mean rate over its duration.
    fn close_block(&mut self, a: usize, c: usize) {
        let d = self.block_n[a] as f64 * self.tau0_s;
        self.blocks[a][c].push((self.block_sum[a] / d, d));
        self.block_sum[a] = -0.0;
        self.block_n[a] = 0;
    }

    /// Advance axis `a`'s phase by a centred value: the Allan terms that end here.
    fn push_phase(&mut self, a: usize, centred: f64) {
        self.x_now[a] += centred;
        let ring = &mut self.phase[a];
        ring.push_back(self.x_now[a]);
        // The phase values `x_{j-2m}, x_{j-m}, x_j` with `j` the newest.
        let j = ring.len() - 1;
        for (o, &m) in self.ms.iter().enumerate() {
            if 2 * m > j {
                break;
            }
            let d = ring[j] - 2.0 * ring[j - m] + ring[j - 2 * m];
            self.acc[a][o] += d * d;
        }
        if ring.len() == self.width {
            ring.pop_front();
        }
    }

    /// The current interval ended (or the records did): its last, shorter block, and its Allan
    /// sums and terms at the octaves it is long enough for.
    fn finish(&mut self) {
        let Some(c) = self.current else {
            return;
        };
        let l = self.intervals[c].len();
        for a in 0..self.phase.len() {
            if self.block_n[a] > 0 {
                self.close_block(a, c);
            }
            for (j, &m) in self.ms.iter().enumerate() {
                if 2 * m > l {
                    break;
                }
                self.allan_sums[a][j] += self.acc[a][j];
                self.acc[a][j] = 0.0;
            }
        }
        for (j, &m) in self.ms.iter().enumerate() {
            if 2 * m > l {
                break;
            }
            self.terms[j] += l + 1 - 2 * m;
        }
    }

    /// Both fits of axis `a` from its blocks and Allan sums (its correlation time
    /// `correlation_s`; the blocks are taken out).
    fn axis_fits(&mut self, a: usize, longest: usize, correlation: &Correlation) -> AxisFits {
        let correlation_s = correlation.records as f64 * self.tau0_s;
        let b = std::mem::take(&mut self.blocks[a]);
        let ml = if b.iter().all(|x| x.len() < 3) {
            Err(NoiseError::TooShort { longest })
        } else {
            let blocks = Blocks {
                block_s: self.block_len[a] as f64 * self.tau0_s,
                intervals: b,
            };
            likelihood::fit_blocks(&blocks).map(|mut f| {
                f.set_correlation(correlation, self.tau0_s);
                f
            })
        };
        let allan = if longest < 2 {
            Err(NoiseError::TooShort { longest })
        } else {
            let mut curve: AllanCurve = allan::curve_of(
                self.tau0_s,
                self.intervals,
                &self.ms,
                &self.allan_sums[a],
                &self.terms,
            );
            let tau_min = BLOCKS_PER_CORRELATION as f64 * correlation_s;
            fit::fit_terms_from(&mut curve, tau_min).map(|fit| AxisNoise { curve, fit })
        };
        AxisFits { ml, allan }
    }
}

fn clone_error(e: &NoiseError) -> NoiseError {
    match e {
        NoiseError::BadInterval0(x) => NoiseError::BadInterval0(*x),
        NoiseError::NoIntervals => NoiseError::NoIntervals,
        NoiseError::BadInterval {
            index,
            start,
            end,
            records,
        } => NoiseError::BadInterval {
            index: *index,
            start: *start,
            end: *end,
            records: *records,
        },
        NoiseError::NotFinite { record } => NoiseError::NotFinite { record: *record },
        NoiseError::TooShort { longest } => NoiseError::TooShort { longest: *longest },
        NoiseError::TooFewPoints(n) => NoiseError::TooFewPoints(*n),
        NoiseError::NoNoise { tau_s } => NoiseError::NoNoise { tau_s: *tau_s },
        NoiseError::NoFit => NoiseError::NoFit,
    }
}

#[cfg(test)]
#[allow(clippy::single_range_in_vec_init, clippy::needless_range_loop)] // one interval: the whole data
mod tests {
    use super::*;
    use crate::analyse_axis_from;
    use crate::likelihood::fit_ml;

    /// White noise, a walk and a moving average (a sensor's own filter) on three axes, over
    /// intervals of several lengths with records between them.
    #[test]
    fn streamed_equals_held() {
        let mut state = 7u64;
        let mut u = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64 - 0.5
        };
        let len = 60_000;
        let mut walk = 0.0;
        let mut prev = 0.0;
        let mut x: Vec<Vec<f64>> = (0..3).map(|_| Vec::with_capacity(len)).collect();
        for _ in 0..len {
            let e = u();
            walk += 1e-3 * u();
            x[0].push(1e-4 * e + 3.0);
            x[1].push(1e-4 * e + 1e-5 * walk);
            x[2].push(1e-4 * (e + prev));
            prev = e;
        }
        for intervals in [
            vec![0..len],
            vec![10..2_000, 2_500..40_000, 40_001..41_000, 50_000..59_990],
            vec![0..2, 5..30_000],
        ] {
            let got = fit_axes_streamed::<()>(3, len, 0.01, &intervals, |visit| {
                for i in 0..len {
                    visit(i, &[x[0][i], x[1][i], x[2][i]]);
                }
                Ok(())
            })
            .unwrap();
            for a in 0..3 {
                let ml = fit_ml(&x[a], 0.01, &intervals);
                assert_eq!(format!("{ml:?}"), format!("{:?}", got[a].ml), "axis {a}");
                let tau_min = ml
                    .as_ref()
                    .map_or(0.0, |m| BLOCKS_PER_CORRELATION as f64 * m.correlation_s);
                let allan = analyse_axis_from(&x[a], 0.01, &intervals, tau_min);
                assert_eq!(
                    format!("{allan:?}"),
                    format!("{:?}", got[a].allan),
                    "axis {a}"
                );
            }
        }
    }
}
