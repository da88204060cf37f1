//! # calib
//!
//! Turntable calibration of a strapdown inertial navigation system, after Vavilova, Golovan,
//! Parusnikov and Vasineva (Lomonosov Moscow State University): a Kalman filter estimates the gyro
//! biases, the full gyro scale/misalignment matrix, the accelerometer biases and the
//! lower-triangular accelerometer matrix from a rotation program, from the IMU's own data alone
//! (24 states) or with the turntable's angle sensors (28 states: + installation misalignment and
//! the delay between the two data streams).
//!
//! The crate is in rooms, each over the ones before it:
//!
//! - [`config`]: run configuration (site, priors, noises, filter rates, clock) from TOML, and
//!   the physical bounds of values read ([`config::plausible`]);
//! - [`io`]: the interchange files (readers with file and line in every error, writers), the
//!   angle records read as a stream, the schema stamp and the correlation of a result;
//! - [`model`]: the error model: transition and measurement matrices, the state layout, the
//!   candidate terms, the compensation of raw records, and the filter's schedule ([`model::engine`]);
//! - [`check`]: tests of a fit from its innovations, NEES and chi-square bands;
//! - [`motion`]: the program (declared or from the angles), its start on the IMU clock, the coarse
//!   attitude, and the rests of recordings without a program;
//! - [`estimate`]: calibration from recorded data, the covariance analysis of a program, the
//!   checks of the records, and a hand-turned recording's noise from its own rests;
//! - [`report`]: the paper's tables and the lab report's figures;
//! - [`extend`]: the model-extension loop, its statistics, and programs that separate what a
//!   recorded program cannot;
//! - [`simulate`]: the truth of a simulated run from a run configuration;
//! - [`paper`]: the paper's configurations.
//!
//! ```
//! use calib::{config::RunConfig, estimate::covariance::covariance_analysis};
//!
//! let mut config = RunConfig::paper();
//! config.filter.imu_rate_hz = 10.0; // coarse sub-steps keep the example fast
//! let imu_only = covariance_analysis(&config, false).unwrap();
//! let with_tt = covariance_analysis(&config, true).unwrap();
//! // The turntable angles sharpen the gyro bias.
//! assert!(with_tt.sigma("gyro.bias.x").unwrap() < imu_only.sigma("gyro.bias.x").unwrap());
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod check;
pub mod config;
pub mod estimate;
pub mod extend;
pub mod io;
pub mod model;
pub mod motion;
pub mod paper;
pub mod report;
pub mod simulate;
