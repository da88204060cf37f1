//! The faer engine against the naive loop reference and against the textbook formulas.

mod common;

use common::*;
use faer::Mat;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::{ColMut, ColRef, Par};
use kalman::KalmanFilter;
use kalman::dense::DenseFilter;
use kalman::reference::{NaiveFilter, invert, matmul, transpose};
use kalman::update::{
    joseph_covariance, joseph_covariance_scratch, joseph_update, joseph_update_scratch,
    state_update, state_update_scratch,
};

const M: usize = 6;

struct Problem {
    x0: Vec<f64>,
    p0: Mat<f64>,
    phi: Mat<f64>,
    q: Mat<f64>,
    h: Vec<Mat<f64>>,
    r: Mat<f64>,
    z: Vec<Vec<f64>>,
}

fn problem(n: usize, steps: usize, seed: u64) -> Problem {
    let mut rng = Rng::new(seed);
    let x0 = rng.vec(n);
    let p0 = rng.spd(n);
    // A random transition of spectral size about 1.
    let phi = rng.mat(n, n) * (1.0 / (n as f64).sqrt());
    let q = rng.spd(n) * 0.1;
    let h = (0..steps).map(|_| rng.mat(M, n)).collect();
    let r = rng.spd(M);
    let z = (0..steps).map(|_| rng.vec(M)).collect();
    Problem {
        x0,
        p0,
        phi,
        q,
        h,
        r,
        z,
    }
}

#[test]
fn dense_predict_and_update_match_naive_loops() {
    for n in [28, 60] {
        let steps = 5;
        let pb = problem(n, steps, 11 + n as u64);
        let mut kf = KalmanFilter::new(&pb.x0, pb.p0.as_ref(), M).unwrap();
        let mut naive = NaiveFilter::new(&pb.x0, &to_row_major(&pb.p0), M);
        let (phi_rm, q_rm, r_rm) = (
            to_row_major(&pb.phi),
            to_row_major(&pb.q),
            to_row_major(&pb.r),
        );
        for s in 0..steps {
            kf.predict(pb.phi.as_ref(), pb.q.as_ref()).unwrap();
            naive.predict(&phi_rm, &q_rm);
            let info = kf
                .update(&pb.z[s], pb.h[s].as_ref(), pb.r.as_ref())
                .unwrap();
            let nis = naive
                .update(&pb.z[s], &to_row_major(&pb.h[s]), &r_rm)
                .unwrap();
            let p_ref = from_row_major(&naive.p, n, n);
            let p = kf.covariance().to_owned();
            let dp = rel_diff(&p, &p_ref);
            let dx = rel_diff_vec(kf.state(), &naive.x);
            assert!(dp < 1e-10, "n={n} step {s}: P differs by {dp:e}");
            assert!(dx < 1e-10, "n={n} step {s}: x differs by {dx:e}");
            assert!(
                (info.nis - nis).abs() <= 1e-10 * nis.abs(),
                "NIS {} vs {nis}",
                info.nis
            );
            assert_eq!(info.dim, M);
        }
    }
}

/// The benchmark baseline is a correct filter too.
#[test]
fn dense_baseline_matches_naive_loops() {
    for n in [1, 28, 60] {
        let steps = 4;
        let pb = problem(n, steps, 21 + n as u64);
        let mut dense = DenseFilter::new(&pb.x0, pb.p0.as_ref(), M);
        let mut naive = NaiveFilter::new(&pb.x0, &to_row_major(&pb.p0), M);
        let (phi_rm, q_rm, r_rm) = (
            to_row_major(&pb.phi),
            to_row_major(&pb.q),
            to_row_major(&pb.r),
        );
        for s in 0..steps {
            dense.predict(pb.phi.as_ref(), pb.q.as_ref()).unwrap();
            naive.predict(&phi_rm, &q_rm);
            let info = dense
                .update(&pb.z[s], pb.h[s].as_ref(), pb.r.as_ref())
                .unwrap();
            let nis = naive
                .update(&pb.z[s], &to_row_major(&pb.h[s]), &r_rm)
                .unwrap();
            let dp = rel_diff(
                &dense.covariance().to_owned(),
                &from_row_major(&naive.p, n, n),
            );
            assert!(dp < 1e-10, "n={n} step {s}: P differs by {dp:e}");
            assert!(rel_diff_vec(dense.state(), &naive.x) < 1e-10);
            assert!((info.nis - nis).abs() <= 1e-10 * nis.abs().max(1.0));
        }
    }
}

