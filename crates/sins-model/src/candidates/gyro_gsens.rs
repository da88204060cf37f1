//! `gyro_g_sensitivity`: gyro error proportional to the specific force, full 3x3 `G`
//! (row-major parameters `gyro.gsens.xx, .xy, ...`; `xy` is the effect on gyro x of the
//! specific force along y): `nu += G f_body`. Affine in the input.
//!
//! Prior 1e-6 rad/s per m/s^2 (2 deg/h/g: dynamically tuned gyros and FOGs of that class quote
//! 0.1 to 10 deg/h/g; ring lasers much less); tactical 1e-5 (20 deg/h/g); consumer 0.1 deg/s/g
//! (a consumer unit's g-sensitivity of 0.05 deg/s/g against a prior of 2 deg/h/g would stay
//! "not observed" where the data show it plainly).

use super::{CorrectionPart, Declaration, Effect, GradePriors, ParamNames, Solved};
use crate::terms::{
    AxisColumn, Feature, Sensor, SensorInput, Unit, matrix_axis_columns, matrix_jacobian,
};
use nalgebra::{Matrix3, Vector3};

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "gyro_g_sensitivity",
    help: "gyro error proportional to the specific force, G f (full 3x3, gyro.gsens.<ij>)",
    group_title: "Gyro g-sensitivity G (row: gyro, column: specific force)",
    params: ParamNames::Matrix("gyro.gsens."),
    unit: Unit::RadPerSecondPerMeterPerSecond2,
    sensor: Sensor::Gyro,
    thermal: false,
    priors: GradePriors {
        navigation: 1e-6,
        tactical: 1e-5,
        consumer: 0.1 * (std::f64::consts::PI / 180.0) / 9.80665,
    },
    typical: "ring lasers well below 0.1 deg/h/g; dynamically tuned gyros and FOGs 0.1 to 10 \
              deg/h/g (5e-8 to 5e-6 rad/s per m/s^2); MEMS gyros 0.01 to 0.1 deg/s/g \
              (data sheets)",
    effect: Some(&GyroGSensitivity),
    correction: CorrectionPart::Solved(Solved {
        key: "gsens",
        effect: |p, input| GyroGSensitivity.error(p, input),
        derivatives_only: false,
    }),
};

/// `nu += G f_body`.
#[derive(Clone, Copy, Debug)]
pub struct GyroGSensitivity;

impl Effect for GyroGSensitivity {
    fn is_affine(&self) -> bool {
        true
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        Matrix3::from_row_slice(&p[..9]) * input.f_body
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let f = input.f_body;
        matrix_jacobian(|_, j| f[j], out);
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some(matrix_axis_columns(Feature::Force))
    }
}
