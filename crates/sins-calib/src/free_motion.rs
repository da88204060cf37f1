//! `sins-calib calibrate --free-motion`: calibration of a hand-turned multi-position recording
//! (no rotation program, no turntable) by `calib::free_motion`, with the static intervals of the
//! `import` crate's detector.

use crate::calibrate::{Args, Outcome};
use crate::table::{self, Align, Table};
use crate::{Error, load_config};
use ::import::detect::{DetectorSettings, segment};
use ::import::sections::SectionsFile;
use calib::free_motion::{
    FreeMotionResult, FreeMotionSettings, GSENS_UNIT, Interval, calibrate_free_motion,
};
use calib::io::{ResultParameter, read_imu_csv};
use serde::Serialize;
use sins_model::earth::Site;
use sins_model::terms::Unit;
use sins_model::units::DEG_PER_HOUR;
use std::fmt::Write as _;

/// Latitude (deg) of the site when neither --config nor --latitude gives one.
pub const DEFAULT_LATITUDE_DEG: f64 = 45.0;

/// The JSON result: parameters, fit summary and validation.
#[derive(Serialize)]
struct FreeMotionJson<'a> {
    parameters: &'a [ResultParameter],
    correlation: Option<Vec<Vec<f64>>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    correction: Option<calib::correction::CorrectionBlock>,
    fit: FitJson,
    #[serde(skip_serializing_if = "Option::is_none")]
    validation: Option<ValidationJson>,
}

#[derive(Serialize)]
struct FitJson {
    method: &'static str,
    gravity_m_s2: f64,
    static_intervals: usize,
    accel: StageJson,
    gyro: StageJson,
    turns: Vec<TurnJson>,
    unobserved: Vec<UnobservedJson>,
    verdict: VerdictJson,
}

#[derive(Serialize)]
struct StageJson {
    residuals: usize,
    effective_parameters: f64,
    reduced_chi2: f64,
    p_value: f64,
}

/// [`calib::free_motion::FreeMotionVerdict`].
#[derive(Serialize)]
struct VerdictJson {
    fits: bool,
    reasons: Vec<String>,
    marginal: Vec<String>,
}

#[derive(Serialize)]
struct TurnJson {
    name: String,
    expected_deg: f64,
    before_deg: f64,
    after_deg: f64,
}

#[derive(Serialize)]
struct UnobservedJson {
    name: String,
    sigma_over_prior: f64,
}

#[derive(Serialize)]
struct BeforeAfter {
    before: f64,
    after: f64,
}

#[derive(Serialize)]
struct ValidationJson {
    static_rms_m_s2: BeforeAfter,
    rotation_rms_deg: BeforeAfter,
    intervals: usize,
    rotation_pairs: usize,
}

/// Gravity and priors from the configuration, or the defaults.
pub(crate) fn settings_of(
    config: Option<&str>,
    latitude: Option<f64>,
) -> Result<(FreeMotionSettings, String), Error> {
    match config {
        Some(name) => {
            let (config, origin) = load_config(name)?;
            let g = config.site().normal_gravity();
            let mut s = FreeMotionSettings::new(g);
            s.priors = config.priors_si();
            Ok((s, format!("{origin}: [site] and [priors]")))
        }
        None => {
            let lat = latitude.unwrap_or(DEFAULT_LATITUDE_DEG);
            if !(-90.0..=90.0).contains(&lat) {
                return Err(format!("--latitude {lat}: expected -90 .. 90 deg").into());
            }
            let g = Site::from_degrees(lat, 0.0, 0.0).normal_gravity();
            Ok((
                FreeMotionSettings::new(g),
                format!("no configuration: latitude {lat} deg, consumer-grade priors"),
            ))
        }
    }
}

/// The section list at `path`, checked against the records of `data` before any work
/// ([`SectionsFile::check_records`]).
pub(crate) fn read_sections(
    path: &std::path::Path,
    data: &calib::io::ImuData,
) -> Result<SectionsFile, Error> {
    let sections = SectionsFile::read(path)?;
    let times: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    sections
        .check_records(&times)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(sections)
}

/// The static intervals of a recording by the detector with `settings`.
pub(crate) fn static_intervals(
    data: &calib::io::ImuData,
    file: &str,
    settings: &DetectorSettings,
) -> Result<(::import::detect::Segmentation, Vec<Interval>), Error> {
    let seg = segment(data, settings).map_err(|e| format!("{file}: {e}"))?;
    let intervals = seg
        .static_intervals
        .iter()
        .map(|s| Interval {
            first_record: s.first_record,
            last_record: s.last_record,
        })
        .collect();
    Ok((seg, intervals))
}

