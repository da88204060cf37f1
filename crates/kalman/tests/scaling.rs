//! Normalisation by prior sigma: round trips, invariance of the filter, and the wide-range case
//! it exists for.

mod common;

use common::*;
use faer::Mat;
use kalman::{KalmanFilter, Scaling};

fn diag(v: &[f64]) -> Mat<f64> {
    Mat::from_fn(v.len(), v.len(), |i, j| if i == j { v[i] } else { 0.0 })
}

fn log_spaced(n: usize, lo: f64, hi: f64) -> Vec<f64> {
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

#[test]
fn transformations_match_the_matrix_definitions_and_round_trip() {
    let (n, k, m) = (7, 3, 2);
    let mut rng = Rng::new(21);
    let sigma: Vec<f64> = (0..n).map(|_| (3.0 * rng.normal()).exp()).collect();
    let sc = Scaling::new(&sigma).unwrap();
    let d = diag(&sigma);
    let dinv = diag(&sigma.iter().map(|s| 1.0 / s).collect::<Vec<_>>());

    let x = rng.vec(n);
    let p = rng.spd(n);
    let phi = rng.mat(n, n);
    let phi_top = rng.mat(k, n);
    let q_top = rng.spd(k);
    let h = rng.mat(m, n);

    let mut xs = x.clone();
    sc.normalise_state(&mut xs).unwrap();
    for i in 0..n {
        assert!((xs[i] - x[i] / sigma[i]).abs() <= 1e-15 * xs[i].abs());
    }
    let mut ps = p.clone();
    sc.normalise_covariance(ps.as_mut()).unwrap();
    assert!(rel_diff(&ps, &(&dinv * &p * &dinv)) < 1e-15);
    let mut phis = phi.clone();
    sc.normalise_transition(phis.as_mut()).unwrap();
    assert!(rel_diff(&phis, &(&dinv * &phi * &d)) < 1e-15);
    // phi_top: the first k rows of D^-1 Phi D
    let mut pts = phi_top.clone();
    sc.normalise_transition(pts.as_mut()).unwrap();
    let dk_inv = diag(&sigma[..k].iter().map(|s| 1.0 / s).collect::<Vec<_>>());
    assert!(rel_diff(&pts, &(&dk_inv * &phi_top * &d)) < 1e-15);
    // q_top: the leading block of D^-1 Q D^-1
    let mut qs = q_top.clone();
    sc.normalise_covariance(qs.as_mut()).unwrap();
    assert!(rel_diff(&qs, &(&dk_inv * &q_top * &dk_inv)) < 1e-15);
    let mut hs = h.clone();
    sc.normalise_measurement(hs.as_mut()).unwrap();
    assert!(rel_diff(&hs, &(&h * &d)) < 1e-15);

    // and back
    sc.denormalise_state(&mut xs).unwrap();
    sc.denormalise_covariance(ps.as_mut()).unwrap();
    sc.denormalise_transition(phis.as_mut()).unwrap();
    sc.denormalise_transition(pts.as_mut()).unwrap();
    sc.denormalise_covariance(qs.as_mut()).unwrap();
    sc.denormalise_measurement(hs.as_mut()).unwrap();
    assert!(rel_diff_vec(&xs, &x) < 1e-15);
    assert!(rel_diff(&ps, &p) < 1e-15);
    assert!(rel_diff(&phis, &phi) < 1e-15);
    assert!(rel_diff(&pts, &phi_top) < 1e-15);
    assert!(rel_diff(&qs, &q_top) < 1e-15);
    assert!(rel_diff(&hs, &h) < 1e-15);
}

/// A physical-units system built from a well-conditioned normalised one.
struct Physical {
    sigma: Vec<f64>,
    x0: Vec<f64>,
    phi_top: Mat<f64>,
    q_top: Mat<f64>,
    h: Vec<Mat<f64>>,
    r: Mat<f64>,
    z: Vec<Vec<f64>>,
}

fn physical(n: usize, k: usize, m: usize, steps: usize, sigma: Vec<f64>, seed: u64) -> Physical {
    let mut rng = Rng::new(seed);
    let sc = Scaling::new(&sigma).unwrap();
    let sys = Structured::random(&mut rng, k, n, 0.05);
    let (mut phi_top, mut q_top) = (sys.phi_top, sys.q_top);
    sc.denormalise_transition(phi_top.as_mut()).unwrap();
    sc.denormalise_covariance(q_top.as_mut()).unwrap();
    let h = (0..steps)
        .map(|_| {
            let mut h = rng.mat(m, n);
            sc.denormalise_measurement(h.as_mut()).unwrap();
            h
        })
        .collect();
    let mut x0 = rng.vec(n);
    sc.denormalise_state(&mut x0).unwrap();
    Physical {
        sigma,
        x0,
        phi_top,
        q_top,
        h,
        r: rng.spd(m),
        z: (0..steps).map(|_| rng.vec(m)).collect(),
    }
}

/// Runs the filter in physical units and, through `Scaling`, in normalised units; returns
/// (physical filter, normalised filter, NIS of both).
fn run_both(sys: &Physical, m: usize) -> (KalmanFilter, KalmanFilter, Vec<(f64, f64)>) {
    let n = sys.x0.len();
    let sc = Scaling::new(&sys.sigma).unwrap();
    let mut phys = KalmanFilter::from_diagonal(&sys.x0, &sys.sigma, m).unwrap();
    let mut x0s = sys.x0.clone();
    sc.normalise_state(&mut x0s).unwrap();
    let mut norm = KalmanFilter::from_diagonal(&x0s, &vec![1.0; n], m).unwrap();
    let (mut phi_s, mut q_s) = (sys.phi_top.clone(), sys.q_top.clone());
    sc.normalise_transition(phi_s.as_mut()).unwrap();
    sc.normalise_covariance(q_s.as_mut()).unwrap();
    let mut nis = Vec::new();
    for (h, z) in sys.h.iter().zip(&sys.z) {
        phys.predict_structured(sys.phi_top.as_ref(), sys.q_top.as_ref())
            .unwrap();
        norm.predict_structured(phi_s.as_ref(), q_s.as_ref())
            .unwrap();
        let mut h_s = h.clone();
        sc.normalise_measurement(h_s.as_mut()).unwrap();
        let a = phys.update(z, h.as_ref(), sys.r.as_ref()).unwrap();
        let b = norm.update(z, h_s.as_ref(), sys.r.as_ref()).unwrap();
        nis.push((a.nis, b.nis));
    }
    (phys, norm, nis)
}

#[test]
fn normalised_filtering_equals_physical_filtering() {
    let (n, k, m) = (10, 3, 4);
    let sigma = log_spaced(n, 1e-3, 1e2);
    let sys = physical(n, k, m, 20, sigma.clone(), 8);
    let (phys, norm, nis) = run_both(&sys, m);
    let sc = Scaling::new(&sigma).unwrap();

    let mut x = norm.state().to_vec();
    sc.denormalise_state(&mut x).unwrap();
    let mut p = norm.covariance().to_owned();
    sc.denormalise_covariance(p.as_mut()).unwrap();
    let pp = phys.covariance();
    for i in 0..n {
        let si = pp[(i, i)].sqrt();
        assert!((x[i] - phys.state()[i]).abs() < 1e-9 * si, "x[{i}]");
        for j in 0..n {
            let sj = pp[(j, j)].sqrt();
            assert!(
                (p[(i, j)] - pp[(i, j)]).abs() < 1e-9 * si * sj,
                "P[{i},{j}]"
            );
        }
    }
    for (a, b) in nis {
        assert!((a - b).abs() < 1e-9 * a.max(1.0), "NIS {a} vs {b}");
    }
    // the update did reduce the parameter uncertainty well below the prior
    assert!((k..n).all(|i| pp[(i, i)].sqrt() < 0.9 * sigma[i]));
}

/// Parameters from 1e-9 to 1e-1, as in the calibration: in normalised coordinates the covariance
/// stays positive definite and every parameter variance stays within its prior.
#[test]
fn wide_sigma_range_stays_positive_definite_when_normalised() {
    let (n, k, m) = (28, 3, 6);
    let sigma = log_spaced(n, 1e-9, 1e-1);
    let sys = physical(n, k, m, 400, sigma.clone(), 9);
    let (phys, norm, _) = run_both(&sys, m);
    let p_s = norm.covariance().to_owned();
    assert!(
        is_pd(&p_s),
        "normalised covariance lost positive definiteness"
    );
    for i in k..n {
        let v = p_s[(i, i)];
        assert!(v > 0.0 && v <= 1.0 + 1e-12, "normalised variance {i} = {v}");
    }
    // Physical coordinates: report how far the unscaled covariance has drifted. Not asserted
    // (it depends on the rounding of the platform), but printed for the record.
    let mut back = p_s.clone();
    Scaling::new(&sigma)
        .unwrap()
        .denormalise_covariance(back.as_mut())
        .unwrap();
    let pp = phys.covariance().to_owned();
    let mut worst = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let s = (back[(i, i)] * back[(j, j)]).sqrt();
            worst = worst.max((pp[(i, j)] - back[(i, j)]).abs() / s);
        }
    }
    eprintln!(
        "physical-units filter: positive definite = {}, worst correlation-scaled difference from \
         the normalised filter = {worst:e}",
        is_pd(&pp)
    );
}

