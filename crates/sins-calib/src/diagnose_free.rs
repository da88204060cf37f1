//! `sins-calib diagnose --free-motion`: the model-extension loop on a hand-turned recording
//! (`calib::extend_free`).

use crate::Error;
use crate::diagnose::Args;
use crate::free_motion::{read_sections, settings_of, static_intervals};
use calib::extend_free::{FreeLoop, free_motion_loop};
use calib::io::read_imu_csv;
use calib::report::p_value_text;
use serde::Serialize;
use std::fmt::Write as _;

#[derive(Serialize)]
struct FreeLoopJson<'a> {
    accepted_terms: &'a [String],
    base_model_fits: bool,
    candidates: &'a [calib::extend_free::FreeCandidate],
    gain: &'a std::collections::BTreeMap<String, calib::extend_free::FreeGain>,
    parameters: &'a [calib::io::ResultParameter],
    rounds: &'a [calib::extend_free::FreeRound],
}

fn summary(r: &FreeLoop, last: &calib::free_motion::FreeMotionVerdict) -> String {
    let mut s = String::new();
    for (k, round) in r.rounds.iter().enumerate() {
        let _ = writeln!(
            s,
            "round {}: candidates by evidence (accept below p = {} if separable)",
            k + 1,
            p_value_text(round.threshold)
        );
        for c in &round.candidates {
            let _ = writeln!(
                s,
                "  {:<24} statistic {:>10.2} dof {:>2} p {:>9}  separable {} (worst sigma/prior {:.3})",
                c.term,
                c.statistic,
                c.dof,
                p_value_text(c.p_value),
                if c.separable { "yes" } else { "no" },
                c.worst_sigma_ratio
            );
        }
        if let Some(g) = round.held_out_gain {
            let _ = writeln!(
                s,
                "  held-out check of {}: log-likelihood of the held-out static and rotation \
                 residuals {g:+.2} with it: {}",
                round.candidates.first().map_or("", |c| c.term.as_str()),
                if g >= 0.0 {
                    "passed"
                } else {
                    "FAILED, not accepted"
                }
            );
        }
        match &round.accepted {
            Some(t) => {
                let g = &r.gain[t];
                let _ = writeln!(
                    s,
                    "  accepted {t}: reduced chi2 {:.3} -> {:.3}; held out: rotation {:.3} -> {:.3} deg, static {:.5} -> {:.5} m/s^2",
                    g.reduced_chi2.0,
                    g.reduced_chi2.1,
                    g.held_out_rotation_deg.0,
                    g.held_out_rotation_deg.1,
                    g.held_out_static_m_s2.0,
                    g.held_out_static_m_s2.1
                );
            }
            None => {
                let _ = writeln!(s, "  nothing accepted");
            }
        }
    }
    if let Some((term, g)) = r.held_out_rejection() {
        let _ = writeln!(
            s,
            "verdict: THE DATA CALL FOR {term}, BUT WITH IT THE HELD-OUT INTERVALS ARE PREDICTED \
             WORSE (held-out log-likelihood {g:+.2}): IT IS NOT ACCEPTED. THE MODEL DOES NOT FIT \
             THESE DATA AND NO CANDIDATE TERM EXPLAINS THE MISFIT (exit status 3); terms \
             accepted before: {}.",
            if r.accepted_terms.is_empty() {
                "none".to_string()
            } else {
                r.accepted_terms.join(", ")
            }
        );
    } else if r.accepted_terms.is_empty() && last.fits {
        let _ = writeln!(
            s,
            "verdict: the paper's model fits these data; no term is called for."
        );
    } else if r.accepted_terms.is_empty() {
        let _ = writeln!(
            s,
            "verdict: THE MODEL DOES NOT FIT THESE DATA, AND NO CANDIDATE TERM EXPLAINS THE \
             MISFIT (exit status 3):"
        );
    } else {
        let _ = writeln!(
            s,
            "verdict: terms accepted: {}",
            r.accepted_terms.join(", ")
        );
        if !last.fits {
            let _ = writeln!(
                s,
                "  the extended model still does not fit these data (exit status 3):"
            );
        }
    }
    for line in last.reasons.iter() {
        let _ = writeln!(s, "  {line}");
    }
    for line in last.marginal.iter() {
        let _ = writeln!(s, "  marginal: {line}");
    }
    s
}

/// Run `diagnose --free-motion`; `Ok(false)`: the final model does not fit (exit status 3).
pub fn run(args: &Args) -> Result<bool, Error> {
    let (mut settings, _) = settings_of(args.config.as_deref(), args.latitude)?;
    settings.holdout = args.holdout;
    let data = read_imu_csv(&args.imu)?;
    let file = args.imu.display().to_string();
    let detector = args
        .detector
        .settings()
        .map_err(|e| format!("diagnose --free-motion: {e}"))?;
    let (_, intervals) = static_intervals(&data, &file, &detector)?;
    let turns = match &args.sections {
        Some(p) => read_sections(p, &data)?.known_turns(&intervals),
        None => Vec::new(),
    };
    let r = free_motion_loop(&data, &intervals, &turns, &settings, args.level)
        .map_err(|e| format!("{file}: {e}"))?;
    let last = r.last.verdict();
    crate::report(&summary(&r, &last), args.json.as_deref())?;
    if let Some(path) = &args.json {
        let j = FreeLoopJson {
            accepted_terms: &r.accepted_terms,
            base_model_fits: r.accepted_terms.is_empty()
                && r.base.verdict().fits
                && r.held_out_rejection().is_none(),
            candidates: r.rounds.last().map_or(&[][..], |l| &l.candidates[..]),
            gain: &r.gain,
            parameters: &r.last.parameters,
            rounds: &r.rounds,
        };
        crate::output::write_file(path, serde_json::to_string_pretty(&j)?.as_bytes())?;
    }
    Ok(last.fits && r.held_out_rejection().is_none())
}
