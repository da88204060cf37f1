//! What a program's data show of a gyro bias random walk, from the covariance analysis alone.
//!
//! A walk adds `s D` to the covariance of all the measurements (`s` the walk's PSD, `D` what a
//! unit walk puts there), so `Sigma(s) = Sigma_0 + s D` and the expected likelihood-ratio
//! statistic of the walk against the model without it, on data that carry it, is twice the
//! Kullback-Leibler divergence of the two data distributions:
//!
//! `E[2 (ln L_s - ln L_0)] = tr(Sigma_0^-1 Sigma(s)) - N - ln det(Sigma_0^-1 Sigma(s))
//!                         = s f'(0) - (f(s) - f(0))`,
//!
//! with `f(s) = ln det Sigma(s)`, which the analysis gives as the sum of `ln det S` over its
//! updates ([`Posterior::log_det_data`]); `f'(0) = tr(Sigma_0^-1 D)` comes from two analyses
//! at small `s` (Richardson's extrapolation of the forward differences). The same holds about a
//! walk already in `[noise]` (`s_0` in place of 0).
//!
//! The statistic's distribution under the walk is a weighted sum of `chi^2_1` variables, skewed
//! when a few slow modes carry the walk: its median is below this mean (on simulated runs with
//! a walk of 0.3 deg/h/sqrt(h), seven of eight statistics came out below their expected
//! value, at 0.26 to 1.16 of it). A walk whose expected statistic is below the loop's threshold
//! is therefore found in fewer than half of the runs: [`smallest_visible_drift`] is a lower
//! bound of what the program finds, not a promise.

use crate::config::RunConfig;
use crate::estimate::covariance::{AnalysisError, Posterior, covariance_analysis_ext};
use crate::model::extension::ModelExtension;
use sins_model::names::GYRO_BIAS;

/// What the data of a program show of a gyro bias random walk of one intensity.
#[derive(Clone, Debug, PartialEq)]
pub struct DriftVisibility {
    /// The walk's intensity, each axis (rad/s/sqrt(s)).
    pub intensity: f64,
    /// The expected likelihood-ratio statistic of the walk against the model without it, on
    /// data that carry it.
    pub expected_statistic: f64,
    /// The gyro biases' posterior sigmas at the end of the program with the walk in the model
    /// (rad/s).
    pub gyro_bias_sigma: [f64; 3],
    /// The same without it (rad/s).
    pub gyro_bias_sigma_without: [f64; 3],
}

/// The covariance analyses behind [`DriftVisibility`]: the base model (`ext` with the
/// configured walk, if any) and the slope of `ln det Sigma` in the walk's PSD there.
pub struct DriftAnalysis<'a> {
    config: &'a RunConfig,
    with_turntable: bool,
    ext: ModelExtension,
    /// The base model's PSD of each gyro bias's walk ((rad/s)^2/s).
    base_psd: f64,
    base: Posterior,
    /// `d ln det Sigma / d psd` at the base.
    slope: f64,
}

impl<'a> DriftAnalysis<'a> {
    /// Analyse the program of `config` (with or without its turntable angles) with the model
    /// `ext` and no walk beyond `[noise]`'s; `scale` is a PSD of the order of those to be
    /// asked about ((rad/s)^2/s), which sets the step of the numerical slope.
    pub fn new(
        config: &'a RunConfig,
        with_turntable: bool,
        ext: &ModelExtension,
        scale: f64,
    ) -> Result<Self, AnalysisError> {
        let mut ext = ext.clone();
        ext.gyro_drift = None;
        let base_psd = config
            .noise
            .gyro_bias_walk()
            .map_or(0.0, |q| q.iter().map(|q| q * q).sum::<f64>() / 3.0);
        let base = covariance_analysis_ext(config, with_turntable, &ext)?;
        let mut this = Self {
            config,
            with_turntable,
            ext,
            base_psd,
            base,
            slope: f64::NAN,
        };
        // Forward differences at h and 2h, extrapolated: f' = 2 D(h) - D(2h) + O(h^2). The
        // step is small against the PSDs asked about (f is smooth and concave in the PSD) and
        // large against the rounding of ln det Sigma (a sum of thousands of terms of order 10).
        let h = 1e-3 * scale.max(base_psd);
        let d = |psd: f64, this: &Self| -> Result<f64, AnalysisError> {
            Ok((this.analyse(base_psd + psd)?.log_det_data - this.base.log_det_data) / psd)
        };
        this.slope = 2.0 * d(h, &this)? - d(2.0 * h, &this)?;
        Ok(this)
    }

    fn analyse(&self, psd: f64) -> Result<Posterior, AnalysisError> {
        let mut ext = self.ext.clone();
        ext.gyro_drift = Some([psd.sqrt(); 3]);
        covariance_analysis_ext(self.config, self.with_turntable, &ext)
    }

    /// What the data show of a walk of `intensity` (rad/s/sqrt(s)) on every axis, in place of
    /// the configured one.
    pub fn at(&self, intensity: f64) -> Result<DriftVisibility, AnalysisError> {
        let psd = intensity * intensity;
        let with = self.analyse(psd)?;
        let excess = psd - self.base_psd;
        let expected_statistic = excess * self.slope - (with.log_det_data - self.base.log_det_data);
        let sigmas = |p: &Posterior| GYRO_BIAS.map(|n| p.sigma(n).unwrap_or(f64::NAN));
        Ok(DriftVisibility {
            intensity,
            expected_statistic,
            gyro_bias_sigma: sigmas(&with),
            gyro_bias_sigma_without: sigmas(&self.base),
        })
    }
}

