//! The least-squares baseline: the accelerometer parameters from the rests' mean specific
//! forces alone, judged on the same held-out rests as the filter.

use super::FreeMotionError;
use super::batch_fit::ACCEL_FLOOR_M_S2;
use super::batch_fit::{gauss_newton, paper_correction};
use super::figures::PoseResidual;
use super::poses::{Increments, pose_stat, poses_of, require_directions};
use crate::io::ImuData;
use crate::model::correction::Correction;
use crate::motion::rests::Rest;
use nalgebra::{DMatrix, DVector, Vector3};
use sins_model::terms::{ErrorModel, PaperPriors};

/// Index of the accelerometer bias in the paper's 21 parameters (gyro bias 3, `Theta` 9 before
/// it); `Gamma`'s six follow it.
pub(super) const ACCEL_BIAS_INDEX: usize = 12;

/// The least-squares baseline's parameters: it is fitted only to more rests than these.
pub const BASELINE_PARAMETERS: usize = 9;

/// The simplest calibration of a recording of rests, what every estimate of this crate must
/// beat: the accelerometers' nine parameters of the paper's model (biases and the
/// lower-triangular `Gamma`: scale factors and non-orthogonality) fitted by plain least squares
/// to `|f| = g` at the means of `rests` (every one with two records or more; a caller with a
/// hold-out passes the fitted ones), every rest weighted alike and no prior; where the poses
/// leave directions free (axis-aligned poses), the minimum-norm solution. The gyros are left
/// as they are (zero parameters). `Err` for [`BASELINE_PARAMETERS`] rests or fewer (the fit
/// would pass through every one of them), or directions too few ([`super::check_poses`]).
pub fn accel_baseline(
    data: &ImuData,
    rests: &[Rest],
    gravity_m_s2: f64,
) -> Result<AccelBaseline, FreeMotionError> {
    let t: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    let inc = Increments::new(data);
    let means: Vec<Vector3<f64>> = poses_of(&t, rests)
        .iter()
        .map(|p| pose_stat(&inc, &p.records).f)
        .collect();
    accel_baseline_of_means(&means, gravity_m_s2)
}

/// [`super::accel_baseline`] of the rests' mean specific forces `means` (raw, m/s^2; what
/// [`super::check_poses`] returns). A consumer unit's per-cent errors converge from zero in a few
/// Gauss-Newton iterations.
pub fn accel_baseline_of_means(
    means: &[Vector3<f64>],
    gravity_m_s2: f64,
) -> Result<AccelBaseline, FreeMotionError> {
    if !(gravity_m_s2.is_finite() && gravity_m_s2 > 0.0) {
        return Err(FreeMotionError::BadGravity(gravity_m_s2));
    }
    if means.len() <= BASELINE_PARAMETERS {
        return Err(FreeMotionError::TooFewForBaseline(means.len()));
    }
    require_directions(means.iter().copied(), means.len())?;
    let paper = |x: &[f64]| {
        let mut p = [0.0; 21];
        p[ACCEL_BIAS_INDEX..].copy_from_slice(x);
        paper_correction(&p)
    };
    let residuals = |x: &[f64]| -> DVector<f64> {
        let cal = paper(x);
        DVector::from_iterator(
            means.len(),
            means
                .iter()
                .map(|f| cal.linear_accel(f).norm() - gravity_m_s2),
        )
    };
    let (x, rank) = minimum_norm_gauss_newton(BASELINE_PARAMETERS, &residuals);
    let mut parameters = [0.0; 9];
    parameters.copy_from_slice(x.as_slice());
    Ok(AccelBaseline {
        parameters,
        correction: paper(x.as_slice()),
        rank,
    })
}

