//! The report of `diagnose --report DIR` (`crate::render::lab_report`): the final model's fit with the
//! paper's model beside it, and the model-extension table of every round.

use crate::Error;
use crate::render::diagnose_figures::Diagnosis;
use crate::render::lab_report::{FitView, Report};
use crate::render::table;
use calib::check::stats::p_value_text;
use std::fmt::Write as _;
use std::path::Path;

/// Write the report of the diagnosis `d` into `dir`; returns the number of plots.
pub fn write(dir: &Path, d: &Diagnosis) -> Result<usize, Error> {
    let r = &d.result;
    let Some(lab) = &d.lab else {
        return Err("diagnose: the report's figures were not made".into());
    };
    // The final model's correction, as `calibrate --json` would write it for that model.
    let result_file = r.last.calibration.result_file();
    let report = Report {
        title: "Model diagnosis report",
        id: &lab.id,
        verdict: &d.verdict,
        mean_nis: &lab.mean_nis,
        hand_turned: d.held_out.as_ref().and_then(|h| h.figures.as_ref()),
        parameters: &lab.parameters,
        unobserved: &lab.unobserved,
        truth: None,
        correlation: &lab.correlation,
        strongest: &lab.strongest,
        segments: &lab.segments,
        fit: FitView {
            est: &r.last.calibration.estimate,
            diagnostics: &r.last.calibration.diagnostics,
        },
        base: (!r.accepted_terms.is_empty()).then_some(FitView {
            est: &r.base.calibration.estimate,
            diagnostics: &r.base.calibration.diagnostics,
        }),
        extension: Some(extension_md(d)),
        navigation: d.navigation.last().map(|m| &m.navigation),
        correction: result_file.correction.as_ref(),
    };
    crate::render::lab_report::write(dir, &report)
}

/// Section 7: every round's candidates with their evidence, and the gain of each accepted term.
fn extension_md(d: &Diagnosis) -> String {
    let r = &d.result;
    let mut s = String::from(
        "## 7. Model extension\n\nEach round tests every candidate term against the \
         innovations (score test; docs/model-extension.md) and accepts the best-supported one \
         below the round's threshold if the recording separates it from the paper's \
         parameters.\n\n",
    );
    let _ = writeln!(
        s,
        "Terms accepted: {}.\n",
        if r.accepted_terms.is_empty() {
            "none".to_string()
        } else {
            r.accepted_terms.join(", ")
        }
    );
    for (k, round) in r.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "Round {} (accept below p = {}):\n\n| term | statistic | dof | p | separable | \
             |\n|---|---:|---:|---:|---|---|",
            k + 1,
            p_value_text(round.threshold)
        );
        for c in &round.candidates {
            let separable =
                crate::commands::diagnose::separability(c, "no (posterior near the prior)");
            let accepted = round.accepted.as_deref() == Some(c.term.as_str());
            let _ = writeln!(
                s,
                "| {} | {:.2} | {} | {} | {separable} | {} |",
                c.term,
                c.statistic,
                c.dof,
                p_value_text(c.p_value),
                if accepted { "**accepted**" } else { "" }
            );
        }
        s.push('\n');
        if let (Some(term), Some(size)) = (&round.accepted, d.sizes.get(k).and_then(Option::as_ref))
        {
            let _ = writeln!(
                s,
                "Size of {term}: {}\n",
                crate::render::diagnose_figures::size_line(size)
                    .trim()
                    .trim_start_matches("size: ")
            );
        }
    }
    if !r.gain.is_empty() {
        let _ = writeln!(
            s,
            "Gain of each accepted term:\n\n| term | log-likelihood | AIC | BIC | mean NIS \
             specific force | mean NIS turntable |\n|---|---:|---:|---:|---|---|"
        );
        for (term, g) in &r.gain {
            let _ = writeln!(
                s,
                "| {term} | +{:.1} | {:+.1} | {:+.1} | {:.3} -> {:.3} | {} |",
                g.information.log_likelihood,
                g.information.delta_aic,
                g.information.delta_bic,
                g.accel_mean_nis.0,
                g.accel_mean_nis.1,
                if g.turntable_mean_nis.0 > 0.0 {
                    format!(
                        "{:.3} -> {:.3}",
                        g.turntable_mean_nis.0, g.turntable_mean_nis.1
                    )
                } else {
                    "-".to_string()
                }
            );
        }
        s.push('\n');
    }
    if let Some(q) = r.last.extension.gyro_drift {
        let f = sins_model::terms::Unit::RadPerSecondPerSqrtSecond.report_factor();
        let _ = writeln!(
            s,
            "Gyro bias random walk of the final model: x {}, y {}, z {} deg/h/sqrt(h).\n",
            table::significant(q[0] * f, 3),
            table::significant(q[1] * f, 3),
            table::significant(q[2] * f, 3)
        );
    }
    s
}
