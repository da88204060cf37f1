//! `sins-calib calibrate`: estimation from recorded data, with a report in the paper's units.

use crate::diagnostic_plots::write_diagnostic_plots;
use crate::table::{self, Align, Table};
use crate::{Error, load_config};
use calib::check::diagnostics::{self, DiagnosticSettings, Diagnostics};
use calib::config::UnitIdentity;
use calib::estimate::{Estimate, FileImu, FitStatistics, ImuSource as _, estimate_from};
use calib::io::angle_records::AngleFile;
use calib::io::{ImuKind, ResultFile, ResultParameter, read_imu_csv, read_result_json};
use calib::model::extension::ModelExtension;
use calib::model::layout::{StateLayout, layout_with};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::fmt::Write as _;
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};

/// IMU records above which a progress bar is shown (about a second of work).
const PROGRESS_ABOVE_RECORDS: usize = 100_000;

/// Arguments of `calibrate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// IMU records: a CSV with the header `t,dthx,dthy,dthz,dvx,dvy,dvz` (increments, rad and m/s)
    /// or `t,wx,wy,wz,fx,fy,fz` (rad/s and m/s^2), an optional `temp` column; t in s on the IMU
    /// clock (the program may start at any time: see --program-start), records at
    /// filter.imu_rate_hz (docs/formats.md).
    #[arg(long, value_name = "FILE")]
    pub imu: PathBuf,
    /// Turntable angle records: a CSV with the header `t,k1,k2,k3` (t in s on the turntable
    /// clock, related to the IMU clock by the configuration's `[clock]`; heading, bank and pitch in
    /// degrees). Adds the installation misalignment and the delay to the estimated parameters
    /// (28 states); without it the IMU data alone are used (24 states).
    #[arg(long, value_name = "FILE")]
    pub turntable: Option<PathBuf>,
    /// Run configuration: a TOML file (docs/formats.md), or `paper` / `paper-reconciled` for the
    /// embedded configurations. Its program must be the one the turntable ran; `[priors]`,
    /// `[noise]`, `[filter]` and `[clock]` set up the filter (`[truth]` is not read). A
    /// configuration without a program and no --turntable calibrate a recording of rests
    /// joined by any motion (a hand-turned unit): the same filter, with the specific force
    /// measured in the rests the data show (docs/estimation.md, "Without a program"). Required
    /// unless --free-motion; with it optional: its `[priors]` and `[site]` (for g) replace the
    /// defaults.
    #[arg(long, value_name = "FILE|NAME")]
    pub config: Option<String>,
    /// A hand-turned multi-position recording, without a rotation program or turntable: the
    /// filter of a recording of rests (the specific force measured in the rests the detector
    /// finds, the attitude carried by the gyros through every motion) with the paper's model
    /// and the terms --terms and --terms-from name; without --config, the unit's grade, priors,
    /// white noise and motion noise from the recording (docs/real-data.md).
    #[arg(long)]
    pub free_motion: bool,
    /// Candidate terms to add to the paper's model (ids): gyro_g_sensitivity,
    /// gyro_scale_asymmetry, accel_quadratic, accel_size_effect, gyro_accel_time_offset and the
    /// thermal gyro_temp_bias, accel_temp_bias, gyro_temp_scale, accel_temp_scale (these need a
    /// `temp` column). None is added without being named.
    #[arg(long, value_name = "ID", num_args = 1..)]
    pub terms: Vec<String>,
    /// Add the terms a `diagnose --json` result accepted (`accepted_terms`).
    #[arg(long, value_name = "DIAGNOSE.json")]
    pub terms_from: Option<PathBuf>,
    /// With --free-motion: the section list written by `import` (sections.json); its rotations
    /// with an expected turn (e.g. 360-degree turns) become measurements of the integrated angle.
    #[arg(long, value_name = "FILE", requires = "free_motion")]
    pub sections: Option<PathBuf>,
    /// With --free-motion: leave every K-th static interval (K, 2K, ... counted from 1) out of
    /// the fit and report the errors on those (a "validation" block in the JSON).
    #[arg(long, value_name = "K", requires = "free_motion")]
    pub holdout: Option<usize>,
    /// With --free-motion: write a PNG of |f| - g per static interval, before and after.
    #[arg(long, value_name = "FILE", requires = "free_motion")]
    pub plot: Option<PathBuf>,
    /// With --free-motion and no --config: latitude of the site (deg) for normal gravity.
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
    /// Write the result to this JSON file: every parameter's name, value, sigma and unit in SI
    /// units, and the fit statistics (docs/formats.md).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// IMU time (s) at which the rotation program starts. Without it the start is found from the
    /// data, by matching the measured rate magnitude against the program's; with it, the data are
    /// checked against the program from there. Either way a recording that does not follow the
    /// program is refused.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub program_start: Option<f64>,
    /// True values (the truth.json of `simulate`, or any result file): also print each
    /// parameter's true value, its error in sigmas and the normalised estimation error squared
    /// (NEES) of all parameters.
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
    /// Test the fit from its innovations (NIS per program segment, whiteness, lines at the
    /// program's frequencies; docs/estimation.md, "Diagnostics"), print a summary and write
    /// PNG plots into DIR (created if missing); with --json the result gets a "diagnostics"
    /// block. A failing verdict (family-wise level 1 %) ends with exit status 3.
    #[arg(long, value_name = "DIR")]
    pub diagnostics: Option<PathBuf>,
    /// Write the report a laboratory files into DIR (created, or replaced whole: no plot of an
    /// earlier report stays): report.md with the inputs' SHA-256, the configuration, version,
    /// date and command line, the verdict and its failing tests, the parameters with 1 sigma,
    /// and PNG plots of the correlations, the residuals and the NIS per segment
    /// (docs/report.md). Runs the diagnostics of --diagnostics: their verdict counts toward
    /// the exit status.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// How rests are found in a recording without a program (and with --free-motion).
    #[command(flatten)]
    pub detector: crate::detector_args::DetectorArgs,
    /// The unit calibrated.
    #[command(flatten)]
    pub unit: crate::provenance::UnitArgs,
}

