//! A simulated run from a run configuration: the truth drawn from (or set against) the priors,
//! then [`turntable::simulate`] for the records.

use crate::config::{ConfigError, RunConfig};
use crate::covariance::layout_for;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use sins_model::names;
use turntable::kinematics::{Kinematics, Mounting};
use turntable::sensor::AngleSensor;
use turntable::simulate::{SimConfig, SimRng, SimulateError, Simulation, simulate};

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
pub fn simulate_run(config: &RunConfig, origin: &str) -> Result<Simulation, SimulationError> {
    let values = true_values(config, origin)?;
    let get = |name: &str| {
        values
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| *v)
            .expect("layout names")
    };
    let layout = layout_for(config, false);
    let p_true: Vec<f64> = layout.entries()[3..].iter().map(|e| get(&e.name)).collect();
    let mounting = Mounting {
        delta_z: nalgebra::Vector3::from_fn(|i, _| get(names::INSTALL_DELTA[i])),
        gamma_p: nalgebra::Vector3::from_fn(|i, _| get(names::BASE_GAMMA[i])),
    };
    let kin = Kinematics::new(config.program()?, mounting, config.site());
    let t = &config.truth;
    let on = if t.noise { 1.0 } else { 0.0 };
    let sigma = on * (config.angle_psd() * t.turntable_rate_hz).sqrt();
    let sensor = AngleSensor {
        sigma: [sigma; 3],
        rate_hz: t.turntable_rate_hz,
        tau: get(names::TURNTABLE_TAU),
        clock: config.clock,
    };
    let sim = SimConfig {
        imu_rate_hz: t.imu_rate_hz,
        gyro_psd: on * config.gyro_psd(),
        accel_psd: on * config.accel_psd(),
        duration_s: t.duration_s,
        seed: t.seed,
        ..SimConfig::default()
    };
    Ok(simulate(&kin, &layout.model, &p_true, &sensor, &sim)?)
}
