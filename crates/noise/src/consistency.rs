//! The maximum-likelihood model against the measured Allan deviation, point by point, and where
//! it leaves the measured band, why.
//!
//! Why a check of its own: the likelihood's whiteness check ([`crate::likelihood::whiteness`])
//! looks at the innovations over windows of blocks, all rests pooled; the longest averaging
//! times of the Allan curve rest on the longest rests alone (an interval of `L` records has no
//! term at `2m > L`), while the likelihood's walk is set by every rest. Where the two disagree
//! the model's Allan deviation can lie far above or below the measured one at the long taus
//! and the whiteness check still pass (docs/noise.md, "The likelihood model against the
//! measured deviation").
//!
//! ## The test
//!
//! At every averaging time from the likelihood's block duration on, or from 1 s where the
//! blocks are longer (the white level is reported as the deviation of a 1-s average, so the
//! model must hold there; below the block duration the likelihood sees no data otherwise: the
//! block means are all it has, and the sensor's own filter shapes the curve there), the measured Allan variance with `edf` degrees of freedom is, if the model is right,
//! `model chi^2(edf) / edf`, the degrees of freedom those of the noise type that dominates the
//! *model* there (the null hypothesis is the model, not the Allan fit). The family is every
//! point tested on every axis of the recording; its level [`FAMILY_LEVEL`] is split over them
//! by Bonferroni (valid whatever the correlation of neighbouring octaves, which is strong for a
//! walk; so conservative there). At each point the model must lie in the measured deviation's
//! interval at `1 - level / points`, widened by the model's own uncertainty: the ends of its
//! 68 % profile intervals (one level at a time, the others at their values) give the model's
//! spread in `ln adev` below and above, scaled to the same level's normal quantile and added
//! in quadrature to the measured interval's half-width in `ln adev` on that side. Without the
//! model's spread a long recording's short-tau points, whose band is a few tenths of a per cent
//! wide, would charge the model for its own white level's uncertainty.
//!
//! ## The cause
//!
//! For an axis with points outside, the rests are split into those long enough for the point
//! furthest outside (`2m` records or more: the only ones its estimate rests on) and the others, and the white-and-walk likelihood ([`crate::likelihood::fit_white_walk`]) is
//! fitted to each on the blocks of the full fit ([`Split`]). [`name_cause`] then says which of
//! three it is: the two walks differ by [`WALKS_DIFFER_SIGMAS`] or more (the difference over the
//! half-widths toward each other, in quadrature): one walk for all rests cannot be both; else
//! the long rests' own curve falls (rises) between an earlier averaging time and the worst
//! point faster than white noise (a walk) can, which no white noise plus walk follows; else
//! not named.

use crate::NoiseError;
use crate::allan;
use crate::edf::{self, NoiseType};
use crate::likelihood::{self, Blocks, Level, MlFit, Model};
use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, Normal};

/// Family-wise level of the check: the probability that a right model is flagged at one or
/// more of the points tested over all axes of a recording is at most this (Bonferroni). Fixed
/// before the check was first run on any recording.
pub const FAMILY_LEVEL: f64 = 0.05;

/// How many sigmas (of their difference) the two walks must differ by to be named the cause.
pub const WALKS_DIFFER_SIGMAS: f64 = 2.0;

/// The check at one averaging time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointCheck {
    /// Averaging time (s) and factor.
    pub tau_s: f64,
    /// Averaging factor (records per average).
    pub m: usize,
    /// Measured Allan deviation (rate unit, SI).
    pub measured: f64,
    /// The likelihood model's Allan deviation.
    pub model: f64,
    /// `model / measured`.
    pub ratio: f64,
    /// Degrees of freedom of the measured estimate under the model's noise type.
    pub edf: f64,
    /// The model's dominant noise type there.
    pub noise_type: NoiseType,
    /// The band the model must lie in (the measured interval at the corrected level, widened
    /// by the model's own uncertainty).
    pub lower: f64,
    /// Upper end of that band.
    pub upper: f64,
    /// Whether the model is outside the band.
    pub outside: bool,
}

/// The check of one axis: the points tested, from the likelihood's block duration on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisCheck {
    /// The shortest averaging time tested (s): the likelihood's block duration, or 1 s where
    /// the blocks are longer ([`tested_from_s`]).
    pub from_tau_s: f64,
    /// Every point tested.
    pub points: Vec<PointCheck>,
}

