//! The measurements' white noise in one place: the levels a fit runs with, where they came
//! from, and the one rule that brings a level to a fit's innovations.
//!
//! A fit's levels are
//! - **configured**: the configuration's `[noise]` levels and
//!   `filter.motion_attitude_noise_deg` as given ([`NoiseSource::Configured`]);
//! - **measured from the rests** of a hand-turned recording: the configuration then holds the
//!   rests' scatter ([`crate::estimate::hand_turned::default_config`]), and each fit runs at
//!   [`MeasuredLevels`] (the specific-force level times a factor, the attitude noise of a
//!   motion), which [`crate::estimate::hand_turned::fit_measuring_noise`] brings to the fit's
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
use crate::estimate::hand_turned::{ScatterExcess, WhiteNoiseAtRest};
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
