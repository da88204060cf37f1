//! `sins-calib diagnose`: fit the paper's model, test every candidate term against the
//! innovations, add the best-supported separable one, measure what it gains, repeat
//! (`calib::extend`; method in docs/model-extension.md).

use crate::{Error, load_config};
use calib::check::stats::p_value_text;
use calib::estimate::RunData;
use calib::extend::{
    CandidateEvidence, LoopResult, LoopSettings, TermGain, run_loop, run_loop_at_rests,
};
use calib::io::angle_records::AngleFile;
use calib::io::{ResultParameter, read_imu_csv};
use serde::Serialize;
use sins_model::candidates::Candidate;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `diagnose`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// IMU records (as for `calibrate`).
    #[arg(long, value_name = "FILE")]
    pub imu: PathBuf,
    /// Turntable angle records (as for `calibrate`); without them the IMU-only model is used.
    #[arg(long, value_name = "FILE")]
    pub turntable: Option<PathBuf>,
    /// Run configuration (a TOML file, or `paper` / `paper-reconciled`). Required unless
    /// --free-motion; with it optional (its `[site]` and `[priors]`).
    #[arg(
        long,
        value_name = "FILE|NAME",
        required_unless_present = "free_motion"
    )]
    pub config: Option<String>,
    /// A hand-turned multi-position recording (no program, no turntable): the loop runs on the
    /// filter of a recording of rests as for a configuration without a program; without
    /// --config, with the configuration `calibrate --free-motion` makes from the recording
    /// (consumer-grade priors, the white noise measured in the rests).
    #[arg(long, conflicts_with_all = ["turntable", "program_start"])]
    pub free_motion: bool,
    /// With --free-motion: the section list written by `import` (its known turns are
    /// measurements of every fit).
    #[arg(long, value_name = "FILE", requires = "free_motion")]
    pub sections: Option<PathBuf>,
    /// With --free-motion: the held-out check of an accepted term holds out every K-th rest
    /// (default 4).
    #[arg(long, value_name = "K", requires = "free_motion")]
    pub holdout: Option<usize>,
    /// With --free-motion and no --config: latitude of the site (deg).
    #[arg(
        long,
        value_name = "DEG",
        requires = "free_motion",
        conflicts_with = "config",
        allow_negative_numbers = true
    )]
    pub latitude: Option<f64>,
    /// With --free-motion and no --config: height of the site above the ellipsoid (m) for
    /// normal gravity (absent: 0, said as an assumption; gravity falls 3.1e-6 m/s^2 a metre, a
    /// scale error of 0.3 ppm a metre in the accelerometers).
    #[arg(
        long,
        value_name = "M",
        requires = "free_motion",
        conflicts_with = "config",
        allow_negative_numbers = true
    )]
    pub height: Option<f64>,
    /// Write the loop's result as JSON: accepted_terms, candidates (last round), gain,
    /// parameters (docs/formats.md).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the report a laboratory files into DIR (created, or replaced whole: no plot of an
    /// earlier report stays): as `calibrate --report` (docs/report.md) for the final model,
    /// with the paper's model beside it and the model-extension table.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Family-wise level of each round's decision.
    #[arg(long, default_value_t = 0.01, value_name = "P")]
    pub level: f64,
    /// The noise identified at rest (the JSON of `sins-calib noise --json`): the gyro bias
    /// random walk candidate is tried at its identified walk, the largest axis's value and the
    /// ends of its 68 % interval, instead of the default grid of 0.003 to 0.3 deg/h/sqrt(h)
    /// (docs/model-extension.md, "The evidence for a term")
    #[arg(long, value_name = "FILE")]
    pub noise: Option<PathBuf>,
    /// Candidate terms to consider (ids; default all): gyro_g_sensitivity,
    /// gyro_scale_asymmetry, accel_quadratic, accel_size_effect, gyro_bias_drift,
    /// gyro_accel_time_offset.
    #[arg(long, value_name = "ID", num_args = 1..)]
    pub terms: Vec<String>,
    /// IMU time (s) at which the rotation program starts (as for `calibrate`).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub program_start: Option<f64>,
    /// How rests are found in a recording without a program (a configuration without
    /// `program` and no --turntable: the loop then runs on the filter of `calibrate` for such
    /// recordings, each candidate's separability from the fit's own posterior).
    #[command(flatten)]
    pub detector: crate::detector_args::DetectorArgs,
}

