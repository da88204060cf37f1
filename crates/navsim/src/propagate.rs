//! Covariance propagation of the navigation errors along a trajectory, the figure of merit rho
//! and the error budget.
//!
//! The full state is `[x_nav (7); c (n)]` with `c` constant (the paper's 21 instrument
//! parameters and those of the candidate terms a calibration estimated), so the transition over
//! a step has the block form `[Phi, Phi_c; 0, I]` and the instrument block of the covariance
//! never changes; the navigation block and the cross block follow
//!
//! ```text
//! P_nc' = Phi P_nc + Phi_c P_cc
//! P_nn' = Phi P_nn Phi^T + Phi P_nc Phi_c^T + Phi_c P_cn Phi^T + Phi_c P_cc Phi_c^T + Q_d
//! ```
//!
//! which [`crate::response`] propagates per unit instrument error (`P_nc = S P_cc`), once for
//! any number of instrument covariances.
//!
//! `Phi = exp(F_nav h)` and `Phi_c = (sum_k F_nav^(k-1) h^k / k!) F_instr` are Taylor series of
//! the block exponential, with `F` evaluated at the middle of the step (second order in `h`);
//! steps are `dt` long and are also ended at the trajectory's breakpoints (start and end of
//! legs, turns and roll phases), so that no jump of the body rate falls inside a step; the
//! covariance is recorded on the regular grid `k dt` and at the end;
//! `Q_d = (Phi Q Phi^T + Q) h / 2` (trapezoidal) with `Q = diag(0, 0, q_a, q_a, q_g, q_g, q_g)`,
//! `q` the white-noise power spectral densities.

use nalgebra::{DMatrix, Matrix3};
use serde::{Deserialize, Serialize};
use sins_model::earth::WGS84_A;

use crate::NavError;
use crate::instruments::{
    ACCEL_BIAS, ACCEL_GAMMA, DEG_PER_HOUR, GYRO_BIAS, GYRO_THETA, INSTRUMENT_NAMES,
    InstrumentCovariance, InstrumentModel, NamePolicy,
};
use crate::model::{DLAT, DLON, NAV_DIM, NAV_NAMES, NavMatrix};
use crate::response::{NavResponse, Part, initial_maps};
use crate::trajectory::Trajectory;

/// Gyro white noise of the paper, 0.1 deg/h (sigma of 1 Hz samples), as a noise density
/// `sigma * sqrt(1 s)` [rad/s/sqrt(Hz)]; the PSD is its square.
pub const PAPER_GYRO_NOISE_DENSITY: f64 = 0.1 * DEG_PER_HOUR;
/// Accelerometer white noise of the paper, 0.001 m/s^2 (sigma of 1 Hz samples), as a noise
/// density `sigma * sqrt(1 s)` [m/s^2/sqrt(Hz)].
pub const PAPER_ACCEL_NOISE_DENSITY: f64 = 0.001;

/// How the initial attitude errors are set.
#[derive(Clone, Debug, PartialEq)]
pub enum InitialAttitude {
    /// From a stationary self-alignment at the start point and heading, as a linear map of the
    /// instrument errors ([`crate::model::alignment_map`]), correlations included.
    Aligned,
    /// Levelled like [`InitialAttitude::Aligned`] (the tilt follows from the accelerometer
    /// errors), the heading given by an external reference without error (`beta_U = 0`): a unit
    /// whose gyros cannot find north (gyrocompassing needs gyro biases well below the
    /// horizontal Earth rate, 8.5 deg/h at 55.7 deg).
    Levelled,
    /// This attitude-error covariance (rad^2) (ENU), uncorrelated with the instruments.
    Explicit(Matrix3<f64>),
}

