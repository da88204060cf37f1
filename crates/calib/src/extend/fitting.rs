//! One fit of the loop: its context (the data and what every fit shares), a model fitted with
//! or without a candidate term, and the gain of a term.

use super::outcome::{
    CandidateEvidence, Fit, HeldOutCheck, ParameterValue, TermGain, held_out_decides,
};
use crate::check::score::solo_scores;
use crate::config::RunConfig;
use crate::estimate::calibration::Calibration;
use crate::estimate::covariance::{Posterior, covariance_analysis_ext};
use crate::estimate::noise::{MeasuredLevels, NoiseSource};
use crate::estimate::{Estimate, ImuSource, RunData, fit_extended};
use crate::extend::evidence::{
    InformationGain, ScoreTest, Separability, chi_bar_square_sf, ln_chi_square_sf, separability,
    without_parameters,
};

use super::{LoopError, LoopSettings, drift_grid, held_out_log_density, log_likelihood, with_term};
use crate::model::extension::ModelExtension;
use crate::model::layout::StateLayout;
use sins_model::candidates::Candidate;
use turntable::program::Program;

/// The loop's context: the data and what every fit shares.
pub(super) struct Context<'a> {
    pub(super) config: &'a RunConfig,
    /// `config` with its white noise scaled to the data, for a round whose current model's
    /// mean NIS contradicts the configured noise ([`noise_rescale`]).
    pub(super) scaled: Option<RunConfig>,
    /// The levels the paper's model's fit measured (a recording whose noise every fit
    /// measures): the next fits start from them.
    pub(super) measured_start: Option<MeasuredLevels>,
    /// The program of a programmed run, compiled by the first fit and kept for the others.
    pub(super) program: Option<Program>,
    pub(super) records: LoopRecords<'a>,
    /// A recording of rests' known turns, measured in every fit.
    pub(super) turns: &'a [crate::motion::rests::Turn],
    pub(super) settings: &'a LoopSettings,
    pub(super) progress: &'a mut dyn FnMut(&str),
    /// Where a candidate's fits stand in their round, put before their progress lines
    /// (`round 2, candidate 3 of 7: `; empty outside a round's candidates).
    pub(super) stage: String,
    /// The recording's temperature on the program's clock and the thermal terms' reference:
    /// what the covariance analysis of a thermal candidate sees (`None`: no temperature).
    pub(super) recorded_temperature: Option<(turntable::temperature::TemperatureProfile, f64)>,
}

/// What the loop fits.
pub(super) enum LoopRecords<'a> {
    /// A programmed run's records and angles, held ([`run_loop`]).
    Program(&'a RunData<'a>),
    /// A recording of rests without a program ([`run_loop_at_rests`]): its records, read again
    /// for every fit, and its rests.
    Rests {
        imu: &'a mut dyn ImuSource,
        rests: &'a [crate::motion::rests::Rest],
    },
}

impl<'a> Context<'a> {
    /// A progress line, after the place of the candidate being tested in its round.
    pub(super) fn say(&mut self, what: &str) {
        let line = format!("{}{what}", self.stage);
        (self.progress)(&line);
    }

