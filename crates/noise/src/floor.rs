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
//! point of fewer is as likely a low draw as the floor) and its neighbours whose 68 % interval (flicker degrees of freedom)
//! reaches down to within [`FLAT_FACTOR`] of the minimum form a run; the run must span at least
//! [`FLOOR_SPAN`] in averaging time (two octaves). White noise and a walk alone have a minimum
//! too, but no flat run: one octave either side of their minimum the deviation is 1.12 times
//! it, two octaves 1.46 times. The interval of `B` is the minimum point's own 68 % interval
//! over 0.664 (its degrees of freedom those of flicker noise). The minimum of noisy estimates is
//! biased low (the lowest of several); on a flat floor the neighbours' scatter is that of one
//! estimate, which the interval covers.
//!
//! ## Rests too short to tell
//!
//! A bias instability and a walk are slow: from rests of a few seconds neither can be told from
//! white noise, from the other, or from a unit settling after each motion. [`slow_terms`] says
//! whether the rests are long enough: a walk only where the longest averaging time reaches two
//! octaves beyond the time where the walk's Allan variance equals the white noise's (it then
//! dominates the curve over two octaves; where the walk's interval reaches 0, the walk at its
//! upper end is taken: the rests must be long enough to see the largest walk the data allow);
//! a bias instability only where the curve shows a floor (above).

use crate::allan::AllanCurve;
use crate::edf::{self, NoiseType};
use crate::likelihood::MlFit;
use serde::{Deserialize, Serialize};

/// Deviation factor within which a neighbour of the minimum counts as on the floor (its 68 %
/// interval's lower end at most this times the minimum). Fixed before the first run on data.
pub const FLAT_FACTOR: f64 = 1.1;

/// Degrees of freedom (under flicker noise) the minimum point must have: its deviation then
/// has a relative standard deviation of about 22 % at most. The lowest of the curve's points
/// whatever their degrees of freedom was tried first: on the simulated recording of
/// `tests/mems.rs` it was the last point (2.7 degrees of freedom), at half the floor.
pub const FLOOR_MIN_EDF: f64 = 10.0;

/// The span in averaging time (last over first point) a floor must have: two octaves.
pub const FLOOR_SPAN: f64 = 4.0;

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
    /// The flat run around it: first and last averaging time (s).
    pub from_tau_s: f64,
    /// Last averaging time of the run (s).
    pub to_tau_s: f64,
    /// The bias instability `adev / 0.664` (rate unit, SI).
    pub value: f64,
    /// Lower end of its 68 % interval.
    pub lower: f64,
    /// Upper end of its 68 % interval.
    pub upper: f64,
}

/// The floor of `curve`, where it has one (module docs).
pub fn flicker_floor(curve: &AllanCurve) -> Option<Floor> {
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
        p.terms > 0 && p.adev.is_finite() && p.adev > 0.0
    };
    let n = curve.points.len();
    let min = (0..n)
        .filter(|&i| valid(i) && flicker_ci(i).0 >= FLOOR_MIN_EDF)
        .min_by(|&a, &b| curve.points[a].adev.total_cmp(&curve.points[b].adev))?;
    let bound = FLAT_FACTOR * curve.points[min].adev;
    let on_floor = |i: usize| valid(i) && flicker_ci(i).1 <= bound;
    let mut first = min;
    while first > 0 && on_floor(first - 1) {
        first -= 1;
    }
    let mut last = min;
    while last + 1 < n && on_floor(last + 1) {
        last += 1;
    }
    let (from, to) = (curve.points[first].tau_s, curve.points[last].tau_s);
    if to < FLOOR_SPAN * from * (1.0 - 1e-9) {
        return None;
    }
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
    /// The averaging time from which the walk (at its value, or at its upper end where its
    /// interval reaches 0) dominates the white noise (s; infinite for no walk at all).
    pub walk_crossover_s: f64,
    /// Whether the walk is determined: the curve reaches [`FLOOR_SPAN`] times the crossover.
    pub walk: bool,
    /// Whether a bias instability is determined: the curve shows a floor
    /// ([`flicker_floor`]).
    pub bias_instability: bool,
}

/// Whether the rests of `curve` are long enough to tell a walk (the likelihood's, `ml`) and a
/// bias instability (module docs).
pub fn slow_terms(curve: &AllanCurve, ml: &MlFit) -> SlowTerms {
    let longest = curve.interval_records.iter().copied().max().unwrap_or(0);
    let longest_tau_s = curve
        .points
        .iter()
        .filter(|p| p.terms > 0)
        .map(|p| p.tau_s)
        .fold(0.0, f64::max);
    let k = if ml.walk.lower > 0.0 {
        ml.walk.value
    } else {
        ml.walk.upper
    };
    // N^2 / tau = K^2 tau / 3 at tau = sqrt(3) N / K.
    let walk_crossover_s = if k > 0.0 && k.is_finite() {
        3f64.sqrt() * ml.white.value / k
    } else {
        f64::INFINITY
    };
    SlowTerms {
        longest_rest_s: longest as f64 * curve.tau0_s,
        longest_tau_s,
        walk_crossover_s,
        walk: longest_tau_s >= FLOOR_SPAN * walk_crossover_s * (1.0 - 1e-9),
        bias_instability: flicker_floor(curve).is_some(),
    }
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

    #[test]
    fn a_flat_floor_gives_its_level_and_white_and_walk_give_none() {
        // White 1e-3 at 1 s and a flicker floor of B = 1e-4 over 3 h at 100 Hz.
        let b = 1e-4;
        let c = curve(1_080_000, |t| {
            (1e-6 / t + (FLICKER_ADEV * b).powi(2)).sqrt()
        });
        let f = flicker_floor(&c).expect("a floor");
        // The minimum is at the longest tau, where the white noise still adds 2 %.
        let last = c.points.last().unwrap();
        assert_eq!(f.tau_s, last.tau_s);
        assert_eq!(f.value, last.adev / FLICKER_ADEV);
        assert!((f.value / b - 1.0).abs() < 0.03, "{f:?}");
        assert!(f.lower < f.value && f.value < f.upper);
        // White noise and a walk crossing at 1 s: a minimum, no floor.
        let c = curve(1_080_000, |t| (1e-6 / t + 1e-6 * t).sqrt());
        assert!(flicker_floor(&c).is_none());
    }
}
