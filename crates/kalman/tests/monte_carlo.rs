//! Monte-Carlo consistency: with the truth drawn from the prior and the noises from the model,
//! the normalised estimation error squared (NEES) and the normalised innovation squared (NIS)
//! are chi-square distributed; their sums over independent runs must fall inside chi-square
//! bands.

mod common;

use common::*;
use faer::Mat;
use kalman::KalmanFilter;
use statrs::distribution::{ChiSquared, ContinuousCDF};

const RUNS: usize = 200;
const STEPS: usize = 30;
const N: usize = 4;
const M: usize = 2;

/// Two-sided chi-square band with `k` degrees of freedom and a false-alarm probability of 1e-3.
fn chi2_band(k: f64) -> (f64, f64) {
    let d = ChiSquared::new(k).unwrap();
    (d.inverse_cdf(0.0005), d.inverse_cdf(1.0 - 0.0005))
}

struct Model {
    phi_top: Mat<f64>,
    q_top: Mat<f64>,
    h: Mat<f64>,
    r: Mat<f64>,
    x0: Vec<f64>,
    p0: Mat<f64>,
}

/// Two dynamic states (a rotating error, like an attitude error) driven by two constant
/// parameters (like drifts); the dynamic states are measured.
fn model() -> Model {
    let (dt, w, q) = (0.1, 0.5, 0.02);
    let phi_top = Mat::from_fn(2, N, |i, j| match (i, j) {
        (0, 0) | (1, 1) => 1.0,
        (0, 1) => w * dt,
        (1, 0) => -w * dt,
        (0, 2) | (1, 3) => dt,
        _ => 0.0,
    });
    let q_top = Mat::from_fn(2, 2, |i, j| if i == j { q * dt } else { 0.0 });
    let h = Mat::from_fn(M, N, |i, j| if i == j { 1.0 } else { 0.0 });
    let r = Mat::from_fn(M, M, |i, j| if i == j { 0.05 } else { 0.01 });
    let mut rng = Rng::new(77);
    let p0 = rng.spd(N);
    Model {
        phi_top,
        q_top,
        h,
        r,
        x0: vec![0.3, -0.2, 0.1, 0.0],
        p0,
    }
}

fn sample(rng: &mut Rng, mean: &[f64], chol: &Mat<f64>) -> Vec<f64> {
    let e = rng.vec(mean.len());
    (0..mean.len())
        .map(|i| mean[i] + (0..=i).map(|j| chol[(i, j)] * e[j]).sum::<f64>())
        .collect()
}

fn nees(x_true: &[f64], kf: &KalmanFilter) -> f64 {
    let e: Vec<f64> = x_true.iter().zip(kf.state()).map(|(t, x)| t - x).collect();
    let pinv = inv(&kf.covariance());
    let mut s = 0.0;
    for i in 0..N {
        for j in 0..N {
            s += e[i] * pinv[(i, j)] * e[j];
        }
    }
    s
}

/// Sums of NEES after the first update, NEES at the end, and NIS over all steps, for a filter
/// that believes the measurement noise is `r_scale * R`.
fn run(r_scale: f64) -> (f64, f64, f64) {
    let md = model();
    let mut rng = Rng::new(2024);
    let chol_p0 = cholesky(&md.p0);
    let chol_q = cholesky(&md.q_top);
    let chol_r = cholesky(&md.r);
    let r_filter = &md.r * r_scale;
    let (mut nees_first, mut nees_last, mut nis_sum) = (0.0, 0.0, 0.0);
    for _ in 0..RUNS {
        let mut truth = sample(&mut rng, &md.x0, &chol_p0);
        let mut kf = KalmanFilter::new(&md.x0, md.p0.as_ref(), M).unwrap();
        for step in 0..STEPS {
            // truth: x <- Phi x + w
            let w = sample(&mut rng, &[0.0; 2], &chol_q);
            let top: Vec<f64> = (0..2)
                .map(|i| (0..N).map(|j| md.phi_top[(i, j)] * truth[j]).sum::<f64>() + w[i])
                .collect();
            truth[..2].copy_from_slice(&top);
            let hx: Vec<f64> = (0..M)
                .map(|i| (0..N).map(|j| md.h[(i, j)] * truth[j]).sum())
                .collect();
            let z = sample(&mut rng, &hx, &chol_r);

            kf.predict(md.phi_top.as_ref(), md.q_top.as_ref()).unwrap();
            let info = kf.update(&z, md.h.as_ref(), r_filter.as_ref()).unwrap();
            nis_sum += info.nis;
            if step == 0 {
                nees_first += nees(&truth, &kf);
            }
        }
        nees_last += nees(&truth, &kf);
    }
    (nees_first, nees_last, nis_sum)
}

#[test]
fn nees_and_nis_are_chi_square_consistent() {
    let (nees_first, nees_last, nis) = run(1.0);
    eprintln!(
        "NEES sums {nees_first:.1} / {nees_last:.1} (expected {}), NIS sum {nis:.1} (expected {})",
        RUNS * N,
        RUNS * STEPS * M
    );
    let (lo, hi) = chi2_band((RUNS * N) as f64);
    for (name, v) in [
        ("NEES after the first update", nees_first),
        ("final NEES", nees_last),
    ] {
        assert!(
            (lo..=hi).contains(&v),
            "{name}: sum {v:.1} over {RUNS} runs outside the chi-square({}) band [{lo:.1}, {hi:.1}]",
            RUNS * N
        );
    }
    let (lo, hi) = chi2_band((RUNS * STEPS * M) as f64);
    assert!(
        (lo..=hi).contains(&nis),
        "NIS sum {nis:.1} outside the chi-square({}) band [{lo:.1}, {hi:.1}]",
        RUNS * STEPS * M
    );
}

/// The same statistics detect a filter whose noise model is wrong by a factor of 2: the bands
/// are narrow enough to matter.
#[test]
fn a_mistuned_filter_fails_the_same_bands() {
    let (_, _, nis) = run(2.0);
    let (lo, hi) = chi2_band((RUNS * STEPS * M) as f64);
    assert!(
        !(lo..=hi).contains(&nis),
        "NIS sum {nis:.1} inside [{lo:.1}, {hi:.1}]"
    );
    let (_, nees_last, _) = run(0.25);
    let (lo, hi) = chi2_band((RUNS * N) as f64);
    assert!(
        !(lo..=hi).contains(&nees_last),
        "NEES sum {nees_last:.1} inside [{lo:.1}, {hi:.1}]"
    );
}
