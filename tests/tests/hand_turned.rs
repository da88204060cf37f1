//! Hand-turned recordings without a configuration (what `calibrate --free-motion` and
//! `diagnose --free-motion` do when no `--config` is given): the grade, priors, white noise and
//! motion noise from the recording (`calib::estimate::hand_turned`), the verdict from the held-out rests.
//!
//! The recordings are the 19-position runs of `rests.rs` (20-s rests joined by 90-degree turns),
//! simulated at 25 Hz, with the program's dwells as the rests. Fixed before the runs were looked
//! at: seed 900 for the navigation-grade comparison (every gyro and accelerometer sigma without
//! a configuration within 3 times the one with the navigation configuration, issue 31), seed
//! 901 for the noise-free navigation-grade recording with accelerometer quadratic terms of
//! 10/20/30 ug/g^2, inner lever arms and a 5-ms time offset (`diagnose` accepts
//! `accel_quadratic` first); seeds 902/903 for the verdicts of a clean consumer-grade recording
//! (nothing contradicts the model) and one with an unmodelled gyro g-sensitivity of the shipped
//! Xsens unit's size (the held-out rests contradict it); seeds 904/906 the same for a
//! navigation-grade recording (the paper's noise) and one with a gyro g-sensitivity of
//! 50 deg/h/g (905, a quadratic term, did not spoil the held-out figures: see its test).

use calib::config::RunConfig;
use calib::estimate::calibration::Calibration;
use calib::estimate::hand_turned::{self, WhiteNoiseAtRest};
use calib::estimate::verdict::RunVerdict;
use calib::estimate::{HandTurnedRun, MemoryImu, Plan, Records, RunKind};
use calib::extend::{LoopSettings, run_loop_at_rests};
use calib::io::ImuData;
use calib::model::extension::HiddenEffects;
use calib::model::layout::layout_for;
use calib::motion::rests::Rest;
use sins_model::candidates::UnitGrade;

/// The 19-position run of `rests.rs` at 25 Hz.
fn config(seed: u64) -> RunConfig {
    let mut c = crate::rests::config(seed);
    c.truth.imu_rate_hz = 25.0;
    c.filter.imu_rate_hz = 25.0;
    c
}

/// What `calibrate --free-motion` without `--config` makes of a recording: the noise measured
/// in its rests, the grade chosen from it, the configuration from the data at the site's
/// latitude and height (`--latitude`, `--height`).
pub(crate) fn from_data(
    truth: &RunConfig,
    imu: &ImuData,
    rests: &[Rest],
) -> (RunConfig, WhiteNoiseAtRest) {
    let mut source = calib::estimate::MemoryImu::new(imu, "imu.csv");
    let at_rest = hand_turned::RecordsAtRest::read(&mut source, rests).unwrap();
    let noise = hand_turned::white_noise_at_rest(&at_rest).unwrap();
    let grade = hand_turned::choose_grade(&at_rest, &noise);
    println!("{}", grade.describe());
    let site = &truth.site;
    let (lat, height) = (site.latitude_deg, site.height_m);
    let c = hand_turned::default_config(&at_rest, lat, height, &noise, grade.grade).unwrap();
    (c, noise)
}

pub(crate) fn calibrate(
    config: &RunConfig,
    imu: &ImuData,
    rests: &[Rest],
    holdout: Option<usize>,
    measured: Option<WhiteNoiseAtRest>,
) -> Calibration {
    let run = HandTurnedRun {
        rests,
        turns: &[],
        holdout,
        measured,
    };
    let plan = Plan {
        config,
        layout: Some(&layout_for(config, false)),
        kind: RunKind::HandTurned(run),
    };
    let records = Records::Streamed {
        imu: &mut MemoryImu::new(imu, "imu.csv"),
        turntable: None,
    };
    calib::estimate::run(plan, records, &mut |_, _| {}).unwrap()
}