#[test]
fn structured_predict_equals_dense_predict() {
    for n in [28, 60] {
        for k in [1, 3, n] {
            let mut rng = Rng::new(100 + (n * 7 + k) as u64);
            let x0 = rng.vec(n);
            let p0 = rng.spd(n);
            let sys = Structured::random(&mut rng, k, n, 0.1);
            let (phi, q) = sys.full(n);
            let mut a = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
            let mut b = a.clone();
            for _ in 0..4 {
                a.predict_structured(sys.phi_top.as_ref(), sys.q_top.as_ref())
                    .unwrap();
                b.predict(phi.as_ref(), q.as_ref()).unwrap();
            }
            let dp = rel_diff(&a.covariance().to_owned(), &b.covariance().to_owned());
            let dx = rel_diff_vec(a.state(), b.state());
            assert!(dp < 1e-13, "n={n} k={k}: P differs by {dp:e}");
            assert!(dx < 1e-13, "n={n} k={k}: x differs by {dx:e}");
            // and against the naive loops with the full matrices
            let mut naive = NaiveFilter::new(&x0, &to_row_major(&p0), M);
            for _ in 0..4 {
                naive.predict(&to_row_major(&phi), &to_row_major(&q));
            }
            let dn = rel_diff(&a.covariance().to_owned(), &from_row_major(&naive.p, n, n));
            assert!(dn < 1e-12, "n={n} k={k}: P differs from naive by {dn:e}");
        }
    }
}

/// Textbook `P - K H P` with the optimal gain, computed with the naive loops.
fn textbook(p: &Mat<f64>, h: &Mat<f64>, r: &Mat<f64>) -> Mat<f64> {
    let (n, m) = (p.nrows(), h.nrows());
    let (p_rm, h_rm, r_rm) = (to_row_major(p), to_row_major(h), to_row_major(r));
    let mut ht = vec![0.0; n * m];
    transpose(&mut ht, &h_rm, m, n);
    let mut hp = vec![0.0; m * n];
    matmul(&mut hp, &h_rm, &p_rm, m, n, n);
    let mut s = vec![0.0; m * m];
    matmul(&mut s, &hp, &ht, m, n, m);
    s.iter_mut().zip(&r_rm).for_each(|(a, b)| *a += b);
    let mut sinv = vec![0.0; m * m];
    invert(&mut s, &mut sinv, m).unwrap();
    let mut pht = vec![0.0; n * m];
    matmul(&mut pht, &p_rm, &ht, n, n, m);
    let mut k = vec![0.0; n * m];
    matmul(&mut k, &pht, &sinv, n, m, m);
    let mut khp = vec![0.0; n * n];
    matmul(&mut khp, &k, &hp, n, m, n);
    let out: Vec<f64> = p_rm.iter().zip(&khp).map(|(a, b)| a - b).collect();
    from_row_major(&out, n, n)
}

#[test]
fn joseph_update_equals_textbook_for_optimal_gain() {
    for n in [28, 60] {
        let mut rng = Rng::new(7 + n as u64);
        let p0 = rng.spd(n);
        let h = rng.mat(M, n);
        let r = rng.spd(M);
        let mut kf = KalmanFilter::new(&vec![0.0; n], p0.as_ref(), M).unwrap();
        kf.update_covariance(h.as_ref(), r.as_ref()).unwrap();
        let expected = textbook(&p0, &h, &r);
        let d = rel_diff(&kf.covariance().to_owned(), &expected);
        assert!(d < 1e-12, "n={n}: Joseph differs from textbook by {d:e}");
        // and the update really did something
        assert!(rel_diff(&p0, &expected) > 1e-3);
    }
}

#[test]
fn joseph_kernel_is_the_joseph_form_for_any_gain() {
    let n = 28;
    let mut rng = Rng::new(5);
    let p0 = rng.spd(n);
    let h = rng.mat(M, n);
    let r = rng.spd(M);
    let k = rng.mat(n, M) * 0.1; // deliberately not the optimal gain
    let b = &p0 * h.transpose();
    let s = &h * &b + &r;

    let mut p = p0.clone();
    let mut buf = MemBuffer::new(joseph_covariance_scratch(n, M));
    joseph_covariance(
        p.as_mut(),
        k.as_ref(),
        b.as_ref(),
        s.as_ref(),
        Par::Seq,
        MemStack::new(&mut buf),
    )
    .unwrap();

    let mut naive = NaiveFilter::new(&vec![0.0; n], &to_row_major(&p0), M);
    naive.joseph_with_gain(&to_row_major(&k), &to_row_major(&h), &to_row_major(&r), M);
    let literal = from_row_major(&naive.p, n, n);
    let d = rel_diff(&p, &literal);
    assert!(
        d < 1e-12,
        "Joseph kernel differs from the literal form by {d:e}"
    );

    // For a suboptimal gain the textbook P - K H P is a different matrix: the test above
    // would catch a kernel that silently used it.
    let textbook_k = &p0 - &k * (&h * &p0);
    assert!(rel_diff(&textbook_k, &literal) > 1e-3);
}

