//! The model-extension loop: fit the base model, rank the candidate terms by the evidence in
//! the innovations, add the best-supported separable one, measure what it gains, repeat while
//! the gain is significant (the method in full: `docs/model-extension.md`).
//!
//! Each round:
//! 1. every candidate term not yet in the model gets its score statistic, which says whether
//!    the innovations call for it, with a chi-square p-value: along a program from one extended
//!    pass over the round's reference fit with every candidate appended
//!    ([`crate::check::score::solo_scores`], no fit per candidate); on a recording of rests
//!    whose noise every fit measures, from a fit of the model extended by it
//!    ([`crate::extend::evidence::score_test`]); the gyro bias random walk, a noise process and
//!    not a state, is tested by the likelihood ratio of the innovations over a grid of
//!    intensities, with the chi-bar-square p-value of a parameter on the boundary;
//! 2. the same pass's posterior (conditioned on the other candidates being zero,
//!    [`crate::extend::evidence::without_parameters`]), or the fit's, says whether each candidate
//!    is separable from the parameters already in the model
//!    ([`crate::extend::evidence::separability`]);
//! 3. the candidate with the smallest p-value is accepted if that p-value is below the level
//!    divided by the number of candidates tested in the round (Bonferroni: the family-wise
//!    chance of accepting a term the data do not call for stays under the level) and the
//!    log-likelihood rises with it; when it is significant but not separable it is carried
//!    with its prior ([`Round::carried`]) rather than dropped or replaced by a weaker candidate
//!    that would absorb part of its effect;
//! 4. the gain of the accepted term is measured against the model before it: innovation
//!    log-likelihood, AIC and BIC, the mean NIS of each measurement kind and the diagnostics'
//!    verdict.
//!
//! A significant candidate that is not separable is carried and reported with the base
//! parameters it is confounded with: under this program its effect cannot be told from theirs,
//! so its estimate leans on its prior ([`crate::extend::design`] proposes a program that
//! separates it).

pub mod design;
pub mod drift_visibility;
pub mod evidence;
mod fitting;
mod outcome;
mod rounds;
pub use outcome::{
    CandidateEvidence, DriftReach, Fit, HELD_OUT_TOLERANCE_NATS, HeldOutCheck, LoopResult,
    ParameterValue, Round, TermGain, held_out_decides, thermal_untestable,
};
pub use rounds::{drift_reach, run_loop, run_loop_at_rests};

use crate::check::diagnostics::DiagnosticSettings;
use crate::estimate::EstimateError;
use crate::estimate::covariance::AnalysisError;
use crate::model::extension::ModelExtension;
use sins_model::candidates::{Candidate, UnitGrade};

/// Settings of the loop.
#[derive(Clone, Debug, PartialEq)]
pub struct LoopSettings {
    /// Family-wise level of each round's decision (default 0.01).
    pub level: f64,
    /// The candidate terms to consider (default: all).
    pub candidates: Vec<Candidate>,
    /// At most this many terms are accepted.
    pub max_terms: usize,
    /// Intensities (rad/s/sqrt(s)) tried for the gyro bias random walk, common to the three
    /// axes; the best is refined per axis when the term is accepted. `None`: the grade's
    /// ([`drift_grid`]).
    pub drift_grid: Option<Vec<f64>>,
    /// Settings of the diagnostics.
    pub diagnostics: DiagnosticSettings,
    /// The held-out check of a candidate the statistics accept: every `k`-th segment with
    /// measurements held out ([`HeldOutCheck`]); `None` skips the check.
    pub hold_out_every: Option<usize>,
    /// A recording of rests whose white noise was measured in its rests (a hand-turned
    /// recording without a configuration): every fit brings the specific-force level to its
    /// own innovations and measures its own motion noise
    /// (`estimate::hand_turned::fit_measuring_noise`), so that a term is compared with the
    /// model without it each at the noise the data give it (a missing term's misfit read as
    /// motion noise would otherwise hide the term's own information). `None`: the configured
    /// noise.
    pub measured_noise: Option<crate::estimate::hand_turned::WhiteNoiseAtRest>,
}

