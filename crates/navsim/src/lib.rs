//! # navsim
//!
//! Judges a SINS calibration by what it does to autonomous navigation, as the paper does: the
//! instrument-error covariance a calibration leaves is pushed through the standard SINS error
//! equations along a one-hour "snake" flight (parallel legs joined by alternating 180-degree
//! coordinated turns), starting from a stationary self-alignment whose errors follow from the
//! same instrument errors, and the figure of merit
//! `rho = a sqrt(sigma^2(dlambda cos phi) + sigma^2(dphi))` is reported over time, with an error
//! budget per group of instrument errors.
//!
//! - [`config`]: the flight in TOML ([`SnakeConfig`], default embedded from
//!   `config/snake_default.toml`);
//! - [`trajectory`]: the true motion (snake, or at rest), body rate and specific force;
//! - [`instruments`]: the calibration's parameters by name and their covariance
//!   ([`InstrumentCovariance`]);
//! - [`model`]: the error model in ENU axes and the alignment map;
//! - [`mod@propagate`]: covariance propagation, [`RhoSeries`], [`error_budget`];
//! - [`figure`]: the navigation figure of a calibration (rho at a horizon that follows the
//!   unit's grade, calibrated and uncalibrated, the budget by parameter group);
//! - [`response`]: the propagation itself, per unit instrument error ([`NavResponse`]), once
//!   for any number of instrument covariances.
//!
//! Frames and units: ENU navigation frame, body = instrument frame x1 right wing, x2 forward,
//! x3 up; SI inside. See `docs/navsim.md` for the equations and the numbers.
//!
//! ```
//! use navsim::{InstrumentCovariance, NavOptions, SnakeConfig, SnakeTrajectory, rho_series};
//!
//! // The default one-hour snake and the paper's result table with the turntable angles.
//! let flight = SnakeTrajectory::new(&SnakeConfig::default_config()).unwrap();
//! let calib = InstrumentCovariance::from_paper(&sins_model::paper::TABLE_WITH_TURNTABLE);
//! let rho = rho_series(&flight, &calib, &NavOptions::default()).unwrap();
//! let after_one_hour = rho.final_rho_m();
//! assert_eq!(rho.t.last(), Some(&3600.0));
//! // docs/navsim.md: 1062 m for the paper's table row (the paper itself says 1100 m).
//! assert!((after_one_hour / 1062.0 - 1.0).abs() < 0.01, "{after_one_hour}");
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod config;
pub mod figure;
pub mod instruments;
pub mod model;
pub mod propagate;
pub mod response;
pub mod trajectory;

pub use config::{ConfigError, DEFAULT_SNAKE_TOML, SnakeConfig, TurnDirection};
pub use figure::{
    CalibrationCovariance, FlightSetting, GroupRho, Horizon, Judge, NavigationFigure, TermNote,
    horizon, navigation_figure,
};
pub use instruments::{
    INSTRUMENT_NAMES, InstrumentCovariance, InstrumentModel, NamePolicy, ParameterGroup,
};
pub use propagate::{
    BudgetEntry, BudgetGroup, ErrorBudget, InitialAttitude, NavOptions, NavSnapshot, RhoSeries,
    error_budget, initial_covariance, propagate, rho_series, state_names,
};
pub use response::{NavResponse, Part};
pub use trajectory::{SnakeTrajectory, StaticTrajectory, Trajectory, TrajectoryPoint};

use thiserror::Error;

/// Errors of the navigation-error analysis.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum NavError {
    /// The calibration result lacks parameters navigation needs (names listed); allow with
    /// [`NamePolicy::allow_missing`] to treat them as perfectly known.
    #[error("instrument parameters missing from the calibration result: {0:?}")]
    MissingParameters(Vec<String>),
    /// The calibration result has parameters navigation does not model (names listed).
    #[error("instrument parameters unknown to navigation: {0:?}")]
    UnknownParameters(Vec<String>),
    /// The covariance matrix is malformed.
    #[error("instrument covariance: {0}")]
    BadCovariance(String),
    /// Gyrocompassing cannot work (no horizontal Earth rate).
    #[error("alignment impossible: {0}")]
    AlignmentImpossible(String),
    /// An option is out of range.
    #[error("navigation option `{field}`: {reason}")]
    InvalidOption {
        /// Option name.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// The flight configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
}
