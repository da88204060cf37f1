//! Time update (predict) kernels on faer matrix views: dense and structured.
//!
//! All kernels work in place on matrix views, take the parallelism setting and a scratch stack
//! whose size the matching `*_scratch` function returns, and allocate nothing.
//! [`KalmanFilter::predict`](crate::KalmanFilter::predict) uses [`predict_dense`];
//! [`KalmanFilter::predict_structured`](crate::KalmanFilter::predict_structured) runs the algebra
//! of [`predict_structured`] on its own kernels and storage.

use faer::dyn_stack::{MemStack, StackReq};
use faer::linalg::{temp_mat_scratch, temp_mat_zeroed};
use faer::mat::AsMatMut;
use faer::prelude::*;
use faer::{Accum, ColMut, MatMut, MatRef, Par};

use crate::error::{KalmanError, check_finite_mat, check_shape};
use crate::gemm::matmul;
use crate::small::{copy, gemv};
use crate::symmetric::symmetrise;

/// Scratch needed by [`predict_dense`] for state dimension `n`.
pub fn predict_dense_scratch(n: usize) -> StackReq {
    temp_mat_scratch::<f64>(n, n)
}

/// Scratch needed by [`predict_state_dense`] for state dimension `n`.
pub fn predict_state_dense_scratch(n: usize) -> StackReq {
    temp_mat_scratch::<f64>(n, 1)
}

/// Scratch needed by [`predict_structured`] and [`predict_state_structured`] for `k` dynamic
/// states out of `n`.
pub fn predict_structured_scratch(k: usize, n: usize) -> StackReq {
    temp_mat_scratch::<f64>(n, k)
}

fn check_p(p: MatRef<'_, f64>) -> Result<usize, KalmanError> {
    let n = p.nrows();
    check_shape("P", (p.nrows(), p.ncols()), (n, n))?;
    Ok(n)
}

/// Dense covariance time update `P <- Phi P Phi^T + Q`, then symmetrised. Costs `2 n^3`.
///
/// `p`, `phi` and `q` are `n x n`. `phi` and `q` are checked for shape and finiteness before
/// `p` is touched.
pub fn predict_dense(
    mut p: MatMut<'_, f64>,
    phi: MatRef<'_, f64>,
    q: MatRef<'_, f64>,
    par: Par,
    stack: &mut MemStack,
) -> Result<(), KalmanError> {
    let n = check_p(p.rb())?;
    check_shape("Phi", (phi.nrows(), phi.ncols()), (n, n))?;
    check_shape("Q", (q.nrows(), q.ncols()), (n, n))?;
    check_finite_mat("Phi", phi)?;
    check_finite_mat("Q", q)?;
    let (mut t, _) = temp_mat_zeroed::<f64, _, _>(n, n, stack);
    let mut t = t.as_mat_mut();
    // T = Phi P, P = Q + T Phi^T
    matmul(t.rb_mut(), Accum::Replace, phi, p.rb(), 1.0, par);
    copy(p.rb_mut(), q);
    matmul(p.rb_mut(), Accum::Add, t.rb(), phi.transpose(), 1.0, par);
    symmetrise(p);
    Ok(())
}

/// Dense state time update `x <- Phi x`.
pub fn predict_state_dense(
    x: ColMut<'_, f64>,
    phi: MatRef<'_, f64>,
    par: Par,
    stack: &mut MemStack,
) -> Result<(), KalmanError> {
    let n = x.nrows();
    check_shape("Phi", (phi.nrows(), phi.ncols()), (n, n))?;
    check_finite_mat("Phi", phi)?;
    let _ = par;
    let (mut t, _) = temp_mat_zeroed::<f64, _, _>(n, 1, stack);
    let mut t = t.as_mat_mut();
    gemv(t.rb_mut().col_mut(0), 1.0, phi, x.rb());
    copy(x.as_mat_mut(), t.rb());
    Ok(())
}

/// Structured covariance time update for a state whose first `k` components are dynamic and
/// whose remaining `n - k` components are constant parameters.
///
/// The transition matrix is `Phi = [phi_top; 0 I]`: identity except its first `k` rows, which
/// are `phi_top` (`k x n`). The process noise is zero except its top-left `k x k` block `q_top`.
/// Then, with `T = phi_top P` (`k x n`, the only `O(k n^2)` product):
///
/// ```text
/// P'[0..k, 0..k] = T phi_top^T + q_top
/// P'[0..k, k..n] = T[:, k..n]          (rows k..n of Phi are identity rows)
/// P'[k..n, 0..k] = P'[0..k, k..n]^T
/// P'[k..n, k..n] = P[k..n, k..n]       (unchanged)
/// ```
///
/// which is exactly `Phi P Phi^T + Q` at a cost of `O(k n^2)` instead of `O(n^3)`. The kernel
/// forms `T^T = P phi_top^T` (`P` is symmetric), a tall `n x k` product: faer's product is
/// an order of magnitude slower for the wide `k x n` shape at `n = 60`.
pub fn predict_structured(
    mut p: MatMut<'_, f64>,
    phi_top: MatRef<'_, f64>,
    q_top: MatRef<'_, f64>,
    par: Par,
    stack: &mut MemStack,
) -> Result<(), KalmanError> {
    let n = check_p(p.rb())?;
    let k = phi_top.nrows();
    check_shape("phi_top", (k, phi_top.ncols()), (k.min(n), n))?;
    check_shape("q_top", (q_top.nrows(), q_top.ncols()), (k, k))?;
    check_finite_mat("phi_top", phi_top)?;
    check_finite_mat("q_top", q_top)?;
    if k == 0 {
        return Ok(());
    }
    // tt = T^T = P phi_top^T (n x k)
    let (mut tt, _) = temp_mat_zeroed::<f64, _, _>(n, k, stack);
    let mut tt = tt.as_mat_mut();
    matmul(
        tt.rb_mut(),
        Accum::Replace,
        p.rb(),
        phi_top.transpose(),
        1.0,
        par,
    );
    let tt = tt.rb();
    let tt_bottom = tt.subrows(k, n - k);
    copy(p.rb_mut().submatrix_mut(k, 0, n - k, k), tt_bottom);
    copy(
        p.rb_mut().submatrix_mut(0, k, k, n - k),
        tt_bottom.transpose(),
    );
    let mut p11 = p.rb_mut().submatrix_mut(0, 0, k, k);
    copy(p11.rb_mut(), q_top);
    matmul(p11.rb_mut(), Accum::Add, phi_top, tt, 1.0, par);
    symmetrise(p11);
    Ok(())
}

/// Structured state time update: `x[0..k] <- phi_top x`, `x[k..n]` unchanged
/// (see [`predict_structured`] for the structure).
pub fn predict_state_structured(
    x: ColMut<'_, f64>,
    phi_top: MatRef<'_, f64>,
    par: Par,
    stack: &mut MemStack,
) -> Result<(), KalmanError> {
    let n = x.nrows();
    let k = phi_top.nrows();
    check_shape("phi_top", (k, phi_top.ncols()), (k.min(n), n))?;
    check_finite_mat("phi_top", phi_top)?;
    if k == 0 {
        return Ok(());
    }
    let _ = par;
    let (mut t, _) = temp_mat_zeroed::<f64, _, _>(k, 1, stack);
    let mut t = t.as_mat_mut();
    gemv(t.rb_mut().col_mut(0), 1.0, phi_top, x.rb());
    copy(x.subrows_mut(0, k).as_mat_mut(), t.rb());
    Ok(())
}
