//! [`KalmanFilter`]: state, covariance and all scratch in one value.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::prelude::*;
use faer::{ColMut, ColRef, Mat, MatMut, MatRef, Par};

use crate::error::{KalmanError, check_finite_mat, check_finite_slice, check_shape};
use crate::predict::{
    predict_dense, predict_dense_scratch, predict_state_dense, predict_state_dense_scratch,
    predict_state_structured, predict_structured, predict_structured_scratch,
};
use crate::update::{
    cholesky_in_place, cholesky_in_place_scratch, gain_from_cholesky, gain_from_cholesky_scratch,
    innovation_covariance, joseph_covariance, joseph_covariance_scratch, state_update,
    state_update_scratch,
};

/// Diagnostics of one measurement update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateInfo {
    /// Normalised innovation squared `nu^T S^{-1} nu`; for a consistent filter it is
    /// chi-square distributed with `dim` degrees of freedom.
    pub nis: f64,
    /// Natural logarithm of `det S` (with `nis`, the Gaussian log-likelihood of the measurement
    /// is `-(nis + log_det_s + dim ln 2 pi) / 2`).
    pub log_det_s: f64,
    /// The measurement dimension `m` of this update.
    pub dim: usize,
}

/// A linear Kalman filter (or, with the `*_covariance` methods, a covariance analyser) with
/// `n` states and measurements of up to `m_max` components.
///
/// All scratch memory is allocated by the constructor; `predict*` and `update*` allocate
/// nothing. Every step runs sequentially ([`Par::Seq`]). Every step checks its inputs first and
/// leaves the filter unchanged when it returns an error.
///
/// The covariance is kept symmetric after every step. Use the Joseph-form update
/// ([`update`](Self::update)) in normalised coordinates (see [`Scaling`](crate::Scaling)) when the
/// state components have very different magnitudes.
pub struct KalmanFilter {
    x: Vec<f64>,
    p: Mat<f64>,
    m_max: usize,
    b: Mat<f64>,
    gain: Mat<f64>,
    s: Mat<f64>,
    l: Mat<f64>,
    innovation: Vec<f64>,
    m_last: usize,
    work_req: StackReq,
    work: MemBuffer,
}

impl Clone for KalmanFilter {
    fn clone(&self) -> Self {
        Self {
            x: self.x.clone(),
            p: self.p.clone(),
            m_max: self.m_max,
            b: self.b.clone(),
            gain: self.gain.clone(),
            s: self.s.clone(),
            l: self.l.clone(),
            innovation: self.innovation.clone(),
            m_last: self.m_last,
            work_req: self.work_req,
            work: MemBuffer::new(self.work_req),
        }
    }
}

impl core::fmt::Debug for KalmanFilter {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("KalmanFilter")
            .field("n", &self.dim())
            .field("m_max", &self.m_max)
            .field("x", &self.x)
            .field("p", &self.p)
            .finish_non_exhaustive()
    }
}

impl KalmanFilter {
    /// Creates a filter with initial state `x0` (`n`) and covariance `p0` (`n x n`, symmetric;
    /// its symmetric part is used), for measurements of at most `m_max` components.
    ///
    /// Errors on a shape mismatch or a non-finite value.
    pub fn new(x0: &[f64], p0: MatRef<'_, f64>, m_max: usize) -> Result<Self, KalmanError> {
        let n = x0.len();
        check_shape("P0", (p0.nrows(), p0.ncols()), (n, n))?;
        check_finite_slice("x0", x0)?;
        check_finite_mat("P0", p0)?;
        let mut p = p0.to_owned();
        crate::symmetrise(p.as_mut());
        let work_req = StackReq::any_of(&[
            predict_dense_scratch(n),
            predict_state_dense_scratch(n),
            predict_structured_scratch(n, n),
            joseph_covariance_scratch(n, m_max),
            gain_from_cholesky_scratch(m_max),
            cholesky_in_place_scratch(m_max),
            state_update_scratch(m_max),
        ]);
        Ok(Self {
            x: x0.to_vec(),
            p,
            m_max,
            b: Mat::zeros(n, m_max),
            gain: Mat::zeros(n, m_max),
            s: Mat::zeros(m_max, m_max),
            l: Mat::zeros(m_max, m_max),
            innovation: vec![0.0; m_max],
            m_last: 0,
            work_req,
            work: MemBuffer::new(work_req),
        })
    }

