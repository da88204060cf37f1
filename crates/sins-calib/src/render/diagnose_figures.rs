//! What a `diagnose` run reports, computed once ([`Diagnosis::build`]): the loop's result, the
//! held-out verdict of the final model (a hand-turned recording with measured noise), the
//! verdict, and the figures of the laboratory report. The printout and the JSON
//! (`crate::commands::diagnose`) and the report (`crate::render::lab_report::diagnose_section`) render it.

use crate::Error;
use crate::provenance::identification::Identification;
use crate::render::calibrate_figures::{Case, Verdict};
use crate::session::{Diagnose, Session};
use calib::estimate::verdict::{MeanNis, RunVerdict};
use calib::extend::{CandidateEvidence, LoopResult};
use calib::report::lab::{self, ParameterRow, SegmentRow};
use sins_model::candidates::Candidate;

/// Everything a `diagnose` run reports.
pub struct Diagnosis {
    /// The loop's rounds, accepted terms, gains and fits.
    pub result: LoopResult,
    /// `--noise`: the file and the walks the drift candidate was tried at (deg/h/sqrt(h)).
    pub walk_prior: Option<(String, Vec<f64>)>,
    /// The held-out verdict of the final model (with measured noise).
    pub held_out: Option<HeldOut>,
    /// The verdict: the one the exit status, the printout, the JSON and the report say.
    pub verdict: Verdict,
    /// The size of each round's accepted term.
    pub sizes: Vec<Option<TermSize>>,
    /// The laboratory report's figures (`--report`).
    pub lab: Option<DiagnosisLab>,
    /// The navigation figure of every model the loop moved to: the paper's model first, then
    /// the model after each accepted (or carried) term; the last is the final model's.
    pub navigation: Vec<ModelNavigation>,
}

/// The navigation figure of one model of the loop.
pub struct ModelNavigation {
    /// The term whose acceptance made this model (`None`: the paper's model).
    pub term: Option<String>,
    /// Whether the term was carried rather than accepted.
    pub carried: bool,
    /// The candidate terms of the model.
    pub terms: Vec<String>,
    /// Its figure.
    pub navigation: crate::navigation::Navigation,
}

/// The held-out verdict of the final model.
pub struct HeldOut {
    /// Every K-th rest held out.
    pub every: usize,
    /// The verdict of the final model's fit with them held out.
    pub verdict: RunVerdict,
    /// That fit's noise, turns and held-out figures.
    pub figures: Option<crate::free_motion::FreeMotionFigures>,
}

/// The size of a term a round accepted, against typical values for units of each grade.
pub struct TermSize {
    /// Typical magnitudes (`Candidate::typical`).
    pub typical: &'static str,
    /// Its largest estimate among the parameters the data observe (`None`: they observe none).
    pub largest: Option<Largest>,
}

/// A term's largest observed estimate, in its report unit.
pub struct Largest {
    /// The parameter.
    pub name: String,
    /// Its estimate and posterior sigma (report unit).
    pub value: f64,
    /// See `value`.
    pub sigma: f64,
    /// The report unit.
    pub unit: &'static str,
}

/// The size of the accepted `term` from its round's `candidates`: the largest estimate among
/// its parameters whose posterior sigma is at most [`calib::estimate::UNOBSERVED_SIGMA_RATIO`]
/// of the prior sigma `prior` gives (a parameter without a prior there, such as the random
/// walk's intensity, counts as observed); `None` for an unknown term.
pub fn term_size(
    term: &str,
    candidates: &[CandidateEvidence],
    prior: &dyn Fn(&str) -> Option<f64>,
) -> Option<TermSize> {
    let c = Candidate::from_id(term)?;
    let e = candidates.iter().find(|e| e.term == term)?;
    let unit = match c {
        // The drift's estimate is an intensity, in its own unit.
        Candidate::GyroBiasDrift => sins_model::terms::Unit::RadPerSecondPerSqrtSecond,
        _ => c.unit(),
    };
    let observed = |p: &&calib::extend::ParameterValue| {
        prior(&p.name).is_none_or(|s| p.sigma <= calib::estimate::UNOBSERVED_SIGMA_RATIO * s)
    };
    let largest = e
        .estimate
        .iter()
        .filter(observed)
        .max_by(|a, b| a.value.abs().total_cmp(&b.value.abs()))
        .map(|p| Largest {
            name: p.name.clone(),
            value: p.value * unit.report_factor(),
            sigma: p.sigma * unit.report_factor(),
            unit: unit.report_name(),
        });
    Some(TermSize {
        typical: c.typical(),
        largest,
    })
}