/// Run `calibrate --free-motion`.
pub fn run(args: &Args) -> Result<Outcome, Error> {
    if args.turntable.is_some() || args.program_start.is_some() || args.truth.is_some() {
        return Err(
            "calibrate --free-motion: --turntable, --program-start and --truth belong to \
                    a turntable calibration"
                .into(),
        );
    }
    let inputs = crate::calibrate::input_paths(args);
    if let Some(path) = &args.json {
        crate::output::check_file(path, "--json", &inputs)?;
    }
    if let Some(path) = &args.plot {
        crate::output::check_png(path, "--plot", &inputs)?;
    }
    let (mut settings, origin) = settings_of(args.config.as_deref(), args.latitude)?;
    settings.holdout = args.holdout;
    let data = read_imu_csv(&args.imu)?;
    let file = args.imu.display().to_string();
    let detector = args
        .detector
        .settings()
        .map_err(|e| format!("calibrate --free-motion: {e}"))?;
    let (seg, intervals) = static_intervals(&data, &file, &detector)?;
    let turns = match &args.sections {
        Some(p) => read_sections(p, &data)?.known_turns(&intervals),
        None => Vec::new(),
    };
    let result = calibrate_free_motion(&data, &intervals, &turns, &settings)
        .map_err(|e| format!("{file}: {e}"))?;

    let mut s = String::new();
    let _ = writeln!(s, "sins-calib calibrate --free-motion");
    let _ = writeln!(s, "  settings        {origin}");
    let _ = writeln!(
        s,
        "  IMU data        {file}: {} records, t = {} .. {} s",
        seg.records,
        table::compact(seg.t_first_s),
        table::compact(seg.t_last_s)
    );
    let _ = writeln!(
        s,
        "  static          {} intervals (default detector){}",
        intervals.len(),
        match args.holdout {
            Some(k) => format!(", every {k}-th held out of the fit"),
            None => String::new(),
        }
    );
    let _ = writeln!(
        s,
        "  gravity         {} m/s^2\n  method          batch Gauss-Newton least squares with \
         priors (accelerometers alone, then gyros and accelerometers together)\n",
        table::significant(settings.gravity_m_s2, 7)
    );
    s += &parameter_report(&result);
    s += &fit_report(&result);
    let verdict = result.verdict();
    s += &verdict_lines(&verdict);
    let validation = result.validation.map(|v| ValidationJson {
        static_rms_m_s2: BeforeAfter {
            before: v.static_rms_before_m_s2,
            after: v.static_rms_after_m_s2,
        },
        rotation_rms_deg: BeforeAfter {
            before: v.rotation_rms_before_rad.to_degrees(),
            after: v.rotation_rms_after_rad.to_degrees(),
        },
        intervals: v.intervals,
        rotation_pairs: v.rotation_pairs,
    });
    if let Some(v) = &validation {
        let _ = writeln!(
            s,
            "\nHeld-out validation ({} intervals, {} pairs of consecutive ones)\n  static |f| - g \
             RMS        before {:.5} m/s^2, after {:.5} m/s^2\n  rotation (gravity direction) \
             RMS  before {:.3} deg, after {:.3} deg",
            v.intervals,
            v.rotation_pairs,
            v.static_rms_m_s2.before,
            v.static_rms_m_s2.after,
            v.rotation_rms_deg.before,
            v.rotation_rms_deg.after
        );
    }
    if let Some(path) = &args.json {
        let file = result.to_result_file();
        let json = FreeMotionJson {
            parameters: &result.parameters,
            correlation: file.correlation,
            correction: file.correction,
            fit: fit_json(&result, &settings, intervals.len(), &verdict),
            validation,
        };
        let text = serde_json::to_string_pretty(&json)? + "\n";
        crate::output::write_file(path, text.as_bytes())?;
        if !crate::output::is_stdout(path) {
            let _ = writeln!(s, "\nwrote {}", path.display());
        }
    }
    if let Some(path) = &args.plot {
        crate::plot::static_residuals_png(path, &file, &result.poses)?;
        let _ = writeln!(s, "wrote {}", path.display());
    }
    crate::report(&s, args.json.as_deref())?;
    Ok(if verdict.fits {
        Outcome::Fits
    } else {
        Outcome::DoesNotFit
    })
}

fn fit_json(
    r: &FreeMotionResult,
    settings: &FreeMotionSettings,
    n: usize,
    v: &calib::free_motion::FreeMotionVerdict,
) -> FitJson {
    let stage = |f: &calib::free_motion::StageFit| StageJson {
        residuals: f.residuals,
        effective_parameters: f.effective_parameters,
        reduced_chi2: f.reduced_chi2,
        p_value: f.p_value(),
    };
    FitJson {
        method: "batch Gauss-Newton least squares with priors",
        gravity_m_s2: settings.gravity_m_s2,
        static_intervals: n,
        accel: stage(&r.accel_fit),
        gyro: stage(&r.gyro_fit),
        turns: r
            .turns
            .iter()
            .map(|t| TurnJson {
                name: t.name.clone(),
                expected_deg: t.expected_rad.to_degrees(),
                before_deg: t.before_rad.to_degrees(),
                after_deg: t.after_rad.to_degrees(),
            })
            .collect(),
        unobserved: r
            .unobserved()
            .into_iter()
            .map(|(name, sigma_over_prior)| UnobservedJson {
                name,
                sigma_over_prior,
            })
            .collect(),
        verdict: VerdictJson {
            fits: v.fits,
            reasons: v.reasons.clone(),
            marginal: v.marginal.clone(),
        },
    }
}

