//! `sins-calib apply`: raw IMU records corrected with a calibration result (the estimated model
//! inverted record by record, `calib::model::correction`), written in the form they came in.

use crate::{Error, print};
use calib::config::UnitIdentity;
use calib::io::{ImuKind, ImuReader, ImuRecord, format_f64, read_result_json};
use calib::model::correction::{Correction, CorrectionWindow, ExtensionInputs};
use sins_model::candidates::Candidate;
use std::path::{Path, PathBuf};

/// Arguments of `apply`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Calibration result (JSON of `calibrate --json`, with or without --free-motion; a truth
    /// file of `simulate` also serves): its parameters say which terms to invert.
    #[arg(long, value_name = "FILE")]
    pub calibration: PathBuf,
    /// Raw IMU records (imu.csv, rates or increments, optional temp column).
    #[arg(long, value_name = "FILE")]
    pub imu: PathBuf,
    /// Corrected records: the same form, time stamps and temp column (written to a temporary
    /// file beside it, then renamed; neither the --imu nor the --calibration file).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Apply a calibration whose result says the data contradicted its model (`"fits": false`,
    /// exit status 3 of `calibrate`): refused without this.
    #[arg(long)]
    pub accept_misfit: bool,
    /// The unit the --imu records are of (also read from the `[unit]` of the import profile,
    /// through the import.json beside them): a calibration of another unit (its `unit`) is
    /// refused.
    #[command(flatten, next_help_heading = crate::args::heading::UNIT)]
    pub unit: crate::provenance::UnitArgs,
    /// Apply a calibration whose unit (model or serial) differs from the data's: refused
    /// without this.
    #[arg(long)]
    pub accept_other_unit: bool,
}

/// Refuse a calibration of another unit than the data's (unless `--accept-other-unit`);
/// returns the note for stderr (printed once the records are written) when either side's
/// identity is unknown or a different unit was accepted.
fn check_unit(
    args: &Args,
    cal_file: &str,
    cal_unit: Option<&UnitIdentity>,
) -> Result<Option<String>, Error> {
    let data = crate::provenance::gather(&args.imu, None, &args.unit, false)?;
    let imu_file = args.imu.display();
    let cal_unit = cal_unit.filter(|u| !u.is_empty());
    let Some(cal_unit) = cal_unit else {
        return Ok(Some(format!(
            "apply: {cal_file} does not say which unit it is of: the unit is not checked{}",
            if data.unit.is_empty() {
                String::new()
            } else {
                format!(" (the data's: {})", data.unit.describe())
            }
        )));
    };
    if data.unit.is_empty() {
        return Ok(Some(format!(
            "apply: the unit of {imu_file} is not known (--unit-serial, --unit-model, or the \
             [unit] of its import profile): the calibration's unit ({}) is not checked",
            cal_unit.describe()
        )));
    }
    let conflicts = cal_unit.conflicts(&data.unit);
    if conflicts.is_empty() {
        return Ok(None);
    }
    let what = conflicts
        .iter()
        .map(|(f, c, d)| format!("{f} \"{c}\" against \"{d}\""))
        .collect::<Vec<_>>()
        .join(", ");
    if args.accept_other_unit {
        return Ok(Some(format!(
            "apply: {cal_file} is of another unit than {imu_file} ({what}); applied as \
             --accept-other-unit asks"
        )));
    }
    Err(format!(
        "{cal_file}: this calibration is of another unit than {imu_file} ({what}; the data's \
         unit from {}): its correction belongs to that unit. Give the calibration of this unit, \
         or --accept-other-unit to apply it anyway",
        data.unit_sources.join(", ")
    )
    .into())
}

/// The same file, whether or not `b` exists yet.
fn same_file(a: &Path, b: &Path) -> bool {
    let canon = |p: &Path| -> Option<PathBuf> {
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let dir = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    };
    matches!((canon(a), canon(b)), (Some(x), Some(y)) if x == y)
}

