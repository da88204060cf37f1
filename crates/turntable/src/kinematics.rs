//! True motion of an instrument mounted on the turntable at a site.
//!
//! The frames chain as `body -> platform -> base -> ENU`:
//! - `c_body_to_platform = exp(skew(delta_z))`: installation misalignment `delta_z`;
//! - `c_platform_to_base` from the gimbal angles ([`crate::gimbal`]);
//! - `c_base_to_enu = exp(skew(gamma_p))`: base misalignment `gamma_p` (the paper neglects it).
//!
//! The instrument's reduced proof mass is taken to lie on the rotation axes, so the specific
//! force is gravity's reaction, `(0, 0, g)` in ENU, whatever the platform does.

use crate::gimbal::{c_platform_to_base, gimbal_frame_sin_cos};
use crate::program::Program;
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use sins_model::attitude::exp_so3;
use sins_model::earth::Site;

/// How the instrument sits on the platform and the turntable on its foundation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mounting {
    /// Installation misalignment of the instrument frame relative to the platform (rad).
    pub delta_z: Vector3<f64>,
    /// Misalignment of the turntable base relative to ENU (rad).
    pub gamma_p: Vector3<f64>,
}

impl Mounting {
    /// `c_body_to_platform`.
    pub fn c_body_to_platform(&self) -> Matrix3<f64> {
        exp_so3(&self.delta_z)
    }
    /// `c_base_to_enu`.
    pub fn c_base_to_enu(&self) -> Matrix3<f64> {
        exp_so3(&self.gamma_p)
    }
}

/// The motion at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionSample {
    /// Time (s).
    pub t: f64,
    /// Gimbal angles (rad).
    pub k: [f64; 3],
    /// Gimbal rates (rad/s).
    pub k_dot: [f64; 3],
    /// Instrument attitude.
    pub c_body_to_enu: Matrix3<f64>,
    /// Angular rate of the instrument relative to inertial space, in body axes (rad/s).
    pub omega_body: Vector3<f64>,
    /// Specific force in body axes (m/s^2).
    pub f_body: Vector3<f64>,
    /// Angular rate of the platform relative to the base, in ENU axes (rad/s) (`Omega_x`).
    pub platform_rate_enu: Vector3<f64>,
}

/// A program run at a site with a given mounting.
#[derive(Clone, Debug)]
pub struct Kinematics {
    /// The rotation program.
    pub program: Program,
    /// Mounting errors.
    pub mounting: Mounting,
    /// The site.
    pub site: Site,
    c_body_to_platform: Matrix3<f64>,
    c_base_to_enu: Matrix3<f64>,
    u_enu: Vector3<f64>,
    f_enu: Vector3<f64>,
}

impl Kinematics {
    /// Set up the kinematics.
    pub fn new(program: Program, mounting: Mounting, site: Site) -> Self {
        Self {
            c_body_to_platform: mounting.c_body_to_platform(),
            c_base_to_enu: mounting.c_base_to_enu(),
            u_enu: site.earth_rate_enu(),
            f_enu: site.specific_force_at_rest_enu(),
            program,
            mounting,
            site,
        }
    }

    /// Earth rate in ENU (rad/s).
    pub fn earth_rate_enu(&self) -> Vector3<f64> {
        self.u_enu
    }

    /// Specific force in ENU (m/s^2).
    pub fn specific_force_enu(&self) -> Vector3<f64> {
        self.f_enu
    }

    /// `c_body_to_enu` for given gimbal angles.
    pub fn c_body_to_enu(&self, k: &[f64; 3]) -> Matrix3<f64> {
        self.c_base_to_enu * c_platform_to_base(k) * self.c_body_to_platform
    }

    /// The motion at time `t`.
    pub fn sample(&self, t: f64) -> MotionSample {
        let (k, k_dot) = self.program.state(t);
        self.motion(t, k, k_dot)
    }

    /// The motion at time `t` with the rates' left limits ([`Program::state_left`]): where the
    /// program's rate jumps, `omega_body(b) - omega_body(a)` from these samples counts the jump
    /// once, in the interval `(a, b]` that holds it.
    pub fn sample_left(&self, t: f64) -> MotionSample {
        let (k, k_dot) = self.program.state_left(t);
        self.motion(t, k, k_dot)
    }

    fn motion(&self, t: f64, k: [f64; 3], k_dot: [f64; 3]) -> MotionSample {
        // One sine and cosine per angle for the attitude and the rate together (the same to the
        // bit as `c_body_to_enu` and `gimbal::platform_rate_base`, which take them twice).
        let (c_platform, jacobian) = gimbal_frame_sin_cos(&k.map(f64::sin_cos));
        let c = self.c_base_to_enu * c_platform * self.c_body_to_platform;
        let platform_rate_enu = self.c_base_to_enu * (jacobian * Vector3::from(k_dot));
        let omega_body = c.transpose() * (self.u_enu + platform_rate_enu);
        MotionSample {
            t,
            k,
            k_dot,
            c_body_to_enu: c,
            omega_body,
            f_body: c.transpose() * self.f_enu,
            platform_rate_enu,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::Program;
    use sins_model::attitude::skew;

    #[test]
    fn paper_program_puts_each_instrument_axis_along_east_in_turn() {
        let kin = Kinematics::new(
            Program::paper(),
            Mounting::default(),
            Site::from_degrees(55.7, 37.6, 0.0),
        );
        let east = Vector3::x();
        for (t, axis) in [(100.0, 0usize), (1000.0, 1), (2000.0, 2)] {
            let s = kin.sample(t);
            let along = s.c_body_to_enu.column(axis).into_owned();
            assert!((along.dot(&east).abs() - 1.0).abs() < 1e-12, "t = {t}");
            // The platform turns at 10 deg/s about that axis.
            assert!((s.platform_rate_enu.norm() - 10f64.to_radians()).abs() < 1e-12);
            assert!((s.platform_rate_enu.normalize().dot(&east).abs() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn body_rate_is_consistent_with_the_attitude_derivative() {
        let m = Mounting {
            delta_z: Vector3::new(1e-3, -2e-3, 5e-4),
            gamma_p: Vector3::new(1e-4, 0.0, -3e-4),
        };
        let kin = Kinematics::new(Program::paper(), m, Site::from_degrees(55.7, 37.6, 0.0));
        for t in [50.0, 1200.0, 2100.0] {
            let h = 1e-5;
            let c_dot =
                (kin.sample(t + h).c_body_to_enu - kin.sample(t - h).c_body_to_enu) / (2.0 * h);
            let s = kin.sample(t);
            // dC/dt = C skew(omega_body) - skew(u) C for the body-to-ENU DCM.
            let u = kin.earth_rate_enu();
            let expected = s.c_body_to_enu * skew(&s.omega_body) - skew(&u) * s.c_body_to_enu;
            assert!((c_dot - expected).norm() < 1e-8, "t = {t}");
        }
    }
}
