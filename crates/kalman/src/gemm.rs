//! The one matrix-product entry point of the crate: faer's `matmul`, followed by clearing the
//! upper halves of the AVX registers.
//!
//! faer 0.24 sends products above `16^3` multiply-adds to the assembly kernels of
//! `private-gemm-x86`, which use AVX-512/AVX registers and return without `vzeroupper`. Until
//! something clears the upper register state, every legacy-SSE instruction (which is what
//! scalar `f64` code compiles to on the baseline x86-64 target) pays a false dependency on the
//! dirty upper halves; on the benchmark machine this made the scalar loops that follow a product
//! (symmetrisation, the small Cholesky, the triangular solves) three to four times slower. One
//! `vzeroupper` after each product removes the penalty.

use faer::{Accum, MatMut, MatRef, Par};

/// `dst = [dst +] alpha * lhs * rhs`, then [`clear_upper_avx_state`].
#[inline]
pub(crate) fn matmul(
    dst: MatMut<'_, f64>,
    beta: Accum,
    lhs: MatRef<'_, f64>,
    rhs: MatRef<'_, f64>,
    alpha: f64,
    par: Par,
) {
    faer::linalg::matmul::matmul(dst, beta, lhs, rhs, alpha, par);
    clear_upper_avx_state();
}

/// Issues `vzeroupper` when the CPU has AVX; a no-op elsewhere.
#[inline]
pub(crate) fn clear_upper_avx_state() {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: `zeroupper` only needs AVX, which was just detected at run time.
            unsafe { zeroupper() }
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn zeroupper() {
    core::arch::x86_64::_mm256_zeroupper();
}
