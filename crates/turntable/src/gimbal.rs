//! Three-axis gimbal kinematics in the paper's heading-bank-pitch sequence.
//!
//! The platform frame `z*` is obtained from the base frame `p` by three successive turns:
//! `k1` about the base's third (vertical) axis, `k2` about the once-turned first axis, `k3` about
//! the twice-turned second axis (all right-handed, active):
//!
//! `c_platform_to_base = rot_z(k1) * rot_x(k2) * rot_y(k3)`.
//!
//! At `k = 0` the platform axes coincide with the base's (ideally East, North, Up). Gimbal lock is
//! at `k2 = +-90 deg`, where the pitch axis becomes vertical; nothing here divides by `cos k2`, so
//! the forward kinematics and the angle-error Jacobian are valid at any angle.

use nalgebra::{Matrix3, Vector3};
use sins_model::attitude::{rot_x, rot_y, rot_z};

/// Wrap a difference of gimbal angles into (-180, 180] degrees.
pub fn wrap_deg(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// `c_platform_to_base` of gimbal angles `k` (rad).
pub fn c_platform_to_base(k: &[f64; 3]) -> Matrix3<f64> {
    rot_z(k[0]) * rot_x(k[1]) * rot_y(k[2])
}

/// The three gimbal axes in the base frame: vertical, once-turned first, twice-turned second.
pub fn gimbal_axes_base(k: &[f64; 3]) -> [Vector3<f64>; 3] {
    let r1 = rot_z(k[0]);
    let a1 = Vector3::z();
    let a2 = r1 * Vector3::x();
    let a3 = r1 * rot_x(k[1]) * Vector3::y();
    [a1, a2, a3]
}

/// Matrix whose columns are the gimbal axes in the base frame. It maps gimbal-angle rates to the
/// platform's angular rate relative to the base (in base axes), and small gimbal-angle errors
/// `rho` to the small rotation `phi` with `c_platform_to_base(k + rho) = exp(skew(phi)) *
/// c_platform_to_base(k)` to first order.
pub fn gimbal_jacobian(k: &[f64; 3]) -> Matrix3<f64> {
    let [a1, a2, a3] = gimbal_axes_base(k);
    Matrix3::from_columns(&[a1, a2, a3])
}

/// [`c_platform_to_base`] and [`gimbal_jacobian`] of the same angles from each angle's
/// `(sin, cos)` (the estimator needs both at every IMU step and has the sines and cosines
/// already; bit for bit what the two functions give).
#[inline]
pub fn gimbal_frame_sin_cos(sc: &[(f64, f64); 3]) -> (Matrix3<f64>, Matrix3<f64>) {
    let [(s1, c1), (s2, c2), (s3, c3)] = *sc;
    // rot_z(k1) rot_x(k2) rot_y(k3) of sins_model::attitude multiplied out: the products of
    // the full matrices add only exact zeros and multiply only by exact ones, so this is
    // the same to the bit with 16 multiplications instead of 54.
    let r12 = Matrix3::new(c1, -s1 * c2, s1 * s2, s1, c1 * c2, -(c1 * s2), 0.0, s2, c2);
    let (x, z) = (r12.column(0), r12.column(2));
    let c = Matrix3::from_columns(&[x * c3 - z * s3, r12.column(1).into(), x * s3 + z * c3]);
    let j = Matrix3::from_columns(&[
        Vector3::z(),
        Vector3::new(c1, s1, 0.0),
        r12.column(1).into(),
    ]);
    (c, j)
}

/// Platform angular rate relative to the base, in base axes (rad/s).
pub fn platform_rate_base(k: &[f64; 3], k_dot: &[f64; 3]) -> Vector3<f64> {
    gimbal_jacobian(k) * Vector3::from(*k_dot)
}

#[cfg(test)]
mod tests {

    #[test]
    fn angle_differences_wrap_the_short_way() {
        assert_eq!(wrap_deg(350.0), -10.0);
        assert_eq!(wrap_deg(-350.0), 10.0);
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(10.0), 10.0);
    }
    use super::*;
    use sins_model::attitude::{log_so3, skew};

    #[test]
    fn zero_angles_give_identity_and_heading_turns_counter_clockwise() {
        assert!((c_platform_to_base(&[0.0; 3]) - Matrix3::identity()).norm() < 1e-15);
        // k1 = 90 deg turns the platform's x axis (East) to North.
        let c = c_platform_to_base(&[90f64.to_radians(), 0.0, 0.0]);
        assert!((c * Vector3::x() - Vector3::y()).norm() < 1e-15);
    }

    #[test]
    fn gimbal_frame_is_both_functions_bit_for_bit() {
        for k in [
            [0.3, -0.4, 1.2],
            [1.0, std::f64::consts::FRAC_PI_2, -0.7],
            [-2.0, 2.5, 0.1],
        ] {
            let (c, j) = gimbal_frame_sin_cos(&k.map(f64::sin_cos));
            assert_eq!(c, c_platform_to_base(&k));
            assert_eq!(j, gimbal_jacobian(&k));
        }
    }

    #[test]
    fn jacobian_matches_finite_differences_including_gimbal_lock() {
        for k in [
            [0.3, -0.4, 1.2],
            [1.0, std::f64::consts::FRAC_PI_2, -0.7],
            [-2.0, 2.5, 0.1],
        ] {
            let j = gimbal_jacobian(&k);
            let c0 = c_platform_to_base(&k);
            for g in 0..3 {
                let h = 1e-6;
                let mut kp = k;
                kp[g] += h;
                let mut km = k;
                km[g] -= h;
                let phi = (log_so3(&(c_platform_to_base(&kp) * c0.transpose()))
                    - log_so3(&(c_platform_to_base(&km) * c0.transpose())))
                    / (2.0 * h);
                assert!((phi - j.column(g)).norm() < 1e-8, "k {k:?} gimbal {g}");
            }
        }
    }

    #[test]
    fn platform_rate_is_the_derivative_of_the_attitude() {
        let k = [0.2, 0.9, -0.3];
        let kd = [0.01, -0.17, 0.05];
        let h = 1e-6;
        let kp: [f64; 3] = std::array::from_fn(|i| k[i] + kd[i] * h);
        let km: [f64; 3] = std::array::from_fn(|i| k[i] - kd[i] * h);
        // dC/dt = skew(w_base) C.
        let c_dot = (c_platform_to_base(&kp) - c_platform_to_base(&km)) / (2.0 * h);
        let w = platform_rate_base(&k, &kd);
        assert!((c_dot - skew(&w) * c_platform_to_base(&k)).norm() < 1e-8);
    }
}
