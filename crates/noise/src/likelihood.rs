//! The noise levels by the exact Gaussian likelihood of the data, with profile-likelihood
//! intervals.
//!
//! Why not only the Allan fit ([`crate::fit`]): the Allan estimates at long averaging times have
//! few degrees of freedom and skewed distributions, and least squares on them cannot give honest
//! intervals for the walk (docs/noise.md, "What the checks say"). The likelihood of the data
//! themselves has none of that: it is exact for the model, and its profile gives asymmetric
//! intervals that are longer upwards where the data say little.
//!
//! ## Model
//!
//! Per axis and static interval, the rate `y(t) = b(t) + g(t) + white(t)`:
//!
//! - `white`: white rate noise of two-sided density `N^2` (`N` the deviation of a 1-s average,
//!   the [`crate::fit::Term::White`] convention);
//! - `b`: a bias random walk, `b(t) = b0 + K W(t)` ([`crate::fit::Term::RandomWalk`]'s `K`);
//!   its start `b0` is a nuisance with a diffuse prior (each interval's own: a constant bias
//!   is not noise, and the restricted likelihood that results does not bias the variances the
//!   way an estimated mean does);
//! - `g` (optional): a first-order Gauss-Markov bias, stationary, deviation `sigma`,
//!   correlation time `tc` (an instability with a time scale).
//!
//! ## Block means and their exact moments
//!
//! A 4-h record at 100 Hz has 1.44 million samples per axis, and the fit evaluates the
//! likelihood hundreds of times. The samples are therefore averaged in blocks of `M` records
//! (duration `T = M tau0`), and the model is written exactly for
//! the block means (no approximation: the block likelihood is the likelihood of the block means
//! under the continuous model; only the information within a block is given up, which costs the
//! white level a little precision and the walk nothing). With the state at a block's start,
//!
//! ```text
//! y_j = b_j + a g_j + v_j,        b_{j+1} = b_j + w_j,        g_{j+1} = phi g_j + eta_j
//! v_j = u_j + xi_j + e_j          (the within-block parts of the walk, the Gauss-Markov bias, the white noise)
//! var e = N^2 / T,   var u = K^2 T / 3,   var w = K^2 T,   cov(u, w) = K^2 T / 2
//! phi = exp(-x), x = T / tc,   a = (1 - phi) / x,   var eta = sigma^2 (1 - phi^2)
//! var xi = 2 sigma^2 (x - 2 (1 - e^-x) + (1 - e^-2x) / 2) / x^2
//! cov(xi, eta) = 2 sigma^2 ((1 - e^-x) - (1 - e^-2x) / 2) / x
//! ```
//!
//! (`u = (1/T) int_0^T (b(t) - b_j) dt`, `xi` likewise for `g` without its decay of `g_j`; the
//! integrals of the Wiener process give the moments.) The measurement noise is correlated with
//! the process noise, which the filter below carries exactly (scalar algebra). A shorter last
//! block of an interval has its own `T`. `tests::block_likelihood_is_the_dense_gaussian` checks
//! the filter against the Gaussian density of the block means built from the covariance of the
//! single samples.
//!
//! The block length ([`fit_ml`]): [`BLOCKS_PER_CORRELATION`] times the sensor's correlation
//! length ([`correlation_records`]: the last lag at which the autocorrelation of the first
//! differences of the samples departs from that of white samples; a bias walk does not move
//! it), so that the sensor's own filter, which the model does not have, leaves the block means
//! nearly independent; at most a [`MIN_BLOCKS_PER_INTERVAL`]th of the longest interval (the
//! fit then says so, [`MlFit::below_correlation`]); and long enough for at most [`MAX_BLOCKS`]
//! blocks.
//!
//! ## Likelihood
//!
//! A Kalman filter in innovations form gives `-2 ln L = sum ln S_j + nu_j^2 / S_j` (the constant
//! `ln 2 pi` left out). The diffuse start is exact: the first block of an interval fixes `b`
//! (`b_1` given `y_0` has mean `y_0` and a variance from the moments above) and contributes
//! nothing; intervals are independent and their terms add. All variances scale together, so for
//! the white-and-walk model the scale is concentrated out and the fit is one-dimensional in
//! `K / N`: a grid over it, then Brent's method, so the maximum found is the global one.
//!
//! ## Selection
//!
//! The base model is white noise and a walk. The Gauss-Markov bias is added only when the
//! likelihood-ratio test says `p < 0.01`, with the ratio referred to chi-square with 2 degrees
//! of freedom (the two parameters it adds, `sigma` and `tc`). That reference is not exact: the
//! null value `sigma = 0` is on the boundary (which alone would make 2 degrees conservative) and
//! `tc` is not identified under the null (which makes them liberal); docs/noise.md reports how
//! often the seed set of white-and-walk recordings selects it (0 of 30). Its maximum is
//! searched by Nelder-Mead from five correlation times, `tc` kept between 10 blocks and 1000
//! longest intervals (`tc_penalty`).
//!
//! ## Intervals
//!
//! 68 % intervals from the profile likelihood: a parameter is fixed and the others
//! re-maximised, and the interval is where `-2 ln L` rises by at most 1 above the maximum
//! (Wilks). The ends are found by stepping out and regula falsi in the logarithm of the
//! parameter. A walk (or Gauss-Markov deviation) whose value 0 is inside that rise gets the
//! lower end 0. Quantisation is not in this model: at the block durations used it is invisible
//! (its block variance falls as `1 / T^2`); the Allan fit still reports it.
//!
//! ## Check
//!
//! The likelihood ratio only compares the two models; [`whiteness`] checks the selected one
//! against the data (the normalised innovations' sums over windows of 2, 4, 8, ... blocks).

