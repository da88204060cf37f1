//! The products of the predict and the update as loops over contiguous columns, for the small
//! problems the filter is built for.
//!
//! faer's product has a fixed cost per call (dispatch, blocking, a thread-local workspace) of
//! thousands of instructions; at 28 states and 3-component measurements that was most of an
//! update (22 000 instructions, `docs/performance.md`). Up to [`SMALL_STATES`] states these
//! kernels do the same products: column `axpy`s and dot products, with the model matrices
//! handed in transposed (`n x k`, so that each of their rows is a contiguous column) and their
//! zero entries skipped. Above [`SMALL_STATES`] faer's products are used, whose blocking wins
//! for large `n`.
//!
//! Each group of products runs under pulp's run-time dispatch: the `*Products` types implement
//! [`pulp::WithSimd`], whose `with_simd` pulp compiles inside functions with the target
//! features of each instruction set it supports (AVX2 on x86-64) and calls with the one the
//! processor has. (A closure does not do: pulp inlines the call, not the closure's body.)
//!
//! Like faer's kernels these are free functions on views. Every matrix they take is the
//! filter's own or scratch from its buffer: column-major, with contiguous columns.

use faer::prelude::*;
use faer::{MatMut, MatRef};
use pulp::{Simd, WithSimd};

/// Largest state dimension for which these loops are used.
pub(crate) const SMALL_STATES: usize = 32;

/// Column `j` of a column-major matrix as a slice.
#[inline(always)]
fn col<'a>(a: MatRef<'a, f64>, j: usize) -> &'a [f64] {
    a.col(j)
        .try_as_col_major()
        .expect("the filter's matrices are column-major")
        .as_slice()
}

/// Column `j` of a column-major matrix as a mutable slice.
#[inline(always)]
fn col_mut<'a>(a: MatMut<'a, f64>, j: usize) -> &'a mut [f64] {
    a.col_mut(j)
        .try_as_col_major_mut()
        .expect("the filter's matrices are column-major")
        .as_slice_mut()
}

/// `y += a x`.
#[inline(always)]
fn axpy(y: &mut [f64], a: f64, x: &[f64]) {
    for (y, x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

/// `a . b`, in four interleaved partial sums (so that it vectorises).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut s = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            s[l] += x[l] * y[l];
        }
    }
    (s[0] + s[1]) + (s[2] + s[3]) + tail
}

/// `out = P A` for a symmetric `P` (`n x n`) and `A` (`n x k`): column `i` of `out` is the sum of
/// `P`'s columns weighted by column `i` of `A` (zero weights skipped).
#[inline(always)]
fn sym_times(mut out: MatMut<'_, f64>, p: MatRef<'_, f64>, a: MatRef<'_, f64>) {
    for i in 0..a.ncols() {
        let o = col_mut(out.rb_mut(), i);
        o.fill(0.0);
        for (j, &w) in col(a, i).iter().enumerate() {
            if w != 0.0 {
                axpy(o, w, col(p, j));
            }
        }
    }
}

/// `out += A^T B` for `A` (`n x k`) and `B` (`n x m`): a dot product of columns per entry.
#[inline(always)]
fn add_transpose_times(mut out: MatMut<'_, f64>, a: MatRef<'_, f64>, b: MatRef<'_, f64>) {
    for c in 0..b.ncols() {
        for r in 0..a.ncols() {
            out[(r, c)] += dot(col(a, r), col(b, c));
        }
    }
}

/// `B = P H^T` (into `w`) and `S += H B`, with `H^T` given (`h_t`, `n x m`).
pub(crate) struct InnovationProducts<'a> {
    pub p: MatRef<'a, f64>,
    pub h_t: MatRef<'a, f64>,
    pub w: MatMut<'a, f64>,
    pub s: MatMut<'a, f64>,
}

impl WithSimd for InnovationProducts<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        let Self { p, h_t, mut w, s } = self;
        sym_times(w.rb_mut(), p, h_t);
        add_transpose_times(s, h_t, w.rb());
    }
}

/// `W <- W L^-T` for the Cholesky factor `L` (`m x m`) of `S`, then `P <- P - W W^T` on the
/// whole of `P`: entries `(r, j)` and `(j, r)` subtract the same products in the same order, so
/// an exactly symmetric `P` stays so without a mirror pass.
pub(crate) struct GainProducts<'a> {
    pub l: MatRef<'a, f64>,
    pub w: MatMut<'a, f64>,
    pub p: MatMut<'a, f64>,
}

impl WithSimd for GainProducts<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        let Self { l, mut w, mut p } = self;
        // Columns left to right: w_i <- (w_i - sum_{c < i} L_ic w_c) / L_ii.
        for i in 0..w.ncols() {
            let (done, mut rest) = w.rb_mut().split_at_col_mut(i);
            let wi = col_mut(rest.rb_mut(), 0);
            for c in 0..i {
                axpy(wi, -l[(i, c)], col(done.rb(), c));
            }
            let inv = 1.0 / l[(i, i)];
            for x in wi.iter_mut() {
                *x *= inv;
            }
        }
        let w = w.rb();
        for j in 0..p.ncols() {
            let pj = col_mut(p.rb_mut(), j);
            for i in 0..w.ncols() {
                let wi = col(w, i);
                let f = wi[j];
                if f != 0.0 {
                    axpy(pj, -f, wi);
                }
            }
        }
    }
}