/// The terms a correction inverts, for the report.
fn terms(c: &Correction) -> String {
    let mut t = vec!["the paper's model (nu0, Theta, df0, Gamma)"];
    for (on, name) in [
        (c.has(Candidate::GyroGSensitivity), "g-sensitivity"),
        (c.has(Candidate::GyroScaleAsymmetry), "scale asymmetry"),
        (
            c.has(Candidate::AccelQuadratic),
            "accelerometer quadratic term",
        ),
        (c.has(Candidate::AccelSizeEffect), "size effect"),
        (
            c.has(Candidate::GyroAccelTimeOffset),
            "gyro-accelerometer time offset",
        ),
        (
            c.thermal.is_some(),
            "temperature coefficients (at each record's temperature)",
        ),
    ] {
        if on {
            t.push(name);
        }
    }
    t.join(", ")
}

/// Write one record as a CSV line.
fn line(r: &ImuRecord, out: &mut String) {
    out.clear();
    out.push_str(&format_f64(r.t));
    for v in r.gyro.iter().chain(&r.accel) {
        out.push(',');
        out.push_str(&format_f64(*v));
    }
    if let Some(temp) = r.temp {
        out.push(',');
        out.push_str(&format_f64(temp));
    }
    out.push('\n');
}

/// Correct every record of `reader` into `sink`; returns the number of records.
fn correct_stream(
    reader: &mut ImuReader,
    correction: &Correction,
    sink: &mut dyn std::io::Write,
    sink_name: &str,
) -> Result<usize, Error> {
    let kind = reader.kind();
    let file = reader.file().to_string();
    let mut header = String::from("t,");
    header += &kind.columns().join(",");
    if reader.has_temp() {
        header += ",temp";
    }
    header.push('\n');
    let write_err =
        |e: std::io::Error| -> Error { format!("{sink_name}: cannot write: {e}").into() };
    sink.write_all(header.as_bytes()).map_err(write_err)?;
    // A window of up to four records (two before the one corrected, one after) with their
    // lines: the intervals and the neighbours' rates the correction of a record needs.
    let mut window = CorrectionWindow::new();
    let mut text = String::new();
    let mut count = 0;
    let mut flush = |window: &CorrectionWindow<usize>, at: usize, count: &mut usize| {
        let Some(r) = window.correct(correction, kind) else {
            return Ok(());
        };
        let r = r.map_err(|e| -> Error { format!("{file}: line {at}: {e}").into() })?;
        line(&r, &mut text);
        sink.write_all(text.as_bytes()).map_err(write_err)?;
        *count += 1;
        Ok::<(), Error>(())
    };
    // The first records, checked for their units before any is corrected.
    let mut prefix = Vec::new();
    while prefix.len() < UNIT_CHECK_RECORDS
        && let Some(r) = reader.next_record()?
    {
        prefix.push((r, reader.line()));
    }
    check_units(&prefix, kind, &file)?;
    let times: Vec<f64> = prefix.iter().map(|(r, _)| r.t).collect();
    let median = calib::io::timing::median_interval(&times);
    let mut prefix = prefix.into_iter();
    let mut previous: Option<(f64, usize)> = None;
    loop {
        let next = match prefix.next() {
            Some(x) => Some(x),
            None => reader.next_record()?.map(|r| (r, reader.line())),
        };
        let Some((r, at)) = next else { break };
        if let Some((t_before, line_before)) = previous {
            check_interval(t_before, line_before, r.t, at, median, &file)?;
        }
        previous = Some((r.t, at));
        // The record before the newest now has its successor.
        if let Some(ready) = window.push(r, at) {
            flush(&window, ready, &mut count)?;
        }
    }
    if kind == ImuKind::Increments && window.len() < 2 {
        return Err(format!(
            "{file}: one record only: expected at least two in an increments file (the first \
             record's interval is the one to the second)"
        )
        .into());
    }
    if let Some(last) = window.close() {
        flush(&window, last, &mut count)?;
    }
    Ok(count)
}

/// An interval longer than this many median intervals is a gap (the default of the import's
/// `checks.gap_factor`).
const GAP_FACTOR: f64 = 1.5;

