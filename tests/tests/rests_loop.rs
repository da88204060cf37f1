//! The model-extension loop on recordings of rests without a program
//! (`calib::extend::run_loop_at_rests`): the 19-position run of `rests.rs` at 25 Hz with
//! hidden effects, and clean controls.
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
//! 760-779: no term accepted on at least 19 of 20 (measured: none on 20; of the 20 final
//! models two were said not to fit before the trajectory was re-levelled to the data, one,
//! seed 765, after).
//!
//! Added for the candidates this recording cannot show at the sizes first tried (a scale
//! asymmetry and a gyro bias walk; see each test): a tactical-grade recording turned both ways
//! about every axis ([`both_ways_config`]), sizes chosen from its covariance before a loop was
//! run on it: the asymmetry (seed 705) is found; the clean control on it (seed 706) accepts
//! nothing (its final model was said not to fit); the walk, after three failed first runs
//! (seeds 704, 707 and 708; see the test), on at least 8 of 10 fresh seeds (741-750).
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
use calib::estimate::MemoryImu;
use calib::extend::{LoopSettings, run_loop_at_rests};
use calib::io::ImuData;
use calib::model::extension::HiddenEffects;
use calib::motion::rests::Rest;

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
    let mut data = MemoryImu::new(&imu, "imu.csv");
    let mut lines = vec![];
    let result = run_loop_at_rests(
        config,
        &mut data,
        &rests,
        &[],
        &LoopSettings::default(),
        &mut |l| lines.push(l.to_string()),
    )
    .unwrap();
    check_progress(&lines, &result);
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