/// Options of the propagation.
#[derive(Clone, Debug, PartialEq)]
pub struct NavOptions {
    /// Propagation step \[s\].
    pub dt_s: f64,
    /// Earth rotation rate (rad/s) (0 switches Earth rotation off, for tests).
    pub earth_rate_rad_s: f64,
    /// Gyro white-noise density [rad/s/sqrt(Hz)] (0 = none).
    pub gyro_noise_density: f64,
    /// Accelerometer white-noise density [m/s^2/sqrt(Hz)] (0 = none).
    pub accel_noise_density: f64,
    /// Initial attitude errors.
    pub initial_attitude: InitialAttitude,
    /// Add the velocity error of an (impulsive) take-off from rest to the initial velocity with
    /// the aligned heading error: `dV0 = (V0 x beta0)` horizontally. Off by default (the flight
    /// starts at cruise speed with zero velocity error).
    pub takeoff_velocity_error: bool,
    /// Treatment of missing and unknown parameter names.
    pub names: NamePolicy,
    /// Order of the Taylor series of the step transition matrix.
    pub taylor_order: usize,
    /// The unit's temperature in flight (and at the alignment) less the reference of the
    /// calibration's thermal terms (K): what those terms act on (0: they do nothing).
    pub temperature_delta_k: f64,
}

impl Default for NavOptions {
    fn default() -> Self {
        Self {
            dt_s: 1.0,
            earth_rate_rad_s: sins_model::earth::EARTH_RATE,
            gyro_noise_density: PAPER_GYRO_NOISE_DENSITY,
            accel_noise_density: PAPER_ACCEL_NOISE_DENSITY,
            initial_attitude: InitialAttitude::Aligned,
            takeoff_velocity_error: false,
            names: NamePolicy::default(),
            taylor_order: 4,
            temperature_delta_k: 0.0,
        }
    }
}

impl NavOptions {
    pub(crate) fn check(&self) -> Result<(), NavError> {
        let bad =
            |field: &'static str, reason: String| Err(NavError::InvalidOption { field, reason });
        if !(self.dt_s > 0.0 && self.dt_s.is_finite()) {
            return bad("dt_s", format!("must be > 0, got {}", self.dt_s));
        }
        if !self.earth_rate_rad_s.is_finite() {
            return bad("earth_rate_rad_s", "must be finite".into());
        }
        if !(self.gyro_noise_density >= 0.0 && self.gyro_noise_density.is_finite()) {
            return bad(
                "gyro_noise_density",
                format!("must be >= 0, got {}", self.gyro_noise_density),
            );
        }
        if !(self.accel_noise_density >= 0.0 && self.accel_noise_density.is_finite()) {
            return bad(
                "accel_noise_density",
                format!("must be >= 0, got {}", self.accel_noise_density),
            );
        }
        if !self.temperature_delta_k.is_finite() {
            return bad("temperature_delta_k", "must be finite".into());
        }
        if self.taylor_order == 0 || self.taylor_order > 20 {
            return bad(
                "taylor_order",
                format!("must be in 1..=20, got {}", self.taylor_order),
            );
        }
        if let InitialAttitude::Explicit(p) = &self.initial_attitude
            && (p.iter().any(|x| !x.is_finite())
                || (p - p.transpose()).norm() > 1e-9 * p.norm()
                || p.diagonal().min() < 0.0)
        {
            return bad(
                "initial_attitude",
                "the covariance must be finite, symmetric, with a non-negative diagonal".into(),
            );
        }
        Ok(())
    }
}

/// Covariance of the navigation errors at one instant.
#[derive(Clone, Debug, PartialEq)]
pub struct NavSnapshot {
    /// Time \[s\].
    pub t: f64,
    /// True latitude \[rad\].
    pub latitude: f64,
    /// 7x7 covariance of `[dphi, dlambda, dV_E, dV_N, beta_E, beta_N, beta_U]` (SI).
    pub p_nav: NavMatrix,
}

impl NavSnapshot {
    /// `rho = a sqrt(var(dphi) + cos^2(phi) var(dlambda))` \[m\].
    pub fn rho_m(&self) -> f64 {
        let c = self.latitude.cos();
        WGS84_A
            * (self.p_nav[(DLAT, DLAT)] + c * c * self.p_nav[(DLON, DLON)])
                .max(0.0)
                .sqrt()
    }

