//! The noise levels by the exact Gaussian likelihood of the data, with profile-likelihood
//! intervals.
//!
//! Why not only the Allan fit ([`crate::fit`]): the Allan estimates at long averaging times have
//! few degrees of freedom and skewed distributions, and least squares on them cannot give honest
//! intervals for the walk (docs/noise.md, "What the checks say"). The likelihood of the data
//! themselves has none of that: it is exact for the model, and its profile gives asymmetric
//! intervals that are longer upwards where the data say little.
//!
//! ## Model
//!
//! Per axis and static interval, the rate `y(t) = b(t) + g(t) + white(t)`:
//!
//! - `white`: white rate noise of two-sided density `N^2` (`N` the deviation of a 1-s average,
//!   the [`crate::fit::Term::White`] convention);
//! - `b`: a bias random walk, `b(t) = b0 + K W(t)` ([`crate::fit::Term::RandomWalk`]'s `K`);
//!   its start `b0` is a nuisance with a diffuse prior (each interval's own: a constant bias
//!   is not noise, and the restricted likelihood that results does not bias the variances the
//!   way an estimated mean does);
//! - `g` (optional): a first-order Gauss-Markov bias, stationary, deviation `sigma`,
//!   correlation time `tc` (an instability with a time scale).
//!
//! ## Block means and their exact moments
//!
//! A 4-h record at 100 Hz has 1.44 million samples per axis, and the fit evaluates the
//! likelihood hundreds of times. The samples are therefore averaged in blocks of `M` records
//! (duration `T = M tau0`), and the model is written exactly for
//! the block means (no approximation: the block likelihood is the likelihood of the block means
//! under the continuous model; only the information within a block is given up, which costs the
//! white level a little precision and the walk nothing). With the state at a block's start,
//!
//! ```text
//! y_j = b_j + a g_j + v_j,        b_{j+1} = b_j + w_j,        g_{j+1} = phi g_j + eta_j
//! v_j = u_j + xi_j + e_j          (the within-block parts of the walk, the Gauss-Markov bias, the white noise)
//! var e = N^2 / T,   var u = K^2 T / 3,   var w = K^2 T,   cov(u, w) = K^2 T / 2
//! phi = exp(-x), x = T / tc,   a = (1 - phi) / x,   var eta = sigma^2 (1 - phi^2)
//! var xi = 2 sigma^2 (x - 2 (1 - e^-x) + (1 - e^-2x) / 2) / x^2
//! cov(xi, eta) = 2 sigma^2 ((1 - e^-x) - (1 - e^-2x) / 2) / x
//! ```
//!
//! (`u = (1/T) int_0^T (b(t) - b_j) dt`, `xi` likewise for `g` without its decay of `g_j`; the
//! integrals of the Wiener process give the moments.) The measurement noise is correlated with
//! the process noise, which the filter below carries exactly (scalar algebra). A shorter last
//! block of an interval has its own `T`. `tests::block_likelihood_is_the_dense_gaussian` checks
//! the filter against the Gaussian density of the block means built from the covariance of the
//! single samples.
//!
//! The block length ([`fit_ml`]): [`BLOCKS_PER_CORRELATION`] times the sensor's correlation
//! length ([`correlation_records`]: the last lag at which the autocorrelation of the first
//! differences of the samples departs from that of white samples; a bias walk does not move
//! it), so that the sensor's own filter, which the model does not have, leaves the block means
//! nearly independent; at most a [`MIN_BLOCKS_PER_INTERVAL`]th of the longest interval (the
//! fit then says so, [`MlFit::below_correlation`]); and long enough for at most [`MAX_BLOCKS`]
//! blocks.
//!
//! ## Likelihood
//!
//! A Kalman filter in innovations form gives `-2 ln L = sum ln S_j + nu_j^2 / S_j` (the constant
//! `ln 2 pi` left out). The diffuse start is exact: the first block of an interval fixes `b`
//! (`b_1` given `y_0` has mean `y_0` and a variance from the moments above) and contributes
//! nothing; intervals are independent and their terms add. All variances scale together, so for
//! the white-and-walk model the scale is concentrated out and the fit is one-dimensional in
//! `K / N`: a grid over it, then Brent's method, so the maximum found is the global one.
//!
//! ## Selection
//!
//! The base model is white noise and a walk. The Gauss-Markov bias is added only when the
//! likelihood-ratio test says `p < 0.01`, with the ratio referred to chi-square with 2 degrees
//! of freedom (the two parameters it adds, `sigma` and `tc`). That reference is not exact: the
//! null value `sigma = 0` is on the boundary (which alone would make 2 degrees conservative) and
//! `tc` is not identified under the null (which makes them liberal); docs/noise.md reports how
//! often the seed set of white-and-walk recordings selects it (0 of 30). Its maximum is
//! searched by Nelder-Mead from five correlation times, `tc` kept between 10 blocks and 1000
//! longest intervals (`tc_penalty`).
//!
//! ## Intervals
//!
//! 68 % intervals from the profile likelihood: a parameter is fixed and the others
//! re-maximised, and the interval is where `-2 ln L` rises by at most 1 above the maximum
//! (Wilks). The ends are found by stepping out and regula falsi in the logarithm of the
//! parameter. A walk (or Gauss-Markov deviation) whose value 0 is inside that rise gets the
//! lower end 0. Quantisation is not in this model: at the block durations used it is invisible
//! (its block variance falls as `1 / T^2`); the Allan fit still reports it.
//!
//! ## Check
//!
//! The likelihood ratio only compares the two models; [`whiteness`] checks the selected one
//! against the data (the normalised innovations' sums over windows of 2, 4, 8, ... blocks).

use crate::NoiseError;
use crate::allan::check_intervals;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::ops::Range;

/// The most blocks the samples are averaged into (over all intervals): enough for the white
/// level to 0.3 % (68 % interval, each way) and a fit of a 4-h, 100-Hz axis in under a second.
pub const MAX_BLOCKS: usize = 50_000;

/// Rise of `-2 ln L` that bounds a 68.3 % profile interval (chi-square with 1 degree of
/// freedom).
pub const PROFILE_RISE: f64 = 1.0;

/// p-value below which the Gauss-Markov bias is added to the white-and-walk model.
pub const SELECTION_P: f64 = 0.01;

/// The block means of one axis: per static interval, `(mean rate, duration)` of each block.
#[derive(Clone, Debug, PartialEq)]
pub struct Blocks {
    /// Duration of a full block (s).
    pub block_s: f64,
    /// Per interval, the block means (rate unit, the interval's mean removed) and durations.
    pub intervals: Vec<Vec<(f64, f64)>>,
}

impl Blocks {
    /// Block the increments (one per record, SI: rad or m/s; `tau0_s` the record interval) of
    /// the static `intervals` into at most `max_blocks` blocks of equal length (the last of each
    /// interval shorter). Each interval's mean rate is removed (the likelihood with a diffuse
    /// start does not see it, and it keeps the numbers small).
    pub fn new(
        increments: &[f64],
        tau0_s: f64,
        intervals: &[Range<usize>],
        max_blocks: usize,
    ) -> Result<Blocks, NoiseError> {
        // The inputs are checked by `of_length`.
        let total: usize = intervals.iter().map(|r| r.len()).sum();
        let m = total.div_ceil(max_blocks.max(1)).max(1);
        Blocks::of_length(increments, tau0_s, intervals, m)
    }

