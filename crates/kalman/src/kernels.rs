//! Hand-written kernels for the step [`KalmanFilter`](crate::KalmanFilter) runs: the structured
//! time update and the measurement update, on the filter's own storage.
//!
//! At the sizes of a calibration (`n` of a few tens, `m` and `k` of a few units) a step is a few
//! thousand multiply-adds, and faer's general kernels spend more time in their fixed per-call
//! cost than in the arithmetic. These kernels assume one storage layout and are written for it:
//!
//! - every `n`-row matrix (covariance `P`, `P phi_top^T`, `B = P H^T`, `W`, the gain, the state)
//!   is column-major with one leading dimension `ld`, `n` rounded up to a multiple of
//!   [`LANES`] = 8; the padding rows are zero and stay zero (every kernel maps zero rows to zero
//!   rows), so every column is a whole number of 8-row blocks and no loop has a remainder;
//! - the inputs `H` (`m x n`) and `phi_top` (`k x n`) are copied once per step with their rows
//!   padded to a multiple of 8 (masked loads, so nothing past a column is read), which also
//!   checks them for finiteness; then `H` and `phi_top` are row blocks too, and `H B`, `H x`,
//!   `phi_top T^T` and `phi_top x` are products of the same kind as `P H^T`;
//! - the buffers are 64-byte aligned ([`AlignedVec`]), so a block is one aligned cache line;
//! - the products are register-blocked with the number of columns (at most 8 per pass) a const
//!   parameter, so the accumulators stay in registers;
//! - the arithmetic goes through a small SIMD layer ([`Simd`]): 8-lane vectors that are one
//!   AVX-512 register, two AVX2 registers, or an array of 8 `f64` in the portable fallback.
//!   (The compiler's auto-vectorisation of the same loops written on arrays was tried first: it
//!   vectorised across the wrong dimension or wrapped the loops in run-time alias checks, and
//!   was 2-5 times slower.)
//!
//! [`Isa::detect`] picks the instruction set at run time. The AVX entry points are compiled
//! with `#[target_feature]`, so the compiler ends them with `vzeroupper`; the portable entry
//! points clear the upper register state first (see [`crate::gemm`]), since a faer product
//! before them may have left it dirty.
//!
//! # The measurement update
//!
//! It is the Joseph form specialised to the optimal gain. With `B = P H^T`,
//! `S = H B + R = L L^T` (Cholesky), `K = B S^{-1}` and `W = B L^{-T}`:
//!
//! ```text
//! (I - K H) P (I - K H)^T + K R K^T = P - K B^T - B K^T + K S K^T = P - B S^{-1} B^T = P - W W^T
//! ```
//!
//! `P - W W^T` is formed with the same operations in the same order for entry `(i, j)` and
//! entry `(j, i)`, so the result is exactly symmetric without a symmetrisation pass. The state
//! update uses `K nu = W (L^{-1} nu)`, and `|L^{-1} nu|^2` is the NIS. `L^{-1}` comes from an
//! unrolled `U D U^T` factorisation of `S` for `m <= 8` ([`factor_small`]; the general Cholesky
//! of [`small::cholesky`] otherwise), and `W` and `K` from one pass over the rows of `B` using
//! the triangles of `L^{-1}`. Costs: `n^2 m` multiply-adds for `B`, `n^2 m` for the rank-`m`
//! update, `O(n m^2 + m^3)` for the rest; the Joseph form for a gain other than the optimal one
//! is [`joseph_covariance`](crate::update::joseph_covariance).

// Index loops over the small fixed-size arrays of registers read more plainly than iterator
// chains here, and compile to the same code.
#![allow(clippy::needless_range_loop)]

use faer::MatRef;

use crate::small;

/// Rows per block: the leading dimension of every buffer is a multiple of this.
pub(crate) const LANES: usize = 8;

/// Most columns handled in one pass of a product (the accumulators of a register block).
const MAX_COLS: usize = 8;

/// `n` rounded up to a multiple of [`LANES`].
pub(crate) fn padded(n: usize) -> usize {
    n.div_ceil(LANES) * LANES
}

/// A zero-initialised `f64` buffer whose start is 64-byte aligned.
#[derive(Clone)]
pub(crate) struct AlignedVec {
    lines: Vec<Line>,
}

#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Line([f64; LANES]);

impl AlignedVec {
    /// `len` zeros (rounded up to a whole number of 64-byte lines).
    pub(crate) fn zeros(len: usize) -> Self {
        Self {
            lines: vec![Line([0.0; LANES]); len.div_ceil(LANES)],
        }
    }

    pub(crate) fn as_slice(&self) -> &[f64] {
        // SAFETY: `Line` is `repr(C)` around `[f64; LANES]` and exactly 64 bytes (no padding),
        // so the lines are `lines.len() * LANES` contiguous initialised `f64`.
        unsafe {
            core::slice::from_raw_parts(self.lines.as_ptr().cast::<f64>(), self.lines.len() * LANES)
        }
    }

    pub(crate) fn as_mut_slice(&mut self) -> &mut [f64] {
        // SAFETY: as in `as_slice`, with unique access through `&mut self`.
        unsafe {
            core::slice::from_raw_parts_mut(
                self.lines.as_mut_ptr().cast::<f64>(),
                self.lines.len() * LANES,
            )
        }
    }
}

/// The instruction set the kernels run on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    /// Baseline code for the target (SSE2 on x86-64), separate multiply and add.
    Portable,
    /// AVX2 and FMA.
    Avx2,
    /// AVX-512F (with AVX2 and FMA).
    Avx512,
}

impl Isa {
    /// The kernels to use on the running CPU: AVX-512 when available, else AVX2 + FMA, else
    /// portable.
    ///
    /// On the benchmark machine (Ice Lake server, see `docs/performance.md`) the AVX-512 step at
    /// n = 28 took 1.11 us, the AVX2 one 1.27 us and the portable one 4.1 us. Another set can be
    /// selected with [`KalmanFilter::select_kernel_set`](crate::KalmanFilter::select_kernel_set).
    pub(crate) fn detect() -> Self {
        if Self::Avx512.is_supported() {
            Isa::Avx512
        } else if Self::Avx2.is_supported() {
            Isa::Avx2
        } else {
            Isa::Portable
        }
    }

    /// Whether the running CPU supports AVX2 and FMA.
    fn has_avx2() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }

    /// Whether the running CPU can execute these kernels.
    pub(crate) fn is_supported(self) -> bool {
        match self {
            Isa::Portable => true,
            Isa::Avx2 => Self::has_avx2(),
            Isa::Avx512 => {
                #[cfg(target_arch = "x86_64")]
                {
                    Self::has_avx2() && std::arch::is_x86_feature_detected!("avx512f")
                }
                #[cfg(not(target_arch = "x86_64"))]
                {
                    false
                }
            }
        }
    }
}

