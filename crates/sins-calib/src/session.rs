//! The command line of `calibrate` and `diagnose` resolved once, before any work, into a
//! [`Session`]: the output paths checked; the configuration (given, embedded, or for a
//! hand-turned recording without one the defaults made from the recording, with the
//! assumptions they state); the IMU and turntable files opened; the program (declared or from
//! the angles) with its start, or the rests of a recording without one; the unit and the input
//! files with their SHA-256; and what the command adds (the model and the truth of
//! `calibrate`, the loop's settings of `diagnose`). The commands run over the session: nothing
//! after it reads the command line.

use crate::free_motion::{self, SetupSummary};
use crate::provenance::RunProvenance;
use crate::{Error, load_config};
use calib::config::RunConfig;
use calib::estimate::FileImu;
use calib::estimate::hand_turned::WhiteNoiseAtRest;
use calib::extend::LoopSettings;
use calib::io::angle_records::AngleFile;
use calib::io::{ImuData, ResultFile, read_imu_csv, read_result_json};
use calib::model::extension::ModelExtension;
use calib::model::layout::{StateLayout, layout_with};
use calib::motion::detect::RateSource;
use calib::motion::rests::Rest;
use calib::motion::rests::Turn;
use sins_model::candidates::Candidate;
use std::path::{Path, PathBuf};

/// A command's resolved command line: what every command over recorded data has, and what
/// the command adds (`T`: [`Calibrate`], [`Diagnose`]).
pub struct Session<T> {
    /// The configuration the filter starts from (for a hand-turned recording without one,
    /// made from the recording: [`free_motion::setup`]).
    pub config: RunConfig,
    /// How the configuration was given.
    pub source: ConfigSource,
    /// Its name in messages: the path, `<embedded paper config>`, or `no configuration`.
    pub origin: String,
    /// The IMU file as named in messages.
    pub imu_file: String,
    /// The IMU records: streamed at every pass, or held (`diagnose` of a programmed run).
    pub records: Records,
    /// The turntable's angle records (streamed at every pass, kept in memory when short).
    pub turntable: Option<AngleFile>,
    /// The program's name and duration (s); `None` for a recording of rests.
    pub program: Option<(String, f64)>,
    /// A recording of rests: the rests found (and with `--free-motion` its setup).
    pub rests: Option<RestsFound>,
    /// The unit, the inputs' SHA-256 (with `--free-motion`) and notes on them.
    pub provenance: RunProvenance,
    /// The files a report identifies the run by (role, path).
    pub report_inputs: Vec<(&'static str, PathBuf)>,
    /// `--json`, checked.
    pub json: Option<PathBuf>,
    /// `--report DIR`, checked.
    pub report: Option<PathBuf>,
    /// `--holdout K`: every K-th rest held out.
    pub holdout: Option<usize>,
    /// What the command adds.
    pub task: T,
}

/// How the configuration was given.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ConfigSource {
    /// `--config NAME|PATH`, as given.
    Given(String),
    /// None given where the embedded paper configuration is the default.
    Paper,
    /// `--free-motion` without `--config`: made from the recording.
    FromRecording,
}

impl ConfigSource {
    /// The name or path the report's identification shows (`None`: made from the recording).
    pub fn shown(&self) -> Option<&str> {
        match self {
            Self::Given(name) => Some(name),
            Self::Paper => Some("paper"),
            Self::FromRecording => None,
        }
    }

    /// The configuration file given (none for an embedded configuration).
    fn file(&self) -> Option<&Path> {
        match self {
            Self::Given(name) => Some(Path::new(name)).filter(|p| p.is_file()),
            _ => None,
        }
    }
}

/// The IMU records of a session.
pub enum Records {
    /// Read from the file at every pass (`calibrate`; `diagnose` of a recording of rests).
    Streamed(Box<FileImu>),
    /// Read into memory (`diagnose` of a programmed run, whose model-extension loop takes
    /// them held).
    Held(ImuData),
}

impl Records {
    /// The records when they are in memory.
    pub fn held(&self) -> Option<&ImuData> {
        match self {
            Self::Held(data) => Some(data),
            Self::Streamed(_) => None,
        }
    }

