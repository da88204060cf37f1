//! Frames and attitude: direction cosine matrices, rotation vectors and quaternions.
//!
//! Conventions (see `docs/conventions.md`):
//! - a DCM is named by its two frames, `c_a_to_b`, and maps a vector's coordinates in frame `a`
//!   into frame `b`: `v_b = c_a_to_b * v_a`;
//! - [`skew`] is the ordinary cross-product matrix, `skew(a) * b = a x b`. The paper's hat operator
//!   is its negative, [`paper_hat`]`(w) v = v x w`;
//! - [`rot_x`], [`rot_y`], [`rot_z`] are *active* rotations (right-hand rule, positive angle turns a
//!   vector counter-clockwise when seen from the tip of the axis). The DCM of a frame `b` obtained by
//!   turning frame `a` through angle `t` about axis `k` is `c_b_to_a = rot_k(t)`.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Ordinary cross-product matrix: `skew(a) * b == a.cross(&b)`.
#[inline]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// The paper's hat operator: `paper_hat(w) * v == v.cross(&w)`, i.e. `-skew(w)`.
pub fn paper_hat(w: &Vector3<f64>) -> Matrix3<f64> {
    -skew(w)
}

/// Active rotation about the first axis.
pub fn rot_x(angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Active rotation about the second axis.
pub fn rot_y(angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Active rotation about the third axis.
pub fn rot_z(angle: f64) -> Matrix3<f64> {
    let (s, c) = angle.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// Rotation matrix of the rotation vector `phi` (Rodrigues): `exp(skew(phi))`.
#[inline]
pub fn exp_so3(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    // Series for small angles: full precision near zero, and no trigonometry for the
    // milliradian increments of an IMU step. Below t = 1e-2 rad the first omitted terms
    // (t^8 / 9!, t^8 / 10!) are under 3e-22, far below the rounding of the kept ones.
    let (a, b) = if t2 < 1e-4 {
        // Products with the reciprocals rather than divisions (one IMU step each).
        (
            1.0 - t2 * (1.0 / 6.0) * (1.0 - t2 * (1.0 / 20.0) * (1.0 - t2 * (1.0 / 42.0))),
            0.5 - t2 * (1.0 / 24.0) * (1.0 - t2 * (1.0 / 30.0) * (1.0 - t2 * (1.0 / 56.0))),
        )
    } else {
        let t = t2.sqrt();
        (t.sin() / t, (1.0 - t.cos()) / t2)
    };
    // I + a K + b K^2 with K = skew(phi) and K^2 = phi phi^T - t^2 I, written out (no 3x3
    // product; this runs at every IMU step).
    let (x, y, z) = (phi.x, phi.y, phi.z);
    let (bxy, bxz, byz) = (b * x * y, b * x * z, b * y * z);
    let (ax, ay, az) = (a * x, a * y, a * z);
    Matrix3::new(
        1.0 - b * (y * y + z * z),
        bxy - az,
        bxz + ay,
        bxy + az,
        1.0 - b * (x * x + z * z),
        byz - ax,
        bxz - ay,
        byz + ax,
        1.0 - b * (x * x + y * y),
    )
}

/// Rotation vector of a rotation matrix (inverse of [`exp_so3`] for angles below pi).
#[inline]
pub fn log_so3(c: &Matrix3<f64>) -> Vector3<f64> {
    // sin(t) * axis from the antisymmetric part, cos(t) from the trace; atan2 keeps precision
    // for tiny angles, where acos of the trace would not.
    let v = 0.5
        * Vector3::new(
            c[(2, 1)] - c[(1, 2)],
            c[(0, 2)] - c[(2, 0)],
            c[(1, 0)] - c[(0, 1)],
        );
    let co = 0.5 * (c.trace() - 1.0);
    let s2 = v.norm_squared();
    if co > 0.0 && s2 < 1e-4 {
        // Small angles (the estimator takes one per IMU step): t = asin(s) on this side of
        // pi / 2, and t / s = asin(s) / s by its series; with s^2 < 1e-4 the first omitted
        // term, 63 s^10 / 2816, is under 3e-22. No square root, no atan2, no division (a
        // division on this path was 6 % of an estimation pass's own time).
        let series =
            1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * (5.0 / 112.0 + s2 * (35.0 / 1152.0))));
        return v * series;
    }
    let s = s2.sqrt();
    let t = s.atan2(co);
    if t < 3.0 {
        if s < 1e-300 {
            return v;
        }
        v * (t / s)
    } else {
        // Near pi the antisymmetric part vanishes; use the symmetric part instead.
        Rotation3::from_matrix_unchecked(*c).scaled_axis()
    }
}

/// Inverse of the right Jacobian of SO(3): `log(exp(phi) exp(e)) = phi + J_r^-1(phi) e` to first
/// order in the small rotation `e`. It maps a covariance of a body-frame (right) perturbation
/// of `exp(phi)` into the covariance of the rotation vector `phi` itself. The left form,
/// `log(exp(e) exp(phi)) = phi + J_l^-1(phi) e`, is `J_r^-1(-phi)`.
pub fn right_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let k = skew(phi);
    // Coefficient of skew(phi)^2: 1/t^2 - (1 + cos t) / (2 t sin t), whose series is
    // 1/12 + t^2/720 + t^4/30240 (used below 1e-2 rad, where the closed form cancels).
    let c = if t2 < 1e-4 {
        1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
    } else {
        let t = t2.sqrt();
        1.0 / t2 - (1.0 + t.cos()) / (2.0 * t * t.sin())
    };
    Matrix3::identity() + 0.5 * k + c * k * k
}