/// The JSON result: the parameters as `calib::io::ResultFile` writes them, plus the fit
/// statistics (readers of `ResultFile` ignore the extra field).
#[derive(Serialize)]
struct ResultJson<'a> {
    /// The unit the data are of (absent: unknown).
    #[serde(skip_serializing_if = "UnitIdentity::is_empty")]
    unit: &'a UnitIdentity,
    /// With --free-motion: every input file with its SHA-256.
    #[serde(skip_serializing_if = "Option::is_none")]
    inputs: Option<&'a [crate::provenance::InputHash]>,
    /// What the run assumed for want of an input (e.g. the site's latitude).
    assumptions: &'a [String],
    parameters: &'a [ResultParameter],
    /// The posterior correlation of the parameters (docs/formats.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    correlation: Option<&'a Vec<Vec<f64>>>,
    /// The estimated model inverted (`calib::model::correction`).
    #[serde(skip_serializing_if = "Option::is_none")]
    correction: Option<&'a calib::model::correction::CorrectionBlock>,
    /// The records' temperatures and the thermal terms' reference, when the records have a
    /// temperature.
    #[serde(skip_serializing_if = "Option::is_none")]
    temperature: Option<&'a calib::io::ResultTemperature>,
    /// Whether the model fits the data, with the reasons when it does not.
    verdict: VerdictJson,
    fit: FitJson,
    /// With --diagnostics: `calib::check::diagnostics::Diagnostics`.
    #[serde(skip_serializing_if = "Option::is_none")]
    diagnostics: Option<&'a Diagnostics>,
    /// With --free-motion: the noise, the known turns and the held-out rests.
    #[serde(skip_serializing_if = "Option::is_none")]
    free_motion: Option<&'a crate::free_motion::FreeMotionJson>,
}

/// The verdict in the JSON result: `fits` false (and exit status 3) when a mean NIS is outside
/// its band or the diagnostics fail.
#[derive(Serialize)]
struct VerdictJson {
    fits: bool,
    exit_status: u8,
    /// One line per reason (empty when the model fits).
    reasons: Vec<String>,
    /// What the verdict rests on.
    basis: String,
    /// Whether anything tested the model (false: a hand-turned recording with measured noise,
    /// no held-out rests and no known turns).
    tested: bool,
    /// Findings that do not decide the exit status.
    findings: Vec<String>,
}

/// Fit statistics in the JSON result.
#[derive(Serialize)]
struct FitJson {
    states: usize,
    imu_records: usize,
    final_time_s: f64,
    accel_updates: usize,
    accel_mean_nis: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    turntable: Option<TurntableFitJson>,
    /// Parameters the data leave at their prior (posterior sigma / prior sigma above 0.9).
    unobserved: Vec<UnobservedJson>,
    /// Standard deviation of the second-order specific-force error carried into the
    /// covariance (m/s^2; 0 when negligible).
    second_order_accel_sigma_m_s2: f64,
    /// Known turns measured (a recording of rests with a section list).
    #[serde(skip_serializing_if = "Option::is_none")]
    known_turns: Option<KnownTurnsJson>,
}

#[derive(Serialize)]
struct KnownTurnsJson {
    updates: usize,
    mean_nis: f64,
}

#[derive(Serialize)]
struct UnobservedJson {
    name: String,
    sigma_over_prior: f64,
}

#[derive(Serialize)]
struct TurntableFitJson {
    updates: usize,
    mean_nis: f64,
    /// What `mean_nis` averages when the model fits (`FitStatistics::turntable_expected_nis`).
    expected_mean_nis: f64,
    samples_used: usize,
    samples_near_rate_changes: usize,
    samples_without_data: usize,
    record_rate_hz: f64,
}

