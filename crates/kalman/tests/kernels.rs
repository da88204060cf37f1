//! The filter's own kernels (structured predict and measurement update on its padded storage,
//! for every kernel set the CPU supports) against the naive loops of `kalman::reference`, at
//! sizes around the block boundaries of the kernels (n = 1, 3, 24, 28, 60, 61; m = 1, 3, 6, and
//! m > 8, which takes the general path), in full and covariance-only mode, with changing
//! measurement and dynamic-state dimensions and with strided inputs.

mod common;

use common::*;
use faer::Mat;
use kalman::reference::{NaiveFilter, invert, matmul, transpose};
use kalman::{KalmanError, KalmanFilter};

/// The kernel sets this CPU can run (always including the portable one).
fn kernel_sets() -> Vec<&'static str> {
    let mut probe = KalmanFilter::from_diagonal(&[0.0], &[1.0], 1).unwrap();
    ["portable", "avx2", "avx512"]
        .into_iter()
        .filter(|name| probe.select_kernel_set(name))
        .collect()
}

fn filter(set: &str, x0: &[f64], p0: &Mat<f64>, m_max: usize) -> KalmanFilter {
    let mut kf = KalmanFilter::new(x0, p0.as_ref(), m_max).unwrap();
    assert!(kf.select_kernel_set(set));
    assert_eq!(kf.kernel_set(), set);
    kf
}

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
    let s = from_row_major(&s, m, m) + r;
    let s = sym(s);
    let mut work = to_row_major(&s);
    let mut sinv = vec![0.0; m * m];
    invert(&mut work, &mut sinv, m).unwrap();
    let mut k = vec![0.0; n * m];
    matmul(&mut k, &pht, &sinv, n, m, m);
    let l = cholesky(&s);
    let log_det = 2.0 * (0..m).map(|i| l[(i, i)].ln()).sum::<f64>();
    (s, from_row_major(&k, n, m), log_det)
}

fn assert_symmetric(p: &Mat<f64>, what: &str) {
    for j in 0..p.ncols() {
        for i in 0..j {
            assert_eq!(p[(i, j)], p[(j, i)], "{what}: P[{i}, {j}] != P[{j}, {i}]");
        }
    }
}