/// The rests' `|f| = g` residuals of the accelerometers' nine parameters fitted at their
/// `priors` (the paper model's, as the filter has them): each rest's mean `means[i]` with the
/// sigma `sigmas_m_s2[i]` (its white noise, with [`ACCEL_FLOOR_M_S2`]), the prior as a
/// pseudo-measurement. Unlike [`super::accel_baseline`]'s plain fit, it does not wander along what
/// near-axis-aligned poses barely determine. Returns the residuals (m/s^2) and the effective
/// number of parameters the rests determined (the fit's hat-matrix trace).
pub fn accel_fit_at_priors(
    means: &[Vector3<f64>],
    sigmas_m_s2: &[f64],
    gravity_m_s2: f64,
    priors: &PaperPriors,
) -> (Vec<f64>, f64) {
    let specs = ErrorModel::paper(priors).params();
    let prior: Vec<f64> = specs[ACCEL_BIAS_INDEX..]
        .iter()
        .map(|s| s.prior_sigma)
        .collect();
    let paper = |x: &[f64]| {
        let mut p = [0.0; 21];
        for (k, (v, s)) in x.iter().zip(&prior).enumerate() {
            p[ACCEL_BIAS_INDEX + k] = v * s;
        }
        paper_correction(&p)
    };
    let sigma = |i: usize| sigmas_m_s2[i].hypot(ACCEL_FLOOR_M_S2);
    let fit = gauss_newton(BASELINE_PARAMETERS, &|x: &[f64]| {
        let cal = paper(x);
        (0..means.len())
            .map(|i| (cal.linear_accel(&means[i]).norm() - gravity_m_s2) / sigma(i))
            .collect()
    });
    let cal = paper(fit.x.as_slice());
    let residuals = means
        .iter()
        .map(|f| cal.linear_accel(f).norm() - gravity_m_s2)
        .collect();
    (residuals, fit.fit.effective_parameters)
}

/// Singular values of the baseline's Jacobian below this share of the largest are taken as
/// zero: directions the poses do not determine (axis-aligned poses leave `Gamma`'s
/// off-diagonal terms out of `|f|` to first order).
pub(super) const BASELINE_RANK_TOLERANCE: f64 = 1e-8;

/// Least squares of `residuals` from zero by Gauss-Newton steps through the pseudo-inverse
/// (singular values below [`BASELINE_RANK_TOLERANCE`] of the largest dropped), each step
/// halved until the sum of squares falls: the minimum-norm solution where the data leave
/// directions free, rather than a wander along them. Returns the solution and the rank of the
/// Jacobian there.
pub(super) fn minimum_norm_gauss_newton(
    n: usize,
    residuals: &dyn Fn(&[f64]) -> DVector<f64>,
) -> (DVector<f64>, usize) {
    let jacobian = |x: &DVector<f64>| {
        let e = residuals(x.as_slice());
        let mut j = DMatrix::zeros(e.len(), n);
        for c in 0..n {
            let h = 1e-7 * x[c].abs().max(1e-2);
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[c] += h;
            xm[c] -= h;
            j.set_column(
                c,
                &((residuals(xp.as_slice()) - residuals(xm.as_slice())) / (2.0 * h)),
            );
        }
        (e, j)
    };
    let mut x = DVector::zeros(n);
    let mut rank = 0;
    for _ in 0..50 {
        let (e, j) = jacobian(&x);
        let svd = j.svd(true, true);
        let largest = svd.singular_values.max();
        rank = svd
            .singular_values
            .iter()
            .filter(|&&s| s > BASELINE_RANK_TOLERANCE * largest)
            .count();
        let Ok(step) = svd.solve(&(-&e), BASELINE_RANK_TOLERANCE * largest) else {
            break;
        };
        let cost = e.norm_squared();
        let mut scale = 1.0;
        let mut moved = false;
        for _ in 0..30 {
            let trial = &x + &step * scale;
            if residuals(trial.as_slice()).norm_squared() < cost {
                x = trial;
                moved = true;
                break;
            }
            scale *= 0.5;
        }
        if !moved || (&step * scale).norm() < 1e-12 {
            break;
        }
    }
    (x, rank)
}

/// The least-squares `|f| = g` fit of [`super::accel_baseline`].
#[derive(Clone, Debug)]
pub struct AccelBaseline {
    /// The accelerometer bias (m/s^2) and `Gamma` (in [`sins_model::terms::GAMMA_INDEX`]
    /// order), the paper's parameters 13-21.
    pub parameters: [f64; 9],
    /// The correction they make ([`Correction::paper`], the gyros left as they are).
    pub correction: Correction,
    /// How many of the nine the rests determine (the rank of the fit's Jacobian): the others
    /// stay at zero (the minimum-norm solution).
    pub rank: usize,
}

impl AccelBaseline {
    /// RMS of `|f| - g` over the rests of `poses` that `held` selects, each rest's raw mean
    /// corrected by the baseline (its correction is affine in `f`: the corrected mean is the
    /// mean corrected); `None` where none is selected.
    pub fn static_rms_m_s2(
        &self,
        poses: &[PoseResidual],
        held: bool,
        gravity_m_s2: f64,
    ) -> Option<f64> {
        let e: Vec<f64> = poses
            .iter()
            .filter(|p| p.held_out == held)
            .map(|p| self.correction.linear_accel(&p.raw_mean_f_m_s2).norm() - gravity_m_s2)
            .collect();
        (!e.is_empty()).then(|| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt())
    }
}
