//! `accel_size_effect`: accelerometer `i` sits at `r_i` from the common point (the point whose
//! specific force `f` the unit reports, and the rotation centre of the turntable), parameters
//! `accel.lever.<i><j>` = component `j` of `r_i`. It senses component `i` of
//! `f + dw/dt x r_i + w x (w x r_i)`, so `df_i += e_i . (M r_i)` with
//! `M = skew(dw/dt) + skew(w)^2`. The tangential part is linear in `dw/dt` (the contract of
//! [`SensorInput`]).
//!
//! Prior 0.02 m at every grade (offset of each accelerometer's proof mass from the common point
//! in a navigation-grade cluster of pendulous accelerometers: centimetres).

use super::{CorrectionPart, Declaration, Effect, GradePriors, ParamNames, Solved};
use crate::terms::{Sensor, SensorInput, Unit, matrix_jacobian};
use nalgebra::{Matrix3, Vector3};

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "accel_size_effect",
    help: "offsets of the accelerometers from the common point, the size effect \
           (accel.lever.<ij>)",
    group_title: "Accelerometer lever arms (size effect; row: accelerometer)",
    params: ParamNames::Matrix("accel.lever."),
    unit: Unit::Meter,
    sensor: Sensor::Accel,
    thermal: false,
    priors: GradePriors {
        navigation: 0.02,
        tactical: 0.02,
        consumer: 0.02,
    },
    typical: "proof-mass offsets of a few centimetres in a navigation-grade cluster; \
              millimetres in a MEMS package",
    effect: Some(&AccelSizeEffect),
    correction: CorrectionPart::Solved(Solved {
        key: "lever",
        effect: |p, input| AccelSizeEffect.error(p, input),
        derivatives_only: false,
    }),
};

/// `df_i += e_i . (M r_i)`.
#[derive(Clone, Copy, Debug)]
pub struct AccelSizeEffect;

impl AccelSizeEffect {
    /// `M = skew(dw/dt) + skew(w)^2`: `M r = dw/dt x r + w x (w x r)`.
    fn lever_matrix(input: &SensorInput) -> Matrix3<f64> {
        let sw = input.omega_body.cross_matrix();
        input.omega_dot_body.cross_matrix() + sw * sw
    }
}

impl Effect for AccelSizeEffect {
    fn uses_rate_derivatives(&self) -> bool {
        true
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let m = Self::lever_matrix(input);
        Vector3::from_fn(|i, _| (0..3).map(|j| m[(i, j)] * p[3 * i + j]).sum())
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let m = Self::lever_matrix(input);
        matrix_jacobian(|i, j| m[(i, j)], out);
    }
}