#[test]
fn scaling_rejects_bad_sigma_and_shapes() {
    assert!(Scaling::new(&[1.0, 0.0]).is_err());
    assert!(Scaling::new(&[1.0, -1.0]).is_err());
    assert!(Scaling::new(&[1.0, f64::NAN]).is_err());
    let sc = Scaling::new(&[1.0, 2.0]).unwrap();
    assert!(sc.normalise_state(&mut [1.0, 2.0, 3.0]).is_err());
    assert!(
        sc.normalise_covariance(Mat::<f64>::zeros(3, 3).as_mut())
            .is_err()
    );
    assert!(
        sc.normalise_covariance(Mat::<f64>::zeros(1, 2).as_mut())
            .is_err()
    );
    assert!(
        sc.normalise_transition(Mat::<f64>::zeros(2, 3).as_mut())
            .is_err()
    );
    assert!(
        sc.normalise_measurement(Mat::<f64>::zeros(4, 3).as_mut())
            .is_err()
    );
    // leading blocks are fine
    assert!(
        sc.normalise_covariance(Mat::<f64>::zeros(1, 1).as_mut())
            .is_ok()
    );
    assert!(
        sc.normalise_transition(Mat::<f64>::zeros(1, 2).as_mut())
            .is_ok()
    );
}