    /// Block the increments of the static `intervals` into blocks of `records` records each
    /// (the last of each interval shorter), as [`Blocks::new`] does.
    pub fn of_length(
        increments: &[f64],
        tau0_s: f64,
        intervals: &[Range<usize>],
        records: usize,
    ) -> Result<Blocks, NoiseError> {
        if !(tau0_s.is_finite() && tau0_s > 0.0) {
            return Err(NoiseError::BadInterval0(tau0_s));
        }
        check_intervals(increments.len(), intervals)?;
        if let Some(i) = increments.iter().position(|x| !x.is_finite()) {
            return Err(NoiseError::NotFinite { record: i });
        }
        let m = records.max(1);
        let mut out = Vec::new();
        for r in intervals {
            let data = &increments[r.clone()];
            let mean = data.iter().sum::<f64>() / data.len() as f64;
            let blocks: Vec<(f64, f64)> = data
                .chunks(m)
                .map(|c| {
                    let s: f64 = c.iter().map(|v| v - mean).sum();
                    let d = c.len() as f64 * tau0_s;
                    (s / d, d)
                })
                .collect();
            out.push(blocks);
        }
        let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
        if out.iter().all(|b| b.len() < 3) {
            return Err(NoiseError::TooShort { longest });
        }
        Ok(Blocks {
            block_s: m as f64 * tau0_s,
            intervals: out,
        })
    }

    /// Number of blocks.
    pub fn len(&self) -> usize {
        self.intervals.iter().map(Vec::len).sum()
    }

    /// Whether there is no block.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Innovations the likelihood has: blocks minus one per interval (the diffuse start).
    pub fn innovations(&self) -> usize {
        self.intervals
            .iter()
            .map(|b| b.len().saturating_sub(1))
            .sum()
    }

    /// Longest interval (s).
    pub fn longest_s(&self) -> f64 {
        self.intervals
            .iter()
            .map(|b| b.iter().map(|x| x.1).sum::<f64>())
            .fold(0.0, f64::max)
    }
}

/// Parameters of the model (SI; module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    /// White level `N` (rad/s or m/s^2 of a 1-s average).
    pub white: f64,
    /// Walk `K` (rad/s/sqrt(s) or m/s^2/sqrt(s)); may be 0.
    pub walk: f64,
    /// Gauss-Markov bias `(sigma, correlation time in s)`, if any.
    pub gauss_markov: Option<(f64, f64)>,
}

impl Model {
    /// The model's Allan variance at `tau_s` (to draw it over the measured curve): white
    /// `N^2 / tau`, walk `K^2 tau / 3`, and the first-order Gauss-Markov bias's
    /// `(2 sigma^2 tc / tau) (1 - (tc / 2 tau) (3 - 4 e^(-tau/tc) + e^(-2 tau/tc)))`
    /// (IEEE Std 952-1997, annex C, with `q_c^2 = 2 sigma^2 / tc`).
    pub fn avar(&self, tau_s: f64) -> f64 {
        let mut v = self.white * self.white / tau_s + self.walk * self.walk * tau_s / 3.0;
        if let Some((sigma, tc)) = self.gauss_markov {
            let x = tau_s / tc;
            let bracket = if x < 1e-3 {
                // 1 - (3 - 4 e^-x + e^-2x) / (2x) = x^2/3 - x^3/4 + 7 x^4/60 - ..., which the
                // closed form cancels to below x = 1e-3.
                x * x * (1.0 / 3.0 - x / 4.0 + 7.0 * x * x / 60.0)
            } else {
                1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x)
            };
            v += 2.0 * sigma * sigma / x * bracket;
        }
        v
    }
}

impl Model {
    /// The variance of whole-second means about their own rest's mean that the white noise
    /// and the walk imply, pooled over rests of `whole_seconds` seconds (those of fewer than two
    /// left out; `None` without any): what a scatter of 1-s means inside rests measures
    /// (`calibrate`'s white noise, `calib::estimate::hand_turned::white_noise_at_rest`). Each
    /// 1-s mean has the white variance `N^2`; a walk adds, in a rest of `n` seconds,
    /// `K^2 (sum_i V_i - S / n) / (n - 1)` with `V_i = i + 1/3` the variance of the `i`-th
    /// mean of a walk started at 0 and `S` the sum of all their covariances
    /// (`i + 1/2` for `i < j`). A Gauss-Markov bias is not in it.
    pub fn one_second_scatter(&self, whole_seconds: &[usize]) -> Option<f64> {
        let (mut ss, mut dof) = (0.0, 0usize);
        for &n in whole_seconds.iter().filter(|&&n| n >= 2) {
            let nf = n as f64;
            let sum_v = nf * (nf - 1.0) / 2.0 + nf / 3.0;
            let cross: f64 = (0..n)
                .map(|i| (i as f64 + 0.5) * (nf - 1.0 - i as f64))
                .sum();
            let walk_ss = sum_v - (sum_v + 2.0 * cross) / nf;
            ss += self.white * self.white * (nf - 1.0) + self.walk * self.walk * walk_ss;
            dof += n - 1;
        }
        (dof > 0).then(|| ss / dof as f64)
    }
}

/// The per-block moments of the model for a block of duration `t` (module docs).
#[derive(Clone, Copy, Debug)]
struct Moments {
    /// var v (all within-block noise).
    r: f64,
    /// var w, cov(u, w).
    qb: f64,
    cb: f64,
    /// `R + Q_b - 2 C_b` and `Q_b R - C_b^2` (walk-only filter, a stable form of its update).
    d1: f64,
    d2: f64,
    /// Gauss-Markov: phi, a, var eta, cov(xi, eta), its variance.
    phi: f64,
    a: f64,
    qg: f64,
    cg: f64,
    s2: f64,
}

impl Moments {
    fn new(m: &Model, t: f64) -> Moments {
        let k2 = m.walk * m.walk;
        let (qb, cb) = (k2 * t, 0.5 * k2 * t);
        let mut r = m.white * m.white / t + k2 * t / 3.0;
        let (mut phi, mut a, mut qg, mut cg, mut s2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        if let Some((sigma, tc)) = m.gauss_markov {
            s2 = sigma * sigma;
            let x = t / tc;
            let e1 = -(-x).exp_m1(); // 1 - e^-x
            let e2 = -(-2.0 * x).exp_m1(); // 1 - e^-2x
            phi = 1.0 - e1;
            a = if x < 1e-4 {
                1.0 - 0.5 * x + x * x / 6.0
            } else {
                e1 / x
            };
            qg = s2 * e2;
            // Below x = 0.1 the closed forms cancel (to O(x^3) and O(x^2)): their Taylor
            // series, the coefficients of x^n in x - 2 (1 - e^-x) + (1 - e^-2x) / 2 and in
            // (1 - e^-x) - (1 - e^-2x) / 2 being (-1)^n (2 - 2^(n-1)) / n! and
            // (-1)^(n+1) (1 - 2^(n-1)) / n!.
            let (vxi, cxi) = if x < 0.1 {
                let (mut v, mut c) = (0.0, 0.0);
                let (mut fact, mut p2, mut xn) = (1.0, 0.5, 1.0 / (x * x)); // n!, 2^(n-1), x^(n-2)
                let mut sign = 1.0; // (-1)^n
                for n in 1..=16 {
                    fact *= n as f64;
                    p2 *= 2.0;
                    xn *= x;
                    sign = -sign;
                    if n >= 2 {
                        c += -sign * (1.0 - p2) / fact * xn * x;
                    }
                    if n >= 3 {
                        v += sign * (2.0 - p2) / fact * xn;
                    }
                }
                (2.0 * s2 * v, 2.0 * s2 * c)
            } else {
                (
                    2.0 * s2 * (x - 2.0 * e1 + 0.5 * e2) / (x * x),
                    2.0 * s2 * (e1 - 0.5 * e2) / x,
                )
            };
            r += vxi;
            cg = cxi;
        }
        Moments {
            r,
            qb,
            cb,
            d1: r + qb - 2.0 * cb,
            d2: qb * r - cb * cb,
            phi,
            a,
            qg,
            cg,
            s2,
        }
    }
}

/// Sums of the filter: `sum ln S`, `sum nu^2 / S` and the number of innovations.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    ln_s: f64,
    quad: f64,
    n: usize,
}

