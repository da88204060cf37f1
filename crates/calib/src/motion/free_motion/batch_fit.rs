//! The coarse start's batch fit: a Gauss-Newton least-squares fit with priors of the paper's 21
//! parameters to the rests and the rotations between them.

use super::FreeMotionError;
use super::poses::{
    Increments, Pose, PoseStat, carry_records, pose_stat, poses_of, require_directions,
};
use crate::io::{ImuData, ResultParameter};
use crate::model::correction::Correction;
use crate::motion::rests::{Rest, TURN_SIGMA_RAD, Turn};
use nalgebra::{DMatrix, DVector, Vector3};
use sins_model::earth::EARTH_RATE;
use sins_model::terms::{ErrorModel, PaperPriors};
use std::ops::Range;

/// Settings of the coarse fit ([`coarse_fit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoarseSettings {
    /// Magnitude of gravity at the site (m/s^2).
    pub gravity_m_s2: f64,
    /// Priors of the paper's 21 parameters (SI; from a run configuration with
    /// [`crate::config::RunConfig::priors_si`]).
    pub priors: PaperPriors,
}

/// Noise floor of a rest's `|f|` (m/s^2), added in quadrature to the noise of its mean.
pub const ACCEL_FLOOR_M_S2: f64 = 5e-4;

/// Noise floor of a pose-to-pose gravity-direction mismatch (rad): 0.1 deg.
pub const DIRECTION_FLOOR_RAD: f64 = 0.1 * (std::f64::consts::PI / 180.0);

/// Summary of a least-squares fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StageFit {
    /// Number of data residuals (priors not counted).
    pub residuals: usize,
    /// Effective number of parameters the data determine.
    pub effective_parameters: f64,
    /// Reduced chi-square of the data residuals at the solution.
    pub reduced_chi2: f64,
    /// Gauss-Newton iterations run.
    pub iterations: usize,
}

/// The coarse fit's outcome ([`coarse_fit`]).
#[derive(Clone, Debug, PartialEq)]
pub struct CoarseFit {
    /// The paper's 21 parameters in the paper model's order (gyro bias, `Theta` row by row,
    /// accelerometer bias, `Gamma` in [`sins_model::terms::GAMMA_INDEX`] order), SI, with
    /// their sigmas.
    pub parameters: Vec<ResultParameter>,
    /// The fit's residuals, effective parameters and reduced chi-square.
    pub fit: StageFit,
}

/// A known turn with its records.
pub(super) struct TurnRecords<'a> {
    pub(super) turn: &'a Turn,
    pub(super) records: Range<usize>,
}

/// The poses and known turns of the coarse fit, refused where gravity is not a positive number,
/// the rests are out of order or a turn starts at the first record (whose interval is not
/// known).
pub(super) fn check_inputs<'a>(
    data: &ImuData,
    rests: &[Rest],
    turns: &'a [Turn],
    settings: &CoarseSettings,
) -> Result<(Vec<Pose>, Vec<TurnRecords<'a>>), FreeMotionError> {
    if !(settings.gravity_m_s2.is_finite() && settings.gravity_m_s2 > 0.0) {
        return Err(FreeMotionError::BadGravity(settings.gravity_m_s2));
    }
    let t: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    let poses = poses_of(&t, rests);
    for (i, pair) in poses.windows(2).enumerate() {
        if pair[1].records.start < pair[0].records.end {
            return Err(FreeMotionError::BadInterval(i + 2));
        }
    }
    let mut known = Vec::with_capacity(turns.len());
    for turn in turns {
        let records = turn.records(&t);
        if records.is_empty() {
            continue;
        }
        if records.start == 0 {
            return Err(FreeMotionError::BadTurn(turn.name.clone()));
        }
        known.push(TurnRecords { turn, records });
    }
    Ok((poses, known))
}