/// Vectors of [`LANES`] `f64`. A value of an implementing type is a token that proves the CPU
/// supports its instructions: only the entry points below create one, after detection.
trait Simd: Copy {
    type V: Copy;
    /// How many vectors can serve as accumulators at once.
    const ACCUMULATORS: usize;
    fn zero(self) -> Self::V;
    fn splat(self, v: f64) -> Self::V;
    /// # Safety
    /// `p .. p + LANES` must be readable `f64`.
    unsafe fn load(self, p: *const f64) -> Self::V;
    /// The first `len <= LANES` values from `p`, the other lanes zero.
    ///
    /// # Safety
    /// `p .. p + len` must be readable `f64`.
    unsafe fn load_partial(self, p: *const f64, len: usize) -> Self::V;
    /// # Safety
    /// `p .. p + LANES` must be writable `f64`.
    unsafe fn store(self, p: *mut f64, v: Self::V);
    /// The lanes as an array.
    fn to_array(self, v: Self::V) -> [f64; LANES];
    /// `a * b + c`.
    fn fma(self, a: Self::V, b: Self::V, c: Self::V) -> Self::V;
    /// `c - a * b` (one rounding where FMA is available).
    fn fnma(self, a: Self::V, b: Self::V, c: Self::V) -> Self::V;
    /// `a + b`.
    fn add(self, a: Self::V, b: Self::V) -> Self::V;
    /// `a * b`.
    fn mul(self, a: Self::V, b: Self::V) -> Self::V;
    /// Scalar `a * b + c` (one rounding where FMA is available).
    fn madd(self, a: f64, b: f64, c: f64) -> f64;
}

/// The fallback: arrays, separate multiply and add.
#[derive(Clone, Copy)]
struct Portable;