/// Factor from SI and name of the report unit of a result parameter.
fn report_unit(p: &ResultParameter) -> (f64, &'static str) {
    let unit = match p.unit.as_str() {
        GSENS_UNIT => return (1.0 / DEG_PER_HOUR, "deg/h/(m/s^2)"),
        "rad/s" => Unit::RadPerSecond,
        "m/s^2" => Unit::MeterPerSecond2,
        "rad" => Unit::SmallAngle,
        _ => Unit::Ratio,
    };
    (unit.report_factor(), unit.report_name())
}

fn parameter_report(r: &FreeMotionResult) -> String {
    let mut t = Table::new(&[
        ("parameter", Align::Left),
        ("value", Align::Right),
        ("sigma", Align::Right),
        ("prior", Align::Right),
        ("unit", Align::Left),
    ]);
    let names: Vec<String> = r.parameters.iter().map(|p| p.name.clone()).collect();
    for (title, members) in groups(&names) {
        t.section(title);
        for i in members {
            let p = &r.parameters[i];
            let (f, unit) = report_unit(p);
            let sg = p.sigma.unwrap_or(0.0) * f;
            t.row(vec![
                format!("  {}", p.name),
                table::with_precision_of(p.value * f, sg),
                table::sigma(sg),
                table::sigma(r.prior_sigma[i] * f),
                unit.to_string(),
            ]);
        }
    }
    t.render()
}

/// The report's groups of parameters: the table's, with the terms beyond the paper's model
/// (g-sensitivity, scale-factor asymmetry) under titles of their own.
fn groups(names: &[String]) -> Vec<(&'static str, Vec<usize>)> {
    let extra = [
        (
            "gyro.gsens.",
            "Gyro g-sensitivity G (row: gyro, column: specific force)",
        ),
        (
            "gyro.asym.",
            "Gyro scale-factor asymmetry a (positive rates 1 - theta - a, negative 1 - theta + a)",
        ),
    ];
    let mut out: Vec<(&'static str, Vec<usize>)> = Vec::new();
    for (title, members) in table::grouped(names) {
        for i in members {
            let title = extra
                .iter()
                .find(|(prefix, _)| names[i].starts_with(prefix))
                .map_or(title, |(_, t)| t);
            match out.iter_mut().find(|(t, _)| *t == title) {
                Some((_, m)) => m.push(i),
                None => out.push((title, vec![i])),
            }
        }
    }
    out
}

/// The verdict: does not fit (exit status 3) with its reasons, or fits (marginally where a
/// stage's chi-square is at the edge of its band).
fn verdict_lines(v: &calib::free_motion::FreeMotionVerdict) -> String {
    let mut s = String::new();
    if v.fits {
        let _ = writeln!(s, "\nverdict: the model fits these data");
        for m in &v.marginal {
            let _ = writeln!(s, "  marginal: {m}");
        }
    } else {
        let _ = writeln!(
            s,
            "\nverdict: THE MODEL DOES NOT FIT THESE DATA (exit status 3): the results were \
             computed and written, but are not to be trusted"
        );
        for r in &v.reasons {
            let _ = writeln!(s, "  {r}");
        }
    }
    s
}

fn fit_report(r: &FreeMotionResult) -> String {
    let mut s = String::from("\nFit\n");
    for (what, f) in [
        ("accelerometers alone  ", &r.accel_fit),
        ("gyros + accelerometers", &r.gyro_fit),
    ] {
        let _ = writeln!(
            s,
            "  {what}  {} residuals, {:.1} effective parameters, reduced chi-square {:.3}{}",
            f.residuals,
            f.effective_parameters,
            f.reduced_chi2,
            if f.reduced_chi2 > 1.0 {
                " (sigmas scaled up by its root)"
            } else {
                ""
            }
        );
    }
    let fitted: Vec<_> = r.poses.iter().filter(|p| !p.held_out).collect();
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let before: Vec<f64> = fitted.iter().map(|p| p.before_m_s2).collect();
    let after: Vec<f64> = fitted.iter().map(|p| p.after_m_s2).collect();
    let _ = writeln!(
        s,
        "  static |f| - g RMS over the {} fitted intervals: before {:.5} m/s^2, after {:.5} m/s^2",
        fitted.len(),
        rms(&before),
        rms(&after)
    );
    for t in &r.turns {
        let _ = writeln!(
            s,
            "  turn {}: expected {:.1} deg, raw gyro {:.2} deg, calibrated {:.2} deg",
            t.name,
            t.expected_rad.to_degrees(),
            t.before_rad.to_degrees(),
            t.after_rad.to_degrees()
        );
    }
    let un = r.unobserved();
    if un.is_empty() {
        let _ = writeln!(
            s,
            "  every parameter observed (posterior sigma <= 0.9 prior)"
        );
    } else {
        let names: Vec<String> = un.iter().map(|(n, q)| format!("{n} ({q:.2})")).collect();
        let _ = writeln!(
            s,
            "  unobserved (posterior/prior sigma > 0.9, kept at the prior): {}",
            names.join(", ")
        );
    }
    s
}
