//! `sins-calib diagnose`: fit the paper's model, test every candidate term against the
//! innovations, add the best-supported separable one, measure what it gains, repeat
//! (`calib::extend`; method in docs/model-extension.md).

use crate::Error;
use crate::render::diagnose_figures::{Diagnosis, HeldOut, ModelNavigation, TermSize};
use crate::session::{Records, Session};
use calib::check::stats::p_value_text;
use calib::estimate::RunData;
use calib::extend::{CandidateEvidence, LoopResult, TermGain, run_loop, run_loop_at_rests};
use calib::io::ResultParameter;
use calib::io::angle_records::AngleFile;
use serde::Serialize;
use sins_model::candidates::Candidate;
use std::collections::BTreeMap;
use std::fmt::Write as _;

#[derive(Serialize)]
struct CandidateJson<'a> {
    term: &'a str,
    statistic: f64,
    dof: usize,
    p_value: f64,
    separable: bool,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    confounded_with: Vec<String>,
}

#[derive(Serialize)]
struct LoopJson<'a> {
    accepted_terms: &'a [String],
    /// Terms the data call for that the recording does not separate, carried with their prior.
    carried_terms: Vec<&'a str>,
    base_model_fits: bool,
    candidates: Vec<CandidateJson<'a>>,
    gain: &'a BTreeMap<String, TermGain>,
    parameters: Vec<ResultParameter>,
    rounds: &'a [calib::extend::Round],
    #[serde(skip_serializing_if = "Option::is_none")]
    drift_reach: Option<DriftReachJson>,
    #[serde(skip_serializing_if = "Option::is_none")]
    noise_rescaled: Option<calib::extend::NoiseRescale>,
    /// Candidates not tested, with why.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    not_tested: Vec<NotTestedJson<'a>>,
    /// The records' temperatures and the thermal terms' reference.
    #[serde(skip_serializing_if = "Option::is_none")]
    temperature: Option<calib::io::ResultTemperature>,
    /// The verdict of the final model, as the exit status says it.
    verdict: crate::render::result_json::VerdictJson<'a>,
    /// What the final model buys in navigation (`crate::navigation`).
    navigation: crate::navigation::NavigationJson<'a>,
    /// Every model the loop moved to, the paper's first, each with its navigation figure.
    models: Vec<ModelJson<'a>>,
    /// The navigation figure before and after each accepted (or carried) term.
    navigation_gain: BTreeMap<&'a str, NavigationGainJson>,
}

#[derive(Serialize)]
struct ModelJson<'a> {
    /// The term whose acceptance made the model (absent: the paper's model).
    #[serde(skip_serializing_if = "Option::is_none")]
    term: Option<&'a str>,
    carried: bool,
    terms: &'a [String],
    navigation: crate::navigation::NavigationJson<'a>,
}

#[derive(Serialize)]
struct NavigationGainJson {
    before_m: Option<f64>,
    after_m: Option<f64>,
}

#[derive(Serialize)]
struct NotTestedJson<'a> {
    term: &'a str,
    why: &'a str,
}

/// [`calib::extend::DriftReach`] in SI: the smallest walk the program is expected to show.
#[derive(Serialize)]
pub(crate) struct DriftReachJson {
    /// The statistic at which the walk would be accepted.
    threshold: f64,
    /// rad/s/sqrt(s); `None` when even the largest tried stays below the threshold.
    smallest_visible_rad_s_sqrt_s: Option<f64>,
    expected_statistic: Option<f64>,
    /// The gyro-bias sigmas at the end of the run with that walk in the model, and without (rad/s).
    gyro_bias_sigma_with: Option<[f64; 3]>,
    gyro_bias_sigma_without: Option<[f64; 3]>,
    largest_tried_rad_s_sqrt_s: f64,
}

