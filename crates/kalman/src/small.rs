//! Plain loops for the small and memory-bound parts of a step (copies, `m x m` algebra,
//! matrix-vector products), where the fixed per-call cost of faer's general kernels is larger
//! than the work. Columns with unit row stride are handled as slices so the loops vectorise;
//! other strides fall back to indexing. The `m x m` algebra works on contiguous column-major
//! copies (`a[i + j * m]`) taken from the scratch stack.

use faer::prelude::*;
use faer::{ColMut, ColRef, MatMut, MatRef};

/// `v` as a slice, when contiguous.
#[inline]
pub(crate) fn vec_slice<'a>(v: ColRef<'a, f64>) -> Option<&'a [f64]> {
    v.try_as_col_major().map(|c| c.as_slice())
}

/// `v` as a mutable slice, when contiguous.
#[inline]
pub(crate) fn vec_slice_mut<'a>(v: ColMut<'a, f64>) -> Option<&'a mut [f64]> {
    v.try_as_col_major_mut().map(|c| c.as_slice_mut())
}

/// `dst <- src` (same shape, checked by the caller).
pub(crate) fn copy(mut dst: MatMut<'_, f64>, src: MatRef<'_, f64>) {
    debug_assert_eq!((dst.nrows(), dst.ncols()), (src.nrows(), src.ncols()));
    if dst.row_stride() == 1 && src.row_stride() == 1 {
        for (d, s) in dst.col_iter_mut().zip(src.col_iter()) {
            if let (Some(d), Some(s)) = (vec_slice_mut(d), vec_slice(s)) {
                d.copy_from_slice(s);
            }
        }
    } else {
        for j in 0..src.ncols() {
            for i in 0..src.nrows() {
                dst[(i, j)] = src[(i, j)];
            }
        }
    }
}

/// `dst <- src` for an `r x c` matrix into a contiguous column-major slice of length `r c`.
pub(crate) fn load(dst: &mut [f64], src: MatRef<'_, f64>) {
    let r = src.nrows();
    debug_assert_eq!(dst.len(), r * src.ncols());
    for (j, s) in src.col_iter().enumerate() {
        let d = &mut dst[j * r..(j + 1) * r];
        match vec_slice(s) {
            Some(s) => d.copy_from_slice(s),
            None => d.iter_mut().enumerate().for_each(|(i, v)| *v = s[i]),
        }
    }
}

/// `dst <- src` from a contiguous column-major slice.
pub(crate) fn store(mut dst: MatMut<'_, f64>, src: &[f64]) {
    let r = dst.nrows();
    debug_assert_eq!(src.len(), r * dst.ncols());
    for (j, d) in dst.rb_mut().col_iter_mut().enumerate() {
        let s = &src[j * r..(j + 1) * r];
        let mut d = d;
        match vec_slice_mut(d.rb_mut()) {
            Some(d) => d.copy_from_slice(s),
            None => s.iter().enumerate().for_each(|(i, v)| d[i] = *v),
        }
    }
}

/// `y <- y + alpha A x` (`A` is `r x c`, `x` has `c` entries, `y` has `r`).
///
/// Plain loops over the columns of `A` when everything is contiguous (the filter's own buffers
/// always are): for the shapes of a step (`6 x 28`, `28 x 6`, `3 x 28`) this is several times
/// faster than a general product call. Otherwise faer's product.
pub(crate) fn gemv(mut y: ColMut<'_, f64>, alpha: f64, a: MatRef<'_, f64>, x: ColRef<'_, f64>) {
    debug_assert_eq!((a.nrows(), a.ncols()), (y.nrows(), x.nrows()));
    if a.row_stride() == 1
        && let (Some(ys), Some(xs)) = (vec_slice_mut(y.rb_mut()), vec_slice(x))
    {
        for (aj, &xj) in a.col_iter().zip(xs) {
            let c = alpha * xj;
            if let Some(aj) = vec_slice(aj) {
                ys.iter_mut().zip(aj).for_each(|(yi, ai)| *yi += c * ai);
            }
        }
        return;
    }
    crate::gemm::matmul(
        y.as_mat_mut(),
        faer::Accum::Add,
        a,
        x.as_mat(),
        alpha,
        faer::Par::Seq,
    );
}