/// The state part of an update: `nu = z - H x` (into `innovation`), and, once `e = L^-1 nu` is
/// known, `x <- x + W e` ([`StateCorrection`]).
pub(crate) struct Innovation<'a> {
    pub h_t: MatRef<'a, f64>,
    pub x: &'a [f64],
    pub z: &'a [f64],
    pub innovation: &'a mut [f64],
}

impl WithSimd for Innovation<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        for (i, nu) in self.innovation.iter_mut().enumerate() {
            *nu = self.z[i] - dot(col(self.h_t, i), self.x);
        }
    }
}

/// `x <- x + W e`.
pub(crate) struct StateCorrection<'a> {
    pub w: MatRef<'a, f64>,
    pub e: &'a [f64],
    pub x: &'a mut [f64],
}

impl WithSimd for StateCorrection<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        for (i, e) in self.e.iter().enumerate() {
            axpy(self.x, *e, col(self.w, i));
        }
    }
}

/// The products of the structured predict, with `phi_top^T` given (`phi_t`, `n x k`):
/// `T^T = P phi_top^T` (into `tt`), the off-diagonal blocks `P[k.., ..k] = T^T[k.., :]` and its
/// transpose, `P[..k, ..k] = Q + phi_top T^T` and, with a state, `x[..k] = phi_top x`.
pub(crate) struct PredictProducts<'a> {
    pub phi_t: MatRef<'a, f64>,
    pub q: MatRef<'a, f64>,
    pub tt: MatMut<'a, f64>,
    pub p: MatMut<'a, f64>,
    pub x: Option<&'a mut [f64]>,
}

impl WithSimd for PredictProducts<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) {
        let Self {
            phi_t,
            q,
            mut tt,
            mut p,
            x,
        } = self;
        let (n, k) = (phi_t.nrows(), phi_t.ncols());
        sym_times(tt.rb_mut(), p.rb(), phi_t);
        let tt = tt.rb();
        for j in 0..k {
            let t = col(tt, j);
            for i in k..n {
                p[(i, j)] = t[i];
                p[(j, i)] = t[i];
            }
        }
        let mut p11 = p.submatrix_mut(0, 0, k, k);
        p11.copy_from(q);
        add_transpose_times(p11, phi_t, tt);
        if let Some(x) = x {
            // Each new x_i reads the old x: all k first, then written (k <= n <= SMALL_STATES here).
            let mut top = [0.0; SMALL_STATES];
            for (i, t) in top.iter_mut().enumerate().take(k) {
                *t = dot(col(phi_t, i), x);
            }
            x[..k].copy_from_slice(&top[..k]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    /// A deterministic matrix with some exact zeros (the loops skip them).
    fn mat(r: usize, c: usize, seed: u64) -> Mat<f64> {
        Mat::from_fn(r, c, |i, j| {
            let k = (i * 31 + j * 17) as u64 + seed;
            if k.is_multiple_of(5) {
                0.0
            } else {
                ((k * 2654435761) % 1000) as f64 / 997.0 - 0.4
            }
        })
    }

    /// Every group of products gives the same bits on the baseline path as on the one the
    /// processor picks (AVX2 here): the same operations in the same order, and Rust does not
    /// fuse multiply-adds.
    #[test]
    fn every_instruction_set_gives_the_same_bits() {
        let (n, m, k) = (29, 3, 3);
        let p0 = {
            let a = mat(n, n, 1);
            &a * a.transpose()
        };
        let (h_t, phi_t, q) = (mat(n, m, 2), mat(n, k, 3), mat(k, k, 4));
        let l = Mat::from_fn(m, m, |i, j| match i.cmp(&j) {
            std::cmp::Ordering::Less => 0.0,
            std::cmp::Ordering::Equal => 2.0 + i as f64,
            std::cmp::Ordering::Greater => 0.3,
        });
        let x0: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let run = |arch: pulp::Arch| {
            let (mut p, mut w, mut s) = (p0.clone(), Mat::zeros(n, m), Mat::identity(m, m));
            arch.dispatch(InnovationProducts {
                p: p.as_ref(),
                h_t: h_t.as_ref(),
                w: w.as_mut(),
                s: s.as_mut(),
            });
            arch.dispatch(GainProducts {
                l: l.as_ref(),
                w: w.as_mut(),
                p: p.as_mut(),
            });
            let (z, mut nu, mut x) = ([0.5, -1.0, 2.0], [0.0; 3], x0.clone());
            arch.dispatch(Innovation {
                h_t: h_t.as_ref(),
                x: &x,
                z: &z,
                innovation: &mut nu,
            });
            arch.dispatch(StateCorrection {
                w: w.as_ref(),
                e: &nu,
                x: &mut x,
            });
            let mut tt = Mat::zeros(n, k);
            arch.dispatch(PredictProducts {
                phi_t: phi_t.as_ref(),
                q: q.as_ref(),
                tt: tt.as_mut(),
                p: p.as_mut(),
                x: Some(&mut x),
            });
            (p, w, s, nu, x)
        };
        let (best, baseline) = (run(pulp::Arch::new()), run(pulp::Arch::Scalar));
        assert!(best.0 == baseline.0 && best.1 == baseline.1 && best.2 == baseline.2);
        assert_eq!((best.3, &best.4), (baseline.3, &baseline.4));
        // And they did something.
        assert!(best.0 != p0 && best.4 != x0);
    }
}