    /// Creates a filter with initial state `x0` and a diagonal initial covariance
    /// `diag(sigma0^2)`. Each `sigma0[i]` must be finite and non-negative.
    pub fn from_diagonal(x0: &[f64], sigma0: &[f64], m_max: usize) -> Result<Self, KalmanError> {
        let n = x0.len();
        check_shape("sigma0", (sigma0.len(), 1), (n, 1))?;
        if let Some((index, &value)) = sigma0
            .iter()
            .enumerate()
            .find(|(_, s)| !(s.is_finite() && **s >= 0.0))
        {
            return Err(KalmanError::InvalidSigma {
                what: "sigma0",
                index,
                value,
            });
        }
        let p0 = Mat::from_fn(
            n,
            n,
            |i, j| if i == j { sigma0[i] * sigma0[i] } else { 0.0 },
        );
        Self::new(x0, p0.as_ref(), m_max)
    }

    /// The state dimension `n`.
    pub fn dim(&self) -> usize {
        self.x.len()
    }

    /// The largest measurement dimension this filter accepts (fixed at construction).
    pub fn max_measurement_dim(&self) -> usize {
        self.m_max
    }

    /// The state estimate `x` (`n`).
    pub fn state(&self) -> &[f64] {
        &self.x
    }

    /// Mutable access to the state estimate, e.g. to reset the attitude-error states to zero
    /// after feeding them back into the navigation solution.
    pub fn state_mut(&mut self) -> &mut [f64] {
        &mut self.x
    }

