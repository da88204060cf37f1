//! The bias random walks of `[noise]` (`gyro_bias_walk_deg_h_sqrt_h`,
//! `accel_bias_walk_m_s2_sqrt_s`): in the truth of `simulate`, as process noise in the filter's
//! layout and in the covariance analysis. Seeds and bounds fixed before the first run.

use calib::config::{AttitudePrior, RunConfig};
use calib::estimate::covariance::covariance_analysis;
use calib::estimate::{self, Estimate, Plan, Records, RunData};
use calib::io::{ImuData, TurntableData};
use calib::model::layout::layout_for;
use calib::simulate::{accel_drift_seed, drift_seed, simulate_run};
use sins_model::names;
use sins_model::units::DEG_PER_HOUR;
use turntable::simulate::{AccelDrift, GyroDrift, Simulation, accel_bias_walk, gyro_bias_walk};

/// The paper's program at 100 Hz with 50-Hz angles, a turntable clock of its own.
fn run_config(seed: u64) -> RunConfig {
    let mut c = RunConfig::paper();
    c.filter.attitude_prior = AttitudePrior::Installation;
    c.priors.initial_tilt_deg = 0.01;
    c.priors.initial_heading_deg = 0.01;
    c.clock.turntable_offset_s = 12.5;
    c.clock.turntable_rate_error = 2e-4;
    c.truth.imu_rate_hz = 100.0;
    c.truth.turntable_rate_hz = 50.0;
    c.truth.draw_from_priors = true;
    c.truth.seed = seed;
    c
}

#[test]
fn configured_walks_reach_the_layout_and_the_analysis() {
    let mut c = RunConfig::paper();
    let plain = layout_for(&c, true);
    assert_eq!(plain.gyro_drift, None);
    assert_eq!(plain.accel_drift, None);
    c.noise.gyro_bias_walk_deg_h_sqrt_h = 0.06;
    c.noise.accel_bias_walk_m_s2_sqrt_s = 1e-6;
    let walking = layout_for(&c, true);
    let q = walking.gyro_drift.expect("gyro walk");
    assert!((q[1] - 0.06 * DEG_PER_HOUR / 60.0).abs() < 1e-20);
    assert_eq!(walking.accel_drift, Some([1e-6; 3]));

    // What a drift costs: the biases' posterior sigmas grow by more than a fifth, and no
    // parameter's shrinks (process noise only adds uncertainty). (The scale factors' grow
    // too: gyro.theta.xx's doubles at this walk.)
    let a = covariance_analysis(&RunConfig::paper(), true).unwrap();
    let b = covariance_analysis(&c, true).unwrap();
    for n in ["gyro.bias.x", "gyro.bias.z", "accel.bias.y"] {
        let (sa, sb) = (a.sigma(n).unwrap(), b.sigma(n).unwrap());
        println!("{n}: {sa:.3e} without the walks, {sb:.3e} with them");
        assert!(sb > 1.2 * sa, "{n}: {sa} -> {sb}");
    }
    for n in a.names.iter().filter(|n| !n.starts_with("attitude.")) {
        let (sa, sb) = (a.sigma(n).unwrap(), b.sigma(n).unwrap());
        assert!(sb >= sa * (1.0 - 1e-9), "{n}: {sa} -> {sb}");
    }
}

#[test]
fn configured_walks_are_in_the_truth() {
    let mut c = run_config(3);
    c.truth.duration_s = Some(10.0);
    let base = simulate_run(&c, "test").unwrap();
    assert!(base.truth.get("gyro.drift.x").is_none());
    c.noise.gyro_bias_walk_deg_h_sqrt_h = 0.5;
    c.noise.accel_bias_walk_m_s2_sqrt_s = 1e-4;
    let sim = simulate_run(&c, "test").unwrap();
    assert_eq!(
        sim.truth.get("gyro.drift.z"),
        Some(0.5 * DEG_PER_HOUR / 60.0)
    );
    assert_eq!(sim.truth.get("accel.drift.y"), Some(1e-4));
    // The records differ from the run without the walks by exactly the walks' integrals.
    let dt = 0.01;
    let gw = gyro_bias_walk(
        &GyroDrift {
            intensity: [0.5 * DEG_PER_HOUR / 60.0; 3],
            seed: drift_seed(&c),
        },
        dt,
        sim.imu.len(),
    );
    let aw = accel_bias_walk(
        &AccelDrift {
            intensity: [1e-4; 3],
            seed: accel_drift_seed(&c),
        },
        dt,
        sim.imu.len(),
    );
    for k in [0, 1, 500, sim.imu.len() - 1] {
        let dg = sim.imu[k].dtheta - base.imu[k].dtheta + (gw[k] + gw[k + 1]) * (0.5 * dt);
        let da = sim.imu[k].dv - base.imu[k].dv - (aw[k] + aw[k + 1]) * (0.5 * dt);
        assert!(dg.norm() < 1e-17 && da.norm() < 1e-15, "record {k}");
    }
    assert!(aw.last().unwrap().norm() > 1e-5);
}

