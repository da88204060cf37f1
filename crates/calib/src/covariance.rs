//! Covariance analysis: how well a rotation program calibrates, without any data.
//!
//! The program's true kinematics drive the same [`LinearModel`] and [`NormalisedFilter`] that
//! estimation uses, in covariance-only mode.

use crate::config::{AttitudePrior, ConfigError, RunConfig};
use crate::engine::{
    MeasurementNoise, Schedule, angle_sample_guard, angle_sample_usable, measurement_instant,
};
use crate::filter::NormalisedFilter;
use crate::layout::{NonInstrumentPriors, StateLayout};
use crate::model::{AngleSample, LinearModel};
use nalgebra::{DMatrix, Vector3};
use sins_model::terms::{ErrorModel, SensorInput, Unit};
use turntable::gimbal::gimbal_jacobian;
use turntable::kinematics::{Kinematics, Mounting};

/// Errors of the analysis.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// Configuration problem.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The filter refused a step.
    #[error("Kalman filter at t = {t:.3} s: {source}")]
    Filter {
        /// Time of the failing step [s].
        t: f64,
        /// Cause.
        source: kalman::KalmanError,
    },
}

/// Posterior covariance of all states, with names and units.
#[derive(Clone, Debug)]
pub struct Posterior {
    /// State names (design notes' dotted names).
    pub names: Vec<String>,
    /// State units.
    pub units: Vec<Unit>,
    /// Prior sigma (SI).
    pub prior_sigma: Vec<f64>,
    /// Posterior covariance (SI).
    pub cov: DMatrix<f64>,
}

impl Posterior {
    /// Posterior sigma of a state by name (SI).
    pub fn sigma(&self, name: &str) -> Option<f64> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(self.cov[(i, i)].max(0.0).sqrt())
    }
}

/// The non-instrument priors of a configuration.
pub fn non_instrument_priors(config: &RunConfig) -> NonInstrumentPriors {
    NonInstrumentPriors {
        attitude: config.initial_attitude_sigma(),
        install: config.install_sigma(),
        tau: config.priors.tau_s,
        base: config.base_sigma(),
    }
}

/// The paper's layout for a configuration.
pub fn layout_for(config: &RunConfig, with_turntable: bool) -> StateLayout {
    StateLayout::new(
        ErrorModel::paper(&config.priors_si()),
        &non_instrument_priors(config),
        with_turntable,
        config.filter.estimate_base_misalignment,
    )
}

/// Run the covariance analysis of the configured program with the paper's model.
pub fn covariance_analysis(
    config: &RunConfig,
    with_turntable: bool,
) -> Result<Posterior, AnalysisError> {
    let layout = layout_for(config, with_turntable);
    covariance_analysis_with(config, &layout, &Mounting::default())
}

/// The prior covariance of all states (SI). `c0_body_to_enu` is the start attitude computed from
/// the program's start angles with the nominal mounting; with [`AttitudePrior::Installation`] the
/// attitude error is `beta_0 = C_0 delta_z + eps`, correlated with `delta_z` when that is a state
/// and carrying its variance when it is not (the installation misalignment is real either way).
pub fn initial_covariance(
    config: &RunConfig,
    layout: &StateLayout,
    c0_body_to_enu: &nalgebra::Matrix3<f64>,
) -> DMatrix<f64> {
    let sigma = layout.prior_sigma();
    let mut p = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
        sigma.len(),
        sigma.iter().map(|s| s * s),
    ));
    if config.filter.attitude_prior == AttitudePrior::Installation {
        let var_d = config.install_sigma().powi(2);
        let c = c0_body_to_enu;
        let cc = c * c.transpose() * var_d;
        for i in 0..3 {
            for j in 0..3 {
                p[(i, j)] += cc[(i, j)];
            }
        }
        if let Some(k) = layout.install {
            // cov(beta_0, delta_z) = C_0 P_delta.
            for i in 0..3 {
                for j in 0..3 {
                    p[(i, k + j)] = c[(i, j)] * var_d;
                    p[(k + j, i)] = c[(i, j)] * var_d;
                }
            }
        }
    }
    p
}

/// Run the covariance analysis for any layout and (nominal) mounting.
pub fn covariance_analysis_with(
    config: &RunConfig,
    layout: &StateLayout,
    mounting: &Mounting,
) -> Result<Posterior, AnalysisError> {
    let program = config.program()?;
    let site = config.site();
    let kin = Kinematics::new(program, *mounting, site);
    let f = &config.filter;
    let dt = 1.0 / f.imu_rate_hz;
    let schedule = Schedule::new(config);
    let n_steps = (kin.program.duration() * f.imu_rate_hz).floor() as usize;
    let mut model = LinearModel::new(layout, dt, &kin.earth_rate_enu(), config.gyro_psd());
    let c0 = kin.sample(0.0).c_body_to_enu;
    let mut filter = NormalisedFilter::with_covariance(&initial_covariance(config, layout, &c0))
        .map_err(|source| AnalysisError::Filter { t: 0.0, source })?;
    let p0 = vec![0.0; layout.n_instrument()];
    let f_enu = kin.specific_force_enu();
    let use_tt = layout.install.is_some();
    // Angle records are taken to come at the IMU rate, one per step, so that a window of N steps
    // averages N records: the variance of one record is the PSD times the record rate.
    let noise = MeasurementNoise {
        accel_psd: config.accel_psd(),
        angle_var_per_record: use_tt.then(|| config.angle_psd() * f.imu_rate_hz),
    };
    let zero = Vector3::zeros();
    for j in 1..=n_steps {
        let s = kin.sample((j as f64 - 0.5) * dt);
        let input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
        };
        let in_acc = schedule.in_accel_window(j).then_some(&zero);
        model.substep(layout, &s.c_body_to_enu, &input, &p0, in_acc);
        let t = j as f64 * dt;
        if use_tt && schedule.in_turntable_window(j) {
            let s = kin.sample(t);
            let (guard, threshold) = angle_sample_guard(
                filter.sigma(layout.tau.expect("turntable layout")),
                dt,
                dt,
                config.angle_psd(),
                schedule.turntable_window as f64 * dt,
            );
            let usable = angle_sample_usable(
                &kin.sample(t - guard).omega_body,
                &s.omega_body,
                &kin.sample(t + guard).omega_body,
                guard,
                threshold,
            );
            if usable {
                model.add_angle_sample(&AngleSample {
                    y: zero,
                    c_body_to_enu: s.c_body_to_enu,
                    platform_rate_enu: s.platform_rate_enu,
                    gimbal_jacobian: gimbal_jacobian(&s.k),
                    records: &[(j, 1.0)],
                });
            }
        }
        measurement_instant(
            &mut filter,
            &mut model,
            layout,
            &schedule,
            j,
            &f_enu,
            &noise,
            true,
            false,
        )
        .map_err(|source| AnalysisError::Filter { t, source })?;
    }
    Ok(Posterior {
        names: layout.entries().iter().map(|e| e.name.clone()).collect(),
        units: layout.entries().iter().map(|e| e.unit).collect(),
        prior_sigma: layout.prior_sigma(),
        cov: filter.covariance(),
    })
}
