//! How much of a static recording's slow variation its temperature explains.
//!
//! A bias that follows the temperature looks, on the Allan deviation, like a bias random walk or
//! a rate ramp: the long averaging times rise. With a temperature recorded beside the data the
//! two can be told apart: the records are averaged in bins of [`BIN_S`] seconds, each static
//! interval's bin means and temperatures are taken about their own means (an interval in
//! another orientation has another mean specific force), and each axis is regressed on the
//! temperature. The slope is the bias's temperature coefficient; the share of the bin means'
//! variance it explains, and the Allan deviation of the bin means at the longest averaging time
//! before and after removing it, say how much of the long-tau deviation is thermal.
//!
//! The slope's sigma takes the bin means' residuals as independent: right for white noise (a
//! 10-s mean of white noise is white), optimistic where a walk or flicker is left.

use serde::Serialize;

/// Length of the averaging bins (s).
pub const BIN_S: f64 = 10.0;

/// Bin means of one static interval: time, temperature and each axis's value (the increment
/// per record or the rate, as the caller feeds them).
#[derive(Clone, Debug, Default)]
pub struct IntervalBins {
    bins: Vec<(f64, f64, Vec<f64>)>,
    open: Option<(i64, f64, f64, Vec<f64>, usize)>,
    axes: usize,
}

impl IntervalBins {
    /// Empty bins for `axes` axes.
    pub fn new(axes: usize) -> Self {
        Self {
            axes,
            ..Self::default()
        }
    }

    /// Add a record at time `t` (s) with temperature `temp_c` and the axes' `values`.
    pub fn push(&mut self, t: f64, temp_c: f64, values: &[f64]) {
        let k = (t / BIN_S).floor() as i64;
        match &mut self.open {
            Some((bin, ts, cs, vs, n)) if *bin == k => {
                *ts += t;
                *cs += temp_c;
                for (s, v) in vs.iter_mut().zip(values) {
                    *s += v;
                }
                *n += 1;
            }
            _ => {
                self.close();
                self.open = Some((k, t, temp_c, values.to_vec(), 1));
            }
        }
    }

    /// Close the open bin (a bin with fewer than half the records of a full one is dropped:
    /// the ends of an interval).
    pub fn close(&mut self) {
        if let Some((_, ts, cs, vs, n)) = self.open.take() {
            let n = n as f64;
            self.bins
                .push((ts / n, cs / n, vs.into_iter().map(|v| v / n).collect()));
        }
    }

    /// Number of closed bins.
    pub fn len(&self) -> usize {
        self.bins.len()
    }

    /// Whether no bin is closed.
    pub fn is_empty(&self) -> bool {
        self.bins.is_empty()
    }

    /// The number of axes.
    pub fn axes(&self) -> usize {
        self.axes
    }

    /// The mean temperature of the closed bins (deg C; NaN without any).
    pub fn mean_temp(&self) -> f64 {
        self.bins.iter().map(|b| b.1).sum::<f64>() / self.bins.len() as f64
    }
}

/// The thermal part of one axis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AxisThermal {
    /// Change of the axis's value per kelvin (the caller's unit per K).
    pub coefficient: f64,
    /// Its standard deviation (bin means' residuals taken as independent).
    pub sigma: f64,
    /// Share of the variance of the bin means (about each interval's mean) the temperature
    /// explains, 0..1.
    pub explained: f64,
    /// The longest averaging time of the bin means' Allan deviation (s).
    pub tau_s: f64,
    /// The Allan deviation of the bin means at `tau_s`, as they are.
    pub adev_before: f64,
    /// The same with the thermal part removed.
    pub adev_after: f64,
}