impl Simd for Portable {
    type V = [f64; LANES];
    const ACCUMULATORS: usize = 2;
    #[inline(always)]
    fn zero(self) -> Self::V {
        [0.0; LANES]
    }
    #[inline(always)]
    fn splat(self, v: f64) -> Self::V {
        [v; LANES]
    }
    #[inline(always)]
    unsafe fn load(self, p: *const f64) -> Self::V {
        // SAFETY: guaranteed by the caller.
        unsafe { p.cast::<[f64; LANES]>().read_unaligned() }
    }
    #[inline(always)]
    unsafe fn load_partial(self, p: *const f64, len: usize) -> Self::V {
        let mut v = [0.0; LANES];
        for (i, v) in v.iter_mut().enumerate().take(len) {
            // SAFETY: i < len, guaranteed readable by the caller.
            *v = unsafe { *p.add(i) };
        }
        v
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut f64, v: Self::V) {
        // SAFETY: guaranteed by the caller.
        unsafe { p.cast::<[f64; LANES]>().write_unaligned(v) }
    }
    #[inline(always)]
    fn to_array(self, v: Self::V) -> [f64; LANES] {
        v
    }
    #[inline(always)]
    fn fma(self, a: Self::V, b: Self::V, c: Self::V) -> Self::V {
        core::array::from_fn(|i| a[i] * b[i] + c[i])
    }
    #[inline(always)]
    fn fnma(self, a: Self::V, b: Self::V, c: Self::V) -> Self::V {
        core::array::from_fn(|i| c[i] - a[i] * b[i])
    }
    #[inline(always)]
    fn add(self, a: Self::V, b: Self::V) -> Self::V {
        core::array::from_fn(|i| a[i] + b[i])
    }
    #[inline(always)]
    fn mul(self, a: Self::V, b: Self::V) -> Self::V {
        core::array::from_fn(|i| a[i] * b[i])
    }
    #[inline(always)]
    fn madd(self, a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{
        LANES, Predict, PredictResult, Simd, Update, UpdateResult, predict_impl, update_impl,
    };
    use core::arch::x86_64::*;

    /// AVX-512F: one `zmm` register per vector.
    #[derive(Clone, Copy)]
    pub(super) struct Avx512(());

    impl Simd for Avx512 {
        type V = __m512d;
        const ACCUMULATORS: usize = 24;
        #[inline(always)]
        fn zero(self) -> __m512d {
            // SAFETY: the token proves AVX-512F (see `Simd`).
            unsafe { _mm512_setzero_pd() }
        }
        #[inline(always)]
        fn splat(self, v: f64) -> __m512d {
            // SAFETY: as above.
            unsafe { _mm512_set1_pd(v) }
        }
        #[inline(always)]
        unsafe fn load(self, p: *const f64) -> __m512d {
            // SAFETY: the caller guarantees the memory, the token the instructions.
            unsafe { _mm512_loadu_pd(p) }
        }
        #[inline(always)]
        unsafe fn load_partial(self, p: *const f64, len: usize) -> __m512d {
            let mask = (0xffu32 >> (LANES - len.min(LANES))) as __mmask8;
            // SAFETY: masked-out lanes are neither read nor fault; the caller guarantees the
            // others.
            unsafe { _mm512_maskz_loadu_pd(mask, p) }
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f64, v: __m512d) {
            // SAFETY: as for `load`.
            unsafe { _mm512_storeu_pd(p, v) }
        }
        #[inline(always)]
        fn to_array(self, v: __m512d) -> [f64; LANES] {
            let mut a = [0.0; LANES];
            // SAFETY: `a` has LANES values.
            unsafe { _mm512_storeu_pd(a.as_mut_ptr(), v) };
            a
        }
        #[inline(always)]
        fn fma(self, a: __m512d, b: __m512d, c: __m512d) -> __m512d {
            // SAFETY: the token proves AVX-512F.
            unsafe { _mm512_fmadd_pd(a, b, c) }
        }
        #[inline(always)]
        fn fnma(self, a: __m512d, b: __m512d, c: __m512d) -> __m512d {
            // SAFETY: the token proves AVX-512F.
            unsafe { _mm512_fnmadd_pd(a, b, c) }
        }
        #[inline(always)]
        fn add(self, a: __m512d, b: __m512d) -> __m512d {
            // SAFETY: the token proves AVX-512F.
            unsafe { _mm512_add_pd(a, b) }
        }
        #[inline(always)]
        fn mul(self, a: __m512d, b: __m512d) -> __m512d {
            // SAFETY: the token proves AVX-512F.
            unsafe { _mm512_mul_pd(a, b) }
        }
        #[inline(always)]
        fn madd(self, a: f64, b: f64, c: f64) -> f64 {
            a.mul_add(b, c)
        }
    }

    /// AVX2 + FMA: two `ymm` registers per vector.
    #[derive(Clone, Copy)]
    pub(super) struct Avx2(());

    impl Simd for Avx2 {
        type V = (__m256d, __m256d);
        const ACCUMULATORS: usize = 6;
        #[inline(always)]
        fn zero(self) -> Self::V {
            // SAFETY: the token proves AVX2 and FMA (see `Simd`).
            unsafe { (_mm256_setzero_pd(), _mm256_setzero_pd()) }
        }
        #[inline(always)]
        fn splat(self, v: f64) -> Self::V {
            // SAFETY: as above.
            unsafe { (_mm256_set1_pd(v), _mm256_set1_pd(v)) }
        }
        #[inline(always)]
        unsafe fn load(self, p: *const f64) -> Self::V {
            // SAFETY: the caller guarantees `LANES` readable values, the token the instructions.
            unsafe { (_mm256_loadu_pd(p), _mm256_loadu_pd(p.add(LANES / 2))) }
        }
        #[inline(always)]
        unsafe fn load_partial(self, p: *const f64, len: usize) -> Self::V {
            // SAFETY: masked-out lanes are neither read nor fault; the caller guarantees the
            // others.
            unsafe {
                let n = _mm256_set1_epi64x(len as i64);
                let lo = _mm256_cmpgt_epi64(n, _mm256_setr_epi64x(0, 1, 2, 3));
                let hi = _mm256_cmpgt_epi64(n, _mm256_setr_epi64x(4, 5, 6, 7));
                (
                    _mm256_maskload_pd(p, lo),
                    // `wrapping_add`: for len <= 4 the address may lie past the allocation;
                    // no lane of it is read then.
                    _mm256_maskload_pd(p.wrapping_add(LANES / 2), hi),
                )
            }
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f64, v: Self::V) {
            // SAFETY: as for `load`.
            unsafe {
                _mm256_storeu_pd(p, v.0);
                _mm256_storeu_pd(p.add(LANES / 2), v.1);
            }
        }
        #[inline(always)]
        fn to_array(self, v: Self::V) -> [f64; LANES] {
            let mut a = [0.0; LANES];
            // SAFETY: `a` has LANES values.
            unsafe {
                _mm256_storeu_pd(a.as_mut_ptr(), v.0);
                _mm256_storeu_pd(a.as_mut_ptr().add(LANES / 2), v.1);
            }
            a
        }
        #[inline(always)]
        fn fma(self, a: Self::V, b: Self::V, c: Self::V) -> Self::V {
            // SAFETY: the token proves FMA.
            unsafe {
                (
                    _mm256_fmadd_pd(a.0, b.0, c.0),
                    _mm256_fmadd_pd(a.1, b.1, c.1),
                )
            }
        }
        #[inline(always)]
        fn fnma(self, a: Self::V, b: Self::V, c: Self::V) -> Self::V {
            // SAFETY: the token proves FMA.
            unsafe {
                (
                    _mm256_fnmadd_pd(a.0, b.0, c.0),
                    _mm256_fnmadd_pd(a.1, b.1, c.1),
                )
            }
        }
        #[inline(always)]
        fn add(self, a: Self::V, b: Self::V) -> Self::V {
            // SAFETY: the token proves AVX.
            unsafe { (_mm256_add_pd(a.0, b.0), _mm256_add_pd(a.1, b.1)) }
        }
        #[inline(always)]
        fn mul(self, a: Self::V, b: Self::V) -> Self::V {
            // SAFETY: the token proves AVX.
            unsafe { (_mm256_mul_pd(a.0, b.0), _mm256_mul_pd(a.1, b.1)) }
        }
        #[inline(always)]
        fn madd(self, a: f64, b: f64, c: f64) -> f64 {
            a.mul_add(b, c)
        }
    }

    #[target_feature(enable = "avx512f,avx2,fma")]
    pub(super) fn predict_avx512(a: Predict<'_>) -> PredictResult {
        predict_impl(Avx512(()), a)
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn predict_avx2(a: Predict<'_>) -> PredictResult {
        predict_impl(Avx2(()), a)
    }

    #[target_feature(enable = "avx512f,avx2,fma")]
    pub(super) fn update_avx512(u: Update<'_>) -> UpdateResult {
        update_impl(Avx512(()), u)
    }

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn update_avx2(u: Update<'_>) -> UpdateResult {
        update_impl(Avx2(()), u)
    }
}

/// Whether `cols` columns of `rows` values with column stride `ld` fit in a slice of length
/// `len`.
#[inline(always)]
fn fits(len: usize, rows: usize, cols: usize, ld: usize) -> bool {
    rows == 0 || cols == 0 || (cols - 1) * ld + rows <= len
}

/// Calls `$f::<$s, C>(args)` with the const `C` equal to the runtime `cols` (1 to 8).
macro_rules! with_cols {
    ($cols:expr, $f:ident::<$s:ty>($($arg:expr),* $(,)?)) => {
        match $cols {
            1 => $f::<$s, 1>($($arg),*),
            2 => $f::<$s, 2>($($arg),*),
            3 => $f::<$s, 3>($($arg),*),
            4 => $f::<$s, 4>($($arg),*),
            5 => $f::<$s, 5>($($arg),*),
            6 => $f::<$s, 6>($($arg),*),
            7 => $f::<$s, 7>($($arg),*),
            8 => $f::<$s, 8>($($arg),*),
            _ => unreachable!(),
        }
    };
}

/// Shape of a product `out = A G`, `A` and `out` column-major: `A` is `rows x inner` (leading
/// dimension `lda`), `out` is `rows x cols` (`ldo`), and `G` is `inner x cols` with entry
/// `(j, c)` at `j g_rs + c g_cs`. `rows` is a multiple of [`LANES`].
#[derive(Clone, Copy)]
struct Shape {
    rows: usize,
    inner: usize,
    cols: usize,
    lda: usize,
    g_rs: usize,
    g_cs: usize,
    ldo: usize,
}

/// `out = A G` (see [`Shape`]): register blocks of up to 4 vectors of rows by up to 8 columns
/// (as many accumulators as the registers hold), `G` broadcast one value at a time;
/// `rows inner cols` multiply-adds.
#[inline(always)]
fn gemm<S: Simd>(s: S, out: &mut [f64], a: &[f64], g: &[f64], d: Shape) {
    // Every access below is in bounds by these checks; the loops index without further checks.
    assert!(d.rows.is_multiple_of(LANES) && d.rows <= d.lda && d.rows <= d.ldo);
    assert!(fits(a.len(), d.rows, d.inner, d.lda) && fits(out.len(), d.rows, d.cols, d.ldo));
    assert!(
        d.rows == 0
            || d.inner == 0
            || d.cols == 0
            || (d.inner - 1) * d.g_rs + (d.cols - 1) * d.g_cs < g.len()
    );
    let mut c0 = 0;
    while c0 < d.cols {
        let cc = (d.cols - c0).min(MAX_COLS);
        with_cols!(cc, gemm_cols::<S>(s, out, a, g, d, c0));
        c0 += cc;
    }
}

/// Columns `c0..c0 + C` of [`gemm`], whose checks this relies on.
#[inline(always)]
fn gemm_cols<S: Simd, const C: usize>(
    s: S,
    out: &mut [f64],
    a: &[f64],
    g: &[f64],
    d: Shape,
    c0: usize,
) {
    if d.rows == LANES {
        // A single block of rows: the sum over `inner` would be one long chain of dependent
        // multiply-adds per accumulator, so it is split into independent partial sums, as
        // many as the registers allow.
        let split = S::ACCUMULATORS / C;
        if split >= 4 {
            gemm_block::<S, 1, C, 4>(s, out, a, g, d, c0, 0, LANES);
        } else if split >= 2 {
            gemm_block::<S, 1, C, 2>(s, out, a, g, d, c0, 0, LANES);
        } else {
            gemm_block::<S, 1, C, 1>(s, out, a, g, d, c0, 0, LANES);
        }
        return;
    }
    // Blocks of 4, 2, then 1 vectors of rows, as far as the accumulators fit in registers.
    let mut i = 0;
    if 4 * C <= S::ACCUMULATORS {
        let end = d.rows / (4 * LANES) * (4 * LANES);
        gemm_block::<S, 4, C, 1>(s, out, a, g, d, c0, i, end);
        i = end;
    }
    if 2 * C <= S::ACCUMULATORS {
        let end = i + (d.rows - i) / (2 * LANES) * (2 * LANES);
        gemm_block::<S, 2, C, 1>(s, out, a, g, d, c0, i, end);
        i = end;
    }
    gemm_block::<S, 1, C, 1>(s, out, a, g, d, c0, i, d.rows);
}

/// Rows `begin..end` in steps of `RV` vectors, the sum over `inner` split into `SPLIT`
/// interleaved partial sums.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn gemm_block<S: Simd, const RV: usize, const C: usize, const SPLIT: usize>(
    s: S,
    out: &mut [f64],
    a: &[f64],
    g: &[f64],
    d: Shape,
    c0: usize,
    begin: usize,
    end: usize,
) {
    let (ap, gp, op) = (a.as_ptr(), g.as_ptr(), out.as_mut_ptr());
    /// `acc += A[i.., j] G[j, c0..c0 + C]`.
    ///
    /// # Safety
    /// `i + RV LANES <= rows`, `j < inner`, `c0 + C <= cols`, and `ap`, `gp` point to `A` and
    /// `G` checked against `d` by [`gemm`].
    #[inline(always)]
    unsafe fn step<S: Simd, const RV: usize, const C: usize>(
        s: S,
        acc: &mut [[S::V; RV]; C],
        (ap, gp): (*const f64, *const f64),
        d: Shape,
        c0: usize,
        i: usize,
        j: usize,
    ) {
        let mut col = [s.zero(); RV];
        for (v, col) in col.iter_mut().enumerate() {
            // SAFETY: i + RV LANES <= rows and j < inner: within `A`.
            *col = unsafe { s.load(ap.add(i + v * LANES + j * d.lda)) };
        }
        for (c, acc) in acc.iter_mut().enumerate() {
            // SAFETY: j < inner and c0 + c < cols: within `G`.
            let gv = s.splat(unsafe { *gp.add(j * d.g_rs + (c0 + c) * d.g_cs) });
            for v in 0..RV {
                acc[v] = s.fma(col[v], gv, acc[v]);
            }
        }
    }
    let mut i = begin;
    while i + RV * LANES <= end {
        let mut acc = [[[s.zero(); RV]; C]; SPLIT];
        let mut j = 0;
        while j + SPLIT <= d.inner {
            for (q, acc) in acc.iter_mut().enumerate() {
                // SAFETY: i + RV LANES <= end <= rows, j + q < inner, c0 + C <= cols.
                unsafe { step(s, acc, (ap, gp), d, c0, i, j + q) };
            }
            j += SPLIT;
        }
        while j < d.inner {
            // SAFETY: as above, with j < inner.
            unsafe { step(s, &mut acc[0], (ap, gp), d, c0, i, j) };
            j += 1;
        }
        for q in 1..SPLIT {
            for c in 0..C {
                for v in 0..RV {
                    acc[0][c][v] = s.add(acc[0][c][v], acc[q][c][v]);
                }
            }
        }
        for (c, acc) in acc[0].iter().enumerate() {
            for (v, &acc) in acc.iter().enumerate() {
                // SAFETY: i + RV LANES <= rows and c0 + c < cols: within the checked `out`.
                unsafe { s.store(op.add(i + v * LANES + (c0 + c) * d.ldo), acc) };
            }
        }
        i += RV * LANES;
    }
}

/// `W = B L^{-T}` into `w` and `K = W L^{-1}` into `gain` (all `ld x C`, leading dimension
/// `ld`) for `L^{-1}` (`C x C` lower triangular, row-major: entry `(i, j)` at `i C + j`), one
/// block of rows at a time in registers; the triangles of `L^{-1}` halve the work of two
/// general products.
#[inline(always)]
fn solve_rows<S: Simd, const C: usize>(
    s: S,
    w: &mut [f64],
    gain: &mut [f64],
    b: &[f64],
    linv: &[f64],
    ld: usize,
) {
    assert!(ld.is_multiple_of(LANES) && C * ld <= w.len().min(gain.len()).min(b.len()));
    let linv: &[f64] = &linv[..C * C];
    let (wp, kp, bp) = (w.as_mut_ptr(), gain.as_mut_ptr(), b.as_ptr());
    for i in (0..ld).step_by(LANES) {
        let mut bb = [s.zero(); C];
        for (d, bb) in bb.iter_mut().enumerate() {
            // SAFETY: i + LANES <= ld and d < C: within the checked `b`.
            *bb = unsafe { s.load(bp.add(i + d * ld)) };
        }
        // W[:, c] = sum_{d <= c} B[:, d] L^{-1}[c, d]
        let mut ww = [s.zero(); C];
        for c in 0..C {
            let mut acc = s.zero();
            for d in 0..=c {
                acc = s.fma(bb[d], s.splat(linv[c * C + d]), acc);
            }
            ww[c] = acc;
            // SAFETY: i + LANES <= ld and c < C: within the checked `w`.
            unsafe { s.store(wp.add(i + c * ld), acc) };
        }
        // K[:, c] = sum_{d >= c} W[:, d] L^{-1}[d, c]
        for c in 0..C {
            let mut acc = s.zero();
            for d in c..C {
                acc = s.fma(ww[d], s.splat(linv[d * C + c]), acc);
            }
            // SAFETY: i + LANES <= ld and c < C: within the checked `gain`.
            unsafe { s.store(kp.add(i + c * ld), acc) };
        }
    }
}

/// `P -= W W^T` for `P` (`rows x n`, leading dimension `ld`) and `W` (`rows x m`, `ld`),
/// `rows` a multiple of [`LANES`], `n <= rows`. Entry `(i, j)` is
/// `P[i, j] - W[i, 0] W[j, 0] - W[i, 1] W[j, 1] - ...`, rounded in the same order as entry
/// `(j, i)`, so a symmetric `P` stays exactly symmetric.
#[inline(always)]
fn rank_update<S: Simd>(
    s: S,
    p: &mut [f64],
    w: &[f64],
    ld: usize,
    rows: usize,
    n: usize,
    m: usize,
) {
    assert!(rows.is_multiple_of(LANES) && rows <= ld && n <= rows);
    assert!(fits(p.len(), rows, n, ld) && fits(w.len(), rows, m, ld));
    let mut c0 = 0;
    while c0 < m {
        let cc = (m - c0).min(MAX_COLS);
        with_cols!(cc, rank_update_cols::<S>(s, p, w, ld, rows, n, c0));
        c0 += cc;
    }
}

/// Columns `c0..c0 + C` of `W` in [`rank_update`], whose checks this relies on: several
/// columns of `P` at a time (as many as the registers hold), their coefficients `W[j, c]`
/// broadcast once, so that each block of `W` loaded serves all of them. (Keeping blocks of `W`
/// in registers and running along the rows instead measured slower.)
#[inline(always)]
fn rank_update_cols<S: Simd, const C: usize>(
    s: S,
    p: &mut [f64],
    w: &[f64],
    ld: usize,
    rows: usize,
    n: usize,
    c0: usize,
) {
    let mut j = 0;
    if 4 * C <= S::ACCUMULATORS {
        j = rank_update_run::<S, C, 4>(s, p, w, ld, rows, n, c0, j);
    }
    if C <= S::ACCUMULATORS {
        j = rank_update_run::<S, C, 2>(s, p, w, ld, rows, n, c0, j);
    }
    rank_update_run::<S, C, 1>(s, p, w, ld, rows, n, c0, j);
}

/// Columns `j0..` of `P` in steps of `JC` (as long as `JC` remain); returns the next column.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn rank_update_run<S: Simd, const C: usize, const JC: usize>(
    s: S,
    p: &mut [f64],
    w: &[f64],
    ld: usize,
    rows: usize,
    n: usize,
    c0: usize,
    j0: usize,
) -> usize {
    let (pp, wp) = (p.as_mut_ptr(), w.as_ptr());
    let mut j = j0;
    while j + JC <= n {
        // W[j + q, c0 + c], broadcast.
        let mut f = [[s.zero(); C]; JC];
        for (q, f) in f.iter_mut().enumerate() {
            for (c, f) in f.iter_mut().enumerate() {
                // SAFETY: j + q < n <= rows and c0 + c < m: within the checked `W`.
                *f = s.splat(unsafe { *wp.add(j + q + (c0 + c) * ld) });
            }
        }
        for i in (0..rows).step_by(LANES) {
            let mut v = [s.zero(); JC];
            for (q, v) in v.iter_mut().enumerate() {
                // SAFETY: i + LANES <= rows and j + q < n: within the checked `P`.
                *v = unsafe { s.load(pp.add(i + (j + q) * ld)) };
            }
            for c in 0..C {
                // SAFETY: i + LANES <= rows and c0 + c < m: within the checked `W`.
                let wb = unsafe { s.load(wp.add(i + (c0 + c) * ld)) };
                for q in 0..JC {
                    v[q] = s.fnma(wb, f[q][c], v[q]);
                }
            }
            for (q, &v) in v.iter().enumerate() {
                // SAFETY: as for the reads.
                unsafe { s.store(pp.add(i + (j + q) * ld), v) };
            }
        }
        j += JC;
    }
    j
}

