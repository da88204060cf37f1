//! The bias instability from the floor of the measured Allan curve, and whether the rests are
//! long enough to tell a bias instability or a walk at all.
//!
//! ## The floor
//!
//! Flicker rate noise (the bias instability `B`) gives a flat Allan deviation, `0.664 B`
//! (IEEE Std 952-1997, annex C). Where the measured curve is flat around its minimum, that
//! minimum over 0.664 is the bias instability, as the IEEE standard and common practice read it
//! off the plot, without a fit of every term: the Allan fit can fail its own check (a curve its
//! five power laws do not follow, a sensor's oscillation at the short taus) and then gives no
//! result while the floor is plain to see.
//!
//! Flat: the minimum (over the points with at least [`FLOOR_MIN_EDF`] degrees of freedom: a
//! point of fewer is as likely a low draw as the floor) is at least [`FLOOR_FALL`] of the
//! deviation two octaves ([`FLOOR_SPAN`]) before it: the curve has stopped falling like white
//! noise; and where the curve reaches two octaves beyond it, the deviations two octaves before
//! and after exceed the minimum by less than [`FLOOR_BOWL`] together (the product of the two
//! ratios): it is no bowl of white noise and a walk. White noise alone falls by 2 over two
//! octaves; white noise and a walk have a minimum, and whatever the octave grid's offset from
//! it, the two ratios' product is 2.03 or more. (A first version took the
//! minimum's neighbours whose 68 % interval reached within 1.1 times the minimum, over two
//! octaves: on the Xsens recording the last points, of one or two degrees of freedom, made a
//! "floor" of the white noise at 2.56 s.) The interval of `B` is the minimum point's own 68 % interval
//! over 0.664 (its degrees of freedom those of flicker noise). The minimum of noisy estimates is
//! biased low (the lowest of several); on a flat floor the neighbours' scatter is that of one
//! estimate, which the interval covers.
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
use crate::edf::{self, NoiseType};
use crate::likelihood::{BLOCKS_PER_CORRELATION, MlFit};
use serde::{Deserialize, Serialize};

/// The least ratio of the minimum to the deviation two octaves before it for a floor: the
/// curve falls there by less than `sqrt(2)`, an average slope shallower than -1/4 on the
/// log-log plot, halfway between white noise (-1/2, a ratio of 0.5) and a floor (0). White
/// noise and a walk alone reach their minimum at a ratio of 0.69.
pub const FLOOR_FALL: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Degrees of freedom (under flicker noise) the minimum point must have: its deviation then
/// has a relative standard deviation of about 22 % at most. The lowest of the curve's points
/// whatever their degrees of freedom was tried first: on the simulated recording of
/// `tests/mems.rs` it was the last point (2.7 degrees of freedom), at half the floor.
pub const FLOOR_MIN_EDF: f64 = 10.0;

/// The most the deviations two octaves before and two after the minimum may exceed it by, as
/// the product of the two ratios: the geometric middle between a floor (1) and white noise with
/// a walk (2.03 at the least, whatever the octave grid's offset from their minimum; 2.13 where
/// the grid hits it). Fixed before it was run on data (a first rule, that the deviation two
/// octaves after rise less than `sqrt(2)`, let the 4-h simulation of white noise and a walk
/// make a floor of its minimum on gyro z, its point two octaves after low by chance).
pub const FLOOR_BOWL: f64 = std::f64::consts::SQRT_2;

/// How far before the minimum (a factor in averaging time) the curve must have stopped falling:
/// two octaves.
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
    /// The averaging time of the minimum (s).
    pub tau_s: f64,
    /// The minimum deviation (rate unit, SI).
    pub adev: f64,
    /// Its degrees of freedom under flicker noise.
    pub edf: f64,
    /// The stretch the curve is flat over: the point two octaves before the minimum (s).
    pub from_tau_s: f64,
    /// The minimum's averaging time (s).
    pub to_tau_s: f64,
    /// The bias instability `adev / 0.664` (rate unit, SI).
    pub value: f64,
    /// Lower end of its 68 % interval.
    pub lower: f64,
    /// Upper end of its 68 % interval.
    pub upper: f64,
}

