use super::*;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};
use turntable::program::Program;

fn normal3(rng: &mut StdRng) -> Vector3<f64> {
    Vector3::from_fn(|_, _| StandardNormal.sample(rng))
}

/// A fixed covariance with correlations, and its Cholesky factor.
fn cov() -> (Matrix3<f64>, Matrix3<f64>) {
    let l = Matrix3::new(2e-4, 0.0, 0.0, 5e-5, 1e-4, 0.0, -3e-5, 2e-5, 3e-4);
    (l * l.transpose(), l)
}

/// Innovations drawn from the model over the paper's program: one update of each kind every
/// 0.5 s, `extra(t, kind)` added to the innovation.
fn synthetic(seed: u64, extra: impl Fn(f64, MeasurementKind) -> Vector3<f64>) -> Vec<Innovation> {
    let mut rng = StdRng::seed_from_u64(seed);
    let (s, l) = cov();
    let mut out = vec![];
    let segs = segments(&Program::paper(), 0.0);
    let end = segs.last().unwrap().t1;
    let mut t = 0.5;
    while t <= end {
        for kind in [MeasurementKind::Accel, MeasurementKind::Turntable] {
            out.push(Innovation {
                t,
                kind,
                nu: l * normal3(&mut rng) + extra(t, kind),
                s,
                segment: segment_of(&segs, t),
                held_out: false,
                c_body_to_enu: None,
            });
        }
        t += 0.5;
    }
    out
}

#[test]
fn model_innovations_fit_and_a_line_at_the_cycle_period_does_not() {
    let segs = segments(&Program::paper(), 0.0);
    let settings = DiagnosticSettings::default();
    let clean = diagnose(&synthetic(11, |_, _| Vector3::zeros()), &segs, &settings);
    println!("{}", clean.summary());
    assert!(clean.fits, "{:?}", clean.failures);
    assert_eq!(clean.kinds.len(), 2);
    assert_eq!(clean.kinds[0].segments.len(), 9);
    // About 100 tests: per kind NIS, 9 segments, 3 Ljung-Box, 3 x (mean + program lines).
    println!("{} tests", clean.tests.len());
    // A sine along the first whitened axis at the cycle frequency, amplitude 0.15 sigma: its
    // line has Q about A^2 N / 2 = 61 (p ~ 6e-14); the NIS sum moves by 0.6 % only.
    let (_, l) = cov();
    let sine = diagnose(
        &synthetic(11, |t, kind| {
            let a = if kind == MeasurementKind::Accel {
                0.15
            } else {
                0.0
            };
            l * Vector3::new(a * (std::f64::consts::TAU * t / 900.0).sin(), 0.0, 0.0)
        }),
        &segs,
        &settings,
    );
    println!("{}", sine.summary());
    assert!(!sine.fits);
    assert!(
        sine.failures
            .iter()
            .any(|f| f.contains("specific force: line at 0.00111 Hz") && f.contains("axis x")),
        "{:?}",
        sine.failures
    );
    assert!(sine.failures.iter().all(|f| !f.contains("turntable")));
    // Serializable.
    let json = serde_json::to_string(&sine).unwrap();
    let back: Diagnostics = serde_json::from_str(&json).unwrap();
    assert_eq!(back.fits, sine.fits);
}

#[test]
fn periodogram_finds_a_sine_in_noise() {
    let mut rng = StdRng::seed_from_u64(5);
    let n = 2000;
    let f0 = 1.0 / 36.0;
    let t: Vec<f64> = (0..n).map(|k| 0.5 * k as f64).collect();
    let x: Vec<[f64; 3]> = t
        .iter()
        .map(|&tk| {
            let e = normal3(&mut rng);
            [
                e[0],
                e[1] + 0.2 * (std::f64::consts::TAU * f0 * tk + 0.3).cos(),
                e[2],
            ]
        })
        .collect();
    let o = spectrum::ordinate(&t, &x, f0);
    let d = ChiSquared::new(2.0).unwrap();
    let p = o.q.map(|q| d.sf(q));
    println!("sine at 1/36 Hz, amplitude 0.2: Q = {:?}, p = {p:?}", o.q);
    // Expected Q about A^2 N / 2 = 40 on y; bounds fixed before the run.
    assert!(p[1] < 1e-6, "{p:?}");
    assert!(p[0] > 1e-3 && p[2] > 1e-3, "{p:?}");
    let away = spectrum::ordinate(&t, &x, 0.3);
    assert!(away.q.iter().all(|q| d.sf(*q) > 1e-3), "{away:?}");
}

