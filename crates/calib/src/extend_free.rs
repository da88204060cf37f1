//! The model-extension loop for free-motion recordings (`sins-calib diagnose --free-motion`):
//! the same decision rule as [`crate::extend`] on the batch fit of [`crate::free_motion`],
//! with the candidate terms that fit has (gyro g-sensitivity, gyro scale-factor asymmetry).
//!
//! The evidence for a term is the drop of the joint stage's chi-square when it is added,
//! measured in units of the extended fit's residual variance (`F = (S_base - S_ext) /
//! (S_ext / dof_ext)`, compared with chi-square on the term's parameters: the fits rescale
//! their weights by the residual scatter, so the raw drop would overstate the evidence on a
//! recording whose noise is not the assumed one). A term is separable when every one of its
//! parameters ends at most half its prior sigma. The gain is measured where the data allow it:
//! on the held-out static intervals (`holdout`).

use crate::evidence::{SEPARATED_SIGMA_RATIO, chi_square_sf, ln_chi_square_sf};
use crate::free_motion::{
    FreeMotionError, FreeMotionResult, FreeMotionSettings, Interval, KnownTurn,
    calibrate_free_motion,
};
use crate::io::ImuData;
use serde::Serialize;
use sins_model::candidates::Candidate;
use sins_model::units::DEG;
use std::collections::BTreeMap;

/// The candidate terms of the free-motion fit.
pub const FREE_MOTION_CANDIDATES: [Candidate; 2] =
    [Candidate::GyroGSensitivity, Candidate::GyroScaleAsymmetry];

/// Evidence for one candidate in one round.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FreeCandidate {
    /// Term id.
    pub term: String,
    /// The scaled chi-square drop.
    pub statistic: f64,
    /// Parameters of the term.
    pub dof: usize,
    /// p-value.
    pub p_value: f64,
    /// Every parameter at most half its prior sigma.
    pub separable: bool,
    /// Largest posterior / prior sigma of its parameters.
    pub worst_sigma_ratio: f64,
}

/// What an accepted term gained.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FreeGain {
    /// Reduced chi-square of the joint stage, before and after.
    pub reduced_chi2: (f64, f64),
    /// Held-out rotation RMS (deg), before and after (NaN without a hold-out).
    pub held_out_rotation_deg: (f64, f64),
    /// Held-out static RMS of `|f| - g` (m/s^2), before and after.
    pub held_out_static_m_s2: (f64, f64),
}

/// One round.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FreeRound {
    /// Candidates, best-supported first.
    pub candidates: Vec<FreeCandidate>,
    /// The p-value to beat.
    pub threshold: f64,
    /// The term accepted, if any.
    pub accepted: Option<String>,
    /// The held-out gain of the candidate the statistics picked ([`held_out_gain`]; `None`
    /// without a hold-out, or when none was picked). Negative: refused.
    pub held_out_gain: Option<f64>,
}

/// The held-out log-likelihood gain of `after` over `before`: the held-out static residuals
/// (`|f| - g`, one per held-out interval) and rotation residuals (one angle per pair of
/// consecutive held-out intervals) together, each kind Gaussian with its variance at its own
/// mean square (profiled): `-n_static ln(s_after / s_before) - n_pairs ln(r_after / r_before)`.
/// `None` without a hold-out (or with an RMS of 0). A term is accepted only where it is not
/// negative: a g-sensitivity that cut the held-out rotation error of a consumer recording from
/// 0.29 to 0.03 deg and tripled its held-out static error would be weighed by both.
pub fn held_out_gain(before: &FreeMotionResult, after: &FreeMotionResult) -> Option<f64> {
    let (b, a) = (before.validation.as_ref()?, after.validation.as_ref()?);
    profiled_gain(
        (
            a.intervals,
            b.static_rms_after_m_s2,
            a.static_rms_after_m_s2,
        ),
        (
            a.rotation_pairs,
            b.rotation_rms_after_rad,
            a.rotation_rms_after_rad,
        ),
    )
}

