//! [`KalmanFilter`]: state, covariance and all scratch in one value.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::{ColMut, MatMut, MatRef, Par};

use crate::error::{KalmanError, check_finite_mat, check_finite_slice, check_shape};
use crate::kernels::{self, AlignedVec, Isa, padded};
use crate::predict::{
    predict_dense, predict_dense_scratch, predict_state_dense, predict_state_dense_scratch,
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
/// nothing. Every step runs sequentially on the calling thread. Every step checks its inputs
/// first and leaves the filter unchanged when it returns an error.
///
/// The structured time update and the measurement update run on hand-written kernels for small
/// sizes (the filter's covariance and scratch live in 64-byte aligned column-major buffers with
/// the leading dimension rounded up to a multiple of 8; the instruction set, AVX-512, AVX2 or
/// portable, is picked at run time); the dense time update uses faer's matrix product. The
/// covariance is kept exactly symmetric after every step. Use normalised coordinates (see
/// [`Scaling`](crate::Scaling)) when the state components have very different magnitudes.
pub struct KalmanFilter {
    n: usize,
    /// Leading dimension of every `n`-row buffer: `n` rounded up to a multiple of 8.
    ld: usize,
    /// State, `ld` (padding zero).
    x: AlignedVec,
    /// Covariance, `ld x n` column-major (padding rows zero).
    p: AlignedVec,
    m_max: usize,
    /// `H` with its rows padded to a multiple of 8 (`padded(m_max) x n`).
    h: AlignedVec,
    /// `B = P H^T`, `W = B L^{-T}` and the gain: `ld x m_max` each.
    b: AlignedVec,
    w: AlignedVec,
    gain: AlignedVec,
    /// `phi_top` with its rows padded (`padded(k) x n`) and `P phi_top^T` (`ld x k`) of the
    /// structured predict (`ld x n` each, as `k <= n`).
    phi: AlignedVec,
    tt: AlignedVec,
    /// `S`, `m x m` contiguous for the current `m`.
    s: Vec<f64>,
    /// Scratch for the `m x m` algebra and the new dynamic states.
    small: AlignedVec,
    innovation: Vec<f64>,
    m_last: usize,
    isa: Isa,
    /// Scratch of the faer-based dense time update.
    work_req: StackReq,
    work: MemBuffer,
}

impl Clone for KalmanFilter {
    fn clone(&self) -> Self {
        Self {
            n: self.n,
            ld: self.ld,
            x: self.x.clone(),
            p: self.p.clone(),
            m_max: self.m_max,
            h: self.h.clone(),
            b: self.b.clone(),
            w: self.w.clone(),
            gain: self.gain.clone(),
            phi: self.phi.clone(),
            tt: self.tt.clone(),
            s: self.s.clone(),
            small: self.small.clone(),
            innovation: self.innovation.clone(),
            m_last: self.m_last,
            isa: self.isa,
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
            .field("x", &self.state())
            .field("p", &self.covariance())
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
        let ld = padded(n).max(kernels::LANES);
        let work_req =
            StackReq::any_of(&[predict_dense_scratch(n), predict_state_dense_scratch(n)]);
        let mut kf = Self {
            n,
            ld,
            x: AlignedVec::zeros(ld),
            p: AlignedVec::zeros(ld * n),
            m_max,
            h: AlignedVec::zeros(padded(m_max) * n),
            b: AlignedVec::zeros(ld * m_max),
            w: AlignedVec::zeros(ld * m_max),
            gain: AlignedVec::zeros(ld * m_max),
            phi: AlignedVec::zeros(ld * n),
            tt: AlignedVec::zeros(ld * n),
            s: vec![0.0; m_max * m_max],
            small: AlignedVec::zeros(kernels::update_scratch_len(m_max).max(ld)),
            innovation: vec![0.0; m_max],
            m_last: 0,
            isa: Isa::detect(),
            work_req,
            work: MemBuffer::new(work_req),
        };
        kf.x.as_mut_slice()[..n].copy_from_slice(x0);
        let mut p = kf.covariance_mut();
        for j in 0..n {
            for i in 0..n {
                p[(i, j)] = if i == j {
                    p0[(i, i)]
                } else {
                    0.5 * (p0[(i, j)] + p0[(j, i)])
                };
            }
        }
        Ok(kf)
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
        let p0 = faer::Mat::from_fn(
            n,
            n,
            |i, j| if i == j { sigma0[i] * sigma0[i] } else { 0.0 },
        );
        Self::new(x0, p0.as_ref(), m_max)
    }

    /// The state dimension `n`.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// The largest measurement dimension this filter accepts (fixed at construction).
    pub fn max_measurement_dim(&self) -> usize {
        self.m_max
    }

    /// The state estimate `x` (`n`).
    pub fn state(&self) -> &[f64] {
        &self.x.as_slice()[..self.n]
    }

    /// Mutable access to the state estimate, e.g. to reset the attitude-error states to zero
    /// after feeding them back into the navigation solution.
    pub fn state_mut(&mut self) -> &mut [f64] {
        &mut self.x.as_mut_slice()[..self.n]
    }

    /// The covariance `P` (`n x n`, symmetric).
    pub fn covariance(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice_with_stride(self.p.as_slice(), self.n, self.n, self.ld)
    }

    /// Mutable access to the covariance. The caller must keep it symmetric and positive
    /// semi-definite (see [`symmetrise`](crate::symmetrise)).
    pub fn covariance_mut(&mut self) -> MatMut<'_, f64> {
        MatMut::from_column_major_slice_with_stride_mut(
            self.p.as_mut_slice(),
            self.n,
            self.n,
            self.ld,
        )
    }

    /// The standard deviation `sqrt(P[i, i])` of state `i`.
    ///
    /// # Panics
    /// If `i >= n`.
    pub fn std_dev(&self, i: usize) -> f64 {
        self.covariance()[(i, i)].sqrt()
    }

    /// The kernel set the structured predict and the update run on: `"avx512"`, `"avx2"` or
    /// `"portable"` (for tests and benchmarks).
    #[doc(hidden)]
    pub fn kernel_set(&self) -> &'static str {
        match self.isa {
            Isa::Avx512 => "avx512",
            Isa::Avx2 => "avx2",
            Isa::Portable => "portable",
        }
    }

    /// Selects the kernel set by name (see [`kernel_set`](Self::kernel_set)); returns `false`
    /// and changes nothing when the name is unknown or the CPU lacks the instructions. For
    /// tests and benchmarks.
    #[doc(hidden)]
    pub fn select_kernel_set(&mut self, name: &str) -> bool {
        let isa = match name {
            "avx512" => Isa::Avx512,
            "avx2" => Isa::Avx2,
            "portable" => Isa::Portable,
            _ => return false,
        };
        if !isa.is_supported() {
            return false;
        }
        self.isa = isa;
        true
    }

    /// Dense time update: `x <- Phi x`, `P <- Phi P Phi^T + Q` with `phi`, `q` of size `n x n`.
    /// Costs `2 n^3` (faer's matrix product); prefer
    /// [`predict_structured`](Self::predict_structured) when it applies.
    pub fn predict(&mut self, phi: MatRef<'_, f64>, q: MatRef<'_, f64>) -> Result<(), KalmanError> {
        self.predict_covariance(phi, q)?;
        let n = self.n;
        predict_state_dense(
            ColMut::from_slice_mut(&mut self.x.as_mut_slice()[..n]),
            phi,
            Par::Seq,
            MemStack::new(&mut self.work),
        )
    }

    /// Dense time update of the covariance only (covariance analysis; `x` is left alone).
    pub fn predict_covariance(
        &mut self,
        phi: MatRef<'_, f64>,
        q: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        let (n, ld) = (self.n, self.ld);
        predict_dense(
            MatMut::from_column_major_slice_with_stride_mut(self.p.as_mut_slice(), n, n, ld),
            phi,
            q,
            Par::Seq,
            MemStack::new(&mut self.work),
        )
    }

    /// Structured time update for a state whose first `k = phi_top.nrows()` components are
    /// dynamic and the rest constant: `Phi` is the identity except its first `k` rows
    /// (`phi_top`, `k x n`) and `Q` is zero except its top-left block (`q_top`, `k x k`).
    /// Costs `O(k n^2)`; see [`predict_structured`](crate::predict::predict_structured) for the
    /// algebra.
    pub fn predict_structured(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        self.predict_structured_inner(phi_top, q_top, true)
    }

    /// Structured time update of the covariance only (see
    /// [`predict_structured`](Self::predict_structured)).
    pub fn predict_structured_covariance(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
    ) -> Result<(), KalmanError> {
        self.predict_structured_inner(phi_top, q_top, false)
    }

    fn predict_structured_inner(
        &mut self,
        phi_top: MatRef<'_, f64>,
        q_top: MatRef<'_, f64>,
        with_state: bool,
    ) -> Result<(), KalmanError> {
        let (n, ld) = (self.n, self.ld);
        let k = phi_top.nrows();
        check_shape("phi_top", (k, phi_top.ncols()), (k.min(n), n))?;
        check_shape("q_top", (q_top.nrows(), q_top.ncols()), (k, k))?;
        check_finite_mat("q_top", q_top)?;
        let x = if with_state {
            Some((self.x.as_mut_slice(), self.small.as_mut_slice()))
        } else {
            None
        };
        kernels::predict_structured(
            self.isa,
            kernels::Predict {
                n,
                ld,
                k,
                p: self.p.as_mut_slice(),
                phi_top,
                phi: self.phi.as_mut_slice(),
                tt: self.tt.as_mut_slice(),
                q: q_top,
                x,
            },
        )
        .map_err(|_| KalmanError::NonFinite { what: "phi_top" })
    }

    /// Covariance part of the update (and the state part when `z` is given). Returns
    /// `ln det S` and the NIS (0 without `z`).
    fn update_inner(
        &mut self,
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
        z: Option<&[f64]>,
    ) -> Result<(f64, f64), KalmanError> {
        let (n, ld) = (self.n, self.ld);
        let m = h.nrows();
        if m > self.m_max {
            return Err(KalmanError::MeasurementTooLarge {
                m,
                m_max: self.m_max,
            });
        }
        check_shape("H", (h.nrows(), h.ncols()), (m, n))?;
        check_shape("R", (r.nrows(), r.ncols()), (m, m))?;
        check_finite_mat("R", r)?;
        // From here on the diagnostics describe this update, also if `S` cannot be factored.
        let m_before = self.m_last;
        self.m_last = m;
        let state = z.map(|z| kernels::UpdateState {
            x: self.x.as_mut_slice(),
            z,
            innovation: &mut self.innovation[..m],
        });
        let result = kernels::update(
            self.isa,
            kernels::Update {
                n,
                ld,
                m,
                p: self.p.as_mut_slice(),
                h_in: h,
                h: self.h.as_mut_slice(),
                r,
                b: self.b.as_mut_slice(),
                w: self.w.as_mut_slice(),
                gain: self.gain.as_mut_slice(),
                s: &mut self.s,
                small: self.small.as_mut_slice(),
                x: state,
            },
        );
        result.map_err(|e| match e {
            kernels::StepError::NonFinite => {
                self.m_last = m_before;
                KalmanError::NonFinite { what: "H" }
            }
            kernels::StepError::NotPositiveDefinite(pivot, value) => {
                self.gain.as_mut_slice()[..ld * m].fill(f64::NAN);
                self.innovation[..m].fill(f64::NAN);
                KalmanError::NotPositiveDefinite { m, pivot, value }
            }
        })
    }

    /// Measurement update with `z = H x + v`, `v ~ N(0, R)` (`O(n^2 m)`): the Joseph-form
    /// covariance update for the optimal gain, computed as `P - B S^{-1} B^T` with
    /// `B = P H^T` (to which the Joseph form reduces for that gain; exactly symmetric), and the
    /// state update. `z` has `m <= m_max` components, `h` is `m x n`, `r` is `m x m` symmetric
    /// positive (semi-)definite (its symmetric part is used).
    ///
    /// Returns the NIS and `ln det S`; the innovation, `S` and the gain stay available through
    /// [`innovation`](Self::innovation), [`innovation_covariance`](Self::innovation_covariance)
    /// and [`gain`](Self::gain) until the next update. Errors with
    /// [`KalmanError::NotPositiveDefinite`] when `S` cannot be factored; state and covariance are
    /// then unchanged, [`innovation_covariance`](Self::innovation_covariance) shows the offending
    /// `S`, and the innovation and gain are NaN. For a gain other than the optimal one, see
    /// [`joseph_covariance`](crate::update::joseph_covariance).
    pub fn update(
        &mut self,
        z: &[f64],
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<UpdateInfo, KalmanError> {
        let m = z.len();
        check_shape("H", (h.nrows(), h.ncols()), (m, self.dim()))?;
        check_finite_slice("z", z)?;
        let (log_det_s, nis) = self.update_inner(h, r, Some(z))?;
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
        self.update_inner(h, r, None)?;
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
        let m = self.m_last;
        MatRef::from_column_major_slice(&self.s[..m * m], m, m)
    }

    /// The gain `K = P_prior H^T S^{-1}` of the last update (`n x m`).
    pub fn gain(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice_with_stride(
            self.gain.as_slice(),
            self.n,
            self.m_last,
            self.ld,
        )
    }
}
