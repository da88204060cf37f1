//! The loop's rounds: its entries (along a program, on a recording of rests), the noise
//! rescaled where the data contradict it, each round's candidates tested and the best accepted.

use super::fitting::{Context, LoopRecords, gain};
use super::outcome::{
    CandidateEvidence, DriftReach, Fit, LoopResult, Round, TermGain, thermal_untestable,
};
use crate::config::RunConfig;
use crate::estimate::covariance::Posterior;
use crate::estimate::noise::NoiseRescale;
use crate::estimate::{Estimate, EstimateError, ImuSource, RunData};
use crate::extend::drift_visibility::{DriftAnalysis, drift_threshold, smallest_visible_drift};

use super::{LoopError, LoopSettings, PROGRAM_COVERAGE_SLACK_S, drift_grid, has_term};
use crate::model::extension::ModelExtension;
use sins_model::candidates::Candidate;
use std::collections::BTreeMap;
use turntable::program::Program;

/// Run the loop on recorded data. `progress` hears what is being fitted.
pub fn run_loop(
    config: &RunConfig,
    data: &RunData,
    settings: &LoopSettings,
    progress: &mut dyn FnMut(&str),
) -> Result<LoopResult, LoopError> {
    let imu_start = data
        .imu
        .records
        .first()
        .map(|r| r.t - 1.0 / config.filter.imu_rate_hz);
    let resolved =
        crate::motion::angles_program::resolve_program(config, data.turntable, imu_start)
            .map_err(EstimateError::from)?;
    let config = resolved.as_ref().unwrap_or(config);
    let cx = Context {
        config,
        scaled: None,
        measured_start: None,
        program: None,
        records: LoopRecords::Program(data),
        turns: &[],
        settings,
        progress,
        stage: String::new(),
        recorded_temperature: None,
    };
    loop_in(cx)
}

/// Refuse a fit of data that cover only part of `program` ([`LoopError::PartialProgram`]).
pub(super) fn check_coverage(
    config: &RunConfig,
    program: &Program,
    data: &RunData,
    est: &Estimate,
) -> Result<(), LoopError> {
    let duration_s = program.duration();
    let dt = 1.0 / config.filter.imu_rate_hz;
    let (Some(first), Some(last)) = (data.imu.records.first(), data.imu.records.last()) else {
        return Ok(());
    };
    let from = first.t - dt - est.program_start_s;
    let to = last.t - est.program_start_s;
    if from > PROGRAM_COVERAGE_SLACK_S || to < duration_s - PROGRAM_COVERAGE_SLACK_S {
        return Err(LoopError::PartialProgram {
            file: data.imu_file.to_string(),
            covered_from_s: from.max(0.0),
            covered_to_s: to.min(duration_s),
            duration_s,
        });
    }
    Ok(())
}

/// [`run_loop`] on a recording of rests without a program or turntable angles
/// ([`crate::estimate::run`]): the same candidates, tests and decisions, with each
/// candidate's separability from the fit's own posterior (no program to analyse along). A time
/// offset or the inner lever arms need specific force measured during rotation, which such a
/// recording does not have: their posterior stays at the prior and they are not separable.
/// The records are read again from `imu` for every fit, not held.
pub fn run_loop_at_rests(
    config: &RunConfig,
    imu: &mut dyn ImuSource,
    rests: &[crate::motion::rests::Rest],
    turns: &[crate::motion::rests::Turn],
    settings: &LoopSettings,
    progress: &mut dyn FnMut(&str),
) -> Result<LoopResult, LoopError> {
    let cx = Context {
        config,
        scaled: None,
        measured_start: None,
        program: None,
        records: LoopRecords::Rests { imu, rests },
        turns,
        settings,
        progress,
        stage: String::new(),
        recorded_temperature: None,
    };
    loop_in(cx)
}

/// The loop itself, on a context.
pub(super) fn loop_in(mut cx: Context) -> Result<LoopResult, LoopError> {
    (cx.progress)("fitting the paper's model");
    let base = cx.fit_scored(&ModelExtension::default())?;
    if let LoopRecords::Program(data) = cx.records {
        let program = cx.program.as_ref().expect("a fit of a program keeps it");
        check_coverage(cx.config, program, data, &base.calibration.estimate)?;
    }
    let est = &base.calibration.estimate;
    if let (Some(t), None) = (&est.temperature, cx.rests()) {
        // The 1-s means on the program's clock (a recording of rests has none: its
        // separability comes from the fit's own posterior).
        let points = est
            .temperature_series
            .iter()
            .map(|&[t, c]| [t - est.program_start_s, c])
            .collect();
        cx.recorded_temperature = Some((
            turntable::temperature::TemperatureProfile::Table { points },
            t.reference_c,
        ));
    }
    loop_from(cx, base)
}

