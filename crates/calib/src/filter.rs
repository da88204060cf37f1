//! The Kalman engine in normalised coordinates.
//!
//! States are divided by their prior sigma before they reach [`kalman::KalmanFilter`]: the
//! parameters span 1e-9 rad/s to 0.05 s, and an unscaled covariance matrix would lose the small
//! ones to rounding. Everything outside this module is in SI units.

use faer::{Mat, MatRef};
use kalman::{KalmanError, KalmanFilter, UpdateInfo};
use nalgebra::DMatrix;

/// A Kalman filter whose public face is in SI units and whose inside is normalised.
#[derive(Debug, Clone)]
pub struct NormalisedFilter {
    kf: KalmanFilter,
    sigma: Vec<f64>,
    phi: Mat<f64>,
    q: Mat<f64>,
    h: Mat<f64>,
    r: Mat<f64>,
}

impl NormalisedFilter {
    /// Zero initial state, diagonal prior with standard deviations `sigma` (SI).
    pub fn new(sigma: &[f64]) -> Result<Self, KalmanError> {
        let n = sigma.len();
        Ok(Self {
            kf: KalmanFilter::from_diagonal(&vec![0.0; n], &vec![1.0; n], 3)?,
            sigma: sigma.to_vec(),
            phi: Mat::zeros(3, n),
            q: Mat::zeros(3, 3),
            h: Mat::zeros(3, n),
            r: Mat::zeros(3, 3),
        })
    }

    /// Zero initial state, prior covariance `p0` (SI), normalised by the square roots of its
    /// diagonal.
    pub fn with_covariance(p0: &DMatrix<f64>) -> Result<Self, KalmanError> {
        let n = p0.nrows();
        let sigma: Vec<f64> = (0..n).map(|i| p0[(i, i)].max(0.0).sqrt()).collect();
        let pn = Mat::from_fn(n, n, |i, j| p0[(i, j)] / (sigma[i] * sigma[j]));
        Ok(Self {
            kf: KalmanFilter::new(&vec![0.0; n], pn.as_ref(), 3)?,
            sigma,
            phi: Mat::zeros(3, n),
            q: Mat::zeros(3, 3),
            h: Mat::zeros(3, n),
            r: Mat::zeros(3, 3),
        })
    }

    /// Number of states.
    pub fn dim(&self) -> usize {
        self.sigma.len()
    }

    /// Propagate with the transition `phi_top` (3 x n) and attitude process noise `q_top` (SI).
    pub fn predict_structured(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        self.load_transition(phi_top, q_top);
        self.kf
            .predict_structured(self.phi.as_ref(), self.q.as_ref())
    }

    /// [`Self::predict_structured`] of the covariance only.
    pub fn predict_structured_covariance(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        self.load_transition(phi_top, q_top);
        self.kf
            .predict_structured_covariance(self.phi.as_ref(), self.q.as_ref())
    }

    fn load_transition(&mut self, phi: MatRef<'_, f64>, q: MatRef<'_, f64>) {
        let s = &self.sigma;
        for j in 0..self.dim() {
            for i in 0..3 {
                self.phi[(i, j)] = phi[(i, j)] * s[j] / s[i];
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                self.q[(i, j)] = q[(i, j)] / (s[i] * s[j]);
            }
        }
    }

    fn load(&mut self, h: MatRef<'_, f64>, r: MatRef<'_, f64>) {
        for j in 0..self.dim() {
            for i in 0..3 {
                self.h[(i, j)] = h[(i, j)] * self.sigma[j];
            }
        }
        for i in 0..3 {
            for j in 0..3 {
                self.r[(i, j)] = r[(i, j)];
            }
        }
    }

    /// Covariance-only update with a 3-component measurement (SI `h`, `r`).
    pub fn update_covariance(
        &mut self,
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        self.load(h, r);
        self.kf.update_covariance(self.h.as_ref(), self.r.as_ref())
    }

    /// Full update with measurement `z` (SI).
    pub fn update(
        &mut self,
        z: &[f64],
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<UpdateInfo, KalmanError> {
        self.load(h, r);
        self.kf.update(z, self.h.as_ref(), self.r.as_ref())
    }

    /// State estimate (SI).
    pub fn state(&self) -> Vec<f64> {
        self.kf
            .state()
            .iter()
            .zip(&self.sigma)
            .map(|(x, s)| x * s)
            .collect()
    }

    /// Set state component `i` (SI), e.g. to zero the attitude error after feedback.
    pub fn set_state(&mut self, i: usize, value: f64) {
        self.kf.state_mut()[i] = value / self.sigma[i];
    }

    /// Zero the whole state (after its estimate has been fed back).
    pub fn reset_state(&mut self) {
        self.kf.state_mut().fill(0.0);
    }

    /// Standard deviation of state `i` (SI).
    pub fn sigma(&self, i: usize) -> f64 {
        self.kf.covariance()[(i, i)].max(0.0).sqrt() * self.sigma[i]
    }

    /// Covariance (SI).
    pub fn covariance(&self) -> DMatrix<f64> {
        let p = self.kf.covariance();
        DMatrix::from_fn(self.dim(), self.dim(), |i, j| {
            p[(i, j)] * self.sigma[i] * self.sigma[j]
        })
    }
}
