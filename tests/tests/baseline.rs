//! The filter of a recording of rests against the simplest baseline (issue 42): a plain
//! least-squares fit of `|f| = g` (`calib::motion::free_motion::accel_baseline`: accelerometer
//! biases and the lower-triangular `Gamma`, nine parameters) to the same fitted rests' means,
//! both judged on the held-out rests' static `|f| - g` as `calibrate --free-motion --holdout 4`
//! reports it. The filter has everything the baseline has and the rotations between the poses
//! besides: it must never be worse by more than 5 %.
//!
//! The recordings are hand-turned-like: 20-50 poses reached by random turns about one or two
//! gimbals, each held 2-20 s, simulated at 25 Hz, calibrated as `calibrate --free-motion`
//! without a configuration does (noise, grade and priors from the recording). Seeds fixed
//! before the runs were looked at: 4201-4203 (consumer, tactical, navigation grade) in CI.

use crate::hand_turned::{calibrate, from_data};
use calib::config::RunConfig;
use calib::io::ImuData;
use calib::motion::free_motion::{EarthRotation, Validation, accel_baseline, evaluate};
use calib::motion::rests::{Rest, held_out};
use rand::{RngExt, SeedableRng};
use turntable::program::{ProgramSpec, Segment};

/// The grades of the simulated units.
#[derive(Clone, Copy, Debug)]
pub enum Grade {
    Consumer,
    Tactical,
    Navigation,
}

/// `poses` rests of 2-20 s, reached by random turns of 60-150 deg about one or two gimbals at
/// 30-90 deg/s.
pub fn random_poses(seed: u64, poses: usize) -> ProgramSpec {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut segments = vec![Segment::Dwell {
        duration_s: rng.random_range(2.0..20.0),
    }];
    for _ in 1..poses {
        let turns = rng.random_range(1..=2);
        let mut last = 0;
        for _ in 0..turns {
            let mut gimbal = rng.random_range(1..=3u8);
            while gimbal == last {
                gimbal = rng.random_range(1..=3u8);
            }
            last = gimbal;
            let rate = rng.random_range(30.0..90.0) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            let angle: f64 = rng.random_range(60.0..150.0);
            segments.push(Segment::Rotate {
                gimbal,
                rate_deg_s: rate,
                duration_s: angle / rate.abs(),
            });
        }
        segments.push(Segment::Dwell {
            duration_s: rng.random_range(2.0..20.0),
        });
    }
    ProgramSpec {
        name: format!("{poses} random poses"),
        start_deg: [0.0; 3],
        segments,
    }
}

/// A unit of `grade` turned into `poses` random poses.
pub fn truth(grade: Grade, seed: u64, poses: usize) -> RunConfig {
    let mut c = match grade {
        Grade::Consumer => crate::rests::consumer_config(seed),
        Grade::Navigation => crate::rests::config(seed),
        Grade::Tactical => {
            let mut c = crate::rests::config(seed);
            c.priors.gyro_bias_deg_h = 20.0;
            c.priors.gyro_scale = 1e-3;
            c.priors.gyro_misalignment_arcmin = 10.0;
            c.priors.accel_bias_m_s2 = 0.02;
            c.priors.accel_scale = 1e-3;
            c.priors.accel_misalignment_arcmin = 10.0;
            c.noise.gyro_deg_h = 10.0;
            c.noise.accel_m_s2 = 4e-4;
            c
        }
    };
    c.truth.imu_rate_hz = 25.0;
    c.filter.imu_rate_hz = 25.0;
    c.inline_program = Some(random_poses(seed, poses));
    c
}

/// The filter's and the baseline's held-out figures on one recording.
#[derive(Debug)]
pub struct Comparison {
    pub filter: Validation,
    pub baseline: Validation,
    /// The filter's accelerometer parameters (value, sigma) in [`ACCEL_NAMES`] order.
    pub filter_accel: Vec<(f64, f64)>,
    /// The baseline's.
    pub baseline_accel: [f64; 9],
    /// Mean squared error over the filter's sigma of the filter's and the baseline's
    /// accelerometer parameters (against a truth, where known).
    pub z2: (f64, f64),
    /// The calibration's own figures: the baseline's held-out figure as the calibration
    /// reports it, and its verdict.
    pub reported_baseline: Option<calib::motion::free_motion::BaselineFigures>,
    /// See `reported_baseline`.
    pub verdict: calib::estimate::verdict::RunVerdict,
    /// The error the rests' windows share, as the calibration measured it (m/s^2; 0 where
    /// the rests could not tell it).
    pub rest_error_m_s2: f64,
    /// Whether it was weighed unasked (`RestExcess::weighed_unasked`).
    pub weighed_unasked: bool,
    /// The candidate terms tested by a likelihood ratio (`calib::estimate::motion_terms`).
    pub likelihood_ratios: usize,
}