impl AxisCheck {
    /// The points where the model is outside the band.
    pub fn outside(&self) -> impl Iterator<Item = &PointCheck> {
        self.points.iter().filter(|p| p.outside)
    }

    /// Whether the model lies within the band at every point tested.
    pub fn passes(&self) -> bool {
        self.outside().next().is_none()
    }

    /// The point outside furthest from the measured deviation (in `|ln ratio|`).
    pub fn worst(&self) -> Option<&PointCheck> {
        self.outside()
            .max_by(|a, b| a.ratio.ln().abs().total_cmp(&b.ratio.ln().abs()))
    }
}

/// The check of every axis of a recording as one family.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FamilyCheck {
    /// [`FAMILY_LEVEL`].
    pub family_level: f64,
    /// Points tested over all axes.
    pub points: usize,
    /// The level of each point: `family_level / points`.
    pub point_level: f64,
    /// Per axis, in the order given.
    pub axes: Vec<AxisCheck>,
}

/// The shortest averaging time tested against fit `ml` (s): its block duration, or 1 s where
/// the blocks are longer. The fit's white level is reported as the deviation of a 1-s average
/// (the `[noise]` convention), so the model must hold there too: a fit on blocks of 94 s whose
/// check looked from 164 s on passed a white level 1.6 times the Allan deviation at 1 s (a
/// flicker floor taken for white noise at the block duration).
pub fn tested_from_s(ml: &MlFit) -> f64 {
    ml.block_s.min(1.0)
}

/// Whether a curve point is tested against fit `ml`: at or above [`tested_from_s`], with a
/// measured deviation.
fn tested(p: &allan::AllanPoint, ml: &MlFit) -> bool {
    p.tau_s >= tested_from_s(ml) * (1.0 - 1e-9) && p.terms > 0 && p.adev.is_finite() && p.adev > 0.0
}

/// Check the likelihood model of every axis (`(curve, fit)` pairs) against its measured curve,
/// as one family (module docs).
pub fn check_family(axes: &[(&allan::AllanCurve, &MlFit)]) -> FamilyCheck {
    let points: usize = axes
        .iter()
        .map(|(c, ml)| c.points.iter().filter(|p| tested(p, ml)).count())
        .sum();
    let point_level = FAMILY_LEVEL / points.max(1) as f64;
    FamilyCheck {
        family_level: FAMILY_LEVEL,
        points,
        point_level,
        axes: axes
            .iter()
            .map(|(c, ml)| check_axis(c, ml, point_level))
            .collect(),
    }
}

/// Check one axis's likelihood model against its curve at `point_level` per point.
pub fn check_axis(curve: &allan::AllanCurve, ml: &MlFit, point_level: f64) -> AxisCheck {
    let model = ml.model();
    let z = Normal::standard().inverse_cdf(1.0 - 0.5 * point_level);
    let points = curve
        .points
        .iter()
        .filter(|p| tested(p, ml))
        .map(|p| {
            let noise_type = dominant_type(&model, p.tau_s);
            let edf: f64 = curve
                .interval_records
                .iter()
                .map(|&l| edf::edf_overlapping(l + 1, p.m, noise_type))
                .sum();
            let m_adev = model.avar(p.tau_s).sqrt();
            let (lo, hi) = edf::confidence_interval(p.adev, edf, 1.0 - point_level);
            let (s_lo, s_hi) = model_spread(ml, p.tau_s);
            let up = (hi / p.adev).ln().hypot(z * s_lo);
            let down = (p.adev / lo).ln().hypot(z * s_hi);
            let (lower, upper) = (p.adev * (-down).exp(), p.adev * up.exp());
            PointCheck {
                tau_s: p.tau_s,
                m: p.m,
                measured: p.adev,
                model: m_adev,
                ratio: m_adev / p.adev,
                edf,
                noise_type,
                lower,
                upper,
                // A model that is not a number (none the fit gives) is no finding.
                outside: m_adev.is_finite() && !(lower..=upper).contains(&m_adev),
            }
        })
        .collect();
    AxisCheck {
        from_tau_s: tested_from_s(ml),
        points,
    }
}