/// `y += W v` for `W` (`y.len() x v.len()`, leading dimension `ld`); `y.len()` a multiple of
/// [`LANES`].
#[inline(always)]
fn add_product<S: Simd>(s: S, y: &mut [f64], w: &[f64], ld: usize, v: &[f64]) {
    let rows = y.len();
    assert!(rows.is_multiple_of(LANES) && rows <= ld && fits(w.len(), rows, v.len(), ld));
    let (yp, wp) = (y.as_mut_ptr(), w.as_ptr());
    for i in (0..rows).step_by(LANES) {
        // SAFETY: i + LANES <= rows = y.len().
        let mut acc = unsafe { s.load(yp.add(i)) };
        for (c, &vc) in v.iter().enumerate() {
            // SAFETY: i + LANES <= rows and c < v.len(): within the checked `W`.
            let wb = unsafe { s.load(wp.add(i + c * ld)) };
            acc = s.fma(wb, s.splat(vc), acc);
        }
        // SAFETY: as for the read.
        unsafe { s.store(yp.add(i), acc) };
    }
}

/// Assembles `S = H B + R` from `spad = H B` (`LANES x C`) and `R` into `s_out` (`C x C`,
/// column-major, exactly symmetric: from the lower triangle) and computes its inverse Cholesky
/// factor, for `C <= 8`: writes `L^{-1}` (lower triangular, row-major: entry `(i, j)` at
/// `i C + j`) into `linv` and returns `ln det S`. A pivot that is not larger than
/// `C eps` times its diagonal entry (zero, negative, NaN or lost to rounding) is returned as
/// `Err((pivot, value))`, as by [`small::cholesky`].
///
/// It factors `a = U D U^T` (`U` unit lower triangular, `D` diagonal) right-looking with the
/// columns of `a` as vectors (lanes = rows), so that the chain of dependent operations from one
/// pivot to the next is one division, one multiplication and one multiply-add, and then forms
/// `L^{-1} = D^{-1/2} U^{-1}` with the rows of `U^{-1}` as vectors (lanes = columns).
#[inline(always)]
fn factor_small<S: Simd, const C: usize>(
    s: S,
    spad: &[f64],
    r: MatRef<'_, f64>,
    s_out: &mut [f64],
    linv: &mut [f64],
) -> Result<f64, (usize, f64)> {
    assert!(C <= LANES && spad.len() >= C * LANES && s_out.len() >= C * C);
    assert!(linv.len() >= C * C && (r.nrows(), r.ncols()) == (C, C));
    let tol = C as f64 * f64::EPSILON;
    // S = H B + (R + R^T) / 2: column c is column c of `spad` (rows C.. are zero) plus the
    // symmetric part of R; written to `s_out` from its lower triangle, mirrored.
    let (sp, rp, rrs, rcs) = (spad.as_ptr(), r.as_ptr(), r.row_stride(), r.col_stride());
    let mut col = [s.zero(); C];
    for (c, col) in col.iter_mut().enumerate() {
        let mut rc = [0.0f64; LANES];
        for (a, rc) in rc.iter_mut().enumerate().take(C) {
            // SAFETY: a, c < C and `r` is C x C.
            let (rac, rca) = unsafe {
                (
                    *rp.offset(a as isize * rrs + c as isize * rcs),
                    *rp.offset(c as isize * rrs + a as isize * rcs),
                )
            };
            *rc = if a == c { rac } else { 0.5 * (rac + rca) };
        }
        // SAFETY: `spad` holds C columns of LANES values; `rc` has LANES values.
        *col = unsafe { s.add(s.load(sp.add(c * LANES)), s.load(rc.as_ptr())) };
        let lanes = s.to_array(*col);
        for a in c..C {
            s_out[a + c * C] = lanes[a];
            s_out[c + a * C] = lanes[a];
        }
    }
    let a: &[f64] = s_out;
    // u[j]: lanes i > j hold U[i, j] (lanes <= j are not used).
    let mut u = [[0.0f64; LANES]; C];
    let mut d = [0.0f64; C];
    let mut dinv = [0.0f64; C];
    for j in 0..C {
        let cj = s.to_array(col[j]);
        let dj = cj[j];
        // Written so that a NaN pivot also fails.
        if !(dj > tol * a[j + j * C].abs() && dj.is_finite()) {
            return Err((j, dj));
        }
        d[j] = dj;
        dinv[j] = 1.0 / dj;
        let uj = s.mul(col[j], s.splat(dinv[j]));
        u[j] = s.to_array(uj);
        // Right-looking update of the later columns: a[:, k] -= U[:, j] (U[k, j] d_j).
        for k in (j + 1)..C {
            col[k] = s.fnma(uj, s.splat(cj[k]), col[k]);
        }
    }
    // ln det = ln prod d_j: one `ln`, unless the product leaves a safe range.
    let (mut log_det, mut det_part) = (0.0, 1.0f64);
    for &dj in &d {
        det_part *= dj;
        if !(1e-150..=1e150).contains(&det_part) {
            log_det += det_part.ln();
            det_part = 1.0;
        }
    }
    // Rows of Y = U^{-1}: y[i] = e_i - sum_{c < i} U[i, c] y[c]; then row i of L^{-1} is
    // y[i] / sqrt(d_i).
    let mut y = [s.zero(); C];
    for i in 0..C {
        let mut e = [0.0f64; LANES];
        e[i] = 1.0;
        // SAFETY: `e` has LANES values.
        let mut t = unsafe { s.load(e.as_ptr()) };
        for c in 0..i {
            t = s.fnma(y[c], s.splat(u[c][i]), t);
        }
        y[i] = t;
        let row = s.to_array(s.mul(t, s.splat(dinv[i].sqrt())));
        linv[i * C..(i + 1) * C].copy_from_slice(&row[..C]);
    }
    Ok(log_det + det_part.ln())
}

