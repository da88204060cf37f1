//! Round trips of the correction through the simulator: a noiseless run simulated with known
//! instrument errors, corrected with the true values, gives the records of the same run
//! simulated without them (same program, mounting and delay).

use calib::config::RunConfig;
use calib::estimate::{Plan, Records, run};
use calib::io::{ImuData, ImuKind, ImuRecord, ResultFile};
use calib::model::correction::{Correction, ExtensionInputs, correct_records};
use calib::model::extension::HiddenEffects;
use calib::simulate::simulate_run_hidden;
use nalgebra::Vector3;
use sins_model::candidates::Candidate;

/// The paper's program at 10 Hz without noise, errors drawn from the priors with `seed`.
fn config(seed: u64) -> RunConfig {
    let mut c = RunConfig::paper();
    c.truth.imu_rate_hz = 10.0;
    c.filter.imu_rate_hz = 10.0;
    c.truth.turntable_rate_hz = 1.0;
    c.truth.noise = false;
    c.truth.seed = seed;
    c
}

/// A multi-position program: rests between turns about two gimbals (the paper's program turns
/// all the time, and no record of it is steady).
const DWELLS: &str = r#"
name = "rests and turns"
start_deg = [0.0, 0.0, 0.0]
[[segment]]
kind = "dwell"
duration_s = 30.0
[[segment]]
kind = "rotate"
gimbal = 2
rate_deg_s = 10.0
duration_s = 9.0
[[segment]]
kind = "dwell"
duration_s = 30.0
[[segment]]
kind = "rotate"
gimbal = 3
rate_deg_s = -20.0
duration_s = 9.0
[[segment]]
kind = "dwell"
duration_s = 30.0
[[segment]]
kind = "rotate"
gimbal = 2
rate_deg_s = -10.0
duration_s = 18.0
[[segment]]
kind = "dwell"
duration_s = 30.0
[[segment]]
kind = "rotate"
gimbal = 3
rate_deg_s = 15.0
duration_s = 24.0
[[segment]]
kind = "dwell"
duration_s = 30.0
"#;

/// The run with errors (paper's drawn, plus `hidden`), its truth, and the error-free run; on
/// [`DWELLS`] when `dwells`, else on the paper's program.
fn runs(seed: u64, hidden: &HiddenEffects, dwells: bool) -> (ImuData, ResultFile, ImuData) {
    let mut c = config(seed);
    if dwells {
        c.inline_program =
            Some(toml::from_str::<turntable::program::ProgramSpec>(DWELLS).expect("program"));
    }
    if hidden
        .candidates()
        .expect("known names")
        .iter()
        .any(|c| c.is_thermal())
    {
        // A warm-up for the thermal terms to act on, fast enough to change within the run.
        c.temperature = Some(calib::config::TemperatureConfig {
            profile: "warmup".into(),
            start_c: Some(20.0),
            end_c: Some(35.0),
            time_constant_s: Some(100.0),
            ..Default::default()
        });
    }
    let sim = simulate_run_hidden(&c, "test", hidden).expect("simulation");
    let truth = ResultFile::from(&sim.truth);
    // The same mounting, base and delay, no instrument errors.
    let mut clean = c.clone();
    clean.truth.draw_from_priors = false;
    for p in &truth.parameters {
        if p.name.starts_with("install.")
            || p.name.starts_with("base.")
            || p.name == "turntable.tau"
        {
            clean.truth.values.insert(p.name.clone(), p.value);
        }
    }
    let free = simulate_run_hidden(&clean, "test", &HiddenEffects::default()).expect("simulation");
    (
        ImuData::from_samples(&sim.imu),
        truth,
        ImuData::from_samples(&free.imu),
    )
}

/// Relative error of each corrected record against the error-free one (largest of the two
/// triads), and of the raw records.
fn errors(corrected: &[ImuRecord], clean: &[ImuRecord], raw: &[ImuRecord]) -> (Vec<f64>, Vec<f64>) {
    let rel = |a: &ImuRecord, b: &ImuRecord| {
        let g =
            (Vector3::from(a.gyro) - Vector3::from(b.gyro)).norm() / Vector3::from(b.gyro).norm();
        let f = (Vector3::from(a.accel) - Vector3::from(b.accel)).norm()
            / Vector3::from(b.accel).norm();
        g.max(f)
    };
    (
        corrected
            .iter()
            .zip(clean)
            .map(|(a, b)| rel(a, b))
            .collect(),
        raw.iter().zip(clean).map(|(a, b)| rel(a, b)).collect(),
    )
}