#[test]
fn a_navigation_grade_recording_without_a_configuration_is_calibrated_as_one() {
    let truth = config(900);
    let sim = calib::simulate::simulate_run(&truth, "19 positions").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let rests = crate::rests::rests(&truth);
    let (own, noise) = from_data(&truth, &imu, &rests);
    assert_eq!(own.unit_grade(), UnitGrade::Navigation);
    let configured = calibrate(&truth, &imu, &rests, None, None);
    let measured = calibrate(&own, &imu, &rests, None, Some(noise));
    println!(
        "motion noise {} deg; noise {:?}",
        measured.config.filter.motion_attitude_noise_deg, measured.noise
    );
    let mut worst = (0.0, String::new());
    for name in &configured.estimate.names {
        if !(name.starts_with("gyro.") || name.starts_with("accel.")) {
            continue;
        }
        let ratio =
            measured.estimate.sigma(name).unwrap() / configured.estimate.sigma(name).unwrap();
        if ratio > worst.0 {
            worst = (ratio, name.clone());
        }
    }
    println!("largest sigma ratio without/with the configuration: {worst:?}");
    assert!(worst.0 <= 3.0, "{worst:?}");
}

#[test]
fn the_loop_accepts_the_accelerometer_quadratic_term_of_a_navigation_grade_recording() {
    let mut truth = config(901);
    truth.truth.noise = false;
    let hidden = HiddenEffects {
        values: vec![
            // 10, 20, 30 ug/g^2 in 1/(m/s^2).
            ("accel.k2.x".into(), 10e-6 / 9.81),
            ("accel.k2.y".into(), 20e-6 / 9.81),
            ("accel.k2.z".into(), 30e-6 / 9.81),
            ("accel.lever.xy".into(), 0.01),
            ("accel.lever.yz".into(), -0.01),
            ("accel.lever.zx".into(), 0.015),
            ("time.gyro_accel".into(), 0.005),
        ],
        gyro_drift: None,
    };
    let sim = calib::simulate::simulate_run_hidden(&truth, "19 positions", &hidden).unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let rests = crate::rests::rests(&truth);
    let (own, noise) = from_data(&truth, &imu, &rests);
    println!("noise-free recording: measured {noise:?}");
    let mut data = MemoryImu::new(&imu, "imu.csv");
    let settings = LoopSettings {
        measured_noise: Some(noise),
        ..LoopSettings::default()
    };
    let result = run_loop_at_rests(&own, &mut data, &rests, &[], &settings, &mut |_| {}).unwrap();
    for (k, r) in result.rounds.iter().enumerate() {
        let c: Vec<String> = r
            .candidates
            .iter()
            .map(|c| format!("{} {:.1} sep {}", c.term, c.statistic, c.separable))
            .collect();
        println!("round {}: {c:?}; held out {:?}", k + 1, r.held_out);
    }
    assert_eq!(
        result.accepted_terms.first().map(String::as_str),
        Some("accel_quadratic")
    );
}

/// The verdict of a consumer-grade recording calibrated with the paper's model, every fourth
/// rest held out.
fn consumer_verdict(seed: u64, hidden: &HiddenEffects) -> RunVerdict {
    let mut truth = crate::rests::consumer_config(seed);
    truth.truth.imu_rate_hz = 25.0;
    truth.filter.imu_rate_hz = 25.0;
    let sim = calib::simulate::simulate_run_hidden(&truth, "19 positions", hidden).unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let rests = crate::rests::rests(&truth);
    let (own, noise) = from_data(&truth, &imu, &rests);
    let r = calibrate(&own, &imu, &rests, Some(4), Some(noise));
    let v = RunVerdict::of(&r.estimate, &r.noise, r.evaluation.as_ref(), None, false);
    println!("seed {seed}: {v:?}");
    v
}

#[test]
fn a_clean_consumer_grade_recording_fits() {
    let v = consumer_verdict(902, &HiddenEffects::default());
    assert!(v.tested && v.fits(), "{v:?}");
}

#[test]
fn an_unmodelled_g_sensitivity_is_contradicted_by_the_held_out_rests() {
    // The shipped Xsens unit's g-sensitivity: a few hundred deg/h/g (5e-4 rad/s per g).
    let per_g = 500.0 * sins_model::units::DEG_PER_HOUR / 9.81;
    let hidden = HiddenEffects {
        values: vec![
            ("gyro.gsens.xy".into(), per_g),
            ("gyro.gsens.yx".into(), -per_g),
            ("gyro.gsens.zx".into(), 0.6 * per_g),
            ("gyro.gsens.zy".into(), 0.6 * per_g),
        ],
        gyro_drift: None,
    };
    let v = consumer_verdict(903, &hidden);
    assert!(!v.fits(), "{v:?}");
}

