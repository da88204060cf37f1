//! `sins-calib simulate`: a simulated run written as interchange files.

use crate::{Error, load_config, output, print};
use calib::io::{
    ImuCsvWriter, ImuKind, ImuRecord, TurntableCsvWriter, TurntableRecord, write_truth_json,
};
use calib::simulate::prepare_run;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `simulate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Run configuration: a TOML file (docs/formats.md), or `paper` / `paper-reconciled` for the
    /// embedded configurations of the paper's covariance analysis. Its `[truth]` section sets the
    /// seed, the IMU and turntable record rates, the duration and the true values (drawn from
    /// `[priors]` unless given); `[noise]` the sensor noises; `[clock]` the turntable clock.
    #[arg(long, value_name = "FILE|NAME")]
    pub config: String,
    /// Directory to write imu.csv, turntable.csv and truth.json into; created when missing.
    /// The three files are written whole or not at all: those of an earlier run are replaced
    /// (other files there are kept); a file at this path is refused.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Seed of the random generator (parameter draws and noise), instead of the configuration's
    /// truth.seed.
    #[arg(long, value_name = "N")]
    pub seed: Option<u64>,
}

/// The files `simulate` writes into its directory.
const OUTPUTS: [&str; 3] = ["imu.csv", "turntable.csv", "truth.json"];

/// Records a simulation may write: the records are written as they are made (memory does not
/// grow with the run), but `imu.csv` takes about 140 bytes a record (50 million records: 139 h
/// at 100 Hz, 7 GB).
const MAX_RECORDS: f64 = 5e7;

/// Refuse a run with no records, or more than [`MAX_RECORDS`], before simulating anything.
fn check_size(
    config: &calib::config::RunConfig,
    program_s: f64,
    origin: &str,
) -> Result<(), Error> {
    let t = &config.truth;
    let duration = t.duration_s.unwrap_or(program_s);
    // Absurd durations in exponent form (1e300 has 301 digits).
    let shown = if duration < 1e7 {
        format!("{duration}")
    } else {
        format!("{duration:e}")
    };
    for (name, rate, least) in [
        ("truth.imu_rate_hz", t.imu_rate_hz, 2.0),
        ("truth.turntable_rate_hz", t.turntable_rate_hz, 2.0),
    ] {
        let n = duration * rate;
        if n < least {
            return Err(format!(
                "{origin}: {shown} s at {name} = {rate} gives {n:.3} records: expected a run of \
                 at least {least} records (nothing would be written that calibrate can read)"
            )
            .into());
        }
        if n > MAX_RECORDS {
            return Err(format!(
                "{origin}: {shown} s at {name} = {rate} gives {n:.3e} records: simulate writes \
                 about 140 bytes of imu.csv a record and accepts at most {MAX_RECORDS:.0e} \
                 records; shorten truth.duration_s or lower the rate"
            )
            .into());
        }
    }
    Ok(())
}

/// How many prior sigmas a drawn true value must be able to reach within its physical bound.
const DRAW_SIGMAS: f64 = 5.0;

/// Refuse priors the truth would be drawn from (`truth.draw_from_priors`) when a draw could
/// pass the physical bound of its parameters (`calib::config::plausible`): a `gyro_scale` of 1e6 draws
/// scale factors no instrument has, and writes records calibrate refuses. The priors of
/// parameters `[truth.values]` sets in full are not drawn and not checked.
fn check_drawn_priors(config: &calib::config::RunConfig, origin: &str) -> Result<(), Error> {
    use sins_model::units::{ARCMIN, ARCSEC, DEG_PER_HOUR};
    let t = &config.truth;
    if !t.draw_from_priors {
        return Ok(());
    }
    let p = &config.priors;
    let deg = 1f64.to_radians();
    let mut groups = vec![
        (
            "priors.gyro_bias_deg_h",
            p.gyro_bias_deg_h,
            DEG_PER_HOUR,
            "gyro.bias.",
            &["x", "y", "z"][..],
        ),
        (
            "priors.gyro_scale",
            p.gyro_scale,
            1.0,
            "gyro.theta.",
            &["xx", "yy", "zz"][..],
        ),
        (
            "priors.gyro_misalignment_arcmin",
            p.gyro_misalignment_arcmin,
            ARCMIN,
            "gyro.theta.",
            &["xy", "xz", "yx", "yz", "zx", "zy"][..],
        ),
        (
            "priors.accel_bias_m_s2",
            p.accel_bias_m_s2,
            1.0,
            "accel.bias.",
            &["x", "y", "z"][..],
        ),
        (
            "priors.accel_scale",
            p.accel_scale,
            1.0,
            "accel.gamma.",
            &["xx", "yy", "zz"][..],
        ),
        (
            "priors.accel_misalignment_arcmin",
            p.accel_misalignment_arcmin,
            ARCMIN,
            "accel.gamma.",
            &["yx", "zx", "zy"][..],
        ),
        (
            "priors.install_misalignment_deg",
            p.install_misalignment_deg,
            deg,
            "install.delta.",
            &["x", "y", "z"][..],
        ),
        ("priors.tau_s", p.tau_s, 1.0, "turntable.tau", &[""][..]),
    ];
    if config.filter.estimate_base_misalignment {
        groups.push((
            "priors.base_misalignment_arcsec",
            p.base_misalignment_arcsec,
            ARCSEC,
            "base.gamma.",
            &["x", "y", "z"][..],
        ));
    }
    for (field, sigma, unit, prefix, members) in groups {
        let drawn = members
            .iter()
            .any(|m| !t.values.contains_key(&format!("{prefix}{m}")));
        let Some(b) = calib::config::plausible::bound(prefix) else {
            continue;
        };
        let reach = DRAW_SIGMAS * sigma * unit;
        if drawn && reach > b.max_abs {
            return Err(format!(
                "{origin}: {field} = {}: simulate draws the true {prefix}* from it \
                 (truth.draw_from_priors), and {DRAW_SIGMAS} sigma would reach {reach:.3e} {}, \
                 beyond {} {} (no instrument has such {}): expected a prior within a fifth of \
                 that bound, or the values set in [truth.values] (or draw_from_priors = false)",
                crate::render::table::compact(sigma),
                b.unit,
                b.max_abs,
                b.unit,
                b.what
            )
            .into());
        }
    }
    Ok(())
}

/// Run `simulate`.
pub fn run(args: &Args) -> Result<(), Error> {
    let (mut config, origin) = load_config(&args.config)?;
    if let Some(seed) = args.seed {
        config.truth.seed = seed;
    }
    check_drawn_priors(&config, &origin)?;
    let program = config.program()?;
    check_size(&config, program.duration(), &origin)?;
    let config_file = std::path::Path::new(&args.config);
    let program_file = crate::provenance::identification::program_file(&config);
    let mut inputs = vec![config_file];
    inputs.extend(program_file.as_deref());
    output::Outputs::new(&inputs).dir(&args.out, "--out", &OUTPUTS)?;
    let run = prepare_run(&config, &origin)?;
    let mut rng = run.rng();
    let imu_stream = run.imu(&mut rng)?;
    // The settings the turntable records need are checked before anything is written.
    run.check_turntable()?;
    let has_temp = run.sim.temperature.is_some();

    // The records are written as they are generated: the IMU records, then the turntable
    // records with the rng the IMU records left (the draws of the held simulation).
    let out = output::DirOutput::begin(&args.out, &OUTPUTS)?;
    let [imu_name, tt_name, truth_name] = OUTPUTS;
    let mut imu_writer = ImuCsvWriter::create(&out.path(imu_name), ImuKind::Increments, has_temp)?;
    let mut imu_span: Option<(f64, f64)> = None;
    for sample in imu_stream {
        imu_writer.write(&ImuRecord::from_sample(&sample))?;
        imu_span = Some((imu_span.map_or(sample.t, |(a, _)| a), sample.t));
    }
    let imu_records = imu_writer.finish()?;
    let duration = imu_span.map_or(0.0, |(_, t1)| t1);
    let mut tt_writer = TurntableCsvWriter::create(&out.path(tt_name))?;
    let mut tt_span: Option<(f64, f64)> = None;
    for sample in run.turntable(duration, &mut rng)? {
        tt_writer.write(&TurntableRecord::from_sample(&sample))?;
        tt_span = Some((tt_span.map_or(sample.t_tt, |(a, _)| a), sample.t_tt));
    }
    let tt_records = tt_writer.finish()?;
    write_truth_json(&out.path(truth_name), &run.truth)?;
    let imu_path = out.final_path(imu_name);
    let tt_path = out.final_path(tt_name);
    let truth_path = out.final_path(truth_name);
    out.commit()?;

    let t = &config.truth;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "simulated {} s of program \"{}\" ({} s long) with seed {}, configuration {origin}",
        crate::render::table::compact(duration),
        program.name,
        crate::render::table::compact(program.duration()),
        t.seed
    );
    let span = |sp: Option<(f64, f64)>| match sp {
        Some((a, b)) => format!(
            "t = {} .. {} s",
            crate::render::table::compact(a),
            crate::render::table::compact(b)
        ),
        None => "no records".into(),
    };
    let _ = writeln!(
        s,
        "  wrote {}: {} records at {} Hz, angle and velocity increments, {} (IMU clock)",
        imu_path.display(),
        imu_records,
        t.imu_rate_hz,
        span(imu_span)
    );
    let _ = writeln!(
        s,
        "  wrote {}: {} records at {} Hz, gimbal angles, {} (turntable clock: offset {} s, \
         rate error {})",
        tt_path.display(),
        tt_records,
        t.turntable_rate_hz,
        span(tt_span),
        config.clock.turntable_offset_s,
        config.clock.turntable_rate_error
    );
    let _ = writeln!(
        s,
        "  wrote {}: {} true values (SI)",
        truth_path.display(),
        run.truth.parameters.len()
    );
    if (t.imu_rate_hz - config.filter.imu_rate_hz).abs() > 1e-9 * t.imu_rate_hz {
        let _ = writeln!(
            s,
            "note: truth.imu_rate_hz = {} differs from filter.imu_rate_hz = {}: calibrate with \
             this configuration will refuse these data",
            t.imu_rate_hz, config.filter.imu_rate_hz
        );
    }
    print(&s)
}