/// The paper's accelerometer parameters in the baseline's order.
pub const ACCEL_NAMES: [&str; 9] = [
    "accel.bias.x",
    "accel.bias.y",
    "accel.bias.z",
    "accel.gamma.xx",
    "accel.gamma.yx",
    "accel.gamma.yy",
    "accel.gamma.zx",
    "accel.gamma.zy",
    "accel.gamma.zz",
];

impl Comparison {
    /// Filter's held-out static RMS over the baseline's.
    pub fn static_ratio(&self) -> f64 {
        self.filter.static_rms_after_m_s2 / self.baseline.static_rms_after_m_s2
    }
}

/// `calibrate --free-motion --holdout 4` without a configuration, and the baseline fitted to
/// the same rests, on `imu` with `rests`; `latitude_deg` for the rotation figures.
pub fn compare(truth: &RunConfig, imu: &ImuData, rests: &[Rest]) -> Comparison {
    compare_on(truth, imu, rests, imu, false)
}

/// [`compare`] with the held-out figures taken on `judged` (the same recording without noise:
/// the parameters' errors alone); with `weigh`, calibrated again with the rests' excess the
/// first calibration measured weighed (`--rest-error`, as its report advises).
pub fn compare_on(
    truth: &RunConfig,
    imu: &ImuData,
    rests: &[Rest],
    judged: &ImuData,
    weigh: bool,
) -> Comparison {
    let holdout = Some(4);
    let (mut own, noise) = from_data(truth, imu, rests);
    // As the command line does without `--rest-error`: the excess weighed where the rests
    // show it.
    let mut source = calib::estimate::MemoryImu::new(imu, "imu.csv");
    let unasked = calib::estimate::hand_turned::weigh_rest_excess_unasked(
        &mut own,
        &mut source,
        rests,
        &noise,
        holdout,
    )
    .unwrap();
    let mut c = calibrate(&own, imu, rests, holdout, Some(noise));
    let excess = c.evaluation.as_ref().and_then(|e| e.rest_excess_m_s2);
    if let Some(x) = excess.filter(|&x| weigh && unasked.is_none() && x > 0.0) {
        own.filter.rest_error_m_s2 = x;
        c = calibrate(&own, imu, rests, holdout, Some(noise));
    }
    let g = c.estimate.gravity_m_s2;
    let t: Vec<f64> = imu.records.iter().map(|r| r.t).collect();
    let earth = EarthRotation::at(truth.site.latitude_deg.to_radians(), 1.0);
    let filter_correction =
        calib::model::correction::Correction::of_result(&c.estimate.to_result_file()).unwrap();
    let filter = evaluate(
        &mut calib::estimate::MemoryImu::new(judged, "imu.csv"),
        &t,
        rests,
        &[],
        holdout,
        g,
        &earth,
        &filter_correction,
    )
    .unwrap()
    .validation
    .unwrap();
    let fitted: Vec<Rest> = rests
        .iter()
        .enumerate()
        .filter(|(i, _)| !held_out(*i, holdout))
        .map(|(_, r)| *r)
        .collect();
    let fit = accel_baseline(imu, &fitted, g).unwrap();
    let correction = fit.correction;
    let baseline = evaluate(
        &mut calib::estimate::MemoryImu::new(judged, "imu.csv"),
        &t,
        rests,
        &[],
        holdout,
        g,
        &earth,
        &correction,
    )
    .unwrap()
    .validation
    .unwrap();
    let filter_accel = ACCEL_NAMES
        .iter()
        .map(|n| (c.estimate.value(n).unwrap(), c.estimate.sigma(n).unwrap()))
        .collect();
    Comparison {
        filter,
        baseline,
        filter_accel,
        baseline_accel: fit.parameters,
        z2: (0.0, 0.0),
        reported_baseline: c.evaluation.as_ref().and_then(|e| e.baseline),
        rest_error_m_s2: excess.unwrap_or(0.0),
        weighed_unasked: unasked.is_some(),
        likelihood_ratios: c.estimate.likelihood_ratios.len(),
        verdict: c.verdict,
    }
}

