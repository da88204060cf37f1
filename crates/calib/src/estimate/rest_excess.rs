//! The error a recording's rests share beyond their white noise ("the rests' excess"): measured
//! from the fitted rests' `|f| = g` residuals, reported, and weighed where asked or, without a
//! configuration, where the rests show it (docs/real-data.md, "Against the least-squares
//! baseline").

use super::noise::WhiteNoiseAtRest;
use crate::config::RunConfig;
use crate::io::source::ImuSource;
use crate::motion::rests::Rest;
use crate::motion::stamps::StampCounts;

/// The error the specific-force windows of one rest share (m/s^2, `filter.rest_error_m_s2`),
/// measured from the rests fitted in `config`'s hold-out: the `|f| = g` fit of the
/// accelerometers' nine parameters at `config`'s priors
/// ([`crate::motion::free_motion::accel_fit_at_priors`]) leaves residuals `e_i`; each rest's
/// mean has the white noise `sigma^2 / T_i` of its `T_i` seconds (`at_rest`'s 1-s level); what
/// the residuals scatter beyond that is the shared error,
/// `sum e_i^2 / (n - r) - mean(sigma^2 / T_i)` with `r` the parameters the rests determine
/// (the fit's effective number, at most nine; a variance-components estimate; 0 where the
/// noise explains it all), with its degrees of freedom `n - r`. `None` where the rests cannot
/// tell it: fewer than [`REST_ERROR_MIN_DOF`] degrees of freedom, a rest of fewer than two
/// records.
pub fn rest_error_m_s2(
    config: &RunConfig,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    at_rest: &WhiteNoiseAtRest,
) -> Result<Option<(f64, f64)>, crate::estimate::EstimateError> {
    Ok(rest_excess(config, imu, rests, at_rest)?.map(|e| (e.m_s2, e.dof)))
}

/// What the fitted rests' `|f| = g` residuals scatter beyond their white noise
/// ([`rest_error_m_s2`]), with its degrees of freedom and how likely so large a scatter is
/// from the white noise alone.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestExcess {
    /// The shared error (m/s^2, one sigma per axis; 0 where the noise explains it all).
    pub m_s2: f64,
    /// Degrees of freedom: the fitted rests less the parameters they determine.
    pub dof: f64,
    /// The chance of a scatter at least this large without a shared error: the residuals'
    /// squares, each over its rest mean's white-noise variance, summed and taken as
    /// chi-square with `dof` degrees of freedom.
    pub p_value: f64,
}

/// Fewest degrees of freedom from which a recording of rests without a configuration weighs
/// its rests' excess unasked: its variance is then known to `sqrt(2 / 10)`, 45 %. Set before
/// any run. With the 1 % test alone (tried after: `tests/tests/baseline.rs`, seeds
/// 5000-5059) simulated recordings with an error shared by each rest gained (58 to 60 of 60
/// weighed, every grade's pool better than the least-squares baseline, where this bound
/// leaves 10 of 60 unweighed and the consumer pool 7 % worse), but the 13 Ferraris rests
/// without a hold-out (4 degrees of freedom) then weighed an excess that took their whole
/// scatter: the innovations 0.19 times the rests' noise and `diagnose --free-motion --holdout
/// 2` refusing the asymmetry it accepts (held-out -1.3 nats).
pub const REST_ERROR_UNASKED_MIN_DOF: f64 = 10.0;

/// The level below which the excess's p-value makes it weighed unasked.
pub const REST_ERROR_UNASKED_LEVEL: f64 = 0.01;

impl RestExcess {
    /// Whether a calibration whose noise is measured weighs this excess without being asked
    /// (`calibrate --free-motion` and `diagnose --free-motion` without `--rest-error`): at
    /// least [`REST_ERROR_UNASKED_MIN_DOF`] degrees of freedom and a p-value below
    /// [`REST_ERROR_UNASKED_LEVEL`]. The filter takes each window as independent; a rest's
    /// windows that share an error then outweigh the other rests by their number, and on the
    /// shipped Xsens recording (p = 1e-9 over 20 degrees of freedom) the held-out `|f| - g`
    /// was 1.08 times the least-squares baseline's, 1.04 weighed (docs/real-data.md).
    pub fn weighed_unasked(&self) -> bool {
        self.m_s2 > 0.0
            && self.dof >= REST_ERROR_UNASKED_MIN_DOF
            && self.p_value < REST_ERROR_UNASKED_LEVEL
    }
}

