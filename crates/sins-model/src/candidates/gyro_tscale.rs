//! `gyro_temp_scale`: gyro scale factors that change linearly with temperature
//! (`gyro.tscale.<i>`, 1/K): `nu_i += s_i dT w_i` ([`TempScale`]).
//!
//! Prior 10 ppm/K; tactical 100 ppm/K; consumer 500 ppm/K.

use super::thermal::TempScale;
use super::{CorrectionPart, Declaration, GradePriors, ParamNames, ThermalPart};
use crate::terms::{Sensor, Unit};

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "gyro_temp_scale",
    help: "gyro scale factors that change with temperature, s dT w (gyro.tscale.<i>; needs \
           temperatures)",
    group_title: "Gyro scale-factor temperature coefficients",
    params: ParamNames::PerAxis("gyro.tscale."),
    unit: Unit::PerKelvin,
    sensor: Sensor::Gyro,
    thermal: true,
    priors: GradePriors {
        navigation: 1e-5,
        tactical: 1e-4,
        consumer: 5e-4,
    },
    typical: "navigation gyros a few ppm/K; MEMS gyros 100 to 500 ppm/K (data sheets)",
    effect: Some(&TempScale {
        sensor: Sensor::Gyro,
    }),
    correction: CorrectionPart::Thermal(ThermalPart::Scale),
};
