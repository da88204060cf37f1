//! A simulated run from a run configuration: the truth drawn from (or set against) the priors,
//! then [`turntable::simulate`] for the records.

use crate::config::{ConfigError, RunConfig};
use crate::estimate::covariance::layout_for;
use crate::model::extension::{HiddenEffects, ModelExtension};
use crate::model::layout::{StateLayout, layout_with};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use sins_model::names;
use sins_model::terms::ErrorModel;
use sins_model::terms::Unit;
use std::sync::Arc;
use turntable::kinematics::{Kinematics, Mounting};
use turntable::sensor::AngleSensor;
use turntable::simulate::{
    AccelDrift, GyroDrift, ImuStream, SimConfig, SimRng, SimulateError, Simulation, Truth,
    TruthParameter, TurntableStream, simulate_walking,
};
use turntable::temperature::TemperatureProfile;

/// Errors of a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimulationError {
    /// Configuration problem.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A true value names no parameter.
    #[error(
        "{origin}: truth.values names `{name}`, which is not a parameter; expected one of: {expected}"
    )]
    UnknownName {
        /// Configuration file.
        origin: String,
        /// The unknown name.
        name: String,
        /// The valid names.
        expected: String,
    },
    /// Thermal truth terms without a temperature to act on.
    #[error(
        "{origin}: the truth has the thermal term `{term}` but the configuration has no \
         [temperature] section: expected a temperature profile for it to act on"
    )]
    NoTemperature {
        /// Configuration file.
        origin: String,
        /// The thermal term's id.
        term: String,
    },
    /// The simulator refused its settings.
    #[error(transparent)]
    Simulate(#[from] SimulateError),
}