fn fit_json(est: &Estimate, with_turntable: bool) -> FitJson {
    let s = &est.stats;
    FitJson {
        states: est.names.len(),
        imu_records: s.imu_steps,
        final_time_s: est.final_time,
        accel_updates: s.accel_updates,
        accel_mean_nis: s.accel_mean_nis,
        turntable: with_turntable.then_some(TurntableFitJson {
            updates: s.turntable_updates,
            mean_nis: s.turntable_mean_nis,
            expected_mean_nis: s.turntable_expected_nis,
            samples_used: s.turntable_samples,
            samples_near_rate_changes: s.turntable_samples_near_rate_changes,
            samples_without_data: s.turntable_samples_missing,
            record_rate_hz: s.turntable_record_rate_hz,
        }),
        unobserved: est
            .unobserved()
            .into_iter()
            .map(|(name, sigma_over_prior)| UnobservedJson {
                name,
                sigma_over_prior,
            })
            .collect(),
        second_order_accel_sigma_m_s2: s.second_order_accel_sigma,
        known_turns: (s.turn_updates > 0).then_some(KnownTurnsJson {
            updates: s.turn_updates,
            mean_nis: s.turn_mean_nis,
        }),
    }
}

fn progress_bar(records: usize) -> ProgressBar {
    if records <= PROGRESS_ABOVE_RECORDS || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    // The length is set from the library's (done, total) reports.
    let bar = ProgressBar::with_draw_target(Some(records as u64), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(
        "calibrating [{bar:30}] {human_pos}/{human_len} IMU records read over all passes \
         ({percent:>3} %), {elapsed} elapsed, about {eta} left",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// How a calibration ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every measurement's mean NIS is inside its band.
    Fits,
    /// A measurement's mean NIS is outside its band: the model does not fit these data.
    DoesNotFit,
}

/// The band of a mean of `n` chi-square(3) values: 3 +- three standard deviations, sqrt(6 / n)
/// each (a false alarm about once in 370 runs per measurement).
fn nis_band(n: usize) -> f64 {
    calib::report::lab::mean_nis_half_band(n)
}

/// The files `calibrate` reads (an output must be none of them).
pub(crate) fn input_paths(args: &Args) -> Vec<&Path> {
    let mut v: Vec<&Path> = vec![args.imu.as_path()];
    v.extend(args.turntable.as_deref());
    v.extend(args.truth.as_deref());
    v.extend(args.sections.as_deref());
    v.extend(args.terms_from.as_deref());
    if let Some(c) = args.config.as_deref() {
        v.push(Path::new(c));
    }
    v
}

/// Run `calibrate` with a program, turntable angles, or on a recording of rests (with
/// `--free-motion`, a hand-turned one: `crate::free_motion`).
pub fn run(args: &Args) -> Result<Outcome, Error> {
    if args.free_motion && (args.turntable.is_some() || args.program_start.is_some()) {
        return Err(
            "calibrate --free-motion: --turntable and --program-start belong to a \
                    turntable calibration (a hand-turned recording has neither)"
                .into(),
        );
    }
    let inputs = input_paths(args);
    let mut outputs = crate::output::Outputs::new(&inputs);
    if let Some(path) = &args.json {
        outputs.file(path, "--json")?;
    }
    if let Some(path) = &args.plot {
        outputs.png(path, "--plot")?;
    }
    if let Some(dir) = &args.report {
        outputs.dir(dir, "--report", &crate::lab_report::NAMES)?;
    }
    if let Some(dir) = &args.diagnostics {
        outputs.any_dir(dir, "--diagnostics")?;
        prepare_diagnostics_dir(dir)?;
    }
    let mut input = load_inputs(args)?;
    if args.free_motion && input.program.is_some() {
        return Err(format!(
            "calibrate --free-motion: {} has a rotation program ({}); --free-motion calibrates \
             a hand-turned recording without one (leave --free-motion out to calibrate along \
             the program, or give a configuration without `program`)",
            input.origin,
            input.program.as_ref().map_or("", |p| p.0.as_str())
        )
        .into());
    }
    if input.program.is_some() && args.detector.any() {
        return Err(
            "calibrate: the --rest-* options set how rests are found in a recording \
                    without a program; this configuration has a program (or --turntable gives \
                    one), which says where the unit rests"
                .into(),
        );
    }
    let mut provenance = {
        let config_unit = args
            .config
            .as_deref()
            .map(|_| (input.origin.as_str(), &input.config.unit));
        crate::provenance::gather(&args.imu, config_unit, &args.unit, args.free_motion)?
    };
    let turntable = input.tt.as_ref().map(AngleFile::records);
    let bar = progress_bar(input.imu.len_hint().unwrap_or(0));
    let mut progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let mut hand_turned = None;
    let mut missed_rests = None;
    let terms = crate::free_motion::terms_asked(&args.terms, args.terms_from.as_deref())?;
    let extension = ModelExtension::with_grade(&terms, input.config.unit_grade());
    let est = match &input.program {
        Some(_) => {
            let layout = layout_with(&input.config, turntable.is_some(), &extension);
            check_truth_units(args, &input, &layout)?;
            estimate_from(
                &input.config,
                &layout,
                &mut input.imu,
                turntable,
                &mut progress,
            )?
        }
        None => {
            // No program: the rests the data show stand in for it. The records are read into
            // memory for the detector (recordings of rests are short).
            let data = read_imu_csv(&args.imu)?;
            let settings = args
                .detector
                .settings()
                .map_err(|e| format!("calibrate: {e}"))?;
            let (rests, seg) =
                crate::detector_args::rests_and_segmentation(&data, &input.imu_file, &settings)?;
            missed_rests = seg.missed_report(crate::detector_args::option_name);
            let (layout, turns, measured, origin) = if args.free_motion {
                let given = args
                    .config
                    .is_some()
                    .then_some((&input.config, input.origin.as_str()));
                let setup = crate::free_motion::setup(
                    given,
                    (args.latitude, args.height),
                    args.sections.as_deref(),
                    &terms,
                    &data,
                    &input.imu_file,
                    &rests,
                )?;
                let summary = setup.summary();
                input.config = setup.config;
                (setup.layout, setup.turns, setup.measured, Some(summary))
            } else {
                (
                    layout_with(&input.config, false, &extension),
                    vec![],
                    None,
                    None,
                )
            };
            check_truth_units(args, &input, &layout)?;
            let r = calib::estimate::hand_turned::calibrate(
                &input.config,
                &layout,
                &data,
                &input.imu_file,
                &rests,
                &turns,
                args.holdout,
                measured,
                &mut progress,
            )?;
            input.config = r.config.clone();
            let est = r.estimate.clone();
            hand_turned = Some((r, origin));
            est
        }
    };
    bar.finish_and_clear();

    if args.free_motion {
        // Hashed now that their readers have read (and bounded) them.
        let mut files: Vec<(&str, &Path)> = Vec::new();
        files.extend(args.sections.as_deref().map(|p| ("section list", p)));
        files.extend(
            args.terms_from
                .as_deref()
                .map(|p| ("diagnose result (--terms-from)", p)),
        );
        files.extend(
            args.config
                .as_deref()
                .map(Path::new)
                .filter(|p| p.is_file())
                .map(|p| ("run configuration", p)),
        );
        files.extend(args.truth.as_deref().map(|p| ("truth", p)));
        provenance.hash_files(&files)?;
    }
    let assumptions: Vec<String> = match &hand_turned {
        Some((_, Some(setup))) => setup.assumptions.clone(),
        _ => Vec::new(),
    };
    let mut s = header_report(&input, &est);
    for line in missed_rests.iter().flatten() {
        let _ = writeln!(s, "  missed rests    {line}");
    }
    if let Some((r, Some(setup))) = &hand_turned {
        s += &crate::free_motion::header(setup, r, args.holdout);
    }
    s += &provenance_report(&provenance, &assumptions);
    s.push('\n');
    s += &parameter_report(&est, input.truth.as_ref());
    s.push('\n');
    s += &fit_report(&est.stats, turntable.is_some());
    s += &observability_report(&est);
    if let Some((r, Some(_))) = &hand_turned {
        s += &crate::free_motion::evaluation_report(&r.evaluation);
    }
    if let (Some(truth), Some(path)) = (&input.truth, &args.truth) {
        s.push('\n');
        s += &truth_report(&est, truth, path, &input.config.clock);
    }
    let diagnostics = (args.diagnostics.is_some() || args.report.is_some())
        .then(|| diagnostics_stage(args.diagnostics.as_deref(), &est, &mut s))
        .transpose()?;
    let verdict = calib::report::lab::RunVerdict::of(
        &est,
        hand_turned.as_ref().map(|(r, _)| r),
        diagnostics.as_ref(),
        turntable.is_some(),
    );
    s += &verdict_report(&verdict);
    let bad = verdict.decisive.clone();
    let free_motion_json = match &hand_turned {
        Some((r, Some(setup))) => Some(crate::free_motion::json(r, setup, args.holdout)),
        _ => None,
    };
    if let Some(path) = &args.json {
        write_result_json(
            path,
            &provenance,
            &assumptions,
            &est,
            diagnostics.as_ref(),
            turntable.is_some(),
            &verdict,
            free_motion_json.as_ref(),
        )?;
        if !crate::output::is_stdout(path) {
            let _ = writeln!(s, "\nwrote {}", path.display());
        }
    }
    if let (Some(path), Some((r, _))) = (&args.plot, &hand_turned) {
        crate::output::write_with(path, |tmp| {
            crate::plot::static_residuals_png(tmp, &input.imu_file, &r.evaluation.poses)
        })?;
        let _ = writeln!(s, "wrote {}", path.display());
    }
    if let (Some(dir), Some(d)) = (&args.report, &diagnostics) {
        let truth = input.truth.as_ref().zip(args.truth.as_deref());
        let truth = truth.map(|(t, p)| (t, truth_report(&est, t, p, &input.config.clock)));
        let id = crate::lab_report::identify(
            &report_inputs(args),
            match (args.config.as_deref(), args.free_motion) {
                (None, false) => Some("paper"),
                (c, _) => c,
            },
            &input.config,
        )?
        .with_provenance(&provenance, &assumptions);
        let plots = crate::lab_report::write_calibration(dir, id, &est, d, &bad, truth)?;
        let _ = writeln!(s, "wrote the report {} ({plots} plots)", dir.display());
    }
    crate::report(&s, args.json.as_deref())?;
    if bad.is_empty() {
        return Ok(Outcome::Fits);
    }
    let advice = match (&hand_turned, &input.program) {
        (Some((r, _)), _)
            if matches!(
                r.noise,
                calib::estimate::hand_turned::NoiseSource::Measured { .. }
            ) =>
        {
            "the held-out rests contradict the calibration\n  {}\nThe estimates above are not \
             to be trusted: an error the model lacks outweighs the noise (`sins-calib diagnose \
             --free-motion` names the candidates; --terms adds one)."
        }
        (Some(_), _) => {
            "the innovations scatter unlike the configured noise\n  {}\nThe estimates above \
             are not to be trusted: check the noise levels in [noise], the motion noise \
             (filter.motion_attitude_noise_deg), and errors the model lacks."
        }
        _ => {
            "the innovations scatter unlike the configured noise\n  {}\nThe estimates above \
             are not to be trusted: check the noise levels in [noise], the program, the clock \
             relation, and errors the model lacks."
        }
    };
    eprintln!(
        "\nTHE MODEL DOES NOT FIT THESE DATA (exit status 3): {}",
        advice.replace("{}", &bad.join("\n  "))
    );
    Ok(Outcome::DoesNotFit)
}

/// The verdict's block of the report: what it rests on, and what informs without deciding.
fn verdict_report(v: &calib::report::lab::RunVerdict) -> String {
    let mut s = format!("\nVerdict\n  rests on        {}\n", v.basis);
    for line in &v.informative {
        let _ = writeln!(s, "  finding         {line}");
    }
    let _ = writeln!(
        s,
        "  {}",
        if !v.fits() {
            "the data contradict the model (exit status 3)"
        } else if v.tested {
            "nothing contradicts the model"
        } else {
            "the model was not tested"
        }
    );
    s
}

/// Refuse a truth file whose units are not the model's.
fn check_truth_units(args: &Args, input: &Inputs, layout: &StateLayout) -> Result<(), Error> {
    if let (Some(truth), Some(path)) = (&input.truth, &args.truth) {
        truth.check_units(
            &path.display().to_string(),
            layout
                .entries()
                .iter()
                .map(|e| (e.name.as_str(), e.unit.si_name())),
        )?;
    }
    Ok(())
}

/// The result JSON (docs/formats.md), written atomically (or to standard output for `-`).
#[allow(clippy::too_many_arguments)]
fn write_result_json(
    path: &Path,
    provenance: &crate::provenance::RunProvenance,
    assumptions: &[String],
    est: &Estimate,
    diagnostics: Option<&Diagnostics>,
    with_tt: bool,
    verdict: &calib::report::lab::RunVerdict,
    free_motion: Option<&crate::free_motion::FreeMotionJson>,
) -> Result<(), Error> {
    let bad = &verdict.decisive;
    let result = est.to_result_file();
    let json = ResultJson {
        unit: &provenance.unit,
        inputs: (!provenance.inputs.is_empty()).then_some(provenance.inputs.as_slice()),
        assumptions,
        parameters: &result.parameters,
        correlation: result.correlation.as_ref(),
        correction: result.correction.as_ref(),
        temperature: result.temperature.as_ref(),
        verdict: VerdictJson {
            fits: bad.is_empty(),
            exit_status: if bad.is_empty() {
                0
            } else {
                crate::MODEL_DOES_NOT_FIT
            },
            reasons: bad.to_vec(),
            basis: verdict.basis.clone(),
            tested: verdict.tested,
            findings: verdict.informative.clone(),
        },
        fit: fit_json(est, with_tt),
        diagnostics,
        free_motion,
    };
    let text = calib::io::schema::to_json(calib::io::schema::CALIBRATION, &json)?;
    crate::output::write_file(path, text.as_bytes())
}

/// The report's lines on the unit, the inputs' SHA-256 (with --free-motion) and the
/// assumptions.
fn provenance_report(p: &crate::provenance::RunProvenance, assumptions: &[String]) -> String {
    let mut s = String::new();
    if p.unit.is_empty() {
        let _ = writeln!(
            s,
            "  unit            unknown (no [unit] in the configuration or import profile; \
             --unit-model, --unit-serial)"
        );
    } else {
        let _ = writeln!(
            s,
            "  unit            {} (from {})",
            p.unit.describe(),
            p.unit_sources.join(", ")
        );
    }
    for f in &p.inputs {
        let _ = writeln!(
            s,
            "  input           {}: {} ({} bytes, SHA-256 {})",
            f.role, f.path, f.bytes, f.sha256
        );
    }
    for note in &p.notes {
        let _ = writeln!(s, "  note            {note}");
    }
    for a in assumptions {
        let _ = writeln!(s, "  ASSUMED         {a}");
    }
    s
}

/// What `calibrate` reads before the filter runs.
struct Inputs {
    config: calib::config::RunConfig,
    origin: String,
    /// The program's name and duration (s); `None` for a recording of rests without one.
    program: Option<(String, f64)>,
    truth: Option<ResultFile>,
    imu: FileImu,
    imu_file: String,
    /// The angle records, streamed at every pass (kept in memory when short).
    tt: Option<AngleFile>,
}

/// Read the configuration, the truth, and open the data files (refusing bad ones before any
/// work is done).
fn load_inputs(args: &Args) -> Result<Inputs, Error> {
    let (mut config, origin) = match (args.config.as_deref(), args.free_motion) {
        (Some(name), _) => load_config(name)?,
        // Made from the recording once its rests are found (`crate::free_motion::setup`).
        (None, true) => {
            let mut c = calib::config::RunConfig::paper();
            c.program = calib::config::PROGRAM_FROM_ANGLES.to_string();
            (c, "no configuration".to_string())
        }
        (None, false) => {
            return Err(
                "calibrate: --config is required (or --free-motion for a hand-turned \
                        recording without a rotation program)"
                    .into(),
            );
        }
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
    // Read the truth first: a wrong path should not cost a whole run.
    let truth = args.truth.as_deref().map(read_result_json).transpose()?;
    // The IMU file is streamed (read once per pass, kept in memory only when short).
    let imu = FileImu::open(&args.imu)?;
    let imu_file = imu.file().to_string();
    let tt = args.turntable.as_deref().map(AngleFile::open).transpose()?;
    // Without a program in the configuration the turntable's angles give it (the estimation
    // reads it again, taking its first piece back to the first IMU record).
    let program = match calib::motion::angles_program::resolve_program(
        &config,
        tt.as_ref().map(AngleFile::records),
        None,
    )? {
        Some(c) => Some(c.program()?),
        // Neither a program nor angles: a recording of rests.
        None if tt.is_none() && config.program_from_angles() => None,
        None => Some(config.program()?),
    };
    let program = program.map(|p| (p.name.clone(), p.duration()));
    Ok(Inputs {
        config,
        origin,
        program,
        truth,
        imu,
        imu_file,
        tt,
    })
}

/// The head of the report: configuration, data, model, program start.
/// The header's line of the records' temperatures and the thermal terms' reference (empty
/// without a temperature).
fn temperature_line(est: &Estimate) -> String {
    let Some(t) = &est.temperature else {
        return String::new();
    };
    let span = match (t.min_c, t.max_c) {
        (Some(a), Some(b)) => format!("{a:.2} .. {b:.2} deg C"),
        _ => "unknown".into(),
    };
    format!(
        "  temperature     {span}; thermal terms about {:.2} deg C ({})\n",
        t.reference_c, t.reference_reason
    )
}

fn header_report(input: &Inputs, est: &Estimate) -> String {
    let config = &input.config;
    let mut s = String::new();
    let _ = writeln!(s, "sins-calib calibrate");
    match &input.program {
        Some((name, duration)) => {
            let _ = writeln!(
                s,
                "  configuration   {}: program \"{}\" ({} s)",
                input.origin,
                name,
                table::compact(*duration)
            );
        }
        None if input.origin == "no configuration" => {
            let _ = writeln!(
                s,
                "  configuration   none: a hand-turned recording without a program (--free-motion)"
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  configuration   {}: no program (a recording of rests)",
                input.origin
            );
        }
    }
    let (t0, t1) = est.imu_span;
    let _ = writeln!(
        s,
        "  IMU data        {}: {} records of {}, t = {} .. {} s",
        input.imu_file,
        est.stats.imu_steps,
        match est.imu_kind {
            ImuKind::Increments => "increments",
            ImuKind::Rates => "rates",
        },
        table::compact(t0),
        table::compact(t1),
    );
    s += &temperature_line(est);
    if let Some(tt) = &input.tt {
        let (records, f) = (tt.records(), tt.records().file());
        let summary = records.summary();
        let (a, b) = summary.span;
        let _ = writeln!(
            s,
            "  turntable data  {f}: {} records, t = {} .. {} s on its clock ({} .. {} s on the \
             IMU clock)",
            summary.count,
            table::compact(a),
            table::compact(b),
            table::compact(config.clock.imu_time(a)),
            table::compact(config.clock.imu_time(b)),
        );
    }
    let _ = writeln!(
        s,
        "  model           {} states ({} parameters and the attitude error)",
        est.names.len(),
        est.names.len() - 3
    );
    match &est.start_alignment {
        None => {
            let _ = writeln!(
                s,
                "  program start   t = {} s on the IMU clock ({})",
                table::compact(est.program_start_s),
                if est.program_start_found {
                    "found from the data"
                } else {
                    "given, checked against the data"
                }
            );
        }
        Some(al) => {
            let at_rest: f64 = est.rests.iter().map(|r| r.t1 - r.t0).sum();
            let _ = writeln!(
                s,
                "  rests           {} found in the data, {} s in all; the specific force is \
                 measured in them only ({} windows with motion left out)",
                est.rests.len(),
                table::compact(at_rest),
                est.stats.accel_windows_in_motion
            );
            let _ = writeln!(
                s,
                "  start attitude  levelled in the first rest; heading {}",
                if al.gyrocompassed {
                    format!(
                        "from the Earth rate (gyrocompassing, sigma {} deg from the gyro priors)",
                        table::compact(al.gyrocompass_sigma_rad.to_degrees())
                    )
                } else {
                    format!(
                        "free (the gyro priors allow {} deg of gyrocompassing error): not \
                         observed",
                        table::compact(al.gyrocompass_sigma_rad.to_degrees())
                    )
                }
            );
        }
    }
    s.push('\n');
    s
}

/// Make the diagnostics directory (one level) if it is not there; refuse a file.
fn prepare_diagnostics_dir(dir: &Path) -> Result<(), Error> {
    if dir.is_dir() {
        return Ok(());
    }
    if dir.exists() {
        return Err(format!(
            "{}: --diagnostics needs a directory, this is a file",
            dir.display()
        )
        .into());
    }
    std::fs::create_dir(dir).map_err(|e| {
        format!(
            "{}: cannot create the diagnostics directory: {e}",
            dir.display()
        )
        .into()
    })
}

/// The diagnostics of the fit: their summary appended to the report, the plots written to
/// `dir` when given.
fn diagnostics_stage(
    dir: Option<&Path>,
    est: &Estimate,
    s: &mut String,
) -> Result<Diagnostics, Error> {
    let d = diagnostics::diagnose(
        &est.innovations,
        &est.segments,
        &DiagnosticSettings::default(),
    );
    let _ = writeln!(s, "\nDiagnostics (docs/estimation.md, \"Diagnostics\")");
    s.push_str(&d.summary());
    if let Some(dir) = dir {
        let files = write_diagnostic_plots(dir, &d, &est.innovations, None)?;
        let _ = writeln!(s, "  plots: {} files in {}", files.len(), dir.display());
    }
    Ok(d)
}

/// The data files `calibrate` read, with their roles, for a report's identification.
fn report_inputs(args: &Args) -> Vec<(&'static str, &Path)> {
    let mut v: Vec<(&'static str, &Path)> = vec![("IMU records", args.imu.as_path())];
    v.extend(args.turntable.as_deref().map(|p| ("turntable angles", p)));
    v.extend(args.truth.as_deref().map(|p| ("truth", p)));
    v.extend(args.sections.as_deref().map(|p| ("section list", p)));
    v.extend(
        args.terms_from
            .as_deref()
            .map(|p| ("diagnose result (--terms-from)", p)),
    );
    v
}

/// The estimates by group in the paper's units; with a truth also the true value and the error
/// in sigmas.
fn parameter_report(est: &Estimate, truth: Option<&ResultFile>) -> String {
    let mut columns = vec![
        ("parameter", Align::Left),
        ("value", Align::Right),
        ("sigma", Align::Right),
        ("unit", Align::Left),
    ];
    if truth.is_some() {
        columns.extend([("truth", Align::Right), ("error/sigma", Align::Right)]);
    }
    let mut t = Table::new(&columns);
    for (title, members) in table::grouped(&est.names) {
        t.section(title);
        for i in members {
            let unit = est.units[i];
            let f = unit.report_factor();
            let sigma = est.cov[(i, i)].max(0.0).sqrt();
            let (v, sg) = (est.values[i] * f, sigma * f);
            let mut cells = vec![
                format!("  {}", est.names[i]),
                table::with_precision_of(v, sg),
                table::sigma(sg),
                unit.report_name().to_string(),
            ];
            if let Some(truth) = truth {
                match truth.get(&est.names[i]) {
                    Some(p) => {
                        cells.push(table::with_precision_of(p.value * f, sg));
                        cells.push(format!("{:+.2}", (est.values[i] - p.value) / sigma));
                    }
                    None => cells.extend(["-".to_string(), "-".to_string()]),
                }
            }
            t.row(cells);
        }
    }
    t.render()
}

/// One line on a mean NIS: is it consistent with what it averages when the model fits
/// (`expected`: 3, or a little less for the turntable angles, `FitStatistics::turntable_expected_nis`)?
fn nis_verdict(mean: f64, expected: f64, n: usize) -> String {
    if n == 0 {
        return "no updates".into();
    }
    let band = nis_band(n);
    let head = format!("mean NIS {mean:.3} over {n} updates");
    let centre = if expected == 3.0 {
        "3".to_string()
    } else {
        format!("{expected:.3}")
    };
    let band_text = format!("{centre} +- {}", table::significant(band, 2));
    if (mean - expected).abs() <= band {
        format!("{head}: consistent with {centre} (expected {band_text})")
    } else if mean > expected {
        format!(
            "{head}: larger than expected ({band_text}); the data scatter more than the \
             configured noise and priors allow (noise levels too low, or errors the model lacks)"
        )
    } else {
        format!(
            "{head}: smaller than expected ({band_text}); the configured noise levels are larger \
             than the data's"
        )
    }
}

fn fit_report(stats: &FitStatistics, with_turntable: bool) -> String {
    let mut s = String::from("Fit\n");
    let _ = writeln!(
        s,
        "  specific force    {}",
        nis_verdict(stats.accel_mean_nis, 3.0, stats.accel_updates)
    );
    if with_turntable {
        let _ = writeln!(
            s,
            "  turntable angles  {}",
            nis_verdict(
                stats.turntable_mean_nis,
                stats.turntable_expected_nis,
                stats.turntable_updates
            )
        );
    }
    if stats.turn_updates > 0 {
        let half = 3.0 * (2.0 / stats.turn_updates as f64).sqrt();
        let _ = writeln!(
            s,
            "  known turns       mean NIS {:.3} over {} turns (expected 1 +- {})",
            stats.turn_mean_nis,
            stats.turn_updates,
            table::significant(half, 2)
        );
    }
    let _ = writeln!(s, "  IMU records       {} integrated", stats.imu_steps);
    if with_turntable {
        let _ = writeln!(
            s,
            "  turntable samples {} used, {} left out near rate changes, {} without turntable \
             data; records at {} Hz on the IMU clock",
            stats.turntable_samples,
            stats.turntable_samples_near_rate_changes,
            stats.turntable_samples_missing,
            table::compact(stats.turntable_record_rate_hz)
        );
    }
    s
}

/// Which parameters the run leaves at their prior, and the second-order error carried.
fn observability_report(est: &Estimate) -> String {
    let mut s = String::new();
    let unobserved = est.unobserved();
    if unobserved.is_empty() {
        let _ = writeln!(
            s,
            "  observability     every parameter is observed by this run"
        );
    } else {
        let _ = writeln!(
            s,
            "  not observed      {} of {} parameters keep more than {:.0} % of their prior sigma (estimate = prior, sigma honest): {}",
            unobserved.len(),
            est.names.len() - 3,
            100.0 * calib::estimate::UNOBSERVED_SIGMA_RATIO,
            unobserved
                .iter()
                .map(|(n, r)| format!("{n} ({:.0} %)", 100.0 * r))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if est.stats.consider_directions > 0 {
        let _ = writeln!(
            s,
            "  second order      beta x (C df) is {} m/s^2 (1 sigma) on this run: carried into the covariance ({} directions)",
            table::significant(est.stats.second_order_accel_sigma, 2),
            est.stats.consider_directions
        );
    }
    s
}

/// NEES over the parameters that the truth knows, with the full covariance.
fn truth_report(
    est: &Estimate,
    truth: &ResultFile,
    path: &Path,
    clock: &calib::config::ClockConfig,
) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "Against the truth in {}", path.display());
    let Some(c) = calib::report::lab::truth_comparison(est, truth) else {
        let _ = writeln!(s, "  no estimated parameter is named in the truth file");
        return s;
    };
    let (n, diagonal) = (c.parameters, c.sum_squared_sigmas);
    let expected = format!(
        "a consistent filter gives {n} on average, standard deviation {}",
        table::significant((2.0 * n as f64).sqrt(), 2)
    );
    match c.nees {
        Some(nees) => {
            let _ = writeln!(
                s,
                "  NEES {nees:.1} over {n} parameters ({expected}); sum of squared errors in \
                 sigmas {diagonal:.1}"
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  NEES: the covariance is not positive definite; sum of squared errors in sigmas \
                 {diagonal:.1} over {n} parameters ({expected})"
            );
        }
    }
    let _ = writeln!(
        s,
        "  largest error {:+.2} sigma ({})",
        c.largest.1, c.largest.0
    );
    for (name, configured, what) in [
        (
            sins_model::names::CLOCK_OFFSET,
            clock.turntable_offset_s,
            "clock.turntable_offset_s",
        ),
        (
            sins_model::names::CLOCK_RATE_ERROR,
            clock.turntable_rate_error,
            "clock.turntable_rate_error",
        ),
    ] {
        if let Some(p) = truth.get(name)
            && (p.value - configured).abs() > 1e-12 * (1.0 + configured.abs())
        {
            let _ = writeln!(
                s,
                "  note: the truth's {name} = {} differs from the configuration's {what} = \
                 {configured}: the estimated delay absorbs the difference",
                p.value
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts() {
        assert!(nis_verdict(3.05, 3.0, 2727).contains("consistent"));
        assert!(nis_verdict(3.5, 3.0, 2727).contains("larger"));
        assert!(nis_verdict(2.5, 3.0, 2727).contains("smaller"));
        assert!(nis_verdict(3.5, 3.0, 30).contains("consistent"));
        // About the expected mean: 2.944 over a 10-h run's updates is 1.4 bands below 3 but
        // inside the band about 2.97.
        assert!(nis_verdict(2.944, 3.0, 35559).contains("smaller"));
        let v = nis_verdict(2.944, 2.97, 35559);
        assert!(v.contains("consistent with 2.970"), "{v}");
    }
}
