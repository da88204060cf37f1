//! `accel_quadratic`: accelerometer second-order nonlinearity (`accel.k2.x, .y, .z`):
//! `df_i += k2_i f_i^2`.
//!
//! Prior 1e-5 per m/s^2 (1e-4/g, 100 micro-g/g^2: pendulous quartz accelerometers quote 10 to
//! 100 micro-g/g^2 uncompensated); tactical 2e-5 (200 micro-g/g^2); consumer 1e-4
//! (1000 micro-g/g^2).

use super::{CorrectionPart, Declaration, Effect, GradePriors, ParamNames, Solved};
use crate::terms::{Sensor, SensorInput, Unit, diagonal_jacobian};
use nalgebra::Vector3;

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "accel_quadratic",
    help: "accelerometer error quadratic in the specific force along its axis, k2 f^2 \
           (accel.k2.<i>)",
    group_title: "Accelerometer quadratic term (per axis, on its own specific force)",
    params: ParamNames::PerAxis("accel.k2."),
    unit: Unit::PerMeterPerSecond2,
    sensor: Sensor::Accel,
    thermal: false,
    priors: GradePriors {
        navigation: 1e-5,
        tactical: 2e-5,
        consumer: 1e-4,
    },
    typical: "pendulous quartz accelerometers 10 to 100 micro-g/g^2 uncompensated (1e-6 to \
              1e-5 per m/s^2); tactical MEMS about 200 micro-g/g^2 (2e-5 per m/s^2)",
    effect: Some(&AccelQuadratic),
    correction: CorrectionPart::Solved(Solved {
        key: "k2",
        // `k2_i (f_i f_i)`: the correction's order of operations since it was written (the
        // simulator's, `(k2_i f_i) f_i`, may differ in the last bit).
        effect: |p, input| {
            let f = input.f_body;
            Vector3::new(p[0], p[1], p[2]).component_mul(&f.component_mul(&f))
        },
        derivatives_only: false,
    }),
};

/// `df_i += k2_i f_i^2`.
#[derive(Clone, Copy, Debug)]
pub struct AccelQuadratic;

impl Effect for AccelQuadratic {
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let f = input.f_body;
        Vector3::new(p[0] * f.x * f.x, p[1] * f.y * f.y, p[2] * f.z * f.z)
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        diagonal_jacobian(&input.f_body.component_mul(&input.f_body), out);
    }
}