pub(crate) fn drift_reach_json(d: &calib::extend::DriftReach) -> DriftReachJson {
    let v = d.smallest_visible.as_ref();
    DriftReachJson {
        threshold: d.threshold,
        smallest_visible_rad_s_sqrt_s: v.map(|v| v.intensity),
        expected_statistic: v.map(|v| v.expected_statistic),
        gyro_bias_sigma_with: v.map(|v| v.gyro_bias_sigma),
        gyro_bias_sigma_without: v.map(|v| v.gyro_bias_sigma_without),
        largest_tried_rad_s_sqrt_s: d.largest_tried,
    }
}

fn candidate_json(c: &CandidateEvidence) -> CandidateJson<'_> {
    CandidateJson {
        term: &c.term,
        statistic: c.statistic,
        dof: c.dof,
        p_value: c.p_value,
        separable: c.separable,
        confounded_with: c.separation.as_ref().map_or(Vec::new(), |s| s.confounded()),
    }
}

/// The diagnosis as JSON.
fn to_json(d: &Diagnosis) -> Result<String, Error> {
    let r = &d.result;
    let mut parameters = r.last.calibration.estimate.to_result_file().parameters;
    if let Some(d) = r.last.extension.gyro_drift {
        for (i, a) in ["x", "y", "z"].iter().enumerate() {
            parameters.push(ResultParameter {
                name: format!("gyro.drift.{a}"),
                value: d[i],
                sigma: None,
                unit: "rad/s/sqrt(s)".into(),
            });
        }
    }
    let j = LoopJson {
        accepted_terms: &r.accepted_terms,
        carried_terms: r.carried_terms(),
        base_model_fits: r.base_fits(),
        candidates: r.rounds.last().map_or(Vec::new(), |l| {
            l.candidates.iter().map(candidate_json).collect()
        }),
        gain: &r.gain,
        parameters,
        rounds: &r.rounds,
        drift_reach: r.drift_reach.as_ref().map(drift_reach_json),
        noise_rescaled: r.noise_rescaled,
        not_tested: r
            .not_tested
            .iter()
            .map(|(term, why)| NotTestedJson { term, why })
            .collect(),
        temperature: r.last.calibration.estimate.temperature.clone(),
        verdict: crate::render::result_json::verdict(&d.verdict),
        navigation: final_navigation(d).json(),
        models: d
            .navigation
            .iter()
            .map(|m| ModelJson {
                term: m.term.as_deref(),
                carried: m.carried,
                terms: &m.terms,
                navigation: m.navigation.json(),
            })
            .collect(),
        navigation_gain: d
            .navigation
            .windows(2)
            .filter_map(|w| {
                let term = w[1].term.as_deref()?;
                let gain = NavigationGainJson {
                    before_m: w[0].navigation.rho_m(),
                    after_m: w[1].navigation.rho_m(),
                };
                Some((term, gain))
            })
            .collect(),
    };
    Ok(calib::io::schema::to_json(
        calib::io::schema::DIAGNOSIS,
        &j,
    )?)
}

/// The final model's navigation figure (the last model the loop moved to).
fn final_navigation(d: &Diagnosis) -> &crate::navigation::Navigation {
    &d.navigation
        .last()
        .expect("the paper's model has a navigation figure")
        .navigation
}

/// The accepted line's navigation figures: the model's before the term and after it.
fn navigation_gain_line(models: &[ModelNavigation], term: &str) -> String {
    let Some(k) = models
        .iter()
        .position(|m| m.term.as_deref() == Some(term))
        .filter(|&k| k > 0)
    else {
        return String::new();
    };
    let (before, after) = (&models[k - 1].navigation, &models[k].navigation);
    let why = if before.model_fits == Some(false) {
        "the model without it does not fit these data, which call for the term: its figure was \
         the model's, not the unit's"
    } else {
        "with the term in the model its own uncertainty counts"
    };
    match (&before.figure, &after.figure) {
        (Ok(b), Ok(a)) => format!(
            "  navigation: {} -> {} after {} of {} ({why})\n",
            crate::navigation::distance(b.rho_m),
            crate::navigation::distance(a.rho_m),
            crate::navigation::duration(a.horizon.seconds),
            after.flight_name
        ),
        _ => format!("  {}\n", after.line()),
    }
}