/// The factors by which the configured white noise of each measurement is scaled to the data
/// ([`NoiseRescale::to_innovations`]): the root of its mean NIS over the mean expected when the
/// model fits (3, for the turntable angles a little less:
/// `FitStatistics::turntable_expected_nis`) where that mean is outside its band
/// ([`crate::estimate::verdict::mean_nis_figures`]; `None`: both inside, or no updates).
pub(super) fn noise_rescale(
    stats: &crate::estimate::FitStatistics,
    with_turntable: bool,
) -> Option<NoiseRescale> {
    let figures = crate::estimate::verdict::mean_nis_figures(stats, with_turntable);
    let outside = |kind: crate::model::MeasurementKind| {
        figures
            .iter()
            .find(|m| m.kind == kind)
            .filter(|m| !m.consistent())
            .map(|m| (m.mean, m.expected))
    };
    NoiseRescale::to_innovations(
        outside(crate::model::MeasurementKind::Accel),
        outside(crate::model::MeasurementKind::Turntable),
    )
}

/// The loop's rounds from the fitted base model.
///
/// Every statistic is computed with a noise model: when the data scatter more (or less) than
/// the configured white noise says, every term looks significant (or none does). A round whose
/// current model (fitted with the configured noise) has a mean NIS outside its band tests its
/// candidates with the noise scaled to the data ([`noise_rescale`]); a term accepted there is
/// fitted again with the configured noise for the next round, whose scale then comes from the
/// extended model (a real effect's share of the misfit is not taken for noise twice).
pub(super) fn loop_from(mut cx: Context, base: Fit) -> Result<LoopResult, LoopError> {
    let settings = cx.settings;
    let thermal_off = thermal_untestable(&base.calibration.estimate);
    let mut st = LoopState {
        current: base.clone(),
        accepted: Vec::new(),
        rounds: Vec::new(),
        gains: BTreeMap::new(),
        noise_rescaled: None,
        not_tested: Vec::new(),
        models: Vec::new(),
    };
    loop {
        let reference = cx.round_reference(&mut st)?;
        let mut evidence = cx.round_evidence(&reference, thermal_off.as_deref(), &mut st)?;
        let threshold = settings.level / evidence.len().max(1) as f64;
        // Only the best-supported candidate may be accepted: a weaker one accepted in its place
        // would absorb part of its effect and be reported as the cause. When it is significant
        // but not separable it is carried with its prior (its uncertainty then in the base
        // parameters' sigmas) rather than dropped: dropped, it biased them unseen (19-61 sigma
        // on navigation-grade 19-position runs with a g-sensitivity).
        let pick = evidence
            .first()
            .filter(|(e, _)| e.ln_p_value < threshold.ln())
            .map(|_| 0)
            .filter(|_| st.accepted.len() < settings.max_terms);
        let mut round = Round {
            candidates: evidence.iter().map(|(e, _)| e.clone()).collect(),
            threshold,
            accepted: None,
            held_out: None,
            carried: pick.is_some_and(|k| !evidence[k].0.separable),
            refused: None,
        };
        let Some(k) = pick else {
            st.rounds.push(round);
            break;
        };
        // A candidate tested by the score alone is fitted now that it is picked.
        if evidence[k].1.is_none() {
            let term = evidence[k].0.term.clone();
            evidence[k].1 = Some(cx.fit_candidate(&reference, &term)?);
        }
        let (evidence_k, fit_k) = (&evidence[k].0, evidence[k].1.as_ref().expect("fitted"));
        // Acceptance needs evidence: the likelihood must rise with the term.
        let rise = fit_k.log_likelihood - reference.log_likelihood;
        if rise.is_nan() || rise <= 0.0 {
            round.carried = false;
            round.refused = Some(format!(
                "the log-likelihood does not rise with it ({rise:+.1})"
            ));
            st.rounds.push(round);
            break;
        }
        if let Some(every) = settings.hold_out_every.filter(|_| !round.carried) {
            let check = cx.held_out_check(
                &evidence_k.term,
                &reference.extension,
                &fit_k.extension,
                every,
            )?;
            let refused = check.refused();
            round.held_out = Some(check);
            if refused {
                // The data call for the term, but it predicts held-out data worse: it would be
                // fitting the recording, not the instrument. The loop stops and says so.
                st.rounds.push(round);
                break;
            }
        }
        let (e, fit) = evidence.swap_remove(k);
        cx.accept(&mut st, round, (e, fit.expect("fitted")), &reference)?;
    }
    let drift_reach = cx.last_drift_reach(&st)?;
    // The final model's verdict as `calibrate` gives it: with the score tests of the candidate
    // terms left out (one more fit with the extended pass; the estimate is the same).
    let scored = st.current.calibration.estimate.extended.is_some()
        || st.current.calibration.estimate.extended_error.is_some();
    if cx.rests().is_none() && !scored {
        // The configuration it was fitted with (not the loop's, whose noise may be scaled to
        // the data for testing).
        let mut config = st.current.calibration.config.clone();
        config.filter.score_terms = true;
        let ext = st.current.extension.clone();
        st.current = cx.fit_with(&config, &ext)?;
    }
    Ok(LoopResult {
        accepted_terms: st.accepted,
        rounds: st.rounds,
        gain: st.gains,
        base,
        last: st.current,
        drift_reach,
        noise_rescaled: st.noise_rescaled,
        not_tested: st.not_tested,
        models: st.models,
    })
}

