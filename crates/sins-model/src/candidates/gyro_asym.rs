//! `gyro_scale_asymmetry`: gyro scale-factor asymmetry (`gyro.asym.x, .y, .z`): the
//! scale-factor error is `Theta_ii + a_i` for positive and `Theta_ii - a_i` for negative rates,
//! `nu_i += a_i abs(w_i)`.
//!
//! Prior 1e-5 (10 ppm: RLG/FOG data sheets give 1 to 50 ppm); tactical 1e-3; consumer 1e-2.

use super::{CorrectionPart, Declaration, Effect, GradePriors, ParamNames, Solved};
use crate::terms::{AxisColumn, Feature, Sensor, SensorInput, Unit, diagonal_jacobian};
use nalgebra::Vector3;

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "gyro_scale_asymmetry",
    help: "gyro scale factors that differ for positive and negative rates, a |w| (gyro.asym.<i>)",
    group_title: "Gyro scale-factor asymmetry a (positive rates 1 - theta - a, negative 1 - theta + a)",
    params: ParamNames::PerAxis("gyro.asym."),
    unit: Unit::Ratio,
    sensor: Sensor::Gyro,
    thermal: false,
    priors: GradePriors {
        navigation: 1e-5,
        tactical: 1e-3,
        consumer: 1e-2,
    },
    typical: "RLG/FOG data sheets 1 to 50 ppm; tactical MEMS 100 to 1000 ppm",
    effect: Some(&GyroScaleAsymmetry),
    correction: CorrectionPart::Solved(Solved {
        key: "asym",
        effect: |p, input| GyroScaleAsymmetry.error(p, input),
        derivatives_only: false,
    }),
};

/// `nu_i += a_i abs(w_i)`.
#[derive(Clone, Copy, Debug)]
pub struct GyroScaleAsymmetry;

impl Effect for GyroScaleAsymmetry {
    fn is_affine_in_orthant(&self) -> bool {
        true
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let w = input.omega_body;
        Vector3::new(p[0] * w.x.abs(), p[1] * w.y.abs(), p[2] * w.z.abs())
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        diagonal_jacobian(&input.omega_body.abs(), out);
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some(
            (0..3)
                .map(|k| AxisColumn::new(k, Feature::AbsOmega(k)))
                .collect(),
        )
    }
}