/// Copies `src` (`r x c`, any strides) into the column-major `dst` with leading dimension
/// `padded(r)`, rows `r..padded(r)` zero. Returns whether every entry of `src` is finite.
#[inline(always)]
fn load_padded<S: Simd>(s: S, dst: &mut [f64], src: MatRef<'_, f64>) -> bool {
    let (r, c) = (src.nrows(), src.ncols());
    let ldd = padded(r);
    assert!(c * ldd <= dst.len());
    if r == 0 || c == 0 {
        return true;
    }
    if src.row_stride() != 1 {
        let mut bad = false;
        for (j, d) in dst.chunks_exact_mut(ldd).take(c).enumerate() {
            for (i, d) in d.iter_mut().enumerate() {
                *d = if i < r { src[(i, j)] } else { 0.0 };
                bad |= !d.is_finite();
            }
        }
        return !bad;
    }
    // Unit row stride (the usual case; faer pads the column stride): whole blocks, the last one
    // partial, without reading past the column. `v * 0` is zero for a finite `v` and NaN
    // otherwise, so one accumulator of those tells whether everything was finite.
    let (sp, cs, dp) = (src.as_ptr(), src.col_stride(), dst.as_mut_ptr());
    // Two accumulators (even and odd columns), so that they are not one chain of dependent
    // operations.
    let (mut acc0, mut acc1) = (s.zero(), s.zero());
    /// One column: `r` values from `col`, `ldd` values to `dst`.
    ///
    /// # Safety
    /// `col .. col + r` readable, `dst .. dst + ldd` writable, `r <= ldd = padded(r)`.
    #[inline(always)]
    unsafe fn column<S: Simd>(
        s: S,
        col: *const f64,
        dst: *mut f64,
        r: usize,
        ldd: usize,
        acc: &mut S::V,
    ) {
        if ldd == LANES {
            // SAFETY: rows 0..r of the column are entries of `src`, r <= LANES.
            let v = unsafe { s.load_partial(col, r) };
            *acc = s.fma(v, s.zero(), *acc);
            // SAFETY: LANES = ldd: the column of the checked `dst`.
            unsafe { s.store(dst, v) };
            return;
        }
        for i in (0..ldd).step_by(LANES) {
            // SAFETY: rows i..min(i + LANES, r) of the column are entries of `src`.
            let v = unsafe { s.load_partial(col.add(i), (r - i).min(LANES)) };
            *acc = s.fma(v, s.zero(), *acc);
            // SAFETY: i + LANES <= ldd: within the column of the checked `dst`.
            unsafe { s.store(dst.add(i), v) };
        }
    }
    let mut j = 0;
    while j + 2 <= c {
        // SAFETY: j + 1 < c: columns j and j + 1 of `src` and of `dst`.
        unsafe {
            column(
                s,
                sp.offset(j as isize * cs),
                dp.add(j * ldd),
                r,
                ldd,
                &mut acc0,
            );
            column(
                s,
                sp.offset((j + 1) as isize * cs),
                dp.add((j + 1) * ldd),
                r,
                ldd,
                &mut acc1,
            );
        }
        j += 2;
    }
    if j < c {
        // SAFETY: j < c: column j of `src` and of `dst`.
        unsafe {
            column(
                s,
                sp.offset(j as isize * cs),
                dp.add(j * ldd),
                r,
                ldd,
                &mut acc0,
            )
        };
    }
    let nonfinite = s.add(acc0, acc1);
    s.to_array(nonfinite).iter().all(|v| *v == 0.0)
}