/// Whether a candidate can be told apart from the model's parameters, in words: "yes",
/// `near_prior` when its posterior sigma stays near its prior, or the parameters it is
/// confounded with (the printout and the report word the middle case each their own way).
pub fn separability(c: &calib::extend::CandidateEvidence, near_prior: &str) -> String {
    let confounded = c
        .separation
        .as_ref()
        .map(|x| x.confounded())
        .unwrap_or_default();
    if c.separable {
        "yes".to_string()
    } else if confounded.is_empty() {
        near_prior.to_string()
    } else {
        format!("no: confounded with {}", confounded.join(", "))
    }
}

/// One round of the loop: its candidates with their evidence and separability, what was
/// accepted with its gain (in likelihood and in navigation), and the accepted term's size.
fn round_lines(
    r: &LoopResult,
    k: usize,
    round: &calib::extend::Round,
    size: Option<&TermSize>,
    models: &[ModelNavigation],
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "round {}: candidates by evidence (accept below p = {} if separable)",
        k + 1,
        p_value_text(round.threshold)
    );
    let _ = writeln!(
        s,
        "  {:<24} {:>12} {:>4} {:>10}  separable",
        "term", "statistic", "dof", "p"
    );
    for c in &round.candidates {
        let sep = separability(c, "no (posterior sigma near the prior)");
        let _ = writeln!(
            s,
            "  {:<24} {:>12.2} {:>4} {:>10}  {sep}",
            c.term,
            c.statistic,
            c.dof,
            p_value_text(c.p_value)
        );
    }
    if let Some(h) = round.held_out.as_ref().filter(|h| h.measurements == 0) {
        let _ = writeln!(
            s,
            "  held-out check of {}: nothing to hold out (fewer than {} segments with \
             measurements)",
            h.term, h.every
        );
    } else if let Some(h) = &round.held_out {
        let _ = writeln!(
            s,
            "  held-out check of {} (every {}th segment with measurements held out, {} \
             measurements): log predictive density {:+.1} with it: {}",
            h.term,
            h.every,
            h.measurements,
            h.gain(),
            if h.passed() && h.gain() >= 0.0 {
                "passed".to_string()
            } else if h.passed() {
                format!(
                    "passed (worse by less than the {} nat that would be evidence against it)",
                    calib::extend::HELD_OUT_TOLERANCE_NATS
                )
            } else if h.decides {
                format!(
                    "FAILED (worse by more than {} nat), not accepted",
                    calib::extend::HELD_OUT_TOLERANCE_NATS
                )
            } else {
                "worse (reported only: on a programmed run, and for a random walk, the \
                 check does not decide, docs/model-extension.md)"
                    .to_string()
            }
        );
    }
    s += &decision_line(r, round);
    if let Some(t) = &round.accepted {
        s += &navigation_gain_line(models, t);
    }
    if let Some(size) = size {
        s += &crate::render::diagnose_figures::size_line(size);
    }
    s
}

/// What a round decided: the term accepted (or carried) with what it gained, or why nothing
/// was.
fn decision_line(r: &LoopResult, round: &calib::extend::Round) -> String {
    let mut s = String::new();
    match &round.accepted {
        Some(t) => {
            let g = &r.gain[t];
            let how = if round.carried {
                "carried (the data call for it, this recording does not separate it from the \
                 base parameters: its estimate leans on its prior and its uncertainty is in \
                 their sigmas)"
            } else {
                "accepted"
            };
            let _ = writeln!(
                s,
                "  {how} {t}: log-likelihood +{:.1}, AIC {:+.1}, BIC {:+.1}, mean NIS \
                 accel {:.3} -> {:.3}, turntable {:.3} -> {:.3}",
                g.information.log_likelihood,
                g.information.delta_aic,
                g.information.delta_bic,
                g.accel_mean_nis.0,
                g.accel_mean_nis.1,
                g.turntable_mean_nis.0,
                g.turntable_mean_nis.1
            );
        }
        None => match (&round.refused, round.candidates.first()) {
            (Some(why), Some(c)) => {
                let _ = writeln!(s, "  {} not accepted: {why}", c.term);
            }
            _ => {
                let _ = writeln!(s, "  nothing accepted");
            }
        },
    }
    s
}

