//! Helpers shared by the workspace-level tests.

#![forbid(unsafe_code)]

pub mod hidden;
pub mod operating;

use calib::config::{AttitudePrior, RunConfig};
use calib::estimate::Estimate;
use nalgebra::Vector3;
use sins_model::attitude::attitude_error;
use turntable::kinematics::{Kinematics, Mounting};
use turntable::simulate::Simulation;

/// The run the calibration tests simulate: the paper's program, priors and noises, the start
/// attitude from the installation (its extra error 0.01 deg: none in the simulation), the
/// turntable clock 12.5 s ahead and 2e-4 fast, angles at 50 Hz against the IMU's 100 Hz, every
/// parameter drawn from its prior (seed 1).
pub fn simulated_run_config() -> RunConfig {
    let mut c = RunConfig::paper();
    c.filter.attitude_prior = AttitudePrior::Installation;
    c.priors.initial_tilt_deg = 0.01;
    c.priors.initial_heading_deg = 0.01;
    c.clock.turntable_offset_s = 12.5;
    c.clock.turntable_rate_error = 2e-4;
    c.truth.imu_rate_hz = 100.0;
    c.truth.turntable_rate_hz = 50.0;
    c.truth.draw_from_priors = true;
    c.truth.seed = 1;
    c
}

/// Estimation error of every state of `est` against the truth of `sim` (estimate minus truth;
/// for the attitude states, which are fed back, the remaining error of the computed attitude),
/// with each state's reported sigma. Biases that walk (`[noise]`'s walks, which the simulation
/// puts in its truth) are compared with their values at the end of the run, where the filter's
/// estimate of them is.
pub fn state_errors(config: &RunConfig, sim: &Simulation, est: &Estimate) -> (Vec<f64>, Vec<f64>) {
    let walked = walks_at_end(config, sim.imu.len());
    let truth = |n: &str| sim.truth.get(n).expect("truth names") + walked(n);
    let axes = ["x", "y", "z"];
    let mounting = Mounting {
        delta_z: Vector3::from_fn(|i, _| truth(&format!("install.delta.{}", axes[i]))),
        gamma_p: Vector3::from_fn(|i, _| {
            sim.truth
                .get(&format!("base.gamma.{}", axes[i]))
                .unwrap_or(0.0)
        }),
    };
    let kin = Kinematics::new(config.program().unwrap(), mounting, config.site());
    // Simulated runs start the program at IMU time 0 (the estimate's own start is found).
    let c_true = kin.sample(est.final_time).c_body_to_enu;
    let beta = attitude_error(&est.final_c_body_to_enu, &c_true);
    let errors = est
        .names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            if i < 3 {
                -beta[i]
            } else {
                est.values[i] - truth(n)
            }
        })
        .collect();
    let sigma = (0..est.names.len())
        .map(|i| est.cov[(i, i)].sqrt())
        .collect();
    (errors, sigma)
}

/// The walked part of each bias at the end of a simulated run of `records` IMU records (0 for
/// every other state, and for the biases when `[noise]` has no walk): the simulation's own
/// streams, regenerated from their seeds.
fn walks_at_end(config: &RunConfig, records: usize) -> impl Fn(&str) -> f64 {
    use calib::simulate::{accel_drift_seed, drift_seed};
    use turntable::simulate::{AccelDrift, GyroDrift, accel_bias_walk, gyro_bias_walk};
    let dt = 1.0 / config.truth.imu_rate_hz;
    let end = |w: Vec<Vector3<f64>>| w.last().copied().unwrap_or_else(Vector3::zeros);
    let on = config.truth.noise;
    let gyro = config
        .noise
        .gyro_bias_walk()
        .filter(|_| on)
        .map(|intensity| {
            let seed = drift_seed(config);
            end(gyro_bias_walk(&GyroDrift { intensity, seed }, dt, records))
        });
    let accel = config
        .noise
        .accel_bias_walk()
        .filter(|_| on)
        .map(|intensity| {
            let seed = accel_drift_seed(config);
            end(accel_bias_walk(
                &AccelDrift { intensity, seed },
                dt,
                records,
            ))
        });
    move |name: &str| {
        let axis = |names: &[&str]| names.iter().position(|n| *n == name);
        match (
            axis(&sins_model::names::GYRO_BIAS),
            axis(&sins_model::names::ACCEL_BIAS),
        ) {
            (Some(k), _) => gyro.map_or(0.0, |w| w[k]),
            (_, Some(k)) => accel.map_or(0.0, |w| w[k]),
            _ => 0.0,
        }
    }
}

/// The normalised errors and NEES of many runs of one model.
#[derive(Debug, Default)]
pub struct MonteCarlo {
    /// State names.
    pub names: Vec<String>,
    /// NEES of each run (all states, on the correlation matrix: [`calib::check::stats::nees`]).
    pub nees: Vec<f64>,
    /// Normalised errors (error / sigma), per run and state.
    pub z: Vec<Vec<f64>>,
}

impl MonteCarlo {
    /// Add one run.
    pub fn add(&mut self, config: &RunConfig, sim: &Simulation, est: &Estimate) {
        let (e, s) = state_errors(config, sim, est);
        self.add_errors(est, &e, &s);
    }