/// `0.5 (a[i, j] + a[j, i])` for a small square input matrix.
#[inline(always)]
fn sym_at(a: MatRef<'_, f64>, i: usize, j: usize) -> f64 {
    if i == j {
        a[(i, i)]
    } else {
        0.5 * (a[(i, j)] + a[(j, i)])
    }
}

/// The buffers of a structured time update.
pub(crate) struct Predict<'a> {
    /// State dimension.
    pub n: usize,
    /// Leading dimension of `p` and `tt` (`padded(n)`).
    pub ld: usize,
    /// Number of dynamic states.
    pub k: usize,
    /// Covariance, `ld x n`, padding rows zero.
    pub p: &'a mut [f64],
    /// `phi_top` (`k x n`, checked for shape).
    pub phi_top: MatRef<'a, f64>,
    /// Scratch for `phi_top` with its rows padded to `padded(k)` (`padded(k) x n`).
    pub phi: &'a mut [f64],
    /// Scratch, `ld x k`.
    pub tt: &'a mut [f64],
    /// `q_top`, `k x k`.
    pub q: MatRef<'a, f64>,
    /// The state (`ld`, padding zero) and a scratch of `padded(k)`, when the state is
    /// propagated too.
    pub x: Option<(&'a mut [f64], &'a mut [f64])>,
}

