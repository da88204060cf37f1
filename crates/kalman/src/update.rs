//! Measurement update kernels: innovation covariance, a small Cholesky factorisation, the gain,
//! the Joseph-form covariance update and the state update with its innovation diagnostics.
//!
//! For `n` states and an `m`-dimensional measurement the covariance work is `O(n^2 m)`; the
//! `m x m` work (Cholesky, triangular solves) is done by plain loops, because faer's general
//! kernels carry a fixed overhead that dominates at the sizes used here (`m` of a few units).

use faer::dyn_stack::{MemStack, StackReq};
use faer::linalg::matmul::matmul;
use faer::linalg::{temp_mat_scratch, temp_mat_zeroed};
use faer::mat::AsMatMut;
use faer::prelude::*;
use faer::{Accum, ColMut, ColRef, MatMut, MatRef, Par, unzip, zip};

use crate::error::{KalmanError, check_finite_mat, check_shape};

/// Computes `B = P H^T` (`n x m`) and the innovation covariance `S = H B + R` (`m x m`,
/// symmetrised). Costs `n^2 m + n m^2`.
///
/// `h` and `r` are checked for shape and finiteness. `b` and `s` are outputs.
pub fn innovation_covariance(
    mut b: MatMut<'_, f64>,
    mut s: MatMut<'_, f64>,
    p: MatRef<'_, f64>,
    h: MatRef<'_, f64>,
    r: MatRef<'_, f64>,
    par: Par,
) -> Result<(), KalmanError> {
    let n = p.nrows();
    let m = h.nrows();
    check_shape("P", (p.nrows(), p.ncols()), (n, n))?;
    check_shape("H", (h.nrows(), h.ncols()), (m, n))?;
    check_shape("R", (r.nrows(), r.ncols()), (m, m))?;
    check_shape("B", (b.nrows(), b.ncols()), (n, m))?;
    check_shape("S", (s.nrows(), s.ncols()), (m, m))?;
    check_finite_mat("H", h)?;
    check_finite_mat("R", r)?;
    matmul(b.rb_mut(), Accum::Replace, p, h.transpose(), 1.0, par);
    s.copy_from(r);
    matmul(s.rb_mut(), Accum::Add, h, b.rb(), 1.0, par);
    crate::symmetrise(s);
    Ok(())
}

/// In-place Cholesky factorisation `A = L L^T` of a small symmetric positive definite matrix.
///
/// Reads the lower triangle of `a`; on success the lower triangle holds `L`, the strict upper
/// triangle is zeroed, and the return value is `ln det A`. A pivot that is not larger than
/// `m * eps` times its diagonal entry (so zero, negative, NaN, or lost to rounding) is reported as
/// [`KalmanError::NotPositiveDefinite`]; `a` is then partially overwritten.
///
/// Meant for the `m x m` innovation covariance (`m` small): plain loops, `m^3 / 6` operations.
pub fn cholesky_in_place(mut a: MatMut<'_, f64>) -> Result<f64, KalmanError> {
    let m = a.nrows();
    check_shape("S", (a.nrows(), a.ncols()), (m, m))?;
    let tol = m as f64 * f64::EPSILON;
    let mut log_det = 0.0;
    for j in 0..m {
        let diag = a[(j, j)];
        let mut d = diag;
        for l in 0..j {
            d -= a[(j, l)] * a[(j, l)];
        }
        // `!(d > ..)` also rejects NaN.
        if !(d > tol * diag.abs()) || !d.is_finite() {
            return Err(KalmanError::NotPositiveDefinite {
                m,
                pivot: j,
                value: d,
            });
        }
        let ljj = d.sqrt();
        a[(j, j)] = ljj;
        log_det += 2.0 * ljj.ln();
        let inv = 1.0 / ljj;
        for i in (j + 1)..m {
            let mut v = a[(i, j)];
            for l in 0..j {
                v -= a[(i, l)] * a[(j, l)];
            }
            a[(i, j)] = v * inv;
        }
    }
    for j in 1..m {
        for i in 0..j {
            a[(i, j)] = 0.0;
        }
    }
    Ok(log_det)
}

/// `y <- y - c x` on two columns.
#[inline]
fn axpy(y: ColMut<'_, f64>, c: f64, x: ColRef<'_, f64>) {
    zip!(y, x).for_each(|unzip!(y, x)| *y -= c * *x);
}