    /// The rests of a recording without a program (`None` for a programmed run).
    pub(super) fn rests(&self) -> Option<&'a [crate::motion::rests::Rest]> {
        match self.records {
            LoopRecords::Rests { rests, .. } => Some(rests),
            LoopRecords::Program(_) => None,
        }
    }

    /// Whether the fits have turntable angles.
    pub(super) fn with_turntable(&self) -> bool {
        matches!(self.records, LoopRecords::Program(d) if d.turntable.is_some())
    }

    /// The configuration the fits use now: the scaled one in a scaled round.
    pub(super) fn config(&self) -> &RunConfig {
        self.scaled.as_ref().unwrap_or(self.config)
    }

    pub(super) fn fit(&mut self, ext: &ModelExtension) -> Result<Fit, LoopError> {
        let config = self.config().clone();
        self.fit_with(&config, ext)
    }

    /// The held-out check of `term` (fitted as `with`) against `current`.
    pub(super) fn held_out_check(
        &mut self,
        term: &str,
        current: &ModelExtension,
        with: &ModelExtension,
        every: usize,
    ) -> Result<HeldOutCheck, LoopError> {
        let mut config = self.config().clone();
        config.filter.hold_out_every = Some(every);
        (self.progress)(&format!(
            "held-out check of {term}: every {every}th segment with measurements held out"
        ));
        let mut density = |ext: &ModelExtension| -> Result<(f64, usize), LoopError> {
            let fit = self.fit_with(&config, ext)?;
            Ok(held_out_log_density(&fit.calibration.estimate.innovations))
        };
        let (without, measurements) = density(current)?;
        let (with, _) = density(with)?;
        Ok(HeldOutCheck {
            term: term.to_string(),
            every,
            measurements,
            log_density_without: without,
            log_density_with: with,
            decides: held_out_decides(self.rests().is_some(), term),
        })
    }

    pub(super) fn fit_with(
        &mut self,
        config: &RunConfig,
        ext: &ModelExtension,
    ) -> Result<Fit, LoopError> {
        self.fit_from(config, ext, None)
    }

    /// A fit of `ext` whose passes start from the converged estimates of `warm` (a fit of a
    /// model with the same states: another walk intensity), along a program; from the prior
    /// otherwise. Started there, a pass that moves no parameter by more than the convergence
    /// bound is the last: one or two passes where a fit from the prior takes three.
    pub(super) fn fit_warm(&mut self, ext: &ModelExtension, warm: &Fit) -> Result<Fit, LoopError> {
        let config = self.config().clone();
        self.fit_from(&config, ext, Some(&warm.calibration.estimate))
    }

    fn fit_from(
        &mut self,
        config: &RunConfig,
        ext: &ModelExtension,
        warm: Option<&Estimate>,
    ) -> Result<Fit, LoopError> {
        let (estimate, config, noise) = match &mut self.records {
            LoopRecords::Program(data) => {
                let est = fit_extended(config, **data, ext, &mut self.program, warm)?;
                (est, config.clone(), NoiseSource::Configured)
            }
            LoopRecords::Rests { imu, rests } => {
                let fit = crate::estimate::hand_turned::fit_measuring_noise(
                    config,
                    &crate::model::layout::layout_with(config, false, ext),
                    crate::estimate::hand_turned::RestsInput {
                        imu: &mut **imu,
                        rests,
                        turns: self.turns,
                    },
                    self.settings.measured_noise,
                    self.measured_start,
                    &mut |_, _| {},
                )?;
                if let Some(levels) = fit.noise.measured_levels() {
                    self.measured_start.get_or_insert(levels);
                }
                (fit.estimate, fit.config, fit.noise)
            }
        };
        let (log_likelihood, observations) = log_likelihood(&estimate.innovations);
        let calibration =
            Calibration::new(estimate, config, noise, None, &self.settings.diagnostics);
        Ok(Fit {
            extension: ext.clone(),
            calibration,
            log_likelihood,
            observations,
        })
    }

    pub(super) fn analyse(&mut self, ext: &ModelExtension) -> Result<Posterior, LoopError> {
        let thermal = ext.terms.iter().any(|(c, _)| c.is_thermal());
        if thermal && let Some(recorded) = &self.recorded_temperature {
            let mut config = self.config().clone();
            config.recorded_temperature = Some(recorded.clone());
            return Ok(covariance_analysis_ext(
                &config,
                self.with_turntable(),
                ext,
            )?);
        }
        Ok(covariance_analysis_ext(
            self.config(),
            self.with_turntable(),
            ext,
        )?)
    }

    /// Whether a round tests its constant candidates by the score of the reference fit's
    /// extended pass (one pass for all of them, `crate::estimate::score_pass`) rather than by a
    /// fit each: along a program. A recording of rests fits each candidate, every fit at the
    /// noise the data give it (a missing term's misfit read as noise in the reference fit
    /// would hide the term's own information: [`LoopSettings::measured_noise`]).
    pub(super) fn scores_from_pass(&self) -> bool {
        matches!(self.records, LoopRecords::Program(_))
    }

    /// A fit of `ext` that carries the extended pass where a round tests its candidates from
    /// it ([`Self::scores_from_pass`]): the fits a round tests against, and its final model's
    /// (whose verdict then has the score tests, as `calibrate`'s has).
    pub(super) fn fit_scored(&mut self, ext: &ModelExtension) -> Result<Fit, LoopError> {
        let mut config = self.config().clone();
        config.filter.score_terms |= self.scores_from_pass();
        self.fit_with(&config, ext)
    }

    /// The evidence for the constant candidates `planned` against `reference` from its
    /// extended pass, without a fit per candidate: each one's score test against the model
    /// without any of them and its parameters as the model extended by it alone estimates them
    /// ([`solo_scores`]; exactly what a fit of that model gives in the linear-Gaussian model),
    /// and its separability from the same pass's posterior conditioned on the others being zero
    /// ([`without_parameters`]; a covariance analysis of its own where that fails): the pass
    /// runs over the whole recorded program (a part is refused, [`LoopError::PartialProgram`])
    /// with the fit's noise, as the analysis would, and with the recorded temperature and
    /// timing. Candidates the pass did not carry are left out (the caller fits them).
    pub(super) fn scored_terms(
        &mut self,
        reference: &Fit,
        planned: &[Candidate],
    ) -> Result<Vec<CandidateEvidence>, LoopError> {
        let est = &reference.calibration.estimate;
        let Some(pass) = est.extended.as_ref() else {
            return Ok(Vec::new());
        };
        let Some(solo) = solo_scores(pass) else {
            return Ok(Vec::new());
        };
        let scored: Vec<(Candidate, ScoreTest, Vec<ParameterValue>)> = pass
            .terms
            .iter()
            .zip(solo)
            .filter_map(|((id, _), (test, params))| {
                let c = planned.iter().copied().find(|c| c.id() == id)?;
                let values = params
                    .into_iter()
                    .map(|p| ParameterValue {
                        name: p.name,
                        value: p.value,
                        sigma: p.sigma,
                    })
                    .collect();
                Some((c, test, values))
            })
            .collect();
        if scored.is_empty() {
            return Ok(Vec::new());
        }
        self.say(&format!(
            "score tests and separability of {} candidate terms from the extended pass",
            scored.len()
        ));
        let grade = self.config.unit_grade();
        let base = parameter_names(est);
        let mut out = Vec::new();
        for (c, test, estimate) in scored.iter().cloned() {
            let names = c.param_names();
            let others: Vec<String> = scored
                .iter()
                .filter(|(o, _, _)| *o != c)
                .flat_map(|(o, _, _)| o.param_names())
                .collect();
            let conditioned =
                without_parameters(&pass.names, &pass.prior_sigma, &pass.cov, &others);
            let sep = match conditioned {
                Some((n, s0, cov)) => separability(&n, &s0, &cov, &names, &base),
                None => {
                    let post = self.analyse(&with_term(&reference.extension, c, grade))?;
                    separability(&post.names, &post.prior_sigma, &post.cov, &names, &base)
                }
            };
            out.push(evidence_of(c, test, sep, estimate));
        }
        Ok(out)
    }

    /// The fit of `reference`'s model extended by the candidate `term`, tested by its score
    /// and picked by the round.
    pub(super) fn fit_candidate(&mut self, reference: &Fit, term: &str) -> Result<Fit, LoopError> {
        let c = Candidate::from_id(term).expect("a candidate's id");
        self.say(&format!("fitting with {term}"));
        let ext = with_term(&reference.extension, c, self.config.unit_grade());
        self.fit_scored(&ext)
    }

    /// The evidence for a constant-parameter candidate against the model `current`.
    pub(super) fn constant_term(
        &mut self,
        current: &Fit,
        c: Candidate,
    ) -> Result<(CandidateEvidence, Fit), LoopError> {
        self.say(&format!("fitting with {}", c.id()));
        let ext = with_term(&current.extension, c, self.config.unit_grade());
        let fit = self.fit(&ext)?;
        let names = c.param_names();
        let est = &fit.calibration.estimate;
        let test = est.score_test_of(&names).expect("term in layout");
        // Without a program there is no motion to analyse along: the fit's own posterior says
        // what the recording separates (a term it cannot observe keeps its prior).
        let post = match self.rests() {
            None => self.analyse(&ext)?,
            Some(_) => Posterior {
                names: est.names.clone(),
                units: est.units.clone(),
                prior_sigma: est.prior_sigma.clone(),
                cov: est.cov.clone(),
                log_det_data: f64::NAN,
            },
        };
        let base: Vec<String> = parameter_names(&current.calibration.estimate);
        let mut sep = separability(&post.names, &post.prior_sigma, &post.cov, &names, &base);
        if self.rests().is_some() {
            // A recording of rests sees some entries of a term only through the Earth rate
            // (those acting on the vertical gyro of every pose): they keep their prior but are
            // confounded with nothing. The term is separable when some entry is separated and
            // none is confounded with the base parameters (with every entry required, a
            // g-sensitivity the data called for at p = 7.6e-25 was refused).
            sep.separable = sep.parameters.iter().any(|p| p.separated())
                && sep
                    .parameters
                    .iter()
                    .all(|p| p.separated() || p.confounded_with.is_empty());
        }
        let estimate = names
            .iter()
            .map(|n| ParameterValue {
                name: n.clone(),
                value: est.value(n).expect("term in layout"),
                sigma: est.sigma(n).expect("term in layout"),
            })
            .collect();
        Ok((evidence_of(c, test, sep, estimate), fit))
    }

    /// The evidence for a gyro bias random walk: the likelihood ratio over the grid of common
    /// intensities.
    pub(super) fn drift(&mut self, current: &Fit) -> Result<(CandidateEvidence, Fit), LoopError> {
        let mut best: Option<(f64, Fit)> = None;
        let grid = self
            .settings
            .drift_grid
            .clone()
            .unwrap_or_else(|| drift_grid(self.config.unit_grade()));
        for &q in &grid {
            // q in rad/s/sqrt(s); shown in the unit of `[noise] gyro_bias_walk_deg_h_sqrt_h`.
            let shown = q * 60.0 / sins_model::units::DEG_PER_HOUR;
            self.say(&format!(
                "fitting with a gyro bias random walk of {shown:.3} deg/h/sqrt(h)"
            ));
            let mut ext = current.extension.clone();
            ext.gyro_drift = Some([q; 3]);
            let fit = self.fit_warm(&ext, current)?;
            if best
                .as_ref()
                .is_none_or(|(_, b)| fit.log_likelihood > b.log_likelihood)
            {
                best = Some((q, fit));
            }
        }
        let (q, mut fit) = best.expect("a non-empty grid");
        let lr = (2.0 * (fit.log_likelihood - current.log_likelihood)).max(0.0);
        let p_value = chi_bar_square_sf(lr, 1);
        // Refine per axis around the common value when the data call for the term.
        let mut values = [q; 3];
        let mut sigmas = [f64::NAN; 3];
        if p_value < self.settings.level {
            let common = fit.log_likelihood;
            for axis in 0..3 {
                (values[axis], sigmas[axis]) = self.refine_axis(current, q, common, axis)?;
            }
            let mut ext = current.extension.clone();
            ext.gyro_drift = Some(values);
            self.say("fitting with the per-axis random walk");
            fit = self.fit(&ext)?;
        }
        let estimate = (0..3)
            .map(|i| ParameterValue {
                name: format!("gyro.drift.{}", ["x", "y", "z"][i]),
                value: values[i],
                sigma: sigmas[i],
            })
            .collect();
        Ok((
            CandidateEvidence {
                term: Candidate::GyroBiasDrift.id().to_string(),
                statistic: lr,
                dof: 1,
                p_value,
                ln_p_value: 0.5f64.ln() + ln_chi_square_sf(lr, 1),
                separable: true,
                separation: None,
                estimate,
            },
            fit,
        ))
    }

    /// One axis's intensity, the others at the common value `q`: the log-likelihood at 0, q/2,
    /// q (known: `at_q`) and 2q, a parabola through the best point and its neighbours (the
    /// three lowest or highest at an end of the ladder), its vertex kept within [0, 2q] as the
    /// estimate and its curvature as the sigma.
    pub(super) fn refine_axis(
        &mut self,
        current: &Fit,
        q: f64,
        at_q: f64,
        axis: usize,
    ) -> Result<(f64, f64), LoopError> {
        let mut pts: Vec<(f64, f64)> = vec![(q, at_q)];
        for factor in [0.0, 0.5, 2.0] {
            let mut v = [q; 3];
            v[axis] *= factor;
            let mut ext = current.extension.clone();
            ext.gyro_drift = Some(v);
            pts.push((v[axis], self.fit_warm(&ext, current)?.log_likelihood));
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let best = (0..pts.len())
            .max_by(|&a, &b| pts[a].1.total_cmp(&pts[b].1))
            .expect("points");
        let mid = best.clamp(1, pts.len() - 2);
        let (vertex, sigma) = parabola(&pts[mid - 1..=mid + 1]);
        let estimate = if vertex.is_finite() {
            vertex.clamp(0.0, 2.0 * q)
        } else {
            pts[best].0
        };
        Ok((estimate, sigma))
    }
}