impl Sums {
    fn neg2ll(self) -> f64 {
        self.ln_s + self.quad
    }
}

/// Run the filter over every interval (module docs, "Likelihood").
fn filter(blocks: &Blocks, model: &Model) -> Sums {
    filter_with(blocks, model, |_, _| {})
}

/// The filter, handing every normalised innovation `nu / sqrt(S)` with its interval's index
/// to `on` (a no-op for the likelihood: monomorphised, it costs nothing there).
fn filter_with<F: FnMut(usize, f64)>(blocks: &Blocks, model: &Model, mut on: F) -> Sums {
    let mut sums = Sums::default();
    let mut prod = LnProduct::default();
    let full = Moments::new(model, blocks.block_s);
    for (index, iv) in blocks.intervals.iter().enumerate() {
        if iv.len() < 2 {
            continue;
        }
        let moments = |d: f64| {
            if d == blocks.block_s {
                full
            } else {
                Moments::new(model, d)
            }
        };
        let c0 = moments(iv[0].1);
        if model.gauss_markov.is_none() {
            // Walk only: diffuse start, b_1 | y_0 ~ (y_0, R + Q - 2C).
            let mut m = iv[0].0;
            let mut p = c0.d1;
            for &(y, d) in &iv[1..] {
                let c = moments(d);
                let s = p + c.r;
                let inv = 1.0 / s;
                let nu = y - m;
                prod.push(s);
                sums.quad += nu * nu * inv;
                on(index, nu * inv.sqrt());
                m += (p + c.cb) * inv * nu;
                // P' = P + Q - (P + C)^2 / S, written without the cancellation.
                p = (p * c.d1 + c.d2) * inv;
            }
        } else {
            // Walk and Gauss-Markov: state (b, g), diffuse b, stationary g.
            let (mut mb, mut mg) = (iv[0].0, 0.0);
            let mut pbb = c0.a * c0.a * c0.s2 + c0.d1;
            let mut pbg = -c0.a * c0.phi * c0.s2 - c0.cg;
            let mut pgg = c0.s2;
            for &(y, d) in &iv[1..] {
                let c = moments(d);
                let hpb = pbb + c.a * pbg;
                let hpg = pbg + c.a * pgg;
                let s = hpb + c.a * hpg + c.r;
                let nu = y - mb - c.a * mg;
                prod.push(s);
                sums.quad += nu * nu / s;
                on(index, nu / s.sqrt());
                let kb = hpb + c.cb;
                let kg = c.phi * hpg + c.cg;
                mb += kb / s * nu;
                mg = c.phi * mg + kg / s * nu;
                pbb = pbb + c.qb - kb * kb / s;
                pbg = c.phi * pbg - kb * kg / s;
                pgg = c.phi * c.phi * pgg + c.qg - kg * kg / s;
            }
        }
        sums.n += iv.len() - 1;
    }
    sums.ln_s = prod.ln();
    sums
}

/// `sum ln S` as the logarithm of a running product, rescaled before it leaves the range of
/// `f64`: one logarithm per few hundred blocks instead of one per block (the filter's cost was
/// mostly the logarithm).
#[derive(Clone, Copy, Debug)]
struct LnProduct {
    prod: f64,
    ln: f64,
}

impl Default for LnProduct {
    fn default() -> Self {
        LnProduct { prod: 1.0, ln: 0.0 }
    }
}

impl LnProduct {
    #[inline]
    fn push(&mut self, s: f64) {
        self.prod *= s;
        if !(1e-150..=1e150).contains(&self.prod) {
            self.ln += self.prod.ln();
            self.prod = 1.0;
        }
    }

    fn ln(self) -> f64 {
        self.ln + self.prod.ln()
    }
}

/// The check of a model against the data: under the model the normalised innovations
/// `nu / sqrt(S)` are independent standard normal. Their sums over non-overlapping windows of
/// `w = 2, 4, 8, ...` blocks (within each interval, while there are at least 10 windows) then
/// have variance `w`: `sum (window sum)^2 / w` is chi-square with as many degrees of freedom as
/// windows. A misfit at some time scale (a correlation the model lacks, a walk it has wrong)
/// shows as too much or too little variance at the windows of that length. Each window length
/// gets a two-sided p-value; their smallest, times the number of lengths (Bonferroni: the
/// lengths are nested and correlated, which this bound allows), is the check's p-value.
/// Windows of one block are left out: the fitted scale makes their sum what it should be.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Whiteness {
    /// The check's p-value (Bonferroni over the window lengths).
    pub p_value: f64,
    /// The window length (blocks) with the smallest p-value.
    pub window_blocks: usize,
    /// The variance of the window sums there relative to the model's (1 under the model).
    pub variance_ratio: f64,
}

/// The whiteness check of `model` on `blocks` (see [`Whiteness`]); `None` with fewer than 20
/// innovations.
pub fn whiteness(blocks: &Blocks, model: &Model) -> Option<Whiteness> {
    let mut e: Vec<Vec<f64>> = vec![Vec::new(); blocks.intervals.len()];
    filter_with(blocks, model, |i, x| e[i].push(x));
    let mut tests = Vec::new();
    let mut w = 2;
    loop {
        let (mut stat, mut windows) = (0.0, 0usize);
        for iv in &e {
            for c in iv.chunks_exact(w) {
                let sum: f64 = c.iter().sum();
                stat += sum * sum / w as f64;
                windows += 1;
            }
        }
        if windows < 10 {
            break;
        }
        let f = ChiSquared::new(windows as f64).ok()?.cdf(stat);
        tests.push((2.0 * f.min(1.0 - f), w, stat / windows as f64));
        w *= 2;
    }
    let (p, w, ratio) = tests.iter().copied().min_by(|a, b| a.0.total_cmp(&b.0))?;
    Some(Whiteness {
        p_value: (p * tests.len() as f64).min(1.0),
        window_blocks: w,
        variance_ratio: ratio,
    })
}

/// `-2 ln L` of the block means under `model` (without the constant `n ln 2 pi`).
pub fn neg2_log_likelihood(blocks: &Blocks, model: &Model) -> f64 {
    filter(blocks, model).neg2ll()
}

/// `-2 ln L` with the common scale of all variances maximised out, for the model with white
/// level 1 and the other parameters as given: `(value, maximising white variance)`.
fn concentrated(blocks: &Blocks, ratio: &Model) -> (f64, f64) {
    let s = filter(blocks, ratio);
    let n = s.n as f64;
    let scale = s.quad / n;
    (n * scale.ln() + s.ln_s + n, scale)
}

/// Brent's minimisation of `f` on `[a, b]` from `x` (`f(x)` = `fx`), to `tol` in `x`.
fn brent(
    f: &mut dyn FnMut(f64) -> f64,
    mut a: f64,
    mut b: f64,
    x0: f64,
    fx0: f64,
    tol: f64,
) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105;
    let (mut x, mut w, mut v) = (x0, x0, x0);
    let (mut fx, mut fw, mut fv) = (fx0, fx0, fx0);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..100 {
        let xm = 0.5 * (a + b);
        let tol1 = tol + 1e-12 * x.abs();
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if p.abs() < (0.5 * q * etemp).abs() && p > q * (a - x) && p < q * (b - x) {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = if xm >= x { tol1 } else { -tol1 };
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + if d >= 0.0 { tol1 } else { -tol1 }
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, w, x) = (w, x, u);
            (fv, fw, fx) = (fw, fx, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, w) = (w, u);
                (fv, fw) = (fw, fu);
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    (x, fx)
}