/// Every fourth segment with measurements is held out for the held-out check: two of the
/// paper program's nine segments, four or five of a 19-position recording's rests.
pub const HOLD_OUT_EVERY: usize = 4;

impl Default for LoopSettings {
    fn default() -> Self {
        Self {
            level: 0.01,
            candidates: Candidate::ALL.to_vec(),
            max_terms: 3,
            drift_grid: None,
            diagnostics: DiagnosticSettings::default(),
            hold_out_every: Some(HOLD_OUT_EVERY),
            measured_noise: None,
        }
    }
}

/// The intensities (rad/s/sqrt(s)) the loop tries for the gyro bias random walk of a unit of
/// `grade`: its prior intensity ([`Candidate::prior_sigma`]) times 0.03, 0.1, 0.3, 1 and 3. For
/// a navigation-grade gyro, whose bias instability is of order 0.003-0.03 deg/h/sqrt(h), that is
/// 0.003 to 0.3 deg/h/sqrt(h): the range and a decade above; for a consumer unit 0.3 to 30.
pub fn drift_grid(grade: UnitGrade) -> Vec<f64> {
    let q = Candidate::GyroBiasDrift.prior_sigma(grade);
    [0.03, 0.1, 0.3, 1.0, 3.0].iter().map(|k| k * q).collect()
}

/// Errors of the loop.
#[derive(Debug, thiserror::Error)]
pub enum LoopError {
    /// A fit failed.
    #[error(transparent)]
    Estimate(#[from] EstimateError),
    /// A covariance analysis failed.
    #[error(transparent)]
    Analysis(#[from] AnalysisError),
    /// The IMU data cover only part of the program: the separability of every term comes from
    /// the covariance analysis of the whole program, and a fit of a part says nothing of it.
    #[error(
        "{file}: the IMU data cover the program from {covered_from_s:.1} s to {covered_to_s:.1} \
         s of its {duration_s:.1} s: diagnose tests terms against the whole program (their \
         separability comes from its covariance analysis); record the whole program, or give a \
         program of what was recorded"
    )]
    PartialProgram {
        /// The IMU file.
        file: String,
        /// Program time of the first and last IMU record (s).
        covered_from_s: f64,
        /// See `covered_from_s`.
        covered_to_s: f64,
        /// The program's duration (s).
        duration_s: f64,
    },
}

/// Program time the IMU data may miss at either end and still count as covering the program
/// (s): a recording stopped within a second of the program's end.
pub const PROGRAM_COVERAGE_SLACK_S: f64 = 1.0;

pub use crate::estimate::score_pass::MIN_THERMAL_SPAN_K;

pub use crate::estimate::noise::NoiseRescale;

pub use crate::check::diagnostics::{held_out_log_density, log_likelihood};

/// `ext` with candidate `c` added at its prior for a unit of `grade`
/// ([`Candidate::prior_sigma`]).
pub fn with_term(ext: &ModelExtension, c: Candidate, grade: UnitGrade) -> ModelExtension {
    let mut e = ext.clone();
    if c == Candidate::GyroBiasDrift {
        e.gyro_drift = Some([0.0; 3]);
    } else {
        e.terms.push((c, c.prior_sigma(grade)));
    }
    e
}

/// Whether `ext` holds candidate `c`.
pub fn has_term(ext: &ModelExtension, c: Candidate) -> bool {
    if c == Candidate::GyroBiasDrift {
        ext.gyro_drift.is_some()
    } else {
        ext.terms.iter().any(|(t, _)| *t == c)
    }
}

#[cfg(test)]
mod tests {
    use super::fitting::parabola;

    #[test]
    fn parabola_vertex_and_curvature() {
        // l(x) = -(x - 3)^2 / (2 * 0.5^2): vertex 3, sigma 0.5.
        let l = |x: f64| -(x - 3.0f64).powi(2) / 0.5;
        let (v, s) = parabola(&[(1.0, l(1.0)), (2.5, l(2.5)), (4.0, l(4.0))]);
        assert!(
            (v - 3.0).abs() < 1e-12 && (s - 0.5).abs() < 1e-12,
            "{v} {s}"
        );
        assert!(parabola(&[(0.0, 0.0), (1.0, 1.0), (2.0, 4.0)]).0.is_nan());
    }
}