use crate::NoiseError;
use crate::allan::check_intervals;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::ops::Range;
mod block_filter;
mod correlation;
mod minimise;
mod profile;
pub use block_filter::{Whiteness, neg2_log_likelihood, whiteness};
pub use correlation::{
    BLOCKS_PER_CORRELATION, Correlation, MIN_BLOCKS_PER_INTERVAL, OSCILLATION_MIN_AUTOCORRELATION,
    correlation_from_sums, correlation_of, correlation_records,
};
use profile::{base_levels, checked_base, fit_gauss_markov, gauss_markov_levels};

/// The most blocks the samples are averaged into (over all intervals): enough for the white
/// level to 0.3 % (68 % interval, each way) and a fit of a 4-h, 100-Hz axis in under a second.
pub const MAX_BLOCKS: usize = 50_000;

/// Rise of `-2 ln L` that bounds a 68.3 % profile interval (chi-square with 1 degree of
/// freedom).
pub const PROFILE_RISE: f64 = 1.0;

/// p-value below which the Gauss-Markov bias is added to the white-and-walk model.
pub const SELECTION_P: f64 = 0.01;

/// The block means of one axis: per static interval, `(mean rate, duration)` of each block.
#[derive(Clone, Debug, PartialEq)]
pub struct Blocks {
    /// Duration of a full block (s).
    pub block_s: f64,
    /// Per interval, the block means (rate unit, the interval's mean removed) and durations.
    pub intervals: Vec<Vec<(f64, f64)>>,
}

impl Blocks {
    /// Block the increments (one per record, SI: rad or m/s; `tau0_s` the record interval) of
    /// the static `intervals` into at most `max_blocks` blocks of equal length (the last of each
    /// interval shorter). Each interval's mean rate is removed (the likelihood with a diffuse
    /// start does not see it, and it keeps the numbers small).
    pub fn new(
        increments: &[f64],
        tau0_s: f64,
        intervals: &[Range<usize>],
        max_blocks: usize,
    ) -> Result<Blocks, NoiseError> {
        // The inputs are checked by `of_length`.
        let total: usize = intervals.iter().map(|r| r.len()).sum();
        let m = total.div_ceil(max_blocks.max(1)).max(1);
        Blocks::of_length(increments, tau0_s, intervals, m)
    }

