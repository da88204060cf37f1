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
use crate::likelihood::{self, BLOCKS_PER_CORRELATION, Blocks, MIN_BLOCKS_PER_INTERVAL, MlFit};
use crate::{AxisNoise, NoiseError, fit};
use statrs::distribution::ContinuousCDF;
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
#[allow(clippy::needless_range_loop)] // axes and lags index several tables alike
pub fn fit_axes_streamed<E>(
    axes: usize,
    len: usize,
    tau0_s: f64,
    intervals: &[Range<usize>],
    mut read: impl FnMut(&mut dyn FnMut(usize, &[f64])) -> Result<(), E>,
) -> Result<Vec<AxisFits>, E> {
    let checked = allan::check_intervals(len, intervals);
    let refuse = |e: &NoiseError| -> Vec<AxisFits> {
        (0..axes)
            .map(|_| AxisFits {
                ml: Err(clone_error(e)),
                allan: Err(clone_error(e)),
            })
            .collect()
    };
    if let Err(e) = checked {
        return Ok(refuse(&e));
    }
    // Which interval a record is in, walked along with the records.
    let which = |i: usize, at: &mut usize| -> Option<usize> {
        while *at < intervals.len() && intervals[*at].end <= i {
            *at += 1;
        }
        intervals.get(*at).filter(|r| r.start <= i).map(|_| *at)
    };

    // First reading: the intervals' sums, the first non-finite value, the lagged products.
    let diff_lens: Vec<usize> = intervals
        .iter()
        .filter(|r| r.len() >= 3)
        .map(|r| r.len() - 1)
        .collect();
    let n_diffs: usize = diff_lens.iter().sum();
    let max_lag = (diff_lens.iter().copied().max().unwrap_or(0) / 10).clamp(1, 1000);
    let mut sums = vec![vec![-0.0f64; intervals.len()]; axes];
    let mut non_finite: Vec<Option<usize>> = vec![None; axes];
    let mut g0 = vec![-0.0f64; axes];
    let mut gk = vec![vec![-0.0f64; max_lag + 1]; axes];
    let mut gk_here = vec![vec![-0.0f64; max_lag + 1]; axes];
    let mut diffs: Vec<VecDeque<f64>> = vec![VecDeque::with_capacity(max_lag + 1); axes];
    let mut previous = vec![0.0f64; axes];
    let mut at = 0;
    let mut current: Option<usize> = None;
    read(&mut |i, v| {
        for a in 0..axes {
            if non_finite[a].is_none() && !v[a].is_finite() {
                non_finite[a] = Some(i);
            }
        }
        let here = which(i, &mut at);
        if here != current {
            // An interval ended: its lagged products join the totals (those longer than the
            // lag only, as the held sum filters them).
            if let Some(c) = current {
                let l = intervals[c].len();
                if l >= 3 {
                    for a in 0..axes {
                        for k in 1..=max_lag {
                            if l - 1 > k {
                                gk[a][k] += gk_here[a][k];
                            }
                            gk_here[a][k] = -0.0;
                        }
                        diffs[a].clear();
                    }
                }
            }
            current = here;
        }
        let Some(c) = here else {
            return;
        };
        let r = &intervals[c];
        for a in 0..axes {
            sums[a][c] += v[a];
            if r.len() >= 3 && i > r.start {
                let d = v[a] - previous[a];
                g0[a] += d * d;
                let ring = &mut diffs[a];
                for (k, &e) in ring.iter().rev().enumerate() {
                    gk_here[a][k + 1] += e * d;
                }
                if ring.len() == max_lag {
                    ring.pop_front();
                }
                ring.push_back(d);
            }
            previous[a] = v[a];
        }
    })?;
    if let Some(c) = current {
        let l = intervals[c].len();
        if l >= 3 {
            for a in 0..axes {
                for k in 1..=max_lag {
                    if l - 1 > k {
                        gk[a][k] += gk_here[a][k];
                    }
                }
            }
        }
    }
    // The correlation length of each axis, as `correlation_records` decides it.
    let k_of: Vec<usize> = (0..axes)
        .map(|a| {
            if n_diffs < 10 || g0[a].is_nan() || g0[a] <= 0.0 {
                return 0;
            }
            let z =
                statrs::distribution::Normal::standard().inverse_cdf(1.0 - 0.005 / max_lag as f64);
            let threshold = z * (1.5 / n_diffs as f64).sqrt();
            let mut last = 0;
            for k in 1..=max_lag {
                let white = if k == 1 { -0.5 } else { 0.0 };
                if (gk[a][k] / g0[a] - white).abs() > threshold {
                    last = k;
                }
            }
            last
        })
        .collect();
    let means: Vec<Vec<f64>> = (0..axes)
        .map(|a| {
            intervals
                .iter()
                .zip(&sums[a])
                .map(|(r, s)| s / r.len() as f64)
                .collect()
        })
        .collect();
    let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
    let total: usize = intervals.iter().map(|r| r.len()).sum();
    let cap = (longest / MIN_BLOCKS_PER_INTERVAL).max(1);
    let block_len: Vec<usize> = k_of
        .iter()
        .map(|&k| {
            let min_records = (BLOCKS_PER_CORRELATION * k).min(cap);
            total
                .div_ceil(likelihood::MAX_BLOCKS)
                .max(min_records)
                .max(1)
        })
        .collect();

    // Second reading: block means and Allan sums.
    let mut ms = Vec::new();
    let mut m = 1;
    while 2 * m <= longest {
        ms.push(m);
        m *= 2;
    }
    let width = ms.last().map_or(1, |m| 2 * m + 1);
    let mut blocks: Vec<Vec<Vec<(f64, f64)>>> = vec![Vec::with_capacity(intervals.len()); axes];
    let mut block_sum = vec![-0.0f64; axes];
    let mut block_n = vec![0usize; axes];
    let mut phase: Vec<VecDeque<f64>> = vec![VecDeque::with_capacity(width); axes];
    let mut x_now = vec![0.0f64; axes];
    let mut acc = vec![vec![0.0f64; ms.len()]; axes];
    let mut allan_sums = vec![vec![0.0f64; ms.len()]; axes];
    let mut terms = vec![0usize; ms.len()];
    let mut at = 0;
    let mut current: Option<usize> = None;
    let close = |c: usize,
                 blocks: &mut Vec<Vec<Vec<(f64, f64)>>>,
                 block_sum: &mut Vec<f64>,
                 block_n: &mut Vec<usize>,
                 acc: &mut Vec<Vec<f64>>,
                 allan_sums: &mut Vec<Vec<f64>>,
                 terms: &mut Vec<usize>| {
        let l = intervals[c].len();
        for a in 0..axes {
            if block_n[a] > 0 {
                let d = block_n[a] as f64 * tau0_s;
                blocks[a][c].push((block_sum[a] / d, d));
                block_sum[a] = -0.0;
                block_n[a] = 0;
            }
            for (j, &m) in ms.iter().enumerate() {
                if 2 * m > l {
                    break;
                }
                allan_sums[a][j] += acc[a][j];
                acc[a][j] = 0.0;
            }
        }
        for (j, &m) in ms.iter().enumerate() {
            if 2 * m > l {
                break;
            }
            terms[j] += l + 1 - 2 * m;
        }
    };
    read(&mut |i, v| {
        let here = which(i, &mut at);
        if here != current {
            if let Some(c) = current {
                close(
                    c,
                    &mut blocks,
                    &mut block_sum,
                    &mut block_n,
                    &mut acc,
                    &mut allan_sums,
                    &mut terms,
                );
            }
            if let Some(c) = here {
                for a in 0..axes {
                    blocks[a].resize(c + 1, Vec::new());
                    phase[a].clear();
                    phase[a].push_back(0.0);
                    x_now[a] = 0.0;
                }
            }
            current = here;
        }
        let Some(c) = here else {
            return;
        };
        for a in 0..axes {
            let centred = v[a] - means[a][c];
            block_sum[a] += centred;
            block_n[a] += 1;
            if block_n[a] == block_len[a] {
                let d = block_n[a] as f64 * tau0_s;
                blocks[a][c].push((block_sum[a] / d, d));
                block_sum[a] = -0.0;
                block_n[a] = 0;
            }
            x_now[a] += centred;
            let ring = &mut phase[a];
            ring.push_back(x_now[a]);
            // The phase values `x_{j-2m}, x_{j-m}, x_j` with `j` the newest.
            let j = ring.len() - 1;
            for (o, &m) in ms.iter().enumerate() {
                if 2 * m > j {
                    break;
                }
                let d = ring[j] - 2.0 * ring[j - m] + ring[j - 2 * m];
                acc[a][o] += d * d;
            }
            if ring.len() == width {
                ring.pop_front();
            }
        }
    })?;
    if let Some(c) = current {
        close(
            c,
            &mut blocks,
            &mut block_sum,
            &mut block_n,
            &mut acc,
            &mut allan_sums,
            &mut terms,
        );
    }

    let mut out = Vec::with_capacity(axes);
    for a in 0..axes {
        let bad = |e: NoiseError| AxisFits {
            ml: Err(clone_error(&e)),
            allan: Err(e),
        };
        if !(tau0_s.is_finite() && tau0_s > 0.0) {
            out.push(bad(NoiseError::BadInterval0(tau0_s)));
            continue;
        }
        if let Some(record) = non_finite[a] {
            out.push(bad(NoiseError::NotFinite { record }));
            continue;
        }
        let correlation_s = k_of[a] as f64 * tau0_s;
        let ml = {
            let b = std::mem::take(&mut blocks[a]);
            if b.iter().all(|x| x.len() < 3) {
                Err(NoiseError::TooShort { longest })
            } else {
                let blocks = Blocks {
                    block_s: block_len[a] as f64 * tau0_s,
                    intervals: b,
                };
                likelihood::fit_blocks(&blocks).map(|mut f| {
                    f.correlation_s = correlation_s;
                    f
                })
            }
        };
        let allan = if longest < 2 {
            Err(NoiseError::TooShort { longest })
        } else {
            let mut curve: AllanCurve =
                allan::curve_of(tau0_s, intervals, &ms, &allan_sums[a], &terms);
            let tau_min = BLOCKS_PER_CORRELATION as f64 * correlation_s;
            fit::fit_terms_from(&mut curve, tau_min).map(|fit| AxisNoise { curve, fit })
        };
        out.push(AxisFits { ml, allan });
    }
    Ok(out)
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
