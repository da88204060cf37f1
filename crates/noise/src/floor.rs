//! The bias instability from the floor of the measured Allan curve, and whether the rests are
//! long enough to tell a bias instability or a walk at all.
//!
//! ## The floor
//!
//! Flicker rate noise (the bias instability `B`) gives a flat Allan variance, `(0.664 B)^2`
//! (IEEE Std 952-1997, annex C), added to the white noise's `N^2 / tau`. The likelihood's white
//! level `N` is known to a per cent from the records themselves ([`crate::likelihood`]), so
//! what the measured curve has beyond it, `avar - N^2 / tau`, is the slow noise alone: flat for
//! a floor, rising as `K^2 tau / 3` for a walk. [`flicker_floor`] fits both shapes to the
//! curve's points from `tau_min` on (each point's Allan variance an estimate with its degrees of
//! freedom, `avar chi2_nu / nu`; one parameter each, by maximum likelihood) and finds a floor
//! where the flat shape is [`FLOOR_LN_LR`] more likely than the walk's and than none at all,
//! not as much less likely than the bump of a Gauss-Markov bias (which rises, peaks near twice
//! its correlation time and falls; two parameters, its correlation time searched), and where it
//! dominates the white noise over two octaves ([`FLOOR_SPAN`]) within the curve. The bias
//! instability is the flat shape's level over 0.664.
//!
//! A first rule read the floor off the curve's minimum and refused a minimum with a rise two
//! octaves after it (the bowl of white noise and a walk): on 20 simulated 2.8-h recordings of
//! a flicker floor (`tests/mems.rs`) it found 13 floors within 30 %, the scatter of the few
//! long-tau points making flat curves look like bowls. Subtracting the white noise the
//! likelihood measured takes the white part's curvature out of the comparison: 19 of 20, no
//! floor on 20 recordings of white noise and a walk, and one on 20 of a Gauss-Markov bias
//! alone (`docs/noise.md`).
//!
//! Its interval: the points of one curve share the same slow realisation (the octaves overlap
//! and a flicker's low frequencies move them together), so they are not independent
//! estimates. The 68 % interval is the profile likelihood's with the points' information
//! divided by their number, as if the curve were one point: on the survey its half-width is
//! about the estimates' scatter from recording to recording, which treating the points as
//! independent understated fourfold.
//!
//! ## Rests too short to tell
//!
//! A bias instability and a walk are slow: from rests of a few seconds neither can be told from
//! white noise, from the other, or from a unit settling after each motion. [`slow_terms`] says
//! whether the rests are long enough: a walk above 0 only where the longest averaging time
//! reaches two octaves beyond the time where the walk's Allan variance equals the white
//! noise's (it then dominates the curve over two octaves) and the curve there does not lie
//! below it ([`walk_contradicted`]); a walk whose interval reaches 0 is
//! a bound (its upper end says how much could hide) where the curve reaches
//! [`MIN_WALK_BOUND_TAU_S`]: from a shorter one it allows walks no unit has, and says nothing;
//! a bias instability only where the curve shows a floor (above).

use crate::allan::AllanCurve;
use crate::edf;
use crate::likelihood::{BLOCKS_PER_CORRELATION, MlFit};
use serde::{Deserialize, Serialize};

/// The natural logarithm of the likelihood ratio by which a flat excess over the white noise
/// must beat both a walk's rising one and none at all for a floor: ln 100. Fixed before the
/// rule was run in Rust; the ratios on the surveys' recordings (worked from their printed
/// curves first) were e^19 to e^65 for the flicker floors, e^2.6 at most for white noise and a
/// walk.
pub const FLOOR_LN_LR: f64 = 4.605_170_185_988_091;

/// Over how much of the curve (a factor in averaging time) a floor or a walk must dominate the
/// white noise to be told: two octaves.
pub const FLOOR_SPAN: f64 = 4.0;

/// The longest averaging time (s) the curve must reach for a walk whose interval reaches 0 to
/// count as a bound. The bound's upper end is the walk that would just show at the curve's end
/// (it equals the white noise at 1.0 to 1.8 times the longest averaging time), so a short curve
/// bounds nothing a unit could have: from a curve to 2.5 s (rests of 5 s) a consumer gyro's
/// white noise of 139 deg/h at 1 s allows walks up to about 4 000 deg/h/sqrt(h), from one to
/// 100 s up to about 100 deg/h/sqrt(h), the top of consumer datasheets. Added after a survey
/// (`tests/mems.rs`: 20 poses of 5 s, seeds 3201-3250) found the walk's interval reaching 0 on
/// 41 of 50 recordings, each then counted as determined; the value comes from the datasheet
/// argument, not from that survey (any value above its 2.5 s passes it).
pub const MIN_WALK_BOUND_TAU_S: f64 = 100.0;