    /// Whether every record has a temperature (a file with a `temp` column: its reader takes
    /// no record without one).
    fn have_temp(&self) -> bool {
        match self {
            Self::Held(data) => data.records.iter().all(|r| r.temp.is_some()),
            Self::Streamed(imu) => imu.has_temp(),
        }
    }
}

/// The rests of a recording without a program.
pub struct RestsFound {
    /// The rests on the IMU clock.
    pub rests: Vec<Rest>,
    /// The detector's report of rests it may have missed.
    pub missed: Option<Vec<String>>,
    /// With `--free-motion`: how the run was set up.
    pub free_motion: Option<FreeMotion>,
}

/// What `--free-motion` set up beyond the configuration.
pub struct FreeMotion {
    /// Where the configuration came from, the grade, the terms, the assumptions.
    pub summary: SetupSummary,
    /// The rests' white noise, when the configuration's levels are it.
    pub measured: Option<WhiteNoiseAtRest>,
    /// The section list's known turns.
    pub turns: Vec<Turn>,
}

/// What `calibrate` adds to its session.
pub struct Calibrate {
    /// The model: the paper's with the terms, at the configuration's grade.
    pub layout: StateLayout,
    /// `--truth`: its path and its values (units checked against the model).
    pub truth: Option<(PathBuf, ResultFile)>,
    /// `--plot`, checked.
    pub plot: Option<PathBuf>,
    /// `--diagnostics DIR`, checked and created.
    pub diagnostics: Option<PathBuf>,
    /// The candidate terms added to the paper's model (`--terms`, `--terms-from`), recorded in
    /// the result: a term such as the bias drift changes the estimates without parameters of
    /// its own.
    pub terms: Vec<Candidate>,
}

/// What `diagnose` adds to its session.
pub struct Diagnose {
    /// The loop's settings (level, candidates, hold-out, drift grid, measured noise).
    pub settings: LoopSettings,
    /// `--noise`: the file and the walks the drift candidate is tried at (rad/s/sqrt(s)).
    pub walk_prior: Option<(String, Vec<f64>)>,
}

impl<T> Session<T> {
    /// The hand-turned setup, with `--free-motion`.
    pub fn free_motion(&self) -> Option<&FreeMotion> {
        self.rests.as_ref().and_then(|r| r.free_motion.as_ref())
    }
}

/// Resolve the command line of `calibrate`.
pub fn calibrate(args: &crate::args::CalibrateArgs) -> Result<Session<Calibrate>, Error> {
    if args.free_motion
        && (args.program.turntable.is_some() || args.program.program_start.is_some())
    {
        return Err(
            "calibrate --free-motion: --turntable and --program-start belong to a \
                    turntable calibration (a hand-turned recording has neither)"
                .into(),
        );
    }
    let (plot, diagnostics) = calibrate_outputs(args)?;
    let (mut config, origin, source) = configuration(args.config.as_deref(), args.free_motion)
        .ok_or(
        "calibrate: --config is required (or --free-motion for a hand-turned \
                    recording without a rotation program)",
    )??;
    program_start(&mut config, args.program.program_start)?;
    // Read the truth first: a wrong path should not cost a whole run.
    let truth = args.truth.as_deref().map(read_result_json).transpose()?;
    // The IMU file is streamed (read once per pass, kept in memory only when short).
    let imu = FileImu::open(&args.imu)?;
    let imu_file = calib::estimate::ImuSource::file(&imu).to_string();
    let turntable = args.program.open_turntable()?;
    let program = program_of(&config, turntable.as_ref())?;
    check_turntable_coverage(
        &config,
        turntable.as_ref(),
        program.is_some(),
        imu_span(&args.imu),
    )?;
    if let (true, Some((name, _))) = (args.free_motion, &program) {
        return Err(format!(
            "calibrate --free-motion: {origin} has a rotation program ({name}); --free-motion \
             calibrates a hand-turned recording without one (leave --free-motion out to \
             calibrate along the program, or give a configuration without `program`)"
        )
        .into());
    }
    refuse_detector_with_program("calibrate", program.is_some(), &args.detector)?;
    let config_unit = args
        .config
        .as_deref()
        .map(|_| (origin.as_str(), &config.unit));
    let mut provenance =
        crate::provenance::gather(&args.imu, config_unit, &args.unit, args.free_motion)?;
    let terms = crate::args::terms::terms_asked(&args.terms, args.terms_from.as_deref())?;
    crate::args::terms::check_thermal(
        &terms,
        imu.has_temp(),
        "calibrate",
        &format!("{imu_file}: no `temp` column"),
        "records with a `temp` column (deg C)",
    )?;
    let mut session = Session {
        config,
        source,
        origin,
        imu_file,
        records: Records::Streamed(Box::new(imu)),
        turntable,
        program,
        rests: None,
        provenance: crate::provenance::RunProvenance::default(),
        report_inputs: calibrate_report_inputs(args),
        json: args.json.clone(),
        report: args.report.clone(),
        holdout: args.holdout,
        task: (),
    };
    let mut layout = None;
    if session.program.is_none() {
        // No program: the rests the data show stand in for it.
        let asked = args.free_motion.then(|| FreeMotionArgs {
            site: (args.site.latitude, args.site.height),
            sections: args.sections.as_deref(),
            terms: &terms,
            rest_error_m_s2: args.rest_error,
            holdout: args.holdout,
        });
        layout = rests_streamed(&mut session, &args.detector, "calibrate", asked)?;
    }
    let layout = layout.unwrap_or_else(|| {
        let extension = ModelExtension::with_grade(&terms, session.config.unit_grade());
        layout_with(&session.config, session.turntable.is_some(), &extension)
    });
    let truth = args.truth.clone().zip(truth);
    check_truth_units(truth.as_ref(), &layout)?;
    if args.free_motion {
        // Hashed now that their readers have read (and bounded) them.
        provenance.hash_files(&calibrate_hashed_inputs(args, &session.source))?;
    }
    session.provenance = provenance;
    Ok(session.with(Calibrate {
        layout,
        truth,
        plot,
        diagnostics,
        terms,
    }))
}

