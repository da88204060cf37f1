//! The verdict on the cases issue 40 names, each on its own simulated recording (seeds 4001-4004
//! fixed before the runs): a recording of rests calibrated as `calibrate --free-motion` does
//! without a configuration (noise, grade and priors measured from the recording, every fourth
//! rest held out) must exit 3 naming the term hidden in it; the same noise-free data with the
//! right model and a configured noise larger than theirs must exit 0.

use crate::hand_turned::{calibrate, from_data};
use calib::estimate::calibration::Calibration;
use calib::estimate::{HandTurnedRun, Plan, Records, RunKind};
use calib::io::ImuData;
use calib::model::extension::{HiddenEffects, ModelExtension};
use calib::model::layout::layout_with;
use sins_model::candidates::Candidate;
use turntable::program::{ProgramSpec, Segment};

/// The 19 positions of `operating` and three more (a turn about each gimbal): 22 poses, as the
/// consumer recordings the issue tried.
fn twenty_two_positions() -> ProgramSpec {
    let mut p = workspace_tests::operating::nineteen_positions();
    for (gimbal, rate_deg_s) in [(1, -10.0), (3, 10.0), (2, 10.0)] {
        p.segments.push(Segment::Rotate {
            gimbal,
            rate_deg_s,
            duration_s: 9.0,
        });
        p.segments.push(Segment::Dwell { duration_s: 20.0 });
    }
    p.name = "22 positions".into();
    p
}

fn hidden(values: &[(&str, f64)]) -> HiddenEffects {
    HiddenEffects {
        values: values.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
        gyro_drift: None,
    }
}

/// A consumer-grade recording of 22 rests with `hidden` in it, calibrated without a
/// configuration, every fourth rest held out.
fn consumer_22(seed: u64, hidden: &HiddenEffects) -> (Calibration, f64) {
    consumer_22_turning(seed, 1.0, hidden)
}

/// [`consumer_22`] with every turn's rate (and angle) times `turn`.
fn consumer_22_turning(seed: u64, turn: f64, hidden: &HiddenEffects) -> (Calibration, f64) {
    let mut truth = crate::rests::consumer_config(seed);
    truth.truth.imu_rate_hz = 25.0;
    truth.filter.imu_rate_hz = 25.0;
    let mut program = twenty_two_positions();
    for s in &mut program.segments {
        if let Segment::Rotate { rate_deg_s, .. } = s {
            *rate_deg_s *= turn;
        }
    }
    truth.inline_program = Some(program);
    let sim = calib::simulate::simulate_run_hidden(&truth, "22 positions", hidden).unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let rests = crate::rests::rests(&truth);
    assert_eq!(rests.len(), 22);
    let (own, noise) = from_data(&truth, &imu, &rests);
    let c = calibrate(&own, &imu, &rests, Some(4), Some(noise));
    let worst = workspace_tests::operating::worst_base_error(&c.estimate, &sim.truth);
    println!("seed {seed}: worst base error {worst:?}");
    (c, worst.map_or(0.0, |w| w.1.abs()))
}

/// Exit 3, a decisive line calling for `term`.
fn assert_named(c: &Calibration, term: &str) {
    let v = &c.verdict;
    println!("{term}: {:#?}\n{:#?}", v.decisive, v.informative);
    assert!(!v.fits(), "exit 0: {v:?}");
    assert!(
        v.decisive
            .iter()
            .any(|l| l.contains(&format!("call for {term}"))),
        "{term} not named: {:?}",
        v.decisive
    );
}

/// A gyro g-sensitivity of 100 deg/h/g, what a consumer gyro's data sheet allows (the issue:
/// added to a real 22-pose recording it ended in exit 0 with nothing named). It must be called
/// for, and either decide (exit 3) or leave every base parameter within 3.5 sigma of the truth
/// (the verdict's rule: a term that moves nothing by 3 sigma is a finding). Seed 4001: called at
/// p = 5e-70, its seen part moves `gyro.theta.zz` 1.8 sigma, the worst base error is 3.2 sigma:
/// a finding, exit 0.
#[test]
fn a_consumer_g_sensitivity_is_called_for() {
    let per_g = 100.0 * sins_model::units::DEG_PER_HOUR / 9.81;
    let (c, worst) = consumer_22(
        4001,
        &hidden(&[
            ("gyro.gsens.xy", per_g),
            ("gyro.gsens.yx", -per_g),
            ("gyro.gsens.zx", per_g),
            ("gyro.gsens.zy", -per_g),
            ("gyro.gsens.xz", per_g),
        ]),
    );
    let v = &c.verdict;
    let call = "the data call for gyro_g_sensitivity";
    if v.fits() {
        assert!(v.informative.iter().any(|l| l.starts_with(call)), "{v:?}");
        assert!(
            worst < 3.5,
            "exit 0 with a base parameter {worst} sigma off"
        );
    } else {
        assert_named(&c, "gyro_g_sensitivity");
    }
}

