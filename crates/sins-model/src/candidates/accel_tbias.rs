//! `accel_temp_bias`: accelerometer biases that change linearly with temperature
//! (`accel.tbias.<i>`, m/s^2/K): `df_i += a_i dT` ([`TempBias`]).
//!
//! Prior 1e-4 m/s^2/K (10 micro-g/K: quartz pendulous accelerometers 5 to 50 micro-g/K
//! uncompensated); tactical 5e-4 (50 micro-g/K); consumer 5e-3 (0.5 mg/K).

use super::thermal::TempBias;
use super::{CorrectionPart, Declaration, GradePriors, ParamNames, ThermalPart};
use crate::terms::{Sensor, Unit};

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "accel_temp_bias",
    help: "accelerometer biases that change with temperature, a dT (accel.tbias.<i>; needs \
           temperatures)",
    group_title: "Accelerometer bias temperature coefficients",
    params: ParamNames::PerAxis("accel.tbias."),
    unit: Unit::MeterPerSecond2PerKelvin,
    sensor: Sensor::Accel,
    thermal: true,
    priors: GradePriors {
        navigation: 1e-4,
        tactical: 5e-4,
        consumer: 5e-3,
    },
    typical: "quartz pendulous accelerometers 5 to 50 micro-g/K uncompensated; MEMS 0.1 to \
              0.5 mg/K (data sheets)",
    effect: Some(&TempBias),
    correction: CorrectionPart::Thermal(ThermalPart::Bias),
};