    /// Block the increments of the static `intervals` into blocks of `records` records each
    /// (the last of each interval shorter), as [`Blocks::new`] does.
    pub fn of_length(
        increments: &[f64],
        tau0_s: f64,
        intervals: &[Range<usize>],
        records: usize,
    ) -> Result<Blocks, NoiseError> {
        if !(tau0_s.is_finite() && tau0_s > 0.0) {
            return Err(NoiseError::BadInterval0(tau0_s));
        }
        check_intervals(increments.len(), intervals)?;
        if let Some(i) = increments.iter().position(|x| !x.is_finite()) {
            return Err(NoiseError::NotFinite { record: i });
        }
        let m = records.max(1);
        let mut out = Vec::new();
        for r in intervals {
            let data = &increments[r.clone()];
            let mean = data.iter().sum::<f64>() / data.len() as f64;
            let blocks: Vec<(f64, f64)> = data
                .chunks(m)
                .map(|c| {
                    let s: f64 = c.iter().map(|v| v - mean).sum();
                    let d = c.len() as f64 * tau0_s;
                    (s / d, d)
                })
                .collect();
            out.push(blocks);
        }
        let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
        if out.iter().all(|b| b.len() < 3) {
            return Err(NoiseError::TooShort { longest });
        }
        Ok(Blocks {
            block_s: m as f64 * tau0_s,
            intervals: out,
        })
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.intervals.iter().map(Vec::len).sum()
    }

    /// Whether there is no block.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Innovations the likelihood has: blocks minus one per interval (the diffuse start).
    pub fn innovations(&self) -> usize {
        self.intervals
            .iter()
            .map(|b| b.len().saturating_sub(1))
            .sum()
    }

    /// Longest interval (s).
    pub fn longest_s(&self) -> f64 {
        self.intervals
            .iter()
            .map(|b| b.iter().map(|x| x.1).sum::<f64>())
            .fold(0.0, f64::max)
    }
}

/// Parameters of the model (SI; module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    /// White level `N` (rad/s or m/s^2 of a 1-s average).
    pub white: f64,
    /// Walk `K` (rad/s/sqrt(s) or m/s^2/sqrt(s)); may be 0.
    pub walk: f64,
    /// Gauss-Markov bias `(sigma, correlation time in s)`, if any.
    pub gauss_markov: Option<(f64, f64)>,
}

impl Model {
    /// The model's Allan variance at `tau_s` (to draw it over the measured curve): white
    /// `N^2 / tau`, walk `K^2 tau / 3`, and the first-order Gauss-Markov bias's
    /// `(2 sigma^2 tc / tau) (1 - (tc / 2 tau) (3 - 4 e^(-tau/tc) + e^(-2 tau/tc)))`
    /// (IEEE Std 952-1997, annex C, with `q_c^2 = 2 sigma^2 / tc`).
    pub fn avar(&self, tau_s: f64) -> f64 {
        let mut v = self.white * self.white / tau_s + self.walk * self.walk * tau_s / 3.0;
        if let Some((sigma, tc)) = self.gauss_markov {
            let x = tau_s / tc;
            let bracket = if x < 1e-3 {
                // 1 - (3 - 4 e^-x + e^-2x) / (2x) = x^2/3 - x^3/4 + 7 x^4/60 - ..., which the
                // closed form cancels to below x = 1e-3.
                x * x * (1.0 / 3.0 - x / 4.0 + 7.0 * x * x / 60.0)
            } else {
                1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x)
            };
            v += 2.0 * sigma * sigma / x * bracket;
        }
        v
    }
}

