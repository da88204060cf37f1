//! Diagnostics of whole calibrations of simulated runs of the paper's program: a clean run
//! fits; runs corrupted with an effect the model lacks are (or are not) flagged, and by which
//! statistics. Seeds and effect sizes fixed before the runs.

use calib::check::diagnostics::{DiagnosticSettings, Diagnostics, diagnose, segments};
use calib::config::{AttitudePrior, RunConfig};
use calib::estimate::{Estimate, Plan, Records, RunData, run};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;
use turntable::simulate::Simulation;

/// The workspace tests' `simulated_run_config` (tests/src/lib.rs), with its seed.
fn config(seed: u64) -> RunConfig {
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

fn calibrate(config: &RunConfig, sim: &Simulation, with_tt: bool) -> (Estimate, Diagnostics) {
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: with_tt.then_some((&tt, "turntable.csv").into()),
    };
    let est = run(Plan::fit_only(config), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .unwrap();
    let segs = segments(&config.program().unwrap(), est.program_start_s);
    let d = diagnose(&est.innovations, &segs, &DiagnosticSettings::default());
    (est, d)
}

/// The p-values of the headline statistics, one line.
fn headline(d: &Diagnostics) -> String {
    d.kinds
        .iter()
        .map(|k| {
            let seg = k
                .segments
                .iter()
                .map(|s| s.nis.p_value)
                .fold(f64::INFINITY, f64::min);
            let line = k
                .lines
                .iter()
                .flat_map(|l| l.p_value)
                .fold(f64::INFINITY, f64::min);
            let lb: Vec<String> = k
                .whiteness
                .iter()
                .map(|w| format!("{:.2e}", w.p_value))
                .collect();
            format!(
                "{}: NIS/dof {:.4} p {:.2e}, min segment p {seg:.2e}, Ljung-Box p [{}], \
                 min line p {line:.2e}",
                calib::check::diagnostics::kind_label(k.kind),
                k.nis.sum / k.nis.dof,
                k.nis.p_value,
                lb.join(", ")
            )
        })
        .collect::<Vec<_>>()
        .join("\n    ")
}

/// (a) A noisy run with no unmodelled effect fits, both models, seeds 1 and 2; every Ljung-Box
/// test passes at the verdict's per-test level.
#[test]
fn clean_runs_fit() {
    for seed in [1, 2] {
        let config = config(seed);
        let sim = simulate_run(&config, "clean").unwrap();
        for with_tt in [false, true] {
            let (est, d) = calibrate(&config, &sim, with_tt);
            assert_eq!(
                est.innovations.len(),
                est.stats.accel_updates + est.stats.turntable_updates
            );
            println!(
                "clean seed {seed}, {} states: fits {} ({} tests, each at {:.2e})\n    {}",
                est.names.len(),
                d.fits,
                d.tests.len(),
                d.per_test_level,
                headline(&d)
            );
            for f in &d.failures {
                println!("    FAIL {f}");
            }
            assert!(d.fits, "seed {seed}, turntable {with_tt}: {:?}", d.failures);
            for k in &d.kinds {
                for w in &k.whiteness {
                    assert!(w.p_value >= d.per_test_level, "{w:?}");
                }
            }
        }
    }
}

/// Add a gyro scale asymmetry `asym * |w_i| * dt` to every angle increment.
fn with_scale_asymmetry(sim: &Simulation, asym: f64) -> Simulation {
    let mut s = sim.clone();
    for r in &mut s.imu {
        r.dtheta = r.dtheta.map(|v| v + asym * v.abs());
    }
    s
}

/// Add a gyro bias drifting linearly from 0 to `rate * T` (rad/s) on each axis.
fn with_bias_drift(sim: &Simulation, rate: f64, dt: f64) -> Simulation {
    let mut s = sim.clone();
    for r in &mut s.imu {
        r.dtheta = r.dtheta.map(|v| v + rate * r.t * dt);
    }
    s
}

/// (b) The same run (seed 1, 28 states) corrupted by effects the model lacks. The verdict on
/// the larger scale asymmetry (2e-5) must be "does not fit"; the others are reported only.
/// No seed was tuned. Measured (98 tests, per-test level 1.02e-4):
/// - asymmetry 2e-6: fits; nothing flags it (smallest p 4.4e-3, a segment NIS, as on the clean
///   run), while `gyro.bias.z` moves 19.3 sigma from the clean run's estimate;
/// - asymmetry 2e-5: does not fit, 23 tests: both NIS sums (turntable p 5e-74, specific force
///   1.9e-5), the NIS of the "-" halves of cycles 2 and 3 (both kinds), Ljung-Box (turntable
///   x, y, z; specific force y), the means (specific force y, turntable x), the lines at the
///   cycle period and its harmonics 2 and 3 (both kinds), the turntable line at the rotation
///   frequency (y, z) and its third harmonic (y);
/// - bias drift 0.01 and 0.1 deg/h over the run: fits, nothing flags it (the shifts, 2.2 and
///   21.6 sigma of `gyro.bias.z`, are mostly the drift's mean, 0.005 and 0.05 deg/h, which the
///   constant bias rightly takes up).
#[test]
fn unmodelled_effects_are_flagged() {
    let config = config(1);
    let sim = simulate_run(&config, "clean").unwrap();
    let (clean, _) = calibrate(&config, &sim, true);
    let dt = 1.0 / config.truth.imu_rate_hz;
    let runs = [
        ("scale asymmetry 2e-6", with_scale_asymmetry(&sim, 2e-6)),
        ("scale asymmetry 2e-5", with_scale_asymmetry(&sim, 2e-5)),
        // 0.01 deg/h over the run's 2727 s (the prior bias sigma is 0.5 deg/h).
        (
            "bias drift 0.01 deg/h per 2727 s",
            with_bias_drift(&sim, (0.01f64 / 3600.0).to_radians() / 2727.0, dt),
        ),
        (
            "bias drift 0.1 deg/h per 2727 s",
            with_bias_drift(&sim, (0.1f64 / 3600.0).to_radians() / 2727.0, dt),
        ),
    ];
    let mut flagged = vec![];
    for (label, s) in &runs {
        let (est, d) = calibrate(&config, s, true);
        let shift = (3..est.names.len())
            .map(|i| {
                (
                    (est.values[i] - clean.values[i]).abs() / est.cov[(i, i)].sqrt(),
                    est.names[i].clone(),
                )
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap();
        println!(
            "{label}: largest parameter shift {:.2} sigma ({}); mean NIS accel {:.3}, turntable \
             {:.3}; fits {} ({} of {} tests fail)\n    {}",
            shift.0,
            shift.1,
            est.stats.accel_mean_nis,
            est.stats.turntable_mean_nis,
            d.fits,
            d.failures.len(),
            d.tests.len(),
            headline(&d)
        );
        for f in &d.failures {
            println!("    FAIL {f}");
        }
        flagged.push((*label, d.fits));
    }
    assert!(!flagged[1].1, "scale asymmetry 2e-5 not flagged");
}

mod arbitrary {
    use calib::check::diagnostics::{
        DiagnosticSettings, Innovation, Segment, diagnose, regression_test,
    };
    use calib::model::MeasurementKind;
    use nalgebra::{Matrix3, Vector3};
    use proptest::prelude::*;

    /// Any f64, weighted towards the awkward ones.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            4 => -10.0f64..10.0,
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
            1 => Just(0.0),
            1 => any::<f64>(),
        ]
    }

    fn innovation() -> impl Strategy<Value = Innovation> {
        (
            value(),
            any::<bool>(),
            proptest::array::uniform3(value()),
            proptest::array::uniform9(value()),
            0usize..12,
        )
            .prop_map(|(t, accel, nu, s, segment)| Innovation {
                t,
                kind: if accel {
                    MeasurementKind::Accel
                } else {
                    MeasurementKind::Turntable
                },
                nu: Vector3::from(nu),
                s: Matrix3::from_row_slice(&s),
                segment,
                held_out: false,
                c_body_to_enu: None,
            })
    }

    fn segment() -> impl Strategy<Value = Segment> {
        (0usize..12, value(), value(), value()).prop_map(|(index, t0, t1, rotation_hz)| Segment {
            index,
            cycle: Some(index / 2),
            label: format!("segment {index}"),
            t0,
            t1,
            rotation_hz,
            levels_start: index == 0,
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Diagnostics and the regression test take any values without panicking.
        #[test]
        fn no_panic_on_any_values(
            innov in proptest::collection::vec(innovation(), 0..60),
            segs in proptest::collection::vec(segment(), 0..6),
            alpha in value(),
            lag in 0usize..40,
            reg in proptest::collection::vec(proptest::array::uniform3(value()), 0..60),
        ) {
            let settings = DiagnosticSettings { alpha, max_lag: lag, ..Default::default() };
            let d = diagnose(&innov, &segs, &settings);
            let _ = d.summary();
            let _ = serde_json::to_string(&d);
            let col: Vec<Vector3<f64>> = reg.into_iter().map(Vector3::from).collect();
            let _ = regression_test(&innov, &[col]);
        }
    }
}