/// The size of each round's accepted term (`None` for a round that accepted none), its
/// parameters' priors from the final model.
fn sizes(r: &LoopResult) -> Vec<Option<TermSize>> {
    let est = &r.last.calibration.estimate;
    let prior = |name: &str| {
        est.names
            .iter()
            .position(|n| n == name)
            .map(|i| est.prior_sigma[i])
    };
    r.rounds
        .iter()
        .map(|round| {
            let term = round.accepted.as_deref()?;
            term_size(term, &round.candidates, &prior)
        })
        .collect()
}

/// The laboratory report's figures of the final model.
pub struct DiagnosisLab {
    /// Inputs, configuration, tool, date, command line.
    pub id: Identification,
    /// The final model's parameters in their report units.
    pub parameters: Vec<ParameterRow>,
    /// Its mean NIS of each measurement against its band.
    pub mean_nis: Vec<MeanNis>,
    /// Parameters it leaves at their prior.
    pub unobserved: Vec<(String, f64)>,
    /// Its posterior correlation and its strongest pairs.
    pub correlation: (Vec<String>, Vec<Vec<f64>>),
    /// See `correlation`.
    pub strongest: Vec<(String, String, f64)>,
    /// The NIS of every segment.
    pub segments: Vec<SegmentRow>,
}

impl Diagnosis {
    /// The report of the loop `result` on the session `s`, with the final model's held-out
    /// verdict `held_out` where the noise was measured.
    pub fn build(
        s: &Session<Diagnose>,
        result: LoopResult,
        held_out: Option<HeldOut>,
        flight: &crate::navigation::Flight,
    ) -> Result<Self, Error> {
        let verdict = verdict(s, &result, held_out.as_ref());
        let navigation = navigation(&result, flight, verdict.fits());
        let lab = match &s.report {
            Some(_) => Some(lab_figures(s, &result)?),
            None => None,
        };
        Ok(Self {
            walk_prior: s.task.walk_prior.as_ref().map(|(file, grid)| {
                let shown = grid
                    .iter()
                    .map(|q| q * 60.0 / sins_model::units::DEG_PER_HOUR)
                    .collect();
                (file.clone(), shown)
            }),
            held_out,
            verdict,
            sizes: sizes(&result),
            lab,
            navigation,
            result,
        })
    }
}

/// The verdict of the final model by the rule of `calibrate` (`crate::render::calibrate_figures::Verdict`):
/// with the noise measured from the data its held-out rests decide and the tests of its
/// innovations inform; with a configured noise its mean NIS and those tests decide. A term the
/// data call for that the held-out check refused is one more reason (configured noise) or
/// finding (measured noise).
fn verdict(s: &Session<Diagnose>, r: &LoopResult, held_out: Option<&HeldOut>) -> Verdict {
    let refused = r.held_out_rejection().map(|h| {
        format!(
            "the data call for {} but with it the held-out measurements are predicted worse (log \
             predictive density {:+.1} over {}, beyond the {} nat allowed): no candidate term \
             explains the misfit",
            h.term,
            h.gain(),
            h.measurements,
            calib::extend::HELD_OUT_TOLERANCE_NATS
        )
    });
    let (mut v, measured) = match held_out {
        Some(h) => (h.verdict.clone(), true),
        None => (r.last.calibration.verdict.clone(), false),
    };
    match refused {
        Some(line) if measured => v.informative.push(line),
        Some(line) => v.decisive.insert(0, line),
        None => {}
    }
    // The score tests' advice ("`diagnose` fits it") is for `calibrate`; here the loop has
    // tried every term the final verdict calls for, and says why it left each out.
    for t in &v.scores.clone() {
        if let Some(why) = r.why_left_out(&t.term) {
            v.advise(&t.term, &why);
        }
    }
    let case = Case {
        measured,
        rests: s.rests.is_some(),
        turntable: s.turntable.is_some(),
    };
    let mut verdict = Verdict::of(v, case);
    verdict.rule = format!(
        "The verdict is the final model's ({}). {}",
        if r.accepted_terms.is_empty() {
            "the paper's model".to_string()
        } else {
            format!("the paper's model with {}", r.accepted_terms.join(", "))
        },
        verdict.rule
    );
    verdict
}