/// Computes the gain `K = B S^{-1}` (`n x m`) from `B` (`n x m`) and the lower Cholesky factor
/// `L` of `S` (`m x m`, as left by [`cholesky_in_place`]). Costs `n m^2`.
pub fn gain_from_cholesky(
    mut k: MatMut<'_, f64>,
    b: MatRef<'_, f64>,
    l: MatRef<'_, f64>,
) -> Result<(), KalmanError> {
    let n = b.nrows();
    let m = b.ncols();
    check_shape("L", (l.nrows(), l.ncols()), (m, m))?;
    check_shape("K", (k.nrows(), k.ncols()), (n, m))?;
    k.copy_from(b);
    // Y L^T = B, column by column (forward).
    for j in 0..m {
        for c in 0..j {
            let coef = l[(j, c)];
            let (yj, yc) = k.rb_mut().two_cols_mut(j, c);
            axpy(yj, coef, yc.rb());
        }
        let inv = 1.0 / l[(j, j)];
        zip!(k.rb_mut().col_mut(j)).for_each(|unzip!(v)| *v *= inv);
    }
    // K L = Y, column by column (backward).
    for j in (0..m).rev() {
        for c in (j + 1)..m {
            let coef = l[(c, j)];
            let (kj, kc) = k.rb_mut().two_cols_mut(j, c);
            axpy(kj, coef, kc.rb());
        }
        let inv = 1.0 / l[(j, j)];
        zip!(k.rb_mut().col_mut(j)).for_each(|unzip!(v)| *v *= inv);
    }
    Ok(())
}

/// Scratch needed by [`joseph_covariance`] for `n` states and an `m`-dimensional measurement.
pub fn joseph_covariance_scratch(n: usize, m: usize) -> StackReq {
    temp_mat_scratch::<f64>(n, 3 * m)
}

/// Joseph-form covariance update `P <- (I - K H) P (I - K H)^T + K R K^T` for any gain `K`.
///
/// Takes `B = P H^T` and `S = H P H^T + R` (from [`innovation_covariance`]) rather than `H` and
/// `R`: expanding the Joseph form gives `P - K B^T - B K^T + K S K^T`, which with
/// `C = B - K S / 2` is the symmetric rank-`2m` update
///
/// ```text
/// P <- P - [K C] [C K]^T
/// ```
///
/// one `n x n x 2m` product instead of the four `n x n x m` products of the literal form. It is
/// algebraically the Joseph form for *any* `K` (not only the optimal one), so it keeps the Joseph
/// form's first-order insensitivity to errors in the gain; for the optimal gain `K S = B` and it
/// reduces to the textbook `P - K B^T`. The result is symmetrised.
pub fn joseph_covariance(
    mut p: MatMut<'_, f64>,
    k: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    s: MatRef<'_, f64>,
    par: Par,
    stack: &mut MemStack,
) -> Result<(), KalmanError> {
    let n = p.nrows();
    let m = k.ncols();
    check_shape("P", (p.nrows(), p.ncols()), (n, n))?;
    check_shape("K", (k.nrows(), k.ncols()), (n, m))?;
    check_shape("B", (b.nrows(), b.ncols()), (n, m))?;
    check_shape("S", (s.nrows(), s.ncols()), (m, m))?;
    if m == 0 {
        return Ok(());
    }
    let (mut w, _) = temp_mat_zeroed::<f64, _, _>(n, 3 * m, stack);
    let mut w = w.as_mat_mut();
    // W = [K | C | K] with C = B - K S / 2.
    w.rb_mut().subcols_mut(0, m).copy_from(k);
    w.rb_mut().subcols_mut(2 * m, m).copy_from(k);
    {
        let mut c = w.rb_mut().subcols_mut(m, m);
        c.copy_from(b);
        matmul(c.rb_mut(), Accum::Add, k, s, -0.5, par);
    }
    let w = w.rb();
    matmul(
        p.rb_mut(),
        Accum::Add,
        w.subcols(0, 2 * m),
        w.subcols(m, 2 * m).transpose(),
        -1.0,
        par,
    );
    crate::symmetrise(p);
    Ok(())
}