/// What the program can see of a gyro bias random walk (the covariance analysis's expected
/// statistic against the round's threshold), and what an unseen one does to the bias sigmas.
fn drift_reach_line(reach: &calib::extend::DriftReach) -> String {
    use sins_model::units::DEG_PER_HOUR;
    let walk = |q: f64| q * 60.0 / DEG_PER_HOUR;
    let deg_h = |v: [f64; 3]| v.map(|x| format!("{:.3}", x / DEG_PER_HOUR)).join(", ");
    match &reach.smallest_visible {
        Some(v) => format!(
            "note: this program is expected to show a gyro bias random walk from about {:.3} \
             deg/h/sqrt(h) (expected statistic {:.1}, accepted above {:.1}; the covariance \
             analysis, docs/model-extension.md); a smaller walk mostly goes unseen, and one of \
             that size would make the gyro-bias sigmas at the end of the run {} deg/h where the \
             model without it reports {}.\n",
            walk(v.intensity),
            v.expected_statistic,
            reach.threshold,
            deg_h(v.gyro_bias_sigma),
            deg_h(v.gyro_bias_sigma_without),
        ),
        None => format!(
            "note: even a gyro bias random walk of {:.3} deg/h/sqrt(h) would stay below the \
             threshold {:.1} of its statistic on this program (covariance analysis, \
             docs/model-extension.md): a walk goes unseen here, and the gyro-bias sigmas do \
             not include one.\n",
            walk(reach.largest_tried),
            reach.threshold
        ),
    }
}

/// The summary printed: the loop's notes, its rounds and its verdict. With `measured` noise
/// (a hand-turned recording without a configuration) the innovation diagnostics inform and
/// the held-out rests decide.
pub fn summary(
    r: &LoopResult,
    sizes: &[Option<TermSize>],
    measured: bool,
    models: &[ModelNavigation],
) -> String {
    let mut s = String::new();
    if let Some(n) = &r.noise_rescaled {
        let _ = writeln!(
            s,
            "note: the configured white noise does not match these data (the paper's model's mean \
             NIS is outside its band): the first round tests every term with it scaled to the \
             data, the specific force's by {:.3} and the angles' by {:.3} (each later round by \
             its own model's); set [noise] to the scaled levels, or measure them (sins-calib \
             noise)",
            n.accel_factor, n.angle_factor
        );
    }
    if let Some((_, why)) = r.not_tested.first() {
        let ids: Vec<&str> = r.not_tested.iter().map(|(t, _)| t.as_str()).collect();
        let _ = writeln!(s, "not tested: {} ({why})", ids.join(", "));
    }
    for (k, round) in r.rounds.iter().enumerate() {
        s += &round_lines(r, k, round, sizes.get(k).and_then(Option::as_ref), models);
    }
    let exit = if measured {
        "(against the measured noise: this informs, the verdict below decides)"
    } else {
        "(the verdict below decides)"
    };
    s += &verdict_lines(r, exit);
    if let Some(reach) = &r.drift_reach {
        s += &drift_reach_line(reach);
    }
    s += &separation_notes(r);
    s
}