    /// `a sigma(dphi)` \[m\].
    pub fn sigma_north_m(&self) -> f64 {
        WGS84_A * self.p_nav[(DLAT, DLAT)].max(0.0).sqrt()
    }

    /// `a cos(phi) sigma(dlambda)` \[m\].
    pub fn sigma_east_m(&self) -> f64 {
        WGS84_A * self.latitude.cos() * self.p_nav[(DLON, DLON)].max(0.0).sqrt()
    }
}

/// The figure of merit over time.
#[derive(Clone, Debug, PartialEq, Default, Serialize, Deserialize)]
pub struct RhoSeries {
    /// Time \[s\].
    pub t: Vec<f64>,
    /// `rho(t) = a sqrt(var(dlambda) cos^2(phi) + var(dphi))` \[m\].
    pub rho_m: Vec<f64>,
}

impl RhoSeries {
    /// rho at the end of the trajectory \[m\].
    pub fn final_rho_m(&self) -> f64 {
        self.rho_m.last().copied().unwrap_or(0.0)
    }

    /// rho at time `t` (linear interpolation, clamped) \[m\].
    pub fn at(&self, t: f64) -> f64 {
        if self.t.is_empty() {
            return 0.0;
        }
        let i = self.t.partition_point(|&x| x < t);
        if i == 0 {
            return self.rho_m[0];
        }
        if i >= self.t.len() {
            return *self.rho_m.last().unwrap();
        }
        let (t0, t1) = (self.t[i - 1], self.t[i]);
        let w = (t - t0) / (t1 - t0);
        self.rho_m[i - 1] * (1.0 - w) + self.rho_m[i] * w
    }
}

/// The full initial covariance of `[x_nav; c]` (7 + n, `c` the parameters of the instrument
/// model the covariance names, [`InstrumentModel::for_names`]; 28x28 in [`state_names`] order
/// for the paper's model): with alignment, `[M P M^T, M P; P M^T, P]` where `M` holds the
/// alignment map `A` in the attitude rows.
pub fn initial_covariance<T: Trajectory + ?Sized>(
    traj: &T,
    instruments: &InstrumentCovariance,
    opts: &NavOptions,
) -> Result<DMatrix<f64>, NavError> {
    opts.check()?;
    let (model, p_cc) = model_and_covariance(instruments, opts)?;
    let (m, p_w) = initial_maps(traj, &model, opts)?;
    let k = model.len();
    let p_nc = &m * &p_cc;
    let mut p = DMatrix::zeros(NAV_DIM + k, NAV_DIM + k);
    p.view_mut((0, 0), (NAV_DIM, NAV_DIM))
        .copy_from(&(&p_nc * m.transpose() + p_w));
    p.view_mut((0, NAV_DIM), (NAV_DIM, k)).copy_from(&p_nc);
    p.view_mut((NAV_DIM, 0), (k, NAV_DIM))
        .copy_from(&p_nc.transpose());
    p.view_mut((NAV_DIM, NAV_DIM), (k, k)).copy_from(&p_cc);
    Ok(p)
}

/// Names of the 28 states: [`NAV_NAMES`] then [`INSTRUMENT_NAMES`].
pub fn state_names() -> Vec<&'static str> {
    NAV_NAMES
        .iter()
        .chain(INSTRUMENT_NAMES.iter())
        .copied()
        .collect()
}

/// The instrument model of the parameters `instruments` names (the paper's and the candidate
/// terms among them) and the covariance in its order.
fn model_and_covariance(
    instruments: &InstrumentCovariance,
    opts: &NavOptions,
) -> Result<(InstrumentModel, DMatrix<f64>), NavError> {
    let model = InstrumentModel::for_names(instruments.names.iter().map(String::as_str));
    let p = instruments.in_model_order(&model, opts.names)?;
    Ok((model, p))
}