/// The buffers of a measurement update.
pub(crate) struct Update<'a> {
    /// State dimension.
    pub n: usize,
    /// Leading dimension of the `n`-row buffers (`padded(n)`).
    pub ld: usize,
    /// Measurement dimension.
    pub m: usize,
    /// Covariance, `ld x n`, padding rows zero.
    pub p: &'a mut [f64],
    /// `H` (`m x n`, checked for shape).
    pub h_in: MatRef<'a, f64>,
    /// Scratch for `H` with its rows padded to `padded(m)` (`padded(m) x n`).
    pub h: &'a mut [f64],
    /// `R`, `m x m`.
    pub r: MatRef<'a, f64>,
    /// Scratch for `B = P H^T`, `ld x m`.
    pub b: &'a mut [f64],
    /// Scratch for `W = B L^{-T}`, `ld x m`.
    pub w: &'a mut [f64],
    /// The gain, `ld x m`.
    pub gain: &'a mut [f64],
    /// `S` (`m x m`, column-major, contiguous).
    pub s: &'a mut [f64],
    /// Scratch of [`update_scratch_len`]`(m)`.
    pub small: &'a mut [f64],
    /// The state part, when the state is updated too.
    pub x: Option<UpdateState<'a>>,
}

/// The state part of an [`Update`].
pub(crate) struct UpdateState<'a> {
    /// The state (`ld`, padding zero).
    pub x: &'a mut [f64],
    /// The measurement (`m`).
    pub z: &'a [f64],
    /// Receives the innovation (`m`).
    pub innovation: &'a mut [f64],
}

/// Why a step failed; nothing but scratch (and, for [`StepError::NotPositiveDefinite`], `S`)
/// has then been written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum StepError {
    /// `phi_top` or `H` has a non-finite entry.
    NonFinite,
    /// The Cholesky pivot `.0` of `S` is `.1`.
    NotPositiveDefinite(usize, f64),
}

impl From<(usize, f64)> for StepError {
    fn from((pivot, value): (usize, f64)) -> Self {
        StepError::NotPositiveDefinite(pivot, value)
    }
}

/// The outcome of an [`Update`]: `ln det S` and the NIS (0 without a state).
pub(crate) type UpdateResult = Result<(f64, f64), StepError>;

/// The outcome of a [`Predict`].
pub(crate) type PredictResult = Result<(), StepError>;

#[inline(always)]
fn predict_impl<S: Simd>(s: S, a: Predict<'_>) -> PredictResult {
    let Predict {
        n,
        ld,
        k,
        p,
        phi_top,
        phi,
        tt,
        q,
        x,
    } = a;
    if !load_padded(s, phi, phi_top) {
        return Err(StepError::NonFinite);
    }
    if k == 0 {
        return Ok(());
    }
    let phi: &[f64] = phi;
    let kp = padded(k);
    // T^T = P phi_top^T (ld x k); P is symmetric, so this is (phi_top P)^T.
    let tall = Shape {
        rows: ld,
        inner: n,
        cols: k,
        lda: ld,
        g_rs: kp,
        g_cs: 1,
        ldo: ld,
    };
    gemm(s, tt, p, phi, tall);
    // P'[..k, ..k] = phi_top T^T + q_top. P is no longer read, so the product (kp x k) goes
    // straight into its first k columns; its rows k..kp are zero (the padding rows of phi_top)
    // and rows k..n are overwritten below. One triangle, plus q_top, mirrored.
    let small = Shape {
        rows: kp,
        inner: n,
        cols: k,
        lda: kp,
        g_rs: 1,
        g_cs: ld,
        ldo: ld,
    };
    gemm(s, p, phi, tt, small);
    for b in 0..k {
        for a in b..k {
            let v = p[a + b * ld] + sym_at(q, a, b);
            p[a + b * ld] = v;
            p[b + a * ld] = v;
        }
    }
    // Rows k..n of Phi are identity rows: P'[k.., ..k] = T^T[k.., ..], P'[..k, k..] its mirror.
    copy_rows_and_mirror(s, p, tt, ld, n, k);
    if let Some((x, tmp)) = x {
        let vector = Shape {
            rows: kp,
            inner: n,
            cols: 1,
            lda: kp,
            g_rs: 1,
            g_cs: 0,
            ldo: kp,
        };
        gemm(s, tmp, phi, x, vector);
        x[..k].copy_from_slice(&tmp[..k]);
    }
    Ok(())
}

