//! [`KalmanFilter`]: normalised state, covariance, the results of the last update and all
//! scratch in one value; its stages are [`predict`](KalmanFilter::predict) and
//! [`update`](KalmanFilter::update).

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::{Mat, MatRef, Par};

use crate::error::{KalmanError, check_finite_mat, check_finite_slice, check_shape, check_sigma};
use crate::predict::{predict, predict_scratch};
use crate::update::{Outputs, StatePart, update, update_scratch};

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
/// `n` states and measurements of up to `m_max` components; see the [crate documentation](crate)
/// for the algebra.
///
/// Inside, the filter works on the normalised state `x_i / sigma_i` with fixed scale factors
/// `sigma` ([`scale`](Self::scale)); everything it takes and returns is in the caller's units
/// unless the method name says `normalised`. The covariance is kept exactly symmetric. All
/// scratch is allocated by the constructor; `predict*` and `update*` allocate nothing and leave
/// the filter unchanged when they return an error.
pub struct KalmanFilter {
    /// Scale factors `sigma` (`n`).
    scale: Vec<f64>,
    /// Normalised state `x_i / sigma_i` (`n`).
    x: Vec<f64>,
    /// Normalised covariance `P_ij / (sigma_i sigma_j)` (`n x n`).
    p: Mat<f64>,
    m_max: usize,
    /// `W = B L^{-T}` (normalised, `n x m_max`), `S` and its Cholesky factor `L`
    /// (`m_max x m_max`) and the innovation (`m_max`) of the last update; the leading `m_last`
    /// columns (entries) are valid.
    w: Mat<f64>,
    s: Mat<f64>,
    l: Mat<f64>,
    innovation: Vec<f64>,
    m_last: usize,
    /// Whether `w` and `l` hold the last update's factors (false after a failed factorisation).
    gain_valid: bool,
    work_req: StackReq,
    work: MemBuffer,
}

impl Clone for KalmanFilter {
    fn clone(&self) -> Self {
        Self {
            scale: self.scale.clone(),
            x: self.x.clone(),
            p: self.p.clone(),
            m_max: self.m_max,
            w: self.w.clone(),
            s: self.s.clone(),
            l: self.l.clone(),
            innovation: self.innovation.clone(),
            m_last: self.m_last,
            gain_valid: self.gain_valid,
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
            .field("scale", &self.scale)
            .field("normalised_state", &self.x)
            .field("normalised_covariance", &self.p)
            .finish_non_exhaustive()
    }
}

impl KalmanFilter {
    /// A filter with initial state `x0` (`n`) and covariance `p0` (`n x n`, symmetric; its
    /// symmetric part is used), scaled by the prior standard deviations `sqrt(p0_ii)`, for
    /// measurements of at most `m_max` components.
    ///
    /// Errors on a shape mismatch, a non-finite value or a diagonal entry of `p0` that is not
    /// positive (use [`with_scale`](Self::with_scale) for states with zero prior variance).
    pub fn new(x0: &[f64], p0: MatRef<'_, f64>, m_max: usize) -> Result<Self, KalmanError> {
        let n = x0.len();
        check_shape("P0", (p0.nrows(), p0.ncols()), (n, n))?;
        check_finite_mat("P0", p0)?;
        let variances: Vec<f64> = (0..n).map(|i| p0[(i, i)]).collect();
        check_sigma("P0 diagonal", &variances)?;
        let scale = variances.iter().map(|v| v.sqrt()).collect();
        Self::with_scale(x0, p0, scale, m_max)
    }

    /// A filter with initial state `x0` and a diagonal initial covariance `diag(sigma0^2)`,
    /// scaled by `sigma0`. Each `sigma0[i]` must be finite and positive.
    pub fn from_diagonal(x0: &[f64], sigma0: &[f64], m_max: usize) -> Result<Self, KalmanError> {
        let n = x0.len();
        check_shape("sigma0", (sigma0.len(), 1), (n, 1))?;
        check_sigma("sigma0", sigma0)?;
        Self::from_normalised(x0, Mat::identity(n, n), sigma0.to_vec(), m_max)
    }