/// Minimise `f` of one variable from `x0`: bracket the minimum by steps of `step` growing
/// downhill, then Brent. `(x, f(x))`.
fn minimise_1d(f: &mut dyn FnMut(f64) -> f64, x0: f64, step: f64, tol: f64) -> (f64, f64) {
    let f0 = f(x0);
    let (fp, fm) = (f(x0 + step), f(x0 - step));
    if f0 <= fp && f0 <= fm {
        return brent(f, x0 - step, x0 + step, x0, f0, tol);
    }
    let dir = if fp < fm { 1.0 } else { -1.0 };
    let (mut prev, mut cur, mut fcur) = (x0, x0 + dir * step, fp.min(fm));
    let mut h = step;
    for _ in 0..60 {
        h *= 2.0;
        let next = cur + dir * h;
        let fnext = f(next);
        if fnext >= fcur {
            let (lo, hi) = if dir > 0.0 {
                (prev, next)
            } else {
                (next, prev)
            };
            return brent(f, lo, hi, cur, fcur, tol);
        }
        (prev, cur, fcur) = (cur, next, fnext);
    }
    (cur, fcur)
}

/// Nelder-Mead minimisation of `f` from `x0` with initial steps `step`, to a spread of `ftol`
/// in `f` (or `max_eval` evaluations), restarted `restarts` times from the best point (a
/// collapsed simplex stops short of the minimum). `(x, f(x))`.
fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    x0: &[f64],
    step: f64,
    ftol: f64,
    max_eval: usize,
    restarts: usize,
) -> (Vec<f64>, f64) {
    let n = x0.len();
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for i in 0..n {
        let mut x = x0.to_vec();
        x[i] += step;
        let fx = f(&x);
        simplex.push((x, fx));
    }
    let mut evals = n + 1;
    let at = |c: &[f64], w: &[f64], t: f64| -> Vec<f64> {
        c.iter().zip(w).map(|(c, w)| c + t * (w - c)).collect()
    };
    let mut restarted = 0;
    loop {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = simplex[n].1 - simplex[0].1;
        if evals >= max_eval {
            break;
        }
        if spread <= ftol {
            if restarted >= restarts {
                break;
            }
            restarted += 1;
            let best = simplex[0].clone();
            simplex.truncate(1);
            for i in 0..n {
                let mut x = best.0.clone();
                x[i] += 0.1 * step;
                let fx = f(&x);
                simplex.push((x, fx));
            }
            evals += n;
            continue;
        }
        let mut c = vec![0.0; n];
        for (x, _) in &simplex[..n] {
            for (ci, xi) in c.iter_mut().zip(x) {
                *ci += xi / n as f64;
            }
        }
        let worst = simplex[n].0.clone();
        let xr = at(&c, &worst, -1.0);
        let fr = f(&xr);
        evals += 1;
        if fr < simplex[0].1 {
            let xe = at(&c, &worst, -2.0);
            let fe = f(&xe);
            evals += 1;
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < simplex[n].1 {
                let x = at(&c, &worst, -0.5);
                let fx = f(&x);
                (x, fx)
            } else {
                let x = at(&c, &worst, 0.5);
                let fx = f(&x);
                (x, fx)
            };
            evals += 1;
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (xc, fc);
            } else {
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    s.0 = at(&best, &s.0, 0.5);
                    s.1 = f(&s.0);
                }
                evals += n;
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// A level and its 68 % profile-likelihood interval.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Level {
    /// Maximum-likelihood value.
    pub value: f64,
    /// Lower end of the 68 % interval (0 when the value 0 is inside it).
    pub lower: f64,
    /// Upper end.
    pub upper: f64,
}

impl Level {
    /// The half-width on the side of `x`: `value - lower` below the value, `upper - value`
    /// above.
    pub fn half_width_toward(&self, x: f64) -> f64 {
        if x < self.value {
            self.value - self.lower
        } else {
            self.upper - self.value
        }
    }

    /// `(x - value)` in half-widths on its side (inside the interval: at most 1 in size).
    pub fn z(&self, x: f64) -> f64 {
        (x - self.value) / self.half_width_toward(x)
    }

    /// The mean of the two half-widths.
    pub fn mean_half_width(&self) -> f64 {
        0.5 * (self.upper - self.lower)
    }
}

/// A Gauss-Markov bias found in the data.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GaussMarkov {
    /// Its deviation (rad/s or m/s^2) with the profile interval.
    pub sigma: Level,
    /// Its correlation time (s), maximum-likelihood value.
    pub correlation_time_s: f64,
}

/// The maximum-likelihood fit of one axis.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MlFit {
    /// White level `N`.
    pub white: Level,
    /// Walk `K`.
    pub walk: Level,
    /// The Gauss-Markov bias, when the likelihood-ratio test selected it.
    pub gauss_markov: Option<GaussMarkov>,
    /// `-2 ln L` of the selected model at its maximum.
    pub neg2_log_likelihood: f64,
    /// Likelihood ratio (`-2 ln` of it) of the Gauss-Markov bias against white and walk.
    pub lr_statistic: f64,
    /// Its p-value, chi-square with 2 degrees of freedom (module docs).
    pub lr_p_value: f64,
    /// The whiteness check of the selected model's innovations ([`Whiteness`]): the check of
    /// the model against the data (the likelihood ratio only compares the two models).
    pub whiteness: Option<Whiteness>,
    /// Block duration (s).
    pub block_s: f64,
    /// Number of blocks.
    pub blocks: usize,
    /// The sensor's correlation time the blocks were chosen above (s; [`correlation_records`]
    /// times the record interval; 0 where not estimated).
    pub correlation_s: f64,
    /// Whether the Gauss-Markov correlation time sits at a bound of its search (10 blocks or
    /// 1000 longest intervals): then the value is the bound's, not the data's.
    pub tc_at_bound: bool,
    /// An oscillation in the samples ([`correlation_of`]): the blocks were chosen above its
    /// period rather than above the last correlated lag.
    #[serde(default)]
    pub oscillation: Option<Oscillation>,
}

/// An oscillation in an axis's samples ([`correlation_of`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Oscillation {
    /// Its period (s): the first lag at which the first differences' autocorrelation peaks
    /// positive.
    pub period_s: f64,
    /// Its root mean square in the rate (rad/s or m/s^2).
    pub rms: f64,
    /// The autocorrelation of the first differences at the period.
    pub autocorrelation: f64,
    /// The last lag at which the differences' autocorrelation departs from white (s): where
    /// the correlation search would have put the correlation time without it.
    pub correlated_to_s: f64,
}

impl MlFit {
    /// Record the correlation the blocks were chosen from (`tau0_s` the record interval).
    pub fn set_correlation(&mut self, c: &Correlation, tau0_s: f64) {
        self.correlation_s = c.records as f64 * tau0_s;
        self.oscillation = c.oscillation.map(|(p, r, rms)| Oscillation {
            period_s: p as f64 * tau0_s,
            rms: rms / tau0_s,
            autocorrelation: r,
            correlated_to_s: c.last_lag as f64 * tau0_s,
        });
    }

    /// Whether the blocks are shorter than [`BLOCKS_PER_CORRELATION`] correlation times (the
    /// cap of [`fit_ml`]): the sensor's own correlation may then show in the check.
    pub fn below_correlation(&self) -> bool {
        self.block_s < BLOCKS_PER_CORRELATION as f64 * self.correlation_s * (1.0 - 1e-9)
    }

    /// Whether the model passes its check against the data (whiteness p at least
    /// [`SELECTION_P`]); a fit without a check (too few innovations) does not.
    pub fn passes(&self) -> bool {
        self.whiteness.is_some_and(|w| w.p_value >= SELECTION_P)
    }

    /// The fitted model (maximum-likelihood values).
    pub fn model(&self) -> Model {
        Model {
            white: self.white.value,
            walk: self.walk.value,
            gauss_markov: self
                .gauss_markov
                .map(|g| (g.sigma.value, g.correlation_time_s)),
        }
    }
}