/// The fit over every interval: the temperatures seen and each axis's thermal part; `None`
/// without at least [`MIN_BINS`] bins or a temperature that moves (the spread of the bin
/// temperatures about their intervals' means below 1 mK).
pub fn fit(intervals: &[IntervalBins]) -> Option<(f64, f64, Vec<AxisThermal>)> {
    let axes = intervals.first()?.axes;
    let n: usize = intervals.iter().map(IntervalBins::len).sum();
    if n < MIN_BINS {
        return None;
    }
    let (lo, hi) = intervals
        .iter()
        .flat_map(|i| i.bins.iter().map(|b| b.1))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), c| {
            (a.min(c), b.max(c))
        });
    // Each interval about its own means.
    let centred: Vec<Vec<(f64, Vec<f64>)>> = intervals
        .iter()
        .filter(|i| i.len() >= 2)
        .map(|i| {
            let m = i.len() as f64;
            let tc = i.bins.iter().map(|b| b.1).sum::<f64>() / m;
            let means: Vec<f64> = (0..axes)
                .map(|a| i.bins.iter().map(|b| b.2[a]).sum::<f64>() / m)
                .collect();
            i.bins
                .iter()
                .map(|b| {
                    (
                        b.1 - tc,
                        b.2.iter().zip(&means).map(|(v, m)| v - m).collect(),
                    )
                })
                .collect()
        })
        .collect();
    let stt: f64 = centred.iter().flatten().map(|(t, _)| t * t).sum();
    let dof = centred
        .iter()
        .map(|i| i.len().saturating_sub(1))
        .sum::<usize>();
    if stt.sqrt() < 1e-3 || dof < 3 {
        return None;
    }
    let out = (0..axes)
        .map(|a| {
            let sty: f64 = centred.iter().flatten().map(|(t, v)| t * v[a]).sum();
            let syy: f64 = centred.iter().flatten().map(|(_, v)| v[a] * v[a]).sum();
            let b = sty / stt;
            let rss = (syy - b * sty).max(0.0);
            let sigma = (rss / (dof - 1) as f64 / stt).sqrt();
            let explained = if syy > 0.0 { 1.0 - rss / syy } else { 0.0 };
            let series = |remove: f64| -> Vec<Vec<f64>> {
                centred
                    .iter()
                    .map(|i| i.iter().map(|(t, v)| v[a] - remove * t).collect())
                    .collect()
            };
            let (tau_s, before) = longest_adev(&series(0.0));
            let (_, after) = longest_adev(&series(b));
            AxisThermal {
                coefficient: b,
                sigma,
                explained,
                tau_s,
                adev_before: before,
                adev_after: after,
            }
        })
        .collect();
    Some((lo, hi, out))
}

/// The fewest bins a fit takes (two minutes of records).
pub const MIN_BINS: usize = 12;

/// The overlapping Allan deviation of the bin means at the longest averaging time `m BIN_S`
/// with at least three `m` bins in some interval, pooled over the intervals long enough.
fn longest_adev(series: &[Vec<f64>]) -> (f64, f64) {
    let longest = series.iter().map(Vec::len).max().unwrap_or(0);
    let m = (longest / 3).max(1);
    let (mut sum, mut count) = (0.0, 0usize);
    for s in series.iter().filter(|s| s.len() > 2 * m) {
        let cum: Vec<f64> = std::iter::once(0.0)
            .chain(s.iter().scan(0.0, |acc, v| {
                *acc += v;
                Some(*acc)
            }))
            .collect();
        for k in 0..=s.len() - 2 * m {
            let a = (cum[k + m] - cum[k]) / m as f64;
            let b = (cum[k + 2 * m] - cum[k + m]) / m as f64;
            sum += 0.5 * (b - a) * (b - a);
            count += 1;
        }
    }
    let tau = m as f64 * BIN_S;
    if count == 0 {
        (tau, f64::NAN)
    } else {
        (tau, (sum / count as f64).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// An hour at 10 Hz of white noise plus a drift that follows a warm-up: the slope is found
    /// within 3 sigma, it explains most of the bin means' variance and the long-tau Allan
    /// deviation falls once it is removed; without the drift it explains next to nothing.
    #[test]
    fn a_drift_that_follows_the_temperature_is_found_and_explains_the_long_tau() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(31);
        for (b, thermal) in [(2e-3, true), (0.0, false)] {
            let mut bins = IntervalBins::new(1);
            for k in 0..36_000 {
                let t = k as f64 * 0.1;
                let temp = 20.0 + 15.0 * (1.0 - (-t / 900.0).exp());
                let z: f64 = StandardNormal.sample(&mut rng);
                bins.push(t, temp, &[0.05 * z + b * temp]);
            }
            bins.close();
            let (lo, hi, axes) = fit(&[bins]).expect("a fit");
            assert!(lo < 20.2 && hi > 34.0, "{lo} {hi}");
            let a = &axes[0];
            assert!(((a.coefficient - b) / a.sigma).abs() < 3.0, "{a:?}");
            if thermal {
                // Expected share: the drift's variance over the bins against the bin means'
                // noise (0.05 / sqrt(100) each): about 0.8 for this warm-up.
                let temps: Vec<f64> = (0..360)
                    .map(|k| 20.0 + 15.0 * (1.0 - (-(k as f64 * 10.0 + 5.0) / 900.0).exp()))
                    .collect();
                let m = temps.iter().sum::<f64>() / 360.0;
                let var_t = temps.iter().map(|c| (c - m).powi(2)).sum::<f64>() / 360.0;
                let signal = b * b * var_t;
                let expected = signal / (signal + 0.05f64.powi(2) / 100.0);
                assert!(
                    (a.explained - expected).abs() < 0.1,
                    "{a:?}, expected {expected}"
                );
                assert!(a.adev_after < 0.3 * a.adev_before, "{a:?}");
            } else {
                assert!(a.explained < 0.05, "{a:?}");
            }
        }
    }
}