/// Re-orthonormalise a nearly orthogonal matrix (nearest rotation, via the quaternion).
pub fn orthonormalize(c: &Matrix3<f64>) -> Matrix3<f64> {
    // The iteration starts from the quaternion of `c` itself, a rounding away from the answer
    // for the nearly orthogonal matrices this is for: a step or two instead of the dozens from
    // the identity (11 000 instructions a call, 1 % of a calibration's time).
    // (Normalised: built from a matrix that is not quite orthogonal, it is not quite unit, and
    // the iteration keeps a guess that already meets its tolerance as it is.)
    let guess = UnitQuaternion::new_normalize(*dcm_to_quat(c).quaternion());
    let q = UnitQuaternion::from_matrix_eps(c, 1e-15, 50, guess);
    q.to_rotation_matrix().into_inner()
}

/// Quaternion of a DCM (`q` rotates frame-`a` coordinates into frame `b` like `c_a_to_b`).
pub fn dcm_to_quat(c: &Matrix3<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*c))
}

/// DCM of a quaternion.
pub fn quat_to_dcm(q: &UnitQuaternion<f64>) -> Matrix3<f64> {
    q.to_rotation_matrix().into_inner()
}

/// The paper's orientation matrix `L = C_x->z` from the body-to-ENU DCM: `L = c_body_to_enu^T`.
pub fn paper_l(c_body_to_enu: &Matrix3<f64>) -> Matrix3<f64> {
    c_body_to_enu.transpose()
}

/// Small-angle attitude error `beta` (x frame) between a computed and a true body-to-ENU DCM,
/// with the paper's sign: the computed DCM is `exp(-skew(beta)) * c_true`, so that the computed
/// specific force in ENU is `f_x + f_x x beta` to first order.
#[inline]
pub fn attitude_error(c_computed: &Matrix3<f64>, c_true: &Matrix3<f64>) -> Vector3<f64> {
    -log_so3(&(c_computed * c_true.transpose()))
}