impl Model {
    /// The variance of whole-second means about their own rest's mean that the white noise
    /// and the walk imply, pooled over rests of `whole_seconds` seconds (those of fewer than two
    /// left out; `None` without any): what a scatter of 1-s means inside rests measures
    /// (`calibrate`'s white noise, `calib::estimate::hand_turned::white_noise_at_rest`). Each
    /// 1-s mean has the white variance `N^2`; a walk adds, in a rest of `n` seconds,
    /// `K^2 (sum_i V_i - S / n) / (n - 1)` with `V_i = i + 1/3` the variance of the `i`-th
    /// mean of a walk started at 0 and `S` the sum of all their covariances
    /// (`i + 1/2` for `i < j`). A Gauss-Markov bias is not in it.
    pub fn one_second_scatter(&self, whole_seconds: &[usize]) -> Option<f64> {
        let (mut ss, mut dof) = (0.0, 0usize);
        for &n in whole_seconds.iter().filter(|&&n| n >= 2) {
            let nf = n as f64;
            let sum_v = nf * (nf - 1.0) / 2.0 + nf / 3.0;
            let cross: f64 = (0..n)
                .map(|i| (i as f64 + 0.5) * (nf - 1.0 - i as f64))
                .sum();
            let walk_ss = sum_v - (sum_v + 2.0 * cross) / nf;
            ss += self.white * self.white * (nf - 1.0) + self.walk * self.walk * walk_ss;
            dof += n - 1;
        }
        (dof > 0).then(|| ss / dof as f64)
    }
}

/// A level and its 68 % profile-likelihood interval.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Level {
    /// Maximum-likelihood value.
    pub value: f64,
    /// Lower end of the 68 % interval (0 when the value 0 is inside it).
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
}

impl Level {
    /// The half-width on the side of `x`: `value - lower` below the value, `upper - value`
    /// above.
    pub fn half_width_toward(&self, x: f64) -> f64 {
        if x < self.value {
            self.value - self.lower
        } else {
            self.upper - self.value
        }
    }

    /// `(x - value)` in half-widths on its side (inside the interval: at most 1 in size).
    pub fn z(&self, x: f64) -> f64 {
        (x - self.value) / self.half_width_toward(x)
    }

    /// The mean of the two half-widths.
    pub fn mean_half_width(&self) -> f64 {
        0.5 * (self.upper - self.lower)
    }
}

/// A Gauss-Markov bias found in the data.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GaussMarkov {
    /// Its deviation (rad/s or m/s^2) with the profile interval.
    pub sigma: Level,
    /// Its correlation time (s), maximum-likelihood value.
    pub correlation_time_s: f64,
}

/// The maximum-likelihood fit of one axis.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MlFit {
    /// White level `N`.
    pub white: Level,
    /// Walk `K`.
    pub walk: Level,
    /// The Gauss-Markov bias, when the likelihood-ratio test selected it.
    pub gauss_markov: Option<GaussMarkov>,
    /// `-2 ln L` of the selected model at its maximum.
    pub neg2_log_likelihood: f64,
    /// Likelihood ratio (`-2 ln` of it) of the Gauss-Markov bias against white and walk.
    pub lr_statistic: f64,
    /// Its p-value, chi-square with 2 degrees of freedom (module docs).
    pub lr_p_value: f64,
    /// The whiteness check of the selected model's innovations ([`Whiteness`]): the check of
    /// the model against the data (the likelihood ratio only compares the two models).
    pub whiteness: Option<Whiteness>,
    /// Block duration (s).
    pub block_s: f64,
    /// Number of blocks.
    pub blocks: usize,
    /// The sensor's correlation time the blocks were chosen above (s; [`correlation_records`]
    /// times the record interval; 0 where not estimated).
    pub correlation_s: f64,
    /// Whether the Gauss-Markov correlation time sits at a bound of its search (10 blocks or
    /// 1000 longest intervals): then the value is the bound's, not the data's.
    pub tc_at_bound: bool,
    /// An oscillation in the samples ([`correlation_of`]): the blocks were chosen above its
    /// period rather than above the last correlated lag.
    #[serde(default)]
    pub oscillation: Option<Oscillation>,
}

