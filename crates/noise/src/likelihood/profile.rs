//! The maximum-likelihood fits of the white level, the walk and a Gauss-Markov bias, with their
//! 68 % intervals from the profile likelihood.

use super::block_filter::{concentrated, neg2_log_likelihood};
use super::minimise::{brent, minimise_1d, nelder_mead};
use super::{Blocks, Level, Model, PROFILE_RISE};
use crate::NoiseError;

/// [`fit_base`] of blocks that hold at least three innovations, refused where it finds no
/// white noise.
pub(super) fn checked_base(blocks: &Blocks) -> Result<(f64, f64, f64), NoiseError> {
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
pub(super) fn fit_base(blocks: &Blocks) -> (f64, f64, f64) {
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
pub(super) fn profile_end(
    g: &mut dyn FnMut(f64) -> f64,
    x0: f64,
    dir: f64,
    step0: f64,
) -> Option<f64> {
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
pub(super) fn base_levels(blocks: &Blocks, n: f64, k: f64, best: f64) -> (Level, Level) {
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
pub(super) fn tc_penalty(blocks: &Blocks, ln_tc: f64) -> f64 {
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
pub(super) fn fit_gauss_markov(blocks: &Blocks, n: f64, k: f64) -> (Model, f64) {
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
pub(super) fn gauss_markov_levels(blocks: &Blocks, m: &Model, best: f64) -> (Level, Level, Level) {
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
