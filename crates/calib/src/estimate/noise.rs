//! The measurements' white noise in one place: the levels a fit runs with, where they came
//! from, and the one rule that brings a level to a fit's innovations.
//!
//! A fit's levels are
//! - **configured**: the configuration's `[noise]` levels and
//!   `filter.motion_attitude_noise_deg` as given ([`NoiseSource::Configured`]);
//! - **measured from the rests** of a hand-turned recording: the configuration then holds the
//!   rests' scatter ([`crate::estimate::hand_turned::default_config`]), and each fit runs at
//!   [`MeasuredLevels`] (the specific-force level times a factor, the attitude noise of a
//!   motion), which `estimate::hand_turned::fit_measuring_noise` brings to the fit's
//!   own innovations ([`NoiseSource::Measured`]);
//! - **rescaled**: the configured levels times the [`level_factor`] of each measurement whose
//!   mean NIS is outside its band ([`NoiseRescale`]: a round of the model-extension loop whose
//!   model contradicts the configured noise). A fit whose noise is measured is at the data's
//!   scale already and is not rescaled.
//!
//! The rule: innovations fitted at a level whose mean NIS is `m` where the model that fits
//! gives `e` (3 for the specific force) scatter as a level `sqrt(m / e)` times that one says
//! ([`level_factor`]); their variance against the noise of a base level is the square, with
//! the factor the fit ran at from the base ([`variance_ratio`]).

use crate::config::RunConfig;
use serde::Serialize;

/// What the mean NIS of the specific-force windows averages when the model fits: one per
/// component.
pub const ACCEL_EXPECTED_NIS: f64 = 3.0;

/// The factor on a white-noise level that brings it to the innovations fitted with it: the
/// root of their mean NIS over what it averages when the model fits (`expected`: 3 for the
/// specific force, `FitStatistics::turntable_expected_nis` for the turntable angles).
pub fn level_factor(mean_nis: f64, expected: f64) -> f64 {
    (mean_nis / expected).sqrt()
}

/// The variance of the specific-force innovations over that of the noise at a base level, from
/// their mean NIS in a fit made at `factor` times the base level: `factor^2 mean NIS / 3`, the
/// square of the factor [`level_factor`] puts on the base level.
pub fn variance_ratio(factor: f64, mean_nis: f64) -> f64 {
    factor * factor * mean_nis / ACCEL_EXPECTED_NIS
}

/// Factors on the configured white-noise levels (`[noise] accel_m_s2`, `angle_arcsec`): the
/// [`level_factor`] of each measurement whose mean NIS with the configured levels is outside
/// its band, 1 where it is inside.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NoiseRescale {
    /// Factor on the specific-force noise.
    pub accel_factor: f64,
    /// Factor on the angle noise.
    pub angle_factor: f64,
}

impl NoiseRescale {
    /// The factors that bring the configured levels to a fit's innovations: `accel` and
    /// `angle` are the `(mean NIS, expected mean)` of each measurement whose mean is outside
    /// its band (`None`: inside, or no updates; a mean that is not finite and positive says
    /// nothing of the level either). `None` when both factors are 1.
    pub fn to_innovations(accel: Option<(f64, f64)>, angle: Option<(f64, f64)>) -> Option<Self> {
        let factor = |m: Option<(f64, f64)>| {
            m.filter(|&(mean, _)| mean.is_finite() && mean > 0.0)
                .map_or(1.0, |(mean, expected)| level_factor(mean, expected))
        };
        let r = Self {
            accel_factor: factor(accel),
            angle_factor: factor(angle),
        };
        (r.accel_factor != 1.0 || r.angle_factor != 1.0).then_some(r)
    }

    /// `config` with its white-noise levels scaled by the factors.
    pub fn scaled(&self, config: &RunConfig) -> RunConfig {
        let mut scaled = config.clone();
        scaled.noise.accel_m_s2 *= self.accel_factor;
        scaled.noise.angle_arcsec *= self.angle_factor;
        scaled
    }
}

/// The levels of a fit of a recording of rests: its specific-force level `accel_factor` times
/// the configured one (with measured noise, the rests' scatter) and the attitude noise of a
/// motion (rad).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredLevels {
    /// The factor on the configured specific-force level.
    pub accel_factor: f64,
    /// The attitude noise of a motion, one sigma per axis (rad).
    pub motion_rad: f64,
}

impl MeasuredLevels {
    /// The configured levels: factor 1 and the configuration's motion noise.
    pub fn configured(config: &RunConfig) -> Self {
        Self {
            accel_factor: 1.0,
            motion_rad: config.filter.motion_attitude_noise_deg.to_radians(),
        }
    }

    /// `config` at these levels, its specific-force level `base_accel_m_s2` times the factor.
    pub fn apply(&self, config: &mut RunConfig, base_accel_m_s2: f64) {
        config.noise.accel_m_s2 = base_accel_m_s2 * self.accel_factor;
        config.filter.motion_attitude_noise_deg = self.motion_rad.to_degrees();
    }
}

