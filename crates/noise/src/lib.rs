//! # noise
//!
//! The noise of inertial sensors from data at rest: the overlapping Allan deviation of each
//! axis with confidence intervals, a fit of the IEEE noise terms (quantisation, white
//! noise, bias instability, bias random walk, rate ramp) with their uncertainties and a check of
//! the fitted model against the data, and a maximum-likelihood fit of the white level and walk
//! with profile-likelihood intervals.
//!
//! - [`allan`]: the overlapping Allan variance over one or more static intervals (record index
//!   ranges), combined weighted by their number of terms, at octave averaging times;
//! - [`edf`]: its equivalent degrees of freedom (Howe, Allan and Barnes; NIST SP 1065) and
//!   chi-square confidence intervals;
//! - [`fit`]: weighted least squares of the terms on the Allan variance, non-negative, with the
//!   weights from the degrees of freedom, the covariance of the coefficients and the fit's
//!   chi-square;
//! - [`analyse_axis`]: both for one axis;
//! - [`thermal`]: how much of the slow variation the temperature explains (a recording with a
//!   `temp` column);
//! - [`likelihood`]: the white level, walk and (when the data show one) a Gauss-Markov bias by
//!   the exact Gaussian likelihood of the data (a Kalman filter on block means), with 68 %
//!   intervals from the profile likelihood: the levels whose intervals hold up on a seed set,
//!   where the Allan fit's walk sigmas do not;
//! - [`floor`]: the bias instability from a flat floor of the curve (its excess over the white
//!   noise), and whether the rests are long enough to tell a bias instability or a walk at all;
//! - [`consistency`]: the likelihood model against the measured Allan deviation at every
//!   averaging time (a family-wise level over the points and axes), and where it leaves the
//!   band, why (the long rests' walk against the others', or a curve the two terms cannot
//!   follow).
//!
//! Everything is SI: the increments are rad (gyro) or m/s (accelerometer), the rates rad/s or
//! m/s^2. The white-noise level [`fit::Term::White`] is the standard deviation of a 1-s average
//! of the rate, which is the convention of the run configuration's `[noise]` section.
//! The method and its checks: `docs/noise.md`.
//!
//! ```
//! use noise::{analyse_axis, fit::Term};
//! use rand::{SeedableRng, rngs::Xoshiro256PlusPlus};
//! use rand_distr::{Distribution, StandardNormal};
//!
//! // One hour at 100 Hz of a gyro with white noise of 1e-5 rad/s at 1 Hz (about 2 deg/h).
//! let (rate_hz, white): (f64, f64) = (100.0, 1e-5);
//! let dt = 1.0 / rate_hz;
//! let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
//! let increments: Vec<f64> = (0..360_000)
//!     .map(|_| {
//!         let z: f64 = StandardNormal.sample(&mut rng);
//!         white * dt.sqrt() * z
//!     })
//!     .collect();
//! let axis = analyse_axis(&increments, dt, &[0..increments.len()])?;
//! let n = axis.fit.term(Term::White);
//! assert!((n.value - white).abs() < 3.0 * n.sigma + 0.01 * white);
//! # Ok::<(), noise::NoiseError>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod allan;
pub mod consistency;
pub mod edf;
pub mod fit;
pub mod floor;
pub mod likelihood;
pub mod stream;
pub mod thermal;

use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Refusals of the analysis; the caller adds the file and axis.
#[derive(Debug, thiserror::Error)]
pub enum NoiseError {
    /// The record interval is not a positive number.
    #[error("record interval {0} s: expected a positive number of seconds")]
    BadInterval0(f64),
    /// No static interval given.
    #[error("no static interval: expected at least one range of records at rest")]
    NoIntervals,
    /// An interval is empty, outside the data, or overlaps the one before.
    #[error(
        "static interval {index} (records {start}..{end}) is empty, beyond the {records} records \
         or overlaps the one before: expected non-empty ranges in order inside the data"
    )]
    BadInterval {
        /// 0-based index of the interval.
        index: usize,
        /// Its first record.
        start: usize,
        /// One past its last record.
        end: usize,
        /// Records in the data.
        records: usize,
    },
    /// A value is not finite.
    #[error("record {record} is not a finite number")]
    NotFinite {
        /// 0-based index of the record.
        record: usize,
    },
    /// Every interval is shorter than two records.
    #[error(
        "the longest static interval has {longest} record(s): expected at least 2 (and many \
         more for a useful curve)"
    )]
    TooShort {
        /// Records in the longest interval.
        longest: usize,
    },
    /// Too few averaging times to fit anything.
    #[error("{0} averaging time(s): expected at least 2 to fit noise terms (a longer recording)")]
    TooFewPoints(usize),
    /// The data do not vary at some averaging time.
    #[error(
        "the Allan variance is zero at tau = {tau_s} s: the data are constant (a sensor that \
         reads nothing, or a column of zeros)"
    )]
    NoNoise {
        /// The averaging time (s).
        tau_s: f64,
    },
    /// No subset of terms fits with non-negative coefficients.
    #[error("no combination of noise terms fits the Allan variance with non-negative levels")]
    NoFit,
}

/// The Allan deviation curve of one axis and the noise terms fitted to it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisNoise {
    /// The curve, with the degrees of freedom of the fitted model's noise types.
    pub curve: allan::AllanCurve,
    /// The fitted terms.
    pub fit: fit::NoiseFit,
}

/// The overlapping Allan variance of one axis ([`allan::overlapping_allan`]: `increments` one
/// per record, nominal record interval `tau0_s`, static `intervals` of record indices) and the
/// fit of the noise terms to it ([`fit::fit_terms`]).
pub fn analyse_axis(
    increments: &[f64],
    tau0_s: f64,
    intervals: &[Range<usize>],
) -> Result<AxisNoise, NoiseError> {
    analyse_axis_from(increments, tau0_s, intervals, 0.0)
}

/// [`analyse_axis`] with the fit on the averaging times `tau >= tau_min_s` only
/// ([`fit::fit_terms_from`]): above a sensor's correlation time, where its own filter no longer
/// shows (the points below are still checked against their band and reported).
pub fn analyse_axis_from(
    increments: &[f64],
    tau0_s: f64,
    intervals: &[Range<usize>],
    tau_min_s: f64,
) -> Result<AxisNoise, NoiseError> {
    let mut curve = allan::overlapping_allan(increments, tau0_s, intervals)?;
    let fit = fit::fit_terms_from(&mut curve, tau_min_s)?;
    Ok(AxisNoise { curve, fit })
}