/// Weigh the rests' excess in `config` (`filter.rest_error_m_s2`) where a recording without a
/// configuration shows it ([`RestExcess::weighed_unasked`]), measured on the rests the fit
/// uses (every `holdout`-th held out): what `calibrate --free-motion` and `diagnose
/// --free-motion` do without `--rest-error`. Nothing where `config` weighs an error already.
/// Returns the excess weighed.
pub fn weigh_rest_excess_unasked(
    config: &mut RunConfig,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    at_rest: &WhiteNoiseAtRest,
    holdout: Option<usize>,
) -> Result<Option<RestExcess>, crate::estimate::EstimateError> {
    if config.filter.rest_error_m_s2 > 0.0 {
        return Ok(None);
    }
    let mut measuring = config.clone();
    measuring.filter.hold_out_every = holdout;
    let excess = rest_excess(&measuring, imu, rests, at_rest)?.filter(RestExcess::weighed_unasked);
    if let Some(e) = excess {
        config.filter.rest_error_m_s2 = e.m_s2;
    }
    Ok(excess)
}

/// [`rest_error_m_s2`] with its p-value ([`RestExcess`]).
pub fn rest_excess(
    config: &RunConfig,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    at_rest: &WhiteNoiseAtRest,
) -> Result<Option<RestExcess>, crate::estimate::EstimateError> {
    use crate::motion::free_motion::{BASELINE_PARAMETERS, accel_fit_at_priors, check_poses};
    let holdout = config.filter.hold_out_every;
    let fitted: Vec<Rest> = rests
        .iter()
        .enumerate()
        .filter(|(i, _)| !crate::motion::rests::held_out(*i, holdout))
        .map(|(_, r)| *r)
        .collect();
    if fitted.len() <= BASELINE_PARAMETERS {
        return Ok(None);
    }
    let times = fitted.iter().flat_map(|r| [r.t0, r.t1]);
    let stamps = StampCounts::read(imu, times, [], f64::NAN)?;
    let file = imu.file().to_string();
    let refuse =
        |e: crate::motion::free_motion::FreeMotionError| crate::estimate::EstimateError::Rests {
            file: file.clone(),
            source: crate::motion::rests::RestError::Evaluation(e.to_string()),
        };
    let means = check_poses(imu, &stamps, &fitted, None).map_err(refuse)?;
    if means.len() != fitted.len() {
        // A rest of fewer than two records: its duration is not its mean's.
        return Ok(None);
    }
    let g = config.site().normal_gravity();
    let white: Vec<f64> = fitted
        .iter()
        .map(|r| at_rest.accel_m_s2 / (r.t1 - r.t0).max(f64::MIN_POSITIVE).sqrt())
        .collect();
    let (residuals, determined) = accel_fit_at_priors(&means, &white, g, &config.priors_si());
    let n = means.len() as f64;
    let sum_e2: f64 = residuals.iter().map(|e| e * e).sum();
    let mean_white = white.iter().map(|w| w * w).sum::<f64>() / n;
    let dof = n - determined;
    if dof < REST_ERROR_MIN_DOF {
        return Ok(None);
    }
    let shared = sum_e2 / dof - mean_white;
    let p_value = {
        use statrs::distribution::{ChiSquared, ContinuousCDF};
        let weighed: f64 = residuals
            .iter()
            .zip(&white)
            .map(|(e, w)| (e / w).powi(2))
            .sum();
        ChiSquared::new(dof).map_or(f64::NAN, |d| d.sf(weighed))
    };
    Ok(Some(RestExcess {
        m_s2: shared.max(0.0).sqrt(),
        dof,
        p_value,
    }))
}

/// Fewest degrees of freedom (fitted rests less the parameters they determine) from which
/// [`rest_error_m_s2`] measures the shared error: one, the least a variance needs. Its
/// precision is the user's to judge from the degrees of freedom the report gives with it
/// (`sqrt(2 / dof)` relative on the variance). Without a configuration it is weighed unasked
/// where significant over enough degrees of freedom ([`RestExcess::weighed_unasked`]).
pub const REST_ERROR_MIN_DOF: f64 = 1.0;