/// One simulated recording of `grade` with `poses` poses compared.
pub fn simulated(grade: Grade, seed: u64, poses: usize) -> Comparison {
    simulated_judged(grade, seed, poses, true)
}

/// [`simulated`], judged on the noisy recording or on the same without noise.
pub fn simulated_judged(grade: Grade, seed: u64, poses: usize, noisy: bool) -> Comparison {
    simulated_with_rest_error(grade, seed, poses, noisy, 0.0, false)
}

/// Add to every record of each rest of `rests` one offset of the specific force drawn for
/// that rest (normal, `sigma_m_s2` per axis; seeded with `seed`): an error the windows of one
/// rest share (a mount not the same twice, settling).
pub fn add_rest_error(imu: &mut ImuData, rests: &[Rest], sigma_m_s2: f64, seed: u64) {
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut previous_t: Option<f64> = None;
    let offsets: Vec<[f64; 3]> = rests
        .iter()
        .map(|_| {
            let mut o = [0.0; 3];
            for v in &mut o {
                let z: f64 = StandardNormal.sample(&mut rng);
                *v = sigma_m_s2 * z;
            }
            o
        })
        .collect();
    for r in &mut imu.records {
        let dt = previous_t.map_or(0.0, |p| r.t - p);
        previous_t = Some(r.t);
        if let Some(k) = rests.iter().position(|x| x.t0 < r.t && r.t <= x.t1) {
            for (a, o) in r.accel.iter_mut().zip(offsets[k]) {
                *a += o * dt;
            }
        }
    }
}

/// [`simulated_judged`] with an error of `rest_error_m_s2` shared by each rest's records
/// ([`add_rest_error`]) in the fitted recording and in the judged one alike.
pub fn simulated_with_rest_error(
    grade: Grade,
    seed: u64,
    poses: usize,
    noisy: bool,
    rest_error_m_s2: f64,
    weigh: bool,
) -> Comparison {
    let truth = truth(grade, seed, poses);
    let sim = calib::simulate::simulate_run(&truth, "random poses").unwrap();
    let mut imu = ImuData::from_samples(&sim.imu);
    let rests_of_truth = crate::rests::rests(&truth);
    add_rest_error(&mut imu, &rests_of_truth, rest_error_m_s2, seed);
    let rests = crate::rests::rests(&truth);
    assert_eq!(rests.len(), poses);
    let mut quiet = truth.clone();
    quiet.truth.noise = noisy;
    let judged = ImuData::from_samples(
        &calib::simulate::simulate_run(&quiet, "random poses")
            .unwrap()
            .imu,
    );
    let mut c = simulated_report(
        grade,
        seed,
        poses,
        compare_on(&truth, &imu, &rests, &judged, weigh),
    );
    for (k, n) in ACCEL_NAMES.iter().enumerate() {
        let t = sim.truth.get(n).unwrap();
        let (v, s) = c.filter_accel[k];
        c.z2.0 += ((v - t) / s).powi(2) / 9.0;
        c.z2.1 += ((c.baseline_accel[k] - t) / s).powi(2) / 9.0;
        println!(
            "  {n:16} truth {t:+.3e} filter {:+6.2} sigma, baseline {:+6.2} (filter sigma {s:.2e})",
            (v - t) / s,
            (c.baseline_accel[k] - t) / s
        );
    }
    c
}

#[test]
#[ignore]
fn explain_one() {
    simulated(Grade::Consumer, 4232, 50);
    simulated(Grade::Tactical, 4232, 50);
}

/// The consumer recording of the fresh seeds where the filter lost most (seed 6015, 21 poses),
/// judged without noise as the survey judges it.
#[test]
#[ignore]
fn explain_seed_6015() {
    simulated_with_rest_error(Grade::Consumer, 6015, 21, false, 0.0, false);
}

fn simulated_report(grade: Grade, seed: u64, poses: usize, c: Comparison) -> Comparison {
    println!(
        "{grade:?} seed {seed}, {poses} poses: held-out static filter {:.6} baseline {:.6} m/s^2 \
         (ratio {:.3}); held-out rotation filter {:.4} deg; rest error measured {:.2e} m/s^2",
        c.filter.static_rms_after_m_s2,
        c.baseline.static_rms_after_m_s2,
        c.static_ratio(),
        c.filter.rotation_rms_after_rad.to_degrees(),
        c.rest_error_m_s2,
    );
    c
}