/// Refuse a gap (an interval longer than [`GAP_FACTOR`] median intervals) between the records
/// of lines `line_before` and `line`: the record after it would be corrected over the gap's
/// length (an increment's bias and scale over 10 s instead of 0.01 s), and the derivatives of
/// the size effect and time offset taken across it, with no word. Gaps are never bridged.
fn check_interval(
    t_before: f64,
    line_before: usize,
    t: f64,
    line: usize,
    median: f64,
    file: &str,
) -> Result<(), Error> {
    let d = t - t_before;
    if median.is_finite() && median > 0.0 && d > GAP_FACTOR * median {
        return Err(format!(
            "{file}: line {line}: a gap of {} s ({:.1} median intervals of {} s) between t = {} s \
             (line {line_before}) and t = {} s: expected intervals of at most {GAP_FACTOR} median \
             intervals (the record after a gap would be corrected over the gap's length); gaps \
             are never bridged: split the recording at the gap and correct each part",
            crate::render::table::compact(d),
            d / median,
            crate::render::table::compact(median),
            crate::render::table::compact(t_before),
            crate::render::table::compact(t),
        )
        .into());
    }
    Ok(())
}

/// Refuse a calibration whose compensation matrices `I - Theta` (gyros) and `I + Gamma`
/// (accelerometers) are singular or ill-conditioned (a condition number above
/// [`calib::config::plausible::MAX_COMPENSATION_CONDITION`]): inverting them would amplify the
/// records' noise into nonsense. (Each entry is already within its physical bound, which
/// keeps them well-conditioned; this is the check of what the correction inverts.)
pub(crate) fn check_compensation(result: &calib::io::ResultFile, file: &str) -> Result<(), Error> {
    use calib::config::plausible::{MAX_COMPENSATION_CONDITION, condition_number};
    const AXES: [char; 3] = ['x', 'y', 'z'];
    for (prefix, sign, what) in [
        ("gyro.theta", -1.0, "gyro compensation I - Theta"),
        ("accel.gamma", 1.0, "accelerometer compensation I + Gamma"),
    ] {
        let m = nalgebra::Matrix3::from_fn(|i, j| {
            let name = format!("{prefix}.{}{}", AXES[i], AXES[j]);
            let v = result.get(&name).map_or(0.0, |p| p.value);
            f64::from(u8::from(i == j)) + sign * v
        });
        let c = condition_number(&m);
        if c.is_nan() || c > MAX_COMPENSATION_CONDITION {
            return Err(format!(
                "{file}: the {what} has condition number {c:.3e} (its {prefix}.* parameters): \
                 expected at most {MAX_COMPENSATION_CONDITION} (a singular or ill-conditioned \
                 compensation is no instrument's)"
            )
            .into());
        }
    }
    Ok(())
}

/// Records of the file's beginning the unit checks read.
const UNIT_CHECK_RECORDS: usize = 100_000;

/// The units `segment` checks, on the file's first [`UNIT_CHECK_RECORDS`] records (the
/// correction itself streams, and reads them from this prefix, so that a pipe is read once):
/// time stamps in seconds, gyro and accelerometer columns in their places, a median specific
/// force of g (not g units). A correction of misread records would be written without a word.
fn check_units(prefix: &[(ImuRecord, usize)], kind: ImuKind, file: &str) -> Result<(), Error> {
    if prefix.len() < 2 {
        // `correct_stream` names what is missing.
        return Ok(());
    }
    let data = calib::io::ImuData {
        kind,
        records: prefix.iter().map(|(r, _)| *r).collect(),
    };
    crate::recording_checks::check_plausible(&data, file, 0.0)?;
    crate::recording_checks::check_median_gravity(&data, file)
}

/// Run `apply`.
pub fn run(args: &Args) -> Result<(), Error> {
    check_paths(args)?;
    let cal_file = args.calibration.display().to_string();
    let (correction, inputs, unit_note) = load_correction(args, &cal_file)?;
    let mut reader = ImuReader::open(&args.imu)?;
    let kind = reader.kind();
    if correction.thermal.is_some() && !reader.has_temp() {
        return Err(format!(
            "{}: no `temp` column: the calibration {cal_file} has temperature coefficients, so \
             each record is corrected at its own temperature (deg C)",
            args.imu.display()
        )
        .into());
    }
    let n = write_corrected(&mut reader, &correction, &args.out)?;
    if let Some(note) = unit_note {
        eprintln!("{note}");
    }
    let form = match kind {
        ImuKind::Rates => "rates",
        ImuKind::Increments => "increments",
    };
    print(&format!(
        "sins-calib apply\n  calibration  {cal_file}: {}{}\n  wrote        {}: {n} records ({form}), corrected\n",
        terms(&correction),
        match inputs {
            ExtensionInputs::True => "",
            ExtensionInputs::Measured =>
                " (g-sensitivity and asymmetry on the measured values, as fitted)",
        },
        args.out.display()
    ))
}

