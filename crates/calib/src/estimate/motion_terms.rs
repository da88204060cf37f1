//! The gyro terms a recording of rests tests by the likelihood ratio of a fit with each: where
//! the noise is measured and a motion's attitude noise comes out above zero, that noise takes in
//! what a gyro term would explain of the motions, and the score test, made at the noise of the
//! fit without the term, loses its power ([`crate::check::score::TermRatio`]). The fit with the
//! term measures its noise again, and the ratio of the two fits' likelihoods decides.

use super::Estimate;
use super::noise::NoiseSource;
use super::verdict::{SCORE_LEVEL, per_term_level};
use crate::check::score::{BaseShift, TermRatio, term_scores};
use crate::model::layout::StateLayout;
use sins_model::candidates::Candidate;

/// The terms a motion's attitude noise can take in: those the gyros integrate through a motion.
pub(super) const MOTION_TERMS: [Candidate; 2] =
    [Candidate::GyroGSensitivity, Candidate::GyroScaleAsymmetry];

/// The motion terms `est` tests (its score pass) and does not call for at the per-term level,
/// with the degrees of freedom of their score test, where `noise` measured a motion's attitude
/// noise above zero: the terms to fit and test by the likelihood ratio.
pub(super) fn terms_to_refit(est: &Estimate, noise: &NoiseSource) -> Vec<(Candidate, usize)> {
    let motion_noise = match noise {
        NoiseSource::Measured {
            motion_noise_deg,
            motion_windows,
            ..
        } => *motion_noise_deg > 0.0 && *motion_windows > 0,
        NoiseSource::Configured => false,
    };
    let Some(p) = est.extended.as_ref().filter(|_| motion_noise) else {
        return Vec::new();
    };
    let scores = term_scores(p, SCORE_LEVEL);
    let threshold = per_term_level(&scores);
    MOTION_TERMS
        .into_iter()
        .filter_map(|c| {
            let t = scores.iter().find(|t| t.term == c.id())?;
            (t.test.dof > 0 && t.test.p_value >= threshold).then_some((c, t.test.dof))
        })
        .collect()
}

/// The likelihood ratio of `term` from the fit without it (`base`) and with it (`with`), its
/// noise measured again, with `dof` degrees of freedom; the largest shift of a base parameter
/// between the two, in its sigmas with the term.
pub(super) fn ratio(term: Candidate, dof: usize, base: &Estimate, with: &Estimate) -> TermRatio {
    let (l0, _) = crate::check::diagnostics::log_likelihood(&base.innovations);
    let (l1, _) = crate::check::diagnostics::log_likelihood(&with.innovations);
    let shift = (StateLayout::INSTRUMENT..base.names.len())
        .filter_map(|i| {
            let j = with.names.iter().position(|n| *n == base.names[i])?;
            let sigma = with.cov[(j, j)].sqrt();
            (sigma > 0.0).then(|| BaseShift {
                name: base.names[i].clone(),
                sigmas: (with.values[j] - base.values[i]) / sigma,
            })
        })
        .max_by(|a, b| a.sigmas.abs().total_cmp(&b.sigmas.abs()));
    TermRatio::new(term.id(), (l0, l1), dof, shift)
}
