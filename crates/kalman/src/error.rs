//! The error type shared by the kernels and [`KalmanFilter`](crate::KalmanFilter).

/// What can go wrong in a predict or update step.
///
/// Every fallible function in this crate checks its inputs before it writes anything, so after an
/// `Err` the filter (or the matrices passed to a kernel) are exactly as they were before the call.
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
    /// so no gain can be computed. The filter is left unchanged.
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
    /// An input contains NaN or an infinity.
    #[error("non-finite value (NaN or infinity) in {what}")]
    NonFinite {
        /// Which argument, e.g. `"z"`.
        what: &'static str,
    },
    /// A standard deviation (prior sigma or scaling sigma) is negative, zero where it must not be,
    /// or not finite.
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

pub(crate) fn check_finite_mat(
    what: &'static str,
    m: faer::MatRef<'_, f64>,
) -> Result<(), KalmanError> {
    if crate::small::all_finite(m) {
        Ok(())
    } else {
        Err(KalmanError::NonFinite { what })
    }
}

pub(crate) fn check_finite_slice(what: &'static str, v: &[f64]) -> Result<(), KalmanError> {
    if v.iter().all(|a| a.is_finite()) {
        Ok(())
    } else {
        Err(KalmanError::NonFinite { what })
    }
}