/// [`fit_base`] of blocks that hold at least three innovations, refused where it finds no
/// white noise.
fn checked_base(blocks: &Blocks) -> Result<(f64, f64, f64), NoiseError> {
    if blocks.innovations() < 3 {
        return Err(NoiseError::TooShort {
            longest: blocks.intervals.iter().map(Vec::len).max().unwrap_or(0),
        });
    }
    let (n, k, best) = fit_base(blocks);
    if !(n.is_finite() && n > 0.0) {
        return Err(NoiseError::NoNoise {
            tau_s: blocks.block_s,
        });
    }
    Ok((n, k, best))
}

/// The white-and-walk maximum: the ratio `K / N` on a grid, then Brent. `(N, K, -2 ln L)`.
fn fit_base(blocks: &Blocks) -> (f64, f64, f64) {
    let conc = |rho: f64| {
        concentrated(
            blocks,
            &Model {
                white: 1.0,
                walk: rho,
                gauss_markov: None,
            },
        )
    };
    // Crossover times sqrt(3) N / K from one block to 100 times the longest interval.
    let lo = (3f64.sqrt() / (100.0 * blocks.longest_s())).ln();
    let hi = (3f64.sqrt() / blocks.block_s).ln();
    let steps = 40;
    let grid: Vec<(f64, f64)> = (0..=steps)
        .map(|i| {
            let x = lo + (hi - lo) * i as f64 / steps as f64;
            (x, conc(x.exp()).0)
        })
        .collect();
    let (ib, _) = grid
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.1.total_cmp(&b.1.1))
        .expect("a grid");
    let zero = conc(0.0);
    let (mut best_rho, mut best) = (0.0, zero.0);
    let a = grid[ib.saturating_sub(1)].0;
    let b = grid[(ib + 1).min(steps)].0;
    let (x, fx) = brent(&mut |x| conc(x.exp()).0, a, b, grid[ib].0, grid[ib].1, 1e-7);
    if fx < best {
        best_rho = x.exp();
        best = fx;
    }
    let scale = conc(best_rho).1;
    let n = scale.sqrt();
    (n, best_rho * n, best)
}

/// Find where `g` (a rise of `-2 ln L` above its minimum, as a function of the logarithm of a
/// parameter) crosses `PROFILE_RISE`, going from `x0` (inside) in direction `dir`: steps from
/// `step0`, doubling, until outside, then the Illinois variant of regula falsi to 1e-3 in the
/// rise or 1e-4 in `x`. The root is sought in `sqrt(rise) - sqrt(PROFILE_RISE)`, which is
/// nearly linear where the profile is nearly quadratic: a step or two. `None` when it does not
/// cross within the search.
fn profile_end(g: &mut dyn FnMut(f64) -> f64, x0: f64, dir: f64, step0: f64) -> Option<f64> {
    let mut g = |x: f64| g(x).max(0.0).sqrt() - PROFILE_RISE.sqrt();
    let (mut xi, mut step) = (x0, step0);
    let mut gi = g(x0);
    let mut outside = None;
    for _ in 0..60 {
        let x = xi + dir * step;
        let gx = g(x);
        if gx > 0.0 {
            outside = Some((x, gx));
            break;
        }
        (xi, gi) = (x, gx);
        step *= 2.0;
    }
    let (mut xo, mut go) = outside?;
    // Illinois: the end kept twice in a row has its value halved, so that both ends move.
    let mut side = 0;
    for _ in 0..40 {
        if (xo - xi).abs() < 1e-4 {
            break;
        }
        let x = (xi * go - xo * gi) / (go - gi);
        let gx = g(x);
        if gx.abs() < 1e-3 {
            return Some(x);
        }
        if gx > 0.0 {
            (xo, go) = (x, gx);
            if side == 1 {
                gi *= 0.5;
            }
            side = 1;
        } else {
            (xi, gi) = (x, gx);
            if side == -1 {
                go *= 0.5;
            }
            side = -1;
        }
    }
    Some(0.5 * (xi + xo))
}

/// Profile intervals of `N` and `K` for the white-and-walk model at its maximum `(n, k, best)`.
fn base_levels(blocks: &Blocks, n: f64, k: f64, best: f64) -> (Level, Level) {
    let nll = |white: f64, walk: f64| {
        neg2_log_likelihood(
            blocks,
            &Model {
                white,
                walk,
                gauss_markov: None,
            },
        )
    };
    // K fixed: N re-maximised (1-D in ln N).
    let prof_k = |walk: f64| minimise_1d(&mut |x| nll(x.exp(), walk), n.ln(), 0.05, 1e-6).1;
    // N fixed: K re-maximised, K = 0 included.
    let k_floor = 3f64.sqrt() / (100.0 * blocks.longest_s()) * n;
    let prof_n = |white: f64| {
        let at0 = nll(white, 0.0);
        let start = if k > 0.0 { k.ln() } else { k_floor.ln() };
        let (_, f) = minimise_1d(&mut |x| nll(white, x.exp()), start, 0.3, 1e-5);
        f.min(at0)
    };
    let white = {
        let lo = profile_end(&mut |x| prof_n(x.exp()) - best, n.ln(), -1.0, 1e-3);
        let hi = profile_end(&mut |x| prof_n(x.exp()) - best, n.ln(), 1.0, 1e-3);
        Level {
            value: n,
            lower: lo.map_or(0.0, f64::exp),
            upper: hi.map_or(f64::INFINITY, f64::exp),
        }
    };
    let walk = {
        let zero_inside = prof_k(0.0) - best <= PROFILE_RISE;
        let start = if k > 0.0 { k.ln() } else { k_floor.ln() };
        let lower = if zero_inside || k == 0.0 {
            0.0
        } else {
            profile_end(&mut |x| prof_k(x.exp()) - best, start, -1.0, 0.02).map_or(0.0, f64::exp)
        };
        let upper = profile_end(&mut |x| prof_k(x.exp()) - best, start, 1.0, 0.02)
            .map_or(f64::INFINITY, f64::exp);
        Level {
            value: k,
            lower,
            upper,
        }
    };
    (white, walk)
}

/// The correlation times the Gauss-Markov bias may have: from 10 blocks to 1000 longest
/// intervals. Beyond the upper end it is a walk; below the lower end the block means see it as
/// white noise (it trades off against the white level, which then has no lower bound), and on
/// real sensors a correlation that short is the sensor's own low-pass filter, not a bias. A
/// penalty outside, on the logarithm `ln_tc`.
fn tc_penalty(blocks: &Blocks, ln_tc: f64) -> f64 {
    let (lo, hi) = (
        (10.0 * blocks.block_s).ln(),
        (1000.0 * blocks.longest_s()).ln(),
    );
    if ln_tc < lo {
        1e6 * (1.0 + lo - ln_tc)
    } else if ln_tc > hi {
        1e6 * (1.0 + ln_tc - hi)
    } else {
        0.0
    }
}

/// The maximum of the model with a Gauss-Markov bias, from the white-and-walk maximum:
/// Nelder-Mead on the logarithms of `K / N`, `sigma / N` and `tc` (scale concentrated out),
/// from several correlation times. `(model, -2 ln L)`.
fn fit_gauss_markov(blocks: &Blocks, n: f64, k: f64) -> (Model, f64) {
    let kmin = 3f64.sqrt() / (100.0 * blocks.longest_s());
    let rho_k = (k / n).max(kmin);
    let model_of = |p: &[f64]| Model {
        white: 1.0,
        walk: p[0].exp(),
        gauss_markov: Some((p[1].exp(), p[2].exp())),
    };
    let mut f = |p: &[f64]| concentrated(blocks, &model_of(p)).0 + tc_penalty(blocks, p[2]);
    let (t_lo, t_hi) = (10.0 * blocks.block_s, 0.5 * blocks.longest_s());
    let mut best: Option<(Vec<f64>, f64)> = None;
    let starts = 5;
    for i in 0..starts {
        let tc = if t_hi > t_lo {
            t_lo * (t_hi / t_lo).powf(i as f64 / (starts - 1) as f64)
        } else {
            t_lo
        };
        let x0 = [rho_k.ln(), (1.0 / tc.sqrt()).ln(), tc.ln()];
        let r = nelder_mead(&mut f, &x0, 1.0, 1e-4, 600, 2);
        if best.as_ref().is_none_or(|b| r.1 < b.1) {
            best = Some(r);
        }
    }
    let (p, fx) = best.expect("a start");
    let scale = concentrated(blocks, &model_of(&p)).1.sqrt();
    (
        Model {
            white: scale,
            walk: p[0].exp() * scale,
            gauss_markov: Some((p[1].exp() * scale, p[2].exp())),
        },
        fx,
    )
}