/// Propagate the navigation-error covariance along `traj` from the instrument covariance left by
/// a calibration; returns the navigation covariance at every step (and at `t = 0`). The
/// instrument errors are the paper's and those of every candidate term the covariance names
/// ([`InstrumentModel::for_names`]); the propagation is [`NavResponse`]'s.
pub fn propagate<T: Trajectory + ?Sized>(
    traj: &T,
    instruments: &InstrumentCovariance,
    opts: &NavOptions,
) -> Result<Vec<NavSnapshot>, NavError> {
    let (model, p) = model_and_covariance(instruments, opts)?;
    Ok(NavResponse::new(traj, &model, opts)?.snapshots(&p))
}

/// rho over time along `traj` (see [`propagate`]).
pub fn rho_series<T: Trajectory + ?Sized>(
    traj: &T,
    instruments: &InstrumentCovariance,
    opts: &NavOptions,
) -> Result<RhoSeries, NavError> {
    let (model, p) = model_and_covariance(instruments, opts)?;
    Ok(NavResponse::new(traj, &model, opts)?.rho_series(&p, Part::All))
}

/// rho of a list of snapshots.
pub fn to_series(snaps: &[NavSnapshot]) -> RhoSeries {
    RhoSeries {
        t: snaps.iter().map(|s| s.t).collect(),
        rho_m: snaps.iter().map(|s| s.rho_m()).collect(),
    }
}

/// A group of error sources for the budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BudgetGroup {
    /// Gyro biases `nu0` (3).
    GyroBias,
    /// Gyro scale-factor errors `Theta_ii` (3).
    ThetaDiagonal,
    /// Gyro off-diagonal terms `Theta_ij` (6).
    ThetaOffDiagonal,
    /// Accelerometer biases `df0` (3).
    AccelBias,
    /// Accelerometer scale-factor errors `Gamma_ii` (3).
    GammaDiagonal,
    /// Accelerometer off-diagonal terms `Gamma_ij` (3).
    GammaOffDiagonal,
    /// The initial (alignment) attitude errors alone, the instrument errors switched off in flight.
    AlignmentOnly,
    /// The sensor white noise alone.
    SensorNoiseOnly,
}

impl BudgetGroup {
    /// All groups, in table order.
    pub const ALL: [BudgetGroup; 8] = [
        BudgetGroup::GyroBias,
        BudgetGroup::ThetaDiagonal,
        BudgetGroup::ThetaOffDiagonal,
        BudgetGroup::AccelBias,
        BudgetGroup::GammaDiagonal,
        BudgetGroup::GammaOffDiagonal,
        BudgetGroup::AlignmentOnly,
        BudgetGroup::SensorNoiseOnly,
    ];

    /// Short label for tables.
    pub fn label(self) -> &'static str {
        match self {
            BudgetGroup::GyroBias => "gyro bias nu0",
            BudgetGroup::ThetaDiagonal => "gyro Theta diagonal",
            BudgetGroup::ThetaOffDiagonal => "gyro Theta off-diagonal",
            BudgetGroup::AccelBias => "accel bias df0",
            BudgetGroup::GammaDiagonal => "accel Gamma diagonal",
            BudgetGroup::GammaOffDiagonal => "accel Gamma off-diagonal",
            BudgetGroup::AlignmentOnly => "alignment only",
            BudgetGroup::SensorNoiseOnly => "sensor noise only",
        }
    }

    /// Instrument-state indices of an instrument group (empty for alignment and noise).
    pub fn instrument_indices(self) -> Vec<usize> {
        let diag = |base: usize| vec![base, base + 4, base + 8];
        match self {
            BudgetGroup::GyroBias => (GYRO_BIAS..GYRO_BIAS + 3).collect(),
            BudgetGroup::ThetaDiagonal => diag(GYRO_THETA),
            BudgetGroup::ThetaOffDiagonal => {
                [1, 2, 3, 5, 6, 7].iter().map(|k| GYRO_THETA + k).collect()
            }
            BudgetGroup::AccelBias => (ACCEL_BIAS..ACCEL_BIAS + 3).collect(),
            BudgetGroup::GammaDiagonal => vec![ACCEL_GAMMA, ACCEL_GAMMA + 2, ACCEL_GAMMA + 5],
            BudgetGroup::GammaOffDiagonal => {
                vec![ACCEL_GAMMA + 1, ACCEL_GAMMA + 3, ACCEL_GAMMA + 4]
            }
            BudgetGroup::AlignmentOnly | BudgetGroup::SensorNoiseOnly => vec![],
        }
    }
}