/// The smallest walk intensity in `[lo, hi]` (rad/s/sqrt(s)) whose expected statistic reaches
/// `threshold`, to 2 % (the statistic grows with the intensity): `None` when even `hi` stays
/// below, `lo` when `lo` already reaches it. Each analysis runs the whole program, so the
/// bracket is narrowed by secant steps on logarithmic scales (the statistic is close to a
/// power of the intensity), a step that lands within 2 % of an end of the bracket put 2 %
/// inside it (which then usually closes it): five analyses on the paper's program where
/// halving took ten.
pub fn smallest_visible_drift(
    analysis: &DriftAnalysis,
    threshold: f64,
    lo: f64,
    hi: f64,
) -> Result<Option<DriftVisibility>, AnalysisError> {
    first_crossing(lo, hi, threshold, |q| {
        let v = analysis.at(q)?;
        Ok((v.expected_statistic, v))
    })
}

/// The bracket's width on the logarithmic scale at which [`first_crossing`] stops (2 %).
const CROSSING_TOLERANCE: f64 = 0.02;

/// The point of `[lo, hi]` within [`CROSSING_TOLERANCE`] above where the increasing
/// `statistic` first reaches `threshold`, with what `statistic` gave there: `None` when it
/// stays below at `hi`. Secant steps on the logarithms of both, a step within the tolerance
/// of an end put one tolerance inside it.
fn first_crossing<T, E>(
    lo: f64,
    hi: f64,
    threshold: f64,
    mut statistic: impl FnMut(f64) -> Result<(f64, T), E>,
) -> Result<Option<T>, E> {
    let (at_hi, top) = statistic(hi)?;
    if at_hi < threshold {
        return Ok(None);
    }
    let (at_lo, bottom) = statistic(lo)?;
    if at_lo >= threshold {
        return Ok(Some(bottom));
    }
    let (mut a, mut b) = (lo.ln(), hi.ln());
    // The two latest points, for the secant.
    let (mut older, mut latest) = ((a, at_lo), (b, at_hi));
    let mut found = top;
    while b - a > CROSSING_TOLERANCE {
        let ((x0, s0), (x1, s1)) = (older, latest);
        let secant = x1 + (threshold / s1).ln() * (x1 - x0) / (s1 / s0).ln();
        let x = if s0 > 0.0 && secant.is_finite() && b - a > 2.0 * CROSSING_TOLERANCE {
            // Within the tolerance of an end, the point one tolerance in closes the bracket.
            secant.clamp(a + CROSSING_TOLERANCE, b - CROSSING_TOLERANCE)
        } else {
            0.5 * (a + b)
        };
        let (at_x, value) = statistic(x.exp())?;
        older = latest;
        latest = (x, at_x);
        if at_x >= threshold {
            b = x;
            found = value;
        } else {
            a = x;
        }
    }
    Ok(Some(found))
}

/// The likelihood-ratio statistic at which the loop accepts a walk at `level`: where the
/// p-value `chi_bar_square_sf(x, 1) = P(chi^2_1 > x) / 2` falls to `level`.
pub fn drift_threshold(level: f64) -> f64 {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let level = level.clamp(1e-300, 0.5);
    ChiSquared::new(1.0)
        .expect("one degree of freedom")
        .inverse_cdf(1.0 - 2.0 * level)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extend::evidence::chi_bar_square_sf;

    /// Power laws like the expected statistic's (a square at small intensities, near linear
    /// above), with the crossing anywhere in the range: found within the tolerance above the
    /// crossing, the statistic there at least the threshold, in few evaluations.
    #[test]
    fn the_crossing_is_found_to_the_tolerance_in_few_evaluations() {
        let (lo, hi) = (1e-3f64, 1e-1f64);
        for power in [0.7, 1.0, 1.5, 2.0, 3.0] {
            for k in 1..40 {
                let root = lo * (hi / lo).powf(k as f64 / 40.0);
                let mut evaluations = 0;
                let statistic = |q: f64| -> Result<(f64, f64), ()> {
                    evaluations += 1;
                    // A square below 0.01, the power above, 8.6 at the root.
                    let shape = |q: f64| (q / 0.01).powi(2).min((q / 0.01).powf(power));
                    Ok((8.6 * shape(q) / shape(root), q))
                };
                let found = first_crossing(lo, hi, 8.6, statistic).unwrap().unwrap();
                let ratio = (found / root).ln();
                assert!(
                    (-1e-12..=CROSSING_TOLERANCE + 1e-12).contains(&ratio),
                    "power {power}, root {root}: {found}"
                );
                assert!(
                    evaluations <= 10,
                    "power {power}, root {root}: {evaluations}"
                );
            }
        }
        let below = first_crossing(1.0, 2.0, 10.0, |q| Ok::<_, ()>((q, q))).unwrap();
        assert_eq!(below, None);
        let at_lo = first_crossing(1.0, 2.0, 0.5, |q| Ok::<_, ()>((q, q))).unwrap();
        assert_eq!(at_lo, Some(1.0));
    }

    #[test]
    fn the_threshold_is_where_the_p_value_reaches_the_level() {
        for level in [0.05, 0.01, 0.002] {
            let c = drift_threshold(level);
            assert!((chi_bar_square_sf(c, 1) - level).abs() < 1e-9 * level.max(1e-3));
        }
    }
}