    /// A filter with initial state `x0`, covariance `p0` (its symmetric part) and the scale
    /// factors `scale` (`n`, finite and positive; the prior standard deviations are the usual
    /// choice).
    pub fn with_scale(
        x0: &[f64],
        p0: MatRef<'_, f64>,
        scale: Vec<f64>,
        m_max: usize,
    ) -> Result<Self, KalmanError> {
        let n = x0.len();
        check_shape("P0", (p0.nrows(), p0.ncols()), (n, n))?;
        check_shape("scale", (scale.len(), 1), (n, 1))?;
        check_sigma("scale", &scale)?;
        let p = Mat::from_fn(n, n, |i, j| {
            let pij = if i == j {
                p0[(i, i)]
            } else {
                0.5 * (p0[(i, j)] + p0[(j, i)])
            };
            pij / (scale[i] * scale[j])
        });
        Self::from_normalised(x0, p, scale, m_max)
    }

    /// The filter with state `x0` (caller's units), normalised covariance `p` and checked
    /// `scale`.
    fn from_normalised(
        x0: &[f64],
        p: Mat<f64>,
        scale: Vec<f64>,
        m_max: usize,
    ) -> Result<Self, KalmanError> {
        let n = x0.len();
        let x: Vec<f64> = x0.iter().zip(&scale).map(|(x, s)| x / s).collect();
        check_finite_slice("x0", &x)?;
        check_finite_mat("P0", p.as_ref())?;
        let work_req = StackReq::any_of(&[predict_scratch(n), update_scratch(n, m_max)]);
        Ok(Self {
            scale,
            x,
            p,
            m_max,
            w: Mat::zeros(n, m_max),
            s: Mat::zeros(m_max, m_max),
            l: Mat::zeros(m_max, m_max),
            innovation: vec![0.0; m_max],
            m_last: 0,
            gain_valid: true,
            work_req,
            work: MemBuffer::new(work_req),
        })
    }

    /// The state dimension `n`.
    pub fn dim(&self) -> usize {
        self.x.len()
    }

    /// The largest measurement dimension this filter accepts (fixed at construction).
    pub fn max_measurement_dim(&self) -> usize {
        self.m_max
    }

    /// The scale factors `sigma` (`n`) fixed at construction.
    pub fn scale(&self) -> &[f64] {
        &self.scale
    }

    /// The state estimate `x` (`n`; allocates).
    pub fn state(&self) -> Vec<f64> {
        self.x.iter().zip(&self.scale).map(|(x, s)| x * s).collect()
    }

    /// [`KalmanFilter::state`] written into `out` (length `n`), without allocating.
    ///
    /// # Panics
    /// If `out.len() != n`.
    pub fn state_into(&self, out: &mut [f64]) {
        assert_eq!(out.len(), self.x.len(), "state_into: wrong length");
        for ((o, x), s) in out.iter_mut().zip(&self.x).zip(&self.scale) {
            *o = x * s;
        }
    }

    /// Sets state component `i` to `value`, e.g. to zero an attitude error after feeding it
    /// back into the navigation solution.
    ///
    /// # Panics
    /// If `i >= n`.
    pub fn set_state(&mut self, i: usize, value: f64) {
        self.x[i] = value / self.scale[i];
    }

    /// Sets the whole state estimate to zero (after it has been fed back).
    pub fn reset_state(&mut self) {
        self.x.fill(0.0);
    }

    /// The covariance `P` (`n x n`, symmetric; allocates).
    pub fn covariance(&self) -> Mat<f64> {
        let s = &self.scale;
        Mat::from_fn(self.dim(), self.dim(), |i, j| {
            self.p[(i, j)] * (s[i] * s[j])
        })
    }

    /// The standard deviation `sqrt(P_ii)` of state `i`.
    ///
    /// # Panics
    /// If `i >= n`.
    pub fn std_dev(&self, i: usize) -> f64 {
        self.p[(i, i)].max(0.0).sqrt() * self.scale[i]
    }

    /// The normalised state `x_i / sigma_i` the filter works on.
    pub fn normalised_state(&self) -> &[f64] {
        &self.x
    }

