//! The structured time update, on faer views of the normalised covariance and state.
//!
//! The transition is `Phi = [phi_top; 0 I]`: the identity except its first `k` rows, which are
//! `phi_top` (`k x n`); the process noise is zero except its top-left `k x k` block `q_top`.
//! With `T^T = P phi_top^T` (`n x k`, the only `O(k n^2)` product; `P` is symmetric):
//!
//! ```text
//! P'[0..k, 0..k] = phi_top T^T + q_top      (then symmetrised)
//! P'[k..n, 0..k] = T^T[k..n, :]             (rows k..n of Phi are identity rows)
//! P'[0..k, k..n] = P'[k..n, 0..k]^T
//! P'[k..n, k..n] = P[k..n, k..n]            (unchanged)
//! ```
//!
//! which is exactly `Phi P Phi^T + Q`. The product is formed tall (`P phi_top^T`) rather than
//! wide (`phi_top P`): faer's product is an order of magnitude slower for the wide shape at
//! `n = 60`.

use faer::dyn_stack::{MemStack, StackReq};
use faer::linalg::matmul::matmul;
use faer::linalg::{temp_mat_scratch, temp_mat_zeroed};
use faer::mat::AsMatMut;
use faer::prelude::*;
use faer::{Accum, MatMut, MatRef, Par};

use crate::error::{KalmanError, check_finite_mat, check_shape};
use crate::small;

/// Scratch of [`predict`] for `n` states (any `k <= n`).
pub(crate) fn predict_scratch(n: usize) -> StackReq {
    StackReq::all_of(&[
        temp_mat_scratch::<f64>(n, n), // normalised phi_top, transposed: n x k
        temp_mat_scratch::<f64>(n, n), // normalised q_top, k x k
        temp_mat_scratch::<f64>(n, n), // T^T = P phi_top^T, n x k
        temp_mat_scratch::<f64>(n, 1), // phi_top x
    ])
}

/// Structured time update of the normalised covariance `p` and, if given, the normalised state
/// `x`, from `phi_top` and `q_top` in the caller's units (normalised here with `scale`).
///
/// Shapes and finiteness are checked before `p` or `x` is written.
pub(crate) fn predict(
    mut p: MatMut<'_, f64>,
    x: Option<&mut [f64]>,
    scale: &[f64],
    phi_top: MatRef<'_, f64>,
    q_top: MatRef<'_, f64>,
    stack: &mut MemStack,
) -> Result<(), KalmanError> {
    let n = p.nrows();
    let k = phi_top.nrows();
    check_shape("phi_top", (k, phi_top.ncols()), (k.min(n), n))?;
    check_shape("q_top", (q_top.nrows(), q_top.ncols()), (k, k))?;
    // Phi_s = D^-1 Phi D on the top rows (held transposed, n x k: each row a contiguous
    // column for the loops of `small`), Q_s = D^-1 Q D^-1 on the top block.
    let (mut phi_t, stack) = temp_mat_zeroed::<f64, _, _>(n, k, stack);
    let mut phi_t = phi_t.as_mat_mut();
    for j in 0..n {
        for i in 0..k {
            phi_t[(j, i)] = phi_top[(i, j)] * scale[j] / scale[i];
        }
    }
    check_finite_mat("phi_top", phi_t.rb().transpose())?;
    let (mut q, stack) = temp_mat_zeroed::<f64, _, _>(k, k, stack);
    let mut q = q.as_mat_mut();
    for j in 0..k {
        for i in 0..k {
            q[(i, j)] = q_top[(i, j)] / (scale[i] * scale[j]);
        }
    }
    check_finite_mat("q_top", q.rb())?;
    if k == 0 {
        return Ok(());
    }
    let (phi_t, q) = (phi_t.rb(), q.rb());
    let (mut tt, stack) = temp_mat_zeroed::<f64, _, _>(n, k, stack);
    let mut tt = tt.as_mat_mut();
    if n <= small::SMALL_STATES {
        pulp::Arch::new().dispatch(small::PredictProducts {
            phi_t,
            q,
            tt: tt.rb_mut(),
            p: p.rb_mut(),
            x,
        });
        symmetrise(p.submatrix_mut(0, 0, k, k));
        return Ok(());
    }
    matmul(tt.rb_mut(), Accum::Replace, p.rb(), phi_t, 1.0, Par::Seq);
    let tt = tt.rb();
    p.rb_mut()
        .submatrix_mut(k, 0, n - k, k)
        .copy_from(tt.subrows(k, n - k));
    p.rb_mut()
        .submatrix_mut(0, k, k, n - k)
        .copy_from(tt.subrows(k, n - k).transpose());
    let mut p11 = p.rb_mut().submatrix_mut(0, 0, k, k);
    p11.copy_from(q);
    matmul(
        p11.rb_mut(),
        Accum::Add,
        phi_t.transpose(),
        tt,
        1.0,
        Par::Seq,
    );
    symmetrise(p11);
    if let Some(x) = x {
        let (mut top, _) = temp_mat_zeroed::<f64, _, _>(k, 1, stack);
        let mut top = top.as_mat_mut();
        let x_col = ColRef::from_slice(x).as_mat();
        matmul(
            top.rb_mut(),
            Accum::Replace,
            phi_t.transpose(),
            x_col,
            1.0,
            Par::Seq,
        );
        for (xi, t) in x.iter_mut().zip(top.col(0).iter()) {
            *xi = *t;
        }
    }
    Ok(())
}

/// `P <- (P + P^T) / 2` for a square block.
pub(crate) fn symmetrise(mut p: MatMut<'_, f64>) {
    for j in 0..p.ncols() {
        for i in (j + 1)..p.nrows() {
            let a = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = a;
            p[(j, i)] = a;
        }
    }
}
