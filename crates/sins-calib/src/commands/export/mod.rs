//! `sins-calib export`: the noise levels (`noise --json`) and a calibration (`calibrate --json`)
//! written in the files other tools read: Kalibr's `imu.yaml`, OpenVINS's
//! `kalibr_imu_chain.yaml`, imu_tk's `*_acc.calib` and `*_gyro.calib`. The conventions are in
//! `export_formats` and docs/formats.md, "Files written by `export`".

pub mod formats;

use crate::Error;
use crate::commands::export::formats::{self as fmt, Densities, NoiseFigures};
use calib::io::read_result_json;
use calib::model::correction::{Correction, ExtensionInputs};
use serde_json::Value;
use sins_model::candidates::Candidate;
use sins_model::units::DEG_PER_HOUR;
use std::path::{Path, PathBuf};

/// The tool a file is written for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Target {
    /// Kalibr's `imu.yaml` (noise densities, random walks, rate, topic): needs --noise.
    Kalibr,
    /// OpenVINS's `kalibr_imu_chain.yaml` (noise and intrinsics): needs --noise and
    /// --calibration.
    Openvins,
    /// imu_tk's `<prefix>_acc.calib` and `<prefix>_gyro.calib`: needs --calibration.
    ImuTk,
}

/// Arguments of `export`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The format to write.
    #[arg(long, value_enum)]
    pub to: Target,
    /// Noise levels: the JSON of `sins-calib noise --json`.
    #[arg(long, value_name = "FILE")]
    pub noise: Option<PathBuf>,
    /// Calibration: the JSON of `calibrate --json` (a truth file of `simulate` also serves).
    #[arg(long, value_name = "FILE")]
    pub calibration: Option<PathBuf>,
    /// The file to write (kalibr, openvins; `-`: standard output), or for imu-tk the prefix of
    /// the two files `PREFIX_acc.calib` and `PREFIX_gyro.calib`.
    #[arg(long, value_name = "PATH")]
    pub out: PathBuf,
    /// The ROS topic written into the YAML files.
    #[arg(long, value_name = "TOPIC", default_value = "/imu0")]
    pub rostopic: String,
    /// Write noise figures of axes whose maximum-likelihood fit failed its check (refused
    /// without this: such a figure is no result).
    #[arg(long)]
    pub allow_unchecked: bool,
    /// Export a calibration whose data contradicted its model (`"fits": false`, exit status 3
    /// of `calibrate`): refused without this.
    #[arg(long)]
    pub accept_misfit: bool,
    /// Leave out the terms the target format cannot hold (named in the refusal without this,
    /// and in the report with it).
    #[arg(long)]
    pub drop_terms: bool,
}

/// Which input a target needs: (noise, calibration).
fn needs(to: Target) -> (bool, bool) {
    match to {
        Target::Kalibr => (true, false),
        Target::Openvins => (true, true),
        Target::ImuTk => (false, true),
    }
}

/// The target's name as given on the command line.
fn target_name(to: Target) -> &'static str {
    match to {
        Target::Kalibr => "kalibr",
        Target::Openvins => "openvins",
        Target::ImuTk => "imu-tk",
    }
}

/// Refuse a missing input and one the format has no place for.
fn check_inputs(args: &Args) -> Result<(), Error> {
    let (noise, calibration) = needs(args.to);
    let name = target_name(args.to);
    for (needed, given, option, what) in [
        (noise, args.noise.is_some(), "--noise", "noise levels"),
        (
            calibration,
            args.calibration.is_some(),
            "--calibration",
            "a calibration",
        ),
    ] {
        if needed && !given {
            return Err(format!(
                "--to {name}: expected {option} FILE: the {name} file holds {what}"
            )
            .into());
        }
        if !needed && given {
            return Err(format!(
                "--to {name}: {option} given, but the {name} file has no place for {what}: \
                 expected it without {option}"
            )
            .into());
        }
    }
    Ok(())
}

/// The output files: the one --out names, or imu_tk's pair.
fn outputs(args: &Args) -> Vec<PathBuf> {
    if args.to == Target::ImuTk {
        let prefix = args.out.to_string_lossy();
        vec![
            PathBuf::from(format!("{prefix}_acc.calib")),
            PathBuf::from(format!("{prefix}_gyro.calib")),
        ]
    } else {
        vec![args.out.clone()]
    }
}