/// The noise type whose slope is nearest the model's on the log-log plot at `tau_s` (the
/// variance's slope -1 white, 0 flicker, +1 walk): what sets the degrees of freedom of an
/// estimate drawn from that model (a Gauss-Markov bias rises like a walk below its correlation
/// time and falls like white noise above it).
fn dominant_type(model: &Model, tau_s: f64) -> NoiseType {
    let h = 1.01f64;
    let slope = (model.avar(tau_s * h) / model.avar(tau_s / h)).ln() / (2.0 * h.ln());
    if slope < -0.5 {
        NoiseType::WhiteRate
    } else if slope < 0.5 {
        NoiseType::Flicker
    } else {
        NoiseType::RandomWalk
    }
}

/// The model's one-sigma spread in `ln adev` at `tau_s`, below and above: each level moved to
/// an end of its 68 % profile interval, the others at their values, the shifts in quadrature.
fn model_spread(ml: &MlFit, tau_s: f64) -> (f64, f64) {
    let base = ml.model();
    let a0 = base.avar(tau_s);
    let shift = |m: Model| 0.5 * (m.avar(tau_s) / a0).ln();
    let side = |pick: fn(&Level) -> f64| {
        let mut s2 = shift(Model {
            white: pick(&ml.white),
            ..base
        })
        .powi(2)
            + shift(Model {
                walk: pick(&ml.walk),
                ..base
            })
            .powi(2);
        if let Some(g) = &ml.gauss_markov {
            s2 += shift(Model {
                gauss_markov: Some((pick(&g.sigma), g.correlation_time_s)),
                ..base
            })
            .powi(2);
        }
        let s = s2.sqrt();
        // An end at 0 or infinity bounds nothing: the model is not pinned on that side.
        if s.is_finite() { s } else { f64::INFINITY }
    };
    (side(|l| l.lower), side(|l| l.upper))
}

/// The white-and-walk likelihood of the long rests and of the others, and the long rests' own
/// Allan deviation, for one axis ([`SplitFits`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Split {
    /// The shortest length (records) of a long rest: `2m` of the point furthest outside the
    /// band.
    pub long_records: usize,
    /// Rests in each part.
    pub long_rests: usize,
    /// Rests not long enough.
    pub other_rests: usize,
    /// The walk of the long rests alone (`None`: too few blocks or no noise).
    pub long_walk: Option<Level>,
    /// The walk of the other rests.
    pub other_walk: Option<Level>,
    /// The long rests' own Allan deviation: `(tau_s, adev)` at octaves.
    pub long_curve: Vec<(f64, f64)>,
}

/// Gathers, one rest at a time, what [`Split`] needs: the block means of each part (blocks of
/// the full fit's length, each rest's mean removed, as the full fit blocks them) and the long
/// rests' Allan sums.
#[derive(Clone, Debug)]
pub struct SplitFits {
    tau0_s: f64,
    block_records: usize,
    long_records: usize,
    long: Vec<Vec<(f64, f64)>>,
    other: Vec<Vec<(f64, f64)>>,
    /// Per octave `m`: the sum of `avar * terms` and the terms, over the long rests.
    allan: Vec<(usize, f64, usize)>,
}

impl SplitFits {
    /// For record interval `tau0_s`, blocks of `block_records` records, and long rests of at
    /// least `long_records` records.
    pub fn new(tau0_s: f64, block_records: usize, long_records: usize) -> Self {
        Self {
            tau0_s,
            block_records: block_records.max(1),
            long_records,
            long: Vec::new(),
            other: Vec::new(),
            allan: Vec::new(),
        }
    }

    /// One rest's increments (SI, one per record); a rest of fewer than two records, or with a
    /// value that is not finite, is left out.
    pub fn push(&mut self, data: &[f64]) {
        if data.len() < 2 || data.iter().any(|x| !x.is_finite()) {
            return;
        }
        let mean = data.iter().sum::<f64>() / data.len() as f64;
        let blocks: Vec<(f64, f64)> = data
            .chunks(self.block_records)
            .map(|c| {
                let s: f64 = c.iter().map(|v| v - mean).sum();
                let d = c.len() as f64 * self.tau0_s;
                (s / d, d)
            })
            .collect();
        if data.len() < self.long_records {
            self.other.push(blocks);
            return;
        }
        self.long.push(blocks);
        // One interval, the whole rest.
        let whole = 0..data.len();
        let Ok(curve) = allan::overlapping_allan(data, self.tau0_s, std::slice::from_ref(&whole))
        else {
            return;
        };
        for (j, p) in curve.points.iter().enumerate() {
            if self.allan.len() <= j {
                self.allan.push((p.m, 0.0, 0));
            }
            self.allan[j].1 += p.avar * p.terms as f64;
            self.allan[j].2 += p.terms;
        }
    }

