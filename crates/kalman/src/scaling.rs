//! Normalisation of the state by its prior standard deviations.

use faer::MatMut;

use crate::error::{KalmanError, check_shape};

/// The diagonal change of variables `x = D x_s` with `D = diag(sigma)`, usually the prior
/// standard deviations, so that every normalised state starts with unit variance.
///
/// # Why
/// The states of a turntable calibration span many orders of magnitude: gyro biases of
/// `1e-9 rad/s`, scale factors of `1e-5`, a turntable-data delay of `0.05 s`. In physical units
/// the covariance holds variances from `1e-18` to `1e-3`, a condition number of about `1e15`:
/// anything that compares entries of different states additively — an eigen-decomposition, a
/// pivot or rank test relative to the largest entry, a regularisation `P + eps I`, a "relative"
/// tolerance on the whole matrix — sees the small parameters as rounding noise and loses them.
/// In normalised coordinates all variances start at 1, so those operations see a
/// well-conditioned matrix and the entries of `P` read directly as variance ratios and
/// correlations.
///
/// The filter algebra itself (products, the Joseph update, the per-pivot Cholesky of `S`) is
/// covariant under a diagonal change of variables, so with this crate's kernels a filter run in
/// physical units and one run in normalised units agree to rounding (the tests check both); the
/// normalisation is what keeps everything *around* the filter — diagnostics, covariance
/// analysis, reports — safe, and it costs nothing in the step loop when the model is built in
/// normalised units once.
///
/// # The transformation
/// With `D = diag(sigma)`:
///
/// | quantity | normalised | back |
/// | --- | --- | --- |
/// | state | `x_s = D^-1 x` | `x = D x_s` |
/// | covariance | `P_s = D^-1 P D^-1` | `P = D P_s D` |
/// | transition | `Phi_s = D^-1 Phi D` | `Phi = D Phi_s D^-1` |
/// | process noise | `Q_s = D^-1 Q D^-1` | `Q = D Q_s D` |
/// | measurement matrix | `H_s = H D` | `H = H_s D^-1` |
/// | measurement noise | `R` (unchanged) | `R` |
///
/// The innovation, `S`, the NIS and the likelihood are the same in both coordinates.
///
/// For the structured predict, the first `k` rows of the transition (`phi_top`, `k x n`) and the
/// top-left block of the noise (`q_top`, `k x k`) use the leading `k` sigmas for their rows:
/// [`normalise_transition`](Self::normalise_transition) and
/// [`normalise_covariance`](Self::normalise_covariance) accept such leading blocks.
///
/// All methods work in place and allocate nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct Scaling {
    sigma: Vec<f64>,
}

impl Scaling {
    /// Creates the scaling from `sigma` (`n`); every entry must be finite and positive.
    pub fn new(sigma: &[f64]) -> Result<Self, KalmanError> {
        if let Some((index, &value)) = sigma
            .iter()
            .enumerate()
            .find(|(_, s)| !(s.is_finite() && **s > 0.0))
        {
            return Err(KalmanError::InvalidSigma {
                what: "sigma",
                index,
                value,
            });
        }
        Ok(Self {
            sigma: sigma.to_vec(),
        })
    }

    /// The state dimension `n`.
    pub fn dim(&self) -> usize {
        self.sigma.len()
    }

    /// The scale factors `sigma` (`n`).
    pub fn sigma(&self) -> &[f64] {
        &self.sigma
    }

    fn check_vec(&self, what: &'static str, len: usize) -> Result<(), KalmanError> {
        check_shape(what, (len, 1), (self.dim(), 1))
    }

    /// `x <- D^-1 x` (physical to normalised), `x` of length `n`.
    pub fn normalise_state(&self, x: &mut [f64]) -> Result<(), KalmanError> {
        self.check_vec("x", x.len())?;
        x.iter_mut().zip(&self.sigma).for_each(|(v, s)| *v /= s);
        Ok(())
    }

