//! A plain dense faer implementation of the textbook filter step, kept as the benchmark
//! baseline (`benches/`, `docs/performance.md`) and as a second, independent implementation
//! for the tests. It exploits no structure and shares no kernel with
//! [`KalmanFilter`](crate::KalmanFilter):
//!
//! - predict: `P <- Phi P Phi^T + Q` with two dense faer products, then symmetrised;
//! - update: `B = P H^T` and `S = H B + R` (faer products), the Cholesky factor of `S` from
//!   faer's `llt`, the gain `K = B S^{-1}` from faer's Cholesky solve, and the Joseph form
//!   `P <- P - K C^T - C K^T` with `C = B - K S / 2` (the Joseph form
//!   `(I - K H) P (I - K H)^T + K R K^T` expanded; two more faer products), then symmetrised;
//!   the NIS from a faer triangular solve.
//!
//! Everything runs sequentially ([`Par::Seq`]) on scratch allocated by [`DenseFilter::new`];
//! faer's products go through the crate's `vzeroupper`-safe wrapper like every product in this
//! crate. Inputs are not checked for finiteness.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::prelude::*;
use faer::{Accum, ColRef, Mat, MatMut, MatRef, Par};

use crate::error::{KalmanError, check_shape};
use crate::filter::UpdateInfo;
use crate::gemm::matmul;
use crate::symmetric::symmetrise;

/// The dense baseline filter (see the [module documentation](self)).
pub struct DenseFilter {
    x: Mat<f64>,
    p: Mat<f64>,
    t: Mat<f64>,
    xt: Mat<f64>,
    b: Mat<f64>,
    k: Mat<f64>,
    c: Mat<f64>,
    s: Mat<f64>,
    l: Mat<f64>,
    nu: Mat<f64>,
    m_max: usize,
    work: MemBuffer,
}

impl core::fmt::Debug for DenseFilter {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("DenseFilter")
            .field("x", &self.x)
            .field("p", &self.p)
            .finish_non_exhaustive()
    }
}

impl DenseFilter {
    /// A filter with state `x0` (`n`), covariance `p0` (`n x n`) and measurements of up to
    /// `m_max` components.
    ///
    /// # Panics
    /// If `p0` is not `n x n`.
    pub fn new(x0: &[f64], p0: MatRef<'_, f64>, m_max: usize) -> Self {
        let n = x0.len();
        assert_eq!((p0.nrows(), p0.ncols()), (n, n), "P0 must be n x n");
        let req = StackReq::any_of(&[
            llt::factor::cholesky_in_place_scratch::<f64>(m_max, Par::Seq, Default::default()),
            llt::solve::solve_in_place_scratch::<f64>(m_max, n, Par::Seq),
        ]);
        Self {
            x: Mat::from_fn(n, 1, |i, _| x0[i]),
            p: p0.to_owned(),
            t: Mat::zeros(n, n),
            xt: Mat::zeros(n, 1),
            b: Mat::zeros(n, m_max),
            k: Mat::zeros(n, m_max),
            c: Mat::zeros(n, m_max),
            s: Mat::zeros(m_max, m_max),
            l: Mat::zeros(m_max, m_max),
            nu: Mat::zeros(m_max, 1),
            m_max,
            work: MemBuffer::new(req),
        }
    }

    /// The state estimate.
    pub fn state(&self) -> &[f64] {
        self.x.col_as_slice(0)
    }

