//! `gyro_accel_time_offset`: the accelerometers sample `d` seconds late against the gyros
//! (`time.gyro_accel`): `f'(t) = f(t - d)`, to first order `df = -d df/dt` (body-axis
//! derivative).
//!
//! Prior 1e-3 s (a sample at 1 kHz, or the group delay difference of the two channels'
//! anti-alias filters); consumer 1e-2 s (a sample at 100 Hz).

use super::{CorrectionPart, Declaration, Effect, GradePriors, ParamNames, Solved};
use crate::terms::{Sensor, SensorInput, Unit};
use nalgebra::Vector3;

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "gyro_accel_time_offset",
    help: "the accelerometers sample late against the gyros, -d df/dt (time.gyro_accel)",
    group_title: "Gyro-accelerometer time offset",
    params: ParamNames::Single("time.gyro_accel"),
    unit: Unit::Second,
    sensor: Sensor::Accel,
    thermal: false,
    priors: GradePriors {
        navigation: 1e-3,
        tactical: 1e-3,
        consumer: 1e-2,
    },
    typical: "a sample at the output rate (1 ms at 1 kHz) or the group-delay difference of \
              the two channels' anti-alias filters",
    effect: Some(&GyroAccelTimeOffset),
    correction: CorrectionPart::Solved(Solved {
        key: "time_offset_s",
        effect: |p, input| GyroAccelTimeOffset.error(p, input),
        derivatives_only: true,
    }),
};

/// `df = -d df/dt`.
#[derive(Clone, Copy, Debug)]
pub struct GyroAccelTimeOffset;

impl Effect for GyroAccelTimeOffset {
    fn uses_rate_derivatives(&self) -> bool {
        true
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        -input.f_dot_body * p[0]
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        out[0] = -input.f_dot_body;
    }
}
