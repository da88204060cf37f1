//! The optimal-gain measurement update, on faer views of the normalised covariance and state.
//!
//! With `B = P H^T` (`n x m`), `S = H B + R = L L^T` and `W = B L^{-T}`:
//!
//! ```text
//! P' = P - B S^-1 B^T = P - W W^T          (the Joseph form for the optimal gain)
//! x' = x + K nu = x + W (L^-1 nu)          (K = B S^-1 = W L^-1, nu = z - H x)
//! NIS = nu^T S^-1 nu = |L^-1 nu|^2,   ln det S = 2 sum ln L_jj
//! ```
//!
//! When the measurement noise is correlated with the state's error (`M = E[e v^T]`, `n x m`, as
//! when `v` holds process noise of the interval just predicted over), `B = P H^T + M` and
//! `S = H P H^T + H M + M^T H^T + R`; the rest is unchanged.
//!
//! `W W^T` is formed on the lower triangle only (faer's triangular product) and mirrored, so the
//! updated covariance is exactly symmetric; no gain matrix is formed. The `m x m` Cholesky
//! factorisation is a plain loop: it rejects pivots lost to rounding (not larger than
//! `m * eps` times their diagonal entry), which faer's `llt` would accept.

use faer::dyn_stack::{MemStack, StackReq};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::linalg::{temp_mat_scratch, temp_mat_zeroed};
use faer::mat::AsMatMut;
use faer::prelude::*;
use faer::{Accum, MatMut, MatRef, Par};

use crate::error::{KalmanError, check_finite_mat};
use crate::predict::symmetrise;
use crate::small;

/// Scratch of [`update`] for `n` states and measurements of up to `m_max` components.
pub(crate) fn update_scratch(n: usize, m_max: usize) -> StackReq {
    StackReq::all_of(&[
        temp_mat_scratch::<f64>(n, m_max), // normalised H, transposed
        temp_mat_scratch::<f64>(m_max, 1), // L^-1 nu
    ])
}

/// Where the update writes: the normalised covariance (`n x n`) and the results the filter
/// keeps for its accessors, `W` (`n x m`), `S` and its Cholesky factor `L` (`m x m`).
pub(crate) struct Outputs<'a> {
    pub p: MatMut<'a, f64>,
    pub w: MatMut<'a, f64>,
    pub s: MatMut<'a, f64>,
    pub l: MatMut<'a, f64>,
}

/// The state part of an update: the normalised state (`n`), the measurement (`m`) and where the
/// innovation goes (`m`).
pub(crate) struct StatePart<'a> {
    pub x: &'a mut [f64],
    pub z: &'a [f64],
    pub innovation: &'a mut [f64],
}

/// The measurement update with `h` (`m x n`) in the caller's units (normalised here with
/// `scale`), `r` (`m x m`) and, when given, the cross-covariance `cross = E[e v^T]` (`n x m`,
/// caller's units) of the state error and the measurement noise; returns `(ln det S, NIS)`
/// (NIS 0 without a state part).
///
/// Shapes are checked by the caller. `h` and `r` are checked for finiteness before anything is
/// written. When `S` is not positive definite, `out.s` holds it and `out.p` and the state are
/// unchanged.
pub(crate) fn update(
    out: Outputs<'_>,
    state: Option<StatePart<'_>>,
    scale: &[f64],
    h: MatRef<'_, f64>,
    r: MatRef<'_, f64>,
    cross: Option<MatRef<'_, f64>>,
    stack: &mut MemStack,
) -> Result<(f64, f64), KalmanError> {
    let (m, n) = (h.nrows(), h.ncols());
    // H_s = H D, held transposed (n x m: each row a contiguous column for the loops of
    // `small`).
    let (mut h_t, stack) = temp_mat_zeroed::<f64, _, _>(n, m, stack);
    let mut h_t = h_t.as_mat_mut();
    for (j, &sj) in scale.iter().enumerate() {
        for i in 0..m {
            h_t[(j, i)] = h[(i, j)] * sj;
        }
    }
    check_finite_mat("H", h_t.rb().transpose())?;
    check_finite_mat("R", r)?;
    if let Some(c) = cross {
        check_finite_mat("M", c)?;
    }
    let Outputs { p, mut w, s, mut l } = out;
    let correlation = cross.map(|c| Correlation { cross: c, scale });
    let log_det_s = covariance(p, w.rb_mut(), s, l.rb_mut(), h_t.rb(), r, correlation)?;
    let nis = match state {
        Some(state) => update_state(state, h_t.rb(), w.rb(), l.rb(), stack),
        None => 0.0,
    };
    Ok((log_det_s, nis))
}

/// The cross-covariance of a correlated update, in the caller's units, and the states' scale.
#[derive(Clone, Copy)]
struct Correlation<'a> {
    cross: MatRef<'a, f64>,
    scale: &'a [f64],
}

impl Correlation<'_> {
    /// `B <- B + M_s` and `S <- S + H_s M_s + M_s^T H_s^T` with `M_s = D^-1 M` (`h_t` is
    /// `H_s^T = D H^T`, so `H_s M_s = H M`).
    fn add_to(&self, mut w: MatMut<'_, f64>, mut s: MatMut<'_, f64>, h_t: MatRef<'_, f64>) {
        let m = w.ncols();
        for (i, &si) in self.scale.iter().enumerate() {
            for b in 0..m {
                let c = self.cross[(i, b)] / si;
                if c == 0.0 {
                    continue;
                }
                w[(i, b)] += c;
                for a in 0..m {
                    let hc = h_t[(i, a)] * c;
                    s[(a, b)] += hc;
                    s[(b, a)] += hc;
                }
            }
        }
    }
}