/// The true values of a run: the configured ones, the rest drawn from the priors with the
/// configured seed (or zero when `truth.draw_from_priors` is false). Names and order are those
/// of the 28-state layout (plus `base.gamma.*`), attitude errors excluded.
pub fn true_values(
    config: &RunConfig,
    origin: &str,
) -> Result<Vec<(String, f64)>, SimulationError> {
    let mut with_base = config.clone();
    with_base.filter.estimate_base_misalignment = true;
    let layout = layout_for(&with_base, true);
    // A stream of its own, so that changing the noise settings does not change the draws.
    let mut rng = SimRng::seed_from_u64(config.truth.seed ^ 0x005e_ed7a_1e0f_ca1b);
    let mut values = Vec::new();
    for e in &layout.entries()[3..] {
        let z: f64 = StandardNormal.sample(&mut rng);
        let drawn = config.truth.draw_from_priors
            && (!e.name.starts_with("base.") || config.filter.estimate_base_misalignment);
        values.push((e.name.clone(), if drawn { z * e.prior_sigma } else { 0.0 }));
    }
    for (name, v) in &config.truth.values {
        if HiddenEffects::candidate_of(name).is_some() {
            // An extra term's parameter: [`simulate_run`] passes it on as a hidden effect.
            continue;
        }
        match values.iter_mut().find(|(n, _)| n == name) {
            Some(slot) => slot.1 = *v,
            None => {
                return Err(SimulationError::UnknownName {
                    origin: origin.to_string(),
                    name: name.clone(),
                    expected: values
                        .iter()
                        .map(|(n, _)| n.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        }
    }
    Ok(values)
}

/// Simulate the run a configuration describes (its `[truth]`, `[noise]` and `[clock]`
/// sections). `origin` names the configuration in messages.
///
/// `truth.values` may name the parameters of the candidate terms too (`gyro.tbias.x`,
/// `accel.k2.z`, ...): the unit then has those effects ([`simulate_run_hidden`]).
pub fn simulate_run(config: &RunConfig, origin: &str) -> Result<Simulation, SimulationError> {
    simulate_run_hidden(config, origin, &truth_hidden(config))
}

/// The extra terms' values `truth.values` names.
fn truth_hidden(config: &RunConfig) -> HiddenEffects {
    HiddenEffects {
        values: config
            .truth
            .values
            .iter()
            .filter(|(n, _)| HiddenEffects::candidate_of(n).is_some())
            .map(|(n, v)| (n.clone(), *v))
            .collect(),
        gyro_drift: None,
    }
}

/// Seed of the gyro drift's own random stream, from the run's seed.
pub fn drift_seed(config: &RunConfig) -> u64 {
    config.truth.seed ^ 0x0d21_f7ba_5e5d_0001
}

/// Seed of the accelerometer drift's own random stream, from the run's seed.
pub fn accel_drift_seed(config: &RunConfig) -> u64 {
    config.truth.seed ^ 0x0acc_d21f_7ba5_0002
}

/// [`simulate_run`] with extra effects the paper's model does not have: the named extra terms'
/// true values (the other parameters of their terms zero) and a random walk of the gyro biases
/// (seeded from [`drift_seed`], its own stream). The paper's parameters, the turntable records
/// and every noise draw are those of the run without the effects. The truth lists the paper's
/// parameters, then the extra terms' (in [`sins_model::candidates::Candidate::ALL`] order),
/// then the turntable's, then the drift intensities (`gyro.drift.*`, `accel.drift.*`) when
/// drifting.
///
/// The configuration's `[noise] gyro_bias_walk_deg_h_sqrt_h` and
/// `accel_bias_walk_m_s2_sqrt_s` are part of the truth too: the gyro walk is `hidden`'s when it
/// has one, else the configured one; the accelerometer walk (its own stream, seeded from
/// [`accel_drift_seed`]) is the configured one. Both are off when `truth.noise` is false.
pub fn simulate_run_hidden(
    config: &RunConfig,
    origin: &str,
    hidden: &HiddenEffects,
) -> Result<Simulation, SimulationError> {
    let run = prepare_run_hidden(config, origin, hidden)?;
    let mut out = simulate_walking(
        &run.kin,
        &run.model,
        &run.p_true,
        &run.sensor,
        &run.sim,
        run.drift.as_ref(),
        run.accel_drift.as_ref(),
    )?;
    out.truth = run.truth;
    Ok(out)
}

/// What [`simulate_run`] simulates, set up but not run: the records are then generated one at a
/// time ([`PreparedRun::imu`], then [`PreparedRun::turntable`] with the same rng), in memory
/// that does not grow with the run. The records and the truth are those of [`simulate_run`].
pub fn prepare_run(config: &RunConfig, origin: &str) -> Result<PreparedRun, SimulationError> {
    prepare_run_hidden(config, origin, &truth_hidden(config))
}

/// A run set up by [`prepare_run`] / [`prepare_run_hidden`].
pub struct PreparedRun {
    /// The turntable's motion with the true mounting.
    pub kin: Kinematics,
    /// The error model of the true values.
    pub model: Arc<ErrorModel>,
    /// The true instrument parameters.
    pub p_true: Vec<f64>,
    /// The angle sensor of the turntable records.
    pub sensor: AngleSensor,
    /// The simulator's settings (rate, noise, seed, temperature).
    pub sim: SimConfig,
    /// The gyro bias walk, when there is one.
    pub drift: Option<GyroDrift>,
    /// The accelerometer bias walk, when there is one.
    pub accel_drift: Option<AccelDrift>,
    /// The truth file's contents.
    pub truth: Truth,
}

impl PreparedRun {
    /// The rng of the records' noise, seeded with the run's seed: give it to [`Self::imu`],
    /// then the same to [`Self::turntable`].
    pub fn rng(&self) -> SimRng {
        SimRng::seed_from_u64(self.sim.seed)
    }

    /// The IMU records one at a time.
    pub fn imu<'a>(&'a self, rng: &'a mut SimRng) -> Result<ImuStream<'a, SimRng>, SimulateError> {
        ImuStream::new(
            &self.kin,
            &self.model,
            &self.p_true,
            &self.sim,
            self.drift.as_ref(),
            self.accel_drift.as_ref(),
            rng,
        )
    }

    /// Refuse the turntable records' settings before any record is made (the refusal of
    /// [`Self::turntable`]).
    pub fn check_turntable(&self) -> Result<(), SimulateError> {
        turntable::simulate::check_sensor(&self.sensor)
    }

    /// The turntable records one at a time, covering IMU records up to `imu_duration` (the
    /// last IMU record's time), with the rng the IMU records left.
    pub fn turntable<'a>(
        &'a self,
        imu_duration: f64,
        rng: &'a mut SimRng,
    ) -> Result<TurntableStream<'a, SimRng>, SimulateError> {
        TurntableStream::new(&self.kin, &self.sensor, imu_duration, rng)
    }
}

/// [`prepare_run`] with the extra effects of [`simulate_run_hidden`].
pub fn prepare_run_hidden(
    config: &RunConfig,
    origin: &str,
    hidden: &HiddenEffects,
) -> Result<PreparedRun, SimulationError> {
    let values = true_values(config, origin)?;
    let candidates = hidden
        .candidates()
        .map_err(|name| SimulationError::UnknownName {
            origin: origin.to_string(),
            name,
            expected: "the parameters of the candidate terms (sins_model::candidates)".into(),
        })?;
    let layout = layout_with(config, false, &ModelExtension::with(&candidates));
    let p_true = true_instrument(config, &layout, &values, hidden);
    let mounting = Mounting {
        delta_z: nalgebra::Vector3::from_fn(|i, _| value_of(&values, names::INSTALL_DELTA[i])),
        gamma_p: nalgebra::Vector3::from_fn(|i, _| value_of(&values, names::BASE_GAMMA[i])),
    };
    let kin = Kinematics::new(config.program()?, mounting, config.site());
    let temperature = run_temperature(config, &kin, &candidates, origin)?;
    let sensor = angle_sensor(config, value_of(&values, names::TURNTABLE_TAU));
    let t = &config.truth;
    let on = if t.noise { 1.0 } else { 0.0 };
    let sim = SimConfig {
        imu_rate_hz: t.imu_rate_hz,
        gyro_psd: on * config.gyro_psd(),
        accel_psd: on * config.accel_psd(),
        duration_s: t.duration_s,
        seed: t.seed,
        temperature: temperature.clone(),
        ..SimConfig::default()
    };
    let walks = Walks::of(config, hidden);
    let mut truth = Truth::new(&layout.model, &p_true, &kin, &sensor);
    walks.add_to(&mut truth);
    truth.temperature_reference_c = temperature.map(|(_, r)| r);
    Ok(PreparedRun {
        kin,
        model: layout.model,
        p_true,
        sensor,
        sim,
        drift: walks.gyro.map(|intensity| GyroDrift {
            intensity,
            seed: drift_seed(config),
        }),
        accel_drift: walks.accel.map(|intensity| AccelDrift {
            intensity,
            seed: accel_drift_seed(config),
        }),
        truth,
    })
}

/// The true value of the parameter `name` among `values` ([`true_values`]' layout names).
fn value_of(values: &[(String, f64)], name: &str) -> f64 {
    values
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| *v)
        .expect("layout names")
}

/// The true instrument parameters in the order of `layout` (the paper's model extended by the
/// hidden terms): the paper's from `values`, the extra terms' from `hidden` (the last value
/// named; zero when not named).
fn true_instrument(
    config: &RunConfig,
    layout: &StateLayout,
    values: &[(String, f64)],
    hidden: &HiddenEffects,
) -> Vec<f64> {
    let n_paper = layout_for(config, false).n_instrument();
    layout.entries()[3..]
        .iter()
        .enumerate()
        .map(|(k, e)| {
            if k < n_paper {
                value_of(values, &e.name)
            } else {
                hidden
                    .values
                    .iter()
                    .rev()
                    .find(|(n, _)| *n == e.name)
                    .map_or(0.0, |(_, v)| *v)
            }
        })
        .collect()
}

/// The temperature over the run of the records `kin` and `config.truth` give, with the thermal
/// terms' reference; refused when a hidden thermal term has none to act on.
fn run_temperature(
    config: &RunConfig,
    kin: &Kinematics,
    candidates: &[sins_model::candidates::Candidate],
    origin: &str,
) -> Result<Option<(TemperatureProfile, f64)>, SimulationError> {
    let t = &config.truth;
    let duration = t.duration_s.unwrap_or_else(|| kin.program.duration());
    let n_records = (duration * t.imu_rate_hz * (1.0 + 1e-12)).floor() as usize;
    let temperature = config.temperature_profile(t.imu_rate_hz, n_records);
    if temperature.is_none()
        && let Some(c) = candidates.iter().find(|c| c.is_thermal())
    {
        return Err(SimulationError::NoTemperature {
            origin: origin.to_string(),
            term: c.id().to_string(),
        });
    }
    Ok(temperature)
}

/// The turntable's angle sensor: the configured angle noise at the truth's record rate (none
/// when `truth.noise` is false), the delay `tau` and the clock relation.
fn angle_sensor(config: &RunConfig, tau: f64) -> AngleSensor {
    let t = &config.truth;
    let on = if t.noise { 1.0 } else { 0.0 };
    let sigma = on * (config.angle_psd() * t.turntable_rate_hz).sqrt();
    AngleSensor {
        sigma: [sigma; 3],
        rate_hz: t.turntable_rate_hz,
        tau,
        clock: config.clock,
    }
}

/// The bias random walks of a simulated run (intensities per axis): the gyro's `hidden`'s when
/// it has one, else the configured one; the accelerometer's the configured one; the
/// configured ones only when `truth.noise` is on.
struct Walks {
    gyro: Option<[f64; 3]>,
    accel: Option<[f64; 3]>,
}

impl Walks {
    fn of(config: &RunConfig, hidden: &HiddenEffects) -> Self {
        let configured = |walk: Option<[f64; 3]>| walk.filter(|_| config.truth.noise);
        Self {
            gyro: hidden
                .gyro_drift
                .or(configured(config.noise.gyro_bias_walk())),
            accel: configured(config.noise.accel_bias_walk()),
        }
    }

    /// The walks' intensities as parameters of the truth (`gyro.drift.*`, `accel.drift.*`).
    fn add_to(&self, truth: &mut Truth) {
        for (walk, names, unit) in [
            (
                self.gyro,
                names::GYRO_DRIFT,
                Unit::RadPerSecondPerSqrtSecond.si_name(),
            ),
            (self.accel, names::ACCEL_DRIFT, "m/s^2/sqrt(s)"),
        ] {
            if let Some(d) = walk {
                for (n, v) in names.iter().zip(d) {
                    truth.parameters.push(TruthParameter {
                        name: n.to_string(),
                        value: v,
                        unit: unit.to_string(),
                    });
                }
            }
        }
    }
}