/// Apply an attitude error: the computed DCM `exp(-skew(beta)) * c_true`.
pub fn apply_attitude_error(beta: &Vector3<f64>, c_true: &Matrix3<f64>) -> Matrix3<f64> {
    exp_so3(&(-beta)) * c_true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orthonormalize_gives_the_nearest_rotation() {
        let r = exp_so3(&Vector3::new(0.4, -2.1, 1.3));
        let e = Matrix3::new(0.3, -0.8, 0.1, 0.5, 0.2, -0.6, -0.9, 0.4, 0.7);
        for size in [0.0, 1e-15, 1e-9, 1e-4] {
            let c = r * (Matrix3::identity() + e * size);
            let o = orthonormalize(&c);
            assert!(
                (o.transpose() * o - Matrix3::identity()).norm() < 4e-15,
                "{size}"
            );
            // The nearest rotation is the polar factor U V^T of the SVD.
            let svd = c.svd(true, true);
            let polar = svd.u.unwrap() * svd.v_t.unwrap();
            assert!(
                (o - polar).norm() < 1e-14,
                "{size}: {:e}",
                (o - polar).norm()
            );
        }
    }

    #[test]
    fn skew_is_the_cross_product_and_paper_hat_its_negative() {
        let a = Vector3::new(0.3, -1.2, 2.0);
        let b = Vector3::new(-0.7, 0.4, 1.1);
        assert!((skew(&a) * b - a.cross(&b)).norm() < 1e-15);
        assert!((paper_hat(&a) * b - b.cross(&a)).norm() < 1e-15);
        // The paper writes hat(w) with rows (0, w3, -w2), (-w3, 0, w1), (w2, -w1, 0).
        let h = paper_hat(&a);
        assert_eq!(h[(0, 1)], a.z);
        assert_eq!(h[(0, 2)], -a.y);
        assert_eq!(h[(1, 2)], a.x);
    }

    #[test]
    fn right_jacobian_inverse_matches_finite_differences() {
        for phi in [
            Vector3::new(0.03, -0.035, 0.04),
            Vector3::new(1e-4, 2e-4, -3e-5),
            Vector3::new(0.8, -0.3, 1.1),
        ] {
            let j = right_jacobian_inv(&phi);
            let h = 1e-7;
            for i in 0..3 {
                let mut e = Vector3::zeros();
                e[i] = h;
                let fd = (log_so3(&(exp_so3(&phi) * exp_so3(&e)))
                    - log_so3(&(exp_so3(&phi) * exp_so3(&-e))))
                    / (2.0 * h);
                assert!(
                    (fd - j.column(i)).norm() < 1e-7,
                    "{phi:?} column {i}: {fd:?}"
                );
                // The left form.
                let jl = right_jacobian_inv(&-phi);
                let fd = (log_so3(&(exp_so3(&e) * exp_so3(&phi)))
                    - log_so3(&(exp_so3(&-e) * exp_so3(&phi))))
                    / (2.0 * h);
                assert!(
                    (fd - jl.column(i)).norm() < 1e-7,
                    "left, {phi:?} column {i}"
                );
            }
        }
    }

    #[test]
    fn elementary_rotations_are_active_and_match_exp() {
        let t = 0.4;
        assert!((rot_x(t) - exp_so3(&Vector3::new(t, 0.0, 0.0))).norm() < 1e-15);
        assert!((rot_y(t) - exp_so3(&Vector3::new(0.0, t, 0.0))).norm() < 1e-15);
        assert!((rot_z(t) - exp_so3(&Vector3::new(0.0, 0.0, t))).norm() < 1e-15);
        // Active: x turns towards y under a positive rotation about z.
        let v = rot_z(std::f64::consts::FRAC_PI_2) * Vector3::x();
        assert!((v - Vector3::y()).norm() < 1e-15);
    }

    /// The small-angle series of `log_so3` equals the atan2 form to rounding, up to where it
    /// hands over (sin t = 1e-2) and across.
    #[test]
    fn log_series_equals_the_atan2_form() {
        for t in [1e-7, 1e-4, 3e-3, 9.9e-3, 1.01e-2, 0.05] {
            let phi = Vector3::new(0.6, -0.48, 0.64) * t;
            let c = exp_so3(&phi);
            let v = 0.5
                * Vector3::new(
                    c[(2, 1)] - c[(1, 2)],
                    c[(0, 2)] - c[(2, 0)],
                    c[(1, 0)] - c[(0, 1)],
                );
            let reference = v * (v.norm().atan2(0.5 * (c.trace() - 1.0)) / v.norm());
            assert!(
                (log_so3(&c) - reference).norm() <= 4.0 * f64::EPSILON * t,
                "t = {t}"
            );
        }
    }

    #[test]
    fn exp_log_round_trip_including_tiny_angles() {
        for phi in [
            Vector3::new(0.1, -0.2, 0.3),
            Vector3::new(1e-9, 2e-9, -1e-9),
            Vector3::new(2.0, 1.0, -0.5),
        ] {
            let c = exp_so3(&phi);
            assert!((c * c.transpose() - Matrix3::identity()).norm() < 1e-14);
            assert!((log_so3(&c) - phi).norm() < 1e-12 * (1.0 + phi.norm()));
        }
    }

    #[test]
    fn quaternion_round_trip() {
        let c = exp_so3(&Vector3::new(0.5, -0.3, 1.2));
        let q = dcm_to_quat(&c);
        assert!((quat_to_dcm(&q) - c).norm() < 1e-14);
        let v = Vector3::new(1.0, 2.0, 3.0);
        assert!((q * v - c * v).norm() < 1e-14);
    }

    #[test]
    fn attitude_error_round_trip_and_sign() {
        let c = exp_so3(&Vector3::new(0.2, 0.9, -0.4));
        let beta = Vector3::new(1e-3, -2e-3, 5e-4);
        let cc = apply_attitude_error(&beta, &c);
        assert!((attitude_error(&cc, &c) - beta).norm() < 1e-12);
        // The computed specific force in ENU is f_x + f_x x beta to first order (paper's w).
        let f_body = c.transpose() * Vector3::new(0.0, 0.0, 9.8);
        let w = cc * f_body - c * f_body;
        let lin = Vector3::new(0.0, 0.0, 9.8).cross(&beta);
        assert!((w - lin).norm() < 9.8 * beta.norm_squared());
    }
}