/// What the loop's rounds have found so far.
pub(super) struct LoopState {
    /// The model with the terms accepted, fitted with the configured noise.
    pub(super) current: Fit,
    /// Term ids in the order accepted.
    pub(super) accepted: Vec<String>,
    pub(super) rounds: Vec<Round>,
    pub(super) gains: BTreeMap<String, TermGain>,
    /// The first round's noise factors, when it scaled the noise.
    pub(super) noise_rescaled: Option<NoiseRescale>,
    /// Candidates not tested, with why.
    pub(super) not_tested: Vec<(String, String)>,
    /// The posterior of each model moved to ([`LoopResult::models`]).
    pub(super) models: Vec<(String, Posterior)>,
}

impl Context<'_> {
    /// The fit a round tests its candidates against: the current model, or, where its mean
    /// NIS contradicts the configured noise, the current model fitted again with the noise
    /// scaled to the data ([`noise_rescale`]; the first round's factors are the result's).
    /// A fit that measures its own noise ([`LoopSettings::measured_noise`]) is at the data's
    /// scale already.
    pub(super) fn round_reference(&mut self, st: &mut LoopState) -> Result<Fit, LoopError> {
        self.scaled = None;
        let rescale = match self.settings.measured_noise {
            Some(_) => None,
            None => noise_rescale(
                &st.current.calibration.estimate.stats,
                self.with_turntable(),
            ),
        };
        let Some(r) = rescale else {
            return Ok(st.current.clone());
        };
        self.scaled = Some(r.scaled(self.config));
        (self.progress)(&format!(
            "the configured noise does not match the data (specific force x{:.3}, \
             angles x{:.3}): this round tests with it scaled",
            r.accel_factor, r.angle_factor
        ));
        if st.rounds.is_empty() {
            st.noise_rescaled = Some(r);
        }
        self.fit_scored(&st.current.extension)
    }

    /// The evidence for every candidate of the settings not in `reference`'s model against
    /// it, the best supported first. The thermal candidates are left out where `thermal_off`
    /// says why (noted in the first round).
    pub(super) fn round_evidence(
        &mut self,
        reference: &Fit,
        thermal_off: Option<&str>,
        st: &mut LoopState,
    ) -> Result<Vec<(CandidateEvidence, Option<Fit>)>, LoopError> {
        let settings = self.settings;
        let mut planned = Vec::new();
        for &c in &settings.candidates {
            if has_term(&reference.extension, c) {
                continue;
            }
            if c.is_thermal()
                && let Some(why) = thermal_off
            {
                if st.rounds.is_empty() {
                    st.not_tested.push((c.id().to_string(), why.to_string()));
                }
                continue;
            }
            planned.push(c);
        }
        let mut evidence: Vec<(CandidateEvidence, Option<Fit>)> = Vec::new();
        if self.scores_from_pass() {
            self.stage = format!("round {}: ", st.rounds.len() + 1);
            let constant: Vec<Candidate> = planned
                .iter()
                .copied()
                .filter(|c| *c != Candidate::GyroBiasDrift)
                .collect();
            let scored = self.scored_terms(reference, &constant);
            self.stage.clear();
            evidence.extend(scored?.into_iter().map(|e| (e, None)));
        }
        let rest: Vec<Candidate> = planned
            .iter()
            .copied()
            .filter(|c| !evidence.iter().any(|(e, _)| e.term == c.id()))
            .collect();
        // Numbered among all the round's candidates, after those the pass tested.
        let scored = evidence.len();
        for (i, &c) in rest.iter().enumerate() {
            self.stage = format!(
                "round {}, candidate {} of {}: ",
                st.rounds.len() + 1,
                scored + i + 1,
                planned.len()
            );
            let e = if c == Candidate::GyroBiasDrift {
                self.drift(reference)
            } else {
                self.constant_term(reference, c)
            };
            self.stage.clear();
            let (e, fit) = e?;
            evidence.push((e, Some(fit)));
        }
        evidence.sort_by(|a, b| a.0.ln_p_value.total_cmp(&b.0.ln_p_value));
        Ok(evidence)
    }

    /// Accept the candidate `(e, fit)` of `round`: its gain against `reference`, and the
    /// current model becomes its fit (fitted again with the configured noise in a round that
    /// scaled it).
    pub(super) fn accept(
        &mut self,
        st: &mut LoopState,
        mut round: Round,
        (e, fit): (CandidateEvidence, Fit),
        reference: &Fit,
    ) -> Result<(), LoopError> {
        let added =
            fit.calibration.estimate.names.len() - reference.calibration.estimate.names.len();
        let added = if e.term == Candidate::GyroBiasDrift.id() {
            3
        } else {
            added
        };
        st.gains
            .insert(e.term.clone(), gain(reference, &fit, added));
        round.accepted = Some(e.term.clone());
        // A carried term is in the model but not among the accepted: the data do not determine
        // it (its estimate leans on its prior), and on clean consumer-grade recordings of rests
        // a scale asymmetry the rests cannot separate was called for on 8 of 10 (the call of an
        // inseparable term rests on the prior as much as on the data).
        if !round.carried {
            st.accepted.push(e.term.clone());
        }
        st.rounds.push(round);
        st.current = if self.scaled.take().is_some() {
            self.fit_scored(&fit.extension)?
        } else {
            fit
        };
        let posterior = Posterior::of_estimate(&st.current.calibration.estimate);
        st.models.push((e.term, posterior));
        Ok(())
    }

    /// What the program can see of a gyro bias random walk ([`drift_reach`]), when the last
    /// round tried the walk and did not accept it (a programmed run; `None` otherwise).
    pub(super) fn last_drift_reach(
        &mut self,
        st: &LoopState,
    ) -> Result<Option<DriftReach>, LoopError> {
        let (None, Some(last)) = (self.rests(), st.rounds.last()) else {
            return Ok(None);
        };
        let drift = Candidate::GyroBiasDrift.id();
        let tried = last.candidates.iter().any(|c| c.term == drift);
        if !tried || last.accepted.as_deref() == Some(drift) {
            return Ok(None);
        }
        (self.progress)("how large a walk this program would show");
        drift_reach(
            self.config(),
            self.with_turntable(),
            &st.current.extension,
            self.settings,
            last.threshold,
        )
    }
}

/// [`DriftReach`] of the program of `config` with the model `ext`, for the loop's drift grid
/// and a round's `level` (`None`: an empty grid).
pub fn drift_reach(
    config: &RunConfig,
    with_turntable: bool,
    ext: &ModelExtension,
    settings: &LoopSettings,
    level: f64,
) -> Result<Option<DriftReach>, LoopError> {
    let grid = settings
        .drift_grid
        .clone()
        .unwrap_or_else(|| drift_grid(config.unit_grade()));
    let lo = grid.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = grid.iter().copied().fold(0.0, f64::max);
    if !(lo > 0.0 && hi.is_finite()) {
        return Ok(None);
    }
    let threshold = drift_threshold(level);
    let analysis = DriftAnalysis::new(config, with_turntable, ext, lo * hi)?;
    Ok(Some(DriftReach {
        threshold,
        smallest_visible: smallest_visible_drift(&analysis, threshold, lo, hi)?,
        largest_tried: hi,
    }))
}
