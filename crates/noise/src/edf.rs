//! Equivalent degrees of freedom of the overlapping Allan variance, and its confidence
//! intervals.
//!
//! An Allan variance estimate `s^2` over `edf` equivalent degrees of freedom is taken as
//! `sigma^2 chi^2(edf) / edf`, so the interval that holds the true deviation with probability
//! `p` is `s sqrt(edf / chi^2_{(1+p)/2})` .. `s sqrt(edf / chi^2_{(1-p)/2})` (NIST SP 1065,
//! eq. 45; IEEE Std 952-1997 annex C uses the same chi-square reasoning).
//!
//! The degrees of freedom depend on the kind of noise that dominates at that averaging time.
//! [`edf_overlapping`] gives the approximate formulas of Howe, Allan and Barnes (1981), as
//! tabulated in NIST SP 1065 (Riley 2008), Table 5, and in IEEE Std 1139, for the overlapping
//! Allan variance of `N` phase points (here: `N - 1` records, the phase being the running sum
//! of the increments) at averaging factor `m`. For inertial sensors the "frequency" of those
//! formulas is the sensor's rate (angular rate, specific force) and the "phase" its integral
//! (angle, velocity), so:
//!
//! | sensor noise term | power-law type | alpha |
//! |---|---|---|
//! | quantisation | white phase | +2 |
//! | white noise (angle / velocity random walk) | white frequency | 0 |
//! | bias instability | flicker frequency | -1 |
//! | bias random walk (and rate ramp, which has no formula of its own) | random-walk frequency | -2 |

use serde::{Deserialize, Serialize};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// The power-law noise that dominates the Allan variance at one averaging time, which sets its
/// degrees of freedom ([`edf_overlapping`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseType {
    /// White phase noise (alpha = +2): the quantisation of the increments.
    WhitePhase,
    /// White frequency noise (alpha = 0): white rate noise, i.e. angle or velocity random walk.
    WhiteRate,
    /// Flicker frequency noise (alpha = -1): bias instability.
    Flicker,
    /// Random-walk frequency noise (alpha = -2): the bias random walk.
    RandomWalk,
}

impl NoiseType {
    /// The exponent alpha of the rate's power spectral density, `S(f) ~ f^alpha`.
    pub fn alpha(self) -> i32 {
        match self {
            NoiseType::WhitePhase => 2,
            NoiseType::WhiteRate => 0,
            NoiseType::Flicker => -1,
            NoiseType::RandomWalk => -2,
        }
    }
}

/// Equivalent degrees of freedom of the overlapping Allan variance of `phase_points` phase
/// points (records + 1) at averaging factor `m`, dominated by `noise` (Howe, Allan and Barnes
/// 1981; NIST SP 1065 Table 5):
///
/// - white phase: `(N + 1)(N - 2m) / (2 (N - m))`;
/// - white frequency: `(3 (N - 1) / (2m) - 2 (N - 2) / N) 4 m^2 / (4 m^2 + 5)`;
/// - flicker frequency: `2 (N - 2)^2 / (2.3 N - 4.9)` for `m = 1`, else
///   `5 N^2 / (4 m (N + 3m))`;
/// - random-walk frequency: `(N - 2) / (m (N - 3)^2) ((N - 1)^2 - 3m (N - 1) + 4 m^2)`.
///
/// The result is kept between 1 and the number of terms `N - 2m` (the approximations leave that
/// range for the shortest data); 0 when there is no term (`N <= 2m`).
pub fn edf_overlapping(phase_points: usize, m: usize, noise: NoiseType) -> f64 {
    if m == 0 || phase_points <= 2 * m {
        return 0.0;
    }
    let n = phase_points as f64;
    let mf = m as f64;
    let edf = match noise {
        NoiseType::WhitePhase => (n + 1.0) * (n - 2.0 * mf) / (2.0 * (n - mf)),
        NoiseType::WhiteRate => {
            (3.0 * (n - 1.0) / (2.0 * mf) - 2.0 * (n - 2.0) / n) * 4.0 * mf * mf
                / (4.0 * mf * mf + 5.0)
        }
        NoiseType::Flicker => {
            if m == 1 {
                2.0 * (n - 2.0).powi(2) / (2.3 * n - 4.9)
            } else {
                5.0 * n * n / (4.0 * mf * (n + 3.0 * mf))
            }
        }
        NoiseType::RandomWalk => {
            (n - 2.0) / (mf * (n - 3.0).powi(2))
                * ((n - 1.0).powi(2) - 3.0 * mf * (n - 1.0) + 4.0 * mf * mf)
        }
    };
    let terms = n - 2.0 * mf;
    if edf.is_finite() {
        edf.clamp(1.0, terms.max(1.0))
    } else {
        1.0
    }
}

