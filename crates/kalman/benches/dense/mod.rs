//! The plain dense faer filter the benchmark compares the engine against (`interleaved.rs`,
//! `docs/performance.md`). It exploits no structure, does not normalise, checks nothing and
//! shares no code with [`kalman::KalmanFilter`]:
//!
//! - predict: `P <- Phi P Phi^T + Q` with the full `n x n` `Phi` and `Q`, two faer products,
//!   then symmetrised;
//! - update: `B = P H^T` and `S = H B + R` (faer products), the Cholesky factor of `S` from
//!   faer's `llt`, the gain `K = B S^{-1}` from faer's Cholesky solve, and the Joseph form
//!   `(I - K H) P (I - K H)^T + K R K^T` expanded as `P - K C^T - C K^T` with
//!   `C = B - K S / 2` (two more faer products), then symmetrised; the NIS from a faer
//!   triangular solve.
//!
//! Sequential ([`Par::Seq`]), scratch allocated by [`DenseFilter::new`]. The tests include this
//! file too (`tests/reference.rs`) and check it against the naive reference.
#![allow(dead_code)]

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::prelude::*;
use faer::{Accum, ColRef, Mat, MatMut, MatRef, Par};

/// The dense baseline filter (see the module documentation).
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
    work: MemBuffer,
}

impl DenseFilter {
    /// A filter with state `x0` (`n`), covariance `p0` (`n x n`) and measurements of up to
    /// `m_max` components.
    pub fn new(x0: &[f64], p0: MatRef<'_, f64>, m_max: usize) -> Self {
        let n = x0.len();
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
    pub fn predict(&mut self, phi: MatRef<'_, f64>, q: MatRef<'_, f64>) {
        let seq = Par::Seq;
        matmul(
            self.t.as_mut(),
            Accum::Replace,
            phi,
            self.p.as_ref(),
            1.0,
            seq,
        );
        self.p.copy_from(q);
        matmul(
            self.p.as_mut(),
            Accum::Add,
            &self.t,
            phi.transpose(),
            1.0,
            seq,
        );
        symmetrise(self.p.as_mut());
        matmul(self.xt.as_mut(), Accum::Replace, phi, &self.x, 1.0, seq);
        self.x.copy_from(&self.xt);
    }

    /// Measurement update with `z = H x + v`, `v ~ N(0, R)`; returns the NIS, or `None` (and
    /// a half-updated filter) when `S` is not positive definite.
    pub fn update(&mut self, z: &[f64], h: MatRef<'_, f64>, r: MatRef<'_, f64>) -> Option<f64> {
        let (m, seq) = (z.len(), Par::Seq);
        let mut b = self.b.as_mut().subcols_mut(0, m);
        let mut k = self.k.as_mut().subcols_mut(0, m);
        let mut c = self.c.as_mut().subcols_mut(0, m);
        let mut s = self.s.as_mut().submatrix_mut(0, 0, m, m);
        let mut l = self.l.as_mut().submatrix_mut(0, 0, m, m);
        let mut nu = self.nu.as_mut().subrows_mut(0, m);
        // B = P H^T, S = H B + R = L L^T
        matmul(b.rb_mut(), Accum::Replace, &self.p, h.transpose(), 1.0, seq);
        s.copy_from(r);
        matmul(s.rb_mut(), Accum::Add, h, b.rb(), 1.0, seq);
        symmetrise(s.rb_mut());
        l.copy_from(s.rb());
        let stack = MemStack::new(&mut self.work);
        llt::factor::cholesky_in_place(
            l.rb_mut(),
            Default::default(),
            seq,
            stack,
            Default::default(),
        )
        .ok()?;
        // K^T = S^{-1} B^T
        let mut kt = k.rb_mut().transpose_mut();
        kt.copy_from(b.rb().transpose());
        llt::solve::solve_in_place(l.rb(), kt, seq, MemStack::new(&mut self.work));
        // nu = z - H x, x += K nu, NIS = |L^{-1} nu|^2
        nu.copy_from(ColRef::from_slice(z).as_mat());
        matmul(nu.rb_mut(), Accum::Add, h, &self.x, -1.0, seq);
        matmul(self.x.as_mut(), Accum::Add, k.rb(), nu.rb(), 1.0, seq);
        solve_lower_triangular_in_place(l.rb(), nu.rb_mut(), seq);
        let nis = nu.col(0).squared_norm_l2();
        // Joseph form: C = B - K S / 2, P <- P - 2 K C^T, symmetrised.
        c.copy_from(b.rb());
        matmul(c.rb_mut(), Accum::Add, k.rb(), s.rb(), -0.5, seq);
        matmul(
            self.p.as_mut(),
            Accum::Add,
            k.rb(),
            c.rb().transpose(),
            -2.0,
            seq,
        );
        symmetrise(self.p.as_mut());
        Some(nis)
    }
}

/// `P <- (P + P^T) / 2`.
fn symmetrise(mut p: MatMut<'_, f64>) {
    for j in 0..p.ncols() {
        for i in (j + 1)..p.nrows() {
            let a = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = a;
            p[(j, i)] = a;
        }
    }
}