/// rho at the end of the trajectory for one group alone.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BudgetEntry {
    /// The group.
    pub group: BudgetGroup,
    /// rho with only this group \[m\].
    pub rho_m: f64,
}

/// rho at the end of the trajectory, total and per group.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorBudget {
    /// Time of the figures \[s\] (end of the trajectory).
    pub t_s: f64,
    /// rho with everything \[m\].
    pub total_m: f64,
    /// rho with each group alone \[m\].
    pub entries: Vec<BudgetEntry>,
}

impl ErrorBudget {
    /// Root-sum-square of the group figures \[m\]. It differs from `total_m` because the groups
    /// are not independent: the alignment errors are correlated with the instrument errors they
    /// come from, and [`BudgetGroup::AlignmentOnly`] counts them again.
    pub fn rss_m(&self) -> f64 {
        self.entries
            .iter()
            .map(|e| e.rho_m * e.rho_m)
            .sum::<f64>()
            .sqrt()
    }

    /// rho of a group.
    pub fn get(&self, group: BudgetGroup) -> Option<f64> {
        self.entries
            .iter()
            .find(|e| e.group == group)
            .map(|e| e.rho_m)
    }
}

/// rho at the end of `traj` with all errors and with each [`BudgetGroup`] alone.
///
/// An instrument group alone keeps its own block of the instrument covariance (correlations
/// within the group included) and zeroes the rest; the alignment errors are derived from what is
/// left, so they carry that group's effect on the alignment; no sensor noise. "Alignment only"
/// starts from the initial attitude covariance of all instruments (or the explicit one) with the
/// instrument errors switched off in flight and no noise. "Sensor noise only" has no instrument
/// errors and no initial errors.
pub fn error_budget<T: Trajectory + ?Sized>(
    traj: &T,
    instruments: &InstrumentCovariance,
    opts: &NavOptions,
) -> Result<ErrorBudget, NavError> {
    let (model, p) = model_and_covariance(instruments, opts)?;
    let r = NavResponse::new(traj, &model, opts)?;
    let last = r.points().len() - 1;
    let entries = BudgetGroup::ALL
        .into_iter()
        .map(|group| {
            let rho_m = match group {
                BudgetGroup::AlignmentOnly => r.rho_m(last, &p, Part::Alignment),
                BudgetGroup::SensorNoiseOnly => r.rho_m(last, &p, Part::Noise),
                _ => r.rho_m(
                    last,
                    &block(&p, &group.instrument_indices()),
                    Part::Instruments,
                ),
            };
            BudgetEntry { group, rho_m }
        })
        .collect();
    Ok(ErrorBudget {
        t_s: traj.duration_s(),
        total_m: r.rho_m(last, &p, Part::All),
        entries,
    })
}

/// The covariance `p` with everything outside the rows and columns `idx` zeroed: a group of
/// parameters alone, with the correlations within it.
pub fn block(p: &DMatrix<f64>, idx: &[usize]) -> DMatrix<f64> {
    let mut b = DMatrix::zeros(p.nrows(), p.ncols());
    for &i in idx {
        for &j in idx {
            b[(i, j)] = p[(i, j)];
        }
    }
    b
}