impl Session<()> {
    /// The session with what its command adds.
    fn with<T>(self, task: T) -> Session<T> {
        Session {
            config: self.config,
            source: self.source,
            origin: self.origin,
            imu_file: self.imu_file,
            records: self.records,
            turntable: self.turntable,
            program: self.program,
            rests: self.rests,
            provenance: self.provenance,
            report_inputs: self.report_inputs,
            json: self.json,
            report: self.report,
            holdout: self.holdout,
            task,
        }
    }
}

/// Check `calibrate`'s outputs before any work (none may be an input); returns `--plot` and
/// `--diagnostics` (a directory of outputs, written whole after the work as `--report` is).
fn calibrate_outputs(
    args: &crate::args::CalibrateArgs,
) -> Result<(Option<PathBuf>, Option<PathBuf>), Error> {
    let mut inputs: Vec<&Path> = vec![args.imu.as_path()];
    inputs.extend(args.program.turntable.as_deref());
    inputs.extend(args.truth.as_deref());
    inputs.extend(args.sections.as_deref());
    inputs.extend(args.terms_from.as_deref());
    inputs.extend(args.config.as_deref().map(Path::new));
    inputs.extend(args.flight.flight.as_deref());
    let mut outputs = crate::output::Outputs::new(&inputs);
    if let Some(path) = &args.json {
        outputs.file(path, "--json")?;
    }
    if let Some(path) = &args.plot {
        outputs.png(path, "--plot")?;
    }
    if let Some(dir) = &args.report {
        outputs.dir(dir, "--report", &crate::provenance::identification::NAMES)?;
    }
    if let Some(dir) = &args.diagnostics {
        outputs.dir(
            dir,
            "--diagnostics",
            &crate::plots::innovation_diagnostics::NAMES,
        )?;
    }
    Ok((args.plot.clone(), args.diagnostics.clone()))
}

/// The data files `calibrate` reads, with their roles, for a report's identification.
fn calibrate_report_inputs(args: &crate::args::CalibrateArgs) -> Vec<(&'static str, PathBuf)> {
    let mut v = vec![("IMU records", args.imu.clone())];
    v.extend(
        args.program
            .turntable
            .clone()
            .map(|p| ("turntable angles", p)),
    );
    v.extend(args.truth.clone().map(|p| ("truth", p)));
    v.extend(args.sections.clone().map(|p| ("section list", p)));
    v.extend(
        args.terms_from
            .clone()
            .map(|p| ("diagnose result (--terms-from)", p)),
    );
    v
}

