//! Recordings without a program: the same filter on the rests alone (`calib::estimate::
//! run`) against the filter that knows the program, on the same simulated data.
//!
//! The recording: a 19-position run of a navigation-grade unit (the paper's priors and noise),
//! 20-s rests joined by 90-degree turns at 10 deg/s about the three gimbals, the installation
//! misalignment drawn from its 1-degree prior (a hand-placed unit). The rests are the program's
//! dwells; without the program the filter knows only them.
//!
//! Fixed before the runs were looked at: seeds 500-509 in CI (600-649 behind `--ignored`); the
//! rests-only sigmas of the gyro biases and of the gyro matrix at most 3 times the programmed
//! filter's on every run (issue 19); the rests-only filter consistent
//! ([`workspace_tests::MonteCarlo::check`]: NEES sum in its 95 % band, largest mean error below
//! the Bonferroni bound for 24 states).

use calib::config::RunConfig;
use calib::estimate::{self, HandTurnedRun, MemoryImu, Plan, Records, RunData, RunKind};
use calib::io::ImuData;
use calib::model::layout::layout_for;
use calib::motion::rests::Rest;
use workspace_tests::{MonteCarlo, parallel_map, simulated_run_config, state_errors};

/// Length of each rest (s).
const REST_S: f64 = 20.0;

/// The 19-position program: a rest, then 18 turns of 90 degrees (9 s at 10 deg/s) about the
/// gimbals in turn, each followed by a rest.
pub fn nineteen_positions() -> String {
    // Gimbal and sign of each turn: the pitch and bank gimbals put every face up and down
    // more than once; the heading gimbal turns the horizontal axes.
    let turns: [(u8, f64); 18] = [
        (3, 10.0),
        (3, 10.0),
        (3, 10.0),
        (3, 10.0),
        (2, 10.0),
        (2, 10.0),
        (2, 10.0),
        (2, 10.0),
        (1, 10.0),
        (3, -10.0),
        (3, -10.0),
        (2, -10.0),
        (2, -10.0),
        (1, 10.0),
        (3, 10.0),
        (2, 10.0),
        (3, -10.0),
        (2, -10.0),
    ];
    positions_program(&turns)
}

/// A program of rests joined by 90-degree turns (9 s at `rate` deg/s about `gimbal`; 1 =
/// heading, 2 = bank, 3 = pitch), a rest first.
pub fn positions_program(turns: &[(u8, f64)]) -> String {
    let mut t = format!(
        "name = \"19 positions\"\nstart_deg = [0.0, 0.0, 0.0]\n\n[[segment]]\nkind = \"dwell\"\nduration_s = {REST_S}\n"
    );
    for &(gimbal, rate) in turns {
        t.push_str(&format!(
            "\n[[segment]]\nkind = \"rotate\"\ngimbal = {gimbal}\nrate_deg_s = {rate}\nduration_s = 9.0\n\n[[segment]]\nkind = \"dwell\"\nduration_s = {REST_S}\n"
        ));
    }
    t
}

pub fn config(seed: u64) -> RunConfig {
    config_with_rests(seed, REST_S)
}

