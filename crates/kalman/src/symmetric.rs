//! Symmetrisation of covariance matrices.

use faer::MatMut;

/// Replaces a square matrix by its symmetric part, `P <- (P + P^T) / 2`, in place.
///
/// Covariance propagation in floating point drifts away from exact symmetry by rounding; the
/// predict and update kernels call this on their results, and it is exposed for callers who edit
/// a covariance by hand.
///
/// # Panics
/// If `p` is not square.
pub fn symmetrise(p: MatMut<'_, f64>) {
    assert_eq!(p.nrows(), p.ncols(), "symmetrise needs a square matrix");
    symmetrise_strided(p);
}

fn symmetrise_strided(mut p: MatMut<'_, f64>) {
    let n = p.nrows();
    for j in 0..n {
        for i in (j + 1)..n {
            let a = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = a;
            p[(j, i)] = a;
        }
    }
}