/// `sqrt(2 ln 2 / pi)`: the Allan deviation of flicker rate noise per unit of bias instability.
pub const FLICKER_ADEV: f64 = 0.664_282_466_029_688_7;

/// A floor of the measured Allan deviation and the bias instability it gives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Floor {
    /// Where the floor's Allan variance equals the white noise's (s): it dominates from here.
    pub from_tau_s: f64,
    /// The curve's longest averaging time (s).
    pub to_tau_s: f64,
    /// The floor's Allan deviation, `0.664 B` (rate unit, SI).
    pub adev: f64,
    /// The natural logarithm of the likelihood ratio of the flat excess over a walk's.
    pub ln_lr_over_walk: f64,
    /// The same over no excess at all.
    pub ln_lr_over_none: f64,
    /// The same over a Gauss-Markov bias's bump (the best correlation time; negative where the
    /// bump fits better, down to `-FLOOR_LN_LR`).
    pub ln_lr_over_gauss_markov: f64,
    /// The curve's points fitted (from `tau_min` on).
    pub points: usize,
    /// The bias instability `adev / 0.664` (rate unit, SI).
    pub value: f64,
    /// Lower end of its 68 % interval.
    pub lower: f64,
    /// Upper end of its 68 % interval.
    pub upper: f64,
}

/// The shape of the slow noise beyond the white noise: flat (a floor), rising (a walk), or the
/// bump of a Gauss-Markov bias of the given correlation time (s), which rises, peaks near
/// twice it and falls.
#[derive(Clone, Copy)]
enum Shape {
    Flat,
    Walk,
    GaussMarkov(f64),
}

impl Shape {
    /// Its Allan variance at `tau_s` for the parameter `x` (`F^2`, `K^2`, or `sigma^2`).
    fn avar(self, x: f64, tau_s: f64) -> f64 {
        match self {
            Shape::Flat => x,
            Shape::Walk => x * tau_s / 3.0,
            Shape::GaussMarkov(tc) => crate::likelihood::Model {
                white: 0.0,
                walk: 0.0,
                gauss_markov: Some((x.sqrt(), tc)),
            }
            .avar(tau_s),
        }
    }
}