    /// The normalised covariance `P_ij / (sigma_i sigma_j)` the filter works on (its diagonal
    /// is the posterior variance relative to the scale, 1 at a prior scaled by its sigma).
    pub fn normalised_covariance(&self) -> MatRef<'_, f64> {
        self.p.as_ref()
    }

    /// Time update `x <- Phi x`, `P <- Phi P Phi^T + Q` for a state whose first
    /// `k = phi_top.nrows()` components are dynamic and the rest constant: `Phi` is the
    /// identity except its first `k` rows (`phi_top`, `k x n`) and `Q` is zero except its
    /// top-left block (`q_top`, `k x k`). Costs `O(k n^2)`; `k = n` is the dense predict.
    pub fn predict(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        let stack = MemStack::new(&mut self.work);
        predict(
            self.p.as_mut(),
            Some(&mut self.x),
            &self.scale,
            phi_top,
            q_top,
            stack,
        )
    }

    /// Time update of the covariance only (covariance analysis; the state is left alone); see
    /// [`predict`](Self::predict).
    pub fn predict_covariance(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        let stack = MemStack::new(&mut self.work);
        predict(self.p.as_mut(), None, &self.scale, phi_top, q_top, stack)
    }

    /// Measurement update with `z = H x + v`, `v ~ N(0, R)` (`O(n^2 m)`): the covariance
    /// `P - P H^T S^{-1} H P` (the Joseph form for the optimal gain, exactly symmetric) and the
    /// state `x + K (z - H x)`. `z` has `m <= m_max` components, `h` is `m x n`, `r` is `m x m`
    /// symmetric positive (semi-)definite.
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
        let (log_det_s, nis) = self.update_inner(h, r, None, Some(z))?;
        Ok(UpdateInfo {
            nis,
            log_det_s,
            dim: m,
        })
    }

    /// [`update`](Self::update) with measurement noise correlated with the state's error:
    /// `cross = E[e v^T]` (`n x m`, where `e` is the prior error of the state), as when `v`
    /// holds process noise of the interval just predicted over. The gain becomes
    /// `(P H^T + M) S^-1` with `S = H P H^T + H M + M^T H^T + R`, and the covariance
    /// `P - K S K^T`; `cross = 0` is [`update`](Self::update).
    pub fn update_correlated(
        &mut self,
        z: &[f64],
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
        cross: MatRef<'_, f64>,
    ) -> Result<UpdateInfo, KalmanError> {
        let m = z.len();
        check_shape("H", (h.nrows(), h.ncols()), (m, self.dim()))?;
        check_shape("M", (cross.nrows(), cross.ncols()), (self.dim(), m))?;
        check_finite_slice("z", z)?;
        let (log_det_s, nis) = self.update_inner(h, r, Some(cross), Some(z))?;
        Ok(UpdateInfo {
            nis,
            log_det_s,
            dim: m,
        })
    }

    /// The covariance part of [`update_correlated`](Self::update_correlated); returns
    /// `ln det S` (summed over a run's updates: the log-determinant of the covariance of all
    /// its measurements, what a covariance analysis compares between two noise models).
    pub fn update_covariance_correlated(
        &mut self,
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
        cross: MatRef<'_, f64>,
    ) -> Result<f64, KalmanError> {
        check_shape("M", (cross.nrows(), cross.ncols()), (self.dim(), h.nrows()))?;
        self.update_inner(h, r, Some(cross), None)
            .map(|(log_det_s, _)| log_det_s)
    }

    /// Measurement update of the covariance only (covariance analysis: no measurement value,
    /// the state is left alone, the innovation is NaN). Same covariance arithmetic as
    /// [`update`](Self::update). Returns `ln det S`.
    pub fn update_covariance(
        &mut self,
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<f64, KalmanError> {
        self.update_inner(h, r, None, None)
            .map(|(log_det_s, _)| log_det_s)
    }

    fn update_inner(
        &mut self,
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
        cross: Option<MatRef<'_, f64>>,
        z: Option<&[f64]>,
    ) -> Result<(f64, f64), KalmanError> {
        let (n, m) = (self.dim(), h.nrows());
        if m > self.m_max {
            return Err(KalmanError::MeasurementTooLarge {
                m,
                m_max: self.m_max,
            });
        }
        check_shape("H", (h.nrows(), h.ncols()), (m, n))?;
        check_shape("R", (r.nrows(), r.ncols()), (m, m))?;
        let out = Outputs {
            p: self.p.as_mut(),
            w: self.w.as_mut().subcols_mut(0, m),
            s: self.s.as_mut().submatrix_mut(0, 0, m, m),
            l: self.l.as_mut().submatrix_mut(0, 0, m, m),
        };
        let state = z.map(|z| StatePart {
            x: &mut self.x,
            z,
            innovation: &mut self.innovation[..m],
        });
        let stack = MemStack::new(&mut self.work);
        let result = update(out, state, &self.scale, h, r, cross, stack);
        if !matches!(result, Err(KalmanError::NonFinite { .. })) {
            // From here on the diagnostics describe this update, also if `S` was not PD.
            self.m_last = m;
            self.gain_valid = result.is_ok();
            if z.is_none() || result.is_err() {
                self.innovation[..m].fill(f64::NAN);
            }
        }
        result
    }

    /// The innovation `nu = z - H x_prior` of the last [`update`](Self::update) (empty before
    /// the first one; NaN after a covariance-only or failed update).
    pub fn innovation(&self) -> &[f64] {
        &self.innovation[..self.m_last]
    }

    /// The innovation covariance `S = H P_prior H^T + R` of the last update (`m x m`).
    pub fn innovation_covariance(&self) -> MatRef<'_, f64> {
        self.s.as_ref().submatrix(0, 0, self.m_last, self.m_last)
    }

    /// The gain `K = P_prior H^T S^{-1}` of the last update (`n x m`, NaN after a failed one),
    /// computed on demand from the factors the update keeps (allocates).
    pub fn gain(&self) -> Mat<f64> {
        let (n, m) = (self.dim(), self.m_last);
        if !self.gain_valid {
            return Mat::from_fn(n, m, |_, _| f64::NAN);
        }
        // K_s = W L^-1, i.e. L^T K_s^T = W^T; then K = D K_s.
        let mut k = self.w.as_ref().subcols(0, m).to_owned();
        let l = self.l.as_ref().submatrix(0, 0, m, m);
        solve_upper_triangular_in_place(l.transpose(), k.as_mut().transpose_mut(), Par::Seq);
        for i in 0..n {
            for j in 0..m {
                k[(i, j)] *= self.scale[i];
            }
        }
        k
    }

    /// `out = K rhs` for the gain `K` of the last update ([`gain`](Self::gain)), without
    /// forming `K` or allocating: `rhs` (`m x c`, `m` the last update's dimension) is
    /// overwritten with `L^-1 rhs`, then `out` (`n x c`) gets `D W (L^-1 rhs)`. What a caller
    /// needs to carry a sensitivity of the state through an update (`S <- S + K (D - H S)`)
    /// once per measurement instant. NaN after a failed update.
    ///
    /// # Panics
    /// If `rhs` does not have `m` rows or `out` is not `n x rhs.ncols()`.
    pub fn gain_times(&self, mut rhs: faer::MatMut<'_, f64>, mut out: faer::MatMut<'_, f64>) {
        let (n, m, c) = (self.dim(), self.m_last, rhs.ncols());
        assert_eq!(rhs.nrows(), m, "gain_times: rhs must have m rows");
        assert_eq!(
            (out.nrows(), out.ncols()),
            (n, c),
            "gain_times: out must be n x c"
        );
        if !self.gain_valid {
            out.fill(f64::NAN);
            return;
        }
        let l = self.l.as_ref().submatrix(0, 0, m, m);
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(l, rhs.as_mut(), Par::Seq);
        let w = self.w.as_ref().subcols(0, m);
        for j in 0..c {
            for i in 0..n {
                let mut s = 0.0;
                for a in 0..m {
                    s += w[(i, a)] * rhs[(a, j)];
                }
                out[(i, j)] = s * self.scale[i];
            }
        }
    }
}