/// Scratch needed by [`state_update`] for an `m`-dimensional measurement.
pub fn state_update_scratch(m: usize) -> StackReq {
    temp_mat_scratch::<f64>(m, 1)
}

/// State update with diagnostics: `nu = z - H x`, `x <- x + K nu`, and returns the normalised
/// innovation squared `NIS = nu^T S^{-1} nu` (computed as `|L^{-1} nu|^2`).
///
/// Call it with the *prior* state and the gain and Cholesky factor of this update (the
/// covariance kernels do not touch `x`). `innovation` (`m`) receives `nu`.
pub fn state_update(
    mut x: ColMut<'_, f64>,
    mut innovation: ColMut<'_, f64>,
    z: ColRef<'_, f64>,
    h: MatRef<'_, f64>,
    k: MatRef<'_, f64>,
    l: MatRef<'_, f64>,
    stack: &mut MemStack,
) -> Result<f64, KalmanError> {
    let n = x.nrows();
    let m = z.nrows();
    check_shape("H", (h.nrows(), h.ncols()), (m, n))?;
    check_shape("K", (k.nrows(), k.ncols()), (n, m))?;
    check_shape("L", (l.nrows(), l.ncols()), (m, m))?;
    check_shape("innovation", (innovation.nrows(), 1), (m, 1))?;
    if !z.is_all_finite() {
        return Err(KalmanError::NonFinite { what: "z" });
    }
    innovation.copy_from(z);
    for j in 0..n {
        let xj = x[j];
        zip!(innovation.rb_mut(), h.col(j)).for_each(|unzip!(v, hij)| *v -= *hij * xj);
    }
    let (mut w, _) = temp_mat_zeroed::<f64, _, _>(m, 1, stack);
    let mut w = w.as_mat_mut();
    let mut nis = 0.0;
    for i in 0..m {
        let mut v = innovation[i];
        for c in 0..i {
            v -= l[(i, c)] * w[(c, 0)];
        }
        v /= l[(i, i)];
        w[(i, 0)] = v;
        nis += v * v;
    }
    for c in 0..m {
        axpy(x.rb_mut(), -innovation[c], k.col(c));
    }
    Ok(nis)
}

/// Scratch needed by [`joseph_update`] for `n` states and an `m`-dimensional measurement.
pub fn joseph_update_scratch(n: usize, m: usize) -> StackReq {
    StackReq::all_of(&[
        temp_mat_scratch::<f64>(n, m),
        temp_mat_scratch::<f64>(m, m),
        joseph_covariance_scratch(n, m),
    ])
}

/// Complete covariance measurement update in one call: [`innovation_covariance`],
/// [`cholesky_in_place`], [`gain_from_cholesky`] and [`joseph_covariance`].
///
/// On success `p` holds the posterior covariance, `gain` (`n x m`) the gain `K` and `s_chol`
/// (`m x m`) the lower Cholesky factor of `S`, ready for [`state_update`]; returns `ln det S`.
/// On error `p` is unchanged. Costs about `2 n^2 m` multiply-adds with the symmetric
/// rank-`2m` update counted in full.
pub fn joseph_update(
    p: MatMut<'_, f64>,
    h: MatRef<'_, f64>,
    r: MatRef<'_, f64>,
    mut gain: MatMut<'_, f64>,
    mut s_chol: MatMut<'_, f64>,
    par: Par,
    stack: &mut MemStack,
) -> Result<f64, KalmanError> {
    let n = p.nrows();
    let m = h.nrows();
    let (mut b, stack) = temp_mat_zeroed::<f64, _, _>(n, m, stack);
    let mut b = b.as_mat_mut();
    let (mut s, stack) = temp_mat_zeroed::<f64, _, _>(m, m, stack);
    let mut s = s.as_mat_mut();
    innovation_covariance(b.rb_mut(), s.rb_mut(), p.rb(), h, r, par)?;
    check_shape("s_chol", (s_chol.nrows(), s_chol.ncols()), (m, m))?;
    s_chol.copy_from(s.rb());
    let log_det = cholesky_in_place(s_chol.rb_mut())?;
    gain_from_cholesky(gain.rb_mut(), b.rb(), s_chol.rb())?;
    joseph_covariance(p, gain.rb(), b.rb(), s.rb(), par, stack)?;
    Ok(log_det)
}