/// Run `export`.
pub fn run(args: &Args) -> Result<(), Error> {
    check_inputs(args)?;
    let inputs: Vec<&Path> = args
        .noise
        .iter()
        .chain(&args.calibration)
        .map(PathBuf::as_path)
        .collect();
    let files = outputs(args);
    if args.to == Target::ImuTk && crate::output::is_stdout(&args.out) {
        return Err("--to imu-tk: --out is a prefix of two files: expected a path, not `-`".into());
    }
    let mut out = crate::output::Outputs::new(&inputs);
    for f in &files {
        out.file(f, "--out")?;
    }
    let mut notes = Vec::new();
    let noise = args
        .noise
        .as_deref()
        .map(|p| read_noise(p, args, &mut notes))
        .transpose()?;
    let calibration = args
        .calibration
        .as_deref()
        .map(|p| load_calibration(p, args, &mut notes))
        .transpose()?;
    // The YAML files say in comments what was let through or left out (imu_tk's files hold
    // numbers only: the report says it).
    let header = header(args, &notes);
    let texts: Vec<String> = match (args.to, &noise, &calibration) {
        (Target::Kalibr, Some(n), _) => vec![fmt::kalibr_yaml(n, &header)],
        (Target::Openvins, Some(n), Some(c)) => {
            let i = openvins_of(c, args)?;
            notes.push(format!(
                "biases (not read by OpenVINS, which estimates them): b_g = {} rad/s, b_a = {} \
                 m/s^2 (in the file as sins_calib_bias_g, sins_calib_bias_a)",
                vector(&i.bias_g),
                vector(&i.bias_a)
            ));
            vec![fmt::openvins_yaml(n, &i, &header)]
        }
        (Target::ImuTk, _, Some(c)) => imu_tk_of(c, &args.calibration_name())?,
        // `check_inputs` requires the inputs of every target.
        (to, _, _) => {
            return Err(format!("--to {}: an input is missing", target_name(to)).into());
        }
    };
    write_all(&files, &texts)?;
    let mut report = format!("sins-calib export --to {}\n", target_name(args.to));
    for f in &files {
        if crate::output::is_stdout(f) {
            report += "  wrote  the standard output\n";
        } else {
            report += &format!("  wrote  {}\n", f.display());
        }
    }
    for n in &notes {
        report += &format!("  note   {n}\n");
    }
    if files.iter().any(|f| crate::output::is_stdout(f)) {
        eprint!("{report}");
        Ok(())
    } else {
        crate::print(&report)
    }
}

/// A vector as `[x, y, z]`.
fn vector(v: &nalgebra::Vector3<f64>) -> String {
    format!(
        "[{}, {}, {}]",
        fmt::number(v[0]),
        fmt::number(v[1]),
        fmt::number(v[2])
    )
}

impl Args {
    /// The calibration file as named (for messages).
    fn calibration_name(&self) -> String {
        self.calibration
            .as_ref()
            .map_or_else(String::new, |p| p.display().to_string())
    }
}

/// Write every file; when one fails, the ones already written are removed (the pair of
/// imu_tk is written whole or not at all).
fn write_all(files: &[PathBuf], texts: &[String]) -> Result<(), Error> {
    for (k, (f, t)) in files.iter().zip(texts).enumerate() {
        if let Err(e) = crate::output::write_file(f, t.as_bytes()) {
            for done in &files[..k] {
                let _ = std::fs::remove_file(done);
            }
            return Err(e);
        }
    }
    Ok(())
}

/// The comment lines at the top of a YAML file: what wrote it, from what, which axis, and
/// `notes` (what was let through or left out).
fn header(args: &Args, notes: &[String]) -> String {
    let mut h = format!(
        "# Written by sins-calib export --to {}",
        target_name(args.to)
    );
    if let Some(n) = &args.noise {
        h += &format!("\n# noise levels: {}", one_line(n));
    }
    if let Some(c) = &args.calibration {
        h += &format!("\n# calibration: {}", one_line(c));
    }
    h += "\n# Each noise figure is the largest of the three axes (one figure per sensor: the \
          conservative one).\n";
    for n in notes {
        h += &format!("# Note: {}\n", n.replace(['\n', '\r'], " "));
    }
    h
}

/// A path on one comment line.
fn one_line(p: &Path) -> String {
    p.display().to_string().replace(['\n', '\r'], " ")
}