/// `B = P H^T (+ M)` (into `w`), `S = H B + R (+ M^T H^T)`, `L`, then `W = B L^-T` and
/// `P <- P - W W^T`; returns `ln det S`. `h_t` is `H^T`. `p` is untouched when `S` is not
/// positive definite.
fn covariance(
    mut p: MatMut<'_, f64>,
    mut w: MatMut<'_, f64>,
    mut s: MatMut<'_, f64>,
    mut l: MatMut<'_, f64>,
    h_t: MatRef<'_, f64>,
    r: MatRef<'_, f64>,
    correlation: Option<Correlation<'_>>,
) -> Result<f64, KalmanError> {
    let seq = Par::Seq;
    let small = p.nrows() <= small::SMALL_STATES;
    s.copy_from(r);
    if small {
        pulp::Arch::new().dispatch(small::InnovationProducts {
            p: p.rb(),
            h_t,
            w: w.rb_mut(),
            s: s.rb_mut(),
        });
    } else {
        matmul(w.rb_mut(), Accum::Replace, p.rb(), h_t, 1.0, seq);
        matmul(s.rb_mut(), Accum::Add, h_t.transpose(), w.rb(), 1.0, seq);
    }
    if let Some(c) = correlation {
        c.add_to(w.rb_mut(), s.rb_mut(), h_t);
    }
    symmetrise(s.rb_mut());
    l.copy_from(s.rb());
    let log_det_s = cholesky_in_place(l.rb_mut()).map_err(|(pivot, value)| {
        KalmanError::NotPositiveDefinite {
            m: h_t.ncols(),
            pivot,
            value,
        }
    })?;
    if small {
        pulp::Arch::new().dispatch(small::GainProducts {
            l: l.rb(),
            w: w.rb_mut(),
            p: p.rb_mut(),
        });
        return Ok(log_det_s);
    }
    // W = B L^-T, that is L W^T = B^T
    solve_lower_triangular_in_place(l.rb(), w.rb_mut().transpose_mut(), seq);
    // P <- P - W W^T on the lower triangle, then mirrored.
    let (rect, lower) = (BlockStructure::Rectangular, BlockStructure::TriangularLower);
    let wt = w.rb().transpose();
    triangular::matmul(
        p.rb_mut(),
        lower,
        Accum::Add,
        w.rb(),
        rect,
        wt,
        rect,
        -1.0,
        seq,
    );
    for j in 0..p.ncols() {
        for i in 0..j {
            p[(i, j)] = p[(j, i)];
        }
    }
    Ok(log_det_s)
}

/// `nu = z - H x` (into the innovation; `H_s x_s = H x`; `h_t` is `H_s^T`), `e = L^-1 nu`,
/// `x <- x + W e`; returns the NIS `|e|^2`.
fn update_state(
    state: StatePart<'_>,
    h_t: MatRef<'_, f64>,
    w: MatRef<'_, f64>,
    l: MatRef<'_, f64>,
    stack: &mut MemStack,
) -> f64 {
    let StatePart { x, z, innovation } = state;
    let seq = Par::Seq;
    let small = x.len() <= small::SMALL_STATES;
    if small {
        pulp::Arch::new().dispatch(small::Innovation {
            h_t,
            x,
            z,
            innovation,
        });
    } else {
        let mut nu = ColMut::from_slice_mut(innovation).as_mat_mut();
        nu.copy_from(ColRef::from_slice(z).as_mat());
        let x_prior = ColRef::from_slice(x).as_mat();
        matmul(nu, Accum::Add, h_t.transpose(), x_prior, -1.0, seq);
    }
    let (mut e, _) = temp_mat_zeroed::<f64, _, _>(innovation.len(), 1, stack);
    let mut e = e.as_mat_mut();
    e.copy_from(ColRef::from_slice(innovation).as_mat());
    solve_lower_triangular_in_place(l, e.rb_mut(), seq);
    let e = e.rb();
    if small {
        let e = e
            .col(0)
            .try_as_col_major()
            .expect("scratch is column-major");
        pulp::Arch::new().dispatch(small::StateCorrection {
            w,
            e: e.as_slice(),
            x,
        });
    } else {
        let x = ColMut::from_slice_mut(x).as_mat_mut();
        matmul(x, Accum::Add, w, e, 1.0, seq);
    }
    e.col(0).squared_norm_l2()
}

/// In-place lower Cholesky factor of the small symmetric `a` (lower triangle read, strict upper
/// triangle zeroed). Returns `ln det a`, or the first pivot that is not larger than
/// `m * eps * |a_jj|` (zero, negative, NaN or lost to rounding) and its value.
fn cholesky_in_place(mut a: MatMut<'_, f64>) -> Result<f64, (usize, f64)> {
    let m = a.nrows();
    let tol = m as f64 * f64::EPSILON;
    // ln det = ln prod d_j, accumulated as a product (one `ln` instead of `m`) and folded into
    // the sum whenever it leaves a safe range.
    let (mut log_det, mut det_part) = (0.0, 1.0f64);
    for j in 0..m {
        let diag = a[(j, j)];
        for c in 0..j {
            let f = a[(j, c)];
            for i in j..m {
                a[(i, j)] -= f * a[(i, c)];
            }
        }
        let d = a[(j, j)];
        // Written so that a NaN pivot fails too.
        if !(d > tol * diag.abs() && d.is_finite()) {
            return Err((j, d));
        }
        let ljj = d.sqrt();
        a[(j, j)] = ljj;
        for i in (j + 1)..m {
            a[(i, j)] /= ljj;
        }
        for i in 0..j {
            a[(i, j)] = 0.0;
        }
        det_part *= d;
        if !(1e-150..=1e150).contains(&det_part) {
            log_det += det_part.ln();
            det_part = 1.0;
        }
    }
    Ok(log_det + det_part.ln())
}
