//! The paper's linear error equations in one consistent form (design notes):
//!
//! - attitude error `beta` (x = ENU frame; the computed body-to-ENU DCM is
//!   `exp(-skew(beta)) * c_true`): `d(beta)/dt = beta x u + C nu`, `C = c_body_to_enu = L^T`;
//! - specific-force measurement at rest: `w = f'_x - f_x = f_x x beta + C df`.

use crate::attitude::skew;
use nalgebra::{Matrix3, Vector3};

/// Rate of the attitude error: `beta x u + C nu`.
pub fn beta_rate(
    beta: &Vector3<f64>,
    u_enu: &Vector3<f64>,
    c_body_to_enu: &Matrix3<f64>,
    nu: &Vector3<f64>,
) -> Vector3<f64> {
    beta.cross(u_enu) + c_body_to_enu * nu
}

/// The matrix `A` of `d(beta)/dt = A beta + ...`: `A = -skew(u)` since `beta x u = -u x beta`.
pub fn beta_dynamics_matrix(u_enu: &Vector3<f64>) -> Matrix3<f64> {
    -skew(u_enu)
}

/// The exact transition of `d(beta)/dt = A beta` over `dt` (`A` of [`beta_dynamics_matrix`]):
/// `exp(A dt) = exp(-skew(u dt))`, the Earth's rotation over the step.
pub fn beta_transition(u_enu: &Vector3<f64>, dt: f64) -> Matrix3<f64> {
    crate::attitude::exp_so3(&(-u_enu * dt))
}

/// Specific-force residual `w = f_x x beta + C df` (linear model).
pub fn specific_force_residual(
    beta: &Vector3<f64>,
    f_enu: &Vector3<f64>,
    c_body_to_enu: &Matrix3<f64>,
    df: &Vector3<f64>,
) -> Vector3<f64> {
    f_enu.cross(beta) + c_body_to_enu * df
}

/// Jacobian of [`specific_force_residual`] with respect to `beta`: `skew(f_x)`.
pub fn specific_force_beta_jacobian(f_enu: &Vector3<f64>) -> Matrix3<f64> {
    skew(f_enu)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::{apply_attitude_error, attitude_error, exp_so3};

    /// Integrate the true DCM and the DCM computed from an erroneous gyro, and compare the
    /// growth of their difference with the linear equation.
    #[test]
    fn beta_equation_matches_nonlinear_strapdown() {
        let u = Vector3::new(0.0, 4.1e-5, 6.0e-5);
        let omega_rel = Vector3::new(0.17, 0.0, 0.0); // body rate relative to ENU, in body
        let nu = Vector3::new(3e-6, -2e-6, 5e-6);
        let beta0 = Vector3::new(2e-4, -1e-4, 3e-4);
        let dt = 1e-3;
        let mut c = exp_so3(&Vector3::new(0.1, 0.2, 0.3));
        let mut cc = apply_attitude_error(&beta0, &c);
        let mut beta_lin = beta0;
        for _ in 0..5000 {
            // Body rate w.r.t. inertial: omega = omega_rel + C^T u. dC/dt = C [w x] - [u x] C.
            let omega = omega_rel + c.transpose() * u;
            let step =
                |m: &Matrix3<f64>, w: &Vector3<f64>| exp_so3(&(-u * dt)) * m * exp_so3(&(w * dt));
            // Linear model at mid-interval attitude (trapezoid).
            let r0 = beta_rate(&beta_lin, &u, &c, &nu);
            let c_next = step(&c, &omega);
            let r1 = beta_rate(&(beta_lin + r0 * dt), &u, &c_next, &nu);
            beta_lin += 0.5 * (r0 + r1) * dt;
            cc = step(&cc, &(omega - nu));
            c = c_next;
        }
        let beta_nl = attitude_error(&cc, &c);
        assert!(
            (beta_nl - beta_lin).norm() < 1e-3 * (beta_nl - beta0).norm(),
            "nonlinear {beta_nl:?} vs linear {beta_lin:?}"
        );
    }

    #[test]
    fn residual_jacobian_matches_finite_differences() {
        let f = Vector3::new(0.1, -0.2, 9.81);
        let c = exp_so3(&Vector3::new(0.3, -0.2, 0.1));
        let df = Vector3::new(1e-3, 2e-3, -1e-3);
        let j = specific_force_beta_jacobian(&f);
        for k in 0..3 {
            let mut e = Vector3::zeros();
            e[k] = 1e-6;
            let fd = (specific_force_residual(&e, &f, &c, &df)
                - specific_force_residual(&-e, &f, &c, &df))
                / 2e-6;
            assert!((fd - j.column(k)).norm() < 1e-8);
        }
    }
}
