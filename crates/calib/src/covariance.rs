//! Covariance analysis: how well a rotation program calibrates, without any data.
//!
//! The program's true kinematics drive the same [`LinearModel`] and [`NormalisedFilter`] that
//! estimation uses, in covariance-only mode.

use crate::config::{ConfigError, RunConfig};
use crate::filter::NormalisedFilter;
use crate::layout::{NonInstrumentPriors, StateLayout};
use crate::model::LinearModel;
use nalgebra::DMatrix;
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
    let n_acc = (f.imu_rate_hz / f.accel_rate_hz).round() as usize;
    let n_tt = (f.imu_rate_hz / f.turntable_rate_hz).round() as usize;
    let n_steps = (kin.program.duration() * f.imu_rate_hz).floor() as usize;
    let mut model = LinearModel::new(layout, dt, &kin.earth_rate_enu(), config.gyro_psd());
    let mut filter = NormalisedFilter::new(&layout.prior_sigma())
        .map_err(|source| AnalysisError::Filter { t: 0.0, source })?;
    let p0 = vec![0.0; layout.n_instrument()];
    let f_enu = kin.specific_force_enu();
    let r_acc = nalgebra::Matrix3::identity()
        * config.measurement_variance(config.accel_psd(), f.accel_rate_hz);
    let var_angle = config.measurement_variance(config.angle_psd(), f.turntable_rate_hz);
    // A sampled (not averaged) reading sees the specific force of the last IMU step only.
    let sample_reading = config.noise.reading == crate::config::NoiseReading::Sample;
    let use_tt = layout.install.is_some();
    let mut pending;
    for j in 1..=n_steps {
        let t_mid = (j as f64 - 0.5) * dt;
        let s = kin.sample(t_mid);
        let input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
        };
        if sample_reading && j % n_acc == 0 {
            model.reset_accel();
        }
        model.substep(layout, &s.c_body_to_enu, &input, &p0);
        pending = true;
        let t = j as f64 * dt;
        let err = |source| AnalysisError::Filter { t, source };
        if j % n_acc == 0 {
            filter.predict(&mut model, true).map_err(err)?;
            pending = false;
            let h = model.accel_h(&f_enu);
            filter.update_covariance(&h, &r_acc).map_err(err)?;
            model.reset_accel();
        }
        if use_tt && j % n_tt == 0 {
            if pending {
                filter.predict(&mut model, true).map_err(err)?;
            }
            let s = kin.sample(t);
            let h = LinearModel::turntable_h(layout, &s.c_body_to_enu, &s.platform_rate_enu);
            let r = LinearModel::turntable_r(&gimbal_jacobian(&s.k), var_angle);
            filter.update_covariance(&h, &r).map_err(err)?;
        }
    }
    Ok(Posterior {
        names: layout.entries().iter().map(|e| e.name.clone()).collect(),
        units: layout.entries().iter().map(|e| e.unit).collect(),
        prior_sigma: layout.prior_sigma(),
        cov: filter.covariance(),
    })
}
