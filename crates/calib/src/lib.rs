//! # calib
//!
//! Turntable calibration of a strapdown inertial navigation system, after Vavilova, Golovan,
//! Parusnikov and Vasineva (Lomonosov Moscow State University): a Kalman filter estimates the gyro
//! biases, the full gyro scale/misalignment matrix, the accelerometer biases and the
//! lower-triangular accelerometer matrix from a rotation program, from the IMU's own data alone
//! (24 states) or with the turntable's angle sensors (28 states: + installation misalignment and
//! the delay between the two data streams).
//!
//! - [`config`]: run configuration (site, priors, noises, filter rates) from TOML;
//! - [`layout`]: the state vector assembled from the error terms;
//! - [`model`]: transition and measurement matrices built from IMU-rate samples;
//! - [`engine`]: the filter loop the covariance analysis and the estimation share (the Kalman
//!   engine itself, with its normalised states, is the `kalman` crate);
//! - [`covariance`]: covariance analysis of a program;
//! - [`report`]: the paper's tables.
//!
//! ```
//! use calib::{config::RunConfig, covariance::covariance_analysis};
//!
//! let mut config = RunConfig::paper();
//! config.filter.imu_rate_hz = 10.0; // coarse sub-steps keep the example fast
//! let imu_only = covariance_analysis(&config, false).unwrap();
//! let with_tt = covariance_analysis(&config, true).unwrap();
//! // The turntable angles sharpen the gyro bias.
//! assert!(with_tt.sigma("gyro.bias.x").unwrap() < imu_only.sigma("gyro.bias.x").unwrap());
//! ```

#![forbid(unsafe_code)]

pub mod align;
pub mod config;
pub mod covariance;
pub mod data_checks;
pub mod engine;
pub mod estimate;
pub mod io;
pub mod layout;
pub mod model;
pub mod paper;
pub mod program_start;
pub mod report;
pub mod simulate;
pub mod stats;