fn run(c: &RunConfig, sim: &Simulation) -> Estimate {
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "turntable.csv").into()),
    };
    estimate::run(Plan::fit_only(c), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .unwrap()
}

/// Errors in sigmas of every parameter (attitude excluded) against the truth, the biases at
/// the end of the run (constant part plus the walks' values then).
fn errors(
    sim: &Simulation,
    est: &Estimate,
    gyro_end: [f64; 3],
    accel_end: [f64; 3],
) -> Vec<(f64, String)> {
    est.names
        .iter()
        .enumerate()
        .filter(|(_, n)| !n.starts_with("attitude."))
        .map(|(i, n)| {
            let mut t = sim.truth.get(n).unwrap_or(0.0);
            if let Some(k) = names::GYRO_BIAS.iter().position(|b| b == n) {
                t += gyro_end[k];
            }
            if let Some(k) = names::ACCEL_BIAS.iter().position(|b| b == n) {
                t += accel_end[k];
            }
            ((est.values[i] - t) / est.cov[(i, i)].sqrt(), n.clone())
        })
        .collect()
}

fn worst(z: &[(f64, String)]) -> (f64, String) {
    z.iter()
        .cloned()
        .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()))
        .unwrap()
}

/// The paper's program with the gyro biases walking at 0.2 deg/h/sqrt(h) (0.17 deg/h of 1-sigma
/// change over the 0.76-h run, against posterior sigmas of a few 0.001 deg/h), seed 5: with
/// the walk configured in `[noise]` every parameter is within 3 sigma of the truth (the biases
/// at the end of the run); with the same data and the walk left out of the filter the biases
/// are not (the test can fail).
#[test]
fn calibration_with_the_configured_gyro_walk_is_consistent() {
    let mut c = run_config(5);
    c.noise.gyro_bias_walk_deg_h_sqrt_h = 0.2;
    let sim = simulate_run(&c, "walk").unwrap();
    let q = 0.2 * DEG_PER_HOUR / 60.0;
    let w = gyro_bias_walk(
        &GyroDrift {
            intensity: [q; 3],
            seed: drift_seed(&c),
        },
        0.01,
        sim.imu.len(),
    );
    let end = w.last().unwrap();
    let end = [end.x, end.y, end.z];
    let est = run(&c, &sim);
    let z = errors(&sim, &est, end, [0.0; 3]);
    let (zmax, name) = worst(&z);
    println!(
        "walk end {:?} deg/h; largest error {zmax:+.2} sigma ({name}); mean NIS {:.3} / {:.3}",
        end.map(|x| x / DEG_PER_HOUR),
        est.stats.accel_mean_nis,
        est.stats.turntable_mean_nis
    );
    assert!(zmax.abs() < 3.0, "{name}: {zmax} sigma");

    let mut without = c.clone();
    without.noise.gyro_bias_walk_deg_h_sqrt_h = 0.0;
    let est0 = run(&without, &sim);
    let (z0, name0) = worst(&errors(&sim, &est0, end, [0.0; 3]));
    println!("without the walk in the filter: largest error {z0:+.2} sigma ({name0})");
    assert!(z0.abs() > 3.0);
}

/// The same with the accelerometer biases walking at 2e-6 m/s^2/sqrt(s) (1e-4 m/s^2 over the
/// run, against posterior sigmas near 2e-5 m/s^2), seed 6: every parameter within 3 sigma.
#[test]
fn calibration_with_the_configured_accel_walk_is_consistent() {
    let mut c = run_config(6);
    c.noise.accel_bias_walk_m_s2_sqrt_s = 2e-6;
    let sim = simulate_run(&c, "walk").unwrap();
    let w = accel_bias_walk(
        &AccelDrift {
            intensity: [2e-6; 3],
            seed: accel_drift_seed(&c),
        },
        0.01,
        sim.imu.len(),
    );
    let end = w.last().unwrap();
    let est = run(&c, &sim);
    let z = errors(&sim, &est, [0.0; 3], [end.x, end.y, end.z]);
    let (zmax, name) = worst(&z);
    println!(
        "walk end {end:?} m/s^2; largest error {zmax:+.2} sigma ({name}); mean NIS {:.3} / {:.3}",
        est.stats.accel_mean_nis, est.stats.turntable_mean_nis
    );
    assert!(zmax.abs() < 3.0, "{name}: {zmax} sigma");
}

