//! `gyro_temp_bias`: gyro biases that change linearly with temperature (`gyro.tbias.<i>`,
//! rad/s/K): `nu_i += b_i dT` ([`TempBias`]).
//!
//! Prior 0.01 deg/h/K (navigation FOGs and RLGs quote 0.001 to 0.01 deg/h/K after their own
//! compensation, several times that before it); tactical 1 deg/h/K; consumer 36 deg/h/K
//! (0.01 deg/s/K).

use super::thermal::TempBias;
use super::{CorrectionPart, Declaration, GradePriors, ParamNames, ThermalPart};
use crate::terms::{Sensor, Unit};

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "gyro_temp_bias",
    help: "gyro biases that change with temperature, b dT (gyro.tbias.<i>; needs temperatures)",
    group_title: "Gyro bias temperature coefficients (about the reference temperature)",
    params: ParamNames::PerAxis("gyro.tbias."),
    unit: Unit::RadPerSecondPerKelvin,
    sensor: Sensor::Gyro,
    thermal: true,
    priors: GradePriors {
        navigation: 0.01 / Unit::RadPerSecondPerKelvin.report_factor(),
        tactical: 1.0 / Unit::RadPerSecondPerKelvin.report_factor(),
        consumer: 36.0 / Unit::RadPerSecondPerKelvin.report_factor(),
    },
    typical: "navigation FOGs and RLGs 0.001 to 0.01 deg/h/K after their own compensation; \
              tactical FOGs and MEMS 0.1 to 1 deg/h/K; consumer MEMS 0.001 to 0.01 deg/s/K \
              (data sheets)",
    effect: Some(&TempBias),
    correction: CorrectionPart::Thermal(ThermalPart::Bias),
};
