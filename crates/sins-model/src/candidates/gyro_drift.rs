//! `gyro_bias_drift`: random walk of the gyro biases, `d(nu0_i)/dt` white with PSD
//! `drift_i^2` (`gyro.drift.<i>`, rad/s/sqrt(s)). Not a term (no constant parameters): process
//! noise on the states `gyro.bias.i`, a model option.
//!
//! Its "prior" is the default random-walk intensity, 0.1 deg/h/sqrt(h) (between navigation
//! grade, 0.001 to 0.01, and tactical grade, about 1); tactical 1, consumer 10.

use super::{CorrectionPart, Declaration, GradePriors, ParamNames};
use crate::terms::{Sensor, Unit};

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "gyro_bias_drift",
    help: "random walk of the gyro biases, process noise rather than a constant error \
           (gyro.drift.<i>)",
    group_title: "Gyro bias random walk",
    params: ParamNames::PerAxis("gyro.drift."),
    unit: Unit::RadPerSecondPerSqrtSecond,
    sensor: Sensor::Gyro,
    thermal: false,
    priors: GradePriors {
        navigation: 0.1 / Unit::RadPerSecondPerSqrtSecond.report_factor(),
        tactical: 1.0 / Unit::RadPerSecondPerSqrtSecond.report_factor(),
        consumer: 10.0 * (1.0 / Unit::RadPerSecondPerSqrtSecond.report_factor()),
    },
    typical: "navigation grade 0.001 to 0.01 deg/h/sqrt(h); tactical about 0.1 to 1; \
              consumer MEMS tens",
    effect: None,
    correction: CorrectionPart::None,
};