/// A gyro scale asymmetry of 0.5 % on each axis. On the 90-degree turns it is 0.45 degree a
/// turn against the 0.3 degree the measured motion noise allows (its test: p = 0.063, base
/// parameters 5.3 sigma off at `gyro.theta.xx`): the run cannot see it, and the verdict names it
/// as a blind spot whose bound covers the error. Hand turns of 270 degrees (below) show it.
#[test]
fn a_consumer_scale_asymmetry_on_quarter_turns_is_a_named_blind_spot() {
    let (c, _) = consumer_22(
        4002,
        &hidden(&[
            ("gyro.asym.x", 0.005),
            ("gyro.asym.y", -0.005),
            ("gyro.asym.z", 0.005),
        ]),
    );
    let v = &c.verdict;
    assert!(
        !v.fits()
            || v.informative.iter().any(|l| l.starts_with("blind spots")
                && l.contains("gyro_scale_asymmetry (gyro.theta.xx by up to")),
        "{v:?}"
    );
}

/// The same asymmetry on 22 poses joined by three-quarter turns (270 degrees, 1.35 degree of
/// asymmetry a turn; half turns were tried first: their poses face only two directions, which
/// `calibrate` refuses): exit 3 naming it.
///
/// Failed at first (seed 4002): the score test gave p = 0.007 against the 0.0025 it must beat,
/// exit 0 with `accel.gamma.yx` 8 sigma off, the asymmetry named only as a blind spot. The
/// motion noise measured from the fit's own innovations takes the misfit in (held-out rotation
/// over a motion 1.03 degree against 0.79 on the fitted motions; with no known turn nothing
/// measures a motion's rotation absolutely), and the score test is made at that noise. The
/// gyro terms are now tested where the motion noise is measured above zero by the likelihood
/// ratio of a fit with the term, its noise measured again (`calib::estimate::motion_terms`):
/// 75.7 for 3 parameters, p = 2.6e-16. On the quarter turns above the ratio is 5.6 (p = 0.14):
/// still a blind spot there.
#[test]
fn a_consumer_scale_asymmetry_on_long_turns_is_named() {
    let (c, _) = consumer_22_turning(
        4002,
        3.0,
        &hidden(&[
            ("gyro.asym.x", 0.005),
            ("gyro.asym.y", -0.005),
            ("gyro.asym.z", 0.005),
        ]),
    );
    assert_named(&c, "gyro_scale_asymmetry");
}

/// Noise-free navigation-grade 19-position data with an accelerometer quadratic term of 10, 20
/// and 30 ug/g^2: without a configuration (the noise measured from the data, which then carry
/// the misfit as noise) the verdict must still name the term (the issue: exit 0 with the
/// accelerometer biases 52-107 sigma off).
#[test]
fn a_quadratic_term_in_noise_free_data_is_named() {
    let (truth, imu, rests) = noise_free_quadratic(4003);
    let (own, noise) = from_data(&truth, &imu, &rests);
    let c = calibrate(&own, &imu, &rests, Some(4), Some(noise));
    assert_named(&c, "accel_quadratic");
}

/// The same data with the right model (the quadratic term in it) and the configuration's
/// navigation-grade noise, far above the data's (none): conservative sigmas contradict nothing.
#[test]
fn the_right_model_with_overstated_noise_exits_0() {
    let (truth, imu, rests) = noise_free_quadratic(4003);
    let mut config = truth.clone();
    config.inline_program = None;
    let layout = layout_with(
        &config,
        false,
        &ModelExtension::with(&[Candidate::AccelQuadratic]),
    );
    let run = HandTurnedRun {
        rests: &rests,
        turns: &[],
        holdout: Some(4),
        measured: None,
    };
    let plan = Plan {
        config: &config,
        layout: Some(&layout),
        kind: RunKind::HandTurned(run),
    };
    let records = Records::Streamed {
        imu: &mut calib::estimate::MemoryImu::new(&imu, "imu.csv"),
        turntable: None,
    };
    let c = calib::estimate::run(plan, records, &mut |_, _| {}).unwrap();
    let v = &c.verdict;
    println!("{:#?}\n{:#?}", v.decisive, v.informative);
    assert!(v.fits(), "exit 3: {v:?}");
    assert!(
        v.informative
            .iter()
            .any(|l| l.starts_with("the configured noise is larger than the data's")),
        "{v:?}"
    );
}

fn noise_free_quadratic(
    seed: u64,
) -> (
    calib::config::RunConfig,
    ImuData,
    Vec<calib::motion::rests::Rest>,
) {
    let mut truth = crate::rests::config(seed);
    truth.truth.imu_rate_hz = 25.0;
    truth.filter.imu_rate_hz = 25.0;
    truth.truth.noise = false;
    let g = 9.81;
    let sim = calib::simulate::simulate_run_hidden(
        &truth,
        "19 positions",
        &hidden(&[
            ("accel.k2.x", 10e-6 / g),
            ("accel.k2.y", 20e-6 / g),
            ("accel.k2.z", 30e-6 / g),
        ]),
    )
    .unwrap();
    let rests = crate::rests::rests(&truth);
    (truth, ImuData::from_samples(&sim.imu), rests)
}
