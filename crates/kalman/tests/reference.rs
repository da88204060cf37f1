//! The engine against the naive loops of the reference filter (`tests/common/naive.rs`) and the
//! textbook formulas: at sizes on both sides of the engine's switch from its own loops to faer's
//! products (32 states, `src/small.rs`) and around faer's small-product threshold
//! (n = 1, 3, 24, 28, 32, 33, 60, 61, 80;
//! m = 1, 3, 6, 9, 12, 17; k = 1, 3, 9, n), in full and covariance-only mode, with changing
//! measurement and dynamic-state dimensions and with strided inputs.

mod common;

use common::naive::{NaiveFilter, invert, matmul, transpose};
use common::*;
use faer::Mat;
use kalman::{KalmanError, KalmanFilter};

/// `S = H P H^T + R`, `K = P H^T S^{-1}` and `ln det S` by the naive loops.
fn reference_update(p: &Mat<f64>, h: &Mat<f64>, r: &Mat<f64>) -> (Mat<f64>, Mat<f64>, f64) {
    let (n, m) = (p.nrows(), h.nrows());
    let (p_rm, h_rm) = (to_row_major(p), to_row_major(h));
    let mut ht = vec![0.0; n * m];
    transpose(&mut ht, &h_rm, m, n);
    let mut pht = vec![0.0; n * m];
    matmul(&mut pht, &p_rm, &ht, n, n, m);
    let mut s = vec![0.0; m * m];
    matmul(&mut s, &h_rm, &pht, m, n, m);
    let s = sym(from_row_major(&s, m, m) + r);
    let mut work = to_row_major(&s);
    let mut sinv = vec![0.0; m * m];
    invert(&mut work, &mut sinv, m).unwrap();
    let mut k = vec![0.0; n * m];
    matmul(&mut k, &pht, &sinv, n, m, m);
    let l = cholesky(&s);
    let log_det = 2.0 * (0..m).map(|i| l[(i, i)].ln()).sum::<f64>();
    (s, from_row_major(&k, n, m), log_det)
}

