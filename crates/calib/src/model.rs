//! The linear error model the filter runs on, built from IMU-rate samples.
//!
//! Between two filter instants the attitude error obeys `d(beta)/dt = beta x u + C nu(p)`, and
//! every other state is constant. [`LinearModel::substep`] integrates this over one IMU interval
//! (midpoint rule for `C nu`, exact rotation for `beta x u`) into the first three rows of the
//! transition matrix, `phi_top = [Phi_bb | Phi_bp]`, and the attitude process noise `q_top`.
//! The same sub-steps accumulate the interval average of `C * d(df)/dp` for the specific-force
//! measurement.
//!
//! Measurements (x = ENU frame):
//! - specific force, averaged over the measurement interval `T`:
//!   `z = mean(f'_x) - f_x = f_x x beta + mean(C df)`, noise variance `psd_a / T` per axis;
//! - turntable angles, as the small rotation `y` with `C_imu * C_tt^T = exp(-skew(y))`:
//!   `y = beta - gamma_p - C delta_z - Omega_x tau + J rho`, with `J` the gimbal Jacobian.

use crate::layout::StateLayout;
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::attitude::{exp_so3, skew};
use sins_model::terms::{Sensor, SensorInput};

/// Accumulates the transition and measurement matrices of one filter interval.
#[derive(Debug)]
pub struct LinearModel {
    n: usize,
    n_instr: usize,
    /// Rotation of beta over one IMU step due to `beta x u`.
    a_step: Matrix3<f64>,
    /// Gyro white-noise PSD [rad^2/s].
    psd_gyro: f64,
    phi_top: Vec<Vector3<f64>>,
    q_top: Matrix3<f64>,
    hacc: Vec<Vector3<f64>>,
    t_acc: f64,
    jac: Vec<Vector3<f64>>,
    dt: f64,
}

impl LinearModel {
    /// A model for `layout`, IMU step `dt` [s], Earth rate `u_enu` and gyro PSD [rad^2/s].
    pub fn new(layout: &StateLayout, dt: f64, u_enu: &Vector3<f64>, psd_gyro: f64) -> Self {
        let n = layout.dim();
        let n_instr = layout.n_instrument();
        let mut m = Self {
            n,
            n_instr,
            a_step: exp_so3(&(-u_enu * dt)),
            psd_gyro,
            phi_top: vec![Vector3::zeros(); n],
            q_top: Matrix3::zeros(),
            hacc: vec![Vector3::zeros(); n_instr],
            t_acc: 0.0,
            jac: vec![Vector3::zeros(); n_instr],
            dt,
        };
        m.reset_transition();
        m
    }

    /// Start a new transition interval: `phi_top = [I 0]`, `q_top = 0`.
    pub fn reset_transition(&mut self) {
        self.phi_top.fill(Vector3::zeros());
        for i in 0..3 {
            self.phi_top[i][i] = 1.0;
        }
        self.q_top = Matrix3::zeros();
    }

    /// Start a new specific-force averaging interval.
    pub fn reset_accel(&mut self) {
        self.hacc.fill(Vector3::zeros());
        self.t_acc = 0.0;
    }

    /// Integrate one IMU step with the attitude `c_body_to_enu`, body rate and specific force at
    /// its midpoint, and the current parameter estimate `p` (instrument part).
    pub fn substep(
        &mut self,
        layout: &StateLayout,
        c_body_to_enu: &Matrix3<f64>,
        input: &SensorInput,
        p: &[f64],
    ) {
        let dt = self.dt;
        let a = self.a_step;
        for col in self.phi_top.iter_mut() {
            *col = a * *col;
        }
        let off = StateLayout::INSTRUMENT;
        layout.model.jacobian(Sensor::Gyro, p, input, &mut self.jac);
        for (i, j) in self.jac.iter().enumerate() {
            if *j != Vector3::zeros() {
                self.phi_top[off + i] += c_body_to_enu * j * dt;
            }
        }
        self.q_top = a * self.q_top * a.transpose() + Matrix3::identity() * (self.psd_gyro * dt);
        layout
            .model
            .jacobian(Sensor::Accel, p, input, &mut self.jac);
        for (i, j) in self.jac.iter().enumerate() {
            if *j != Vector3::zeros() {
                self.hacc[i] += c_body_to_enu * j * dt;
            }
        }
        self.t_acc += dt;
    }

    /// The accumulated `phi_top` as a dense 3 x n matrix.
    pub fn phi_top(&self) -> DMatrix<f64> {
        DMatrix::from_fn(3, self.n, |i, j| self.phi_top[j][i])
    }

    /// The accumulated attitude process noise.
    pub fn q_top(&self) -> Matrix3<f64> {
        self.q_top
    }

    /// Length of the current specific-force averaging interval [s].
    pub fn accel_interval(&self) -> f64 {
        self.t_acc
    }

    /// Specific-force measurement matrix (3 x n) for the interval since [`Self::reset_accel`]:
    /// `[skew(f_x) | mean(C dDf/dp) | 0]`.
    pub fn accel_h(&self, f_enu: &Vector3<f64>) -> DMatrix<f64> {
        let mut h = DMatrix::zeros(3, self.n);
        h.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(f_enu));
        let inv = 1.0 / self.t_acc;
        for i in 0..self.n_instr {
            for r in 0..3 {
                h[(r, StateLayout::INSTRUMENT + i)] = self.hacc[i][r] * inv;
            }
        }
        h
    }

    /// Turntable-angle measurement matrix (3 x n) at one instant:
    /// `[I | 0 | -C | -Omega_x | -I]` for `beta`, instrument errors, `delta_z`, `tau`, `gamma_p`.
    pub fn turntable_h(
        layout: &StateLayout,
        c_body_to_enu: &Matrix3<f64>,
        platform_rate_enu: &Vector3<f64>,
    ) -> DMatrix<f64> {
        let mut h = DMatrix::zeros(3, layout.dim());
        h.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&Matrix3::identity());
        if let Some(i) = layout.install {
            h.fixed_view_mut::<3, 3>(0, i).copy_from(&(-c_body_to_enu));
        }
        if let Some(i) = layout.tau {
            h.fixed_view_mut::<3, 1>(0, i)
                .copy_from(&(-platform_rate_enu));
        }
        if let Some(i) = layout.base {
            h.fixed_view_mut::<3, 3>(0, i)
                .copy_from(&(-Matrix3::identity()));
        }
        h
    }

    /// Covariance of the turntable measurement noise: `J diag(var) J^T`, plus a floor of 1e-6 of
    /// the mean variance so that `S` stays invertible at gimbal lock, where `J` loses rank and the
    /// first-order model would claim an exact reading about one axis.
    pub fn turntable_r(gimbal_jacobian: &Matrix3<f64>, var_per_gimbal: f64) -> Matrix3<f64> {
        gimbal_jacobian * gimbal_jacobian.transpose() * var_per_gimbal
            + Matrix3::identity() * (1e-6 * var_per_gimbal)
    }
}