/// Profile intervals of `N`, `K` and `sigma` of the model with a Gauss-Markov bias at its
/// maximum `m` (`best`): each fixed in turn, the other three re-maximised by Nelder-Mead on
/// their logarithms.
fn gauss_markov_levels(blocks: &Blocks, m: &Model, best: f64) -> (Level, Level, Level) {
    let (sg, tc) = m.gauss_markov.expect("a Gauss-Markov model");
    let full = [m.white.ln(), m.walk.max(1e-300).ln(), sg.ln(), tc.ln()];
    let nll = |p: &[f64; 4]| {
        neg2_log_likelihood(
            blocks,
            &Model {
                white: p[0].exp(),
                walk: p[1].exp(),
                gauss_markov: Some((p[2].exp(), p[3].exp())),
            },
        ) + tc_penalty(blocks, p[3])
    };
    // The others re-maximised by Nelder-Mead, warm-started from the last profile point's
    // optimum (the ends are searched outwards and then inwards: neighbouring points).
    let warm = std::cell::Cell::new(full);
    let prof = |which: usize, x: f64| {
        let others: Vec<usize> = (0..4).filter(|&i| i != which).collect();
        let start = warm.get();
        let x0: Vec<f64> = others.iter().map(|&i| start[i]).collect();
        let mut f = |q: &[f64]| {
            let mut p = start;
            p[which] = x;
            for (&i, &v) in others.iter().zip(q) {
                p[i] = v;
            }
            nll(&p)
        };
        let (q, fq) = nelder_mead(&mut f, &x0, 0.05, 1e-3, 300, 1);
        let mut p = start;
        p[which] = x;
        for (&i, &v) in others.iter().zip(&q) {
            p[i] = v;
        }
        warm.set(p);
        fq
    };
    let level = |which: usize, may_be_zero: bool| {
        let v = full[which];
        warm.set(full);
        let lower = if may_be_zero && prof(which, v - 30.0) - best <= PROFILE_RISE {
            0.0
        } else {
            warm.set(full);
            profile_end(&mut |x| prof(which, x) - best, v, -1.0, 0.02).map_or(0.0, f64::exp)
        };
        warm.set(full);
        let upper = profile_end(&mut |x| prof(which, x) - best, v, 1.0, 0.02)
            .map_or(f64::INFINITY, f64::exp);
        Level {
            value: v.exp(),
            lower,
            upper,
        }
    };
    (level(0, false), level(1, true), level(2, true))
}

/// The maximum-likelihood fit of the blocks (module docs): white and walk, the Gauss-Markov
/// bias when the likelihood-ratio test selects it, profile intervals.
pub fn fit_blocks(blocks: &Blocks) -> Result<MlFit, NoiseError> {
    let (n, k, best) = checked_base(blocks)?;
    let (gm, gm_best) = fit_gauss_markov(blocks, n, k);
    let lr = (best - gm_best).max(0.0);
    let p = 1.0 - ChiSquared::new(2.0).expect("2 dof").cdf(lr);
    if p < SELECTION_P {
        let (white, walk, sigma) = gauss_markov_levels(blocks, &gm, gm_best);
        Ok(MlFit {
            white,
            walk,
            gauss_markov: Some(GaussMarkov {
                sigma,
                correlation_time_s: gm.gauss_markov.map_or(0.0, |g| g.1),
            }),
            neg2_log_likelihood: gm_best,
            lr_statistic: lr,
            lr_p_value: p,
            whiteness: whiteness(blocks, &gm),
            block_s: blocks.block_s,
            blocks: blocks.len(),
            correlation_s: 0.0,
            tc_at_bound: gm.gauss_markov.is_some_and(|(_, tc)| {
                let (lo, hi) = (10.0 * blocks.block_s, 1000.0 * blocks.longest_s());
                tc < lo * 1.01 || tc > hi / 1.01
            }),
            oscillation: None,
        })
    } else {
        let (white, walk) = base_levels(blocks, n, k, best);
        Ok(MlFit {
            white,
            walk,
            gauss_markov: None,
            neg2_log_likelihood: best,
            lr_statistic: lr,
            lr_p_value: p,
            whiteness: whiteness(
                blocks,
                &Model {
                    white: n,
                    walk: k,
                    gauss_markov: None,
                },
            ),
            block_s: blocks.block_s,
            blocks: blocks.len(),
            correlation_s: 0.0,
            tc_at_bound: false,
            oscillation: None,
        })
    }
}

/// The white-and-walk model alone (no Gauss-Markov search) fitted to `blocks`: the white level
/// and walk with their profile intervals. For comparing the walks of subsets of the rests
/// ([`crate::consistency`]): there one model's walk is set against another's, and the costly
/// Gauss-Markov search would only change what is compared.
pub fn fit_white_walk(blocks: &Blocks) -> Result<(Level, Level), NoiseError> {
    let (n, k, best) = checked_base(blocks)?;
    Ok(base_levels(blocks, n, k, best))
}

/// The maximum-likelihood fit of one axis: `increments` one per record (SI), record interval
/// `tau0_s`, static `intervals` (record index ranges, in order, not overlapping), blocked into
/// at most [`MAX_BLOCKS`] blocks.
pub fn fit_ml(
    increments: &[f64],
    tau0_s: f64,
    intervals: &[Range<usize>],
) -> Result<MlFit, NoiseError> {
    check_intervals(increments.len(), intervals)?;
    let correlation = correlation_of(increments, intervals);
    let k = correlation.records;
    // Blocks ten correlation lengths long, but no longer than a tenth of the longest interval:
    // with fewer blocks the white level and the check are no longer determined (a strongly
    // quantised axis whose quantisation error stays put for seconds, as on the Ferraris
    // accelerometer z, would otherwise leave fewer than three blocks per interval). Capped, the
    // fit says so ([`MlFit::below_correlation`]) and its check judges what the blocks keep.
    let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
    let cap = (longest / MIN_BLOCKS_PER_INTERVAL).max(1);
    let mut fit = fit_ml_blocks(
        increments,
        tau0_s,
        intervals,
        (BLOCKS_PER_CORRELATION * k).min(cap),
    )?;
    fit.set_correlation(&correlation, tau0_s);
    Ok(fit)
}

/// Blocks the longest interval is cut into at least ([`fit_ml`]'s cap on the block length).
pub const MIN_BLOCKS_PER_INTERVAL: usize = 10;

/// Block length per record of the sensor's correlation ([`correlation_records`]): block means
/// ten correlation lengths long are nearly independent (the correlation of neighbouring means
/// is about the correlation length over the block length) and the filter's deficit in their
/// variance is a few per cent at most.
pub const BLOCKS_PER_CORRELATION: usize = 10;