/// An oscillation in an axis's samples ([`correlation_of`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Oscillation {
    /// Its period (s): the first lag at which the first differences' autocorrelation peaks
    /// positive.
    pub period_s: f64,
    /// Its root mean square in the rate (rad/s or m/s^2).
    pub rms: f64,
    /// The autocorrelation of the first differences at the period.
    pub autocorrelation: f64,
    /// The last lag at which the differences' autocorrelation departs from white (s): where
    /// the correlation search would have put the correlation time without it.
    pub correlated_to_s: f64,
}

impl MlFit {
    /// Record the correlation the blocks were chosen from (`tau0_s` the record interval).
    pub fn set_correlation(&mut self, c: &Correlation, tau0_s: f64) {
        self.correlation_s = c.records as f64 * tau0_s;
        self.oscillation = c.oscillation.map(|(p, r, rms)| Oscillation {
            period_s: p as f64 * tau0_s,
            rms: rms / tau0_s,
            autocorrelation: r,
            correlated_to_s: c.last_lag as f64 * tau0_s,
        });
    }

    /// Whether the blocks are shorter than [`BLOCKS_PER_CORRELATION`] correlation times (the
    /// cap of [`fit_ml`]): the sensor's own correlation may then show in the check.
    pub fn below_correlation(&self) -> bool {
        self.block_s < BLOCKS_PER_CORRELATION as f64 * self.correlation_s * (1.0 - 1e-9)
    }

    /// Whether the model passes its check against the data (whiteness p at least
    /// [`SELECTION_P`]); a fit without a check (too few innovations) does not.
    pub fn passes(&self) -> bool {
        self.whiteness.is_some_and(|w| w.p_value >= SELECTION_P)
    }

    /// The fitted model (maximum-likelihood values).
    pub fn model(&self) -> Model {
        Model {
            white: self.white.value,
            walk: self.walk.value,
            gauss_markov: self
                .gauss_markov
                .map(|g| (g.sigma.value, g.correlation_time_s)),
        }
    }
}

/// The maximum-likelihood fit of the blocks (module docs): white and walk, the Gauss-Markov
/// bias when the likelihood-ratio test selects it, profile intervals.
pub fn fit_blocks(blocks: &Blocks) -> Result<MlFit, NoiseError> {
    let (n, k, best) = checked_base(blocks)?;
    let (gm, gm_best) = fit_gauss_markov(blocks, n, k);
    let lr = (best - gm_best).max(0.0);
    let p = 1.0 - ChiSquared::new(2.0).expect("2 dof").cdf(lr);
    if p < SELECTION_P {
        let (white, walk, sigma) = gauss_markov_levels(blocks, &gm, gm_best);
        Ok(MlFit {
            white,
            walk,
            gauss_markov: Some(GaussMarkov {
                sigma,
                correlation_time_s: gm.gauss_markov.map_or(0.0, |g| g.1),
            }),
            neg2_log_likelihood: gm_best,
            lr_statistic: lr,
            lr_p_value: p,
            whiteness: whiteness(blocks, &gm),
            block_s: blocks.block_s,
            blocks: blocks.len(),
            correlation_s: 0.0,
            tc_at_bound: gm.gauss_markov.is_some_and(|(_, tc)| {
                let (lo, hi) = (10.0 * blocks.block_s, 1000.0 * blocks.longest_s());
                tc < lo * 1.01 || tc > hi / 1.01
            }),
            oscillation: None,
        })
    } else {
        let (white, walk) = base_levels(blocks, n, k, best);
        Ok(MlFit {
            white,
            walk,
            gauss_markov: None,
            neg2_log_likelihood: best,
            lr_statistic: lr,
            lr_p_value: p,
            whiteness: whiteness(
                blocks,
                &Model {
                    white: n,
                    walk: k,
                    gauss_markov: None,
                },
            ),
            block_s: blocks.block_s,
            blocks: blocks.len(),
            correlation_s: 0.0,
            tc_at_bound: false,
            oscillation: None,
        })
    }
}

