//! The model-extension loop on recordings of rests without a program
//! (`calib::extend::run_loop_at_rests`): the 19-position run of `rests.rs` at 25 Hz with a
//! hidden accelerometer quadratic term, and a clean control.
//!
//! Fixed before the runs were looked at: the quadratic term of a tactical MEMS unit
//! (2e-5 per m/s^2 on each axis, signs +, -, +; `workspace_tests::hidden`), seed 700; the
//! control seed 701. The loop must accept `accel_quadratic` (and nothing else) on the first,
//! nothing on the second. The negative control of issue 19: no term accepted on at least 19
//! of the 20 clean runs of seeds 710-729. A tactical g-sensitivity, seed 702.
//!
//! Added with the consumer-grade runs, fixed before they were looked at: an effect no candidate
//! models, an accelerometer bias random walk of 1e-4 m/s^2/sqrt(s) in the data and not in the
//! configuration (seed 740): the loop was to accept nothing and say the model does not fit; and
//! the negative control on consumer-grade recordings (`rests::consumer_config`), seeds
//! 760-779: no term accepted on at least 19 of 20 (measured: none on 20; two of the 20 final
//! models were said not to fit).
//!
//! The first failed as planned and taught something: the loop accepted `gyro_g_sensitivity`
//! and `gyro_bias_drift`, and still said the model does not fit. At rest a change of a
//! horizontal accelerometer bias reads exactly as a change of tilt, which a gyro drift (or a
//! gyro error proportional to the specific force, pose by pose) makes; in a 19-position
//! recording every axis is horizontal in some pose. The walk is therefore not an effect "no
//! candidate models" for this recording, and the test checked only the verdict. With the
//! held-out check (every fourth rest held out whole; `calib::extend::HeldOutCheck`) the loop
//! refuses the g-sensitivity (held-out log predictive density -3.95 with it over 216
//! held-out measurements: it does not predict poses its fit has not seen), accepts nothing and
//! says the model does not fit, as first planned; the test asserts that again.

use calib::config::RunConfig;
use calib::estimate::RunData;
use calib::extend::{LoopSettings, run_loop_at_rests};
use calib::extension::HiddenEffects;
use calib::io::ImuData;
use calib::rests::Rest;

fn config(seed: u64) -> RunConfig {
    let mut c = crate::rests::config(seed);
    c.truth.imu_rate_hz = 25.0;
    c.filter.imu_rate_hz = 25.0;
    c
}

fn accepted(seed: u64, hidden: &HiddenEffects) -> Vec<String> {
    let config = config(seed);
    run(&config, &config, hidden).0
}

/// The loop on a run simulated with `truth` and fitted with `fit`: the accepted terms and
/// whether the final model fits.
fn run(truth: &RunConfig, fit: &RunConfig, hidden: &HiddenEffects) -> (Vec<String>, bool) {
    let (config, seed) = (fit, truth.truth.seed);
    let rests: Vec<Rest> = crate::rests::rests(config);
    let sim = calib::simulate::simulate_run_hidden(truth, "19 positions", hidden).unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: None,
    };
    let result = run_loop_at_rests(
        config,
        &data,
        &rests,
        &[],
        &LoopSettings::default(),
        &mut |_| {},
    )
    .unwrap();
    let terms = result.accepted_terms.clone();
    let fits = result.final_model_fits();
    let checks: Vec<String> = result
        .rounds
        .iter()
        .filter_map(|r| r.held_out.as_ref())
        .map(|h| format!("{} {:+.2} over {}", h.term, h.gain(), h.measurements))
        .collect();
    let first: Vec<String> = result.rounds[0]
        .candidates
        .iter()
        .map(|c| format!("{} p {:.2e}", c.term, c.p_value))
        .collect();
    println!(
        "seed {seed}: accepted {terms:?}, final model fits: {fits}, held-out checks {checks:?}; \
         first round {first:?}"
    );
    (terms, fits)
}

#[test]
fn the_loop_finds_an_accelerometer_quadratic_term_without_a_program() {
    let hidden = HiddenEffects {
        values: vec![
            ("accel.k2.x".into(), 2e-5),
            ("accel.k2.y".into(), -2e-5),
            ("accel.k2.z".into(), 2e-5),
        ],
        gyro_drift: None,
    };
    assert_eq!(accepted(700, &hidden), vec!["accel_quadratic".to_string()]);
}

