//! # sins-model
//!
//! The physics a strapdown inertial navigation system (SINS) calibration is built on, with no
//! knowledge of turntables, filters or files:
//!
//! - [`earth`]: WGS-84 normal gravity, Earth rate and radii at a site;
//! - [`attitude`]: DCMs, rotation vectors, quaternions, and the mapping to the paper's `L` and hat;
//! - [`terms`]: instrument errors as composable terms (parameters with names, units and prior sigma;
//!   the effect on the sensor output; its Jacobian);
//! - [`candidates`]: candidate terms beyond the paper's model (g-sensitivity, scale asymmetry,
//!   accelerometer nonlinearity, size effect, gyro-accelerometer time offset, the thermal terms)
//!   and the gyro bias drift option, each declared once in its own file (id, parameter names,
//!   units, priors by grade, group title, help text, effect, correction part);
//! - [`errors`]: the attitude-error equation for `beta` and the specific-force measurement.
//!
//! ```
//! use sins_model::earth::Site;
//! let moscow = Site::from_degrees(55.7, 37.6, 200.0);
//! let g = moscow.normal_gravity();
//! assert!((g - 9.815).abs() < 0.002);
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod attitude;
pub mod candidates;
pub mod earth;
pub mod errors;
pub mod names;
pub mod paper;
pub mod terms;
pub mod text;
pub mod timing;
pub mod units;