/// One sensor's levels per axis from the noise file: the white level and walk of the
/// maximum-likelihood fit, whether its check passed and whether it selected a Gauss-Markov
/// bias.
struct AxisLevels {
    white: [f64; 3],
    walk: [f64; 3],
    passes: [bool; 3],
    gauss_markov: [bool; 3],
    /// Whether the recording was long enough to tell the walk (`slow_terms[axis]`).
    walk_determined: [bool; 3],
}

/// The three numbers of `sensor.key` (finite, at least 0).
fn three(root: &Value, file: &str, sensor: &str, key: &str, unit: &str) -> Result<[f64; 3], Error> {
    let bad = || -> Error {
        format!(
            "{file}: expected `{sensor}.{key}`, three numbers at least 0 ({unit}), as `sins-calib \
             noise --json` writes them"
        )
        .into()
    };
    let a = root
        .get(sensor)
        .and_then(|s| s.get(key))
        .and_then(Value::as_array)
        .filter(|a| a.len() == 3)
        .ok_or_else(bad)?;
    let mut v = [0.0; 3];
    for (x, j) in v.iter_mut().zip(a) {
        *x = j
            .as_f64()
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(bad)?;
    }
    Ok(v)
}

/// A sensor's levels (`white_key`, `walk_key` in `unit`s) and its fits' checks.
fn axis_levels(
    root: &Value,
    file: &str,
    sensor: &str,
    keys: [(&str, &str); 2],
) -> Result<AxisLevels, Error> {
    let white = three(root, file, sensor, keys[0].0, keys[0].1)?;
    let walk = three(root, file, sensor, keys[1].0, keys[1].1)?;
    let ml = root
        .get(sensor)
        .and_then(|s| s.get("ml"))
        .and_then(Value::as_array)
        .filter(|a| a.len() == 3)
        .ok_or_else(|| {
            format!("{file}: expected `{sensor}.ml`, the three axes' likelihood fits")
        })?;
    let flag = |i: usize, key: &str| -> Result<bool, Error> {
        ml[i].get(key).and_then(Value::as_bool).ok_or_else(|| {
            format!("{file}: expected `{sensor}.ml[{i}].{key}`, true or false").into()
        })
    };
    let mut passes = [false; 3];
    let mut gauss_markov = [false; 3];
    for i in 0..3 {
        passes[i] = flag(i, "passes")?;
        gauss_markov[i] = flag(i, "gauss_markov")?;
    }
    let slow = root
        .get(sensor)
        .and_then(|s| s.get("slow_terms"))
        .and_then(Value::as_array)
        .filter(|a| a.len() == 3)
        .ok_or_else(|| {
            format!(
                "{file}: expected `{sensor}.slow_terms`, whether the recording tells each axis's \
                 walk (a noise file of this version)"
            )
        })?;
    let mut walk_determined = [false; 3];
    for (i, d) in walk_determined.iter_mut().enumerate() {
        *d = slow[i]
            .get("walk_determined")
            .and_then(Value::as_bool)
            .ok_or_else(|| {
                format!(
                    "{file}: expected `{sensor}.slow_terms[{i}].walk_determined`, true or false"
                )
            })?;
    }
    Ok(AxisLevels {
        white,
        walk,
        passes,
        gauss_markov,
        walk_determined,
    })
}

const AXES: [char; 3] = ['x', 'y', 'z'];

/// The largest of three values and its axis.
fn largest(v: &[f64; 3]) -> (f64, char) {
    let mut k = 0;
    for i in 1..3 {
        if v[i] > v[k] {
            k = i;
        }
    }
    (v[k], AXES[k])
}

