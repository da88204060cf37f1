//! Problems whose answer is known in closed form.

mod common;

use common::*;
use faer::mat;
use kalman::KalmanFilter;

/// A constant observed N times with noise variance r, prior N(x0, p0):
/// P_N = 1 / (1/p0 + N/r), x_N = P_N (x0/p0 + sum z / r), after every update.
#[test]
fn scalar_constant_matches_the_posterior_formula() {
    let (x0, p0, r): (f64, f64, f64) = (1.0, 4.0, 0.5);
    let truth = 2.3;
    let mut rng = Rng::new(17);
    let mut kf = KalmanFilter::from_diagonal(&[x0], &[p0.sqrt()], 1).unwrap();
    let (h, rm) = (mat![[1.0]], mat![[r]]);
    let mut sum_z = 0.0;
    for k in 1..=1000 {
        let z = truth + r.sqrt() * rng.normal();
        sum_z += z;
        kf.update(&[z], h.as_ref(), rm.as_ref()).unwrap();
        let p = 1.0 / (1.0 / p0 + k as f64 / r);
        let x = p * (x0 / p0 + sum_z / r);
        let (pk, xk) = (kf.covariance()[(0, 0)], kf.state()[0]);
        assert!((pk - p).abs() <= 1e-12 * p, "step {k}: P {pk} vs {p}");
        assert!(
            (xk - x).abs() <= 1e-10 * x.abs().max(1.0),
            "step {k}: x {xk} vs {x}"
        );
    }
    // and the estimate is where it should be: within 4 sigma of the truth
    assert!((kf.state()[0] - truth).abs() < 4.0 * kf.std_dev(0));
}

/// A vector of constants observed through a fixed H (m = 2) with correlated noise R:
/// the information form P_N^-1 = P0^-1 + N H^T R^-1 H.
#[test]
fn vector_constant_matches_the_information_form() {
    let n = 3;
    let mut rng = Rng::new(5);
    let p0 = rng.spd(n);
    let h = rng.mat(2, n);
    let r = mat![[0.5, 0.2], [0.2, 0.3]];
    let mut kf = KalmanFilter::new(&[0.0; 3], p0.as_ref(), 2).unwrap();
    let steps = 50;
    for _ in 0..steps {
        kf.update_covariance(h.as_ref(), r.as_ref()).unwrap();
    }
    let info = inv(&p0) + h.transpose() * inv(&r) * &h * (steps as f64);
    let expected = inv(&info);
    let d = rel_diff(&kf.covariance().to_owned(), &expected);
    assert!(d < 1e-10, "information form differs by {d:e}");
}

/// A random walk x' = x + w, var(w) = q, observed with variance r converges to the steady-state
/// Riccati solution: prior P- = (q + sqrt(q^2 + 4 q r)) / 2, posterior P+ = P- r / (P- + r);
/// whatever the scale factor the filter works with.
#[test]
fn random_walk_reaches_the_riccati_steady_state() {
    let (q, r): (f64, f64) = (0.01, 1.0);
    let prior = (q + (q * q + 4.0 * q * r).sqrt()) / 2.0;
    let posterior = prior * r / (prior + r);
    let one = mat![[1.0]];
    let (qm, rm) = (mat![[q]], mat![[r]]);
    for scale in [10.0, 1.0, 1e-3] {
        let p0 = mat![[100.0]];
        let mut kf = KalmanFilter::with_scale(&[0.0], p0.as_ref(), vec![scale], 1).unwrap();
        for _ in 0..2000 {
            kf.predict_covariance(one.as_ref(), qm.as_ref()).unwrap();
            assert!(kf.covariance()[(0, 0)] > 0.0);
            kf.update_covariance(one.as_ref(), rm.as_ref()).unwrap();
        }
        kf.predict_covariance(one.as_ref(), qm.as_ref()).unwrap();
        let p_prior = kf.covariance()[(0, 0)];
        kf.update_covariance(one.as_ref(), rm.as_ref()).unwrap();
        let p_post = kf.covariance()[(0, 0)];
        assert!(
            (p_prior - prior).abs() < 1e-12 * prior,
            "scale {scale}: prior {p_prior} vs {prior}"
        );
        assert!(
            (p_post - posterior).abs() < 1e-12 * posterior,
            "scale {scale}: posterior {p_post} vs {posterior}"
        );
        // S of the last update is P- + r, and the gain P- / (P- + r)
        let s = kf.innovation_covariance()[(0, 0)];
        assert!((s - (prior + r)).abs() < 1e-12 * s);
        assert!((kf.gain()[(0, 0)] - prior / (prior + r)).abs() < 1e-12);
    }
}

/// NIS and ln det S of a scalar update by hand.
#[test]
fn update_info_is_the_scalar_formula() {
    let mut kf = KalmanFilter::from_diagonal(&[1.0, -2.0], &[2.0, 3.0], 1).unwrap();
    let h = mat![[1.0, 1.0]];
    let r = mat![[0.5]];
    let info = kf.update(&[0.5], h.as_ref(), r.as_ref()).unwrap();
    let s = 4.0 + 9.0 + 0.5;
    let nu: f64 = 0.5 - (1.0 - 2.0);
    assert!((info.nis - nu * nu / s).abs() < 1e-14);
    assert!((info.log_det_s - s.ln()).abs() < 1e-14);
    assert_eq!(info.dim, 1);
    assert!((kf.innovation()[0] - nu).abs() < 1e-15);
    // x = x0 + K nu with K = P H^T / s
    assert!((kf.state()[0] - (1.0 + 4.0 / s * nu)).abs() < 1e-14);
    assert!((kf.state()[1] - (-2.0 + 9.0 / s * nu)).abs() < 1e-14);
    // P = P0 - K H P0
    let p = kf.covariance();
    assert!((p[(0, 0)] - (4.0 - 16.0 / s)).abs() < 1e-14);
    assert!((p[(0, 1)] - (-36.0 / s)).abs() < 1e-14);
    assert_eq!(p[(0, 1)], p[(1, 0)]);
}