/// The survey behind the bound (`--ignored`): every grade at 20, 35 and 50 poses, seeds
/// 4210-4219.
#[test]
#[ignore]
fn survey_filter_against_baseline() {
    let mut worst: (f64, String) = (0.0, String::new());
    for grade in [Grade::Consumer, Grade::Tactical, Grade::Navigation] {
        for (k, poses) in [20, 35, 50].into_iter().enumerate() {
            for seed in 4210..4214 {
                let c = simulated(grade, seed + 10 * k as u64, poses);
                if c.static_ratio() > worst.0 {
                    worst = (
                        c.static_ratio(),
                        format!("{grade:?} seed {seed} {poses} poses"),
                    );
                }
            }
        }
    }
    println!("worst ratio {worst:?}");
}

#[test]
#[ignore]
fn many_seeds() {
    many_seeds_with(0.0, false);
    many_seeds_with(0.0, true);
}

#[test]
#[ignore]
fn many_seeds_with_rest_error() {
    many_seeds_with(1e-3, false);
    many_seeds_with(1e-3, true);
}

/// The unasked weighing of the rests' excess (`RestExcess::weighed_unasked`) checked on seeds
/// it was not chosen on (6000-6059, fixed before the run; the gate was set on 5000-5059).
#[test]
#[ignore]
fn many_seeds_fresh() {
    many_seeds_in(6000..6060, 0.0, false);
    many_seeds_in(6000..6060, 1e-3, false);
}

fn many_seeds_with(rest_error_m_s2: f64, weigh: bool) {
    many_seeds_in(5000..5060, rest_error_m_s2, weigh);
}

fn many_seeds_in(seeds: std::ops::Range<u64>, rest_error_m_s2: f64, weigh: bool) {
    println!("SUMMARY rest error {rest_error_m_s2:e}, weighed {weigh}, seeds {seeds:?}");
    for grade in [Grade::Consumer, Grade::Tactical, Grade::Navigation] {
        let mut ratios = Vec::new();
        let mut filt = 0.0;
        let mut base = 0.0;
        let mut z2 = (0.0, 0.0);
        let (mut trend_fails, mut trend_decides) = (0, 0);
        let (mut exits_3, mut ratio_runs, mut ratio_calls) = (0, 0, 0);
        let mut unasked = 0;
        let mut rest_error = 0.0;
        for seed in seeds.clone() {
            let poses = 20 + (seed as usize % 31);
            let c = simulated_with_rest_error(grade, seed, poses, false, rest_error_m_s2, weigh);
            rest_error += c.rest_error_m_s2.powi(2) / 60.0;
            unasked += c.weighed_unasked as usize;
            ratios.push(c.static_ratio());
            let trend = c.verdict.tests.iter().find(|t| t.name == "trend").unwrap();
            trend_fails += trend.fails as usize;
            trend_decides += trend.decides as usize;
            exits_3 += usize::from(!c.verdict.fits());
            ratio_runs += usize::from(c.likelihood_ratios > 0);
            ratio_calls += usize::from(
                c.verdict
                    .decisive
                    .iter()
                    .chain(&c.verdict.informative)
                    .any(|l| l.starts_with("the data call") && l.contains("likelihood ratio")),
            );
            z2.0 += c.z2.0 / 60.0;
            z2.1 += c.z2.1 / 60.0;
            filt += c.filter.static_rms_after_m_s2.powi(2);
            base += c.baseline.static_rms_after_m_s2.powi(2);
        }
        let n = ratios.len() as f64;
        let worse = ratios.iter().filter(|r| **r > 1.05).count();
        let mean_log = ratios.iter().map(|r| r.ln()).sum::<f64>() / n;
        println!(
            "SUMMARY {grade:?}: rest error measured, RMS {:.2e} m/s^2 (truth {rest_error_m_s2:.1e})",
            rest_error.sqrt()
        );
        println!(
            "SUMMARY {grade:?}: trend significant {trend_fails}/60, decisive {trend_decides}/60"
        );
        println!("SUMMARY {grade:?}: excess weighed unasked on {unasked}/60");
        println!(
            "SUMMARY {grade:?}: exit 3 on {exits_3}/60; a gyro term tested by the likelihood \
             ratio on {ratio_runs}/60, called for on {ratio_calls}/60"
        );
        println!(
            "SUMMARY {grade:?}: mean z^2 filter {:.2} baseline {:.2}",
            z2.0, z2.1
        );
        println!(
            "SUMMARY {grade:?}: {worse}/{n} worse by >5 %, geometric mean ratio {:.3}, pooled rms filter {:.3e} baseline {:.3e}",
            mean_log.exp(),
            (filt / n).sqrt(),
            (base / n).sqrt()
        );
    }
}