    /// The covariance.
    pub fn covariance(&self) -> MatRef<'_, f64> {
        self.p.as_ref()
    }

    /// Mutable access to the covariance (keep it symmetric).
    pub fn covariance_mut(&mut self) -> MatMut<'_, f64> {
        self.p.as_mut()
    }

    /// `x <- Phi x`, `P <- Phi P Phi^T + Q` (`phi`, `q`: `n x n`).
    pub fn predict(&mut self, phi: MatRef<'_, f64>, q: MatRef<'_, f64>) -> Result<(), KalmanError> {
        let n = self.p.nrows();
        check_shape("Phi", (phi.nrows(), phi.ncols()), (n, n))?;
        check_shape("Q", (q.nrows(), q.ncols()), (n, n))?;
        matmul(
            self.t.as_mut(),
            Accum::Replace,
            phi,
            self.p.as_ref(),
            1.0,
            Par::Seq,
        );
        self.p.copy_from(q);
        matmul(
            self.p.as_mut(),
            Accum::Add,
            self.t.as_ref(),
            phi.transpose(),
            1.0,
            Par::Seq,
        );
        symmetrise(self.p.as_mut());
        matmul(
            self.xt.as_mut(),
            Accum::Replace,
            phi,
            self.x.as_ref(),
            1.0,
            Par::Seq,
        );
        self.x.copy_from(&self.xt);
        Ok(())
    }

    /// Measurement update with `z = H x + v`, `v ~ N(0, R)` (see the
    /// [module documentation](self)).
    pub fn update(
        &mut self,
        z: &[f64],
        h: MatRef<'_, f64>,
        r: MatRef<'_, f64>,
    ) -> Result<UpdateInfo, KalmanError> {
        let n = self.p.nrows();
        let m = z.len();
        if m > self.m_max {
            return Err(KalmanError::MeasurementTooLarge {
                m,
                m_max: self.m_max,
            });
        }
        check_shape("H", (h.nrows(), h.ncols()), (m, n))?;
        check_shape("R", (r.nrows(), r.ncols()), (m, m))?;
        let mut b = self.b.as_mut().subcols_mut(0, m);
        let mut k = self.k.as_mut().subcols_mut(0, m);
        let mut c = self.c.as_mut().subcols_mut(0, m);
        let mut s = self.s.as_mut().submatrix_mut(0, 0, m, m);
        let mut l = self.l.as_mut().submatrix_mut(0, 0, m, m);
        let mut nu = self.nu.as_mut().subrows_mut(0, m);
        // B = P H^T, S = H B + R
        matmul(
            b.rb_mut(),
            Accum::Replace,
            self.p.as_ref(),
            h.transpose(),
            1.0,
            Par::Seq,
        );
        s.copy_from(r);
        matmul(s.rb_mut(), Accum::Add, h, b.rb(), 1.0, Par::Seq);
        symmetrise(s.rb_mut());
        // S = L L^T
        l.copy_from(s.rb());
        llt::factor::cholesky_in_place(
            l.rb_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut self.work),
            Default::default(),
        )
        .map_err(|llt::factor::LltError::NonPositivePivot { index }| {
            KalmanError::NotPositiveDefinite {
                m,
                pivot: index,
                value: f64::NAN,
            }
        })?;
        // K^T = S^{-1} B^T
        let mut kt = k.rb_mut().transpose_mut();
        kt.copy_from(b.rb().transpose());
        llt::solve::solve_in_place(l.rb(), kt, Par::Seq, MemStack::new(&mut self.work));
        // nu = z - H x, x += K nu, NIS = |L^{-1} nu|^2
        nu.copy_from(ColRef::from_slice(z).as_mat());
        matmul(nu.rb_mut(), Accum::Add, h, self.x.as_ref(), -1.0, Par::Seq);
        matmul(self.x.as_mut(), Accum::Add, k.rb(), nu.rb(), 1.0, Par::Seq);
        solve_lower_triangular_in_place(l.rb(), nu.rb_mut(), Par::Seq);
        let nis = nu.col(0).squared_norm_l2();
        let log_det_s = 2.0 * (0..m).map(|i| l[(i, i)]).product::<f64>().ln();
        // Joseph form: C = B - K S / 2, P <- P - 2 K C^T, symmetrised.
        c.copy_from(b.rb());
        matmul(c.rb_mut(), Accum::Add, k.rb(), s.rb(), -0.5, Par::Seq);
        matmul(
            self.p.as_mut(),
            Accum::Add,
            k.rb(),
            c.rb().transpose(),
            -2.0,
            Par::Seq,
        );
        symmetrise(self.p.as_mut());
        Ok(UpdateInfo {
            nis,
            log_det_s,
            dim: m,
        })
    }
}