/// The white-and-walk model alone (no Gauss-Markov search) fitted to `blocks`: the white level
/// and walk with their profile intervals. For comparing the walks of subsets of the rests
/// ([`crate::consistency`]): there one model's walk is set against another's, and the costly
/// Gauss-Markov search would only change what is compared.
pub fn fit_white_walk(blocks: &Blocks) -> Result<(Level, Level), NoiseError> {
    let (n, k, best) = checked_base(blocks)?;
    Ok(base_levels(blocks, n, k, best))
}

/// The maximum-likelihood fit of one axis: `increments` one per record (SI), record interval
/// `tau0_s`, static `intervals` (record index ranges, in order, not overlapping), blocked into
/// at most [`MAX_BLOCKS`] blocks.
pub fn fit_ml(
    increments: &[f64],
    tau0_s: f64,
    intervals: &[Range<usize>],
) -> Result<MlFit, NoiseError> {
    check_intervals(increments.len(), intervals)?;
    let correlation = correlation_of(increments, intervals);
    let k = correlation.records;
    // Blocks ten correlation lengths long, but no longer than a tenth of the longest interval:
    // with fewer blocks the white level and the check are no longer determined (a strongly
    // quantised axis whose quantisation error stays put for seconds, as on the Ferraris
    // accelerometer z, would otherwise leave fewer than three blocks per interval). Capped, the
    // fit says so ([`MlFit::below_correlation`]) and its check judges what the blocks keep.
    let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
    let cap = (longest / MIN_BLOCKS_PER_INTERVAL).max(1);
    let mut fit = fit_ml_blocks(
        increments,
        tau0_s,
        intervals,
        (BLOCKS_PER_CORRELATION * k).min(cap),
    )?;
    fit.set_correlation(&correlation, tau0_s);
    Ok(fit)
}

/// [`fit_ml`] on blocks of at least `min_records` records (more where [`MAX_BLOCKS`] needs
/// them).
pub fn fit_ml_blocks(
    increments: &[f64],
    tau0_s: f64,
    intervals: &[Range<usize>],
    min_records: usize,
) -> Result<MlFit, NoiseError> {
    let total: usize = intervals.iter().map(|r| r.len()).sum();
    let m = total.div_ceil(MAX_BLOCKS).max(min_records).max(1);
    let blocks = Blocks::of_length(increments, tau0_s, intervals, m)?;
    fit_blocks(&blocks)
}

#[cfg(test)]
#[allow(clippy::single_range_in_vec_init)] // one interval
mod tests {
    use super::minimise::{minimise_1d, nelder_mead};
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// The covariance of the means of consecutive blocks `(start, duration)` under the
    /// continuous model, walk started at 0 at time 0 and Gauss-Markov stationary, by the
    /// integrals of the processes (independent of the filter's moments).
    fn dense_cov(spans: &[(f64, f64)], m: &Model) -> DMatrix<f64> {
        let n = spans.len();
        let k2 = m.walk * m.walk;
        DMatrix::from_fn(n, n, |i, j| {
            let (si, ti) = spans[i];
            let (sj, tj) = spans[j];
            // Walk: mean over block i of K^2 min(s, t); for disjoint blocks the earlier's
            // midpoint, on the diagonal start + T/3.
            let mut c = if i == j {
                k2 * (si + ti / 3.0)
            } else {
                let (s, t) = if si < sj { (si, ti) } else { (sj, tj) };
                k2 * (s + t / 2.0)
            };
            if i == j {
                c += m.white * m.white / ti;
            }
            if let Some((sigma, tc)) = m.gauss_markov {
                let b = 1.0 / tc;
                let s2 = sigma * sigma;
                if i == j {
                    let x = b * ti;
                    c += 2.0 * s2 * (x + (-x).exp_m1()) / (x * x);
                } else {
                    let ((s1, t1), (s2_, t2)) = if si < sj {
                        ((si, ti), (sj, tj))
                    } else {
                        ((sj, tj), (si, ti))
                    };
                    // (1/(t1 t2)) int_{block 1} int_{block 2} s2 e^{-b (v - u)} dv du
                    let a1 = (b * (s1 - s2_)).exp() * (b * t1).exp_m1() / b;
                    let a2 = (1.0 - (-b * t2).exp()) / b;
                    c += s2 * a1 * a2 / (t1 * t2);
                }
            }
            c
        })
    }

