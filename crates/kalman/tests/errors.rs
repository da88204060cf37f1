//! Bad inputs return an error, never panic, and leave the filter unchanged.

mod common;

use common::*;
use faer::{Mat, mat};
use kalman::{KalmanError, KalmanFilter};

fn filter(n: usize, m_max: usize) -> KalmanFilter {
    let mut rng = Rng::new(3);
    KalmanFilter::new(&rng.vec(n), rng.spd(n).as_ref(), m_max).unwrap()
}

/// Runs `f` on a clone of `kf` and checks that it errs with a matching error and leaves the
/// state and covariance bit for bit unchanged.
fn assert_rejected(
    kf: &KalmanFilter,
    f: impl FnOnce(&mut KalmanFilter) -> Result<(), KalmanError>,
    expect: impl Fn(&KalmanError) -> bool,
) {
    let mut g = kf.clone();
    let err = f(&mut g).expect_err("expected an error");
    assert!(expect(&err), "unexpected error {err:?}");
    assert_eq!(
        g.normalised_state(),
        kf.normalised_state(),
        "state changed by a failed call ({err})"
    );
    assert_eq!(
        g.normalised_covariance(),
        kf.normalised_covariance(),
        "covariance changed by a failed call ({err})"
    );
}

fn is_dim(e: &KalmanError) -> bool {
    matches!(e, KalmanError::DimensionMismatch { .. })
}

fn is_nonfinite(e: &KalmanError) -> bool {
    matches!(e, KalmanError::NonFinite { .. })
}

#[test]
fn dimension_mismatches_are_errors() {
    let n = 5;
    let kf = filter(n, 2);
    let id = |k: usize| Mat::<f64>::identity(k, k);
    assert!(matches!(
        KalmanFilter::new(&[0.0; 3], id(4).as_ref(), 1),
        Err(KalmanError::DimensionMismatch { what: "P0", .. })
    ));
    assert!(matches!(
        KalmanFilter::from_diagonal(&[0.0; 3], &[1.0; 2], 1),
        Err(KalmanError::DimensionMismatch { what: "sigma0", .. })
    ));
    assert!(matches!(
        KalmanFilter::with_scale(&[0.0; 3], id(3).as_ref(), vec![1.0; 4], 1),
        Err(KalmanError::DimensionMismatch { what: "scale", .. })
    ));
    // the dense predict (k = n) with Q of the wrong size, more rows than states
    assert_rejected(&kf, |f| f.predict(id(5).as_ref(), id(4).as_ref()), is_dim);
    assert_rejected(
        &kf,
        |f| f.predict_covariance(id(6).as_ref(), id(6).as_ref()),
        is_dim,
    );
    // phi_top with the wrong number of columns, q_top of the wrong size, too many rows
    let (phi_top, q_top) = (Mat::<f64>::zeros(2, 4), id(2));
    assert_rejected(&kf, |f| f.predict(phi_top.as_ref(), q_top.as_ref()), is_dim);
    let phi_top = Mat::<f64>::zeros(2, n);
    assert_rejected(&kf, |f| f.predict(phi_top.as_ref(), id(3).as_ref()), is_dim);
    let phi_top = Mat::<f64>::zeros(6, n);
    assert_rejected(&kf, |f| f.predict(phi_top.as_ref(), id(6).as_ref()), is_dim);
    // z length vs H rows, H columns, R size
    let h = Mat::<f64>::zeros(2, n);
    assert_rejected(
        &kf,
        |f| f.update(&[1.0], h.as_ref(), id(2).as_ref()).map(drop),
        is_dim,
    );
    let h = Mat::<f64>::zeros(2, n + 1);
    assert_rejected(
        &kf,
        |f| f.update(&[1.0, 2.0], h.as_ref(), id(2).as_ref()).map(drop),
        is_dim,
    );
    let h = Mat::<f64>::zeros(2, n);
    assert_rejected(
        &kf,
        |f| f.update(&[1.0, 2.0], h.as_ref(), id(3).as_ref()).map(drop),
        is_dim,
    );
    assert_rejected(
        &kf,
        |f| f.update_covariance(h.as_ref(), id(1).as_ref()).map(drop),
        is_dim,
    );
    // more measurement components than reserved
    let h = Mat::<f64>::zeros(3, n);
    assert_rejected(
        &kf,
        |f| f.update(&[1.0; 3], h.as_ref(), id(3).as_ref()).map(drop),
        |e| matches!(e, KalmanError::MeasurementTooLarge { m: 3, m_max: 2 }),
    );
}

#[test]
fn non_positive_definite_innovation_covariance_is_an_error() {
    let n = 4;
    let kf = filter(n, 3);
    let mut rng = Rng::new(8);
    let h = rng.mat(3, n);
    // R strongly negative: S = H P H^T + R is negative definite
    let r = Mat::<f64>::identity(3, 3) * -1e3;
    assert_rejected(
        &kf,
        |f| f.update(&[0.0; 3], h.as_ref(), r.as_ref()).map(drop),
        |e| matches!(e, KalmanError::NotPositiveDefinite { m: 3, .. }),
    );
    // H = 0 and R = 0: S = 0
    let (h0, r0) = (Mat::<f64>::zeros(2, n), Mat::<f64>::zeros(2, 2));
    assert_rejected(
        &kf,
        |f| f.update_covariance(h0.as_ref(), r0.as_ref()).map(drop),
        |e| matches!(e, KalmanError::NotPositiveDefinite { m: 2, pivot: 0, .. }),
    );
    // two identical rows and no noise: S is singular at the second pivot
    let row = rng.mat(1, n);
    let h2 = Mat::from_fn(2, n, |_, j| row[(0, j)]);
    assert_rejected(
        &kf,
        |f| f.update_covariance(h2.as_ref(), r0.as_ref()).map(drop),
        |e| matches!(e, KalmanError::NotPositiveDefinite { m: 2, pivot: 1, .. }),
    );
    // the message names the measurement dimension
    let mut g = kf.clone();
    let msg = g
        .update_covariance(h0.as_ref(), r0.as_ref())
        .unwrap_err()
        .to_string();
    assert!(msg.contains("2-dimensional"), "{msg}");
    // the failed S is shown, innovation and gain are NaN
    assert_eq!(g.innovation_covariance().nrows(), 2);
    assert!(g.innovation().iter().all(|v| v.is_nan()));
    assert!(g.gain()[(0, 0)].is_nan());
}

