//! Covariance analysis: how well a rotation program calibrates, without any data.
//!
//! The program's true kinematics drive the same [`LinearModel`] and [`KalmanFilter`] that
//! estimation uses, in covariance-only mode.
//!
//! [`KalmanFilter`]: kalman::KalmanFilter

use crate::config::{AttitudePrior, ConfigError, RunConfig};
use crate::model::engine::{Engine, MeasurementNoise, RateChanges, Schedule, prior_filter};
use crate::model::extension::ModelExtension;
use crate::model::layout::StateLayout;
pub use crate::model::layout::{
    initial_covariance, layout_for, layout_with, non_instrument_priors,
};
use crate::model::{AngleSample, LinearModel};
use crate::motion::align::{BinsByIndex, aligned_prior_by, ideal_bin, ideal_bin_count};
use nalgebra::{DMatrix, Vector3};
use sins_model::terms::{SensorInput, Unit};
use turntable::gimbal::gimbal_jacobian;
use turntable::kinematics::{Kinematics, Mounting};

/// The most IMU steps a covariance analysis runs (duration times `filter.imu_rate_hz`): 1e8,
/// ten days of program at 100 Hz with room to spare. Each step propagates the full covariance
/// (about a microsecond at 28 states), so the bound keeps an analysis under a few minutes;
/// longer ones are refused before anything is allocated.
pub const MAX_ANALYSIS_STEPS: f64 = 1e8;

/// Errors of the analysis.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// Configuration problem.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The program at the configured rate needs more than [`MAX_ANALYSIS_STEPS`] steps.
    #[error(
        "{origin}: a program of {duration_s} s at filter.imu_rate_hz = {rate_hz} Hz needs \
         {steps:.3e} IMU steps: expected at most {max:.0e} (the covariance analysis steps at the \
         IMU rate); shorten the program or lower filter.imu_rate_hz",
        max = MAX_ANALYSIS_STEPS
    )]
    TooManySteps {
        /// The program's origin (file, or `<inline program>`).
        origin: String,
        /// Program duration (s).
        duration_s: f64,
        /// IMU rate (Hz).
        rate_hz: f64,
        /// Steps it would take.
        steps: f64,
    },
    /// The filter refused a step.
    #[error("Kalman filter at t = {t:.3} s: {source}")]
    Filter {
        /// Time of the failing step (s).
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
    /// `ln det` of the covariance of every measurement the analysis took (the prior and the
    /// noise model included; `NaN` where the posterior did not come from an analysis): what
    /// [`crate::extend::drift_visibility`] compares between two noise models.
    pub log_det_data: f64,
}

impl Posterior {
    /// The posterior of a fit's estimate (no analysis behind it: `log_det_data` is `NaN`).
    pub fn of_estimate(est: &crate::estimate::Estimate) -> Self {
        Self {
            names: est.names.clone(),
            units: est.units.clone(),
            prior_sigma: est.prior_sigma.clone(),
            cov: est.cov.clone(),
            log_det_data: f64::NAN,
        }
    }

    /// Posterior sigma of a state by name (SI).
    pub fn sigma(&self, name: &str) -> Option<f64> {
        let i = self.index(name)?;
        Some(self.cov[(i, i)].max(0.0).sqrt())
    }

    /// Index of a state by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Posterior sigma over prior sigma of a state by name.
    pub fn sigma_ratio(&self, name: &str) -> Option<f64> {
        let i = self.index(name)?;
        Some(self.sigma(name)? / self.prior_sigma[i])
    }

    /// Posterior correlation of two states by name.
    pub fn correlation(&self, a: &str, b: &str) -> Option<f64> {
        let (i, j) = (self.index(a)?, self.index(b)?);
        let d = (self.cov[(i, i)] * self.cov[(j, j)]).sqrt();
        Some(if d > 0.0 { self.cov[(i, j)] / d } else { 0.0 })
    }
}

/// Run the covariance analysis of the configured program with the paper's model.
pub fn covariance_analysis(
    config: &RunConfig,
    with_turntable: bool,
) -> Result<Posterior, AnalysisError> {
    covariance_analysis_ext(config, with_turntable, &ModelExtension::default())
}

/// Run the covariance analysis of the configured program with the paper's model extended by
/// `ext` ([`layout_with`]). The posterior holds every state's name, prior sigma and the full
/// covariance ([`Posterior::correlation`]).
pub fn covariance_analysis_ext(
    config: &RunConfig,
    with_turntable: bool,
    ext: &ModelExtension,
) -> Result<Posterior, AnalysisError> {
    let layout = layout_with(config, with_turntable, ext);
    covariance_analysis_with(config, &layout, &Mounting::default())
}

/// Refuse a program whose steps at the IMU rate exceed [`MAX_ANALYSIS_STEPS`] (also a
/// duration or rate that is not finite).
pub fn check_steps(config: &RunConfig, duration_s: f64) -> Result<(), AnalysisError> {
    let rate_hz = config.filter.imu_rate_hz;
    let steps = duration_s * rate_hz;
    if steps.is_finite() && steps <= MAX_ANALYSIS_STEPS {
        return Ok(());
    }
    let origin = if config.inline_program.is_some() {
        "<inline program>".to_string()
    } else {
        format!("program \"{}\"", config.program)
    };
    Err(AnalysisError::TooManySteps {
        origin,
        duration_s,
        rate_hz,
        steps,
    })
}

