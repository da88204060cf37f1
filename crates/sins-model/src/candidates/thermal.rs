//! The effects the four thermal terms share: a bias or a scale factor that changes linearly
//! with `dT` = [`SensorInput::temp_delta`], for the gyros or the accelerometers. Affine in the
//! rate and force for a fixed temperature but not for a fixed set of parameters, so not
//! [`Effect::is_affine`].

use super::Effect;
use crate::terms::{AxisColumn, Feature, Sensor, SensorInput, diagonal_jacobian};
use nalgebra::Vector3;

/// Biases that change with temperature (`<sensor>.tbias.<i>`): `e_i += b_i dT`.
#[derive(Clone, Copy, Debug)]
pub struct TempBias;

impl Effect for TempBias {
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        Vector3::new(p[0], p[1], p[2]) * input.temp_delta
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        diagonal_jacobian(&Vector3::repeat(input.temp_delta), out);
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some((0..3).map(|k| AxisColumn::new(k, Feature::Temp)).collect())
    }
}

/// Scale factors that change with temperature (`<sensor>.tscale.<i>`): `e_i += s_i dT x_i`,
/// `x` the body rate (gyros) or specific force (accelerometers).
#[derive(Clone, Copy, Debug)]
pub struct TempScale {
    /// Whose scale factors.
    pub sensor: Sensor,
}

impl TempScale {
    fn input_of(&self, input: &SensorInput) -> Vector3<f64> {
        match self.sensor {
            Sensor::Gyro => input.omega_body,
            Sensor::Accel => input.f_body,
        }
    }
}

impl Effect for TempScale {
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let x = self.input_of(input) * input.temp_delta;
        Vector3::new(p[0] * x.x, p[1] * x.y, p[2] * x.z)
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        diagonal_jacobian(&(self.input_of(input) * input.temp_delta), out);
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        let feature = |k| match self.sensor {
            Sensor::Gyro => Feature::TempOmega(k),
            Sensor::Accel => Feature::TempForce(k),
        };
        Some((0..3).map(|k| AxisColumn::new(k, feature(k))).collect())
    }
}