/// The navigation figure of every model of the loop `r` on `flight`: a model the loop moved on
/// from does not fit these data (they call for the next term), the final model's fit is the
/// verdict's (`final_fits`).
fn navigation(
    r: &LoopResult,
    flight: &crate::navigation::Flight,
    final_fits: bool,
) -> Vec<ModelNavigation> {
    use crate::navigation::Navigation;
    let config = &r.last.calibration.config;
    let cal = |p: &calib::estimate::covariance::Posterior| navsim::CalibrationCovariance {
        names: p.names.clone(),
        posterior: p.cov.clone(),
        prior_sigma: p.prior_sigma.clone(),
        reference_temperature_c: r
            .last
            .calibration
            .estimate
            .temperature
            .as_ref()
            .map(|t| t.reference_c),
    };
    let n = r.models.len();
    let base_fits = n == 0 && final_fits;
    let base = calib::estimate::covariance::Posterior::of_estimate(&r.base.calibration.estimate);
    let mut out = vec![ModelNavigation {
        term: None,
        carried: false,
        terms: Vec::new(),
        navigation: Navigation::of(cal(&base), config, flight, &[], Some(base_fits)),
    }];
    let mut terms: Vec<String> = Vec::new();
    for (k, (term, post)) in r.models.iter().enumerate() {
        terms.push(term.clone());
        let fits = k + 1 == n && final_fits;
        let ids: Vec<&str> = terms.iter().map(String::as_str).collect();
        let carried = r
            .rounds
            .iter()
            .any(|round| round.accepted.as_deref() == Some(term) && round.carried);
        out.push(ModelNavigation {
            term: Some(term.clone()),
            carried,
            terms: terms.clone(),
            navigation: Navigation::of(cal(post), config, flight, &ids, Some(fits)),
        });
    }
    out
}

/// The laboratory report's figures of the final model.
fn lab_figures(s: &Session<Diagnose>, r: &LoopResult) -> Result<DiagnosisLab, Error> {
    let inputs: Vec<(&'static str, &std::path::Path)> = s
        .report_inputs
        .iter()
        .map(|(role, p)| (*role, p.as_path()))
        .collect();
    let id = crate::provenance::identification::identify(&inputs, s.source.shown(), &s.config)?;
    let f = lab::Figures::of(&r.last.calibration, None);
    Ok(DiagnosisLab {
        id,
        parameters: f.parameters,
        mean_nis: f.mean_nis,
        unobserved: f.unobserved,
        correlation: f.correlation,
        strongest: f.strongest,
        segments: f.segments,
    })
}

/// An accepted term's size: its largest estimate among the parameters the recording
/// observes, against typical magnitudes for units of each grade.
pub fn size_line(size: &TermSize) -> String {
    match &size.largest {
        Some(l) => format!(
            "  size: largest {} = {:.3e} {} (+- {:.1e}); typical: {}\n",
            l.name, l.value, l.unit, l.sigma, size.typical
        ),
        None => format!(
            "  size: this recording observes none of its parameters (posterior sigma above {:.0} \
             % of the prior); typical: {}\n",
            100.0 * calib::estimate::UNOBSERVED_SIGMA_RATIO,
            size.typical
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib::extend::ParameterValue;

    fn evidence(values: &[(&str, f64, f64)]) -> CandidateEvidence {
        CandidateEvidence {
            term: "accel_quadratic".into(),
            statistic: 40.0,
            dof: 3,
            p_value: 1e-8,
            ln_p_value: 1e-8f64.ln(),
            separable: true,
            separation: None,
            estimate: values
                .iter()
                .map(|(n, v, s)| ParameterValue {
                    name: n.to_string(),
                    value: *v,
                    sigma: *s,
                })
                .collect(),
        }
    }

    #[test]
    fn an_accepted_terms_size_is_its_largest_observed_estimate() {
        let e = evidence(&[
            ("accel.k2.x", 1.9e-5, 1e-6),
            ("accel.k2.y", -2.2e-5, 1e-6),
            ("accel.k2.z", 2.0e-5, 1e-6),
        ]);
        let prior = |_: &str| Some(1e-4);
        let size = term_size("accel_quadratic", &[e], &prior).unwrap();
        let line = size_line(&size);
        assert!(line.contains("largest accel.k2.y"), "{line}");
        assert!(line.contains("typical: pendulous quartz"), "{line}");
        assert!(term_size("gyro_g_sensitivity", &[], &prior).is_none());
        // The largest estimate of a parameter the data leave at its prior is not quoted.
        let e = evidence(&[
            ("accel.k2.x", 1.9e-5, 1e-6),
            ("accel.k2.y", -9.0e-5, 0.95e-4),
        ]);
        let size = term_size("accel_quadratic", &[e], &prior).unwrap();
        assert_eq!(
            size.largest.as_ref().map(|l| l.name.as_str()),
            Some("accel.k2.x")
        );
        let e = evidence(&[("accel.k2.y", -9.0e-5, 0.95e-4)]);
        let size = term_size("accel_quadratic", &[e], &prior).unwrap();
        assert!(size.largest.is_none());
        let line = size_line(&size);
        assert!(line.contains("observes none of its parameters"), "{line}");
    }
}