/// The loop's verdict: what it accepted, and whether the model fits; `exit` says what a misfit
/// does to the exit status.
fn verdict_lines(r: &LoopResult, exit: &str) -> String {
    let mut s = String::new();
    let accepted = if r.accepted_terms.is_empty() {
        "none".to_string()
    } else {
        r.accepted_terms.join(", ")
    };
    if let Some(h) = r.held_out_rejection() {
        let p = r
            .rounds
            .last()
            .and_then(|l| l.candidates.iter().find(|c| c.term == h.term))
            .map_or(f64::NAN, |c| c.p_value);
        let _ = writeln!(
            s,
            "loop: the data call for {} (p = {}), but with it the held-out measurements are \
             predicted worse (log predictive density {:+.1} over {}, beyond the {} nat \
             allowed): it is not accepted; the model does not fit these data and no candidate \
             term explains the misfit {exit}; terms accepted before: {accepted}.",
            h.term,
            p_value_text(p),
            h.gain(),
            h.measurements,
            calib::extend::HELD_OUT_TOLERANCE_NATS,
        );
    } else if r.accepted_terms.is_empty()
        && r.noise_rescaled.is_some()
        && r.inseparable_calls().is_empty()
    {
        let _ = writeln!(
            s,
            "loop: the configured white noise does not match these data {exit}; with it \
             scaled to them (note above) no term is called for."
        );
    } else if r.base_fits() {
        let _ = writeln!(
            s,
            "loop: the paper's model fits these data; no term is called for."
        );
    } else if r.accepted_terms.is_empty() && !r.last.calibration.diagnostics.fits {
        let _ = writeln!(
            s,
            "loop: the innovation tests fail and no candidate term explains the misfit {exit}. \
             Failing tests:"
        );
        s += &failure_lines(&r.last.calibration.diagnostics.failures);
    } else {
        let _ = writeln!(s, "loop: terms accepted: {accepted}");
        if !r.last.calibration.diagnostics.fits {
            let _ = writeln!(
                s,
                "  the extended model still does not fit these data {exit}. Failing tests:"
            );
            s += &failure_lines(&r.last.calibration.diagnostics.failures);
        }
    }
    s
}

/// The notes on the candidates this recording cannot separate, and on those the data call for
/// that it cannot.
fn separation_notes(r: &LoopResult) -> String {
    let mut s = String::new();
    let inseparable: Vec<String> = r.rounds.last().map_or(Vec::new(), |l| {
        l.candidates
            .iter()
            .filter(|c| !c.separable)
            .map(|c| {
                let conf = c
                    .separation
                    .as_ref()
                    .map(|x| x.confounded())
                    .unwrap_or_default();
                if conf.is_empty() {
                    format!(
                        "{} (not observed: its posterior stays near its prior)",
                        c.term
                    )
                } else {
                    format!("{} (confounded with {})", c.term, conf.join(", "))
                }
            })
            .collect()
    });
    let is_thermal = |line: &String| {
        line.split(' ')
            .next()
            .and_then(Candidate::from_id)
            .is_some_and(|c| c.is_thermal())
    };
    let (thermal, motion): (Vec<String>, Vec<String>) =
        inseparable.into_iter().partition(is_thermal);
    if !motion.is_empty() {
        let _ = writeln!(
            s,
            "note: this recording cannot separate {}: the base parameters would absorb such an \
             effect, or the motion does not excite it (a time offset and the inner lever arms \
             need specific force measured while the unit turns); `sins-calib design` proposes a \
             turntable program that separates them.",
            motion.join("; ")
        );
    }
    if !thermal.is_empty() {
        let _ = writeln!(
            s,
            "note: this recording cannot separate {}: the temperature's course over the program \
             does not tell the coefficient from the constant terms (a warm-up is not a chamber); \
             `sins-calib analyse --terms ...` with a [temperature] profile (a ramp, steps) says \
             which course does (docs/temperature.md).",
            thermal.join("; ")
        );
    }
    for c in r.inseparable_calls() {
        let _ = writeln!(
            s,
            "note: the data call for {} (p = {}) but this recording cannot separate it; run \
             `sins-calib design --config ... --terms {}` for a program that does.",
            c.term,
            p_value_text(c.p_value),
            c.term
        );
    }
    s
}

/// The failing tests one per line, the first ten and how many more.
fn failure_lines(failures: &[String]) -> String {
    const SHOWN: usize = 10;
    let mut s = String::new();
    for f in failures.iter().take(SHOWN) {
        let _ = writeln!(s, "    {f}");
    }
    if failures.len() > SHOWN {
        let _ = writeln!(
            s,
            "    ... and {} more (all of them in --json)",
            failures.len() - SHOWN
        );
    }
    s
}