/// The floor of `curve` at averaging times from `tau_min_s` on, where it has one (module docs).
/// Below the sensor's correlation time its own filter shapes the curve (the Allan fit's
/// fitted range, [`crate::fit::NoiseFit::tau_min_s`]): a filter flattens the curve at the
/// short taus, and that is no floor.
pub fn flicker_floor(curve: &AllanCurve, tau_min_s: f64) -> Option<Floor> {
    let flicker_ci = |i: usize| {
        let p = &curve.points[i];
        let edf: f64 = curve
            .interval_records
            .iter()
            .map(|&l| edf::edf_overlapping(l + 1, p.m, NoiseType::Flicker))
            .sum();
        let (lo, hi) = edf::confidence_interval(p.adev, edf, edf::ONE_SIGMA);
        (edf, lo, hi)
    };
    let valid = |i: usize| {
        let p = &curve.points[i];
        p.terms > 0 && p.adev.is_finite() && p.adev > 0.0 && p.tau_s >= tau_min_s * (1.0 - 1e-9)
    };
    let n = curve.points.len();
    let min = (0..n)
        .filter(|&i| valid(i) && flicker_ci(i).0 >= FLOOR_MIN_EDF)
        .min_by(|&a, &b| curve.points[a].adev.total_cmp(&curve.points[b].adev))?;
    // The point two octaves before the minimum: the curve must have stopped falling at the
    // white noise's rate by then.
    let tau = curve.points[min].tau_s;
    let before = (0..min)
        .rev()
        .find(|&i| valid(i) && curve.points[i].tau_s <= tau / FLOOR_SPAN * (1.0 + 1e-9))?;
    if curve.points[min].adev / curve.points[before].adev < FLOOR_FALL {
        return None;
    }
    // Two octaves after it (whatever its degrees of freedom), where there is a point: the curve
    // must not bend up on both sides like the bowl of white noise and a walk.
    let after = (min + 1..n)
        .find(|&i| valid(i) && curve.points[i].tau_s >= tau * FLOOR_SPAN * (1.0 - 1e-9));
    let bowl = |i: usize| {
        curve.points[before].adev * curve.points[i].adev / curve.points[min].adev.powi(2)
    };
    if after.is_some_and(|i| bowl(i) >= FLOOR_BOWL) {
        return None;
    }
    let (from, to) = (curve.points[before].tau_s, tau);
    let p = &curve.points[min];
    let (edf, lo, hi) = flicker_ci(min);
    Some(Floor {
        tau_s: p.tau_s,
        adev: p.adev,
        edf,
        from_tau_s: from,
        to_tau_s: to,
        value: p.adev / FLICKER_ADEV,
        lower: lo / FLICKER_ADEV,
        upper: hi / FLICKER_ADEV,
    })
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
    /// interval reaches 0) dominates the white noise (s; infinite for no walk at all).
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
        longest_rest_s: longest as f64 * curve.tau0_s,
        longest_tau_s,
        walk_contradicted_at,
        walk_crossover_s,
        walk_bound: bound,
        walk: if bound {
            longest_tau_s >= MIN_WALK_BOUND_TAU_S * (1.0 - 1e-9)
        } else {
            longest_tau_s >= FLOOR_SPAN * walk_crossover_s * (1.0 - 1e-9)
                && walk_contradicted_at.is_none()
        },
        bias_instability: flicker_floor(curve, BLOCKS_PER_CORRELATION as f64 * ml.correlation_s)
            .is_some(),
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
        let st = slow_terms(&curve(100_000, bump), &ml(n, k));
        assert!(!st.walk && st.walk_contradicted_at.is_some(), "{st:?}");
    }

    #[test]
    fn a_flat_floor_gives_its_level_and_white_and_walk_give_none() {
        // White 3.2e-4 at 1 s and a flicker floor of B = 1e-4 over 3 h at 100 Hz.
        let b = 1e-4;
        let c = curve(1_080_000, |t| {
            (1e-7 / t + (FLICKER_ADEV * b).powi(2)).sqrt()
        });
        let f = flicker_floor(&c, 0.0).expect("a floor");
        // The minimum is the longest tau of 10 degrees of freedom or more (655 s), where the
        // white noise still adds 2 %.
        let at = c.points.iter().find(|p| p.tau_s == f.tau_s).unwrap();
        assert!(f.edf >= FLOOR_MIN_EDF && f.tau_s > 600.0, "{f:?}");
        assert_eq!(f.value, at.adev / FLICKER_ADEV);
        assert!((f.value / b - 1.0).abs() < 0.03, "{f:?}");
        assert!(f.lower < f.value && f.value < f.upper);
        // White noise and a walk crossing at 1 s: a minimum, no floor; white noise alone: none.
        let c = curve(1_080_000, |t| (1e-6 / t + 1e-6 * t).sqrt());
        assert!(flicker_floor(&c, 0.0).is_none());
        let c = curve(1_080_000, |t| (1e-6 / t).sqrt());
        assert!(flicker_floor(&c, 0.0).is_none());
    }
}