/// Vertex and `1 / sqrt(-l'')` of the parabola through three (value, log-likelihood) points
/// (NaN when it opens upwards).
pub(super) fn parabola(p: &[(f64, f64)]) -> (f64, f64) {
    let ((x0, y0), (x1, y1), (x2, y2)) = (p[0], p[1], p[2]);
    let d1 = (y1 - y0) / (x1 - x0);
    let d2 = (y2 - y1) / (x2 - x1);
    let second = 2.0 * (d2 - d1) / (x2 - x0);
    if second < 0.0 {
        // l(x) = l1 + slope (x - x1) + second / 2 (x - x1)^2, slope at x1 from the two chords.
        let slope = d1 + 0.5 * second * (x1 - x0);
        (x1 - slope / second, (-1.0 / second).sqrt())
    } else {
        (f64::NAN, f64::NAN)
    }
}

/// The estimated parameters of a fit (every state but the attitude errors).
pub(super) fn parameter_names(est: &Estimate) -> Vec<String> {
    est.names[StateLayout::INSTRUMENT..].to_vec()
}

pub(super) fn gain(before: &Fit, after: &Fit, parameters: usize) -> TermGain {
    let (b, a) = (
        &before.calibration.estimate.stats,
        &after.calibration.estimate.stats,
    );
    TermGain {
        information: InformationGain::new(
            before.log_likelihood,
            after.log_likelihood,
            parameters,
            after.observations,
        ),
        accel_mean_nis: (b.accel_mean_nis, a.accel_mean_nis),
        turntable_mean_nis: (b.turntable_mean_nis, a.turntable_mean_nis),
        diagnostics_fit: (
            before.calibration.diagnostics.fits,
            after.calibration.diagnostics.fits,
        ),
    }
}

/// A constant candidate's evidence from its test, separability and estimate.
fn evidence_of(
    c: Candidate,
    test: ScoreTest,
    sep: Separability,
    estimate: Vec<ParameterValue>,
) -> CandidateEvidence {
    CandidateEvidence {
        term: c.id().to_string(),
        statistic: test.statistic,
        dof: test.dof,
        p_value: test.p_value,
        ln_p_value: test.ln_p_value,
        separable: sep.separable,
        separation: Some(sep),
        estimate,
    }
}
