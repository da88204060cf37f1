//! The correlation of the increments over the fitted intervals: how many records a block must
//! hold for the blocks to be independent, and whether an oscillation shows.

use statrs::distribution::ContinuousCDF;
use std::ops::Range;

/// Blocks the longest interval is cut into at least ([`super::fit_ml`]'s cap on the block length).
pub const MIN_BLOCKS_PER_INTERVAL: usize = 10;

/// Block length per record of the sensor's correlation ([`correlation_records`]): block means
/// ten correlation lengths long are nearly independent (the correlation of neighbouring means
/// is about the correlation length over the block length) and the filter's deficit in their
/// variance is a few per cent at most.
pub const BLOCKS_PER_CORRELATION: usize = 10;

/// The sensor's correlation length in records, from the data: the last lag at which the
/// sample autocorrelation of the first differences of the increments (within each interval,
/// pooled over the intervals) departs from that of white increments, searched up to a tenth
/// of the longest interval (at most 1000 lags); 0 for white samples; the period of an
/// oscillation where the samples hold one ([`correlation_of`]).
///
/// Why the differences and not the increments themselves: a bias walk (or a slow Gauss-Markov
/// bias), which the likelihood models, makes the increments' autocorrelation significant at
/// every lag (the walk's share of their variance grows with the interval: on a 30-min rest
/// with 0.1 deg/h and 0.5 deg/h/sqrt(h) at 100 Hz, about 2 %, above the `3 / sqrt(n)` = 0.7 %
/// of a test), so a search for where it ends runs to its cap and the blocks grow to 100 s,
/// too few to determine the white level. The differences of white increments plus a walk have
/// autocorrelation `-1/2` at lag 1 and 0 beyond whatever the walk (its step adds a white
/// sample of a millionth of the white variance), while a sensor's own filter spanning `L`
/// records shows up to lag `L` (an `L`-record moving average: exactly at lag `L`, which is why
/// the last departing lag is taken, not the end of a leading run). The test is two-sided at
/// 1 % over all the lags searched (Bonferroni), each lag's standard deviation `sqrt(1.5 / n)`
/// (Bartlett's formula for the differences of white samples, `1 + 2 (1/2)^2 = 1.5`).
pub fn correlation_records(increments: &[f64], intervals: &[Range<usize>]) -> usize {
    correlation_of(increments, intervals).records
}

/// Autocorrelation of the first differences (at the period) from which a positive peak is
/// taken for an oscillation, besides being significant: an oscillation of period 5 records
/// with about 7 % of the samples' variance. Fixed before the first run on any data.
pub const OSCILLATION_MIN_AUTOCORRELATION: f64 = 0.05;

/// What the autocorrelation of the first differences says about a sensor's short-time
/// structure ([`correlation_of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correlation {
    /// The correlation length the blocks are chosen above (records): [`Self::last_lag`], or
    /// the oscillation's period where there is one.
    pub records: usize,
    /// The last lag at which the differences' autocorrelation departs from white (records).
    pub last_lag: usize,
    /// An oscillation: its period (records), the differences' autocorrelation there and the
    /// oscillation's root mean square in the increments.
    pub oscillation: Option<(usize, f64, f64)>,
}

/// [`correlation_records`] with the oscillation it looks for: a positive autocorrelation of
/// the first differences at a lag of 2 or more, significant (the same test) and at least
/// [`OSCILLATION_MIN_AUTOCORRELATION`]. A sensor's own low-pass filter (a moving average, a
/// first-order lag) and any bias process give the differences negative autocorrelations only;
/// a positive one at lag `P` is a periodic part of period about `P` records, and the first
/// lag at which it peaks is taken as that period. An oscillation that stays coherent keeps
/// the differences correlated at its multiples to the end of the search, and blocks ten times
/// that long (on a user's MEMS gyro, 94 s) take a flicker floor for white noise; but a block
/// mean over many of its periods averages it out (its variance falls as `1 / T^2`, the white
/// noise's as `1 / T`), so the blocks are chosen above its period instead. Its root mean
/// square in the increments: a periodic part of variance `v` and angular frequency
/// `omega = 2 pi / P` adds `v (2 - 2 cos omega) cos(omega k)` to the differences'
/// autocovariance at lag `k`, so at `k = P` it is `gamma_d(P) / (2 - 2 cos omega)`.
pub fn correlation_of(increments: &[f64], intervals: &[Range<usize>]) -> Correlation {
    let diffs: Vec<Vec<f64>> = intervals
        .iter()
        .filter(|r| r.end <= increments.len() && r.len() >= 3)
        .map(|r| {
            increments[r.clone()]
                .windows(2)
                .map(|w| w[1] - w[0])
                .collect()
        })
        .collect();
    let n: usize = diffs.iter().map(Vec::len).sum();
    let g0: f64 = diffs.iter().flatten().map(|v| v * v).sum();
    let longest = diffs.iter().map(Vec::len).max().unwrap_or(0);
    let max_lag = (longest / 10).clamp(1, 1000);
    let mut gk = vec![0.0; max_lag + 1];
    if n >= 10 {
        for (k, g) in gk.iter_mut().enumerate().skip(1) {
            *g = diffs
                .iter()
                .filter(|c| c.len() > k)
                .map(|c| c.iter().zip(&c[k..]).map(|(a, b)| a * b).sum::<f64>())
                .sum();
        }
    }
    correlation_from_sums(n, g0, &gk)
}

/// [`correlation_of`] from the sums: `n` differences, `g0` the sum of their squares, `gk[k]`
/// the sum of their products at lag `k` (`1 ..= gk.len() - 1`, the lags searched).
pub fn correlation_from_sums(n: usize, g0: f64, gk: &[f64]) -> Correlation {
    let none = Correlation {
        records: 0,
        last_lag: 0,
        oscillation: None,
    };
    if n < 10 || g0.is_nan() || g0 <= 0.0 || gk.len() < 2 {
        return none;
    }
    let max_lag = gk.len() - 1;
    let z = statrs::distribution::Normal::standard().inverse_cdf(1.0 - 0.005 / max_lag as f64);
    let threshold = z * (1.5 / n as f64).sqrt();
    let r = |k: usize| gk[k] / g0;
    let mut last = 0;
    for k in 1..=max_lag {
        let white = if k == 1 { -0.5 } else { 0.0 };
        if (r(k) - white).abs() > threshold {
            last = k;
        }
    }
    let oscillation = (2..=max_lag)
        .find(|&k| {
            let peak = r(k) >= r(k - 1) && (k == max_lag || r(k) >= r(k + 1));
            peak && r(k) > threshold && r(k) >= OSCILLATION_MIN_AUTOCORRELATION
        })
        .map(|p| {
            let omega = std::f64::consts::TAU / p as f64;
            let gamma = gk[p] / n as f64;
            (p, r(p), (gamma / (2.0 - 2.0 * omega.cos())).max(0.0).sqrt())
        });
    Correlation {
        records: oscillation.map_or(last, |o| o.0),
        last_lag: last,
        oscillation,
    }
}