/// Records whose error-free neighbours are the same record (rest or a steady state): there
/// the mean over an interval is the value throughout it, and every term is exact. "The same"
/// to 1e-12: the simulator's records at rest differ by its rounding, up to about 1e-13.
fn steady(clean: &[ImuRecord]) -> Vec<bool> {
    let same = |a: &ImuRecord, b: &ImuRecord| {
        let d = (Vector3::from(a.gyro) - Vector3::from(b.gyro)).norm()
            + (Vector3::from(a.accel) - Vector3::from(b.accel)).norm();
        d <= 1e-12 * (Vector3::from(a.accel).norm())
    };
    (0..clean.len())
        .map(|k| {
            k > 0
                && k + 1 < clean.len()
                && same(&clean[k - 1], &clean[k])
                && same(&clean[k], &clean[k + 1])
        })
        .collect()
}

fn correct(raw: &ImuData, truth: &ResultFile) -> Vec<ImuRecord> {
    let reference = truth.temperature.as_ref().map(|t| t.reference_c);
    let c = Correction::from_parameters_at(&truth.parameters, ExtensionInputs::True, reference)
        .expect("truth");
    correct_records(&c, raw.kind, &raw.records).expect("corrected")
}

/// The paper's model (and the g-sensitivity, linear too): every record to 1e-12, increments
/// and rates.
#[test]
fn linear_terms_round_trip_exactly() {
    let hidden = HiddenEffects {
        values: Candidate::GyroGSensitivity
            .param_names()
            .into_iter()
            .enumerate()
            .map(|(k, n)| (n, 2e-6 * (1.0 + k as f64).sin()))
            .collect(),
        gyro_drift: None,
    };
    let (raw, truth, clean) = runs(3, &hidden, false);
    assert_eq!(raw.records.len(), clean.records.len());
    let corrected = correct(&raw, &truth);
    let (err, before) = errors(&corrected, &clean.records, &raw.records);
    let worst = err.iter().cloned().fold(0.0, f64::max);
    let raw_worst = before.iter().cloned().fold(0.0, f64::max);
    println!(
        "linear terms: {} records, largest relative error {worst:e} (raw {raw_worst:e})",
        err.len()
    );
    assert!(worst < 1e-12, "{worst:e}");
    assert!(raw_worst > 1e-4, "the errors were there: {raw_worst:e}");
    // Rates form: the same records as mean rates.
    let rates = ImuData {
        kind: ImuKind::Rates,
        records: raw
            .records
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let dt = if k == 0 {
                    raw.records[1].t - r.t
                } else {
                    r.t - raw.records[k - 1].t
                };
                ImuRecord {
                    gyro: r.gyro.map(|x| x / dt),
                    accel: r.accel.map(|x| x / dt),
                    ..*r
                }
            })
            .collect(),
    };
    let corrected = correct(&rates, &truth);
    for (k, (a, b)) in corrected.iter().zip(&clean.records).enumerate() {
        let dt = if k == 0 {
            0.1
        } else {
            b.t - clean.records[k - 1].t
        };
        let e = (Vector3::from(a.gyro) * dt - Vector3::from(b.gyro)).norm()
            / Vector3::from(b.gyro).norm();
        assert!(e < 1e-12, "rates, record {k}: {e:e}");
        assert_eq!(a.t, b.t);
    }
}