    /// The restricted (diffuse-mean) `-2 ln L` of `y` with covariance `sigma0` plus an
    /// infinitely wide common offset: `ln det S0 + ln(1' S0^-1 1) + y' P y`.
    fn dense_diffuse(y: &[f64], sigma0: &DMatrix<f64>) -> f64 {
        let n = y.len();
        let chol = sigma0.clone().cholesky().expect("positive definite");
        let ln_det: f64 = chol.l().diagonal().iter().map(|d| 2.0 * d.ln()).sum();
        let y = DVector::from_column_slice(y);
        let one = DVector::from_element(n, 1.0);
        let si_y = chol.solve(&y);
        let si_1 = chol.solve(&one);
        let a = one.dot(&si_1);
        let b = one.dot(&si_y);
        ln_det + a.ln() + y.dot(&si_y) - b * b / a
    }

    fn models() -> Vec<Model> {
        vec![
            Model {
                white: 0.7,
                walk: 0.3,
                gauss_markov: None,
            },
            Model {
                white: 0.7,
                walk: 0.0,
                gauss_markov: None,
            },
            Model {
                white: 0.5,
                walk: 0.2,
                gauss_markov: Some((0.8, 3.0)),
            },
            Model {
                white: 0.5,
                walk: 0.0,
                gauss_markov: Some((0.8, 5000.0)),
            },
        ]
    }

    /// The filter's `-2 ln L` of per-sample data (blocks of one record) and of block means
    /// (blocks of 7 records, the last of 3) equals the Gaussian density of the same numbers
    /// with the covariance from the integrals of the processes; the block case with the
    /// covariance of the block means built as `A Sigma_samples A^T` from the samples'.
    #[test]
    fn block_likelihood_is_the_dense_gaussian() {
        let tau0 = 0.25;
        let records = 52;
        // Any numbers: the density is exact for any data.
        let inc: Vec<f64> = (0..records)
            .map(|i| ((i * 37 % 11) as f64 - 5.0) * 0.1 * tau0 + (i as f64 * 0.3).sin() * tau0)
            .collect();
        for model in models() {
            // Per sample.
            let samples = Blocks::new(&inc, tau0, &[0..records], records).unwrap();
            assert_eq!(samples.block_s, tau0);
            let spans: Vec<(f64, f64)> = (0..records).map(|i| (i as f64 * tau0, tau0)).collect();
            let cov_s = dense_cov(&spans, &model);
            let y: Vec<f64> = samples.intervals[0].iter().map(|b| b.0).collect();
            let kf = neg2_log_likelihood(&samples, &model);
            let dense = dense_diffuse(&y, &cov_s);
            assert!(
                (kf - dense).abs() < 1e-8 * (1.0 + dense.abs()),
                "{model:?}: samples: filter {kf}, dense {dense}"
            );
            // Blocks of 7 (the last of 3): the block means as A y, covariance A Sigma A^T.
            let blocks = Blocks::new(&inc, tau0, &[0..records], 8).unwrap();
            assert_eq!(blocks.block_s, 7.0 * tau0);
            let nb = blocks.intervals[0].len();
            assert_eq!(nb, 8);
            let a = DMatrix::from_fn(nb, records, |j, i| {
                let first = 7 * j;
                let len = (records - first).min(7);
                if i >= first && i < first + len {
                    1.0 / len as f64
                } else {
                    0.0
                }
            });
            let cov_b = &a * &cov_s * a.transpose();
            let yb: Vec<f64> = blocks.intervals[0].iter().map(|b| b.0).collect();
            let kf = neg2_log_likelihood(&blocks, &model);
            let dense = dense_diffuse(&yb, &cov_b);
            assert!(
                (kf - dense).abs() < 1e-8 * (1.0 + dense.abs()),
                "{model:?}: blocks: filter {kf}, dense {dense}"
            );
        }
    }