/// Run `diagnose` on a programmed run or a recording of rests (hand-turned with
/// --free-motion); returns its exit status (3: the model does not fit these data).
pub fn run(args: &crate::args::DiagnoseArgs) -> Result<u8, Error> {
    let flight = crate::navigation::Flight::load(&args.flight)?;
    let mut session = crate::session::diagnose(args)?;
    note_setup(&session);
    let result = fit_loop(&mut session)?;
    crate::commands::calibrate::check_estimate(
        &result.last.calibration.estimate,
        &session.imu_file,
    )?;
    let held_out = held_out_verdict(&mut session, &result)?;
    let d = Diagnosis::build(&session, result, held_out, &flight)?;
    let mut text = render(&d);
    if let Some(path) = &session.json {
        crate::output::write_file(path, to_json(&d)?.as_bytes())?;
    }
    if let Some(dir) = &session.report {
        let plots = crate::render::lab_report::diagnose_section::write(dir, &d)?;
        let _ = writeln!(text, "wrote the report {} ({plots} plots)", dir.display());
    }
    crate::report(&text, session.json.as_deref())?;
    Ok(d.verdict.exit_status())
}

/// The setup's notes on standard error: the rests the detector may have missed, and where a
/// hand-turned recording's configuration came from.
fn note_setup(s: &Session<crate::session::Diagnose>) {
    let Some(found) = &s.rests else {
        return;
    };
    for line in found.missed.iter().flatten() {
        eprintln!("diagnose: {line}");
    }
    if let Some(f) = &found.free_motion {
        eprintln!("diagnose: {}", f.summary.origin);
        if let Some(g) = &f.summary.grade {
            eprintln!("diagnose: {}", g.describe());
        }
    }
}

/// The model-extension loop on the session's data, with progress lines on standard error: a
/// recording of rests read again for every fit, a programmed run's records held.
fn fit_loop(s: &mut Session<crate::session::Diagnose>) -> Result<LoopResult, Error> {
    let mut timer = StepTimer::new();
    let mut progress = |what: &str| eprintln!("diagnose: {}", timer.line(what));
    let settings = &s.task.settings;
    Ok(match (&mut s.records, &s.rests) {
        (Records::Streamed(imu), Some(found)) => {
            let turns: Vec<calib::motion::rests::Turn> = found
                .free_motion
                .iter()
                .flat_map(|f| f.turns.iter().cloned())
                .collect();
            run_loop_at_rests(
                &s.config,
                &mut **imu,
                &found.rests,
                &turns,
                settings,
                &mut progress,
            )?
        }
        (Records::Held(imu), None) => {
            let data = RunData {
                imu,
                imu_file: &s.imu_file,
                turntable: s.turntable.as_ref().map(AngleFile::records),
            };
            run_loop(&s.config, &data, settings, &mut progress)?
        }
        _ => unreachable!("diagnose streams a recording of rests and holds a programmed run"),
    })
}

