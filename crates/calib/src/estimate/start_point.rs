//! Where the passes start: the prior about the start attitude, and the first linearisation point.

use super::{EstimateError, Motion, Nominal, Scan, SitePriors};
use crate::config::{AttitudePrior, RunConfig};
use crate::model::engine::prior_filter;
use crate::model::layout::{StateLayout, initial_covariance};
use crate::motion::align::{DirectionErrors, aligned_prior, fit_mounting};
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::attitude::{exp_so3, log_so3};
use turntable::gimbal::c_platform_to_base;

/// The start attitude the prior is about, and the prior covariance of all states. With the
/// turntable angles (or the `independent` attitude prior of the paper's analysis) the start
/// attitude is the program's with the nominal mounting (`c_nominal`) and its error is tied to the
/// installation misalignment ([`initial_covariance`]). Without them it comes from the
/// alignment to the program's rotations where the program turns about two axes
/// ([`crate::motion::align`]), with the error tied to the gyro parameters.
pub(super) fn start_prior(
    config: &RunConfig,
    plan: &SitePriors,
    layout: &StateLayout,
    scan: &Scan,
    motion: &Motion,
    install_hat: &Vector3<f64>,
) -> (Matrix3<f64>, DMatrix<f64>) {
    let program = match motion {
        Motion::Program(program) => program,
        Motion::Rests { align, .. } => {
            let p = initial_covariance(config, layout, &align.c_start);
            let mut p = crate::motion::rests::rest_covariance(&p, align);
            crate::model::layout::copy_start_attitude(&mut p, layout);
            return (align.c_start, p);
        }
    };
    let dt = 1.0 / config.filter.imu_rate_hz;
    let (k0, _) = program.state(scan.span.0 - dt - scan.program_start);
    let c_nominal = c_platform_to_base(&k0);
    // The start attitude error is tied to the installation error as a perturbation of the
    // mounting about its linearisation point: C_true = C_p exp(dz_hat) exp(d) gives
    // beta_0 = C_p exp(dz_hat) d + eps, so the correlation is with the attitude of that mounting,
    // not the nominal one (the two differ by dz_hat x d, 1e-3 rad for degree-level mountings,
    // six times the sigma of eps; with the nominal one a static run's installation heading came
    // out 6 sigma off).
    let c_linearised = c_nominal * exp_so3(install_hat);
    let nominal = || (c_nominal, initial_covariance(config, layout, &c_linearised));
    if layout.install.is_some() || config.filter.attitude_prior == AttitudePrior::Independent {
        return nominal();
    }
    let start = scan.program_start;
    aligned_prior(
        config,
        &plan.site,
        layout,
        &scan.bins,
        program,
        start,
        scan.span.0 - dt,
    )
    .unwrap_or_else(nominal)
}

/// The point the first pass starts from. With the turntable angles, the mounting fitted to the
/// program's directions ([`fit_mounting`]: levelling where the platform rests, the rotation axes
/// where it turns), so that the first pass does not linearise about a start attitude and an
/// installation misalignment that are degrees off (their products with the other errors misled
/// the filter: on a static run it became sure of an installation misalignment that was 1.5 deg
/// off). Without them the start prior itself comes from the program ([`start_prior`]).
pub(super) fn first_linearisation_point(
    config: &RunConfig,
    plan: &SitePriors,
    layout: &StateLayout,
    scan: &Scan,
    motion: &Motion,
) -> Option<Nominal> {
    let (Some(k), Motion::Program(program)) = (layout.install, motion) else {
        return None;
    };
    let pri = plan.priors;
    let errors = DirectionErrors {
        gyro_bias: pri.gyro_bias,
        gyro_matrix: pri.gyro_scale.hypot(pri.gyro_misalignment),
        accel_bias: pri.accel_bias,
        accel_matrix: pri.accel_scale.hypot(pri.accel_misalignment),
        mounting: config.install_sigma(),
    };
    let start = scan.program_start;
    let m = fit_mounting(&scan.bins, program, &plan.site, start, &errors)?;
    let dt = 1.0 / config.filter.imu_rate_hz;
    let (k0, _) = program.state(scan.span.0 - dt - start);
    let mut totals = vec![0.0; layout.dim()];
    totals[k..k + 3].copy_from_slice(log_so3(&m).as_slice());
    Some(Nominal {
        totals,
        c_start: c_platform_to_base(&k0) * m,
    })
}

/// The filter at the start of a pass: the prior covariance about the program's start attitude
/// (aligned or from the installation), the prior means of the errors of the linearisation
/// point `totals`, and the start attitude (the program's with the nominal mounting, or the
/// estimate of the pass before), which it returns with the filter.
pub(super) fn start_filter(
    config: &RunConfig,
    plan: &SitePriors,
    layout: &StateLayout,
    scan: &Scan,
    motion: &Motion,
    nominal: Option<&Nominal>,
    totals: &[f64],
) -> Result<(kalman::KalmanFilter, Matrix3<f64>), EstimateError> {
    let install_hat = layout.install.map_or(Vector3::zeros(), |k| {
        Vector3::new(totals[k], totals[k + 1], totals[k + 2])
    });
    let (c_program, p0) = start_prior(config, plan, layout, scan, motion, &install_hat);
    let mut filter = prior_filter(&p0).map_err(|source| EstimateError::Filter {
        t: scan.span.0,
        line: 0,
        source,
    })?;
    // The prior means are zero (or a recording's coarse start): as errors of the nominal values
    // they are the prior mean less the nominal value.
    let prior_mean = |k: usize| match motion {
        Motion::Rests {
            coarse: Some(c), ..
        } => c.get(k - StateLayout::INSTRUMENT).copied().unwrap_or(0.0),
        _ => 0.0,
    };
    for (k, v) in totals.iter().enumerate().skip(StateLayout::INSTRUMENT) {
        filter.set_state(k, prior_mean(k) - v);
    }
    // The start attitude: the program's with the nominal mounting, or the estimate of the pass
    // before. The prior is about the program's start attitude, so relative to the estimate the
    // start attitude error (and its copy) has the prior mean `log(C_program C_start^T)`.
    let c0 = nominal.map_or(c_program, |n| n.c_start);
    let beta_prior = log_so3(&(c_program * c0.transpose()));
    for k in 0..3 {
        filter.set_state(k, beta_prior[k]);
        if let Some(s) = layout.start_attitude {
            filter.set_state(s + k, beta_prior[k]);
        }
    }
    Ok((filter, c0))
}
