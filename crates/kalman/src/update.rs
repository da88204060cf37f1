//! Measurement update kernels on faer matrix views: innovation covariance, a small Cholesky
//! factorisation, the gain, the Joseph-form covariance update for any gain and the state update
//! with its innovation diagnostics.
//!
//! For `n` states and an `m`-dimensional measurement the covariance work is `O(n^2 m)` and goes
//! through faer's matrix product; the `O(m^3)` and `O(n m)` parts (Cholesky, inverse of `S`,
//! matrix-vector products, copies) are plain loops, because faer's general kernels carry a fixed
//! per-call cost that is larger than that work at the sizes used here (`m` of a few units).
//!
//! [`KalmanFilter::update`](crate::KalmanFilter::update) does not use these functions: it runs
//! the same update (for the optimal gain) on its own kernels and storage, several times faster
//! at calibration sizes, and agrees with them to rounding (`tests/reference.rs`).

use faer::dyn_stack::{MemStack, StackReq};
use faer::linalg::{temp_mat_scratch, temp_mat_zeroed};
use faer::mat::AsMatMut;
use faer::prelude::*;
use faer::{Accum, ColMut, ColRef, MatMut, MatRef, Par};

use crate::error::{KalmanError, check_finite_mat, check_shape};
use crate::gemm::matmul;
use crate::small::{self, copy, gemv, load, store};

/// Computes `B = P H^T` (`n x m`) and the innovation covariance `S = H B + R` (`m x m`,
/// symmetrised). Costs `n^2 m + n m^2`.
///
/// `h` and `r` are checked for shape and finiteness before anything is written; `b` and `s` are
/// outputs.
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
    copy(s.rb_mut(), r);
    matmul(s.rb_mut(), Accum::Add, h, b.rb(), 1.0, par);
    crate::symmetrise(s);
    Ok(())
}

/// Scratch needed by [`cholesky_in_place`] for an `m x m` matrix.
pub fn cholesky_in_place_scratch(m: usize) -> StackReq {
    StackReq::new::<f64>(m * m)
}

/// In-place Cholesky factorisation `A = L L^T` of a small symmetric positive definite matrix.
///
/// Reads the lower triangle of `a`; on success the lower triangle holds `L`, the strict upper
/// triangle is zeroed, and the return value is `ln det A`. A pivot that is not larger than
/// `m * eps` times its diagonal entry (so zero, negative, NaN, or lost to rounding) is reported as
/// [`KalmanError::NotPositiveDefinite`], and `a` is then left unchanged.
///
/// Meant for the `m x m` innovation covariance (`m` small): plain loops on a contiguous copy,
/// `m^3 / 6` operations.
pub fn cholesky_in_place(a: MatMut<'_, f64>, stack: &mut MemStack) -> Result<f64, KalmanError> {
    let m = a.nrows();
    check_shape("S", (a.nrows(), a.ncols()), (m, m))?;
    let (mut buf, _) = stack.make_with::<f64>(m * m, |_| 0.0);
    load(&mut buf, a.rb());
    let log_det = small::cholesky(&mut buf, m)
        .map_err(|(pivot, value)| KalmanError::NotPositiveDefinite { m, pivot, value })?;
    store(a, &buf);
    Ok(log_det)
}

/// Scratch needed by [`gain_from_cholesky`] for an `m`-dimensional measurement.
pub fn gain_from_cholesky_scratch(m: usize) -> StackReq {
    StackReq::new::<f64>(3 * m * m)
}

/// Computes the gain `K = B S^{-1}` (`n x m`) from `B = P H^T` (`n x m`) and the lower Cholesky
/// factor `L` of `S` (`m x m`, as left by [`cholesky_in_place`]): `S^{-1} = L^{-T} L^{-1}`
/// (`m^3 / 2`), then one `n x m x m` product.
pub fn gain_from_cholesky(
    k: MatMut<'_, f64>,
    b: MatRef<'_, f64>,
    l: MatRef<'_, f64>,
    par: Par,
    stack: &mut MemStack,
) -> Result<(), KalmanError> {
    let n = b.nrows();
    let m = b.ncols();
    check_shape("L", (l.nrows(), l.ncols()), (m, m))?;
    check_shape("K", (k.nrows(), k.ncols()), (n, m))?;
    let (mut buf, _) = stack.make_with::<f64>(3 * m * m, |_| 0.0);
    let (lbuf, rest) = buf.split_at_mut(m * m);
    let (w, sinv) = rest.split_at_mut(m * m);
    load(lbuf, l);
    small::spd_inverse_from_cholesky(sinv, w, lbuf, m);
    matmul(
        k,
        Accum::Replace,
        b,
        MatRef::from_column_major_slice(sinv, m, m),
        1.0,
        par,
    );
    Ok(())
}

/// Scratch needed by [`joseph_covariance`] for `n` states and an `m`-dimensional measurement.
pub fn joseph_covariance_scratch(n: usize, m: usize) -> StackReq {
    temp_mat_scratch::<f64>(n, m)
}