    /// Both fits and the long rests' curve.
    pub fn finish(self) -> Split {
        let walk = |intervals: Vec<Vec<(f64, f64)>>| -> Option<Level> {
            let blocks = Blocks {
                block_s: self.block_records as f64 * self.tau0_s,
                intervals,
            };
            let fit: Result<_, NoiseError> = likelihood::fit_white_walk(&blocks);
            fit.ok().map(|(_, k)| k)
        };
        let (long_rests, other_rests) = (self.long.len(), self.other.len());
        let long_curve = self
            .allan
            .iter()
            .filter(|(_, _, n)| *n > 0)
            .map(|&(m, s, n)| (m as f64 * self.tau0_s, (s / n as f64).sqrt()))
            .collect();
        Split {
            long_records: self.long_records,
            long_rests,
            other_rests,
            long_walk: if long_rests > 0 {
                walk(self.long)
            } else {
                None
            },
            other_walk: if other_rests > 0 {
                walk(self.other)
            } else {
                None
            },
            long_curve,
        }
    }
}

/// Why the model leaves the band on an axis ([`name_cause`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Cause {
    /// The walk of the long rests and that of the others differ by `sigmas` (at least
    /// [`WALKS_DIFFER_SIGMAS`]): one walk for all rests cannot be both.
    WalksDiffer {
        /// The difference over its sigma.
        sigmas: f64,
    },
    /// The long rests' own deviation falls (or rises) from `from_tau_s` to `to_tau_s` by
    /// `factor`, more than white noise falls (a walk rises) over that span (`limit`).
    Shape {
        /// From this averaging time (s).
        from_tau_s: f64,
        /// To the point furthest outside (s).
        to_tau_s: f64,
        /// The long rests' deviation at the first over that at the second (falls) or the
        /// second over the first (rises).
        factor: f64,
        /// The same ratio for white noise (falls) or a walk (rises): `sqrt(to / from)`.
        limit: f64,
        /// Whether the model lies above the data there (the curve falls).
        falls: bool,
    },
    /// Neither: the walks agree within [`WALKS_DIFFER_SIGMAS`] (or cannot be compared) and the
    /// long rests' curve does not bend beyond what the two terms follow.
    NotNamed {
        /// The walks' difference over its sigma, where both were fitted.
        sigmas: Option<f64>,
    },
}

/// The walks' difference over its sigma: the half-widths of their 68 % intervals toward each
/// other, in quadrature (positive where the other rests' walk is the larger).
pub fn walks_sigmas(long: &Level, other: &Level) -> f64 {
    let d = other.value - long.value;
    let s = long
        .half_width_toward(other.value)
        .hypot(other.half_width_toward(long.value));
    if s > 0.0 { d / s } else { 0.0 }
}

