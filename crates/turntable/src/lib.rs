//! # turntable
//!
//! What a calibration turntable does to an instrument and what its angle sensors report:
//!
//! - [`program`]: rotation programs (segments of constant gimbal rate, dwells, moves) read from
//!   TOML, with the paper's three-cycle program embedded as the default;
//! - [`gimbal`]: three-axis gimbal kinematics in the paper's heading-bank-pitch sequence and the
//!   Jacobian that maps angle-sensor errors to a small rotation;
//! - [`kinematics`]: the true attitude, body rate and specific force of an instrument mounted on
//!   the platform (installation misalignment `delta_z`, base misalignment `gamma_p`);
//! - [`sensor`]: the angle-sensor model (noise, delay `tau`, its own clock);
//! - [`temperature`]: the instrument's temperature over a run (constant, warm-up, ramp, steps).
//!
//! ```
//! use turntable::{kinematics::{Kinematics, Mounting}, program::Program};
//! use sins_model::earth::Site;
//!
//! let kin = Kinematics::new(Program::paper(), Mounting::default(), Site::from_degrees(55.7, 37.6, 0.0));
//! let s = kin.sample(100.0); // first cycle: instrument x along the East rotation axis
//! assert!((s.c_body_to_enu[(0, 0)] - 1.0).abs() < 1e-12);
//! assert!((s.omega_body.x - 10f64.to_radians()).abs() < 1e-9);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod gimbal;
pub mod kinematics;
pub mod program;
pub mod sensor;
pub mod simulate;
pub mod temperature;