/// `-n ln(after / before)` summed over the kinds `(n, rms_before, rms_after)`: the change of a
/// Gaussian log-likelihood of `n` residuals whose variance is profiled (set to their mean
/// square). `None` where an RMS is 0 or not finite.
fn profiled_gain(kinds: (usize, f64, f64), more: (usize, f64, f64)) -> Option<f64> {
    [kinds, more]
        .into_iter()
        .map(|(n, before, after)| {
            if n == 0 {
                Some(0.0)
            } else if before > 0.0 && after > 0.0 && before.is_finite() && after.is_finite() {
                Some(-(n as f64) * (after / before).ln())
            } else {
                None
            }
        })
        .sum()
}

/// The loop's result.
#[derive(Clone, Debug)]
pub struct FreeLoop {
    /// Terms in the order accepted.
    pub accepted_terms: Vec<String>,
    /// Every round.
    pub rounds: Vec<FreeRound>,
    /// Gain of each accepted term.
    pub gain: BTreeMap<String, FreeGain>,
    /// The paper's model fitted.
    pub base: FreeMotionResult,
    /// The final model fitted.
    pub last: FreeMotionResult,
}

impl FreeLoop {
    /// The last round's held-out gain when it refused the candidate the statistics picked.
    pub fn held_out_rejection(&self) -> Option<(&str, f64)> {
        let last = self.rounds.last()?;
        let g = last.held_out_gain.filter(|g| *g < 0.0)?;
        Some((last.candidates.first()?.term.as_str(), g))
    }
}

fn with_term(
    settings: &FreeMotionSettings,
    c: Candidate,
    base: &FreeMotionSettings,
) -> FreeMotionSettings {
    let mut s = *settings;
    match c {
        Candidate::GyroGSensitivity => s.g_sensitivity_prior = base.g_sensitivity_prior,
        Candidate::GyroScaleAsymmetry => s.scale_asymmetry_prior = base.scale_asymmetry_prior,
        _ => {}
    }
    s
}

/// Sum of squared normalised data residuals and its degrees of freedom.
fn chi2(r: &FreeMotionResult) -> (f64, f64) {
    let f = &r.gyro_fit;
    let dof = (f.residuals as f64 - f.effective_parameters).max(1.0);
    (f.reduced_chi2 * dof, dof)
}

fn evidence(current: &FreeMotionResult, ext: &FreeMotionResult, c: Candidate) -> FreeCandidate {
    let names = c.param_names();
    let ratios: Vec<f64> = ext
        .parameters
        .iter()
        .zip(&ext.prior_sigma)
        .filter(|(p, _)| names.contains(&p.name))
        .map(|(p, s0)| p.sigma.unwrap_or(*s0) / s0)
        .collect();
    let worst = ratios.iter().copied().fold(0.0, f64::max);
    let ((s0, _), (s1, d1)) = (chi2(current), chi2(ext));
    let statistic = ((s0 - s1) / (s1 / d1)).max(0.0);
    let dof = ratios.len();
    FreeCandidate {
        term: c.id().to_string(),
        statistic,
        dof,
        p_value: chi_square_sf(statistic, dof),
        separable: !ratios.is_empty() && worst <= SEPARATED_SIGMA_RATIO,
        worst_sigma_ratio: worst,
    }
}

fn gain(before: &FreeMotionResult, after: &FreeMotionResult) -> FreeGain {
    let v = |r: &FreeMotionResult| {
        r.validation.as_ref().map_or((f64::NAN, f64::NAN), |v| {
            (v.rotation_rms_after_rad / DEG, v.static_rms_after_m_s2)
        })
    };
    let (b, a) = (v(before), v(after));
    FreeGain {
        reduced_chi2: (before.gyro_fit.reduced_chi2, after.gyro_fit.reduced_chi2),
        held_out_rotation_deg: (b.0, a.0),
        held_out_static_m_s2: (b.1, a.1),
    }
}