/// The best log-likelihood of a Gauss-Markov bump over correlation times from a tenth of the
/// shortest averaging time to ten times the longest, twenty a decade.
fn fit_gauss_markov(points: &[Point], white2: f64) -> f64 {
    let shortest = points.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let longest = points.iter().map(|p| p.0).fold(0.0, f64::max);
    let (lo, hi) = ((shortest / 10.0).ln(), (longest * 10.0).ln());
    let n = ((hi - lo) / std::f64::consts::LN_10 * 20.0).ceil() as usize;
    (0..=n)
        .map(|i| {
            let tc = (lo + (hi - lo) * i as f64 / n.max(1) as f64).exp();
            fit_shape(points, white2, Shape::GaussMarkov(tc)).1
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// A point of the curve as the floor's likelihood takes it: `(tau, avar, edf)`.
type Point = (f64, f64, f64);

/// The log-likelihood of the points' Allan variances (each `avar chi2_nu / nu` about the
/// model's) under white noise `white2 / tau` and `shape` at `x`, up to a constant.
fn ln_likelihood(points: &[Point], white2: f64, shape: Shape, x: f64) -> f64 {
    points
        .iter()
        .map(|&(tau, avar, edf)| {
            let m = white2 / tau + shape.avar(x, tau);
            0.5 * edf * (-avar / m - m.ln())
        })
        .sum()
}

/// The maximum-likelihood `x >= 0` of `shape` and its log-likelihood: a grid of 400 points in
/// `ln x` over ten decades below the largest variance the points allow and one above, refined
/// by golden section between the best one's neighbours.
fn fit_shape(points: &[Point], white2: f64, shape: Shape) -> (f64, f64) {
    let ll = |x: f64| ln_likelihood(points, white2, shape, x);
    let top = points
        .iter()
        .map(|&(tau, avar, _)| avar / shape.avar(1.0, tau))
        .fold(0.0, f64::max);
    let (lo, hi) = ((top * 1e-10).ln(), (top * 10.0).ln());
    let n = 400;
    let at = |i: usize| (lo + (hi - lo) * i as f64 / n as f64).exp();
    let grid: Vec<f64> = (0..=n).map(|i| ll(at(i))).collect();
    let best = (0..=n)
        .max_by(|&i, &j| grid[i].total_cmp(&grid[j]))
        .unwrap_or(0);
    let (a, b) = (at(best.saturating_sub(1)).ln(), at((best + 1).min(n)).ln());
    let x = golden_section(&|u: f64| ll(u.exp()), a, b, 60).exp();
    (x, ll(x))
}

/// The maximum of `f` on `[a, b]` by `steps` steps of golden section (the midpoint of the last
/// interval).
fn golden_section(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64, steps: usize) -> f64 {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..steps {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if f(c) > f(d) {
            b = d;
        } else {
            a = c;
        }
    }
    0.5 * (a + b)
}

/// Where the log-likelihood of the flat shape falls `drop` below its maximum at `x_hat`, on
/// either side (bisection in `ln x`; 0 below where it never falls that far).
fn profile_interval(points: &[Point], white2: f64, x_hat: f64, drop: f64) -> (f64, f64) {
    let target = ln_likelihood(points, white2, Shape::Flat, x_hat) - drop;
    let inside = |x: f64| ln_likelihood(points, white2, Shape::Flat, x) >= target;
    let side = |outer: f64| boundary(&inside, x_hat, outer, 80);
    let lower = side(x_hat * 1e-12);
    (
        if lower <= x_hat * 1e-12 { 0.0 } else { lower },
        side(x_hat * 1e12),
    )
}

/// Where `inside` (true at `from`) turns false between `from` and `outer`: `steps` bisections
/// in the logarithm; `outer` itself where it is still inside.
fn boundary(inside: &dyn Fn(f64) -> bool, from: f64, outer: f64, steps: usize) -> f64 {
    if inside(outer) {
        return outer;
    }
    let (mut a, mut b) = (from.ln(), outer.ln());
    for _ in 0..steps {
        let m = 0.5 * (a + b);
        if inside(m.exp()) {
            a = m;
        } else {
            b = m;
        }
    }
    a.exp()
}

/// The points of `curve` a floor is fitted to: those from `tau_min_s` on with a variance.
fn floor_points(curve: &AllanCurve, tau_min_s: f64) -> Vec<Point> {
    curve
        .points
        .iter()
        .filter(|p| {
            p.terms > 0
                && p.avar.is_finite()
                && p.avar > 0.0
                && p.edf > 0.0
                && p.tau_s >= tau_min_s * (1.0 - 1e-9)
        })
        .map(|p| (p.tau_s, p.avar, p.edf))
        .collect()
}

/// The floor of `curve` at averaging times from `tau_min_s` on, where it has one, with the
/// white noise `white` (the likelihood's level; module docs). Below the sensor's correlation
/// time its own filter shapes the curve (the Allan fit's fitted range,
/// [`crate::fit::NoiseFit::tau_min_s`]): a filter flattens the curve at the short taus, and
/// that is no floor.
pub fn flicker_floor(curve: &AllanCurve, tau_min_s: f64, white: f64) -> Option<Floor> {
    let points = floor_points(curve, tau_min_s);
    let longest = points.iter().map(|p| p.0).fold(0.0, f64::max);
    if points.len() < 3 || white.is_nan() || white <= 0.0 {
        return None;
    }
    let white2 = white * white;
    let (x, ll_flat) = fit_shape(&points, white2, Shape::Flat);
    let (_, ll_walk) = fit_shape(&points, white2, Shape::Walk);
    let ll_none = ln_likelihood(&points, white2, Shape::Flat, 0.0);
    let (over_walk, over_none) = (ll_flat - ll_walk, ll_flat - ll_none);
    let from = white2 / x;
    if over_walk < FLOOR_LN_LR || over_none < FLOOR_LN_LR || longest < FLOOR_SPAN * from {
        return None;
    }
    // A Gauss-Markov bias alone (a correlation of seconds to minutes, a unit settling) gives a
    // bump, which the flat shape fits better than a walk's rise; it is no floor where the bump
    // is the more likely by the same ratio.
    let over_gauss_markov = ll_flat - fit_gauss_markov(&points, white2);
    if over_gauss_markov < -FLOOR_LN_LR {
        return None;
    }
    let (lo, hi) = profile_interval(&points, white2, x, 0.5 * points.len() as f64);
    Some(Floor {
        from_tau_s: from,
        to_tau_s: longest,
        adev: x.sqrt(),
        ln_lr_over_walk: over_walk,
        ln_lr_over_none: over_none,
        ln_lr_over_gauss_markov: over_gauss_markov,
        points: points.len(),
        value: x.sqrt() / FLICKER_ADEV,
        lower: lo.sqrt() / FLICKER_ADEV,
        upper: hi.sqrt() / FLICKER_ADEV,
    })
}

/// A walk fitted beside a floor ([`walk_beyond_floor`]): where the curve shows a floor, the
/// likelihood's walk, whose model has white noise and a walk only, takes the flicker's slow
/// power in as walk (on 20 simulated 2.8-h recordings of a floor with a walk meeting it at
/// 2000 s, `tests/mems.rs`, it came out 0.7 to 3.8 times the truth, median 1.85, with 68 %
/// intervals that mostly excluded it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WalkBeyondFloor {
    /// The walk `K` (rate unit per sqrt(s), SI): the maximum-likelihood value.
    pub value: f64,
    /// Lower end of its 68 % interval (0 where it reaches 0).
    pub lower: f64,
    /// Upper end of its 68 % interval.
    pub upper: f64,
    /// The floor's Allan variance fitted with it (`(0.664 B)^2`).
    pub floor_avar: f64,
    /// Where the walk (its value, or its upper end where the interval reaches 0) equals the
    /// floor (s): it dominates from here.
    pub crossover_s: f64,
}

/// The log-likelihood of the points under white noise `white2 / tau`, a floor `f` and a walk
/// `k2 tau / 3`.
fn ln_likelihood_floor_walk(points: &[Point], white2: f64, f: f64, k2: f64) -> f64 {
    points
        .iter()
        .map(|&(tau, avar, edf)| {
            let m = white2 / tau + f + k2 * tau / 3.0;
            0.5 * edf * (-avar / m - m.ln())
        })
        .sum()
}

/// The floor of the largest likelihood with the walk `k2`, between `f_lo` and `f_hi` (golden
/// section in `ln f` after a grid of 60), and that likelihood.
fn best_floor_with_walk(
    points: &[Point],
    white2: f64,
    k2: f64,
    f_lo: f64,
    f_hi: f64,
) -> (f64, f64) {
    let ll = |lf: f64| ln_likelihood_floor_walk(points, white2, lf.exp(), k2);
    let (lo, hi) = (f_lo.ln(), f_hi.ln());
    let n = 60;
    let at = |i: usize| lo + (hi - lo) * i as f64 / n as f64;
    let best = (0..=n)
        .max_by(|&i, &j| ll(at(i)).total_cmp(&ll(at(j))))
        .unwrap_or(0);
    let lf = golden_section(&ll, at(best.saturating_sub(1)), at((best + 1).min(n)), 40);
    (lf.exp(), ll(lf))
}

/// The walk of `curve` fitted with its floor `floor` (found by [`flicker_floor`] at `tau_min_s`
/// with the white noise `white`): the points from `tau_min_s` on as white noise (fixed), a flat
/// floor and a walk, by maximum likelihood over the last two; the walk's 68 % interval is its
/// profile likelihood's with the points' information divided by their number, as the floor's.
pub fn walk_beyond_floor(
    curve: &AllanCurve,
    tau_min_s: f64,
    white: f64,
    floor: &Floor,
) -> WalkBeyondFloor {
    let points = floor_points(curve, tau_min_s);
    let f0 = floor.adev * floor.adev;
    fit_walk_and_floor(&points, white * white, (f0 * 1e-4, f0 * 1e2))
}

/// Where the curve has no floor that dominates two octaves ([`flicker_floor`]) but a floor
/// under its walk all the same: the joint fit of [`walk_beyond_floor`] (the floor searched over
/// eight decades below the largest Allan variance of the points) whose floor is above zero at
/// the floor's interval convention (its profile likelihood at zero, the walk refitted, more than
/// half a unit a point below the maximum). The likelihood's walk has no floor in its model and
/// takes its power in: on 20 simulated 2.8-h recordings of the floor below a walk meeting it at
/// 250 s (`tests/mems.rs`), where the floor was not found it came out 1.25 to 1.67 times the
/// truth with intervals excluding it. `None` where the curve shows no floor under the walk.
pub fn floor_under_walk(curve: &AllanCurve, tau_min_s: f64, white: f64) -> Option<WalkBeyondFloor> {
    let points = floor_points(curve, tau_min_s);
    if points.len() < 3 || white.is_nan() || white <= 0.0 {
        return None;
    }
    let white2 = white * white;
    let top = points.iter().map(|p| p.1).fold(0.0, f64::max);
    let joint = fit_walk_and_floor(&points, white2, (top * 1e-8, top * 10.0));
    let ll_joint =
        ln_likelihood_floor_walk(&points, white2, joint.floor_avar, joint.value * joint.value);
    let (_, ll_walk) = fit_shape(&points, white2, Shape::Walk);
    (ll_joint - ll_walk > 0.5 * points.len() as f64).then_some(joint)
}

/// The joint fit of [`walk_beyond_floor`] on `points`, the floor searched over `f_range`.
fn fit_walk_and_floor(points: &[Point], white2: f64, (f_lo, f_hi): (f64, f64)) -> WalkBeyondFloor {
    let points = points.to_vec();
    // The walk's variance over ten decades below the largest the points allow, and zero.
    let top = points
        .iter()
        .map(|&(tau, avar, _)| 3.0 * avar / tau)
        .fold(0.0, f64::max);
    let profile = |k2: f64| best_floor_with_walk(&points, white2, k2, f_lo, f_hi).1;
    let n = 200;
    let at = |i: usize| (top * 1e-10) * (1e11f64).powf(i as f64 / n as f64);
    let mut best = (0.0, profile(0.0));
    for i in 0..=n {
        let l = profile(at(i));
        if l > best.1 {
            best = (at(i), l);
        }
    }
    // Refined in ln k2 between the best grid point's neighbours (golden section).
    if best.0 > 0.0 {
        let step = (1e11f64).ln() / n as f64;
        let (a, b) = (best.0.ln() - step, best.0.ln() + step);
        let k2 = golden_section(&|u: f64| profile(u.exp()), a, b, 40).exp();
        let l = profile(k2);
        if l > best.1 {
            best = (k2, l);
        }
    }
    let (k2_hat, ll_hat) = best;
    let target = ll_hat - 0.5 * points.len() as f64;
    let inside = |k2: f64| profile(k2) >= target;
    // Bisection in ln k2 from the estimate to an outer end, which is returned where the
    // profile never falls that far.
    let start = if k2_hat > 0.0 { k2_hat } else { top * 1e-10 };
    let side = |outer: f64| boundary(&inside, start, outer, 60);
    let lower = if k2_hat <= 0.0 || inside(0.0) {
        0.0
    } else {
        side(k2_hat * 1e-12)
    };
    let upper = side(top * 1e3);
    let f_hat = best_floor_with_walk(&points, white2, k2_hat, f_lo, f_hi).0;
    let k_cross = if lower > 0.0 { k2_hat } else { upper };
    WalkBeyondFloor {
        value: k2_hat.sqrt(),
        lower: lower.sqrt(),
        upper: upper.sqrt(),
        floor_avar: f_hat,
        crossover_s: if k_cross > 0.0 {
            3.0 * f_hat / k_cross
        } else {
            f64::INFINITY
        },
    }
}

/// Whether the rests are long enough for the slow terms ([`slow_terms`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlowTerms {
    /// The longest rest (s).
    pub longest_rest_s: f64,
    /// The longest averaging time of the curve (s).
    pub longest_tau_s: f64,
    /// Where the curve beyond the crossover contradicts the walk (a value, not a bound): the
    /// averaging time (s) of the point whose upper bound, at [`WALK_CONTRADICTION_LEVEL`]
    /// over the points beyond the crossover, lies furthest below the deviation of the white
    /// noise and the walk at the lower end of its 68 % interval, with that ratio (walk over
    /// bound, above 1). `None` where no point does.
    pub walk_contradicted_at: Option<(f64, f64)>,
    /// The averaging time from which the walk (at its value, or at its upper end where its
    /// interval reaches 0) dominates the white noise, or the floor where the curve shows one
    /// (s; infinite for no walk at all).
    pub walk_crossover_s: f64,
    /// Whether the walk's interval reaches 0: then the crossover is that of its upper end.
    pub walk_bound: bool,
    /// Whether the walk is determined: a bound (its interval reaches 0) where the curve reaches
    /// [`MIN_WALK_BOUND_TAU_S`], or a value where the curve reaches [`FLOOR_SPAN`] times the
    /// crossover and does not contradict it there (`walk_contradicted_at`).
    pub walk: bool,
    /// Whether a bias instability is determined: the curve shows a floor
    /// ([`flicker_floor`]).
    pub bias_instability: bool,
    /// Where the curve shows a floor, the walk fitted with it ([`walk_beyond_floor`]): the
    /// walk the decision above is about, in place of the likelihood's.
    #[serde(default)]
    pub walk_beyond_floor: Option<WalkBeyondFloor>,
}

/// Whether the rests of `curve` are long enough to tell a walk (the likelihood's, `ml`) and a
/// bias instability (module docs; the floor above [`BLOCKS_PER_CORRELATION`] times the
/// likelihood's correlation time, where the Allan fit starts).
pub fn slow_terms(curve: &AllanCurve, ml: &MlFit) -> SlowTerms {
    let longest = curve.interval_records.iter().copied().max().unwrap_or(0);
    let longest_tau_s = curve
        .points
        .iter()
        .filter(|p| p.terms > 0)
        .map(|p| p.tau_s)
        .fold(0.0, f64::max);
    let tau_min_s = BLOCKS_PER_CORRELATION as f64 * ml.correlation_s;
    let floor = flicker_floor(curve, tau_min_s, ml.white.value);
    let rest_s = longest as f64 * curve.tau0_s;
    // The walk beside a floor, or a flat excess under it, which it must dominate rather than
    // the white noise.
    let beside = match &floor {
        Some(floor) => Some(walk_beyond_floor(curve, tau_min_s, ml.white.value, floor)),
        None => floor_under_walk(curve, tau_min_s, ml.white.value),
    };
    if let Some(wb) = beside {
        let bound = wb.lower <= 0.0;
        return SlowTerms {
            longest_rest_s: rest_s,
            longest_tau_s,
            walk_contradicted_at: None,
            walk_crossover_s: wb.crossover_s,
            walk_bound: bound,
            walk: walk_told(bound, longest_tau_s, wb.crossover_s),
            bias_instability: floor.is_some(),
            walk_beyond_floor: Some(wb),
        };
    }
    // A walk above 0 must dominate the curve over two octaves. A bound (the interval reaching
    // 0): its upper end is where a walk would just show at the longest taus, so its crossover
    // scales with the rests and no rule relative to them separates short rests from long (on
    // an hour's rest it lay at 1.0 to 1.6 times the longest tau, on 7-s rests at 1.2 to 1.8
    // times); what separates them is what the bound allows (`MIN_WALK_BOUND_TAU_S`).
    let bound = ml.walk.lower <= 0.0;
    let k = if bound { ml.walk.upper } else { ml.walk.value };
    // N^2 / tau = K^2 tau / 3 at tau = sqrt(3) N / K.
    let walk_crossover_s = if k > 0.0 && k.is_finite() {
        3f64.sqrt() * ml.white.value / k
    } else {
        f64::INFINITY
    };
    let walk_contradicted_at = if bound {
        None
    } else {
        walk_contradicted(curve, ml.white.value, ml.walk.lower, walk_crossover_s)
    };
    SlowTerms {
        longest_rest_s: rest_s,
        longest_tau_s,
        walk_contradicted_at,
        walk_crossover_s,
        walk_bound: bound,
        walk: walk_told(bound, longest_tau_s, walk_crossover_s) && walk_contradicted_at.is_none(),
        bias_instability: false,
        walk_beyond_floor: None,
    }
}

/// Whether a curve to `longest_tau_s` tells a walk whose crossover is `crossover_s`: a bound
/// (`bound`, its interval reaching 0) where it reaches [`MIN_WALK_BOUND_TAU_S`], a value where
/// it reaches [`FLOOR_SPAN`] times the crossover.
fn walk_told(bound: bool, longest_tau_s: f64, crossover_s: f64) -> bool {
    if bound {
        longest_tau_s >= MIN_WALK_BOUND_TAU_S * (1.0 - 1e-9)
    } else {
        longest_tau_s >= FLOOR_SPAN * crossover_s * (1.0 - 1e-9)
    }
}

/// The family-wise level at which the curve's points beyond a walk's crossover contradict it
/// ([`walk_contradicted`]): 1 %, Bonferroni over those points.
pub const WALK_CONTRADICTION_LEVEL: f64 = 0.01;

/// Where the measured curve beyond `crossover_s` contradicts a walk `k` (rad/s/sqrt(s) or
/// m/s^2/sqrt(s); the lower end of its 68 % interval) with white noise `n`: a point whose
/// one-sided upper bound at [`WALK_CONTRADICTION_LEVEL`] over those points lies below the
/// two's deviation `sqrt(n^2 / tau + k^2 tau / 3)`; the furthest one, as (tau, deviation over
/// bound). The likelihood's walk rests on the records' structure over its blocks; a sensor whose
/// deviation rises over a few seconds and falls again (a correlation, a unit settling) gives a
/// walk the longer averaging times deny: the Xsens accelerometer z's 0.00132 m/s^2/sqrt(s),
/// dominating from 1.6 s, lay 5.5 and 12 times above the curve at 10 and 20 s (5.5 and 1.7
/// degrees of freedom), inside the band check, which widens by the model's own interval at a
/// level corrected over every point of every axis, and was written into `[noise]`.
pub fn walk_contradicted(
    curve: &AllanCurve,
    n: f64,
    k: f64,
    crossover_s: f64,
) -> Option<(f64, f64)> {
    if !(k > 0.0 && crossover_s.is_finite()) {
        return None;
    }
    let beyond: Vec<_> = curve
        .points
        .iter()
        .filter(|p| p.terms > 0 && p.edf > 0.0 && p.tau_s >= crossover_s * (1.0 - 1e-9))
        .collect();
    let alpha = WALK_CONTRADICTION_LEVEL / beyond.len().max(1) as f64;
    beyond
        .iter()
        .filter_map(|p| {
            let (_, upper) = edf::confidence_interval(p.adev, p.edf, 1.0 - 2.0 * alpha);
            let model = (n * n / p.tau_s + k * k * p.tau_s / 3.0).sqrt();
            (model > upper).then_some((p.tau_s, model / upper))
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::allan::AllanPoint;
    use crate::edf::NoiseType;

    /// A curve of exact values `adev(tau)` at octaves from 0.01 s, with the degrees of freedom of
    /// `records` records in one interval.
    fn curve(records: usize, adev: impl Fn(f64) -> f64) -> AllanCurve {
        let mut points = Vec::new();
        let mut m = 1;
        while 2 * m <= records {
            let tau_s = 0.01 * m as f64;
            let a = adev(tau_s);
            points.push(AllanPoint {
                m,
                tau_s,
                avar: a * a,
                adev: a,
                terms: records + 1 - 2 * m,
                edf: 0.0,
                noise_type: NoiseType::WhiteRate,
                lower: a,
                upper: a,
            });
            m *= 2;
        }
        let mut c = AllanCurve {
            tau0_s: 0.01,
            interval_records: vec![records],
            points,
        };
        let types = vec![NoiseType::WhiteRate; c.points.len()];
        c.set_noise_types(&types);
        c
    }

    /// A likelihood fit of white noise `n` and a walk `k` (68 % interval +-10 %).
    fn ml(n: f64, k: f64) -> MlFit {
        use crate::likelihood::Level;
        MlFit {
            white: Level {
                value: n,
                lower: 0.9 * n,
                upper: 1.1 * n,
            },
            walk: Level {
                value: k,
                lower: 0.9 * k,
                upper: 1.1 * k,
            },
            gauss_markov: None,
            neg2_log_likelihood: 0.0,
            lr_statistic: 0.0,
            lr_p_value: 1.0,
            whiteness: None,
            block_s: 0.1,
            blocks: 100,
            correlation_s: 0.0,
            tc_at_bound: false,
            oscillation: None,
        }
    }

    /// A walk dominating from 1 s over two octaves is determined where the curve follows it,
    /// and not where the curve beyond 1 s falls (a correlation of a second, the Xsens
    /// accelerometer z's shape), though the curve reaches as far.
    #[test]
    fn a_walk_the_curve_denies_is_not_determined() {
        let (n, k) = (1e-3, 3f64.sqrt() * 1e-3);
        let walk = |t: f64| (n * n / t + k * k * t / 3.0).sqrt();
        let st = slow_terms(&curve(100_000, walk), &ml(n, k));
        assert!((st.walk_crossover_s - 1.0).abs() < 1e-9, "{st:?}");
        assert!(st.walk && st.walk_contradicted_at.is_none(), "{st:?}");
        // A Gauss-Markov bias of 1 s: the deviation peaks near the correlation time and then
        // falls as 1/sqrt(tau).
        let bump = |t: f64| {
            let gm = k * (1.0f64).min(1.0 / t).sqrt();
            (n * n / t + gm * gm).sqrt()
        };
        // The likelihood's walk is not taken: the curve denies it, or the fit of the curve
        // with a flat excess under the walk bounds the walk far below it.
        let st = slow_terms(&curve(100_000, bump), &ml(n, k));
        let bounded_below = st
            .walk_beyond_floor
            .as_ref()
            .is_some_and(|w| w.lower == 0.0 && w.upper < 0.1 * k);
        assert!(st.walk_contradicted_at.is_some() || bounded_below, "{st:?}");
        assert!(!st.walk || st.walk_bound, "{st:?}");
    }

    /// On exact curves of white noise, a floor and a walk the walk fitted beside the floor is
    /// the walk's (the curve's points are exact, so the estimate is), and with no walk its
    /// interval reaches 0; the decision is made against the floor, not the white noise.
    #[test]
    fn the_walk_beside_a_floor_is_the_walk_s() {
        let (n, b) = (1e-7f64.sqrt(), 1e-4);
        let f = (FLICKER_ADEV * b).powi(2);
        // The walk meets the floor at 1000 s (the floor dominates from 23 s); 3 h at 100 Hz
        // reach 2.7e3 s, short of the two octaves beyond 1000 s that tell the walk.
        let k = (3.0 * f / 1000.0).sqrt();
        let c = curve(1_080_000, |t| (n * n / t + f + k * k * t / 3.0).sqrt());
        let fl = flicker_floor(&c, 0.0, n).expect("a floor");
        let w = walk_beyond_floor(&c, 0.0, n, &fl);
        assert!((w.value / k - 1.0).abs() < 0.02, "{w:?} against {k}");
        assert!(w.lower < k && k < w.upper, "{w:?}");
        assert!((w.floor_avar / f - 1.0).abs() < 0.02, "{w:?}");
        // Its interval, the curve's information divided by its number of points, reaches 0:
        // a bound, whose crossover with the floor is its upper end's.
        assert_eq!(w.lower, 0.0, "{w:?}");
        assert!(
            (w.crossover_s - 3.0 * w.floor_avar / w.upper.powi(2)).abs() < 1e-6,
            "{w:?}"
        );
        // The likelihood's walk, ten times too large, decides nothing.
        let st = slow_terms(&c, &ml(n, 10.0 * k));
        assert_eq!(st.walk_beyond_floor.as_ref(), Some(&w));
        assert!(st.walk_bound && st.bias_instability, "{st:?}");
        assert_eq!(st.walk_crossover_s, w.crossover_s);
        let flat = curve(1_080_000, |t| (n * n / t + f).sqrt());
        let fl = flicker_floor(&flat, 0.0, n).expect("a floor");
        let w = walk_beyond_floor(&flat, 0.0, n, &fl);
        assert_eq!(w.lower, 0.0, "{w:?}");
        assert!(w.value < 0.05 * k, "{w:?}");
    }

    #[test]
    fn a_flat_floor_gives_its_level_and_white_and_walk_give_none() {
        // White 3.2e-4 at 1 s and a flicker floor of B = 1e-4 over 3 h at 100 Hz.
        let b = 1e-4;
        let n = 1e-7f64.sqrt();
        let c = curve(1_080_000, |t| {
            (n * n / t + (FLICKER_ADEV * b).powi(2)).sqrt()
        });
        let f = flicker_floor(&c, 0.0, n).expect("a floor");
        // Exact values: the level itself, within the grid's refinement.
        assert!((f.value / b - 1.0).abs() < 1e-5, "{f:?}");
        assert!(f.lower < f.value && f.value < f.upper, "{f:?}");
        assert!((f.from_tau_s - n * n / (FLICKER_ADEV * b).powi(2)).abs() < 1e-3 * f.from_tau_s);
        assert!(f.ln_lr_over_walk >= FLOOR_LN_LR && f.ln_lr_over_none >= FLOOR_LN_LR);
        // White noise and a walk crossing at 1 s: a minimum, no floor; white noise alone: none.
        let c = curve(1_080_000, |t| (1e-6 / t + 1e-6 * t).sqrt());
        assert!(flicker_floor(&c, 0.0, 1e-3).is_none());
        let c = curve(1_080_000, |t| (1e-6 / t).sqrt());
        assert!(flicker_floor(&c, 0.0, 1e-3).is_none());
        // The same floor on a curve that ends before it has dominated for two octaves: none.
        let c = curve(8_000, |t| (n * n / t + (FLICKER_ADEV * b).powi(2)).sqrt());
        assert!(flicker_floor(&c, 0.0, n).is_none());
    }
}