/// Pooled over six recordings of each grade (seeds 4201-4206, 20-45 poses), the filter's
/// held-out static `|f| - g` is no worse than the baseline's by more than 5 %; the figure the
/// calibration reports for the baseline is the one computed here.
#[test]
fn pooled_over_recordings_the_filter_is_not_worse_than_the_baseline() {
    for grade in [Grade::Consumer, Grade::Tactical, Grade::Navigation] {
        let (mut filter, mut baseline) = (0.0, 0.0);
        for seed in 4201..=4206u64 {
            let poses = 20 + 5 * (seed - 4201) as usize;
            let c = simulated(grade, seed, poses);
            // White noise only: the rests show no excess to weigh (none of 360 surveyed).
            assert!(!c.weighed_unasked, "{grade:?} seed {seed}: weighed unasked");
            let reported = c.reported_baseline.expect("a baseline with a hold-out");
            let own = c.baseline.static_rms_after_m_s2;
            assert!(
                (reported.held_out_static_rms_m_s2 - own).abs() <= 1e-9 * own,
                "{reported:?} against {own}"
            );
            filter += c.filter.static_rms_after_m_s2.powi(2);
            baseline += c.baseline.static_rms_after_m_s2.powi(2);
        }
        let ratio = (filter / baseline).sqrt();
        println!("{grade:?}: pooled held-out static RMS, filter over baseline {ratio:.3}");
        assert!(ratio <= 1.05, "{grade:?}: {ratio}");
    }
}

/// An error each rest's windows share (1e-3 m/s^2 per axis, what a hand-placed consumer unit's
/// rests show beyond their noise), six recordings of each grade (seeds 4211-4216, fixed before
/// the runs): the calibration measures it (the "rests' excess"; the RMS of its estimates within
/// 30 % of the truth over the recordings whose rests tell it), weighs it unasked on at least
/// three of the six, and, calibrated again with it weighed as its report advises where it was
/// not (`--rest-error`), loses nothing to the baseline pooled over the recordings (within 5 %). First written with the excess weighed automatically; that
/// took the Ferraris session's white level to its floor (docs/real-data.md), and the weighing
/// became the user's choice.
#[test]
fn an_error_shared_by_each_rest_is_measured_and_weighed() {
    for grade in [Grade::Consumer, Grade::Tactical, Grade::Navigation] {
        let (mut filter, mut baseline, mut measured, mut told) = (0.0, 0.0, 0.0, 0);
        let mut unasked = 0;
        for seed in 4211..=4216u64 {
            let poses = 20 + 5 * (seed - 4211) as usize;
            let c = simulated_with_rest_error(grade, seed, poses, true, 1e-3, true);
            unasked += usize::from(c.weighed_unasked);
            if c.rest_error_m_s2 > 0.0 {
                measured += c.rest_error_m_s2.powi(2);
                told += 1;
            }
            filter += c.filter.static_rms_after_m_s2.powi(2);
            baseline += c.baseline.static_rms_after_m_s2.powi(2);
        }
        let ratio = (filter / baseline).sqrt();
        let measured = (measured / told.max(1) as f64).sqrt();
        println!(
            "{grade:?}: rest error measured {measured:.2e} on {told} of 6; filter over baseline {ratio:.3}"
        );
        assert!(told >= 4, "{grade:?}: told on {told}");
        // Weighed without being asked where the rests show it (150 of 180 surveyed; the bound,
        // 3 of 6, set before this test's first run).
        assert!(unasked >= 3, "{grade:?}: weighed unasked on {unasked} of 6");
        assert!(
            (measured / 1e-3 - 1.0).abs() <= 0.3,
            "{grade:?}: {measured}"
        );
        assert!(ratio <= 1.05, "{grade:?}: {ratio}");
    }
}
