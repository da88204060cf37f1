//! What a `diagnose` run reports, computed once ([`Diagnosis::build`]): the loop's result, the
//! held-out verdict of the final model (a hand-turned recording with measured noise), the
//! verdict, and the figures of the laboratory report. The printout and the JSON
//! (`crate::diagnose`) and the report (`crate::diagnose_report`) render it.

use crate::Error;
use crate::identification::Identification;
use crate::run_report::{Case, Verdict};
use crate::session::{Diagnose, Session};
use calib::extend::LoopResult;
use calib::report::lab::{self, MeanNis, ParameterRow, RunVerdict, SegmentRow};

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
    /// The laboratory report's figures (`--report`).
    pub lab: Option<DiagnosisLab>,
}

/// The held-out verdict of the final model.
pub struct HeldOut {
    /// Every K-th rest held out.
    pub every: usize,
    /// The verdict of the final model's fit with them held out.
    pub verdict: RunVerdict,
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
    ) -> Result<Self, Error> {
        let verdict = verdict(s, &result, held_out.as_ref());
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
            lab,
            result,
        })
    }
}

/// The verdict of the final model by the rule of `calibrate` (`crate::run_report::Verdict`):
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
    let with_turntable = s.turntable.is_some();
    let (mut v, measured) = match held_out {
        Some(h) => (h.verdict.clone(), true),
        None => (
            RunVerdict::of(
                &r.last.estimate,
                None,
                Some(&r.last.diagnostics),
                with_turntable,
            ),
            false,
        ),
    };
    match refused {
        Some(line) if measured => v.informative.push(line),
        Some(line) => v.decisive.insert(0, line),
        None => {}
    }
    let case = Case {
        measured,
        rests: s.rests.is_some(),
        turntable: with_turntable,
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

/// The laboratory report's figures of the final model.
fn lab_figures(s: &Session<Diagnose>, r: &LoopResult) -> Result<DiagnosisLab, Error> {
    let inputs: Vec<(&'static str, &std::path::Path)> = s
        .report_inputs
        .iter()
        .map(|(role, p)| (*role, p.as_path()))
        .collect();
    let id = crate::identification::identify(&inputs, s.source.shown(), &s.config)?;
    let est = &r.last.estimate;
    let correlation = lab::correlation(est);
    let strongest = lab::strongest_correlations(&correlation.0, &correlation.1, 8);
    Ok(DiagnosisLab {
        id,
        parameters: lab::parameter_rows(est, None),
        mean_nis: lab::mean_nis_figures(&est.stats, with_turntable(est)),
        unobserved: est.unobserved(),
        correlation,
        strongest,
        segments: lab::segment_rows(&r.last.diagnostics, &est.segments),
    })
}

/// Whether a fit used the turntable angles (its layout has their delay).
fn with_turntable(est: &calib::estimate::Estimate) -> bool {
    est.names
        .iter()
        .any(|n| n == sins_model::names::TURNTABLE_TAU)
}