#[test]
fn covariance_only_equals_full_mode() {
    let n = 28;
    let mut rng = Rng::new(99);
    let p0 = rng.spd(n);
    let sys = Structured::random(&mut rng, 3, n, 0.05);
    let (phi, q) = sys.full(n);
    let r = rng.spd(M);
    let mut full = KalmanFilter::new(&rng.vec(n), p0.as_ref(), M).unwrap();
    let mut cov = full.clone();
    for step in 0..20 {
        let h = rng.mat(M, n);
        let z = rng.vec(M);
        if step % 2 == 0 {
            full.predict_structured(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
            cov.predict_structured_covariance(sys.phi_top.as_ref(), sys.q_top.as_ref())
                .unwrap();
        } else {
            full.predict(phi.as_ref(), q.as_ref()).unwrap();
            cov.predict_covariance(phi.as_ref(), q.as_ref()).unwrap();
        }
        full.update(&z, h.as_ref(), r.as_ref()).unwrap();
        cov.update_covariance(h.as_ref(), r.as_ref()).unwrap();
    }
    // Same arithmetic, so bit for bit the same covariance.
    assert_eq!(full.covariance().to_owned(), cov.covariance().to_owned());
    // And the covariance-only filter never touched its state.
    assert_ne!(full.state(), cov.state());
}

#[test]
fn free_kernels_agree_with_the_filter() {
    let n = 28;
    let mut rng = Rng::new(1234);
    let p0 = rng.spd(n);
    let x0 = rng.vec(n);
    let h = rng.mat(M, n);
    let r = rng.spd(M);
    let z = rng.vec(M);
    let mut kf = KalmanFilter::new(&x0, p0.as_ref(), M).unwrap();
    let info = kf.update(&z, h.as_ref(), r.as_ref()).unwrap();

    let mut p = p0.clone();
    let mut x = x0.clone();
    let mut gain = Mat::<f64>::zeros(n, M);
    let mut l = Mat::<f64>::zeros(M, M);
    let mut nu = vec![0.0; M];
    let mut buf = MemBuffer::new(StackReq::any_of(&[
        joseph_update_scratch(n, M),
        state_update_scratch(M),
    ]));
    let log_det = joseph_update(
        p.as_mut(),
        h.as_ref(),
        r.as_ref(),
        gain.as_mut(),
        l.as_mut(),
        Par::Seq,
        MemStack::new(&mut buf),
    )
    .unwrap();
    let nis = state_update(
        ColMut::from_slice_mut(&mut x),
        ColMut::from_slice_mut(&mut nu),
        ColRef::from_slice(&z),
        h.as_ref(),
        gain.as_ref(),
        l.as_ref(),
        MemStack::new(&mut buf),
    )
    .unwrap();
    // The filter runs its own kernels (`P - W W^T` on its padded storage), the free functions
    // faer's products (the expanded Joseph form): the same update up to rounding.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1.0);
    assert!(rel_diff(&p, &kf.covariance().to_owned()) < 1e-12);
    assert!(rel_diff_vec(&x, kf.state()) < 1e-12);
    assert!(rel_diff_vec(&nu, kf.innovation()) < 1e-13);
    assert!(rel_diff(&gain, &kf.gain().to_owned()) < 1e-12);
    assert!(close(nis, info.nis), "NIS {nis} vs {}", info.nis);
    assert!(close(log_det, info.log_det_s));
    // S = L L^T is the reported innovation covariance, and ln det S matches.
    let s = kf.innovation_covariance().to_owned();
    assert!(rel_diff(&(&l * l.transpose()), &s) < 1e-14);
    let det_l: f64 = (0..M).map(|i| l[(i, i)]).product();
    assert!((2.0 * det_l.ln() - log_det).abs() < 1e-12);
}