    /// `x <- D x` (normalised to physical), `x` of length `n`.
    pub fn denormalise_state(&self, x: &mut [f64]) -> Result<(), KalmanError> {
        self.check_vec("x", x.len())?;
        x.iter_mut().zip(&self.sigma).for_each(|(v, s)| *v *= s);
        Ok(())
    }

    fn check_leading_square(
        &self,
        what: &'static str,
        m: &MatMut<'_, f64>,
    ) -> Result<usize, KalmanError> {
        let k = m.nrows();
        check_shape(what, (k, m.ncols()), (k.min(self.dim()), k))?;
        Ok(k)
    }

    /// `P <- D^-1 P D^-1` for a covariance `P` (`n x n`), or for the leading `k x k` block
    /// (`q_top` of the structured predict, `k <= n`).
    pub fn normalise_covariance(&self, mut p: MatMut<'_, f64>) -> Result<(), KalmanError> {
        let k = self.check_leading_square("P", &p)?;
        for j in 0..k {
            for i in 0..k {
                p[(i, j)] /= self.sigma[i] * self.sigma[j];
            }
        }
        Ok(())
    }

    /// `P <- D P D` (normalised to physical), for `n x n` or leading `k x k` blocks.
    pub fn denormalise_covariance(&self, mut p: MatMut<'_, f64>) -> Result<(), KalmanError> {
        let k = self.check_leading_square("P", &p)?;
        for j in 0..k {
            for i in 0..k {
                p[(i, j)] *= self.sigma[i] * self.sigma[j];
            }
        }
        Ok(())
    }

    fn check_top_rows(&self, what: &'static str, m: &MatMut<'_, f64>) -> Result<(), KalmanError> {
        let k = m.nrows();
        check_shape(what, (k, m.ncols()), (k.min(self.dim()), self.dim()))
    }

    /// `Phi <- D^-1 Phi D` for a transition matrix (`n x n`) or its first `k` rows
    /// (`phi_top`, `k x n`): row `i` is divided by `sigma[i]`, column `j` multiplied by
    /// `sigma[j]`.
    pub fn normalise_transition(&self, mut phi: MatMut<'_, f64>) -> Result<(), KalmanError> {
        self.check_top_rows("Phi", &phi)?;
        for j in 0..phi.ncols() {
            for i in 0..phi.nrows() {
                phi[(i, j)] *= self.sigma[j] / self.sigma[i];
            }
        }
        Ok(())
    }

    /// `Phi <- D Phi D^-1` (normalised to physical), for `n x n` or `k x n`.
    pub fn denormalise_transition(&self, mut phi: MatMut<'_, f64>) -> Result<(), KalmanError> {
        self.check_top_rows("Phi", &phi)?;
        for j in 0..phi.ncols() {
            for i in 0..phi.nrows() {
                phi[(i, j)] *= self.sigma[i] / self.sigma[j];
            }
        }
        Ok(())
    }

    /// `H <- H D` for a measurement matrix (`m x n`): column `j` multiplied by `sigma[j]`.
    pub fn normalise_measurement(&self, mut h: MatMut<'_, f64>) -> Result<(), KalmanError> {
        check_shape("H", (h.nrows(), h.ncols()), (h.nrows(), self.dim()))?;
        for j in 0..h.ncols() {
            for i in 0..h.nrows() {
                h[(i, j)] *= self.sigma[j];
            }
        }
        Ok(())
    }

    /// `H <- H D^-1` (normalised to physical), `m x n`.
    pub fn denormalise_measurement(&self, mut h: MatMut<'_, f64>) -> Result<(), KalmanError> {
        check_shape("H", (h.nrows(), h.ncols()), (h.nrows(), self.dim()))?;
        for j in 0..h.ncols() {
            for i in 0..h.nrows() {
                h[(i, j)] /= self.sigma[j];
            }
        }
        Ok(())
    }
}