/// The cause of an axis's points outside the band (module docs); `None` where it passes.
pub fn name_cause(check: &AxisCheck, split: &Split) -> Option<Cause> {
    let worst = check.worst()?;
    let sigmas = match (&split.long_walk, &split.other_walk) {
        (Some(l), Some(o)) => Some(walks_sigmas(l, o)),
        _ => None,
    };
    if let Some(s) = sigmas
        && s.abs() >= WALKS_DIFFER_SIGMAS
    {
        return Some(Cause::WalksDiffer { sigmas: s });
    }
    let falls = worst.ratio > 1.0;
    let at = split
        .long_curve
        .iter()
        .find(|(t, _)| (t / worst.tau_s - 1.0).abs() < 1e-6);
    let shape = at.and_then(|&(t_f, a_f)| {
        split
            .long_curve
            .iter()
            .filter(|(t, a)| *t >= check.from_tau_s * (1.0 - 1e-9) && *t < t_f && *a > 0.0)
            .map(|&(t, a)| {
                let factor = if falls { a / a_f } else { a_f / a };
                (t, factor, (t_f / t).sqrt())
            })
            .max_by(|x, y| (x.1 / x.2).total_cmp(&(y.1 / y.2)))
            .filter(|(_, factor, limit)| factor > limit)
            .map(|(t, factor, limit)| Cause::Shape {
                from_tau_s: t,
                to_tau_s: t_f,
                factor,
                limit,
                falls,
            })
    });
    Some(shape.unwrap_or(Cause::NotNamed { sigmas }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(value: f64, lower: f64, upper: f64) -> Level {
        Level {
            value,
            lower,
            upper,
        }
    }

    #[test]
    fn walks_sigmas_take_the_half_widths_toward_each_other() {
        // 2.2e-4 [1.3e-4, 3.8e-4] against 6.9e-4 [5.8e-4, 8.0e-4]: (6.9 - 2.2) / hypot(1.6, 1.1).
        let s = walks_sigmas(
            &level(2.2e-4, 1.3e-4, 3.8e-4),
            &level(6.9e-4, 5.8e-4, 8.0e-4),
        );
        assert!((s - 4.7 / 1.6f64.hypot(1.1)).abs() < 1e-9, "{s}");
        let s = walks_sigmas(&level(1.0, 0.9, 1.1), &level(1.0, 0.9, 1.1));
        assert_eq!(s, 0.0);
    }

    /// An axis check whose only point outside is at `tau_s` with `ratio`.
    fn outside_at(tau_s: f64, ratio: f64) -> AxisCheck {
        AxisCheck {
            from_tau_s: 0.2,
            points: vec![PointCheck {
                tau_s,
                m: (tau_s / 0.01).round() as usize,
                measured: 1.0,
                model: ratio,
                ratio,
                edf: 3.0,
                noise_type: NoiseType::RandomWalk,
                lower: 0.5,
                upper: 2.0,
                outside: true,
            }],
        }
    }

    fn split(long: Level, other: Level, long_curve: Vec<(f64, f64)>) -> Split {
        Split {
            long_records: 2048,
            long_rests: 1,
            other_rests: 37,
            long_walk: Some(long),
            other_walk: Some(other),
            long_curve,
        }
    }

    #[test]
    fn the_cause_is_the_walks_then_the_shape_then_not_named() {
        let check = outside_at(10.24, 5.5);
        let curve = vec![(2.56, 1.3), (5.12, 1.5), (10.24, 0.45)];
        // Walks 4 sigma apart: named first, whatever the curve.
        let c = name_cause(
            &check,
            &split(level(1.0, 0.5, 1.5), level(3.0, 2.5, 3.5), curve.clone()),
        );
        assert!(
            matches!(c, Some(Cause::WalksDiffer { sigmas }) if sigmas > 2.0),
            "{c:?}"
        );
        // Walks that agree, a curve falling 3.3 times over an octave (white: 1.41).
        let c = name_cause(
            &check,
            &split(level(1.1, 0.9, 1.5), level(1.4, 1.2, 1.8), curve),
        );
        match c {
            Some(Cause::Shape {
                from_tau_s,
                factor,
                limit,
                falls: true,
                ..
            }) => {
                assert_eq!(from_tau_s, 5.12);
                assert!((factor - 1.5 / 0.45).abs() < 1e-12 && (limit - 2f64.sqrt()).abs() < 1e-9);
            }
            _ => panic!("{c:?}"),
        }
        // A curve falling slower than white noise: not named.
        let white = vec![(2.56, 1.9), (5.12, 1.4), (10.24, 1.0)];
        let c = name_cause(
            &check,
            &split(level(1.1, 0.9, 1.5), level(1.4, 1.2, 1.8), white),
        );
        assert!(
            matches!(c, Some(Cause::NotNamed { sigmas: Some(_) })),
            "{c:?}"
        );
        // A check that passes has no cause.
        let mut pass = check.clone();
        pass.points[0].outside = false;
        assert_eq!(
            name_cause(
                &pass,
                &split(level(1.0, 0.5, 1.5), level(3.0, 2.5, 3.5), vec![])
            ),
            None
        );
    }

    #[test]
    fn the_dominant_type_follows_the_slope() {
        let m = Model {
            white: 1.0,
            walk: 0.1,
            gauss_markov: None,
        };
        // Crossover sqrt(3) N / K = 17.3 s.
        assert_eq!(dominant_type(&m, 0.1), NoiseType::WhiteRate);
        assert_eq!(dominant_type(&m, 17.3), NoiseType::Flicker);
        assert_eq!(dominant_type(&m, 1000.0), NoiseType::RandomWalk);
    }
}
