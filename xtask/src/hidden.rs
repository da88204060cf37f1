//! `cargo xtask hidden-effects`: every hidden-effect case and the negative control through the
//! model-extension loop, as a table (effect, accepted terms, estimate against truth, gain).

use std::process::ExitCode;
use workspace_tests::hidden::{cases, negative_control, run_case, term_errors};

/// Run every case and print the table; non-zero exit when a case fails its checks.
pub fn hidden_effects(control_seeds: u64, only: Option<&str>) -> ExitCode {
    println!(
        "| effect | source of the magnitude | accepted (in order) | estimate against truth | gain |"
    );
    println!("|---|---|---|---|---|");
    let mut failed = 0;
    for case in cases()
        .into_iter()
        .filter(|c| only.is_none_or(|o| c.name == o))
    {
        let r = run_case(&case);
        let want: Vec<&str> = case.terms.iter().map(|t| t.id()).collect();
        let first_ok = r.accepted_terms.len() >= want.len()
            && want
                .iter()
                .all(|w| r.accepted_terms[..want.len()].iter().any(|a| a == w));
        let errs = term_errors(&case, &r);
        let worst = errs
            .iter()
            .map(|(_, e, s, t)| ((e - t) / s).abs())
            // A sigma that could not be computed is a failure, not a pass.
            .fold(
                0.0,
                |w: f64, z| if z.is_nan() { f64::INFINITY } else { w.max(z) },
            );
        let shown: Vec<String> = errs
            .iter()
            .filter(|(_, _, _, t)| *t != 0.0)
            .map(|(n, e, s, t)| format!("{n} {e:.3e} +- {s:.1e} (truth {t:.3e})"))
            .collect();
        let gain: Vec<String> = r
            .gain
            .iter()
            .map(|(t, g)| {
                format!(
                    "{t}: dlnL {:+.1}, dAIC {:+.1}",
                    g.information.log_likelihood, g.information.delta_aic
                )
            })
            .collect();
        for h in r.rounds.iter().filter_map(|round| round.held_out.as_ref()) {
            eprintln!(
                "{}: held-out check of {}: {} measurements, log density {:+.2} with it",
                case.name,
                h.term,
                h.measurements,
                h.gain()
            );
        }
        let ok = first_ok && worst <= 3.0 && !r.base_fits() && r.last.diagnostics.fits;
        failed += usize::from(!ok);
        println!(
            "| {} | {} | {} | {} (worst {:.2} sigma) | {} |{}",
            case.name,
            case.source,
            r.accepted_terms.join(", "),
            shown.join("; "),
            worst,
            gain.join("; "),
            if ok { "" } else { " FAILED" }
        );
    }
    let accepted: Vec<(u64, Vec<String>)> = (101..101 + control_seeds)
        .map(|s| (s, run_case(&negative_control(s)).accepted_terms))
        .filter(|(_, a)| !a.is_empty())
        .collect();
    println!(
        "\nnegative control: a term accepted in {} of {control_seeds} seeds {:?}",
        accepted.len(),
        accepted
    );
    if accepted.len() as u64 * 20 > control_seeds {
        failed += 1;
    }
    if failed == 0 {
        ExitCode::SUCCESS
    } else {
        println!("{failed} check(s) failed");
        ExitCode::FAILURE
    }
}