/// Joseph-form covariance update `P <- (I - K H) P (I - K H)^T + K R K^T` for any gain `K`.
///
/// Takes `B = P H^T` and `S = H P H^T + R` (from [`innovation_covariance`]) rather than `H` and
/// `R`. Expanding the Joseph form gives `P - K B^T - B K^T + K S K^T`, that is, with
/// `C = B - K S / 2`,
///
/// ```text
/// P' = P - K C^T - C K^T = (A + A^T) / 2   where   A = P - 2 K C^T
/// ```
///
/// (for symmetric `P`). So the kernel forms `C` (`n m^2`), subtracts `2 K C^T` from `P` with one
/// `n x n x m` product, and symmetrises, which it would do anyway: the whole Joseph update costs
/// one product more than `B` (`2 n^2 m` multiply-adds in all), like the textbook `P - K B^T`,
/// and its result is exactly symmetric. It is algebraically the Joseph form for *any* `K` (not
/// only the optimal one), so it keeps the Joseph form's first-order insensitivity to errors in
/// the gain; for the optimal gain `K S = B` and it reduces to `P - K B^T`.
///
/// `p` must be symmetric on entry (its symmetric part is what is updated).
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
    let (mut c, _) = temp_mat_zeroed::<f64, _, _>(n, m, stack);
    let mut c = c.as_mat_mut();
    copy(c.rb_mut(), b);
    matmul(c.rb_mut(), Accum::Add, k, s, -0.5, par);
    matmul(p.rb_mut(), Accum::Add, k, c.rb().transpose(), -2.0, par);
    crate::symmetrise(p);
    Ok(())
}

/// Scratch needed by [`state_update`] for an `m`-dimensional measurement.
pub fn state_update_scratch(m: usize) -> StackReq {
    StackReq::new::<f64>(m * m + m)
}

/// State update with diagnostics: `nu = z - H x`, `x <- x + K nu`, and returns the normalised
/// innovation squared `NIS = nu^T S^{-1} nu` (computed as `|L^{-1} nu|^2`).
///
/// Call it with the *prior* state and the gain and Cholesky factor of this update (the
/// covariance kernels do not touch `x`). `innovation` (`m`) receives `nu`. `z` is checked for
/// shape and finiteness before anything is written.
pub fn state_update(
    x: ColMut<'_, f64>,
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
    check_finite_mat("z", z.as_mat())?;
    // nu = z - H x
    copy(innovation.rb_mut().as_mat_mut(), z.as_mat());
    gemv(innovation.rb_mut(), -1.0, h, x.rb());
    // NIS = |w|^2 with L w = nu.
    let (mut buf, _) = stack.make_with::<f64>(m * m + m, |_| 0.0);
    let (lbuf, w) = buf.split_at_mut(m * m);
    load(lbuf, l);
    let nis = small::whitened_norm2(lbuf, innovation.rb(), w, m);
    // x += K nu
    gemv(x, 1.0, k, innovation.rb());
    Ok(nis)
}

/// Scratch needed by [`joseph_update`] for `n` states and an `m`-dimensional measurement.
pub fn joseph_update_scratch(n: usize, m: usize) -> StackReq {
    StackReq::all_of(&[
        temp_mat_scratch::<f64>(n, m),
        temp_mat_scratch::<f64>(m, m),
        StackReq::any_of(&[
            cholesky_in_place_scratch(m),
            gain_from_cholesky_scratch(m),
            joseph_covariance_scratch(n, m),
        ]),
    ])
}

/// Complete covariance measurement update in one call: [`innovation_covariance`],
/// [`cholesky_in_place`], [`gain_from_cholesky`] and [`joseph_covariance`].
///
/// On success `p` holds the posterior covariance, `gain` (`n x m`) the gain `K` and `s_chol`
/// (`m x m`) the lower Cholesky factor of `S`, ready for [`state_update`]; returns `ln det S`.
/// On error `p` is unchanged. Costs about `2 n^2 m` multiply-adds.
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
    check_shape("gain", (gain.nrows(), gain.ncols()), (n, m))?;
    check_shape("s_chol", (s_chol.nrows(), s_chol.ncols()), (m, m))?;
    let (mut b, stack) = temp_mat_zeroed::<f64, _, _>(n, m, stack);
    let mut b = b.as_mat_mut();
    let (mut s, stack) = temp_mat_zeroed::<f64, _, _>(m, m, stack);
    let mut s = s.as_mat_mut();
    innovation_covariance(b.rb_mut(), s.rb_mut(), p.rb(), h, r, par)?;
    copy(s_chol.rb_mut(), s.rb());
    let log_det = cholesky_in_place(s_chol.rb_mut(), stack)?;
    gain_from_cholesky(gain.rb_mut(), b.rb(), s_chol.rb(), par, stack)?;
    joseph_covariance(p, gain.rb(), b.rb(), s.rb(), par, stack)?;
    Ok(log_det)
}