/// Where the white-noise levels of a calibration came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoiseSource {
    /// The configuration's `[noise]` and `filter.motion_attitude_noise_deg`.
    Configured,
    /// Measured in the rests ([`crate::estimate::hand_turned::white_noise_at_rest`]); the
    /// specific force's level then multiplied by `accel_factor` (above or below 1) to the
    /// scatter of the filter's innovations, and the motion noise measured
    /// ([`crate::estimate::hand_turned::noise_ml`]); `fits` fits made.
    Measured {
        /// The rests' scatter.
        at_rest: WhiteNoiseAtRest,
        /// The factor on its specific-force level.
        accel_factor: f64,
        /// The innovations' scatter at the rests' own level: the F-test of whether the
        /// windows scatter more than the rests' noise says.
        excess: ScatterExcess,
        /// The same of the held-out windows (with a hold-out).
        held_out_excess: Option<ScatterExcess>,
        /// The attitude noise of a motion measured from the first windows after the motions
        /// (deg), and how many windows it rests on.
        motion_noise_deg: f64,
        /// First windows after a motion behind it.
        motion_windows: usize,
        /// Fits made.
        fits: usize,
    },
}

impl NoiseSource {
    /// The levels measured, for a fit of a model close to this one to start from (`None`:
    /// configured).
    pub fn measured_levels(&self) -> Option<MeasuredLevels> {
        match *self {
            NoiseSource::Configured => None,
            NoiseSource::Measured {
                accel_factor,
                motion_noise_deg,
                ..
            } => Some(MeasuredLevels {
                accel_factor,
                motion_rad: motion_noise_deg.to_radians(),
            }),
        }
    }
}

/// The white-noise levels measured in the rests of a recording: each the standard deviation of
/// a 1-s mean of one axis, pooled over the rests and the three axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WhiteNoiseAtRest {
    /// Gyro (rad/s).
    pub gyro_rad_s: f64,
    /// Accelerometer (m/s^2).
    pub accel_m_s2: f64,
    /// Degrees of freedom of the pooled variance (per axis).
    pub dof: usize,
}

/// Whether the specific-force innovations scatter more than the rests' own noise says: the
/// ratio of their variance to it, `F = accel_factor^2` (the fit's mean NIS over 3 at the
/// measured level), against the F distribution of `3 windows` and `3 dof` degrees of freedom
/// (one-sided, the upper [`EXCESS_LEVEL`] tail; the log-normal approximation
/// `ln F ~ N(0, 2/d1 + 2/d2)`). An excess says the rests differ by more than their noise: the
/// model lacks an error, or the unit settles or warms after each turn. Not a verdict alone:
/// the held-out rests decide ([`crate::estimate::verdict::hand_turned_tests`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScatterExcess {
    /// The variance ratio.
    pub ratio: f64,
    /// Its one-sided p-value.
    pub p_value: f64,
    /// Windows behind it.
    pub windows: usize,
    /// Degrees of freedom of the rests' noise (per axis).
    pub dof: usize,
}

/// The level of the one-sided tests of [`ScatterExcess`] and [`crate::estimate::verdict::hand_turned_tests`].
pub const EXCESS_LEVEL: f64 = 0.01;

impl ScatterExcess {
    /// The test of a variance ratio over `windows` windows against rests of `dof` degrees of
    /// freedom.
    pub(crate) fn of(ratio: f64, windows: usize, dof: usize) -> Self {
        let v = 2.0 / (3 * windows.max(1)) as f64 + 2.0 / (3 * dof.max(1)) as f64;
        let z = ratio.max(f64::MIN_POSITIVE).ln() / v.sqrt();
        Self {
            ratio,
            p_value: normal_upper_tail(z),
            windows,
            dof,
        }
    }

    /// Whether the excess is significant.
    pub fn significant(&self) -> bool {
        self.p_value < EXCESS_LEVEL
    }

    /// Whether the excess is gross: the variance ratio significantly above
    /// [`GROSS_VARIANCE_RATIO`] (the same one-sided test of `ratio / GROSS_VARIANCE_RATIO`).
    pub fn gross(&self) -> bool {
        ScatterExcess::of(self.ratio / GROSS_VARIANCE_RATIO, self.windows, self.dof).significant()
    }
}

/// The variance ratio of innovations to the rests' own noise above which what the model
/// lacks outweighs the noise: at 4 the part of the scatter that the rests' noise does not
/// explain is three times the part it does (residuals twice the noise in sigma). Below it a
/// real unit's settling after a hand turn, slow drift and sensor filtering (the shipped Xsens
/// recording with its g-sensitivity: 1.9) are within what a calibration is judged on; above it
/// the calibration is dominated by an error it does not model (the same recording without the
/// g-sensitivity: 65).
pub const GROSS_VARIANCE_RATIO: f64 = 4.0;

/// `P(Z > z)` for a standard normal `Z`.
fn normal_upper_tail(z: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, Normal};
    Normal::new(0.0, 1.0).map_or(f64::NAN, |n| n.sf(z))
}