    /// Add one run from its state errors and sigmas ([`state_errors`]).
    pub fn add_errors(&mut self, est: &Estimate, e: &[f64], s: &[f64]) {
        let n = e.len();
        let cov = nalgebra::DMatrix::from_fn(n, n, |i, j| est.cov[(i, j)]);
        self.nees
            .push(calib::check::stats::nees(e, &cov).expect("posterior positive definite"));
        self.z.push(e.iter().zip(s).map(|(e, s)| e / s).collect());
        self.names = est.names.clone();
    }

    /// Check, and print, the two figures of consistency fixed before the runs were looked at:
    /// the NEES summed over the runs inside the two-sided 95 % band of its chi-square
    /// distribution, and the largest mean normalised error (in standard errors of the mean)
    /// below the Bonferroni bound for the number of states at a family-wise 5 %. Returns the
    /// failures (empty: consistent).
    pub fn check(&self, label: &str) -> Vec<String> {
        let runs = self.nees.len() as f64;
        let k = self.names.len();
        let total: f64 = self.nees.iter().sum();
        let (lo, hi) = calib::check::stats::chi_square_band(k as f64 * runs, 0.95);
        let bound = calib::check::stats::bonferroni_bound(k, 0.05);
        let (worst, name) = (0..k)
            .map(|i| {
                let mean = self.z.iter().map(|z| z[i]).sum::<f64>() / runs;
                (mean * runs.sqrt(), &self.names[i])
            })
            .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
            .expect("states");
        println!(
            "{label}: {runs} runs, NEES per run {:.2} for {k} states (sum {total:.1}, 95 % band [{lo:.1}, {hi:.1}]); \
             largest mean error {worst:+.2} SEM ({name}), bound {bound:.2}",
            total / runs
        );
        // The states whose normalised errors scatter most (rms well above 1: sigma too small).
        let mut rms: Vec<(f64, &String)> = (0..k)
            .map(|i| {
                (
                    (self.z.iter().map(|z| z[i] * z[i]).sum::<f64>() / runs).sqrt(),
                    &self.names[i],
                )
            })
            .collect();
        rms.sort_by(|a, b| b.0.total_cmp(&a.0));
        println!(
            "{label}: largest rms normalised errors: {}",
            rms.iter()
                .take(4)
                .map(|(r, n)| format!("{n} {r:.2}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let mut failures = vec![];
        if !(lo..=hi).contains(&total) {
            failures.push(format!(
                "{label}: NEES sum {total:.1} outside [{lo:.1}, {hi:.1}]"
            ));
        }
        if worst.abs() > bound {
            failures.push(format!(
                "{label}: {name} biased by {worst:+.2} SEM (bound {bound:.2})"
            ));
        }
        failures
    }
}

/// Simulate the run of `config` with each seed and calibrate it with both models (IMU only,
/// then with the turntable angles), handing every estimate to `inspect` (which may assert on
/// it) and collecting the Monte-Carlo figures; then check both ([`MonteCarlo::check`]) under
/// `label` and fail on any inconsistency.
pub fn monte_carlo_both_models(
    label: &str,
    seeds: std::ops::RangeInclusive<u64>,
    config: impl Fn(u64) -> RunConfig + Sync,
    mut inspect: impl FnMut(bool, &Estimate),
) {
    use calib::estimate::{Plan, Records, RunData, run};
    use calib::io::{ImuData, TurntableData};
    // The runs are independent: they go in parallel, and their results are taken in seed
    // order, so the figures do not depend on the number of threads.
    let runs = parallel_map(&seeds.collect::<Vec<_>>(), |&seed| {
        let config = config(seed);
        let sim = calib::simulate::simulate_run(&config, label).unwrap();
        let imu = ImuData::from_samples(&sim.imu);
        let tt = TurntableData::from_samples(&sim.turntable);
        [false, true].map(|with_tt| {
            let data = RunData {
                imu: &imu,
                imu_file: "imu.csv",
                turntable: with_tt.then_some((&tt, "turntable.csv").into()),
            };
            let est = run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
                .map(|c| c.estimate)
                .unwrap();
            let (e, s) = state_errors(&config, &sim, &est);
            (est, e, s)
        })
    });
    let (mut imu_only, mut with_turntable) = (MonteCarlo::default(), MonteCarlo::default());
    for run in runs {
        for ((est, e, s), (with_tt, mc)) in run
            .into_iter()
            .zip([(false, &mut imu_only), (true, &mut with_turntable)])
        {
            inspect(with_tt, &est);
            mc.add_errors(&est, &e, &s);
        }
    }
    let mut failures = imu_only.check(&format!("{label}, 24 states"));
    failures.extend(with_turntable.check(&format!("{label}, 28 states")));
    assert!(failures.is_empty(), "{failures:?}");
}

/// `f` of every item, on as many threads as the machine has cores, in the items' order.
pub fn parallel_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism()
        .map_or(1, std::num::NonZeroUsize::get)
        .min(items.len())
        .max(1);
    let mut out: Vec<(usize, R)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|w| {
                let f = &f;
                scope.spawn(move || {
                    (w..items.len())
                        .step_by(threads)
                        .map(|i| (i, f(&items[i])))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|h| h.join().expect("a Monte-Carlo run panicked"))
            .collect()
    });
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, r)| r).collect()
}