/// With noise measured from the recording the diagnostics test the innovations against a
/// level the tool set itself: they inform, and the held-out rests decide (as for `calibrate
/// --free-motion`): the final model fitted with every K-th rest held out.
fn held_out_verdict(
    s: &mut Session<crate::session::Diagnose>,
    result: &LoopResult,
) -> Result<Option<HeldOut>, Error> {
    let (Some(noise), Some(found), Records::Streamed(imu)) =
        (s.task.settings.measured_noise, &s.rests, &mut s.records)
    else {
        return Ok(None);
    };
    let known: &[calib::motion::rests::Turn] = found.free_motion.as_ref().map_or(&[], |f| &f.turns);
    let every = s.holdout.unwrap_or(calib::extend::HOLD_OUT_EVERY);
    let layout = calib::model::layout::layout_with(&s.config, false, &result.last.extension);
    // Its verdict with the tests of its innovations, as `calibrate --free-motion` runs them:
    // they inform.
    let run = calib::estimate::HandTurnedRun {
        rests: &found.rests,
        turns: known,
        holdout: Some(every),
        measured: Some(noise),
    };
    let plan = calib::estimate::Plan {
        config: &s.config,
        layout: Some(&layout),
        kind: calib::estimate::RunKind::HandTurned(run),
    };
    let records = calib::estimate::Records::Streamed {
        imu: &mut **imu,
        turntable: None,
    };
    let r = calib::estimate::run(plan, records, &mut |_, _| {})?;
    let figures = found.free_motion.as_ref().and_then(|f| {
        let turns = calib::estimate::verdict::known_turn_figures(&r.estimate.stats);
        crate::free_motion::figures(&r, &f.summary, Some(every), turns)
    });
    Ok(Some(HeldOut {
        every,
        verdict: r.verdict,
        figures,
    }))
}

/// The printout of a diagnosis.
fn render(d: &Diagnosis) -> String {
    let mut text = String::new();
    if let Some((file, grid)) = &d.walk_prior {
        let shown: Vec<String> = grid.iter().map(|q| format!("{q:.4}")).collect();
        let _ = writeln!(
            text,
            "note: the gyro bias random walk candidate is tried at {} deg/h/sqrt(h), the walk \
             {file} identified at rest (its 68 % interval and value)",
            shown.join(", ")
        );
    }
    text += &summary(&d.result, &d.sizes, d.held_out.is_some(), &d.navigation);
    let _ = writeln!(text, "final model's {}", final_navigation(d).line());
    text += &verdict_block(d);
    text
}

/// The verdict of the final model: what it rests on, the findings, and the reasons for exit
/// status 3.
fn verdict_block(d: &Diagnosis) -> String {
    let v = &d.verdict;
    let mut s = String::new();
    let _ = match &d.held_out {
        Some(h) => writeln!(
            s,
            "held-out verdict of the final model (every {}th rest held out; rests on {}):",
            h.every, v.basis
        ),
        None => writeln!(s, "verdict of the final model (rests on {}):", v.basis),
    };
    for line in &v.findings {
        let _ = writeln!(s, "  finding: {line}");
    }
    if v.fits() {
        let _ = writeln!(s, "  nothing contradicts the model (exit status 0)");
    } else {
        let _ = writeln!(
            s,
            "  THE {} CONTRADICT THE MODEL (exit status {}):",
            if d.held_out.is_some() {
                "HELD-OUT RESTS"
            } else {
                "DATA"
            },
            v.exit_status()
        );
        for line in &v.reasons {
            let _ = writeln!(s, "    {line}");
        }
    }
    s
}

/// The time figures of `diagnose`'s progress lines: the time elapsed, and for the step that
/// starts (a fit, mostly) the time left as the steps so far took on average. The number of
/// fits depends on what each fit finds, so the estimate is of the step, not of the whole run.
struct StepTimer {
    start: std::time::Instant,
    steps: usize,
}

impl StepTimer {
    fn new() -> Self {
        Self {
            start: std::time::Instant::now(),
            steps: 0,
        }
    }

    /// The progress line of a step that starts now.
    fn line(&mut self, what: &str) -> String {
        let elapsed = self.start.elapsed().as_secs_f64();
        let line = if self.steps == 0 {
            format!("{what} [{} elapsed]", duration_text(elapsed))
        } else {
            let each = elapsed / self.steps as f64;
            format!(
                "{what} [{} elapsed, step {}; about {} left for this step at the {} a step so \
                 far]",
                duration_text(elapsed),
                self.steps + 1,
                duration_text(each),
                duration_text(each)
            )
        };
        self.steps += 1;
        line
    }
}

/// A duration as `12 s`, `3 min 05 s` or `1 h 02 min`.
fn duration_text(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s < 60 {
        format!("{s} s")
    } else if s < 3600 {
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        format!("{} h {:02} min", s / 3600, (s % 3600) / 60)
    }
}