/// The files beyond the IMU records whose SHA-256 a `--free-motion` result names.
fn calibrate_hashed_inputs<'a>(
    args: &'a crate::args::CalibrateArgs,
    source: &'a ConfigSource,
) -> Vec<(&'static str, &'a Path)> {
    let mut files: Vec<(&str, &Path)> = Vec::new();
    files.extend(args.sections.as_deref().map(|p| ("section list", p)));
    files.extend(
        args.terms_from
            .as_deref()
            .map(|p| ("diagnose result (--terms-from)", p)),
    );
    files.extend(source.file().map(|p| ("run configuration", p)));
    files.extend(args.truth.as_deref().map(|p| ("truth", p)));
    files
}

/// Resolve the command line of `diagnose`.
pub fn diagnose(args: &crate::args::DiagnoseArgs) -> Result<Session<Diagnose>, Error> {
    diagnose_outputs(args)?;
    let (mut config, origin, source) = configuration(args.config.as_deref(), args.free_motion)
        .unwrap_or_else(|| {
            load_config("paper").map(|(c, origin)| (c, origin, ConfigSource::Paper))
        })?;
    program_start(&mut config, args.program.program_start)?;
    let mut settings = LoopSettings {
        level: args.level,
        ..LoopSettings::default()
    };
    if let Some(k) = args.holdout {
        settings.hold_out_every = Some(k);
    }
    if !args.terms.is_empty() {
        settings.candidates = crate::args::terms::parse_terms(&args.terms)?;
    }
    let walk_prior = args.noise.as_deref().map(walk_prior).transpose()?;
    if let Some((_, grid)) = &walk_prior {
        settings.drift_grid = Some(grid.clone());
    }
    // A recording of rests (no program, no angles) is read again for every fit; a programmed
    // run's records are held for the model-extension loop (`calib::extend::run_loop`).
    let rests_mode = args.program.turntable.is_none() && config.program_from_angles();
    let imu = diagnose_records(&args.imu, rests_mode)?;
    let imu_file = args.imu.display().to_string();
    // Without --terms every candidate is considered and the loop leaves the thermal ones out
    // on records without temperatures, saying so; named, they are refused.
    crate::args::terms::check_thermal(
        &settings.candidates,
        args.terms.is_empty() || imu.have_temp(),
        "diagnose",
        &format!("{imu_file}: no `temp` column"),
        "records with a `temp` column (deg C)",
    )?;
    let turntable = args.program.open_turntable()?;
    if args.free_motion && !config.program_from_angles() {
        return Err(format!(
            "diagnose --free-motion: {origin} has a rotation program; --free-motion is for a \
             hand-turned recording without one (leave --free-motion out to diagnose along the \
             program, or give a configuration without `program`)"
        )
        .into());
    }
    refuse_detector_with_program("diagnose", !rests_mode, &args.detector)?;
    // (A recording of rests has no program to cover: nothing to check, and no span held.)
    let span = imu
        .held()
        .and_then(|d| d.records.first().zip(d.records.last()));
    check_turntable_coverage(
        &config,
        turntable.as_ref(),
        !rests_mode,
        span.map(|(a, b)| (a.t, b.t)),
    )?;
    let mut report_inputs = vec![("IMU records", args.imu.clone())];
    report_inputs.extend(
        args.program
            .turntable
            .clone()
            .map(|p| ("turntable angles", p)),
    );
    let mut session = Session {
        config,
        source,
        origin,
        imu_file,
        records: imu,
        turntable,
        program: None,
        rests: None,
        provenance: crate::provenance::RunProvenance::default(),
        report_inputs,
        json: args.json.clone(),
        report: args.report.clone(),
        holdout: args.holdout,
        task: (),
    };
    if rests_mode {
        let asked = args.free_motion.then_some(FreeMotionArgs {
            site: (args.site.latitude, args.site.height),
            sections: args.sections.as_deref(),
            terms: &[],
            rest_error_m_s2: None,
            // The loop fits every rest; its held-out verdict holds some out afterwards.
            holdout: None,
        });
        rests_streamed(&mut session, &args.detector, "diagnose", asked)?;
        settings.measured_noise = session.free_motion().and_then(|f| f.measured);
    }
    Ok(session.with(Diagnose {
        settings,
        walk_prior,
    }))
}