/// Parse candidate ids, naming the valid ones on a bad id and refusing one given twice (it
/// would be tested twice and halve every Bonferroni threshold).
pub fn parse_terms(ids: &[String]) -> Result<Vec<Candidate>, Error> {
    for (i, id) in ids.iter().enumerate() {
        if ids[..i].contains(id) {
            return Err(format!(
                "--terms {}: `{id}` is given twice: expected each candidate term once",
                ids.join(" ")
            )
            .into());
        }
    }
    ids.iter()
        .map(|id| {
            Candidate::from_id(id).ok_or_else(|| {
                let valid: Vec<&str> = Candidate::ALL.iter().map(|c| c.id()).collect();
                format!("unknown term {id:?}: expected one of {}", valid.join(", ")).into()
            })
        })
        .collect()
}

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

/// The loop's result as JSON.
fn to_json(r: &LoopResult) -> Result<String, Error> {
    let mut parameters = r.last.estimate.to_result_file().parameters;
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
        temperature: r.last.estimate.temperature.clone(),
    };
    Ok(calib::io::schema::to_json(
        calib::io::schema::DIAGNOSIS,
        &j,
    )?)
}

/// One round of the loop: its candidates with their evidence and separability, what was
/// accepted with its gain, and the accepted term's size.
fn round_lines(r: &LoopResult, k: usize, round: &calib::extend::Round) -> String {
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
        let conf = c
            .separation
            .as_ref()
            .map(|x| x.confounded())
            .unwrap_or_default();
        let sep = if c.separable {
            "yes".to_string()
        } else if conf.is_empty() {
            "no (posterior sigma near the prior)".to_string()
        } else {
            format!("no: confounded with {}", conf.join(", "))
        };
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
    match &round.accepted {
        Some(t) => {
            let g = &r.gain[t];
            let _ = writeln!(
                s,
                "  accepted {t}: log-likelihood +{:.1}, AIC {:+.1}, BIC {:+.1}, mean NIS \
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
        None => {
            let _ = writeln!(s, "  nothing accepted");
        }
    }
    if let Some(t) = &round.accepted {
        s += &size_line(t, &round.candidates);
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

/// The summary printed (and heading the Markdown report).
pub fn summary(r: &LoopResult) -> String {
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
        s += &round_lines(r, k, round);
    }
    let calls = r.inseparable_calls();
    if let Some(h) = r.held_out_rejection() {
        let p = r
            .rounds
            .last()
            .and_then(|l| l.candidates.iter().find(|c| c.term == h.term))
            .map_or(f64::NAN, |c| c.p_value);
        let _ = writeln!(
            s,
            "verdict: THE DATA CALL FOR {} (p = {}), BUT WITH IT THE HELD-OUT MEASUREMENTS ARE \
             PREDICTED WORSE (log predictive density {:+.1} over {}, beyond the {} nat \
             allowed): IT IS NOT ACCEPTED. THE \
             MODEL DOES NOT FIT THESE DATA AND NO CANDIDATE TERM EXPLAINS THE MISFIT (exit status \
             3); terms accepted before: {}.",
            h.term,
            p_value_text(p),
            h.gain(),
            h.measurements,
            calib::extend::HELD_OUT_TOLERANCE_NATS,
            if r.accepted_terms.is_empty() {
                "none".to_string()
            } else {
                r.accepted_terms.join(", ")
            }
        );
    } else if r.accepted_terms.is_empty() && r.noise_rescaled.is_some() && calls.is_empty() {
        let _ = writeln!(
            s,
            "verdict: THE CONFIGURED WHITE NOISE DOES NOT MATCH THESE DATA (exit status 3); with \
             it scaled to them (note above) no term is called for."
        );
    } else if r.base_fits() {
        let _ = writeln!(
            s,
            "verdict: the paper's model fits these data; no term is called for."
        );
    } else if r.accepted_terms.is_empty() && !r.last.diagnostics.fits {
        let _ = writeln!(
            s,
            "verdict: THE MODEL DOES NOT FIT THESE DATA, AND NO CANDIDATE TERM THAT THIS \
             RECORDING SEPARATES EXPLAINS THE MISFIT (exit status 3). Failing tests:"
        );
        s += &failure_lines(&r.last.diagnostics.failures);
    } else {
        let _ = writeln!(
            s,
            "verdict: terms accepted: {}",
            if r.accepted_terms.is_empty() {
                "none".to_string()
            } else {
                r.accepted_terms.join(", ")
            }
        );
        if !r.last.diagnostics.fits {
            let _ = writeln!(
                s,
                "  the extended model still does not fit these data (exit status 3). Failing \
                 tests:"
            );
            s += &failure_lines(&r.last.diagnostics.failures);
        }
    }
    if let Some(reach) = &r.drift_reach {
        s += &drift_reach_line(reach);
    }
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
    for c in calls {
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

/// An accepted term's largest estimate in the report's units, against typical magnitudes for
/// units of each grade.
fn size_line(term: &str, candidates: &[CandidateEvidence]) -> String {
    let (Some(c), Some(e)) = (
        Candidate::from_id(term),
        candidates.iter().find(|e| e.term == term),
    ) else {
        return String::new();
    };
    let Some(largest) = e
        .estimate
        .iter()
        .max_by(|a, b| a.value.abs().total_cmp(&b.value.abs()))
    else {
        return String::new();
    };
    let unit = match c {
        // The drift's estimate is an intensity, in its own unit.
        Candidate::GyroBiasDrift => sins_model::terms::Unit::RadPerSecondPerSqrtSecond,
        _ => c.unit(),
    };
    format!(
        "  size: largest {} = {:.3e} {} (+- {:.1e}); typical: {}\n",
        largest.name,
        largest.value * unit.report_factor(),
        unit.report_name(),
        largest.sigma * unit.report_factor(),
        c.typical()
    )
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

/// The data files `diagnose` read, with their roles, for a report's identification.
fn report_inputs(args: &Args) -> Vec<(&'static str, &std::path::Path)> {
    let mut v: Vec<(&'static str, &std::path::Path)> = vec![("IMU records", args.imu.as_path())];
    v.extend(args.turntable.as_deref().map(|p| ("turntable angles", p)));
    v
}

/// Run `diagnose`; returns whether the final model fits the data (its diagnostics pass).
/// The checks of `diagnose`'s arguments made before any work, in either mode (outputs,
/// level, terms).
pub fn check_args(args: &Args) -> Result<(), Error> {
    let mut inputs: Vec<&std::path::Path> = vec![args.imu.as_path()];
    inputs.extend(args.turntable.as_deref());
    inputs.extend(args.sections.as_deref());
    inputs.extend(args.noise.as_deref());
    if let Some(c) = args.config.as_deref() {
        inputs.push(std::path::Path::new(c));
    }
    let mut outputs = crate::output::Outputs::new(&inputs);
    if let Some(p) = &args.json {
        outputs.file(p, "--json")?;
    }
    if let Some(p) = &args.report {
        outputs.dir(p, "--report", &crate::lab_report::NAMES)?;
    }
    // The family-wise level of a decision: a probability, and one that means something.
    if !(args.level.is_finite() && args.level > 0.0 && args.level <= 0.5) {
        return Err(format!(
            "--level {}: expected a family-wise level above 0 and at most 0.5 (0.01 by default)",
            args.level
        )
        .into());
    }
    if args.holdout.is_some_and(|k| k < 2) {
        return Err("--holdout: expected K of at least 2 (every K-th rest held out)".into());
    }
    Ok(())
}

/// Run `diagnose` on a programmed run or a recording of rests (hand-turned with
/// --free-motion; after [`check_args`]); `Ok(false)`: the model does not fit.
pub fn run(args: &Args) -> Result<bool, Error> {
    let (mut config, origin) = match args.config.as_deref() {
        Some(name) => load_config(name)?,
        None if args.free_motion => {
            let mut c = calib::config::RunConfig::paper();
            c.program = calib::config::PROGRAM_FROM_ANGLES.to_string();
            (c, "no configuration".to_string())
        }
        None => load_config("paper")?,
    };
    if let Some(t) = args.program_start {
        // The configuration's range for filter.program_start_s.
        let max = calib::config::PROGRAM_START_MAX_S;
        if !(t.is_finite() && t.abs() <= max) {
            return Err(format!(
                "--program-start {t}: expected the IMU time (s) at which the program starts, \
                 in -{max:e} .. {max:e} s"
            )
            .into());
        }
        config.filter.program_start_s = Some(t);
    }
    let mut settings = LoopSettings {
        level: args.level,
        ..LoopSettings::default()
    };
    if let Some(k) = args.holdout {
        settings.hold_out_every = Some(k);
    }
    if !args.terms.is_empty() {
        settings.candidates = parse_terms(&args.terms)?;
    }
    // The identified walk as the candidate's prior: tried where the data at rest put it.
    let walk_prior = match &args.noise {
        Some(path) => {
            let walk = crate::noise::read_identified_walk(path)?;
            let grid = walk.grid();
            if grid.is_empty() {
                return Err(format!(
                    "{}: the identified gyro bias walk is 0 with no upper end: nothing to try \
                     the walk candidate at (leave --noise out for the default grid)",
                    path.display()
                )
                .into());
            }
            settings.drift_grid = Some(grid.clone());
            Some((path.display().to_string(), grid))
        }
        None => None,
    };
    let imu = read_imu_csv(&args.imu)?;
    let imu_file = args.imu.display().to_string();
    let tt = args.turntable.as_deref().map(AngleFile::open).transpose()?;
    let data = RunData {
        imu: &imu,
        imu_file: &imu_file,
        turntable: tt.as_ref().map(AngleFile::records),
    };
    let mut timer = StepTimer::new();
    let mut progress = |what: &str| eprintln!("diagnose: {}", timer.line(what));
    if args.free_motion && !config.program_from_angles() {
        return Err(format!(
            "diagnose --free-motion: {origin} has a rotation program; --free-motion is for a \
             hand-turned recording without one (leave --free-motion out to diagnose along the \
             program, or give a configuration without `program`)"
        )
        .into());
    }
    let rests_mode = tt.is_none() && config.program_from_angles();
    if !rests_mode && args.detector.any() {
        return Err(
            "diagnose: the --rest-* options set how rests are found in a recording \
                    without a program; this configuration has a program (or --turntable gives \
                    one), which says where the unit rests"
                .into(),
        );
    }
    let mut measured_input = None;
    let mut rests_input: Option<(
        Vec<calib::motion::rests::Rest>,
        Vec<calib::motion::rests::Turn>,
    )> = None;
    let result = if rests_mode {
        let detector = args
            .detector
            .settings()
            .map_err(|e| format!("diagnose: {e}"))?;
        let (rests, seg) =
            crate::detector_args::rests_and_segmentation(&imu, &imu_file, &detector)?;
        for line in seg
            .missed_report(crate::detector_args::option_name)
            .iter()
            .flatten()
        {
            eprintln!("diagnose: {line}");
        }
        let (turns, known) = if args.free_motion {
            let given = args.config.is_some().then_some((&config, origin.as_str()));
            let setup = crate::free_motion::setup(
                given,
                (args.latitude, args.height),
                args.sections.as_deref(),
                &[],
                &imu,
                &imu_file,
                &rests,
            )?;
            config = setup.config;
            settings.measured_noise = setup.measured;
            eprintln!("diagnose: {}", setup.origin);
            if let Some(g) = &setup.grade {
                eprintln!("diagnose: {}", g.describe());
            }
            measured_input = setup.measured;
            (setup.turns.clone(), setup.turns)
        } else {
            (Vec::new(), Vec::new())
        };
        let r = run_loop_at_rests(&config, &data, &rests, &turns, &settings, &mut progress)?;
        rests_input = Some((rests, known));
        r
    } else {
        run_loop(&config, &data, &settings, &mut progress)?
    };
    let mut text = String::new();
    if let Some((file, grid)) = &walk_prior {
        let shown: Vec<String> = grid
            .iter()
            .map(|q| format!("{:.4}", q * 60.0 / sins_model::units::DEG_PER_HOUR))
            .collect();
        let _ = writeln!(
            text,
            "note: the gyro bias random walk candidate is tried at {} deg/h/sqrt(h), the walk \
             {file} identified at rest (its 68 % interval and value)",
            shown.join(", ")
        );
    }
    let mut summary_text = summary(&result);
    // With noise measured from the recording the diagnostics test the innovations against a
    // level the tool set itself: they inform, and the held-out rests decide (as for
    // `calibrate --free-motion`).
    let held_out_verdict = match (&measured_input, rests_input.as_ref()) {
        (Some(noise), Some((rests, turns))) => {
            summary_text = summary_text.replace(
                "(exit status 3)",
                "(against the measured noise: the held-out rests decide, below)",
            );
            let every = args.holdout.unwrap_or(calib::extend::HOLD_OUT_EVERY);
            let layout = calib::model::layout::layout_with(&config, false, &result.last.extension);
            let r = calib::estimate::hand_turned::calibrate(
                &config,
                &layout,
                &imu,
                &imu_file,
                rests,
                turns,
                Some(every),
                Some(*noise),
                &mut |_, _| {},
            )?;
            let v = calib::report::lab::RunVerdict::of(&r.estimate, Some(&r), None, false);
            let _ = writeln!(
                summary_text,
                "held-out verdict of the final model (every {every}th rest held out; rests on \
                 {}):",
                v.basis
            );
            for line in v.informative.iter() {
                let _ = writeln!(summary_text, "  finding: {line}");
            }
            if v.fits() {
                let _ = writeln!(
                    summary_text,
                    "  nothing contradicts the model (exit status 0)"
                );
            } else {
                let _ = writeln!(
                    summary_text,
                    "  THE HELD-OUT RESTS CONTRADICT THE MODEL (exit status 3):"
                );
                for line in &v.decisive {
                    let _ = writeln!(summary_text, "    {line}");
                }
            }
            Some(v.fits())
        }
        _ => None,
    };
    text += &summary_text;
    if let Some(path) = &args.json {
        crate::output::write_file(path, to_json(&result)?.as_bytes())?;
    }
    if let Some(dir) = &args.report {
        let shown = match (args.config.as_deref(), args.free_motion) {
            (None, false) => Some("paper"),
            (c, _) => c,
        };
        let id = crate::lab_report::identify(&report_inputs(args), shown, &config)?;
        let plots = crate::diagnose_report::write(dir, id, &result)?;
        let _ = writeln!(text, "wrote the report {} ({plots} plots)", dir.display());
    }
    crate::report(&text, args.json.as_deref())?;
    Ok(held_out_verdict.unwrap_or_else(|| result.final_model_fits()))
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

#[cfg(test)]
mod tests {
    use super::*;
    use calib::extend::ParameterValue;

    #[test]
    fn an_accepted_terms_size_is_set_against_typical_values() {
        let e = CandidateEvidence {
            term: "accel_quadratic".into(),
            statistic: 40.0,
            dof: 3,
            p_value: 1e-8,
            ln_p_value: 1e-8f64.ln(),
            separable: true,
            separation: None,
            estimate: [
                ("accel.k2.x", 1.9e-5),
                ("accel.k2.y", -2.2e-5),
                ("accel.k2.z", 2.0e-5),
            ]
            .iter()
            .map(|(n, v)| ParameterValue {
                name: n.to_string(),
                value: *v,
                sigma: 1e-6,
            })
            .collect(),
        };
        let line = size_line("accel_quadratic", &[e]);
        assert!(line.contains("largest accel.k2.y"), "{line}");
        assert!(line.contains("typical: pendulous quartz"), "{line}");
        assert!(size_line("gyro_g_sensitivity", &[]).is_empty());
    }
}