/// The sensor's correlation length in records, from the data: the last lag at which the
/// sample autocorrelation of the first differences of the increments (within each interval,
/// pooled over the intervals) departs from that of white increments, searched up to a tenth
/// of the longest interval (at most 1000 lags); 0 for white samples; the period of an
/// oscillation where the samples hold one ([`correlation_of`]).
///
/// Why the differences and not the increments themselves: a bias walk (or a slow Gauss-Markov
/// bias), which the likelihood models, makes the increments' autocorrelation significant at
/// every lag (the walk's share of their variance grows with the interval: on a 30-min rest
/// with 0.1 deg/h and 0.5 deg/h/sqrt(h) at 100 Hz, about 2 %, above the `3 / sqrt(n)` = 0.7 %
/// of a test), so a search for where it ends runs to its cap and the blocks grow to 100 s,
/// too few to determine the white level. The differences of white increments plus a walk have
/// autocorrelation `-1/2` at lag 1 and 0 beyond whatever the walk (its step adds a white
/// sample of a millionth of the white variance), while a sensor's own filter spanning `L`
/// records shows up to lag `L` (an `L`-record moving average: exactly at lag `L`, which is why
/// the last departing lag is taken, not the end of a leading run). The test is two-sided at
/// 1 % over all the lags searched (Bonferroni), each lag's standard deviation `sqrt(1.5 / n)`
/// (Bartlett's formula for the differences of white samples, `1 + 2 (1/2)^2 = 1.5`).
pub fn correlation_records(increments: &[f64], intervals: &[Range<usize>]) -> usize {
    correlation_of(increments, intervals).records
}

/// Autocorrelation of the first differences (at the period) from which a positive peak is
/// taken for an oscillation, besides being significant: an oscillation of period 5 records
/// with about 7 % of the samples' variance. Fixed before the first run on any data.
pub const OSCILLATION_MIN_AUTOCORRELATION: f64 = 0.05;

/// What the autocorrelation of the first differences says about a sensor's short-time
/// structure ([`correlation_of`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Correlation {
    /// The correlation length the blocks are chosen above (records): [`Self::last_lag`], or
    /// the oscillation's period where there is one.
    pub records: usize,
    /// The last lag at which the differences' autocorrelation departs from white (records).
    pub last_lag: usize,
    /// An oscillation: its period (records), the differences' autocorrelation there and the
    /// oscillation's root mean square in the increments.
    pub oscillation: Option<(usize, f64, f64)>,
}

/// [`correlation_records`] with the oscillation it looks for: a positive autocorrelation of
/// the first differences at a lag of 2 or more, significant (the same test) and at least
/// [`OSCILLATION_MIN_AUTOCORRELATION`]. A sensor's own low-pass filter (a moving average, a
/// first-order lag) and any bias process give the differences negative autocorrelations only;
/// a positive one at lag `P` is a periodic part of period about `P` records, and the first
/// lag at which it peaks is taken as that period. An oscillation that stays coherent keeps
/// the differences correlated at its multiples to the end of the search, and blocks ten times
/// that long (on a user's MEMS gyro, 94 s) take a flicker floor for white noise; but a block
/// mean over many of its periods averages it out (its variance falls as `1 / T^2`, the white
/// noise's as `1 / T`), so the blocks are chosen above its period instead. Its root mean
/// square in the increments: a periodic part of variance `v` and angular frequency
/// `omega = 2 pi / P` adds `v (2 - 2 cos omega) cos(omega k)` to the differences'
/// autocovariance at lag `k`, so at `k = P` it is `gamma_d(P) / (2 - 2 cos omega)`.
pub fn correlation_of(increments: &[f64], intervals: &[Range<usize>]) -> Correlation {
    let diffs: Vec<Vec<f64>> = intervals
        .iter()
        .filter(|r| r.end <= increments.len() && r.len() >= 3)
        .map(|r| {
            increments[r.clone()]
                .windows(2)
                .map(|w| w[1] - w[0])
                .collect()
        })
        .collect();
    let n: usize = diffs.iter().map(Vec::len).sum();
    let g0: f64 = diffs.iter().flatten().map(|v| v * v).sum();
    let longest = diffs.iter().map(Vec::len).max().unwrap_or(0);
    let max_lag = (longest / 10).clamp(1, 1000);
    let mut gk = vec![0.0; max_lag + 1];
    if n >= 10 {
        for (k, g) in gk.iter_mut().enumerate().skip(1) {
            *g = diffs
                .iter()
                .filter(|c| c.len() > k)
                .map(|c| c.iter().zip(&c[k..]).map(|(a, b)| a * b).sum::<f64>())
                .sum();
        }
    }
    correlation_from_sums(n, g0, &gk)
}

/// [`correlation_of`] from the sums: `n` differences, `g0` the sum of their squares, `gk[k]`
/// the sum of their products at lag `k` (`1 ..= gk.len() - 1`, the lags searched).
pub fn correlation_from_sums(n: usize, g0: f64, gk: &[f64]) -> Correlation {
    let none = Correlation {
        records: 0,
        last_lag: 0,
        oscillation: None,
    };
    if n < 10 || g0.is_nan() || g0 <= 0.0 || gk.len() < 2 {
        return none;
    }
    let max_lag = gk.len() - 1;
    let z = statrs::distribution::Normal::standard().inverse_cdf(1.0 - 0.005 / max_lag as f64);
    let threshold = z * (1.5 / n as f64).sqrt();
    let r = |k: usize| gk[k] / g0;
    let mut last = 0;
    for k in 1..=max_lag {
        let white = if k == 1 { -0.5 } else { 0.0 };
        if (r(k) - white).abs() > threshold {
            last = k;
        }
    }
    let oscillation = (2..=max_lag)
        .find(|&k| {
            let peak = r(k) >= r(k - 1) && (k == max_lag || r(k) >= r(k + 1));
            peak && r(k) > threshold && r(k) >= OSCILLATION_MIN_AUTOCORRELATION
        })
        .map(|p| {
            let omega = std::f64::consts::TAU / p as f64;
            let gamma = gk[p] / n as f64;
            (p, r(p), (gamma / (2.0 - 2.0 * omega.cos())).max(0.0).sqrt())
        });
    Correlation {
        records: oscillation.map_or(last, |o| o.0),
        last_lag: last,
        oscillation,
    }
}

/// [`fit_ml`] on blocks of at least `min_records` records (more where [`MAX_BLOCKS`] needs
/// them).
pub fn fit_ml_blocks(
    increments: &[f64],
    tau0_s: f64,
    intervals: &[Range<usize>],
    min_records: usize,
) -> Result<MlFit, NoiseError> {
    let total: usize = intervals.iter().map(|r| r.len()).sum();
    let m = total.div_ceil(MAX_BLOCKS).max(min_records).max(1);
    let blocks = Blocks::of_length(increments, tau0_s, intervals, m)?;
    fit_blocks(&blocks)
}

