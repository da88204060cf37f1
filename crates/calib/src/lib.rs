//! # calib
//!
//! Turntable calibration of a strapdown inertial navigation system, after Vavilova, Golovan,
//! Parusnikov and Vasineva (Lomonosov Moscow State University): a Kalman filter estimates the gyro
//! biases, the full gyro scale/misalignment matrix, the accelerometer biases and the
//! lower-triangular accelerometer matrix from a rotation program, from the IMU's own data alone
//! (24 states) or with the turntable's angle sensors (28 states: + installation misalignment and
//! the delay between the two data streams).
//!
//! - [`config`]: run configuration (site, priors, noises, filter rates, clock) from TOML;
//! - [`correction`]: the estimated model inverted, to correct raw IMU records;
//! - [`posterior`]: correlation matrices of posterior covariances for result files;
//! - [`layout`]: the state vector assembled from the error terms, and the prior;
//! - [`model`]: transition and measurement matrices built from IMU-rate samples;
//! - [`engine`]: the measurement schedule and the predict/update loop shared by the covariance
//!   analysis and the estimation, on [`kalman::KalmanFilter`];
//! - [`covariance`]: covariance analysis of a program;
//! - [`evidence`]: the statistics of model extension (score test, separability, gain);
//! - [`extend`]: the model-extension loop (fit, test the candidate terms, accept, measure);
//! - [`design`]: programs that separate candidate terms the recorded program cannot;
//! - [`estimate`]: calibration from recorded data (`imu.csv`, `turntable.csv`);
//! - [`extension`]: candidate terms beyond the paper's model for the filter
//!   ([`extension::ModelExtension`]) and the simulator ([`extension::HiddenEffects`]);
//! - [`angles_program`]: the program read from the turntable's angle records;
//! - [`align`]: coarse alignment of the start attitude to the program's rotations;
//! - [`program_start`]: where the program starts on the IMU clock;
//! - [`rests`]: recordings without a program: the rests in place of the program;
//! - [`data_checks`]: checks of the IMU data before any filter;
//! - [`free_motion`]: the batch fit of a hand-turned multi-position recording (no turntable):
//!   the coarse start of the filter on such recordings, and their held-out figures;
//! - [`hand_turned`]: a hand-turned recording's noise and configuration from its own rests;
//! - [`io`]: the interchange files (readers with file and line in every error, writers);
//! - [`simulate`]: the truth of a simulated run from a run configuration;
//! - [`schema`]: the schema stamp of the JSON files written and its check on reading;
//! - [`stats`]: NEES and chi-square bands;
//! - [`diagnostics`]: tests of a fit from its innovations (NIS per segment, whiteness, lines at
//!   the program's frequencies, regression on candidate terms);
//! - [`paper`], [`report`]: the paper's configurations and tables.
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
#![warn(missing_docs)]

pub mod align;
pub mod angle_records;
pub mod angles_program;
pub mod config;
pub mod correction;
pub mod covariance;
pub mod data_checks;
pub mod design;
pub mod diagnostics;
pub mod drift_visibility;
pub mod engine;
pub mod estimate;
pub mod evidence;
pub mod extend;
pub mod extension;
pub mod free_motion;
pub mod hand_turned;
pub mod io;
pub mod layout;
pub mod model;
pub mod paper;
pub mod plausible;
pub mod posterior;
pub mod program_start;
pub mod report;
pub mod rests;
pub mod schema;
pub mod simulate;
pub mod stats;