/// The off-diagonal blocks of the structured predict: `P[k..n, b] = T^T[k..n, b]` and
/// `P[b, k..n] = T^T[k..n, b]` for `b < k`, with `T^T` in `tt` (`ld x k`, padding rows zero).
#[inline(always)]
fn copy_rows_and_mirror<S: Simd>(s: S, p: &mut [f64], tt: &[f64], ld: usize, n: usize, k: usize) {
    assert!(k <= n && n <= ld && ld.is_multiple_of(LANES));
    assert!(n * ld <= p.len() && k * ld <= tt.len());
    let (pp, tp) = (p.as_mut_ptr(), tt.as_ptr());
    let first_block = k.div_ceil(LANES) * LANES;
    for b in 0..k {
        for i in k..first_block.min(ld) {
            // SAFETY: b < k <= n and i < ld: within both checked buffers.
            unsafe { *pp.add(i + b * ld) = *tp.add(i + b * ld) };
        }
        for i in (first_block..ld).step_by(LANES) {
            // SAFETY: i + LANES <= ld and b < k <= n: within both checked buffers.
            unsafe { s.store(pp.add(i + b * ld), s.load(tp.add(i + b * ld))) };
        }
        for j in k..n {
            // SAFETY: j < n, b < k <= n: within both checked buffers.
            unsafe { *pp.add(b + j * ld) = *tp.add(j + b * ld) };
        }
    }
}

/// Length of the scratch of an update with `m` components.
pub(crate) fn update_scratch_len(m: usize) -> usize {
    let mp = padded(m);
    3 * m * m + mp * m + mp + m
}

#[inline(always)]
fn update_impl<S: Simd>(s: S, u: Update<'_>) -> UpdateResult {
    let Update {
        n,
        ld,
        m,
        p,
        h_in,
        h,
        r,
        b,
        w,
        gain,
        s: s_mat,
        small,
        x,
    } = u;
    if !load_padded(s, h, h_in) {
        return Err(StepError::NonFinite);
    }
    if m == 0 {
        return Ok((0.0, 0.0));
    }
    let h: &[f64] = h;
    let mp = padded(m);
    let mm = m * m;
    let (linv, rest) = small.split_at_mut(mm);
    let (t1, rest) = rest.split_at_mut(mm);
    let (t2, rest) = rest.split_at_mut(mm);
    let (spad, rest) = rest.split_at_mut(mp * m);
    let (hx, rest) = rest.split_at_mut(mp);
    let v = &mut rest[..m];
    // B = P H^T (ld x m)
    let tall = Shape {
        rows: ld,
        inner: n,
        cols: m,
        lda: ld,
        g_rs: mp,
        g_cs: 1,
        ldo: ld,
    };
    gemm(s, b, p, h, tall);
    // S = H B + R (the product is mp x m): one triangle, plus R, mirrored.
    let small_rows = Shape {
        rows: mp,
        inner: n,
        cols: m,
        lda: mp,
        g_rs: 1,
        g_cs: ld,
        ldo: mp,
    };
    gemm(s, spad, h, b, small_rows);
    // S, L^{-1} (row-major) and ln det S.
    let log_det = if m <= MAX_COLS {
        with_cols!(m, factor_small::<S>(s, spad, r, s_mat, linv))?
    } else {
        for c in 0..m {
            for a in c..m {
                let (rac, rca) = (r[(a, c)], r[(c, a)]);
                let v = spad[a + c * mp] + if a == c { rac } else { 0.5 * (rac + rca) };
                s_mat[a + c * m] = v;
                s_mat[c + a * m] = v;
            }
        }
        t1[..mm].copy_from_slice(&s_mat[..mm]);
        let log_det = small::cholesky(&mut t1[..mm], m)?;
        small::spd_inverse_from_cholesky(t2, linv, &t1[..mm], m);
        // `linv` is column-major here: transpose it.
        t1[..mm].copy_from_slice(&linv[..mm]);
        for i in 0..m {
            for j in 0..m {
                linv[i * m + j] = t1[i + j * m];
            }
        }
        log_det
    };
    let linv: &[f64] = linv;
    // W = B L^{-T} and K = B S^{-1} = W L^{-1} (ld x m each).
    if m <= MAX_COLS {
        with_cols!(m, solve_rows::<S>(s, w, gain, b, linv, ld));
    } else {
        let mut shape = Shape {
            rows: ld,
            inner: m,
            cols: m,
            lda: ld,
            g_rs: 1,
            g_cs: m,
            ldo: ld,
        };
        gemm(s, w, b, linv, shape);
        (shape.g_rs, shape.g_cs) = (m, 1);
        gemm(s, gain, w, linv, shape);
    }
    // P -= W W^T, exactly symmetric.
    rank_update(s, p, w, ld, ld, n, m);
    let mut nis = 0.0;
    if let Some(UpdateState { x, z, innovation }) = x {
        // nu = z - H x; v = L^{-1} nu; NIS = |v|^2; x += K nu = W v.
        let vector = Shape {
            rows: mp,
            inner: n,
            cols: 1,
            lda: mp,
            g_rs: 1,
            g_cs: 0,
            ldo: mp,
        };
        gemm(s, hx, h, x, vector);
        for a in 0..m {
            innovation[a] = z[a] - hx[a];
        }
        for (i, vi) in v.iter_mut().enumerate() {
            let mut t = 0.0;
            for c in 0..=i {
                t = s.madd(linv[i * m + c], innovation[c], t);
            }
            *vi = t;
            nis += t * t;
        }
        add_product(s, &mut x[..ld], w, ld, v);
    }
    Ok((log_det, nis))
}

/// Structured time update (see [`Predict`] and
/// [`predict_structured`](crate::predict::predict_structured) for the algebra).
pub(crate) fn predict_structured(isa: Isa, a: Predict<'_>) -> PredictResult {
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Isa::Avx512` is only used when the CPU has been detected to support it.
        Isa::Avx512 => unsafe { x86::predict_avx512(a) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, for AVX2 and FMA.
        Isa::Avx2 => unsafe { x86::predict_avx2(a) },
        _ => {
            crate::gemm::clear_upper_avx_state();
            predict_impl(Portable, a)
        }
    }
}

/// Measurement update (see the module documentation for the algebra).
pub(crate) fn update(isa: Isa, u: Update<'_>) -> UpdateResult {
    match isa {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Isa::Avx512` is only used when the CPU has been detected to support it.
        Isa::Avx512 => unsafe { x86::update_avx512(u) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above, for AVX2 and FMA.
        Isa::Avx2 => unsafe { x86::update_avx2(u) },
        _ => {
            crate::gemm::clear_upper_avx_state();
            update_impl(Portable, u)
        }
    }
}