/// [`config`] with rests of `rest_s` seconds.
pub fn config_with_rests(seed: u64, rest_s: f64) -> RunConfig {
    let dir = std::env::temp_dir().join(format!("sins-rests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("program-{seed}-{rest_s}.toml"));
    let program = nineteen_positions().replace(
        &format!("kind = \"dwell\"\nduration_s = {REST_S}\n"),
        &format!("kind = \"dwell\"\nduration_s = {rest_s}\n"),
    );
    std::fs::write(&path, program).unwrap();
    let mut c = simulated_run_config();
    c.program = path.display().to_string();
    c.truth.seed = seed;
    c
}

/// The dwells of the program, on the IMU clock (the simulated program starts at 0).
pub fn rests(config: &RunConfig) -> Vec<Rest> {
    let program = config.program().unwrap();
    program
        .pieces()
        .iter()
        .filter(|p| p.rate == [0.0; 3])
        .map(|p| Rest { t0: p.t0, t1: p.t1 })
        .collect()
}

fn run(seeds: std::ops::RangeInclusive<u64>) {
    let runs = parallel_map(&seeds.collect::<Vec<_>>(), |&seed| {
        let config = config(seed);
        let sim = calib::simulate::simulate_run(&config, "19 positions").unwrap();
        let imu = ImuData::from_samples(&sim.imu);
        let data = RunData {
            imu: &imu,
            imu_file: "imu.csv",
            turntable: None,
        };
        let programmed =
            estimate::run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
                .map(|c| c.estimate)
                .unwrap();
        let rests = rests(&config);
        let plan = Plan {
            config: &config,
            layout: None,
            kind: RunKind::RestsFilter {
                rests: &rests,
                turns: &[],
            },
        };
        let at_rests = estimate::run(plan, Records::Held(data), &mut |_, _| {})
            .unwrap()
            .estimate;
        let (e, s) = state_errors(&config, &sim, &at_rests);
        (seed, programmed, at_rests, e, s)
    });
    let mut mc = MonteCarlo::default();
    let mut worst_ratio = (0.0, String::new(), 0);
    for (seed, programmed, at_rests, e, s) in &runs {
        for name in &at_rests.names {
            if !name.starts_with("gyro.") {
                continue;
            }
            let ratio = at_rests.sigma(name).unwrap() / programmed.sigma(name).unwrap();
            if ratio > worst_ratio.0 {
                worst_ratio = (ratio, name.clone(), *seed);
            }
        }
        mc.add_errors(at_rests, e, s);
    }
    let (_, programmed, at_rests, ..) = &runs[0];
    for name in [
        "gyro.bias.x",
        "gyro.theta.xx",
        "gyro.theta.xy",
        "accel.bias.x",
    ] {
        println!(
            "seed {}: {name} sigma {:.3e} (rests) against {:.3e} (program)",
            runs[0].0,
            at_rests.sigma(name).unwrap(),
            programmed.sigma(name).unwrap()
        );
    }
    println!(
        "largest sigma ratio rests / program over the gyro parameters: {:.2} ({}, seed {})",
        worst_ratio.0, worst_ratio.1, worst_ratio.2
    );
    let failures = mc.check("19 positions, rests only, 24 states");
    assert!(failures.is_empty(), "{failures:?}");
    assert!(
        worst_ratio.0 <= 3.0,
        "rests-only sigma {:.2} times the programmed filter's ({}, seed {})",
        worst_ratio.0,
        worst_ratio.1,
        worst_ratio.2
    );
}

#[test]
fn nineteen_positions_without_the_program_10_seeds() {
    run(500..=509);
}

#[test]
#[ignore = "50 runs x 2 calibrations, about a minute in release on 2 cores"]
fn nineteen_positions_without_the_program_50_seeds() {
    run(600..=649);
}

/// A consumer-grade unit on the same 19-position recording: per-cent scale factors, a degree of
/// misalignment, a degree per second of gyro bias, 0.3 m/s^2 of accelerometer bias, and the
/// noise of a MEMS unit (120 deg/h and 0.0012 m/s^2, each the sigma of a 1-s average; the Xsens
/// MTi of `docs/real-data.md` is of this order). `calib::estimate::run` (`RunKind::RestsFilter`)
/// starts it from the coarse batch fit (`needs_coarse_start`).
///
/// Fixed before the runs were looked at: seeds 800-809 (in CI) and 850-899 (behind
/// `--ignored`), the same consistency figures as the navigation-grade runs. Both pass since the
/// trajectory is re-levelled to each window's measured specific force rather than to the
/// filter's tilt estimate (`estimate::pass::level_rotation`): 800-809 NEES 23.76 per run for 24
/// states, largest mean error +2.01 SEM; 850-899 NEES 25.03, -2.12 SEM (`gyro.theta.yy`), the
/// largest run 44. Before, feeding back the tilt estimate (which swings in the first rest and
/// after each turn, while the tilt and the horizontal accelerometer errors are not yet told
/// apart) gave 28.50 (the band's edge) and 36.52 with `accel.gamma.xx` biased by -5.32 SEM and
/// a tail of runs at 56-207; with the accelerometer noise ten times lower, 275 per run.
pub fn consumer_config(seed: u64) -> RunConfig {
    let mut c = config(seed);
    c.priors.gyro_bias_deg_h = 3600.0;
    c.priors.gyro_scale = 0.02;
    c.priors.gyro_misalignment_arcmin = 60.0;
    c.priors.accel_bias_m_s2 = 0.3;
    c.priors.accel_scale = 0.02;
    c.priors.accel_misalignment_arcmin = 60.0;
    c.noise.gyro_deg_h = 120.0;
    c.noise.accel_m_s2 = 0.0012;
    c
}

fn run_consumer(seeds: std::ops::RangeInclusive<u64>) {
    let runs = parallel_map(&seeds.collect::<Vec<_>>(), |&seed| {
        let config = consumer_config(seed);
        assert!(calib::estimate::needs_coarse_start(&config));
        let sim = calib::simulate::simulate_run(&config, "19 positions").unwrap();
        let imu = ImuData::from_samples(&sim.imu);
        let rests = rests(&config);
        let plan = Plan {
            config: &config,
            layout: None,
            kind: RunKind::RestsFilter {
                rests: &rests,
                turns: &[],
            },
        };
        let held = RunData {
            imu: &imu,
            imu_file: "imu.csv",
            turntable: None,
        };
        let est = estimate::run(plan, Records::Held(held), &mut |_, _| {})
            .unwrap()
            .estimate;
        let (e, s) = state_errors(&config, &sim, &est);
        (est, e, s)
    });
    let mut mc = MonteCarlo::default();
    for (est, e, s) in &runs {
        println!(
            "accel mean NIS {:.3} over {} updates",
            est.stats.accel_mean_nis, est.stats.accel_updates
        );
        mc.add_errors(est, e, s);
    }
    let mut sorted = mc.nees.clone();
    sorted.sort_by(f64::total_cmp);
    println!("NEES per run, sorted: {:.1?}", sorted);
    let failures = mc.check("19 positions, consumer grade, rests only, 24 states");
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn consumer_grade_without_the_program_10_seeds() {
    run_consumer(800..=809);
}

#[test]
#[ignore = "50 runs, about 10 s in release on 2 cores"]
fn consumer_grade_without_the_program_50_seeds() {
    run_consumer(850..=899);
}

/// A known turn is a measurement of the filter (`calib::motion::rests::Turn`): on a consumer-grade
/// 19-position recording (25 Hz, seed 810, fixed before the run), the first 90-degree turn
/// given with its true angle (from an error-free copy of the run) is met by the calibration
/// within 0.2 deg, with a turn NIS below 9. Given 1 deg too large, the calibrated turn moves
/// towards it by what a linear-Gaussian update says: `1 deg * s^2 / (s^2 + sigma^2)`, `s` the
/// calibration's own sigma of that angle without the turn (`grad A^T P grad A`, the gradient by
/// central differences of the evaluated turn), `sigma` the turn's 0.5 deg; within half of it.
/// (A first version asked for a move of 0.1 deg, set before the run without knowing `s`: the
/// rests fix this angle to about 0.04 deg, so the move is a few thousandths.)
#[test]
fn a_known_turn_pulls_the_calibration_towards_its_angle() {
    use calib::motion::rests::Turn;
    let mut config = consumer_config(810);
    config.truth.imu_rate_hz = 25.0;
    config.filter.imu_rate_hz = 25.0;
    let sim = calib::simulate::simulate_run(&config, "19 positions").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let mut clean = config.clone();
    clean.truth.draw_from_priors = false;
    clean.truth.noise = false;
    clean.truth.values.clear();
    let clean = ImuData::from_samples(&calib::simulate::simulate_run(&clean, "clean").unwrap().imu);
    // The first turn: 20 .. 29 s (after the first rest).
    let t: Vec<f64> = imu.records.iter().map(|r| r.t).collect();
    let (first, last) = (
        t.partition_point(|&x| x <= 20.0),
        t.partition_point(|&x| x <= 29.0) - 1,
    );
    let total: nalgebra::Vector3<f64> = (first..=last)
        .map(|k| nalgebra::Vector3::from(clean.records[k].gyro))
        .sum();
    let (axis, angle) = (total.normalize(), total.norm());
    assert!(
        (angle.to_degrees() - 90.0).abs() < 0.5,
        "{}",
        angle.to_degrees()
    );
    let layout = layout_for(&config, false);
    let rests = rests(&config);
    let known = |angle_rad: f64| Turn {
        name: "first".into(),
        t0: t[first],
        t1: t[last],
        axis,
        angle_rad,
    };
    let g = config.site().specific_force_at_rest_enu().norm();
    // The calibrated turn (deg) for parameter values `values` (by state index).
    let turn_of = |est: &calib::estimate::Estimate, values: &[f64]| {
        let mut file = est.to_result_file();
        for p in &mut file.parameters {
            p.value = values[est.names.iter().position(|m| *m == p.name).unwrap()];
        }
        let correction = calib::model::correction::Correction::of_result(&file).unwrap();
        let none = calib::motion::free_motion::EarthRotation::at(0.0, f64::INFINITY);
        let t: Vec<f64> = imu.records.iter().map(|r| r.t).collect();
        let e = calib::motion::free_motion::evaluate(
            &mut MemoryImu::new(&imu, "imu.csv"),
            &t,
            &rests,
            &[known(angle)],
            None,
            g,
            &none,
            &correction,
        )
        .unwrap();
        e.turns[0].after_rad.to_degrees()
    };
    let calibrated = |offset_deg: Option<f64>| {
        let turns: Vec<Turn> = offset_deg
            .map(|o| known(angle + o.to_radians()))
            .into_iter()
            .collect();
        let run = HandTurnedRun {
            rests: &rests,
            turns: &turns,
            holdout: None,
            measured: None,
        };
        let plan = Plan {
            config: &config,
            layout: Some(&layout),
            kind: RunKind::HandTurned(run),
        };
        let imu = &mut MemoryImu::new(&imu, "imu.csv");
        let records = Records::Streamed {
            imu,
            turntable: None,
        };
        estimate::run(plan, records, &mut |_, _| {}).unwrap()
    };
    let (none, exact, off) = (
        calibrated(None),
        calibrated(Some(0.0)),
        calibrated(Some(1.0)),
    );
    let turn =
        |r: &calib::estimate::calibration::Calibration| turn_of(&r.estimate, &r.estimate.values);
    let (a_none, a_exact, a_off) = (turn(&none), turn(&exact), turn(&off));
    // The calibration's sigma of the turn without it: the gradient by central differences.
    let est = &none.estimate;
    let n = est.names.len();
    let grad: Vec<f64> = (0..n)
        .map(|i| {
            let h = 1e-3 * est.cov[(i, i)].sqrt().max(1e-12);
            let mut v = est.values.clone();
            v[i] += h;
            let up = turn_of(est, &v);
            v[i] -= 2.0 * h;
            let down = turn_of(est, &v);
            (up - down) / (2.0 * h)
        })
        .collect();
    let s2: f64 = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| grad[i] * est.cov[(i, j)] * grad[j])
                .sum::<f64>()
        })
        .sum();
    let sigma2 = (calib::motion::rests::TURN_SIGMA_RAD.to_degrees()).powi(2);
    let expected = 1.0 * s2 / (s2 + sigma2);
    let truth = angle.to_degrees();
    let stats = exact.estimate.stats;
    println!(
        "true {truth:.4} deg; calibrated without the turn {a_none:.4} (sigma {:.4}), with it \
         {a_exact:.4} (NIS {:.3}), with it 1 deg too large {a_off:.4}: moved {:.5}, expected \
         {expected:.5}",
        s2.sqrt(),
        stats.turn_mean_nis,
        a_off - a_none
    );
    assert_eq!(stats.turn_updates, 1);
    assert!(stats.turn_mean_nis < 9.0, "{}", stats.turn_mean_nis);
    assert!((a_exact - truth).abs() < 0.2, "{a_exact} against {truth}");
    let moved = a_off - a_none;
    assert!(
        moved > 0.0 && (moved / expected - 1.0).abs() < 0.5,
        "moved {moved} deg, expected {expected}"
    );
}