    /// Two intervals: their likelihoods add.
    #[test]
    fn intervals_add() {
        let tau0 = 0.1;
        let inc: Vec<f64> = (0..60).map(|i| (i as f64 * 0.7).cos() * tau0).collect();
        let m = models()[2];
        let both = Blocks::new(&inc, tau0, &[0..25, 30..60], 100).unwrap();
        let a = Blocks::new(&inc, tau0, &[0..25], 100).unwrap();
        let b = Blocks::new(&inc, tau0, &[30..60], 100).unwrap();
        let (x, y, z) = (
            neg2_log_likelihood(&both, &m),
            neg2_log_likelihood(&a, &m),
            neg2_log_likelihood(&b, &m),
        );
        assert!((x - y - z).abs() < 1e-9 * x.abs());
    }

    /// The Gauss-Markov Allan variance: a walk `K^2 = 2 sigma^2 / tc` far below `tc`, white
    /// noise `N^2 = 2 sigma^2 tc` far above, the two forms continuous at the series' switch.
    #[test]
    fn gauss_markov_allan_variance_limits() {
        let (sigma, tc) = (0.3, 50.0);
        let m = Model {
            white: 0.0,
            walk: 0.0,
            gauss_markov: Some((sigma, tc)),
        };
        let k2 = 2.0 * sigma * sigma / tc;
        assert!((m.avar(0.01) / (k2 * 0.01 / 3.0) - 1.0).abs() < 1e-3);
        let n2 = 2.0 * sigma * sigma * tc;
        assert!((m.avar(1e6) / (n2 / 1e6) - 1.0).abs() < 1e-3);
        let (a, b) = (m.avar(tc * 0.999_999e-3), m.avar(tc * 1.000_001e-3));
        assert!((a / b - 1.0).abs() < 1e-5, "{a} {b}");
    }

    #[test]
    fn one_second_scatter_of_a_walk() {
        // Two seconds: the two means differ by a walk's variance 2/3, so their scatter is 1/3.
        let walk = Model {
            white: 0.0,
            walk: 1.0,
            gauss_markov: None,
        };
        assert!((walk.one_second_scatter(&[2]).unwrap() - 1.0 / 3.0).abs() < 1e-12);
        // The white noise alone: N^2 whatever the rests.
        let white = Model {
            white: 2.0,
            walk: 0.0,
            gauss_markov: None,
        };
        assert_eq!(white.one_second_scatter(&[5, 1, 30]).unwrap(), 4.0);
        assert!(white.one_second_scatter(&[1, 0]).is_none());
        // A long rest: the scatter of a walk's means about their mean grows as n / 6.
        let s = walk.one_second_scatter(&[3000]).unwrap();
        assert!((s / 500.0 - 1.0).abs() < 0.01, "{s}");
    }

    #[test]
    fn optimisers_find_minima() {
        let (x, fx) = minimise_1d(&mut |x| (x - 3.0).powi(2) + 1.0, 0.0, 0.1, 1e-8);
        assert!((x - 3.0).abs() < 1e-6 && (fx - 1.0).abs() < 1e-10);
        let (p, fp) = nelder_mead(
            &mut |p| (p[0] - 1.0).powi(2) + 10.0 * (p[1] + 2.0).powi(2),
            &[0.0, 0.0],
            0.5,
            1e-12,
            2000,
            2,
        );
        assert!((p[0] - 1.0).abs() < 1e-4 && (p[1] + 2.0).abs() < 1e-4 && fp < 1e-8);
    }
}