/// Read the noise file: the figures for Kalibr (the largest axis of each, in SI), refusing
/// axes whose fit failed its check (unless --allow-unchecked) and a Gauss-Markov bias Kalibr
/// cannot hold (unless --drop-terms); `notes` gets what was let through.
fn read_noise(path: &Path, args: &Args, notes: &mut Vec<String>) -> Result<NoiseFigures, Error> {
    let (file, root) = crate::commands::noise::read_noise_json(path)?;
    let median = root
        .get("median_interval_s")
        .and_then(Value::as_f64)
        .filter(|x| x.is_finite() && *x > 0.0)
        .ok_or_else(|| format!("{file}: expected `median_interval_s`, a number above 0 (s)"))?;
    let gyro = axis_levels(
        &root,
        &file,
        "gyro",
        [
            ("white_deg_h", "deg/h"),
            ("bias_walk_deg_h_sqrt_h", "deg/h/sqrt(h)"),
        ],
    )?;
    let accel = axis_levels(
        &root,
        &file,
        "accel",
        [
            ("white_m_s2", "m/s^2"),
            ("bias_walk_m_s2_sqrt_s", "m/s^2/sqrt(s)"),
        ],
    )?;
    check_levels(&file, args, &gyro, &accel, notes)?;
    // deg/h at 1 Hz is deg/h * sqrt(s) = deg/h/sqrt(Hz); deg/h/sqrt(h) is deg/h / (60 sqrt(s)).
    let densities = |l: &AxisLevels, white_si: f64, walk_si: f64| {
        let (w, wa) = largest(&l.white);
        let (k, ka) = largest(&l.walk);
        Densities {
            noise_density: w * white_si,
            noise_axis: wa,
            random_walk: k * walk_si,
            walk_axis: ka,
        }
    };
    Ok(NoiseFigures {
        gyro: densities(&gyro, DEG_PER_HOUR, DEG_PER_HOUR / 60.0),
        accel: densities(&accel, 1.0, 1.0),
        update_rate_hz: rate_of(median),
        rostopic: args.rostopic.clone(),
    })
}

/// The record rate of a median interval, to 9 significant digits: the median of time stamps
/// written in decimal carries their rounding (100.00000000000213 Hz for 0.01 s).
fn rate_of(median_s: f64) -> f64 {
    let r = 1.0 / median_s;
    let scale = 10f64.powi(8 - r.log10().floor() as i32);
    (r * scale).round() / scale
}

/// Refuse failed checks and Gauss-Markov biases unless asked for.
fn check_levels(
    file: &str,
    args: &Args,
    gyro: &AxisLevels,
    accel: &AxisLevels,
    notes: &mut Vec<String>,
) -> Result<(), Error> {
    let list = |f: fn(&AxisLevels, usize) -> bool| -> Vec<String> {
        [("gyro", gyro), ("accel", accel)]
            .iter()
            .flat_map(|(s, l)| {
                (0..3)
                    .filter(move |i| f(l, *i))
                    .map(move |i| format!("{s} {}", AXES[i]))
            })
            .collect()
    };
    let failed = list(|l, i| !l.passes[i]);
    if !failed.is_empty() {
        if !args.allow_unchecked {
            return Err(format!(
                "{file}: the likelihood fit of {} failed its check (`ml[axis].passes` false): \
                 its levels are no result, and the largest axis is written. Measure the noise \
                 again (docs/noise.md, \"What the checks say\"), or give --allow-unchecked to \
                 write them anyway",
                failed.join(", ")
            )
            .into());
        }
        notes.push(format!(
            "the levels of {} failed their check; written as --allow-unchecked asks",
            failed.join(", ")
        ));
    }
    let undetermined = list(|l, i| !l.walk_determined[i]);
    if !undetermined.is_empty() {
        if !args.allow_unchecked {
            return Err(format!(
                "{file}: the bias walk of {} is not determined (the recording's rests are too \
                 short to tell it, `slow_terms[axis].walk_determined` false): the random walk \
                 written would be no result. Record longer rests, or give --allow-unchecked to \
                 write it anyway",
                undetermined.join(", ")
            )
            .into());
        }
        notes.push(format!(
            "the bias walk of {} is not determined; written as --allow-unchecked asks",
            undetermined.join(", ")
        ));
    }
    let gm = list(|l, i| l.gauss_markov[i]);
    if !gm.is_empty() {
        if !args.drop_terms {
            return Err(format!(
                "{file}: the noise of {} has a Gauss-Markov bias, which the {} file cannot hold \
                 (white noise and a bias random walk only): give --drop-terms to leave it out",
                gm.join(", "),
                target_name(args.to)
            )
            .into());
        }
        notes.push(format!(
            "dropped: the Gauss-Markov bias of {} (--drop-terms)",
            gm.join(", ")
        ));
    }
    Ok(())
}