/// Run the loop: `settings` carry the priors of the candidate terms (the defaults of
/// [`FreeMotionSettings::new`]); the base fit has both terms off. `level` is the family-wise
/// level of each round.
pub fn free_motion_loop(
    data: &ImuData,
    intervals: &[Interval],
    turns: &[KnownTurn],
    settings: &FreeMotionSettings,
    level: f64,
) -> Result<FreeLoop, FreeMotionError> {
    let mut cur_settings = *settings;
    cur_settings.g_sensitivity_prior = None;
    cur_settings.scale_asymmetry_prior = None;
    let base = calibrate_free_motion(data, intervals, turns, &cur_settings)?;
    let mut current = base.clone();
    let (mut accepted, mut rounds, mut gains) = (Vec::new(), Vec::new(), BTreeMap::new());
    let mut remaining = FREE_MOTION_CANDIDATES.to_vec();
    loop {
        let mut ev = Vec::new();
        for &c in &remaining {
            let s = with_term(&cur_settings, c, settings);
            let fit = calibrate_free_motion(data, intervals, turns, &s)?;
            let e = evidence(&current, &fit, c);
            ev.push((ln_chi_square_sf(e.statistic, e.dof), c, e, s, fit));
        }
        ev.sort_by(|a, b| a.0.total_cmp(&b.0));
        let threshold = level / ev.len().max(1) as f64;
        let take = ev
            .first()
            .is_some_and(|(lnp, _, e, _, _)| e.separable && *lnp < threshold.ln());
        let mut round = FreeRound {
            candidates: ev.iter().map(|x| x.2.clone()).collect(),
            threshold,
            accepted: None,
            held_out_gain: None,
        };
        if take {
            // Accepted only where its held-out prediction is not worse.
            round.held_out_gain = held_out_gain(&current, &ev[0].4);
        }
        if !take || round.held_out_gain.is_some_and(|g| g < 0.0) {
            rounds.push(round);
            break;
        }
        let (_, c, e, s, fit) = ev.swap_remove(0);
        gains.insert(e.term.clone(), gain(&current, &fit));
        round.accepted = Some(e.term.clone());
        rounds.push(round);
        accepted.push(e.term);
        remaining.retain(|x| *x != c);
        cur_settings = s;
        current = fit;
        if remaining.is_empty() {
            break;
        }
    }
    Ok(FreeLoop {
        accepted_terms: accepted,
        rounds,
        gain: gains,
        base,
        last: current,
    })
}

#[cfg(test)]
mod tests {
    use super::profiled_gain;

    #[test]
    fn the_held_out_gain_weighs_both_kinds_by_their_counts() {
        // The consumer recording: rotation 0.29 -> 0.03 deg, static tripled. With as
        // many rotation pairs as held-out intervals the rotation wins; with few pairs it does
        // not.
        let g = |n_static, n_pairs| {
            profiled_gain((n_static, 0.0045, 0.0135), (n_pairs, 0.29, 0.03)).unwrap()
        };
        assert!((g(3, 2) - (-3.0 * 3f64.ln() + 2.0 * (0.29f64 / 0.03).ln())).abs() < 1e-12);
        assert!(g(3, 2) > 0.0);
        assert!(g(3, 1) < 0.0);
        // Worse in both: negative; no change: 0; nothing held out: 0; an RMS of 0: none.
        assert!(profiled_gain((4, 1.0, 1.1), (3, 1.0, 1.2)).unwrap() < 0.0);
        assert_eq!(profiled_gain((4, 1.0, 1.0), (3, 2.0, 2.0)), Some(0.0));
        assert_eq!(profiled_gain((0, 0.0, 0.0), (0, 0.0, 0.0)), Some(0.0));
        assert_eq!(profiled_gain((4, 0.0, 1.0), (3, 1.0, 1.0)), None);
    }
}