/// The programmed tests' tactical g-sensitivity (`workspace_tests::hidden`), seed 702: the
/// size and seed were set before the first run; the separability rule for recordings of rests
/// was changed after it (with every entry required to be separated, the term was refused at
/// p = 7.6e-25: `calib::extend`).
#[test]
fn the_loop_finds_a_gyro_g_sensitivity_without_a_program() {
    let hidden = HiddenEffects {
        values: vec![
            ("gyro.gsens.xx".into(), 3e-7),
            ("gyro.gsens.yz".into(), -2e-7),
            ("gyro.gsens.zy".into(), 2e-7),
        ],
        gyro_drift: None,
    };
    assert_eq!(
        accepted(702, &hidden),
        vec!["gyro_g_sensitivity".to_string()]
    );
}

#[test]
fn the_loop_accepts_nothing_on_a_clean_recording_of_rests() {
    assert!(accepted(701, &HiddenEffects::default()).is_empty());
}

#[test]
fn the_loop_accepts_nothing_on_19_of_20_clean_recordings_of_rests() {
    let seeds: Vec<u64> = (710..730).collect();
    let runs =
        workspace_tests::parallel_map(&seeds, |&seed| accepted(seed, &HiddenEffects::default()));
    let false_calls = runs.iter().filter(|t| !t.is_empty()).count();
    assert!(
        false_calls <= 1,
        "terms accepted on {false_calls} of 20 clean runs: {runs:?}"
    );
}

#[test]
fn an_unmodelled_accelerometer_bias_walk_is_not_called_a_fit() {
    let fit = config(740);
    let mut truth = fit.clone();
    truth.noise.accel_bias_walk_m_s2_sqrt_s = 1e-4;
    let (terms, fits) = run(&truth, &fit, &HiddenEffects::default());
    assert!(
        !fits,
        "the final model was said to fit (accepted {terms:?})"
    );
    assert!(terms.is_empty(), "accepted {terms:?}");
}

#[test]
fn the_loop_accepts_nothing_on_19_of_20_clean_consumer_grade_recordings() {
    let seeds: Vec<u64> = (760..780).collect();
    let runs = workspace_tests::parallel_map(&seeds, |&seed| {
        let mut c = crate::rests::consumer_config(seed);
        c.truth.imu_rate_hz = 25.0;
        c.filter.imu_rate_hz = 25.0;
        run(&c, &c, &HiddenEffects::default()).0
    });
    let false_calls = runs.iter().filter(|t| !t.is_empty()).count();
    assert!(
        false_calls <= 1,
        "terms accepted on {false_calls} of 20 clean consumer-grade runs: {runs:?}"
    );
}

/// The programmed tests' tactical scale-factor asymmetry (`workspace_tests::hidden`: 2e-5,
/// -1.5e-5, 1e-5) on the 19-position recording, whose turns go both ways about every gimbal.
/// Size and seed (703) fixed before the first run (issue 19: a hidden-effect test for every
/// candidate a recording of rests can observe).
///
/// FAILS, as first run: nothing accepted and the paper's model fits (the asymmetry's score test
/// p = 0.79 in the first round). The size was taken from the programmed runs (45 min, 9 cycles
/// of +-10 deg/s), which carry far more turning than 18 turns of 90 deg; on this recording it
/// leaves no trace. Not a false decision; the size this recording can see is not known yet.
#[test]
#[ignore = "fails as first run: the asymmetry at the programmed runs' size leaves no trace on a 19-position recording (p = 0.79)"]
fn the_loop_finds_a_scale_asymmetry_without_a_program() {
    let hidden = HiddenEffects {
        values: vec![
            ("gyro.asym.x".into(), 2e-5),
            ("gyro.asym.y".into(), -1.5e-5),
            ("gyro.asym.z".into(), 1e-5),
        ],
        gyro_drift: None,
    };
    assert_eq!(
        accepted(703, &hidden),
        vec!["gyro_scale_asymmetry".to_string()]
    );
}

/// A gyro bias random walk of 0.3 deg/h/sqrt(h) on every axis (a tactical FOG's, the top of the
/// navigation grade's grid) on the 19-position recording (9.5 min). Size and seed (704) fixed
/// before the first run.
///
/// FAILS, as first run: nothing accepted and the paper's model fits (the walk's likelihood
/// ratio p = 0.23). In 9.5 min such a walk moves a bias by about 0.1 deg/h, a fifth of its
/// prior; the recording does not show it.
#[test]
#[ignore = "fails as first run: a 0.3 deg/h/sqrt(h) walk leaves no trace in 9.5 min (p = 0.23)"]
fn the_loop_finds_a_gyro_bias_walk_without_a_program() {
    let q = 0.3 * sins_model::units::DEG_PER_HOUR / 60.0;
    let hidden = HiddenEffects {
        values: vec![],
        gyro_drift: Some([q; 3]),
    };
    assert_eq!(accepted(704, &hidden), vec!["gyro_bias_drift".to_string()]);
}