/// The calibration's correction, refused when its data contradicted its model (unless
/// --accept-misfit) or when its compensation is ill-conditioned.
fn load_calibration(
    path: &Path,
    args: &Args,
    notes: &mut Vec<String>,
) -> Result<Correction, Error> {
    let file = path.display().to_string();
    let result = read_result_json(path).map_err(|e| {
        format!(
            "{e}: expected the JSON that `calibrate --json` writes (or a truth.json of `simulate`)"
        )
    })?;
    if let Some(v) = result.verdict.as_ref().filter(|v| !v.fits) {
        if !args.accept_misfit {
            return Err(format!(
                "{file}: this calibration's data contradicted its model (\"fits\": false, exit \
                 status 3 of calibrate){}: its correction is not to be trusted. Calibrate again \
                 with the terms `diagnose` names, or give --accept-misfit to export it anyway",
                if v.reasons.is_empty() {
                    String::new()
                } else {
                    format!(": {}", v.reasons.join("; "))
                }
            )
            .into());
        }
        notes.push(format!(
            "{file}: the data contradicted this calibration's model; exported as \
             --accept-misfit asks"
        ));
    }
    crate::commands::apply::check_compensation(&result, &file)?;
    let c = Correction::of_result(&result)
        .map_err(|e| format!("{file}: {e} (a result file of `calibrate --json` is expected)"))?;
    let dropped = dropped_terms(&c, args.to);
    if !dropped.is_empty() {
        if !args.drop_terms {
            return Err(format!(
                "{file}: the {} files cannot hold {}: give --drop-terms to export without \
                 them (the exported correction is then not this calibration's whole correction)",
                target_name(args.to),
                dropped.join(", ")
            )
            .into());
        }
        notes.push(format!("dropped (--drop-terms): {}", dropped.join(", ")));
    }
    Ok(c)
}

/// The estimated terms of `c` the target cannot hold.
fn dropped_terms(c: &Correction, to: Target) -> Vec<String> {
    // OpenVINS holds the g-sensitivity (its Tg) on the corrected specific force, as this tool
    // fits it; the form of earlier results, on the measured one, it cannot hold.
    let gsens_held = to == Target::Openvins && c.extension_inputs == ExtensionInputs::True;
    let mut d = Vec::new();
    for (on, name) in [
        (
            c.has(Candidate::GyroGSensitivity) && !gsens_held,
            "the gyro g-sensitivity (gyro.gsens)",
        ),
        (
            c.has(Candidate::GyroScaleAsymmetry),
            "the scale asymmetry (gyro.asym)",
        ),
        (
            c.has(Candidate::AccelQuadratic),
            "the accelerometer quadratic term (accel.k2)",
        ),
        (
            c.has(Candidate::AccelSizeEffect),
            "the size effect (accel.lever)",
        ),
        (
            c.has(Candidate::GyroAccelTimeOffset),
            "the gyro-accelerometer time offset (time.gyro_accel)",
        ),
    ] {
        if on {
            d.push(name.to_string());
        }
    }
    if let Some(t) = &c.thermal {
        d.push(format!(
            "the temperature coefficients (written at their reference, {} deg C)",
            fmt::number(t.reference_c)
        ));
    }
    d
}

/// OpenVINS's intrinsics of the correction.
fn openvins_of(c: &Correction, args: &Args) -> Result<fmt::OpenVinsIntrinsics, Error> {
    let gsens = c
        .values(Candidate::GyroGSensitivity)
        .map(nalgebra::Matrix3::from_row_slice)
        .filter(|_| c.extension_inputs == ExtensionInputs::True);
    fmt::openvins_intrinsics(
        &c.gyro_matrix,
        &c.gyro_offset,
        gsens.as_ref(),
        &c.accel_matrix,
        &c.accel_offset,
    )
    .ok_or_else(|| {
        format!(
            "{}: the compensation matrices have no factoring into a rotation and a \
             lower-triangular matrix with a positive diagonal (a determinant at most 0): \
             expected scale factors near 1",
            args.calibration_name()
        )
        .into()
    })
}

/// imu_tk's two files (accelerometers, gyros) of the correction.
fn imu_tk_of(c: &Correction, file: &str) -> Result<Vec<String>, Error> {
    let mut texts = Vec::new();
    for (m, offset, what) in [
        (&c.accel_matrix, &c.accel_offset, "accelerometer"),
        (&c.gyro_matrix, &c.gyro_offset, "gyro"),
    ] {
        let t = fmt::imu_tk_triad(m, offset).ok_or_else(|| {
            format!(
                "{file}: the {what} compensation matrix has a diagonal entry at most 0: imu_tk's \
                 scale factors must be positive"
            )
        })?;
        texts.push(fmt::imu_tk_text(&t));
    }
    Ok(texts)
}