/// Every extension term the simulator supports: exact (1e-12) on the records where the motion
/// is steady over the interval and its neighbours; elsewhere the correction of the mean rate
/// neglects the variation of the non-linear and derivative terms within an interval, and the
/// remaining error is bounded (and far below the error corrected).
#[test]
fn extension_terms_round_trip() {
    for c in Candidate::ALL {
        let Some(term) = c.term(1.0) else { continue };
        let sigma = c.default_prior_sigma() * 5.0;
        let hidden = HiddenEffects {
            values: term
                .params()
                .iter()
                .enumerate()
                .map(|(k, p)| (p.name.clone(), sigma * (0.4 + 0.6 * (k as f64 * 1.3).cos())))
                .collect(),
            gyro_drift: None,
        };
        let (raw, truth, clean) = runs(5, &hidden, true);
        let corrected = correct(&raw, &truth);
        let (err, before) = errors(&corrected, &clean.records, &raw.records);
        let st = steady(&clean.records);
        let n_steady = st.iter().filter(|&&s| s).count();
        let worst_steady = err
            .iter()
            .zip(&st)
            .filter(|(_, s)| **s)
            .map(|(e, _)| *e)
            .fold(0.0, f64::max);
        let worst = err.iter().cloned().fold(0.0, f64::max);
        // What the term alone does to the records (raw errors of the paper's terms removed).
        let paper_only = {
            let mut t = truth.clone();
            for p in &mut t.parameters {
                if term.params().iter().any(|q| q.name == p.name) {
                    p.value = 0.0;
                }
            }
            correct(&raw, &t)
        };
        let (term_effect, _) = errors(&paper_only, &clean.records, &raw.records);
        let effect = term_effect.iter().cloned().fold(0.0, f64::max);
        println!(
            "{:<24} steady records {n_steady:>5}: largest error {worst_steady:.1e}; all {}: {worst:.1e} (term's effect {effect:.1e}, raw {:.1e})",
            c.id(),
            err.len(),
            before.iter().cloned().fold(0.0, f64::max)
        );
        assert!(
            n_steady > 500 && n_steady + 500 < err.len(),
            "{}: {n_steady} steady records",
            c.id()
        );
        assert!(worst_steady < 1e-12, "{}: {worst_steady:e}", c.id());
        if term.uses_rate_derivatives() {
            // The derivative terms take dw/dt and df/dt from the neighbouring records, which
            // spreads a rate jump's effect over the two records around it: record by record
            // the error is of the term's size there, but the velocity (running sum of the
            // velocity increments) is corrected.
            // (largest over the run, at the end of the run)
            let velocity_error = |recs: &[ImuRecord]| {
                let mut sum = Vector3::zeros();
                let mut worst: f64 = 0.0;
                for (a, b) in recs.iter().zip(&clean.records) {
                    sum += Vector3::from(a.accel) - Vector3::from(b.accel);
                    worst = worst.max(sum.norm());
                }
                (worst, sum.norm())
            };
            let (after, after_end) = velocity_error(&corrected);
            let (effect, effect_end) = velocity_error(&paper_only);
            // The largest single record's error of the term (a rate jump's dw x r).
            let jump = paper_only
                .iter()
                .zip(&clean.records)
                .map(|(a, b)| (Vector3::from(a.accel) - Vector3::from(b.accel)).norm())
                .fold(0.0, f64::max);
            println!(
                "{:<24} velocity error: largest {after:.1e} m/s, at the end {after_end:.1e} m/s; \
                 the term's {effect:.1e} and {effect_end:.1e} m/s, its largest record {jump:.1e} m/s",
                ""
            );
            assert!(
                after <= 0.51 * jump,
                "{}: velocity {after:e} against {jump:e}",
                c.id()
            );
            assert!(
                after_end < 1e-6 * effect.max(effect_end),
                "{}: {after_end:e}",
                c.id()
            );
        } else {
            assert!(
                worst < 1e-2 * effect,
                "{}: {worst:e} against the term's {effect:e}",
                c.id()
            );
        }
    }
}

/// The filter's result file carries the full posterior (the correlation of every parameter
/// pair, from the covariance) and its correction block (the exact inverse of the estimate).
#[test]
fn filter_result_carries_correlation_and_correction() {
    let (c, imu, tt) = crate::paper_20hz::paper_20hz_run(4);
    let data = calib::estimate::RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "turntable.csv").into()),
    };
    let est = run(Plan::fit_only(&c), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .expect("estimate");
    let r = est.to_result_file();
    let n = r.parameters.len();
    assert_eq!(n, 25);
    let corr = r.correlation.as_ref().expect("correlation");
    let off = est.values.len() - n; // the attitude errors come first
    for (i, row) in corr.iter().enumerate() {
        assert_eq!(row[i], 1.0);
        for (j, &x) in row.iter().enumerate() {
            let (a, b) = (i + off, j + off);
            let exact = est.cov[(a, b)] / (est.cov[(a, a)] * est.cov[(b, b)]).sqrt();
            assert!((x - exact).abs() <= 0.5e-6 + 1e-15, "{i} {j}");
            assert_eq!(x, corr[j][i]);
        }
    }
    // Strongly correlated pairs exist (what navigation gains from them).
    assert!(corr.iter().flatten().any(|x| x.abs() > 0.9 && *x != 1.0));
    let block = r.correction.as_ref().expect("correction");
    assert_eq!(block.extension_inputs, ExtensionInputs::True);
    let theta = nalgebra::Matrix3::from_fn(|i, j| {
        r.get(&format!(
            "gyro.theta.{}{}",
            ["x", "y", "z"][i],
            ["x", "y", "z"][j]
        ))
        .expect("theta")
        .value
    });
    let m = nalgebra::Matrix3::from_fn(|i, j| block.gyro.matrix[i][j]);
    assert!(
        ((nalgebra::Matrix3::identity() - theta) * m - nalgebra::Matrix3::identity()).norm()
            < 1e-15
    );
    assert_eq!(block.gyro.offset[1], r.get("gyro.bias.y").unwrap().value);
    assert_eq!(block.accel.offset[2], -r.get("accel.bias.z").unwrap().value);
    // Written and read back unchanged.
    let text = serde_json::to_string(&r).unwrap();
    let back: ResultFile = serde_json::from_str(&text).unwrap();
    assert_eq!(back, r);
}