/// The coarse start of a hand-turned recording: the paper's 21 parameters fitted to the `rests`
/// (every one of them with two records or more: a caller with a hold-out leaves the held-out
/// ones out) and the known `turns` (those in the records). See the module documentation for
/// the method.
pub fn coarse_fit(
    data: &ImuData,
    rests: &[Rest],
    turns: &[Turn],
    settings: &CoarseSettings,
) -> Result<CoarseFit, FreeMotionError> {
    let (poses, turns) = check_inputs(data, rests, turns, settings)?;
    let inc = Increments::new(data);
    let stats: Vec<PoseStat> = poses.iter().map(|p| pose_stat(&inc, &p.records)).collect();
    if stats.len() < 3 {
        return Err(FreeMotionError::TooFewIntervals(stats.len()));
    }
    require_directions(stats.iter().map(|s| s.f), stats.len())?;
    let ctx = FitContext {
        inc: &inc,
        poses: &poses,
        stats: &stats,
        turns: &turns,
        g: settings.gravity_m_s2,
        rotations: Default::default(),
    };
    let specs = ErrorModel::paper(&settings.priors).params();
    let prior: Vec<f64> = specs.iter().map(|s| s.prior_sigma).collect();
    let joint = gauss_newton(prior.len(), &|x: &[f64]| {
        let cal = paper_correction(&scaled(x, &prior));
        let mut e = ctx.accel_residuals(&cal);
        e.extend(ctx.gyro_residuals(&cal));
        e
    });
    let p = scaled(joint.x.as_slice(), &prior);
    let parameters = specs
        .into_iter()
        .zip(&p)
        .enumerate()
        .map(|(k, (s, &value))| ResultParameter {
            name: s.name,
            value,
            sigma: Some(joint.cov[(k, k)].max(0.0).sqrt() * prior[k]),
            unit: s.unit.si_name().into(),
        })
        .collect();
    Ok(CoarseFit {
        parameters,
        fit: joint.fit,
    })
}

/// The correction of the paper's parameters `p` ([`Correction::paper`]); none (the raw data)
/// where a sensor matrix cannot be inverted, which the fit's priors keep it far from.
pub(super) fn paper_correction(p: &[f64]) -> Correction {
    Correction::paper(p)
        .unwrap_or_else(|_| Correction::paper(&[0.0; 21]).expect("the identity is invertible"))
}

/// Normalised parameters times their prior sigmas: SI values.
pub(super) fn scaled(x: &[f64], prior: &[f64]) -> Vec<f64> {
    x.iter().zip(prior).map(|(a, s)| a * s).collect()
}

/// What the residuals of the fit need.
pub(super) struct FitContext<'a> {
    pub(super) inc: &'a Increments,
    pub(super) poses: &'a [Pose],
    pub(super) stats: &'a [PoseStat],
    pub(super) turns: &'a [TurnRecords<'a>],
    pub(super) g: f64,
    /// The integrated rotations of the last gyro correction evaluated: a Jacobian's columns
    /// of the accelerometer parameters leave the gyro correction as it was, and its
    /// integrations over every motion (most of the fit's cost) are taken from here.
    pub(super) rotations: std::cell::RefCell<Option<GyroIntegrals>>,
}

/// What [`FitContext::gyro_residuals`] integrates, for one gyro correction.
pub(super) struct GyroIntegrals {
    /// The gyro correction's matrix and offset.
    key: (nalgebra::Matrix3<f64>, Vector3<f64>),
    /// `c_end_to_start` of the records from each rest to the next.
    carries: Vec<nalgebra::Matrix3<f64>>,
    /// The angle of each known turn.
    turns: Vec<f64>,
}

impl FitContext<'_> {
    /// `|f| - g` of every rest over its sigma.
    pub(super) fn accel_residuals(&self, cal: &Correction) -> Vec<f64> {
        self.stats
            .iter()
            .map(|s| {
                let sigma = s.sigma_f.hypot(ACCEL_FLOOR_M_S2);
                (cal.linear_accel(&s.f).norm() - self.g) / sigma
            })
            .collect()
    }

    /// Bias measurements (3 per rest), gravity-direction mismatches (3 per pair of consecutive
    /// rests), known turns (1 each); all divided by their sigma.
    pub(super) fn gyro_residuals(&self, cal: &Correction) -> Vec<f64> {
        let mut out = Vec::new();
        // The bias from every rest; the Earth rate is part of its noise.
        for s in self.stats {
            let sb = s.sigma_w.hypot(EARTH_RATE);
            let b = cal.gyro_offset;
            for a in 0..3 {
                out.push((b[a] + s.w[a]) / sb);
            }
        }
        // The calibrated gravity direction of every rest.
        let up: Vec<Vector3<f64>> = self
            .stats
            .iter()
            .map(|s| cal.linear_accel(&s.f).normalize())
            .collect();
        let key = (cal.gyro_matrix, cal.gyro_offset);
        let mut memo = self.rotations.borrow_mut();
        if memo.as_ref().is_none_or(|m| m.key != key) {
            *memo = Some(self.integrate(cal, key));
        }
        let integrals = memo.as_ref().expect("set above");
        for j in 1..self.stats.len() {
            let i = j - 1;
            let c = integrals.carries[i];
            let predicted = c.transpose() * up[i];
            let mismatch = up[j].cross(&predicted);
            let su = |k: usize| self.stats[k].sigma_f / self.g;
            let sigma = (su(i).powi(2) + su(j).powi(2) + DIRECTION_FLOOR_RAD.powi(2)).sqrt();
            out.extend(mismatch.iter().map(|m| m / sigma));
        }
        for (t, angle) in self.turns.iter().zip(&integrals.turns) {
            out.push((angle - t.turn.angle_rad) / TURN_SIGMA_RAD);
        }
        out
    }

    /// The gyro increments corrected by `cal` integrated over every motion between rests and
    /// about every known turn's axis.
    fn integrate(
        &self,
        cal: &Correction,
        key: (nalgebra::Matrix3<f64>, Vector3<f64>),
    ) -> GyroIntegrals {
        let carries = (1..self.stats.len())
            .map(|j| {
                let records = carry_records(&self.poses[j - 1], &self.poses[j]);
                self.inc.rotation(records, Some(cal))
            })
            .collect();
        let turns = self
            .turns
            .iter()
            .map(|t| {
                let a = t.turn.axis.normalize();
                self.inc.turn(t.records.clone(), &a, Some(cal))
            })
            .collect();
        GyroIntegrals {
            key,
            carries,
            turns,
        }
    }
}