/// Probability that a normal variable lies within one standard deviation of its mean: the
/// confidence level of the intervals reported (`erf(1 / sqrt 2)`).
pub const ONE_SIGMA: f64 = 0.682_689_492_137_085_9;

/// The quantile `q` of the chi-square distribution with `dof` degrees of freedom: statrs'
/// inverse below 1000 degrees of freedom, the Wilson-Hilferty approximation above (relative
/// error below 1e-4 there, and no iteration on millions of degrees of freedom).
pub fn chi_square_quantile(dof: f64, q: f64) -> f64 {
    if dof < 1000.0 {
        ChiSquared::new(dof)
            .map(|d| d.inverse_cdf(q))
            .unwrap_or(f64::NAN)
    } else {
        let z = statrs::distribution::Normal::standard().inverse_cdf(q);
        let a = 2.0 / (9.0 * dof);
        dof * (1.0 - a + z * a.sqrt()).powi(3)
    }
}

/// The interval `(lower, upper)` that holds the true Allan deviation with probability `level`
/// (e.g. [`ONE_SIGMA`]), for an estimate `adev` with `edf` degrees of freedom.
pub fn confidence_interval(adev: f64, edf: f64, level: f64) -> (f64, f64) {
    if edf.is_nan() || edf <= 0.0 {
        return (0.0, f64::INFINITY);
    }
    let tail = 0.5 * (1.0 - level);
    let hi = chi_square_quantile(edf, 1.0 - tail);
    let lo = chi_square_quantile(edf, tail);
    (adev * (edf / hi).sqrt(), adev * (edf / lo).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edf_formulas_match_hand_values() {
        // White frequency, N = 1001 phase points, m = 10: (3*1000/20 - 2*999/1001) * 400/405.
        let e = edf_overlapping(1001, 10, NoiseType::WhiteRate);
        let want = (150.0 - 2.0 * 999.0 / 1001.0) * 400.0 / 405.0;
        assert!((e - want).abs() < 1e-9, "{e} {want}");
        // Random walk, N = 1001, m = 100.
        let n: f64 = 1001.0;
        let want = (n - 2.0) / (100.0 * (n - 3.0).powi(2))
            * ((n - 1.0).powi(2) - 300.0 * (n - 1.0) + 40000.0);
        let e = edf_overlapping(1001, 100, NoiseType::RandomWalk);
        assert!((e - want).abs() < 1e-9);
        // Flicker m = 1 and m = 4.
        let e = edf_overlapping(101, 1, NoiseType::Flicker);
        assert!((e - 2.0 * 99.0f64.powi(2) / (2.3 * 101.0 - 4.9)).abs() < 1e-9);
        let e = edf_overlapping(101, 4, NoiseType::Flicker);
        assert!((e - 5.0 * 101.0f64.powi(2) / (16.0 * 113.0)).abs() < 1e-9);
        // No term, and the clamp to [1, terms].
        assert_eq!(edf_overlapping(10, 5, NoiseType::WhiteRate), 0.0);
        assert_eq!(edf_overlapping(3, 1, NoiseType::RandomWalk), 1.0);
    }

    #[test]
    fn confidence_interval_brackets_and_shrinks() {
        let (lo, hi) = confidence_interval(1.0, 10.0, ONE_SIGMA);
        assert!(lo < 1.0 && hi > 1.0);
        let (lo2, hi2) = confidence_interval(1.0, 1000.0, ONE_SIGMA);
        assert!(lo2 > lo && hi2 < hi);
        // For many degrees of freedom the 1-sigma half width of the deviation is about
        // 1 / sqrt(2 edf).
        let (lo3, hi3) = confidence_interval(1.0, 1e6, ONE_SIGMA);
        let half = 0.5 * (hi3 - lo3);
        assert!((half * (2e6f64).sqrt() - 1.0).abs() < 1e-3, "{half}");
        // The two quantile routes agree near their switch.
        let a = chi_square_quantile(999.0, 0.2);
        let b = chi_square_quantile(1000.0, 0.2);
        assert!((a - b).abs() < 2.0, "{a} {b}");
    }
}