/// Whether every entry is finite. No early exit and an associative reduction (boolean or), so
/// the loop vectorises.
pub(crate) fn all_finite(m: MatRef<'_, f64>) -> bool {
    let mut bad = false;
    for c in m.col_iter() {
        match vec_slice(c) {
            Some(c) => bad |= c.iter().fold(false, |b, v| b | !v.is_finite()),
            None => {
                for i in 0..c.nrows() {
                    bad |= !c[i].is_finite();
                }
            }
        }
    }
    !bad
}

/// In-place lower Cholesky factor of the `m x m` column-major `a` (lower triangle read; strict
/// upper triangle zeroed). Returns `ln det a`, or the failing pivot and its value.
pub(crate) fn cholesky(a: &mut [f64], m: usize) -> Result<f64, (usize, f64)> {
    debug_assert_eq!(a.len(), m * m);
    let tol = m as f64 * f64::EPSILON;
    // ln det = ln prod d_j, accumulated as a product (one `ln` instead of `m`) and folded into
    // the sum whenever it leaves a safe range.
    let mut log_det = 0.0;
    let mut det_part = 1.0f64;
    for j in 0..m {
        let diag = a[j + j * m];
        for c in 0..j {
            let f = a[j + c * m];
            for i in j..m {
                a[i + j * m] -= f * a[i + c * m];
            }
        }
        let d = a[j + j * m];
        // Written so that a NaN pivot also fails.
        let acceptable = d > tol * diag.abs() && d.is_finite();
        if !acceptable {
            return Err((j, d));
        }
        let ljj = d.sqrt();
        let inv = 1.0 / ljj;
        a[j + j * m] = ljj;
        for i in (j + 1)..m {
            a[i + j * m] *= inv;
        }
        for i in 0..j {
            a[i + j * m] = 0.0;
        }
        det_part *= d;
        if !(1e-150..=1e150).contains(&det_part) {
            log_det += det_part.ln();
            det_part = 1.0;
        }
    }
    Ok(log_det + det_part.ln())
}

/// `S^{-1}` from the lower Cholesky factor `l` of `S` (all `m x m` column-major), via
/// `W = L^{-1}` (into `w`) and `S^{-1} = W^T W` (into `sinv`). `m` divisions, `m^3 / 2`
/// multiply-adds.
pub(crate) fn spd_inverse_from_cholesky(sinv: &mut [f64], w: &mut [f64], l: &[f64], m: usize) {
    for j in 0..m {
        w[j + j * m] = 1.0 / l[j + j * m];
    }
    for j in 0..m {
        for i in 0..j {
            w[i + j * m] = 0.0;
        }
        for i in (j + 1)..m {
            let mut v = 0.0;
            for c in j..i {
                v += l[i + c * m] * w[c + j * m];
            }
            w[i + j * m] = -v * w[i + i * m];
        }
    }
    for j in 0..m {
        for i in j..m {
            let mut v = 0.0;
            for c in i..m {
                v += w[c + i * m] * w[c + j * m];
            }
            sinv[i + j * m] = v;
            sinv[j + i * m] = v;
        }
    }
}

/// `|L^{-1} v|^2` for the lower triangular `l` (`m x m` column-major), using `w` (`m`) as
/// scratch.
pub(crate) fn whitened_norm2(l: &[f64], v: ColRef<'_, f64>, w: &mut [f64], m: usize) -> f64 {
    let mut sum = 0.0;
    for i in 0..m {
        let mut t = v[i];
        for c in 0..i {
            t -= l[i + c * m] * w[c];
        }
        t /= l[i + i * m];
        w[i] = t;
        sum += t * t;
    }
    sum
}