/// Outcome of [`gauss_newton`]: normalised solution and covariance.
pub(super) struct GnSolution {
    pub(super) x: DVector<f64>,
    pub(super) cov: DMatrix<f64>,
    pub(super) fit: StageFit,
}

/// [`gauss_newton`] stops at a step shorter than this (the parameters are in prior sigmas).
/// Above the noise floor of the central-difference Jacobian: at 1e-9 the accelerometer stage of
/// the 324-s recording of docs/performance.md never got there (steps of 8.9e-7, then 1e-7 to
/// 3e-7 for all 30 iterations) and the joint stage ran three iterations past 8e-6 for steps of
/// 1e-9.
pub(super) const GN_STEP_TOLERANCE: f64 = 1e-6;

/// Minimise `|e(x)|^2 + |x|^2` (data residuals already divided by their sigma, `x` the
/// parameters over their prior sigma) by Gauss-Newton with central-difference Jacobians.
pub(super) fn gauss_newton(n: usize, residuals: &dyn Fn(&[f64]) -> Vec<f64>) -> GnSolution {
    let mut x = DVector::zeros(n);
    let h = 1e-5;
    let mut iterations = 0;
    let jacobian = |x: &DVector<f64>| -> (DVector<f64>, DMatrix<f64>) {
        let e = DVector::from_vec(residuals(x.as_slice()));
        let mut j = DMatrix::zeros(e.len(), n);
        for c in 0..n {
            let (mut xp, mut xm) = (x.clone(), x.clone());
            xp[c] += h;
            xm[c] -= h;
            let d = (DVector::from_vec(residuals(xp.as_slice()))
                - DVector::from_vec(residuals(xm.as_slice())))
                / (2.0 * h);
            j.set_column(c, &d);
        }
        (e, j)
    };
    let (mut e, mut j) = jacobian(&x);
    for _ in 0..30 {
        iterations += 1;
        let normal = j.transpose() * &j + DMatrix::identity(n, n);
        let rhs = -(j.transpose() * &e + &x);
        let dx = normal
            .cholesky()
            .map(|c| c.solve(&rhs))
            .unwrap_or_else(|| DVector::zeros(n));
        x += &dx;
        (e, j) = jacobian(&x);
        if dx.norm() < GN_STEP_TOLERANCE {
            break;
        }
    }
    let jtj = j.transpose() * &j;
    let plain = (jtj.clone() + DMatrix::identity(n, n))
        .try_inverse()
        .unwrap_or_else(|| DMatrix::identity(n, n));
    let n_eff = (&jtj * &plain).trace();
    let m = e.len();
    let dof = (m as f64 - n_eff).max(1.0);
    let reduced_chi2 = e.norm_squared() / dof;
    let scale = reduced_chi2.max(1.0);
    let cov = (jtj / scale + DMatrix::identity(n, n))
        .try_inverse()
        .unwrap_or_else(|| DMatrix::identity(n, n));
    GnSolution {
        x,
        cov,
        fit: StageFit {
            residuals: m,
            effective_parameters: n_eff,
            reduced_chi2,
            iterations,
        },
    }
}
