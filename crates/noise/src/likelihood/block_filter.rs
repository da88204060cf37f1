//! The exact Gaussian likelihood of the block means: a Kalman filter over the blocks, its
//! innovations' whiteness, and the likelihood concentrated over the white level.

use super::{Blocks, Model};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// The per-block moments of the model for a block of duration `t` (module docs).
#[derive(Clone, Copy, Debug)]
pub(super) struct Moments {
    /// var v (all within-block noise).
    pub(super) r: f64,
    /// var w, cov(u, w).
    pub(super) qb: f64,
    pub(super) cb: f64,
    /// `R + Q_b - 2 C_b` and `Q_b R - C_b^2` (walk-only filter, a stable form of its update).
    pub(super) d1: f64,
    pub(super) d2: f64,
    /// Gauss-Markov: phi, a, var eta, cov(xi, eta), its variance.
    pub(super) phi: f64,
    pub(super) a: f64,
    pub(super) qg: f64,
    pub(super) cg: f64,
    pub(super) s2: f64,
}

impl Moments {
    pub(super) fn new(m: &Model, t: f64) -> Moments {
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
pub(super) struct Sums {
    pub(super) ln_s: f64,
    pub(super) quad: f64,
    pub(super) n: usize,
}

impl Sums {
    pub(super) fn neg2ll(self) -> f64 {
        self.ln_s + self.quad
    }
}

/// Run the filter over every interval (module docs, "Likelihood").
pub(super) fn filter(blocks: &Blocks, model: &Model) -> Sums {
    filter_with(blocks, model, |_, _| {})
}

/// The filter, handing every normalised innovation `nu / sqrt(S)` with its interval's index
/// to `on` (a no-op for the likelihood: monomorphised, it costs nothing there).
pub(super) fn filter_with<F: FnMut(usize, f64)>(blocks: &Blocks, model: &Model, mut on: F) -> Sums {
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
pub(super) struct LnProduct {
    pub(super) prod: f64,
    pub(super) ln: f64,
}

impl Default for LnProduct {
    fn default() -> Self {
        LnProduct { prod: 1.0, ln: 0.0 }
    }
}

impl LnProduct {
    #[inline]
    pub(super) fn push(&mut self, s: f64) {
        self.prod *= s;
        if !(1e-150..=1e150).contains(&self.prod) {
            self.ln += self.prod.ln();
            self.prod = 1.0;
        }
    }

    pub(super) fn ln(self) -> f64 {
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
pub(super) fn concentrated(blocks: &Blocks, ratio: &Model) -> (f64, f64) {
    let s = filter(blocks, ratio);
    let n = s.n as f64;
    let scale = s.quad / n;
    (n * scale.ln() + s.ln_s + n, scale)
}