#[cfg(test)]
#[allow(clippy::single_range_in_vec_init)] // one interval
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// The covariance of the means of consecutive blocks `(start, duration)` under the
    /// continuous model, walk started at 0 at time 0 and Gauss-Markov stationary, by the
    /// integrals of the processes (independent of the filter's moments).
    fn dense_cov(spans: &[(f64, f64)], m: &Model) -> DMatrix<f64> {
        let n = spans.len();
        let k2 = m.walk * m.walk;
        DMatrix::from_fn(n, n, |i, j| {
            let (si, ti) = spans[i];
            let (sj, tj) = spans[j];
            // Walk: mean over block i of K^2 min(s, t); for disjoint blocks the earlier's
            // midpoint, on the diagonal start + T/3.
            let mut c = if i == j {
                k2 * (si + ti / 3.0)
            } else {
                let (s, t) = if si < sj { (si, ti) } else { (sj, tj) };
                k2 * (s + t / 2.0)
            };
            if i == j {
                c += m.white * m.white / ti;
            }
            if let Some((sigma, tc)) = m.gauss_markov {
                let b = 1.0 / tc;
                let s2 = sigma * sigma;
                if i == j {
                    let x = b * ti;
                    c += 2.0 * s2 * (x + (-x).exp_m1()) / (x * x);
                } else {
                    let ((s1, t1), (s2_, t2)) = if si < sj {
                        ((si, ti), (sj, tj))
                    } else {
                        ((sj, tj), (si, ti))
                    };
                    // (1/(t1 t2)) int_{block 1} int_{block 2} s2 e^{-b (v - u)} dv du
                    let a1 = (b * (s1 - s2_)).exp() * (b * t1).exp_m1() / b;
                    let a2 = (1.0 - (-b * t2).exp()) / b;
                    c += s2 * a1 * a2 / (t1 * t2);
                }
            }
            c
        })
    }

    /// The restricted (diffuse-mean) `-2 ln L` of `y` with covariance `sigma0` plus an
    /// infinitely wide common offset: `ln det S0 + ln(1' S0^-1 1) + y' P y`.
    fn dense_diffuse(y: &[f64], sigma0: &DMatrix<f64>) -> f64 {
        let n = y.len();
        let chol = sigma0.clone().cholesky().expect("positive definite");
        let ln_det: f64 = chol.l().diagonal().iter().map(|d| 2.0 * d.ln()).sum();
        let y = DVector::from_column_slice(y);
        let one = DVector::from_element(n, 1.0);
        let si_y = chol.solve(&y);
        let si_1 = chol.solve(&one);
        let a = one.dot(&si_1);
        let b = one.dot(&si_y);
        ln_det + a.ln() + y.dot(&si_y) - b * b / a
    }

    fn models() -> Vec<Model> {
        vec![
            Model {
                white: 0.7,
                walk: 0.3,
                gauss_markov: None,
            },
            Model {
                white: 0.7,
                walk: 0.0,
                gauss_markov: None,
            },
            Model {
                white: 0.5,
                walk: 0.2,
                gauss_markov: Some((0.8, 3.0)),
            },
            Model {
                white: 0.5,
                walk: 0.0,
                gauss_markov: Some((0.8, 5000.0)),
            },
        ]
    }

    /// The filter's `-2 ln L` of per-sample data (blocks of one record) and of block means
    /// (blocks of 7 records, the last of 3) equals the Gaussian density of the same numbers
    /// with the covariance from the integrals of the processes; the block case with the
    /// covariance of the block means built as `A Sigma_samples A^T` from the samples'.
    #[test]
    fn block_likelihood_is_the_dense_gaussian() {
        let tau0 = 0.25;
        let records = 52;
        // Any numbers: the density is exact for any data.
        let inc: Vec<f64> = (0..records)
            .map(|i| ((i * 37 % 11) as f64 - 5.0) * 0.1 * tau0 + (i as f64 * 0.3).sin() * tau0)
            .collect();
        for model in models() {
            // Per sample.
            let samples = Blocks::new(&inc, tau0, &[0..records], records).unwrap();
            assert_eq!(samples.block_s, tau0);
            let spans: Vec<(f64, f64)> = (0..records).map(|i| (i as f64 * tau0, tau0)).collect();
            let cov_s = dense_cov(&spans, &model);
            let y: Vec<f64> = samples.intervals[0].iter().map(|b| b.0).collect();
            let kf = neg2_log_likelihood(&samples, &model);
            let dense = dense_diffuse(&y, &cov_s);
            assert!(
                (kf - dense).abs() < 1e-8 * (1.0 + dense.abs()),
                "{model:?}: samples: filter {kf}, dense {dense}"
            );
            // Blocks of 7 (the last of 3): the block means as A y, covariance A Sigma A^T.
            let blocks = Blocks::new(&inc, tau0, &[0..records], 8).unwrap();
            assert_eq!(blocks.block_s, 7.0 * tau0);
            let nb = blocks.intervals[0].len();
            assert_eq!(nb, 8);
            let a = DMatrix::from_fn(nb, records, |j, i| {
                let first = 7 * j;
                let len = (records - first).min(7);
                if i >= first && i < first + len {
                    1.0 / len as f64
                } else {
                    0.0
                }
            });
            let cov_b = &a * &cov_s * a.transpose();
            let yb: Vec<f64> = blocks.intervals[0].iter().map(|b| b.0).collect();
            let kf = neg2_log_likelihood(&blocks, &model);
            let dense = dense_diffuse(&yb, &cov_b);
            assert!(
                (kf - dense).abs() < 1e-8 * (1.0 + dense.abs()),
                "{model:?}: blocks: filter {kf}, dense {dense}"
            );
        }
    }

    /// Two intervals: their likelihoods add.
    #[test]
    fn intervals_add() {
        let tau0 = 0.1;
        let inc: Vec<f64> = (0..60).map(|i| (i as f64 * 0.7).cos() * tau0).collect();
        let m = models()[2];
        let both = Blocks::new(&inc, tau0, &[0..25, 30..60], 100).unwrap();
        let a = Blocks::new(&inc, tau0, &[0..25], 100).unwrap();
        let b = Blocks::new(&inc, tau0, &[30..60], 100).unwrap();
        let (x, y, z) = (
            neg2_log_likelihood(&both, &m),
            neg2_log_likelihood(&a, &m),
            neg2_log_likelihood(&b, &m),
        );
        assert!((x - y - z).abs() < 1e-9 * x.abs());
    }

    /// The Gauss-Markov Allan variance: a walk `K^2 = 2 sigma^2 / tc` far below `tc`, white
    /// noise `N^2 = 2 sigma^2 tc` far above, the two forms continuous at the series' switch.
    #[test]
    fn gauss_markov_allan_variance_limits() {
        let (sigma, tc) = (0.3, 50.0);
        let m = Model {
            white: 0.0,
            walk: 0.0,
            gauss_markov: Some((sigma, tc)),
        };
        let k2 = 2.0 * sigma * sigma / tc;
        assert!((m.avar(0.01) / (k2 * 0.01 / 3.0) - 1.0).abs() < 1e-3);
        let n2 = 2.0 * sigma * sigma * tc;
        assert!((m.avar(1e6) / (n2 / 1e6) - 1.0).abs() < 1e-3);
        let (a, b) = (m.avar(tc * 0.999_999e-3), m.avar(tc * 1.000_001e-3));
        assert!((a / b - 1.0).abs() < 1e-5, "{a} {b}");
    }

    #[test]
    fn one_second_scatter_of_a_walk() {
        // Two seconds: the two means differ by a walk's variance 2/3, so their scatter is 1/3.
        let walk = Model {
            white: 0.0,
            walk: 1.0,
            gauss_markov: None,
        };
        assert!((walk.one_second_scatter(&[2]).unwrap() - 1.0 / 3.0).abs() < 1e-12);
        // The white noise alone: N^2 whatever the rests.
        let white = Model {
            white: 2.0,
            walk: 0.0,
            gauss_markov: None,
        };
        assert_eq!(white.one_second_scatter(&[5, 1, 30]).unwrap(), 4.0);
        assert!(white.one_second_scatter(&[1, 0]).is_none());
        // A long rest: the scatter of a walk's means about their mean grows as n / 6.
        let s = walk.one_second_scatter(&[3000]).unwrap();
        assert!((s / 500.0 - 1.0).abs() < 0.01, "{s}");
    }

    #[test]
    fn optimisers_find_minima() {
        let (x, fx) = minimise_1d(&mut |x| (x - 3.0).powi(2) + 1.0, 0.0, 0.1, 1e-8);
        assert!((x - 3.0).abs() < 1e-6 && (fx - 1.0).abs() < 1e-10);
        let (p, fp) = nelder_mead(
            &mut |p| (p[0] - 1.0).powi(2) + 10.0 * (p[1] + 2.0).powi(2),
            &[0.0, 0.0],
            0.5,
            1e-12,
            2000,
            2,
        );
        assert!((p[0] - 1.0).abs() < 1e-4 && (p[1] + 2.0).abs() < 1e-4 && fp < 1e-8);
    }
}