#[test]
fn walks_are_read_from_noise_and_checked_with_their_line() {
    use calib::config::PAPER_CONFIG_TOML;
    let c = RunConfig::from_toml_str(PAPER_CONFIG_TOML, "paper.toml").unwrap();
    assert_eq!(c.noise.gyro_bias_walk_deg_h_sqrt_h, 0.0);
    assert_eq!(c.noise.accel_bias_walk_m_s2_sqrt_s, 0.0);
    let text = PAPER_CONFIG_TOML.replace(
        "[noise]",
        "[noise]\ngyro_bias_walk_deg_h_sqrt_h = 0.037\naccel_bias_walk_m_s2_sqrt_s = 1e-6",
    );
    let c = RunConfig::from_toml_str(&text, "run.toml").unwrap();
    assert_eq!(c.noise.gyro_bias_walk_deg_h_sqrt_h, 0.037);
    assert_eq!(c.noise.accel_bias_walk_m_s2_sqrt_s, 1e-6);
    let bad = PAPER_CONFIG_TOML.replace("[noise]", "[noise]\ngyro_bias_walk_deg_h_sqrt_h = -1");
    let e = RunConfig::from_toml_str(&bad, "run.toml")
        .unwrap_err()
        .to_string();
    let line = PAPER_CONFIG_TOML
        .lines()
        .position(|l| l.trim() == "[noise]")
        .unwrap()
        + 2;
    assert!(
        e.contains("run.toml") && e.contains(&format!("line {line}")),
        "{e}"
    );
    assert!(
        e.contains("-1: expected 0 or a random walk in 1e-12 .. 1e6"),
        "{e}"
    );
}

/// The reach of a walk on the paper's program (`calib::extend::drift_visibility`): the expected
/// statistic is zero without a walk beyond the configured one, grows with the intensity, and
/// the smallest visible walk is where it crosses the threshold (within the bisection's 2 %).
#[test]
fn the_smallest_visible_walk_is_where_the_expected_statistic_crosses_the_threshold() {
    use calib::extend::drift_visibility::{DriftAnalysis, drift_threshold, smallest_visible_drift};
    use calib::model::extension::ModelExtension;
    let unit = DEG_PER_HOUR / 60.0;
    let c = RunConfig::paper();
    let a = DriftAnalysis::new(&c, true, &ModelExtension::default(), 1e-3 * unit * unit).unwrap();
    assert!(a.at(0.0).unwrap().expected_statistic.abs() < 1e-9);
    let stats: Vec<f64> = [0.01, 0.03, 0.1, 0.3]
        .iter()
        .map(|q| a.at(q * unit).unwrap().expected_statistic)
        .collect();
    println!("expected statistics at 0.01, 0.03, 0.1, 0.3 deg/h/sqrt(h): {stats:.4?}");
    // The table of docs/model-extension.md: both models at the walk among others.
    for with_tt in [false, true] {
        let b = DriftAnalysis::new(&c, with_tt, &ModelExtension::default(), 1e-3 * unit * unit)
            .unwrap();
        let row: Vec<f64> = [0.01, 0.037, 0.1, 0.3]
            .iter()
            .map(|q| b.at(q * unit).unwrap().expected_statistic)
            .collect();
        println!("turntable {with_tt}: at 0.01, 0.037, 0.1, 0.3 deg/h/sqrt(h): {row:.4?}");
    }
    assert!(stats.windows(2).all(|w| w[1] > w[0]) && stats[0] > 0.0);
    let threshold = drift_threshold(0.01 / 6.0);
    let reach = smallest_visible_drift(&a, threshold, 0.003 * unit, 0.3 * unit)
        .unwrap()
        .expect("the paper's program with its angles shows 0.3 deg/h/sqrt(h)");
    let below = a.at(reach.intensity / 1.03).unwrap().expected_statistic;
    println!(
        "reach {:.4} deg/h/sqrt(h): {:.2} (below it {below:.2}), threshold {threshold:.2}",
        reach.intensity / unit,
        reach.expected_statistic
    );
    assert!(reach.expected_statistic >= threshold && below < threshold);
    // The unseen walk's cost: the bias sigmas grow.
    assert!((0..3).all(|i| reach.gyro_bias_sigma[i] > 2.0 * reach.gyro_bias_sigma_without[i]));
}