    /// The covariance `P` (`n x n`, symmetric).
    pub fn covariance(&self) -> MatRef<'_, f64> {
        self.p.as_ref()
    }

    /// Mutable access to the covariance. The caller must keep it symmetric and positive
    /// semi-definite (see [`symmetrise`](crate::symmetrise)).
    pub fn covariance_mut(&mut self) -> MatMut<'_, f64> {
        self.p.as_mut()
    }

    /// The standard deviation `sqrt(P[i, i])` of state `i`.
    ///
    /// # Panics
    /// If `i >= n`.
    pub fn std_dev(&self, i: usize) -> f64 {
        self.p[(i, i)].sqrt()
    }

    fn stack(work: &mut MemBuffer) -> &mut MemStack {
        MemStack::new(work)
    }

    /// Dense time update: `x <- Phi x`, `P <- Phi P Phi^T + Q` with `phi`, `q` of size `n x n`.
    /// Costs `2 n^3`; prefer [`predict_structured`](Self::predict_structured) when it applies.
    pub fn predict(&mut self, phi: MatRef<'_, f64>, q: MatRef<'_, f64>) -> Result<(), KalmanError> {
        predict_dense(
            self.p.as_mut(),
            phi,
            q,
            Par::Seq,
            Self::stack(&mut self.work),
        )?;
        predict_state_dense(
            ColMut::from_slice_mut(&mut self.x),
            phi,
            Par::Seq,
            Self::stack(&mut self.work),
        )
    }

    /// Dense time update of the covariance only (covariance analysis; `x` is left alone).
    pub fn predict_covariance(
        &mut self,
        phi: MatRef<'_, f64>,
        q: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        predict_dense(
            self.p.as_mut(),
            phi,
            q,
            Par::Seq,
            Self::stack(&mut self.work),
        )
    }

    /// Structured time update for a state whose first `k = phi_top.nrows()` components are
    /// dynamic and the rest constant: `Phi` is the identity except its first `k` rows
    /// (`phi_top`, `k x n`) and `Q` is zero except its top-left block (`q_top`, `k x k`).
    /// Costs `O(k n^2)`; see [`predict_structured`](crate::predict::predict_structured).
    pub fn predict_structured(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        predict_structured(
            self.p.as_mut(),
            phi_top,
            q_top,
            Par::Seq,
            Self::stack(&mut self.work),
        )?;
        predict_state_structured(
            ColMut::from_slice_mut(&mut self.x),
            phi_top,
            Par::Seq,
            Self::stack(&mut self.work),
        )
    }

    /// Structured time update of the covariance only (see
    /// [`predict_structured`](Self::predict_structured)).
    pub fn predict_structured_covariance(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        predict_structured(
            self.p.as_mut(),
            phi_top,
            q_top,
            Par::Seq,
            Self::stack(&mut self.work),
        )
    }

    /// Covariance part of the update; leaves gain, `S` and its Cholesky factor in scratch.
    fn update_cov_inner(
        &mut self,
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<f64, KalmanError> {
        let n = self.dim();
        let m = h.nrows();
        if m > self.m_max {
            return Err(KalmanError::MeasurementTooLarge {
                m,
                m_max: self.m_max,
            });
        }
        let mut b = self.b.as_mut().subcols_mut(0, m);
        let mut s = self.s.as_mut().submatrix_mut(0, 0, m, m);
        let mut l = self.l.as_mut().submatrix_mut(0, 0, m, m);
        let mut k = self.gain.as_mut().subcols_mut(0, m);
        check_shape("H", (h.nrows(), h.ncols()), (m, n))?;
        innovation_covariance(b.rb_mut(), s.rb_mut(), self.p.as_ref(), h, r, Par::Seq)?;
        // From here on the diagnostics describe this update, also if it fails.
        self.m_last = m;
        crate::small::copy(l.rb_mut(), s.rb());
        let log_det = match cholesky_in_place(l.rb_mut(), MemStack::new(&mut self.work)) {
            Ok(v) => v,
            Err(e) => {
                k.fill(f64::NAN);
                self.innovation[..m].fill(f64::NAN);
                return Err(e);
            }
        };
        gain_from_cholesky(
            k.rb_mut(),
            b.rb(),
            l.rb(),
            Par::Seq,
            MemStack::new(&mut self.work),
        )?;
        joseph_covariance(
            self.p.as_mut(),
            k.rb(),
            b.rb(),
            s.rb(),
            Par::Seq,
            MemStack::new(&mut self.work),
        )?;
        Ok(log_det)
    }

    /// Measurement update with `z = H x + v`, `v ~ N(0, R)`: Joseph-form covariance update
    /// (`O(n^2 m)`) and state update. `z` has `m <= m_max` components, `h` is `m x n`, `r` is
    /// `m x m` symmetric positive (semi-)definite.
    ///
    /// Returns the NIS and `ln det S`; the innovation, `S` and the gain stay available through
    /// [`innovation`](Self::innovation), [`innovation_covariance`](Self::innovation_covariance)
    /// and [`gain`](Self::gain) until the next update. Errors with
    /// [`KalmanError::NotPositiveDefinite`] when `S` cannot be factored; state and covariance are
    /// then unchanged, [`innovation_covariance`](Self::innovation_covariance) shows the offending
    /// `S`, and the innovation and gain are NaN.
    pub fn update(
        &mut self,
        z: &[f64],
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<UpdateInfo, KalmanError> {
        let m = z.len();
        check_shape("H", (h.nrows(), h.ncols()), (m, self.dim()))?;
        check_finite_slice("z", z)?;
        let log_det_s = self.update_cov_inner(h, r)?;
        let nis = state_update(
            ColMut::from_slice_mut(&mut self.x),
            ColMut::from_slice_mut(&mut self.innovation[..m]),
            ColRef::from_slice(z),
            h,
            self.gain.as_ref().subcols(0, m),
            self.l.as_ref().submatrix(0, 0, m, m),
            MemStack::new(&mut self.work),
        )?;
        Ok(UpdateInfo {
            nis,
            log_det_s,
            dim: m,
        })
    }

    /// Covariance-only measurement update (covariance analysis: no measurement value, `x` is
    /// left alone). Same covariance arithmetic as [`update`](Self::update).
    pub fn update_covariance(
        &mut self,
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        self.update_cov_inner(h, r)?;
        self.innovation[..self.m_last].fill(f64::NAN);
        Ok(())
    }

    /// The innovation `nu = z - H x_prior` of the last [`update`](Self::update) (empty before
    /// the first one; NaN after a covariance-only update).
    pub fn innovation(&self) -> &[f64] {
        &self.innovation[..self.m_last]
    }

    /// The innovation covariance `S = H P_prior H^T + R` of the last update (`m x m`).
    pub fn innovation_covariance(&self) -> MatRef<'_, f64> {
        self.s.as_ref().submatrix(0, 0, self.m_last, self.m_last)
    }

    /// The gain `K = P_prior H^T S^{-1}` of the last update (`n x m`).
    pub fn gain(&self) -> MatRef<'_, f64> {
        self.gain.as_ref().subcols(0, self.m_last)
    }
}
