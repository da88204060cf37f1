//! The error type of the filter and the input checks every step runs first.

use faer::MatRef;

/// What can go wrong in a predict or update step.
///
/// Every step checks its inputs before it writes anything, so after an `Err` the filter's state
/// and covariance are exactly as they were before the call.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KalmanError {
    /// A matrix or vector argument has the wrong shape.
    #[error("dimension mismatch for {what}: expected {expected:?} (rows, cols), found {found:?}")]
    DimensionMismatch {
        /// Which argument, e.g. `"H"`.
        what: &'static str,
        /// The shape the call needs, as (rows, cols); vectors are (len, 1).
        expected: (usize, usize),
        /// The shape that was passed.
        found: (usize, usize),
    },
    /// A measurement has more components than the filter reserved scratch for.
    #[error("measurement dimension {m} exceeds the maximum {m_max} fixed at construction")]
    MeasurementTooLarge {
        /// The measurement dimension of the call.
        m: usize,
        /// The maximum measurement dimension given to the constructor.
        m_max: usize,
    },
    /// The innovation covariance `S = H P H^T + R` is not (numerically) positive definite,
    /// so no gain can be computed. The filter's state and covariance are left unchanged.
    #[error(
        "innovation covariance S of the {m}-dimensional measurement is not positive definite \
         (Cholesky pivot {pivot} is {value:e})"
    )]
    NotPositiveDefinite {
        /// The measurement dimension (S is m x m).
        m: usize,
        /// The index of the first Cholesky pivot that failed.
        pivot: usize,
        /// The value of that pivot before its square root (zero, negative, tiny or NaN).
        value: f64,
    },
    /// An input contains NaN or an infinity (after scaling to normalised units, so a finite
    /// input that overflows there is reported too).
    #[error("non-finite value (NaN or infinity) in {what}")]
    NonFinite {
        /// Which argument, e.g. `"z"`.
        what: &'static str,
    },
    /// A standard deviation or scale factor is not finite and positive (a prior variance on
    /// the diagonal of `P0` counts as its square).
    #[error("invalid standard deviation {value:e} at index {index} of {what}")]
    InvalidSigma {
        /// Which argument, e.g. `"sigma0"`.
        what: &'static str,
        /// The offending index.
        index: usize,
        /// The offending value.
        value: f64,
    },
}

pub(crate) fn check_shape(
    what: &'static str,
    found: (usize, usize),
    expected: (usize, usize),
) -> Result<(), KalmanError> {
    if found == expected {
        Ok(())
    } else {
        Err(KalmanError::DimensionMismatch {
            what,
            expected,
            found,
        })
    }
}

pub(crate) fn check_finite_mat(what: &'static str, m: MatRef<'_, f64>) -> Result<(), KalmanError> {
    let mut bad = false;
    for c in m.col_iter() {
        bad |= c.iter().fold(false, |b, v| b | !v.is_finite());
    }
    if bad {
        Err(KalmanError::NonFinite { what })
    } else {
        Ok(())
    }
}

pub(crate) fn check_finite_slice(what: &'static str, v: &[f64]) -> Result<(), KalmanError> {
    if v.iter().all(|a| a.is_finite()) {
        Ok(())
    } else {
        Err(KalmanError::NonFinite { what })
    }
}

/// The first entry of `sigma` that is not finite and positive, as an error.
pub(crate) fn check_sigma(what: &'static str, sigma: &[f64]) -> Result<(), KalmanError> {
    match sigma
        .iter()
        .enumerate()
        .find(|(_, s)| !(s.is_finite() && **s > 0.0))
    {
        Some((index, &value)) => Err(KalmanError::InvalidSigma { what, index, value }),
        None => Ok(()),
    }
}