/// A few predict + update steps of the filter (full and covariance-only) against the naive
/// reference, comparing everything the filter reports.
fn check_steps(set: &str, n: usize, m: usize, k: usize, seed: u64) {
    let what = format!("{set}, n = {n}, m = {m}, k = {k}");
    let mut rng = Rng::new(seed);
    let x0 = rng.vec(n);
    let p0 = rng.spd(n);
    let sys = Structured::random(&mut rng, k, n, 0.05);
    let (phi, q) = sys.full(n);
    let (phi_rm, q_rm) = (to_row_major(&phi), to_row_major(&q));
    let r = rng.spd(m);
    let r_rm = to_row_major(&r);

    let mut kf = filter(set, &x0, &p0, m);
    let mut cov = kf.clone();
    let mut naive = NaiveFilter::new(&x0, &to_row_major(&p0), m);
    for step in 0..4 {
        // Mostly the structured predict; once the dense one.
        if step == 2 {
            kf.predict(phi.as_ref(), q.as_ref()).unwrap();
            cov.predict_covariance(phi.as_ref(), q.as_ref()).unwrap();
        } else {
            kf.predict_structured(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
            cov.predict_structured_covariance(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
        }
        naive.predict(&phi_rm, &q_rm);
        let dp = rel_diff(&kf.covariance().to_owned(), &from_row_major(&naive.p, n, n));
        assert!(
            dp < 1e-12,
            "{what}, step {step}: predicted P differs by {dp:e}"
        );
        assert!(
            rel_diff_vec(kf.state(), &naive.x) < 1e-12,
            "{what}: predicted x"
        );
        assert_symmetric(&kf.covariance().to_owned(), &what);

        let h = rng.mat(m, n);
        let z = rng.vec(m);
        let p_prior = from_row_major(&naive.p, n, n);
        let x_prior = naive.x.clone();
        let (s_ref, k_ref, log_det_ref) = reference_update(&p_prior, &h, &r);
        let info = kf.update(&z, h.as_ref(), r.as_ref()).unwrap();
        cov.update_covariance(h.as_ref(), r.as_ref()).unwrap();
        let nis_ref = naive.update(&z, &to_row_major(&h), &r_rm).unwrap();

        let p = kf.covariance().to_owned();
        let dp = rel_diff(&p, &from_row_major(&naive.p, n, n));
        assert!(dp < 1e-10, "{what}, step {step}: P differs by {dp:e}");
        assert_symmetric(&p, &what);
        let dx = rel_diff_vec(kf.state(), &naive.x);
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
        assert_eq!(info.dim, m);
        let s = kf.innovation_covariance().to_owned();
        assert!(rel_diff(&s, &s_ref) < 1e-12, "{what}: S");
        assert_symmetric(&s, &what);
        assert!(
            rel_diff(&kf.gain().to_owned(), &k_ref) < 1e-10,
            "{what}: gain"
        );
        let nu_ref: Vec<f64> = (0..m)
            .map(|a| z[a] - (0..n).map(|j| h[(a, j)] * x_prior[j]).sum::<f64>())
            .collect();
        assert!(
            rel_diff_vec(kf.innovation(), &nu_ref) < 1e-12,
            "{what}: innovation"
        );

        // Covariance-only mode: the same covariance arithmetic, bit for bit; x untouched.
        assert_eq!(cov.covariance().to_owned(), p, "{what}: covariance-only P");
        assert_eq!(cov.state(), &x0[..], "{what}: covariance-only x");
        assert!(cov.innovation().iter().all(|v| v.is_nan()));
        assert_eq!(cov.gain().to_owned(), kf.gain().to_owned());
    }
}

#[test]
fn step_matches_the_naive_reference_for_every_kernel_set_and_size() {
    for set in kernel_sets() {
        for n in [1usize, 3, 24, 28, 60, 61] {
            for m in [1usize, 3, 6] {
                let k = n.min(3);
                check_steps(set, n, m, k, (n * 100 + m) as u64);
            }
        }
    }
}

#[test]
fn more_dynamic_states_and_larger_measurements_take_the_general_paths() {
    for set in kernel_sets() {
        // k = n (the whole matrix is dynamic), k = 9 (more than 8 columns per pass)
        check_steps(set, 12, 3, 12, 1);
        check_steps(set, 28, 6, 9, 2);
        // m > 8: the factorisation and solves for any m
        check_steps(set, 28, 9, 3, 3);
        check_steps(set, 24, 12, 3, 4);
        check_steps(set, 5, 17, 5, 5);
    }
}

#[test]
fn changing_dimensions_and_strided_inputs() {
    for set in kernel_sets() {
        let n = 28;
        let mut rng = Rng::new(77);
        let x0 = rng.vec(n);
        let p0 = rng.spd(n);
        let mut kf = filter(set, &x0, &p0, 9);
        let mut naive = NaiveFilter::new(&x0, &to_row_major(&p0), 9);
        // (m, k) per step: both shrink and grow, across the 8-row block of the padded copies.
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
            kf.predict_structured(phi_top, sys.q_top.as_ref()).unwrap();
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
            let dp = rel_diff(&kf.covariance().to_owned(), &from_row_major(&naive.p, n, n));
            assert!(dp < 1e-10, "{set}, step {step}: P differs by {dp:e}");
            assert!(rel_diff_vec(kf.state(), &naive.x) < 1e-10);
            assert!((info.nis - nis).abs() <= 1e-9 * nis.max(1.0));
            assert_symmetric(&kf.covariance().to_owned(), set);
        }
    }
}

#[test]
fn failures_leave_every_kernel_set_unchanged() {
    for set in kernel_sets() {
        let n = 28;
        let mut rng = Rng::new(5);
        let x0 = rng.vec(n);
        let p0 = rng.spd(n);
        let mut kf = filter(set, &x0, &p0, 6);
        let sys = Structured::random(&mut rng, 3, n, 0.05);
        let (h, r, z) = (rng.mat(6, n), rng.spd(6), rng.vec(6));
        kf.update(&z, h.as_ref(), r.as_ref()).unwrap();
        let before = kf.clone();
        let unchanged = |g: &KalmanFilter| {
            assert_eq!(g.state(), before.state(), "{set}: state changed");
            assert_eq!(
                g.covariance().to_owned(),
                before.covariance().to_owned(),
                "{set}: covariance changed"
            );
        };
        // a non-finite entry in H (last column, last row) or phi_top
        for v in [f64::NAN, f64::INFINITY] {
            let mut bad = h.clone();
            bad[(5, n - 1)] = v;
            let err = kf.update(&z, bad.as_ref(), r.as_ref()).unwrap_err();
            assert_eq!(err, KalmanError::NonFinite { what: "H" });
            unchanged(&kf);
            assert_eq!(kf.innovation(), before.innovation());
            let mut bad = sys.phi_top.clone();
            bad[(2, 0)] = v;
            let err = kf
                .predict_structured(bad.as_ref(), sys.q_top.as_ref())
                .unwrap_err();
            assert_eq!(err, KalmanError::NonFinite { what: "phi_top" });
            unchanged(&kf);
        }
        // S not positive definite: R very negative
        let neg = Mat::<f64>::identity(6, 6) * -1e6;
        let err = kf.update_covariance(h.as_ref(), neg.as_ref()).unwrap_err();
        assert!(matches!(err, KalmanError::NotPositiveDefinite { m: 6, .. }));
        unchanged(&kf);
        assert!(
            kf.gain()
                .to_owned()
                .col_iter()
                .all(|c| c.iter().all(|v| v.is_nan()))
        );
        // and the filter goes on exactly like one that never failed
        let mut fresh = before.clone();
        for g in [&mut kf, &mut fresh] {
            g.predict_structured(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
            g.update(&z, h.as_ref(), r.as_ref()).unwrap();
        }
        assert_eq!(kf.covariance().to_owned(), fresh.covariance().to_owned());
        assert_eq!(kf.state(), fresh.state());
    }
}

#[test]
fn kernel_sets_agree() {
    let sets = kernel_sets();
    let n = 28;
    let mut rng = Rng::new(9);
    let x0 = rng.vec(n);
    let p0 = rng.spd(n);
    let sys = Structured::random(&mut rng, 3, n, 0.05);
    let steps: Vec<_> = (0..20)
        .map(|_| (rng.mat(3, n), rng.spd(3), rng.vec(3)))
        .collect();
    let run = |set: &str| {
        let mut kf = filter(set, &x0, &p0, 3);
        for (h, r, z) in &steps {
            kf.predict_structured(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
            kf.update(z, h.as_ref(), r.as_ref()).unwrap();
        }
        kf
    };
    let portable = run("portable");
    for set in sets {
        let kf = run(set);
        assert!(
            rel_diff(
                &kf.covariance().to_owned(),
                &portable.covariance().to_owned()
            ) < 1e-12
        );
        assert!(rel_diff_vec(kf.state(), portable.state()) < 1e-12);
    }
}

#[test]
fn empty_state_and_empty_measurement() {
    for set in kernel_sets() {
        // n = 0: the update only reports S = R.
        let mut kf = filter(set, &[], &Mat::zeros(0, 0), 2);
        let r = Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { 0.5 });
        let info = kf
            .update(&[1.0, -1.0], Mat::zeros(2, 0).as_ref(), r.as_ref())
            .unwrap();
        assert_eq!(kf.innovation_covariance().to_owned(), r);
        assert!((info.log_det_s - (4.0f64 - 0.25).ln()).abs() < 1e-14);
        kf.predict_structured(Mat::zeros(0, 0).as_ref(), Mat::zeros(0, 0).as_ref())
            .unwrap();
        // m = 0 and k = 0: nothing changes.
        let mut rng = Rng::new(1);
        let p0 = rng.spd(5);
        let mut kf = filter(set, &[1.0; 5], &p0, 0);
        let info = kf
            .update(&[], Mat::zeros(0, 5).as_ref(), Mat::zeros(0, 0).as_ref())
            .unwrap();
        assert_eq!((info.nis, info.log_det_s, info.dim), (0.0, 0.0, 0));
        kf.predict_structured(Mat::zeros(0, 5).as_ref(), Mat::zeros(0, 0).as_ref())
            .unwrap();
        assert_eq!(kf.covariance().to_owned(), p0);
        assert_eq!(kf.state(), &[1.0; 5]);
    }
}