/// The prior covariance at the program's start: with the turntable angles (or an independent
/// attitude prior) the configured one at the ideal start attitude; without them the start
/// attitude aligned to the program's rotations, as the estimation does
/// ([`crate::motion::align`]), on the ideal motion.
fn start_covariance(
    config: &RunConfig,
    layout: &StateLayout,
    kin: &Kinematics,
) -> nalgebra::DMatrix<f64> {
    let c0 = kin.sample(0.0).c_body_to_enu;
    let use_tt = layout.install.is_some();
    let aligned = (!use_tt && config.filter.attitude_prior == AttitudePrior::Installation)
        .then(|| {
            // The bins made on demand: a ten-day program has 8.6 million (550 MB held).
            aligned_prior_by(
                config,
                &kin.site,
                layout,
                BinsByIndex {
                    count: ideal_bin_count(kin, 0.1),
                    at: &|i| ideal_bin(kin, 0.1, i),
                },
                &kin.program,
                0.0,
                0.0,
            )
        })
        .flatten();
    aligned.map_or_else(|| initial_covariance(config, layout, &c0), |(_, p)| p)
}

/// Run the covariance analysis for any layout and (nominal) mounting.
pub fn covariance_analysis_with(
    config: &RunConfig,
    layout: &StateLayout,
    mounting: &Mounting,
) -> Result<Posterior, AnalysisError> {
    let program = config.program()?;
    check_steps(config, program.duration())?;
    let rate_changes = RateChanges::new(&program);
    let site = config.site();
    let kin = Kinematics::new(program, *mounting, site);
    let f = &config.filter;
    let dt = 1.0 / f.imu_rate_hz;
    let n_steps = (kin.program.duration() * f.imu_rate_hz).floor() as usize;
    let model = LinearModel::new(layout, dt, &kin.earth_rate_enu(), config.gyro_psd());
    let use_tt = layout.install.is_some();
    let p0 = start_covariance(config, layout, &kin);
    let filter = prior_filter(&p0).map_err(|source| AnalysisError::Filter { t: 0.0, source })?;
    // Angle records are taken to come at the IMU rate, one per step, so that a window of N steps
    // averages N records: the variance of one record is the PSD times the record rate.
    let noise = MeasurementNoise {
        accel_psd: config.accel_psd(),
        angle_var_per_record: use_tt.then(|| config.angle_psd() * f.imu_rate_hz),
    };
    let mut engine = Engine::new(filter, model, Schedule::new(config), noise, true);
    let p0 = vec![0.0; layout.n_instrument()];
    let f_enu = kin.specific_force_enu();
    let zero = Vector3::zeros();
    // Terms that use the rate derivatives get their mean over each step, from the values at its
    // ends (left limits, as the simulator integrates them: a jump of the rate at a step's end
    // belongs to the next step).
    let derivatives = layout.model.uses_rate_derivatives();
    let mut left = derivatives.then(|| kin.sample_left(0.0));
    // The thermal terms see the temperature's departure from the reference in each step (the
    // configured profile, or the recording's own in the model-extension loop).
    let temperature = config.temperature_profile(f.imu_rate_hz, n_steps);
    for j in 1..=n_steps {
        let t_mid = (j as f64 - 0.5) * dt;
        let s = kin.sample(t_mid);
        let mut input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
            temp_delta: temperature
                .as_ref()
                .map_or(0.0, |(profile, reference)| profile.at(t_mid) - reference),
            ..SensorInput::default()
        };
        if let Some(a) = &mut left {
            let b = kin.sample_left(j as f64 * dt);
            input.omega_dot_body = (b.omega_body - a.omega_body) / dt;
            input.f_dot_body = (b.f_body - a.f_body) / dt;
            *a = b;
        }
        let in_acc = engine.schedule.in_accel_window(j).then_some(&zero);
        engine
            .model
            .substep(layout, &s.c_body_to_enu, &input, &p0, in_acc);
        let t = j as f64 * dt;
        if use_tt && engine.schedule.in_turntable_window(j) {
            // One record per step, exactly at t: the sample depends on t and on the delay band.
            let band = 3.0 * engine.filter.std_dev(layout.tau.expect("turntable layout")) + dt;
            if rate_changes.clear(t - band, t + band) {
                let s = kin.sample(t);
                engine.model.add_angle_sample(&AngleSample {
                    y: zero,
                    c_body_to_enu: s.c_body_to_enu,
                    platform_rate_enu: s.platform_rate_enu,
                    gimbal_jacobian: gimbal_jacobian(&s.k),
                    records: &[(j, 1.0)],
                });
            }
        }
        engine
            .measurement_instant(layout, j, &f_enu, false)
            .map_err(|source| AnalysisError::Filter { t, source })?;
    }
    Ok(Posterior {
        names: layout.entries().iter().map(|e| e.name.clone()).collect(),
        units: layout.entries().iter().map(|e| e.unit).collect(),
        prior_sigma: layout.prior_sigma(),
        cov: engine.covariance(),
        log_det_data: engine.log_det_data,
    })
}