fn regression_data(seed: u64, coef: f64) -> (Vec<Innovation>, Vec<Vec<Vector3<f64>>>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let (s, l) = cov();
    let n = 300;
    let r0: Vec<Vector3<f64>> = (0..n)
        .map(|k| Vector3::new((k as f64 * 0.05).sin(), 0.5, (k as f64 * 0.01).cos()) * 1e-4)
        .collect();
    let r1: Vec<Vector3<f64>> = (0..n)
        .map(|k| Vector3::new(0.0, (k as f64 / n as f64) - 0.5, 0.2) * 1e-4)
        .collect();
    let innov = (0..n)
        .map(|k| Innovation {
            t: k as f64,
            kind: MeasurementKind::Accel,
            nu: l * normal3(&mut rng) + r0[k] * coef,
            s,
            segment: 0,
            held_out: false,
            c_body_to_enu: None,
        })
        .collect();
    (innov, vec![r0, r1])
}

#[test]
fn regression_recovers_a_coefficient_and_is_chi_square_on_noise() {
    let (innov, regs) = regression_data(1, 3.0);
    let r = regression_test(&innov, &regs).unwrap();
    println!("coefficient 3: {r:?}");
    assert!((r.coefficients[0] - 3.0).abs() < 4.0 * r.sigma[0], "{r:?}");
    assert!(r.coefficients[1].abs() < 4.0 * r.sigma[1], "{r:?}");
    assert!(r.p_value < 1e-6 && r.dof == 2 && r.used == 300);
    // 200 draws without the effect: the statistics sum to chi-square(400); bounds fixed before
    // the run: the sum inside its two-sided 99 % band, at most 20 of 200 p-values below 5 %
    // (binomial(200, 0.05): P(> 20) = 1.6e-3).
    let (mut sum, mut small) = (0.0, 0);
    for seed in 1000..1200 {
        let (innov, regs) = regression_data(seed, 0.0);
        let r = regression_test(&innov, &regs).unwrap();
        sum += r.statistic;
        if r.p_value < 0.05 {
            small += 1;
        }
    }
    let (lo, hi) = crate::check::stats::chi_square_band(400.0, 0.99);
    println!("pure noise: sum {sum:.1} in [{lo:.1}, {hi:.1}], {small} of 200 below 5 %");
    assert!((lo..=hi).contains(&sum) && small <= 20);
}

#[test]
fn bad_input_gives_errors_or_counts_not_panics() {
    let (innov, regs) = regression_data(1, 0.0);
    assert_eq!(
        regression_test(&innov, &[]).unwrap_err(),
        DiagnosticsError::NoRegressors
    );
    assert!(matches!(
        regression_test(&innov[..10], &regs),
        Err(DiagnosticsError::LengthMismatch { .. })
    ));
    let zero = vec![vec![Vector3::zeros(); innov.len()]];
    assert_eq!(
        regression_test(&innov, &zero).unwrap_err(),
        DiagnosticsError::Singular
    );
    let mut bad = innov.clone();
    bad[0].s = Matrix3::zeros();
    bad[1].nu[0] = f64::NAN;
    bad[2].s[(0, 0)] = f64::INFINITY;
    bad[3].t = f64::NAN;
    let d = diagnose(&bad, &[], &DiagnosticSettings::default());
    assert_eq!(d.kinds[0].unusable, 4);
    let empty = diagnose(&[], &[], &DiagnosticSettings::default());
    assert!(empty.fits && empty.kinds.is_empty());
    let one = diagnose(&innov[..1], &[], &DiagnosticSettings::default());
    assert_eq!(one.kinds[0].updates, 1);
    let weird = DiagnosticSettings {
        alpha: f64::NAN,
        max_lag: 0,
        harmonics: 0,
        max_lines: 0,
        spectrum_points: 0,
    };
    let _ = diagnose(&innov, &[], &weird);
}