/// The progress lines of each round's candidates say which of how many is being fitted:
/// `round R, candidate I of N: ...`, I counting 1..=N in order, N the candidates the round
/// reports.
fn check_progress(lines: &[String], result: &calib::extend::LoopResult) {
    let mut seen: Vec<Vec<(usize, usize)>> = vec![vec![]; result.rounds.len()];
    for l in lines.iter().filter(|l| l.starts_with("round ")) {
        let (place, _) = l
            .split_once(": ")
            .expect("a colon after the candidate's place");
        let n: Vec<usize> = place
            .split(|c: char| !c.is_ascii_digit())
            .filter(|w| !w.is_empty())
            .map(|w| w.parse().unwrap())
            .collect();
        assert_eq!(n.len(), 3, "{l}");
        assert!(n[0] >= 1 && n[0] <= result.rounds.len(), "{l}");
        let round = &mut seen[n[0] - 1];
        if round.last().is_none_or(|&(i, _)| i != n[1]) {
            round.push((n[1], n[2]));
        }
    }
    for (k, (seen, round)) in seen.iter().zip(&result.rounds).enumerate() {
        let planned = round.candidates.len();
        let expected: Vec<(usize, usize)> = (1..=planned).map(|i| (i, planned)).collect();
        assert_eq!(seen, &expected, "round {}: {lines:?}", k + 1);
    }
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

/// A tactical-grade unit (gyro-bias prior 10 deg/h, so the candidates take the tactical
/// priors of `sins_model::candidates::Candidate::prior_sigma`) on a 19-position recording whose
/// turns go there and back about every body axis while it is horizontal: pitch up, the bank
/// gimbal both ways (about the body z axis), pitch back, the bank gimbal both ways (y), the
/// pitch gimbal both ways (x), the heading gimbal both ways. A turn of +90 degrees leaves
/// `(theta_ii + a_i) pi/2` about the axis, one of -90 degrees `(-theta_ii + a_i) pi/2`: only
/// turns both ways about a horizontal axis tell the asymmetry from the scale factor.
pub fn both_ways_config(seed: u64) -> RunConfig {
    let turns: [(u8, f64); 18] = [
        (3, 10.0),
        (2, 10.0),
        (2, -10.0),
        (2, -10.0),
        (2, 10.0),
        (3, -10.0),
        (2, 10.0),
        (2, -10.0),
        (2, -10.0),
        (2, 10.0),
        (3, -10.0),
        (3, 10.0),
        (3, 10.0),
        (3, -10.0),
        (1, 10.0),
        (1, -10.0),
        (1, -10.0),
        (1, 10.0),
    ];
    let mut c = config(seed);
    let path = std::path::Path::new(&c.program).with_file_name(format!("both-ways-{seed}.toml"));
    std::fs::write(&path, crate::rests::positions_program(&turns)).unwrap();
    c.program = path.display().to_string();
    c.priors.gyro_bias_deg_h = 10.0;
    c
}

fn accepted_both_ways(seed: u64, hidden: &HiddenEffects) -> Vec<String> {
    let config = both_ways_config(seed);
    run(&config, &config, hidden).0
}

/// A gyro scale-factor asymmetry on a recording that separates it ([`both_ways_config`]).
///
/// History: the first test of this term put the programmed tests' navigation-grade
/// asymmetry (2e-5, -1.5e-5, 1e-5) into the 19-position recording of the other tests (seed
/// 703), and it failed as first run: nothing accepted, p = 0.79. That recording cannot show
/// it: its x and z turns go one way while the axis is horizontal, so `gyro.asym.x` and `.z`
/// are confounded with `gyro.theta.xx` and `.zz` (posterior correlations -0.9996 and 0.999, the
/// separability analysis calls the term inseparable), and `.y`, the one it separates, has a
/// data-only sigma of 2e-5, larger than the effect. The recording and size below were then
/// chosen from the covariance of the fit alone, before any loop was run on them: with the
/// tactical prior (1e-3) the fit of a clean run of this recording gives the asymmetry sigmas of
/// 7.6e-6, 8.4e-6 and 1.3e-5, no entry confounded; the effect is 1e-4 on each axis (signs +, -,
/// +), the low end of a tactical MEMS gyro (100 to 1000 ppm, `Candidate::typical`), 8 to 13 of
/// those sigmas. Seed 705; the loop must accept `gyro_scale_asymmetry` and nothing else. The
/// clean control on the same recording and grade: seed 706, nothing accepted.
#[test]
fn the_loop_finds_a_scale_asymmetry_without_a_program() {
    let hidden = HiddenEffects {
        values: vec![
            ("gyro.asym.x".into(), 1e-4),
            ("gyro.asym.y".into(), -1e-4),
            ("gyro.asym.z".into(), 1e-4),
        ],
        gyro_drift: None,
    };
    assert_eq!(
        accepted_both_ways(705, &hidden),
        vec!["gyro_scale_asymmetry".to_string()]
    );
}

#[test]
fn the_loop_accepts_nothing_on_a_clean_tactical_recording_turned_both_ways() {
    assert!(accepted_both_ways(706, &HiddenEffects::default()).is_empty());
}

/// A gyro bias random walk on the tactical recording of [`both_ways_config`], over ten seeds.
///
/// History, three first runs that failed:
/// - A walk of 0.3 deg/h/sqrt(h) (a navigation-grade unit's largest) in the navigation-grade
///   19-position recording, seed 704: nothing accepted (likelihood ratio p = 0.23). Its
///   expected statistic there, with the program known, is 5.1 against the threshold 8.6
///   (`calib::extend::drift_visibility`).
/// - 1 deg/h/sqrt(h) on this recording (expected statistic 89 with the program known), seed
///   707: 4.4 without the program, 10.3 with it. The expected statistic is the mean of a
///   skewed distribution, so the size was then taken from a pilot on seeds of its own
///   (790-799, never a test's) with a rule fixed before it ran: the smallest of 2 and 3
///   deg/h/sqrt(h) at which the loop accepts the walk alone on at least 9 of the 10.
/// - The pilot showed the walk called first at p = 1e-88 to 1e-10 and refused by the held-out
///   check on four runs (gains -0.27 to -0.87 nats), and a clean run (793) whose first pass
///   diverged (fixed: the filter of a recording of rests, `calib::estimate::at_rests`, feeds back
///   only the tilt where the heading is free). With the check refusing only a loss of more than one
///   nat (`calib::extend::HELD_OUT_TOLERANCE_NATS`) the pilot gave 9 of 10 at 3 deg/h/sqrt(h), and
///   the test at seed 708 failed: the walk called at p = 2e-25 and refused at -1.42.
///
/// Over the pilot and 708 the walk's held-out gain ran from -1.42 to +1.60 nats, unrelated to
/// how strongly it was called: the check has no power on a walk, and it no longer decides on
/// one (`calib::extend::held_out_decides`; it is reported). This test was then fixed before it
/// ran, on seeds none of the above used: 3 deg/h/sqrt(h) on every axis (the top of the
/// tactical drift grid), seeds 741-750; the loop must accept `gyro_bias_drift` and nothing
/// else on at least 8 of the 10.
#[test]
fn the_loop_finds_a_gyro_bias_walk_without_a_program() {
    let q = 3.0 * sins_model::units::DEG_PER_HOUR / 60.0;
    let hidden = HiddenEffects {
        values: vec![],
        gyro_drift: Some([q; 3]),
    };
    let seeds: Vec<u64> = (741..751).collect();
    let runs = workspace_tests::parallel_map(&seeds, |&seed| accepted_both_ways(seed, &hidden));
    let found = runs
        .iter()
        .filter(|t| *t == &vec!["gyro_bias_drift".to_string()])
        .count();
    assert!(
        found >= 8,
        "the walk alone accepted on {found} of 10: {runs:?}"
    );
}

/// Rests with a warm-up (20 -> 35 deg C, time constant 900 s; `workspace_tests::hidden`): an
/// accelerometer bias temperature coefficient of 2 ug/K per axis (signs +, -, +), seed 790, is
/// accepted first; the same warm-up without it, seed 791, accepts no thermal term. The rests
/// last 120 s (41 minutes in all): with the 20-s rests of the other tests (9 minutes, 7 K of the
/// warm-up, each rest's mean 22 ug noisy) seed 790 showed the term at p = 0.18 only, which no
/// loop can call (tried first; the recording, not the seed, was changed).
#[test]
fn the_loop_finds_an_accelerometer_temperature_coefficient_in_a_warm_up_without_a_program() {
    let warm = |seed| {
        let mut c = crate::rests::config_with_rests(seed, 120.0);
        c.truth.imu_rate_hz = 25.0;
        c.filter.imu_rate_hz = 25.0;
        c.temperature = Some(workspace_tests::hidden::warm_up());
        c
    };
    let c = warm(790);
    let hidden = HiddenEffects {
        values: vec![
            ("accel.tbias.x".into(), 2e-5),
            ("accel.tbias.y".into(), -2e-5),
            ("accel.tbias.z".into(), 2e-5),
        ],
        gyro_drift: None,
    };
    let (terms, _) = run(&c, &c, &hidden);
    assert_eq!(terms.first().map(String::as_str), Some("accel_temp_bias"));
    let c = warm(791);
    let (terms, _) = run(&c, &c, &HiddenEffects::default());
    assert!(
        !terms.iter().any(|t| t.contains("temp")),
        "no thermal effect, accepted {terms:?}"
    );
}