/// A few predict + update steps of the filter (full and covariance-only) against the naive
/// reference, comparing everything the filter reports.
fn check_steps(n: usize, m: usize, k: usize, seed: u64) {
    let what = format!("n = {n}, m = {m}, k = {k}");
    let mut rng = Rng::new(seed);
    let x0 = rng.vec(n);
    let p0 = rng.spd(n);
    let sys = Structured::random(&mut rng, k, n, 0.05);
    let (phi, q) = sys.full(n);
    let (phi_rm, q_rm) = (to_row_major(&phi), to_row_major(&q));
    let r = rng.spd(m);
    let r_rm = to_row_major(&r);

    let mut kf = KalmanFilter::new(&x0, p0.as_ref(), m).unwrap();
    let mut cov = kf.clone();
    let xs0 = kf.normalised_state().to_vec();
    let mut naive = NaiveFilter::new(&x0, &to_row_major(&p0), m);
    for step in 0..4 {
        // Mostly the structured predict; once the dense one (k = n).
        if step == 2 {
            kf.predict(phi.as_ref(), q.as_ref()).unwrap();
            cov.predict_covariance(phi.as_ref(), q.as_ref()).unwrap();
        } else {
            kf.predict(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
            cov.predict_covariance(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
        }
        naive.predict(&phi_rm, &q_rm);
        let dp = rel_diff(&kf.covariance(), &from_row_major(&naive.p, n, n));
        assert!(
            dp < 1e-12,
            "{what}, step {step}: predicted P differs by {dp:e}"
        );
        assert!(
            rel_diff_vec(&kf.state(), &naive.x) < 1e-12,
            "{what}: predicted x"
        );
        assert_symmetric(&kf.covariance(), &what);

        let h = rng.mat(m, n);
        let z = rng.vec(m);
        let p_prior = from_row_major(&naive.p, n, n);
        let x_prior = naive.x.clone();
        let (s_ref, k_ref, log_det_ref) = reference_update(&p_prior, &h, &r);
        let info = kf.update(&z, h.as_ref(), r.as_ref()).unwrap();
        let cov_log_det = cov.update_covariance(h.as_ref(), r.as_ref()).unwrap();
        let nis_ref = naive.update(&z, &to_row_major(&h), &r_rm).unwrap();

        let p = kf.covariance();
        let dp = rel_diff(&p, &from_row_major(&naive.p, n, n));
        assert!(dp < 1e-10, "{what}, step {step}: P differs by {dp:e}");
        assert_symmetric(&p, &what);
        assert_symmetric(&kf.normalised_covariance().to_owned(), &what);
        let dx = rel_diff_vec(&kf.state(), &naive.x);
        assert!(dx < 1e-10, "{what}, step {step}: x differs by {dx:e}");
        assert!(
            (info.nis - nis_ref).abs() <= 1e-9 * nis_ref.abs().max(1.0),
            "{what}, step {step}: NIS {} vs {nis_ref}",
            info.nis
        );
        assert!(
            (info.log_det_s - log_det_ref).abs() <= 1e-10 * log_det_ref.abs().max(1.0),
            "{what}, step {step}: ln det S {} vs {log_det_ref}",
            info.log_det_s
        );
        assert!(
            (cov_log_det - log_det_ref).abs() <= 1e-10 * log_det_ref.abs().max(1.0),
            "{what}, step {step}: covariance-only ln det S {cov_log_det} vs {log_det_ref}"
        );
        assert_eq!(info.dim, m);
        let s = kf.innovation_covariance().to_owned();
        assert!(rel_diff(&s, &s_ref) < 1e-12, "{what}: S");
        assert_symmetric(&s, &what);
        assert!(rel_diff(&kf.gain(), &k_ref) < 1e-10, "{what}: gain");
        check_gain_times(&kf, &what);
        let nu_ref: Vec<f64> = (0..m)
            .map(|a| z[a] - (0..n).map(|j| h[(a, j)] * x_prior[j]).sum::<f64>())
            .collect();
        assert!(
            rel_diff_vec(kf.innovation(), &nu_ref) < 1e-12,
            "{what}: innovation"
        );

        // Covariance-only mode: the same covariance arithmetic, bit for bit; x untouched.
        assert_eq!(cov.covariance(), p, "{what}: covariance-only P");
        assert_eq!(cov.normalised_state(), xs0, "{what}: covariance-only x");
        assert!(cov.innovation().iter().all(|v| v.is_nan()));
        assert_eq!(cov.gain(), kf.gain());
    }
}

/// `gain_times` gives `K rhs` for a few right-hand sides, without forming `K`.
fn check_gain_times(kf: &KalmanFilter, what: &str) {
    let k = kf.gain();
    let (n, m) = (k.nrows(), k.ncols());
    for c in [1usize, 3] {
        let rhs = Mat::from_fn(m, c, |i, j| {
            0.3 + (i as f64) - 0.7 * (j as f64) * (i as f64)
        });
        let expected = &k * &rhs;
        let mut work = rhs.clone();
        let mut out = Mat::zeros(n, c);
        kf.gain_times(work.as_mut(), out.as_mut());
        assert!(
            rel_diff(&out, &expected) < 1e-10,
            "{what}: gain_times with {c} columns"
        );
    }
}

#[test]
fn step_matches_the_naive_reference_at_every_size() {
    for n in [1usize, 3, 24, 28, 32, 33, 60, 61, 80] {
        for m in [1usize, 3, 6] {
            check_steps(n, m, n.min(3), (n * 100 + m) as u64);
        }
    }
}

#[test]
fn more_dynamic_states_and_larger_measurements() {
    check_steps(12, 3, 12, 1); // k = n: the whole matrix is dynamic
    check_steps(28, 6, 9, 2);
    check_steps(28, 9, 3, 3);
    check_steps(24, 12, 3, 4);
    check_steps(5, 17, 5, 5);
}

/// Textbook `P - K H P` with the optimal gain, computed with the naive loops.
fn textbook(p: &Mat<f64>, h: &Mat<f64>, r: &Mat<f64>) -> Mat<f64> {
    let (_, k, _) = reference_update(p, h, r);
    p - &k * (h * p)
}

#[test]
fn update_equals_textbook_for_optimal_gain() {
    for n in [28, 60, 80] {
        let m = 6;
        let mut rng = Rng::new(7 + n as u64);
        let p0 = rng.spd(n);
        let h = rng.mat(m, n);
        let r = rng.spd(m);
        let mut kf = KalmanFilter::new(&vec![0.0; n], p0.as_ref(), m).unwrap();
        kf.update_covariance(h.as_ref(), r.as_ref()).unwrap();
        let expected = textbook(&p0, &h, &r);
        let d = rel_diff(&kf.covariance(), &expected);
        assert!(d < 1e-12, "n={n}: update differs from textbook by {d:e}");
        // and the update really did something
        assert!(rel_diff(&p0, &expected) > 1e-3);
    }
}

#[test]
fn changing_dimensions_and_strided_inputs() {
    let n = 28;
    let mut rng = Rng::new(77);
    let x0 = rng.vec(n);
    let p0 = rng.spd(n);
    let mut kf = KalmanFilter::new(&x0, p0.as_ref(), 9).unwrap();
    let mut naive = NaiveFilter::new(&x0, &to_row_major(&p0), 9);
    // (m, k) per step: both shrink and grow.
    for (step, (m, k)) in [(6, 3), (3, 1), (9, 3), (1, 2), (6, 9), (2, 3)]
        .into_iter()
        .enumerate()
    {
        let sys = Structured::random(&mut rng, k, n, 0.05);
        let (phi, q) = sys.full(n);
        // phi_top as a view into a larger matrix (column stride > k), or transposed
        // (row stride != 1).
        let big = Mat::from_fn(
            k + 5,
            n,
            |i, j| if i < k { sys.phi_top[(i, j)] } else { f64::NAN },
        );
        let phi_t = sys.phi_top.transpose().to_owned();
        let phi_top = if step % 2 == 0 {
            big.as_ref().subrows(0, k)
        } else {
            phi_t.as_ref().transpose()
        };
        kf.predict(phi_top, sys.q_top.as_ref()).unwrap();
        naive.predict(&to_row_major(&phi), &to_row_major(&q));
        // H row-major (row stride != 1) every other step.
        let h = rng.mat(m, n);
        let h_t = h.transpose().to_owned();
        let h_view = if step % 2 == 1 {
            h_t.as_ref().transpose()
        } else {
            h.as_ref()
        };
        let r = rng.spd(m);
        let z = rng.vec(m);
        let info = kf.update(&z, h_view, r.as_ref()).unwrap();
        let nis = naive
            .update(&z, &to_row_major(&h), &to_row_major(&r))
            .unwrap();
        let dp = rel_diff(&kf.covariance(), &from_row_major(&naive.p, n, n));
        assert!(dp < 1e-10, "step {step}: P differs by {dp:e}");
        assert!(rel_diff_vec(&kf.state(), &naive.x) < 1e-10);
        assert!((info.nis - nis).abs() <= 1e-9 * nis.max(1.0));
        assert_symmetric(&kf.covariance(), "strided");
    }
}

#[test]
fn failures_leave_the_filter_unchanged_and_it_goes_on() {
    let n = 28;
    let mut rng = Rng::new(5);
    let x0 = rng.vec(n);
    let p0 = rng.spd(n);
    let mut kf = KalmanFilter::new(&x0, p0.as_ref(), 6).unwrap();
    let sys = Structured::random(&mut rng, 3, n, 0.05);
    let (h, r, z) = (rng.mat(6, n), rng.spd(6), rng.vec(6));
    kf.update(&z, h.as_ref(), r.as_ref()).unwrap();
    let before = kf.clone();
    let unchanged = |g: &KalmanFilter| {
        assert_eq!(g.normalised_state(), before.normalised_state());
        assert_eq!(g.normalised_covariance(), before.normalised_covariance());
    };
    // a non-finite entry in H (last column, last row) or phi_top
    for v in [f64::NAN, f64::INFINITY] {
        let mut bad = h.clone();
        bad[(5, n - 1)] = v;
        let err = kf.update(&z, bad.as_ref(), r.as_ref()).unwrap_err();
        assert_eq!(err, KalmanError::NonFinite { what: "H" });
        unchanged(&kf);
        assert_eq!(kf.innovation(), before.innovation());
        assert_eq!(kf.gain(), before.gain());
        let mut bad = sys.phi_top.clone();
        bad[(2, 0)] = v;
        let err = kf.predict(bad.as_ref(), sys.q_top.as_ref()).unwrap_err();
        assert_eq!(err, KalmanError::NonFinite { what: "phi_top" });
        unchanged(&kf);
    }
    // S not positive definite: R very negative
    let neg = Mat::<f64>::identity(6, 6) * -1e6;
    let err = kf.update_covariance(h.as_ref(), neg.as_ref()).unwrap_err();
    assert!(matches!(err, KalmanError::NotPositiveDefinite { m: 6, .. }));
    unchanged(&kf);
    assert!(kf.gain().col_iter().all(|c| c.iter().all(|v| v.is_nan())));
    // and the filter goes on exactly like one that never failed
    let mut fresh = before.clone();
    for g in [&mut kf, &mut fresh] {
        g.predict(sys.phi_top.as_ref(), sys.q_top.as_ref()).unwrap();
        g.update(&z, h.as_ref(), r.as_ref()).unwrap();
    }
    assert_eq!(kf.normalised_covariance(), fresh.normalised_covariance());
    assert_eq!(kf.normalised_state(), fresh.normalised_state());
}

#[test]
fn empty_state_and_empty_measurement() {
    // n = 0: the update only reports S = R.
    let mut kf = KalmanFilter::new(&[], Mat::zeros(0, 0).as_ref(), 2).unwrap();
    let r = Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { 0.5 });
    let info = kf
        .update(&[1.0, -1.0], Mat::zeros(2, 0).as_ref(), r.as_ref())
        .unwrap();
    assert_eq!(kf.innovation_covariance().to_owned(), r);
    assert!((info.log_det_s - (4.0f64 - 0.25).ln()).abs() < 1e-14);
    kf.predict(Mat::zeros(0, 0).as_ref(), Mat::zeros(0, 0).as_ref())
        .unwrap();
    // m = 0 and k = 0: nothing changes.
    let mut rng = Rng::new(1);
    let p0 = rng.spd(5);
    let mut kf = KalmanFilter::new(&[1.0; 5], p0.as_ref(), 0).unwrap();
    let before = kf.normalised_covariance().to_owned();
    let info = kf
        .update(&[], Mat::zeros(0, 5).as_ref(), Mat::zeros(0, 0).as_ref())
        .unwrap();
    assert_eq!((info.nis, info.log_det_s, info.dim), (0.0, 0.0, 0));
    kf.predict(Mat::zeros(0, 5).as_ref(), Mat::zeros(0, 0).as_ref())
        .unwrap();
    assert_eq!(kf.normalised_covariance().to_owned(), before);
    assert!(rel_diff_vec(&kf.state(), &[1.0; 5]) < 1e-15);
}

/// The benchmark's dense baseline (`benches/dense/mod.rs`) is a correct filter too.
#[path = "../benches/dense/mod.rs"]
mod dense;

#[test]
fn dense_baseline_matches_naive_loops() {
    for n in [1, 28, 60] {
        let (m, steps) = (6, 4);
        let mut rng = Rng::new(21 + n as u64);
        let (x0, p0) = (rng.vec(n), rng.spd(n));
        let phi = rng.mat(n, n) * (1.0 / (n as f64).sqrt());
        let q = rng.spd(n) * 0.1;
        let r = rng.spd(m);
        let mut dense = dense::DenseFilter::new(&x0, p0.as_ref(), m);
        let mut naive = NaiveFilter::new(&x0, &to_row_major(&p0), m);
        for s in 0..steps {
            let (h, z) = (rng.mat(m, n), rng.vec(m));
            dense.predict(phi.as_ref(), q.as_ref());
            naive.predict(&to_row_major(&phi), &to_row_major(&q));
            let nis = dense.update(&z, h.as_ref(), r.as_ref()).unwrap();
            let nis_ref = naive
                .update(&z, &to_row_major(&h), &to_row_major(&r))
                .unwrap();
            let dp = rel_diff(
                &dense.covariance().to_owned(),
                &from_row_major(&naive.p, n, n),
            );
            assert!(dp < 1e-10, "n={n} step {s}: P differs by {dp:e}");
            assert!(rel_diff_vec(dense.state(), &naive.x) < 1e-10);
            assert!((nis - nis_ref).abs() <= 1e-10 * nis_ref.abs().max(1.0));
        }
    }
}

/// A measurement whose noise is correlated with the state's error, against the textbook update
/// of the augmented state `[x; v]` (joint covariance `[[P, M], [M^T, R]]`) measured without
/// noise through `[H I]`: the posterior of `x` is the top block. Sizes on both sides of the
/// engine's switch to faer's products; full and covariance-only mode; and `M = 0` gives the
/// plain update bit for bit.
#[test]
fn correlated_update_matches_the_augmented_state() {
    for (n, m) in [(1usize, 1usize), (3, 3), (24, 3), (33, 3), (60, 6)] {
        let what = format!("n = {n}, m = {m}");
        let mut rng = Rng::new(500 + (n * 10 + m) as u64);
        let joint = rng.spd(n + m);
        let p0 = Mat::from_fn(n, n, |i, j| joint[(i, j)]);
        let cross = Mat::from_fn(n, m, |i, j| joint[(i, n + j)]);
        let r = Mat::from_fn(m, m, |i, j| joint[(n + i, n + j)]);
        let (x0, h, z) = (rng.vec(n), rng.mat(m, n), rng.vec(m));

        let h_aug = Mat::from_fn(m, n + m, |a, j| {
            if j < n {
                h[(a, j)]
            } else if j - n == a {
                1.0
            } else {
                0.0
            }
        });
        let (s_ref, k_aug, log_det_ref) = reference_update(&joint, &h_aug, &Mat::zeros(m, m));
        let p_aug = &joint - &k_aug * (&h_aug * &joint);
        let p_ref = Mat::from_fn(n, n, |i, j| p_aug[(i, j)]);
        let nu: Vec<f64> = (0..m)
            .map(|a| z[a] - (0..n).map(|j| h[(a, j)] * x0[j]).sum::<f64>())
            .collect();
        let x_ref: Vec<f64> = (0..n)
            .map(|i| x0[i] + (0..m).map(|a| k_aug[(i, a)] * nu[a]).sum::<f64>())
            .collect();

        let mut kf = KalmanFilter::new(&x0, p0.as_ref(), m).unwrap();
        let info = kf
            .update_correlated(&z, h.as_ref(), r.as_ref(), cross.as_ref())
            .unwrap();
        let dp = rel_diff(&kf.covariance(), &p_ref);
        assert!(dp < 1e-10, "{what}: P differs by {dp:e}");
        assert_symmetric(&kf.covariance(), &what);
        let dx = rel_diff_vec(&kf.state(), &x_ref);
        assert!(dx < 1e-10, "{what}: x differs by {dx:e}");
        assert!(rel_diff(&kf.innovation_covariance().to_owned(), &s_ref) < 1e-12);
        assert!((info.log_det_s - log_det_ref).abs() <= 1e-10 * log_det_ref.abs().max(1.0));
        let k_ref = Mat::from_fn(n, m, |i, a| k_aug[(i, a)]);
        assert!(rel_diff(&kf.gain(), &k_ref) < 1e-10, "{what}: gain");
        check_gain_times(&kf, &what);
        // The correlation matters here (the test would pass a plain update otherwise).
        let mut plain = KalmanFilter::new(&x0, p0.as_ref(), m).unwrap();
        plain.update(&z, h.as_ref(), r.as_ref()).unwrap();
        assert!(rel_diff(&plain.covariance(), &p_ref) > 1e-6, "{what}");

        let mut cov = KalmanFilter::new(&x0, p0.as_ref(), m).unwrap();
        cov.update_covariance_correlated(h.as_ref(), r.as_ref(), cross.as_ref())
            .unwrap();
        assert_eq!(cov.covariance(), kf.covariance(), "{what}: covariance-only");

        let mut zero = KalmanFilter::new(&x0, p0.as_ref(), m).unwrap();
        zero.update_correlated(&z, h.as_ref(), r.as_ref(), Mat::zeros(n, m).as_ref())
            .unwrap();
        assert_eq!(zero.covariance(), plain.covariance(), "{what}: M = 0");
        assert_eq!(zero.state(), plain.state(), "{what}: M = 0");
    }
}