#[test]
fn non_finite_inputs_are_errors() {
    let n = 4;
    let kf = filter(n, 2);
    let mut rng = Rng::new(4);
    let (h, r) = (rng.mat(2, n), rng.spd(2));
    let phi = Mat::<f64>::identity(n, n);
    let q = Mat::<f64>::identity(n, n) * 0.1;
    let nan_in = |m: &Mat<f64>, v: f64| {
        let mut m = m.clone();
        let (i, j) = (m.nrows() - 1, m.ncols() - 1);
        m[(i, j)] = v;
        m
    };
    assert_rejected(
        &kf,
        |f| f.update(&[0.0, f64::NAN], h.as_ref(), r.as_ref()).map(drop),
        is_nonfinite,
    );
    assert_rejected(
        &kf,
        |f| {
            f.update(&[0.0, 1.0], nan_in(&h, f64::NAN).as_ref(), r.as_ref())
                .map(drop)
        },
        is_nonfinite,
    );
    assert_rejected(
        &kf,
        |f| {
            f.update(&[0.0, 1.0], h.as_ref(), nan_in(&r, f64::INFINITY).as_ref())
                .map(drop)
        },
        is_nonfinite,
    );
    assert_rejected(
        &kf,
        |f| {
            f.update_covariance(h.as_ref(), nan_in(&r, f64::NAN).as_ref())
                .map(drop)
        },
        is_nonfinite,
    );
    assert_rejected(
        &kf,
        |f| f.predict(nan_in(&phi, f64::NAN).as_ref(), q.as_ref()),
        is_nonfinite,
    );
    assert_rejected(
        &kf,
        |f| f.predict(phi.as_ref(), nan_in(&q, f64::NEG_INFINITY).as_ref()),
        is_nonfinite,
    );
    let (phi_top, q_top) = (Mat::<f64>::identity(2, n), mat![[0.1, 0.0], [0.0, 0.1]]);
    assert_rejected(
        &kf,
        |f| f.predict(nan_in(&phi_top, f64::NAN).as_ref(), q_top.as_ref()),
        is_nonfinite,
    );
    assert_rejected(
        &kf,
        |f| f.predict_covariance(phi_top.as_ref(), nan_in(&q_top, f64::NAN).as_ref()),
        is_nonfinite,
    );
    // finite in the caller's units, infinite once normalised
    let tiny = KalmanFilter::from_diagonal(&[0.0; 2], &[1e-300, 1e300], 1).unwrap();
    assert_rejected(
        &tiny,
        |f| f.predict(mat![[1.0, 1.0]].as_ref(), mat![[0.0]].as_ref()),
        |e| matches!(e, KalmanError::NonFinite { what: "phi_top" }),
    );
    assert!(matches!(
        KalmanFilter::new(&[0.0, f64::NAN], Mat::<f64>::identity(2, 2).as_ref(), 1),
        Err(KalmanError::NonFinite { what: "x0" })
    ));
    assert!(matches!(
        KalmanFilter::new(
            &[0.0, 0.0],
            nan_in(&Mat::<f64>::identity(2, 2), f64::NAN).as_ref(),
            1
        ),
        Err(KalmanError::NonFinite { what: "P0" })
    ));
    // After all the failures, the filter still works.
    let mut g = kf.clone();
    g.predict(phi.as_ref(), q.as_ref()).unwrap();
    g.update(&[0.0, 1.0], h.as_ref(), r.as_ref()).unwrap();
}

#[test]
fn invalid_scales_are_errors() {
    assert!(matches!(
        KalmanFilter::from_diagonal(&[0.0, 0.0], &[1.0, -1.0], 1),
        Err(KalmanError::InvalidSigma { index: 1, .. })
    ));
    assert!(matches!(
        KalmanFilter::from_diagonal(&[0.0, 0.0], &[0.0, 1.0], 1),
        Err(KalmanError::InvalidSigma { index: 0, .. })
    ));
    // a zero prior variance cannot be its own scale ...
    let p0 = mat![[1.0, 0.0], [0.0, 0.0]];
    assert!(matches!(
        KalmanFilter::new(&[0.0, 0.0], p0.as_ref(), 1),
        Err(KalmanError::InvalidSigma {
            what: "P0 diagonal",
            index: 1,
            ..
        })
    ));
    // ... but is fine with an explicit scale.
    let kf = KalmanFilter::with_scale(&[0.0, 0.0], p0.as_ref(), vec![1.0, 2.0], 1).unwrap();
    assert_eq!(kf.std_dev(1), 0.0);
    for bad in [f64::NAN, f64::INFINITY, 0.0, -2.0] {
        assert!(matches!(
            KalmanFilter::with_scale(&[0.0, 0.0], p0.as_ref(), vec![1.0, bad], 1),
            Err(KalmanError::InvalidSigma {
                what: "scale",
                index: 1,
                ..
            })
        ));
    }
}