/// The IMU records of `diagnose` at `path`: held for a programmed run; for a recording of
/// rests (`stream`) opened to be read again for every fit, and read through once now, so that
/// a line no reader takes is refused here, as the held reading refuses it.
fn diagnose_records(path: &Path, stream: bool) -> Result<Records, Error> {
    if !stream {
        return Ok(Records::Held(read_imu_csv(path)?));
    }
    let mut imu = FileImu::open(path)?;
    calib::io::source::read_records(&mut imu, &mut Vec::new(), &mut |_, _| true)?;
    Ok(Records::Streamed(Box::new(imu)))
}

/// Check `diagnose`'s outputs and options before any work (outputs, level, hold-out).
fn diagnose_outputs(args: &crate::args::DiagnoseArgs) -> Result<(), Error> {
    let mut inputs: Vec<&Path> = vec![args.imu.as_path()];
    inputs.extend(args.program.turntable.as_deref());
    inputs.extend(args.sections.as_deref());
    inputs.extend(args.noise.as_deref());
    inputs.extend(args.config.as_deref().map(Path::new));
    inputs.extend(args.flight.flight.as_deref());
    let mut outputs = crate::output::Outputs::new(&inputs);
    if let Some(p) = &args.json {
        outputs.file(p, "--json")?;
    }
    if let Some(p) = &args.report {
        outputs.dir(p, "--report", &crate::provenance::identification::NAMES)?;
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

/// The walk identified at rest (`--noise`) as the drift candidate's grid: tried where the
/// data at rest put it.
fn walk_prior(path: &Path) -> Result<(String, Vec<f64>), Error> {
    let walk = crate::commands::noise::read_identified_walk(path)?;
    let grid = walk.grid();
    if grid.is_empty() {
        return Err(format!(
            "{}: the identified gyro bias walk is 0 with no upper end: nothing to try the walk \
             candidate at (leave --noise out for the default grid)",
            path.display()
        )
        .into());
    }
    Ok((path.display().to_string(), grid))
}

/// The configuration given (`--config`), or with `--free-motion` and none the paper's with
/// its program from the angles, to be made from the recording once its rests are found
/// ([`free_motion::setup`]); `None` when neither.
fn configuration(
    given: Option<&str>,
    free_motion: bool,
) -> Option<Result<(RunConfig, String, ConfigSource), Error>> {
    match given {
        Some(name) => Some(
            load_config(name)
                .map(|(config, origin)| (config, origin, ConfigSource::Given(name.to_string()))),
        ),
        None if free_motion => {
            let mut c = RunConfig::paper();
            c.program = calib::config::PROGRAM_FROM_ANGLES.to_string();
            Some(Ok((
                c,
                "no configuration".to_string(),
                ConfigSource::FromRecording,
            )))
        }
        None => None,
    }
}

/// `--program-start`: the IMU time at which the program starts, in the configuration's range
/// for `filter.program_start_s`.
fn program_start(config: &mut RunConfig, start: Option<f64>) -> Result<(), Error> {
    if let Some(t) = start {
        let max = calib::config::PROGRAM_START_MAX_S;
        if !(t.is_finite() && t.abs() <= max) {
            return Err(format!(
                "--program-start {t}: expected the IMU time (s) at which the program starts, in \
                 -{max:e} .. {max:e} s"
            )
            .into());
        }
        config.filter.program_start_s = Some(t);
    }
    Ok(())
}

/// The program's name and duration: the configuration's, or (`"from-angles"`) the one the
/// turntable's angles give (the estimation reads it again, taking its first piece back to the
/// first IMU record); `None` for a recording of rests (neither a program nor angles).
fn program_of(
    config: &RunConfig,
    turntable: Option<&AngleFile>,
) -> Result<Option<(String, f64)>, Error> {
    let program = match calib::motion::angles_program::resolve_program(
        config,
        turntable.map(AngleFile::records),
        None,
    )? {
        Some(c) => Some(c.program()?),
        None if turntable.is_none() && config.program_from_angles() => None,
        None => Some(config.program()?),
    };
    Ok(program.map(|p| (p.name.clone(), p.duration())))
}

/// The least share of the IMU records' span the turntable angles must cover.
const TURNTABLE_COVERAGE_MIN: f64 = 0.9;

/// The first and last time stamps of an `imu.csv`, read cheaply before the work: the first
/// record, and the last line of the file's tail. `None` where that cannot be done (a pipe, a
/// last line that is not a record) or where the stamps are not plausibly seconds (the first
/// interval above 1 s: the checks of the records then name the unit): the fit's own statistics
/// count what is uncovered.
fn imu_span(path: &Path) -> Option<(f64, f64)> {
    use std::io::{Read as _, Seek as _, SeekFrom};
    // A regular file only: a second reader of a pipe would take the records from the first.
    if !std::fs::metadata(path).ok()?.is_file() {
        return None;
    }
    let mut reader = calib::io::ImuReader::open(path).ok()?;
    let first = reader.next_record().ok()??.t;
    let second = reader.next_record().ok()??.t;
    if !(second > first && second - first <= 1.0) {
        return None;
    }
    let mut f = std::fs::File::open(path).ok()?;
    let meta = f.metadata().ok()?;
    f.seek(SeekFrom::Start(meta.len().saturating_sub(4096)))
        .ok()?;
    let mut tail = Vec::new();
    f.take(4096).read_to_end(&mut tail).ok()?;
    let tail = String::from_utf8_lossy(&tail);
    // The last line whole: a line break before it within the tail (a line longer than the
    // tail would be read from its middle).
    let (_, last_line) = tail.trim_end().rsplit_once('\n')?;
    let last: f64 = last_line.split(',').next()?.trim().parse().ok()?;
    (last.is_finite() && last > first).then_some((first, last))
}

/// Refuse, before the work, turntable angles that cover less than [`TURNTABLE_COVERAGE_MIN`]
/// of the IMU records' span `imu` (on the IMU clock, through `[clock]`) along a program: the
/// rest of the run would go without turntable measurements, the installation misalignment and
/// delay resting on part of it, with no word but a count in the fit's statistics.
fn check_turntable_coverage(
    config: &RunConfig,
    turntable: Option<&AngleFile>,
    has_program: bool,
    imu: Option<(f64, f64)>,
) -> Result<(), Error> {
    let (Some(tt), true, Some((i0, i1))) = (turntable, has_program, imu) else {
        return Ok(());
    };
    let records = tt.records();
    let summary = records.summary();
    let (a, b) = summary.span;
    // `[clock]`: t_tt = offset + (1 + rate error) t_imu.
    let c = &config.clock;
    let on_imu = |t: f64| (t - c.turntable_offset_s) / (1.0 + c.turntable_rate_error);
    let covered = (on_imu(b).min(i1) - on_imu(a).max(i0)).max(0.0);
    let length = i1 - i0;
    if summary.count >= 2 && length > 0.0 && covered < TURNTABLE_COVERAGE_MIN * length {
        return Err(format!(
            "{}: the turntable records span t = {} .. {} s (turntable clock), {} s of the IMU \
             records' t = {} .. {} s ({:.0} %): expected angles over at least {:.0} % of the \
             IMU records (the rest would go without turntable measurements); give the whole \
             recording, or leave --turntable out to calibrate from the IMU alone",
            records.file(),
            crate::render::table::compact(a),
            crate::render::table::compact(b),
            crate::render::table::compact(covered),
            crate::render::table::compact(i0),
            crate::render::table::compact(i1),
            100.0 * covered / length,
            100.0 * TURNTABLE_COVERAGE_MIN
        )
        .into());
    }
    Ok(())
}

/// Refuse the `--rest-*` options where a program says where the unit rests.
fn refuse_detector_with_program(
    command: &str,
    has_program: bool,
    detector: &crate::args::detector::DetectorArgs,
) -> Result<(), Error> {
    if has_program && detector.any() {
        return Err(format!(
            "{command}: the --rest-* options set how rests are found in a recording without a \
             program; this configuration has a program (or --turntable gives one), which says \
             where the unit rests"
        )
        .into());
    }
    Ok(())
}

/// The rests of the records of `source` (named `file`) by the detector's settings.
fn find_rests(
    source: &mut RateSource,
    file: &str,
    detector: &crate::args::detector::DetectorArgs,
    command: &str,
) -> Result<RestsFound, Error> {
    let settings = detector.settings().map_err(|e| format!("{command}: {e}"))?;
    let (rests, seg) = crate::args::detector::rests_and_segmentation(source, file, &settings)?;
    Ok(RestsFound {
        rests,
        missed: seg.missed_report(crate::args::detector::option_name),
        free_motion: None,
    })
}

/// The rests of a recording without a program (and with `--free-motion` its setup,
/// [`set_up_free_motion`], whose model is returned), found and set up on the session's records
/// read again for every step, as the filter reads them (docs/performance.md, "Memory of every
/// command on a long run").
fn rests_streamed<T>(
    session: &mut Session<T>,
    detector: &crate::args::detector::DetectorArgs,
    command: &str,
    free_motion: Option<FreeMotionArgs>,
) -> Result<Option<StateLayout>, Error> {
    let Records::Streamed(imu) = &mut session.records else {
        unreachable!("the records of a recording of rests are streamed")
    };
    // A first reading of every record: a line no reader takes is refused before the rests.
    let mut source = RateSource::new(&mut **imu)?;
    let file = &session.imu_file;
    let mut found = find_rests(&mut source, file, detector, command)?;
    let layout = match free_motion {
        Some(asked) => {
            let config = (
                &mut session.config,
                &session.source,
                session.origin.as_str(),
            );
            Some(set_up_free_motion(config, &mut found, &mut source, asked)?)
        }
        None => None,
    };
    session.rests = Some(found);
    Ok(layout)
}

/// What the command line of a `--free-motion` run adds to its setup.
struct FreeMotionArgs<'a> {
    /// `--latitude`, `--height`.
    site: (Option<f64>, Option<f64>),
    /// `--sections`.
    sections: Option<&'a Path>,
    /// The terms asked for.
    terms: &'a [Candidate],
    /// `--rest-error`: the error each rest's windows share, weighed (m/s^2).
    rest_error_m_s2: Option<f64>,
    /// `--holdout`: the rests held out of the fit, whose excess is not measured.
    holdout: Option<usize>,
}

/// Set up a `--free-motion` run on the rests `found` in the records of `source`
/// ([`free_motion::setup`]) with the session's configuration (`config`: the configuration,
/// how it was given, its name), which becomes the one it gives; returns the model with the
/// terms asked for.
fn set_up_free_motion(
    (config, given_as, origin): (&mut RunConfig, &ConfigSource, &str),
    found: &mut RestsFound,
    source: &mut RateSource,
    args: FreeMotionArgs,
) -> Result<StateLayout, Error> {
    let given = match given_as {
        ConfigSource::FromRecording => None,
        _ => Some((&*config, origin)),
    };
    let FreeMotionArgs {
        site,
        sections,
        terms,
        rest_error_m_s2,
        holdout,
    } = args;
    let mut setup = free_motion::setup(given, site, sections, terms, source, &found.rests)?;
    let mut rest_error_unasked = None;
    match (rest_error_m_s2, setup.measured) {
        (Some(v), _) => setup.config.filter.rest_error_m_s2 = v,
        // Without a configuration the rests' excess is weighed where the rests show it
        // (`RestExcess::weighed_unasked`), measured on the rests the fit uses.
        (None, Some(at_rest)) => {
            rest_error_unasked = calib::estimate::hand_turned::weigh_rest_excess_unasked(
                &mut setup.config,
                source.source(),
                &found.rests,
                &at_rest,
                holdout,
            )?;
        }
        _ => {}
    }
    let mut summary = setup.summary();
    summary.rest_error_unasked = rest_error_unasked;
    found.free_motion = Some(FreeMotion {
        summary,
        measured: setup.measured,
        turns: setup.turns,
    });
    *config = setup.config;
    Ok(setup.layout)
}

/// Refuse a truth file whose units are not the model's.
fn check_truth_units(
    truth: Option<&(PathBuf, ResultFile)>,
    layout: &StateLayout,
) -> Result<(), Error> {
    if let Some((path, truth)) = truth {
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