/// The verdict of a navigation-grade recording (the paper's noise) calibrated without a
/// configuration with the paper's model, every fourth rest held out.
fn navigation_verdict(seed: u64, hidden: &HiddenEffects) -> RunVerdict {
    let truth = config(seed);
    let sim = calib::simulate::simulate_run_hidden(&truth, "19 positions", hidden).unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let rests = crate::rests::rests(&truth);
    let (own, noise) = from_data(&truth, &imu, &rests);
    let r = calibrate(&own, &imu, &rests, Some(4), Some(noise));
    let v = RunVerdict::of(&r.estimate, &r.noise, r.evaluation.as_ref(), None, false);
    println!("seed {seed}: {v:?}");
    v
}

#[test]
fn a_clean_navigation_grade_recording_fits() {
    let v = navigation_verdict(904, &HiddenEffects::default());
    assert!(v.tested && v.fits(), "{v:?}");
}

/// An unmodelled error a navigation-grade calibration's held-out rests must contradict.
///
/// First tried (seed 905, fixed before the run): a tactical MEMS accelerometer's quadratic term
/// (2e-5 per m/s^2, 200 ug at 1 g: the size of `rests_loop.rs`). It does not spoil the held-out
/// figures (held-out `|f| - g` 0.0004 m/s^2 against 0.0002 on the fitted rests; the windows
/// scatter 1.13 times the rests' own noise): on axis-aligned poses the bias takes its up/down
/// part and the motion noise its horizontal part, and the verdict, which judges by the held-out
/// rests, rightly passes it (the loop names the term: `rests_loop.rs`). The case kept here
/// (seed 906, fixed before its run): a gyro g-sensitivity of 50 deg/h/g, the top of a
/// dynamically tuned gyro's range, in a unit whose noise is navigation grade.
#[test]
fn an_unmodelled_g_sensitivity_spoils_a_navigation_grade_calibration() {
    let per_g = 50.0 * sins_model::units::DEG_PER_HOUR / 9.81;
    let hidden = HiddenEffects {
        values: vec![
            ("gyro.gsens.xy".into(), per_g),
            ("gyro.gsens.yx".into(), -per_g),
            ("gyro.gsens.zx".into(), 0.6 * per_g),
            ("gyro.gsens.zy".into(), 0.6 * per_g),
        ],
        gyro_drift: None,
    };
    let v = navigation_verdict(906, &hidden);
    assert!(!v.fits(), "{v:?}");
}

/// The negative control of the loop whose fits measure their own noise (what `diagnose
/// --free-motion` runs without a configuration): clean consumer-grade 19-position recordings,
/// seeds 910-919 fixed before the run; no term accepted on at least 9 of the 10.
#[test]
fn the_loop_with_measured_noise_accepts_nothing_on_clean_consumer_recordings() {
    let seeds: Vec<u64> = (910..=919).collect();
    let accepted = workspace_tests::parallel_map(&seeds, |&seed| {
        let mut truth = crate::rests::consumer_config(seed);
        truth.truth.imu_rate_hz = 25.0;
        truth.filter.imu_rate_hz = 25.0;
        let sim = calib::simulate::simulate_run(&truth, "19 positions").unwrap();
        let imu = ImuData::from_samples(&sim.imu);
        let rests = crate::rests::rests(&truth);
        let (own, noise) = from_data(&truth, &imu, &rests);
        let mut data = MemoryImu::new(&imu, "imu.csv");
        let settings = LoopSettings {
            measured_noise: Some(noise),
            ..LoopSettings::default()
        };
        let r = run_loop_at_rests(&own, &mut data, &rests, &[], &settings, &mut |_| {}).unwrap();
        let first: Vec<String> = r.rounds[0]
            .candidates
            .iter()
            .map(|c| format!("{} p {:.2e} sep {}", c.term, c.p_value, c.separable))
            .collect();
        println!(
            "seed {seed}: accepted {:?}; first round {first:?}",
            r.accepted_terms
        );
        r.accepted_terms
    });
    let clean = accepted.iter().filter(|a| a.is_empty()).count();
    assert!(clean >= 9, "{accepted:?}");
}
