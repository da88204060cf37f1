//! `accel_temp_scale`: accelerometer scale factors that change linearly with temperature
//! (`accel.tscale.<i>`, 1/K): `df_i += s_i dT f_i` ([`TempScale`]).
//!
//! Prior 50 ppm/K (quartz pendulous 100 to 200 ppm/K before their own compensation); tactical
//! 200 ppm/K; consumer 500 ppm/K.

use super::thermal::TempScale;
use super::{CorrectionPart, Declaration, GradePriors, ParamNames, ThermalPart};
use crate::terms::{Sensor, Unit};

/// The declaration.
pub static DECLARATION: Declaration = Declaration {
    id: "accel_temp_scale",
    help: "accelerometer scale factors that change with temperature, s dT f (accel.tscale.<i>; \
           needs temperatures)",
    group_title: "Accelerometer scale-factor temperature coefficients",
    params: ParamNames::PerAxis("accel.tscale."),
    unit: Unit::PerKelvin,
    sensor: Sensor::Accel,
    thermal: true,
    priors: GradePriors {
        navigation: 5e-5,
        tactical: 2e-4,
        consumer: 5e-4,
    },
    typical: "quartz pendulous accelerometers 100 to 200 ppm/K before their own \
              compensation; MEMS 100 to 500 ppm/K (data sheets)",
    effect: Some(&TempScale {
        sensor: Sensor::Accel,
    }),
    correction: CorrectionPart::Thermal(ThermalPart::Scale),
};