/// Refuse an output that is an input, before any work.
fn check_paths(args: &Args) -> Result<(), Error> {
    if same_file(&args.imu, &args.out) {
        return Err(format!(
            "{}: --out is the --imu file: expected another file for the corrected records (the \
             raw ones are kept)",
            args.out.display()
        )
        .into());
    }
    if same_file(&args.calibration, &args.out) {
        return Err(format!(
            "{}: --out is the --calibration file: expected another file for the corrected records",
            args.out.display()
        )
        .into());
    }
    crate::output::Outputs::new(&[&args.imu, &args.calibration]).file(&args.out, "--out")
}

/// The calibration's correction, refused when its data contradicted its model (unless
/// `--accept-misfit`), when it is ill-conditioned or of another unit; with the note on the
/// unit for standard error.
fn load_correction(
    args: &Args,
    cal_file: &str,
) -> Result<(Correction, ExtensionInputs, Option<String>), Error> {
    let result = read_result_json(&args.calibration)?;
    if let Some(v) = result.verdict.as_ref().filter(|v| !v.fits) {
        if !args.accept_misfit {
            return Err(format!(
                "{cal_file}: this calibration's data contradicted its model (\"fits\": false, \
                 exit status 3 of calibrate){}: its correction is not to be trusted. Calibrate \
                 again with the terms `diagnose` names, or give --accept-misfit to apply it anyway",
                if v.reasons.is_empty() {
                    String::new()
                } else {
                    format!(": {}", v.reasons.join("; "))
                }
            )
            .into());
        }
        eprintln!(
            "apply: {cal_file}: the data contradicted this calibration's model; applied as \
             --accept-misfit asks"
        );
    }
    check_compensation(&result, cal_file)?;
    let unit_note = check_unit(args, cal_file, result.unit.as_ref())?;
    let inputs = result
        .correction
        .as_ref()
        .map_or(ExtensionInputs::True, |b| b.extension_inputs);
    let reference = result.temperature.as_ref().map(|t| t.reference_c);
    let correction = Correction::from_parameters_at(&result.parameters, inputs, reference)
        .map_err(|e| {
            format!("{cal_file}: {e} (a result file of `calibrate --json` is expected)")
        })?;
    Ok((correction, inputs, unit_note))
}

/// Correct every record of `reader` into `out`: written to a temporary file beside it, then
/// renamed; returns the number of records.
fn write_corrected(
    reader: &mut ImuReader,
    correction: &Correction,
    out: &Path,
) -> Result<usize, Error> {
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = out
        .file_name()
        .ok_or_else(|| format!("{}: expected a file name", out.display()))?;
    let tmp = crate::output::fresh_temporary(&dir.join(name))?;
    // Removed on a failure (the guard's drop) and on an interruption (the signal thread): the
    // corrected records of a long recording are hundreds of megabytes.
    let guard = crate::signals::Pending::new(&tmp);
    let written = (|| -> Result<usize, Error> {
        let f = std::fs::File::options()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| format!("{}: cannot write: {e}", tmp.display()))?;
        let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
        let n = correct_stream(reader, correction, &mut w, &tmp.display().to_string())?;
        let f = w
            .into_inner()
            .map_err(|e| format!("{}: cannot write: {}", tmp.display(), e.error()))?;
        f.sync_all()
            .map_err(|e| format!("{}: cannot write: {e}", tmp.display()))?;
        std::fs::rename(&tmp, out).map_err(|e| format!("{}: cannot write: {e}", out.display()))?;
        Ok(n)
    })();
    let n = written?;
    guard.keep();
    Ok(n)
}
