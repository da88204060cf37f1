//! The second-order specific-force error that a linear model cannot carry, as a consider
//! parameter.
//!
//! The specific-force residual of the computed frame is `beta x f + C df + beta x (C df)`: the
//! linear model keeps the first two terms. The third is a product of two errors. Where the
//! program makes both small (the paper's: the heading is known to arcseconds) it is nothing;
//! where it leaves both unobserved (a static run: the heading stays at its 1-degree prior and
//! the horizontal accelerometer biases are only known together with the tilt) it is a constant
//! offset of the residual of `sigma(beta_z) * sigma(df_h)`, about 3.5e-4 m/s^2 for the paper's
//! priors, against the 4e-5 m/s^2 to which 600 s of data fix the tilt-and-bias combination. The
//! filter then reported that combination a hundred sigmas sure of a wrong value (NEES in the
//! hundreds on noiseless static runs).
//!
//! The product is not Gaussian and not in the state, so it is treated as a consider parameter:
//! its covariance `B` follows from the posterior of `beta` and of the accelerometer errors; the
//! sensitivity `S` of the estimate to a constant residual offset is carried through the final
//! pass beside the estimate ([`crate::model::engine::OffsetSensitivity`]); the posterior covariance
//! grows by `S B S^T` over the principal directions of `B` that matter. The product is
//! evaluated at the final attitude, exact for a static run; on a rotating program where it is
//! not negligible it is an approximation of its mean size.
//!
//! Until session 15 `S` came from running the final pass again with the offset along each
//! such direction (the pass is linear about its linearisation point): two of the five passes
//! over a consumer-grade recording of rests. Carried through the pass (compared side by side
//! with the re-runs in a temporary build of `iterate_passes`, not kept) it gives the same
//! parameter sigmas to 1e-6 on programs (static runs, seeds 300-309 and 400-449) and to 4e-4 on
//! recordings of rests (the shipped ones, and `tests/tests/rests.rs`), where the re-run pass
//! also re-levelled its trajectory to the offset data.

use super::Estimate;
use crate::config::RunConfig;
use crate::model::layout::StateLayout;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use sins_model::terms::{Sensor, SensorInput};

/// Directions of `B` whose standard deviation is below this fraction of the white-noise sigma
/// of the whole run's mean specific force are left out.
const NEGLIGIBLE: f64 = 0.1;

/// Covariance of `b = beta x d` for independent zero-mean `beta` and `d`:
/// `B_ij = sum eps_ikl eps_jmn P_beta_km P_d_ln`.
fn cross_product_covariance(p_beta: &Matrix3<f64>, p_d: &Matrix3<f64>) -> Matrix3<f64> {
    let eps = |i: usize, j: usize, k: usize| -> f64 {
        match (i, j, k) {
            (0, 1, 2) | (1, 2, 0) | (2, 0, 1) => 1.0,
            (0, 2, 1) | (2, 1, 0) | (1, 0, 2) => -1.0,
            _ => 0.0,
        }
    };
    Matrix3::from_fn(|i, j| {
        let mut s = 0.0;
        for k in 0..3 {
            for l in 0..3 {
                for m in 0..3 {
                    for n in 0..3 {
                        s += eps(i, k, l) * eps(j, m, n) * p_beta[(k, m)] * p_d[(l, n)];
                    }
                }
            }
        }
        s
    })
}

/// Adds the consider covariance of the second-order specific-force error to `est` (whose
/// states follow `layout`, which carries the copy of the start attitude error), from the final
/// pass's sensitivity `sens` (`n x 3`) of its estimate to a constant residual offset
/// ([`crate::model::engine::OffsetSensitivity`]; its attitude rows that of the final attitude).
pub(super) fn second_order_accel(
    config: &RunConfig,
    layout: &StateLayout,
    est: &mut Estimate,
    sens: &nalgebra::DMatrix<f64>,
) {
    let Some(s) = layout.start_attitude else {
        return;
    };
    let c = est.final_c_body_to_enu;
    let off = StateLayout::INSTRUMENT;
    let n_p = layout.n_instrument();
    let p = &est.values[off..off + n_p];
    let site = config.site();
    let input = SensorInput {
        omega_body: c.transpose() * site.earth_rate_enu(),
        f_body: c.transpose() * site.specific_force_at_rest_enu(),
        ..SensorInput::default()
    };
    let mut jac = vec![Vector3::zeros(); n_p];
    layout.model.jacobian(Sensor::Accel, p, &input, &mut jac);
    let cj: Vec<Vector3<f64>> = jac.iter().map(|j| c * j).collect();
    let mut p_d = Matrix3::zeros();
    for (a, ja) in cj.iter().enumerate() {
        for (b, jb) in cj.iter().enumerate() {
            p_d += ja * jb.transpose() * est.cov[(off + a, off + b)];
        }
    }
    let p_beta = est.cov.fixed_view::<3, 3>(s, s).into_owned();
    let b = cross_product_covariance(&p_beta, &p_d);
    let run_s = est.imu_span.1 - est.imu_span.0;
    let white = config.accel_psd().sqrt() / run_s.max(1.0).sqrt();
    let eig = SymmetricEigen::new(b);
    est.stats.second_order_accel_sigma = eig.eigenvalues.max().max(0.0).sqrt();
    for k in 0..3 {
        let sigma = eig.eigenvalues[k].max(0.0).sqrt();
        if sigma < NEGLIGIBLE * white {
            continue;
        }
        est.stats.consider_directions += 1;
        let col = sens * (sigma * eig.eigenvectors.column(k).into_owned());
        for i in 0..col.len() {
            for j in 0..col.len() {
                est.cov[(i, j)] += col[i] * col[j];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_product_covariance_matches_sampling_formula() {
        // Heading error only (sigma a) against a horizontal d (sigma b along x): b = beta_z z x d
        // has variance (a b)^2 along y and nothing else.
        let (a, bs) = (0.02, 0.03);
        let p_beta = Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, a * a));
        let p_d = Matrix3::from_diagonal(&Vector3::new(bs * bs, 0.0, 0.0));
        let b = cross_product_covariance(&p_beta, &p_d);
        let expected = Matrix3::from_diagonal(&Vector3::new(0.0, (a * bs).powi(2), 0.0));
        assert!((b - expected).norm() < 1e-15, "{b}");
        // Symmetric in general, and the expectation of (beta x d)(beta x d)^T for full
        // covariances: E[skew(beta) d d^T skew(beta)^T] = E_beta[skew(beta) P_d skew(beta)^T].
        let pb = Matrix3::new(2.0, 0.3, -0.1, 0.3, 1.0, 0.2, -0.1, 0.2, 0.5);
        let pd = Matrix3::new(1.0, -0.2, 0.1, -0.2, 3.0, 0.4, 0.1, 0.4, 2.0);
        let b = cross_product_covariance(&pb, &pd);
        // E_beta[skew(beta) P skew(beta)^T] is linear in beta beta^T: sum over the basis.
        let mut e = Matrix3::zeros();
        for k in 0..3 {
            for m in 0..3 {
                let (ek, em) = (
                    sins_model::attitude::skew(&Vector3::ith(k, 1.0)),
                    sins_model::attitude::skew(&Vector3::ith(m, 1.0)),
                );
                e += pb[(k, m)] * ek * pd * em.transpose();
            }
        }
        assert!((b - e).norm() < 1e-12, "{b} vs {e}");
    }
}
