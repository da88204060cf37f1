//! Plain loops for the small and memory-bound parts of a step (copies, `m x m` algebra,
//! matrix-vector products), where the fixed per-call cost of faer's general kernels is larger
//! than the work. Columns with unit row stride are handled as slices so the loops vectorise;
//! other strides fall back to indexing.

use faer::prelude::*;
use faer::{ColMut, ColRef, MatMut, MatRef};

/// Column `j` of `m` as a slice, when its rows are contiguous.
#[inline]
pub(crate) fn col_slice<'a>(m: MatRef<'a, f64>, j: usize) -> Option<&'a [f64]> {
    m.col(j).try_as_col_major().map(|c| c.as_slice())
}

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
    for j in 0..src.ncols() {
        match (vec_slice_mut(dst.rb_mut().col_mut(j)), col_slice(src, j)) {
            (Some(d), Some(s)) => d.copy_from_slice(s),
            _ => {
                for i in 0..src.nrows() {
                    dst[(i, j)] = src[(i, j)];
                }
            }
        }
    }
}

/// `y <- y + a x`.
#[inline]
pub(crate) fn axpy(mut y: ColMut<'_, f64>, a: f64, x: ColRef<'_, f64>) {
    match (vec_slice_mut(y.rb_mut()), vec_slice(x)) {
        (Some(y), Some(x)) => y.iter_mut().zip(x).for_each(|(y, x)| *y += a * x),
        _ => {
            for i in 0..x.nrows() {
                y[i] += a * x[i];
            }
        }
    }
}

/// Whether every entry is finite. No early exit and an associative reduction (boolean or), so
/// the loop vectorises.
pub(crate) fn all_finite(m: MatRef<'_, f64>) -> bool {
    let mut bad = false;
    for j in 0..m.ncols() {
        match col_slice(m, j) {
            Some(c) => bad |= c.iter().fold(false, |b, v| b | !v.is_finite()),
            None => {
                for i in 0..m.nrows() {
                    bad |= !m[(i, j)].is_finite();
                }
            }
        }
    }
    !bad
}

/// Inverse of `S = L L^T` from its lower Cholesky factor `l` (`m x m`) into `sinv`: column
/// `j` solves `L L^T x = e_j` by forward and back substitution, in place. `m^3` operations.
pub(crate) fn spd_inverse_from_cholesky(mut sinv: MatMut<'_, f64>, l: MatRef<'_, f64>) {
    let m = l.nrows();
    for j in 0..m {
        // forward: L y = e_j (y_i = 0 for i < j)
        for i in 0..j {
            sinv[(i, j)] = 0.0;
        }
        for i in j..m {
            let mut v = if i == j { 1.0 } else { 0.0 };
            for c in j..i {
                v -= l[(i, c)] * sinv[(c, j)];
            }
            sinv[(i, j)] = v / l[(i, i)];
        }
        // backward: L^T x = y
        for i in (0..m).rev() {
            let mut v = sinv[(i, j)];
            for c in (i + 1)..m {
                v -= l[(c, i)] * sinv[(c, j)];
            }
            sinv[(i, j)] = v / l[(i, i)];
        }
    }
}
