//! # import
//!
//! Recordings in other layouts turned into the project's interchange files. (Static detection
//! on them is calib's: [`calib::motion::detect`].)
//!
//! - [`profile`]: the import profile (TOML): input files, delimiter, skipped lines, which column
//!   is which, the time base, rates or increments, units (physical or counts with offset and
//!   sensitivity), axis mapping with sign flips, sensor ranges, turntable angles, a section list;
//! - [`import_recording`]: reads the files a profile names and checks them: time strictly
//!   increasing, jitter kept (every record keeps its own time stamp), gaps refused unless allowed
//!   (then recorded), saturated samples counted, a specific force at rest nowhere near g refused
//!   with the likely cause; [`write_outputs`] writes `imu.csv` (with `calib::io`'s writer),
//!   `turntable.csv` when the source has angles, `sections.json` when the profile has a section
//!   list, and the report `import.json`;
//! - [`sections`]: section lists (static faces, rotations) carried onto the imported records.
//! - [`bag`]: ROS 1 bags and MCAP files ([`import_bag`]): the `sensor_msgs/Imu` messages on a
//!   topic into `imu.csv` at their header stamps, streamed, with the same checks.
//!
//! Every refusal is an [`ImportError`] naming the file, the line where there is one, and what was
//! expected; nothing panics on user data. Formats: `docs/formats.md`.
//!
//! ```no_run
//! use import::{ImportOptions, import_recording, profile::Profile, write_outputs};
//! use std::path::Path;
//!
//! let profile = Profile::load(Path::new("examples/xsens_mti.toml"))?;
//! let imported = import_recording(&profile, &ImportOptions::default())?;
//! write_outputs(&imported, Path::new("out/xsens"))?;
//! let segmentation = calib::motion::detect::segment(&imported.imu, &Default::default())?;
//! assert_eq!(segmentation.static_intervals.len(), 38);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bag;
mod error;
mod fields;
pub mod profile;
pub mod sections;
mod streamed;
mod text;

pub use bag::import_bag;
pub use calib::estimate::data_checks::Stuck;
pub use error::ImportError;
pub use streamed::{ImportedFiles, import_into};

use calib::io::timing::{self, GapAt, Timing};
use calib::io::{ImuData, ImuKind, ImuRecord, TurntableData, TurntableRecord};
use calib::motion::detect;
use profile::{AngleUnit, Column, Form, Join, Profile, STANDARD_GRAVITY, Sensor, Unit};
use sections::SectionsFile;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use text::{Table, Wanted, read_table};

/// The specific force at rest must have a median magnitude within this band, in units of
/// standard gravity, over the quietest window of the recording.
pub const G_BAND: (f64, f64) = (0.8, 1.2);

/// The median interval between records must lie in this band (s): from 100 kHz down to one
/// record a second. Every IMU records at 1 Hz or faster; a longer interval is time stamps in
/// milliseconds (or a counter's rate) read wrongly: 10 Hz .. 1 kHz stamped in ms and read as
/// seconds give 1 .. 100 "s".
pub const MEDIAN_INTERVAL_RANGE_S: (f64, f64) = (1e-5, 1.0);

/// Largest plausible angular rate after conversion (rad/s, about 5700 deg/s, above the range
/// of any gyro on a turntable or in a hand).
pub const MAX_GYRO_RAD_S: f64 = 100.0;

/// Largest plausible specific force after conversion (m/s^2, about 200 g).
pub const MAX_ACCEL_M_S2: f64 = calib::motion::sections::MAX_ACCEL_M_S2;

/// Length of the window in which the specific force at rest is checked (s).
pub const QUIET_WINDOW_S: f64 = 1.0;

/// Choices of an import that are not part of the profile.
#[derive(Clone, Copy, Debug, Default)]
pub struct ImportOptions {
    /// Import a recording with gaps (intervals longer than the profile's `checks.gap_factor`
    /// median intervals) as it is, the gaps recorded in the report; without it such a recording
    /// is refused at its first gap.
    pub allow_gaps: bool,
}

/// One input file of an import, as the report lists it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputFile {
    /// `"imu"` (the single file), `"gyro"` or `"accel"`.
    pub role: String,
    /// The file (resolved path).
    pub file: String,
    /// Data rows read.
    pub rows: usize,
    /// Line of the first data row (1-based).
    pub first_line: usize,
    /// Line of the last data row.
    pub last_line: usize,
}

/// A gap as the report lists it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GapReport {
    /// 0-based index of the record after the gap in `imu.csv`.
    pub record: usize,
    /// The input file of the line below.
    pub file: String,
    /// Line of the record after the gap in that file.
    pub line: usize,
    /// Time of the record before the gap (s).
    pub t_before_s: f64,
    /// Time of the record after the gap (s).
    pub t_after_s: f64,
    /// Length of the interval (s).
    pub length_s: f64,
    /// Length in median intervals.
    pub median_intervals: f64,
}

/// Saturated samples of one sensor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaturationReport {
    /// `"gyro"` or `"accel"`.
    pub sensor: String,
    /// The profile's range `[lowest, highest]`, in the file's values.
    pub range: [f64; 2],
    /// Records with any axis at or beyond the range.
    pub count: usize,
    /// The input file of `first_line`.
    pub file: String,
    /// Line of the first saturated record, if any.
    pub first_line: Option<usize>,
    /// Stretches of consecutive saturated records, `[first t, last t]` (s).
    pub stretches: Vec<[f64; 2]>,
}

/// The specific force in the quietest window (the check against g).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StaticForce {
    /// Median magnitude of the specific force over the window (m/s^2).
    pub median_norm_m_s2: f64,
    /// Its ratio to standard gravity.
    pub ratio_to_g: f64,
    /// First and last time stamp of the window (s).
    pub window_s: [f64; 2],
    /// Standard deviation of the specific force over the window (m/s^2).
    pub std_m_s2: f64,
}

/// What an import read, found and wrote (`import.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImportReport {
    /// The profile file (absent for a ROS recording, which needs none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
    /// The profile's description.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// The input files.
    pub inputs: Vec<InputFile>,
    /// `"rates"` or `"increments"`.
    pub form: String,
    /// Records written to `imu.csv`.
    pub records: usize,
    /// First time stamp (s).
    pub t_first_s: f64,
    /// Last time stamp (s).
    pub t_last_s: f64,
    /// Interval statistics (jitter is kept).
    pub timing: Timing,
    /// Gaps (only with [`ImportOptions::allow_gaps`]; otherwise the import is refused).
    pub gaps: Vec<GapReport>,
    /// Saturation per sensor with a range in the profile.
    pub saturation: Vec<SaturationReport>,
    /// The check of the specific force at rest against g.
    pub static_force: StaticForce,
    /// Whether `turntable.csv` was written.
    pub turntable: bool,
    /// Number of sections written to `sections.json` (absent without a section list).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sections: Option<usize>,
    /// The topic, message type, frame ids and covariances of a ROS recording (absent for a
    /// profile's import).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bag: Option<bag::BagSource>,
}

/// An imported recording.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The records for `imu.csv`.
    pub imu: ImuData,
    /// The angles for `turntable.csv`, when the profile has `[angles]`.
    pub turntable: Option<TurntableData>,
    /// The sections for `sections.json`, when the profile has `[sections]`.
    pub sections: Option<SectionsFile>,
    /// What was read and found.
    pub report: ImportReport,
}

/// A read input file with its time stamps.
struct Source {
    role: &'static str,
    table: Table,
    t: Vec<f64>,
}

/// Indices of the columns in a table, by what they hold.
#[derive(Default)]
struct Layout {
    time: Option<usize>,
    gyro: Option<usize>,
    accel: Option<usize>,
    angles: Option<usize>,
    temp: Option<usize>,
}

fn want<'a>(
    wanted: &mut Vec<Wanted<'a>>,
    what: &str,
    columns: &'a [Column],
    axes: [&str; 3],
) -> usize {
    let at = wanted.len();
    for (c, a) in columns.iter().zip(axes) {
        wanted.push(Wanted {
            what: format!("{what} {a} ({c})"),
            column: c,
        });
    }
    at
}

/// The columns wanted of an input file in its role, and where each quantity is among them.
fn wanted_of<'a>(profile: &'a Profile, role: &str) -> (Vec<Wanted<'a>>, Layout) {
    let mut wanted = Vec::new();
    let mut layout = Layout::default();
    let time = &profile.time;
    if let Some(c) = &time.column {
        layout.time = Some(wanted.len());
        wanted.push(Wanted {
            what: format!("time ({c})"),
            column: c,
        });
    } else if let Some(c) = &time.counter_column {
        layout.time = Some(wanted.len());
        wanted.push(Wanted {
            what: format!("sample counter ({c})"),
            column: c,
        });
    }
    let xyz = ["x", "y", "z"];
    if role != "accel" {
        layout.gyro = Some(want(&mut wanted, "gyro", &profile.gyro.columns, xyz));
    }
    if role != "gyro" {
        layout.accel = Some(want(&mut wanted, "accel", &profile.accel.columns, xyz));
    }
    if role != "accel"
        && let Some(a) = &profile.angles
    {
        layout.angles = Some(want(&mut wanted, "angle", &a.columns, ["k1", "k2", "k3"]));
    }
    if role != "accel"
        && let Some(tc) = &profile.temperature
    {
        layout.temp = Some(wanted.len());
        wanted.push(Wanted {
            what: format!("temperature ({})", tc.column),
            column: &tc.column,
        });
    }
    (wanted, layout)
}

fn read_source(
    profile: &Profile,
    role: &'static str,
    path: &Path,
) -> Result<(Source, Layout), ImportError> {
    let (wanted, layout) = wanted_of(profile, role);
    let table = read_table(path, &profile.input, &wanted, &profile.origin)?;
    let t = times(&table, layout.time, profile)?;
    Ok((Source { role, table, t }, layout))
}

/// The time of data row `i` (0-based) from its time or counter value, if the profile has one.
fn time_of(profile: &Profile, value: Option<f64>, i: usize) -> f64 {
    let time = &profile.time;
    match (value, time.counter_column.is_some(), time.rate_hz) {
        (Some(v), false, _) => v / time.unit.unwrap_or_default().per_second(),
        (Some(v), true, Some(r)) => v / r,
        (_, _, Some(r)) => i as f64 / r,
        _ => f64::NAN, // excluded by the profile's check
    }
}

/// A time that is not finite, refused.
fn time_not_finite(file: &str, line: usize, ti: f64) -> ImportError {
    ImportError::line(
        file,
        line,
        format!(
            "the time comes out as {ti} s: expected a finite time (check the profile's [time])"
        ),
    )
}

/// A time not after the previous row's (`p`, on line `previous_line`), refused.
fn time_not_increasing(
    profile: &Profile,
    file: &str,
    line: usize,
    ti: f64,
    p: f64,
    previous_line: usize,
) -> ImportError {
    let what = if profile.time.counter_column.is_some() {
        "sample counter"
    } else {
        "time"
    };
    ImportError::line(
        file,
        line,
        format!(
            "t = {} s is not after the previous row's t = {} s (line {}): expected a strictly \
             increasing {what}",
            show_t(ti),
            show_t(p),
            previous_line
        ),
    )
}

/// Time stamps of a table's rows, checked to increase strictly.
fn times(table: &Table, column: Option<usize>, profile: &Profile) -> Result<Vec<f64>, ImportError> {
    let mut t = Vec::with_capacity(table.rows());
    for i in 0..table.rows() {
        let ti = time_of(profile, column.map(|j| table.get(i, j)), i);
        if !ti.is_finite() {
            return Err(time_not_finite(&table.file, table.lines[i], ti));
        }
        if let Some(&p) = t.last()
            && ti.partial_cmp(&p) != Some(std::cmp::Ordering::Greater)
        {
            return Err(time_not_increasing(
                profile,
                &table.file,
                table.lines[i],
                ti,
                p,
                table.lines[i - 1],
            ));
        }
        t.push(ti);
    }
    Ok(t)
}

/// Check that two files pair row by row (the join), naming the first row without a partner.
fn join(profile: &Profile, g: &Source, a: &Source) -> Result<(), ImportError> {
    let tol = join_tolerance(profile, &g.table.file, timing::median_interval(&g.t))?;
    let n = g.t.len().min(a.t.len());
    fn at(s: &Source, i: usize) -> JoinRow<'_> {
        JoinRow {
            file: &s.table.file,
            line: s.table.lines[i],
            t: s.t[i],
        }
    }
    for i in 0..n {
        if let Some(e) = join_pair(profile, tol, at(g, i), at(a, i), [g.role, a.role]) {
            return Err(e);
        }
    }
    if g.t.len() != a.t.len() {
        let (long, short) = if g.t.len() > a.t.len() {
            (g, a)
        } else {
            (a, g)
        };
        return Err(unpartnered(
            at(long, n),
            n,
            &short.table.file,
            [g.role, a.role],
        ));
    }
    Ok(())
}

/// The join's tolerance: the profile's, or a tenth of the gyro file's median interval.
fn join_tolerance(profile: &Profile, g_file: &str, median: f64) -> Result<f64, ImportError> {
    let tol = profile.input.join_tolerance_s.unwrap_or(0.1 * median);
    let tol = if tol.is_finite() { tol } else { 0.0 };
    if profile.input.join_tolerance_s.is_some() && tol >= 0.5 * median {
        return Err(ImportError::profile(
            &profile.origin,
            format!(
                "[input] join_tolerance_s = {tol}: expected less than half the median interval \
                 of {g_file} ({} s), so that a row pairs only with the row of its own time",
                round_sig(median)
            ),
        ));
    }
    Ok(tol)
}

/// A data row as the join names it.
#[derive(Clone, Copy)]
struct JoinRow<'a> {
    file: &'a str,
    line: usize,
    t: f64,
}

/// The error of a gyro row and an accelerometer row of the same position that do not pair.
fn join_pair(
    profile: &Profile,
    tol: f64,
    g: JoinRow<'_>,
    a: JoinRow<'_>,
    roles: [&str; 2],
) -> Option<ImportError> {
    let has_time = profile.time.column.is_some() || profile.time.counter_column.is_some();
    match profile.input.join {
        Join::Time => {
            let d = g.t - a.t;
            if d.abs() > tol {
                // The file whose time is earlier has a row the other lacks.
                let (lone, other) = if d < 0.0 { (g, a) } else { (a, g) };
                return Some(ImportError::line(
                    lone.file,
                    lone.line,
                    format!(
                        "t = {} s has no row with the same time in {} (its row there, line {}, \
                         has t = {} s): expected the {} and {} files to hold the same time \
                         stamps, within join_tolerance_s = {tol} s",
                        show_t(lone.t),
                        other.file,
                        other.line,
                        show_t(other.t),
                        roles[0],
                        roles[1]
                    ),
                ));
            }
        }
        Join::Row => {
            if has_time && (g.t - a.t).abs() > tol {
                return Some(ImportError::line(
                    a.file,
                    a.line,
                    format!(
                        "t = {} s, but line {} of {} has t = {} s: expected rows joined by \
                         position to have the same time within join_tolerance_s = {tol} s",
                        show_t(a.t),
                        g.line,
                        g.file,
                        show_t(g.t)
                    ),
                ));
            }
        }
    }
    None
}

/// Row `n` of the longer file (`long`) has no partner: the other file (`short_file`) has `n`
/// rows.
fn unpartnered(long: JoinRow<'_>, n: usize, short_file: &str, roles: [&str; 2]) -> ImportError {
    ImportError::line(
        long.file,
        long.line,
        format!(
            "row {} (t = {} s) has no partner: {} ends after {} rows; expected the {} and {} files \
             to have as many rows",
            n + 1,
            show_t(long.t),
            short_file,
            n,
            roles[0],
            roles[1]
        ),
    )
}

/// Saturation bookkeeping of one sensor.
struct Saturation {
    count: usize,
    first: Option<usize>,
    stretches: Vec<[f64; 2]>,
    open: bool,
}

impl Saturation {
    fn new() -> Self {
        Self {
            count: 0,
            first: None,
            stretches: Vec::new(),
            open: false,
        }
    }

    fn push(&mut self, k: usize, t: f64, saturated: bool) {
        if saturated {
            self.count += 1;
            self.first.get_or_insert(k);
            match (self.open, self.stretches.last_mut()) {
                (true, Some(s)) => s[1] = t,
                _ => self.stretches.push([t, t]),
            }
        }
        self.open = saturated;
    }
}

fn triad(table: &Table, i: usize, at: usize) -> [f64; 3] {
    [table.get(i, at), table.get(i, at + 1), table.get(i, at + 2)]
}

/// Read, convert and check the recording a profile describes.
pub fn import_recording(
    profile: &Profile,
    options: &ImportOptions,
) -> Result<Imported, ImportError> {
    let (sources, layouts) = read_sources(profile)?;
    let (gs, gl) = (&sources[0], &layouts[0]);
    let (as_, al) = (
        sources.last().expect("one or two"),
        layouts.last().expect("one or two"),
    );
    let (imu, sat_g, sat_a) = convert_records(profile, gs, gl, as_, al)?;
    let n = gs.t.len();
    let t = &gs.t;
    let (timing, gaps, gap_reports) = check_timing(profile, options, gs)?;
    check_magnitudes(profile, &imu, timing.median_interval_s, [gs, as_])?;
    let mut stuck = Stuck::default();
    imu.records.iter().for_each(|r| stuck.push(r));
    stuck
        .check(gs.table.lines[0], gs.table.lines[n - 1])
        .map_err(|message| ImportError::File {
            file: gs.table.file.clone(),
            message,
        })?;
    let static_force = check_static_force(profile, &imu, &gaps, as_)?;
    let saturation = saturation_reports(profile, [(&sat_g, gs), (&sat_a, as_)]);
    let turntable = turntable_of(profile, gs, gl);
    let sections = match &profile.sections {
        Some(s) => Some(sections::carry(
            s,
            &profile.resolve(&s.file),
            &imu,
            &profile.gyro,
            &profile.accel,
        )?),
        None => None,
    };

    let report = ImportReport {
        profile: Some(profile.origin.clone()),
        description: profile.description.clone(),
        inputs: sources.iter().map(input_file).collect(),
        form: match imu.kind {
            ImuKind::Rates => "rates",
            ImuKind::Increments => "increments",
        }
        .into(),
        records: n,
        t_first_s: t[0],
        t_last_s: t[n - 1],
        timing,
        gaps: gap_reports,
        saturation,
        static_force,
        turntable: turntable.is_some(),
        sections: sections.as_ref().map(|s| s.sections.len()),
        bag: None,
    };
    Ok(Imported {
        imu,
        turntable,
        sections,
        report,
    })
}

/// Stage 1: read the profile's input files (one, or gyro and accelerometer files joined on
/// time).
fn read_sources(profile: &Profile) -> Result<(Vec<Source>, Vec<Layout>), ImportError> {
    let mut sources = Vec::new();
    let mut layouts = Vec::new();
    for (role, path) in &profile.input_files() {
        let (s, l) = read_source(profile, role, path)?;
        sources.push(s);
        layouts.push(l);
    }
    if let [g, a] = sources.as_slice() {
        join(profile, g, a)?;
    }
    Ok((sources, layouts))
}

/// Stage 2: the records converted to SI, with the saturation of both sensors in the file's
/// values.
fn convert_records(
    profile: &Profile,
    gs: &Source,
    gl: &Layout,
    as_: &Source,
    al: &Layout,
) -> Result<(ImuData, Saturation, Saturation), ImportError> {
    let (g_at, a_at) = (gl.gyro.unwrap_or(0), al.accel.unwrap_or(0));
    let kind = match profile.form {
        Form::Rates => ImuKind::Rates,
        Form::Increments => ImuKind::Increments,
    };
    let mut records = Vec::with_capacity(gs.t.len());
    let mut sat_g = Saturation::new();
    let mut sat_a = Saturation::new();
    for (k, &tk) in gs.t.iter().enumerate() {
        let raw_g = triad(&gs.table, k, g_at);
        let raw_a = triad(&as_.table, k, a_at);
        sat_g.push(k, tk, profile.gyro.saturated(&raw_g));
        sat_a.push(k, tk, profile.accel.saturated(&raw_a));
        let temp = match (&profile.temperature, gl.temp) {
            (Some(tc), Some(j)) => Some(celsius(
                tc,
                gs.table.get(k, j),
                &gs.table.file,
                gs.table.lines[k],
                &gs.table.place(j, matches!(tc.column, Column::Name(_))),
            )?),
            _ => None,
        };
        records.push(ImuRecord {
            t: tk,
            gyro: profile.gyro.convert(raw_g),
            accel: profile.accel.convert(raw_a),
            temp,
        });
    }
    Ok((ImuData { kind, records }, sat_g, sat_a))
}

/// A file's temperature value in deg C, refused outside [`profile::TEMP_RANGE_C`] with the
/// file, the line and the field (`place`, as the reader names it).
fn celsius(
    tc: &profile::Temperature,
    raw: f64,
    file: &str,
    line: usize,
    place: &str,
) -> Result<f64, ImportError> {
    let c = tc.to_celsius(raw);
    let (lo, hi) = profile::TEMP_RANGE_C;
    if (lo..=hi).contains(&c) {
        return Ok(c);
    }
    let conversion = match tc.unit {
        profile::TempUnit::Counts => format!(
            "check [temperature] offset ({}) and sensitivity ({} counts per deg C)",
            tc.offset.unwrap_or(f64::NAN),
            tc.sensitivity.unwrap_or(f64::NAN)
        ),
        u => format!(
            "check [temperature] unit (\"{}\"; \"degC\", \"K\", \"degF\", or \"counts\" with \
             offset and sensitivity)",
            u.name()
        ),
    };
    Err(ImportError::line(
        file,
        line,
        format!(
            "temperature ({}){place}: `{}` {} gives {} deg C: expected {lo} .. {hi} deg C; \
             {conversion} and column",
            tc.column,
            raw,
            tc.unit.name(),
            show_number(c)
        ),
    ))
}

/// Stage 3, timing: jitter kept, gaps refused unless allowed.
fn check_timing(
    profile: &Profile,
    options: &ImportOptions,
    gs: &Source,
) -> Result<(timing::Timing, Vec<timing::GapAt>, Vec<GapReport>), ImportError> {
    let t = &gs.t;
    if t.len() < 2 {
        return Err(too_short(&gs.table.file, gs.table.lines[0]));
    }
    let (timing, gaps) = timing::analyse(t, profile.checks.gap_factor);
    check_time_base(
        profile,
        &gs.table.file,
        gs.table.lines[0],
        timing.median_interval_s,
    )?;
    let gap_reports = gap_reports(&gaps, &timing, &gs.table.file, |k| gs.table.lines[k]);
    if !options.allow_gaps {
        check_gaps(profile, &timing, &gap_reports, |k| gs.table.lines[k])?;
    }
    Ok((timing, gaps, gap_reports))
}

/// A recording of one row, refused.
fn too_short(file: &str, line: usize) -> ImportError {
    ImportError::line(
        file,
        line,
        "expected at least two data rows (a recording), found one",
    )
}

/// The gaps as the report lists them (`line`: the source line of a record).
fn gap_reports(
    gaps: &[GapAt],
    timing: &Timing,
    file: &str,
    line: impl Fn(usize) -> usize,
) -> Vec<GapReport> {
    gaps.iter()
        .map(|g| GapReport {
            record: g.index,
            file: file.to_string(),
            line: line(g.index),
            t_before_s: g.t_before_s,
            t_after_s: g.t_after_s,
            length_s: g.length_s(),
            median_intervals: g.length_s() / timing.median_interval_s,
        })
        .collect()
}

/// Gaps refused (without `--allow-gaps`), at the first.
fn check_gaps(
    profile: &Profile,
    timing: &Timing,
    gap_reports: &[GapReport],
    line: impl Fn(usize) -> usize,
) -> Result<(), ImportError> {
    let Some(g) = gap_reports.first() else {
        return Ok(());
    };
    Err(ImportError::line(
        &g.file,
        g.line,
        format!(
            "a gap of {} s ({:.1} median intervals of {} s) between t = {} s (line {}) and t = {} \
             s: expected intervals of at most {} median intervals ({} gap{} in all); gaps are \
             never bridged: import with gaps allowed (sins-calib import --allow-gaps) to keep \
             the records as they are with the gaps recorded in import.json",
            round_sig(g.length_s),
            g.median_intervals,
            round_sig(timing.median_interval_s),
            show_t(g.t_before_s),
            line(g.record - 1),
            show_t(g.t_after_s),
            profile.checks.gap_factor,
            gap_reports.len(),
            if gap_reports.len() == 1 { "" } else { "s" }
        ),
    ))
}

/// The median interval must be plausible for an IMU; stamps in milliseconds (or micro-,
/// nanoseconds) declared as seconds are named as such.
fn check_time_base(
    profile: &Profile,
    file: &str,
    first_line: usize,
    median: f64,
) -> Result<(), ImportError> {
    let (lo, hi) = MEDIAN_INTERVAL_RANGE_S;
    let time = &profile.time;
    let seconds = time.column.is_some() && time.unit.unwrap_or_default() == profile::TimeUnit::S;
    // An IMU records at 10 Hz .. 10 kHz: stamps declared in seconds that advance a thousand
    // (million, billion) times that interval are in a smaller unit.
    let smaller = [(1e3, "ms"), (1e6, "us"), (1e9, "ns")]
        .into_iter()
        .find(|(f, _)| (1e-4..=0.1).contains(&(median / f)));
    let cause = match (seconds, smaller) {
        (true, Some((f, unit))) if median >= 1.0 => format!(
            "the stamps look like {unit} declared as seconds (in {unit} the interval would be {} \
             s, {} Hz): set [time] unit = \"{unit}\"",
            round_sig(median / f),
            round_sig(f / median)
        ),
        _ if (lo..=hi).contains(&median) => return Ok(()),
        _ if time.column.is_some() => format!(
            "check [time] column and unit (unit = \"{}\")",
            match time.unit.unwrap_or_default() {
                profile::TimeUnit::S => "s",
                profile::TimeUnit::Ms => "ms",
                profile::TimeUnit::Us => "us",
                profile::TimeUnit::Ns => "ns",
            }
        ),
        _ => format!(
            "check [time] rate_hz = {} (and counter_column)",
            time.rate_hz.unwrap_or(f64::NAN)
        ),
    };
    Err(ImportError::line(
        file,
        first_line,
        format!(
            "the time stamps (profile {}) advance by a median {} s ({} Hz) between records: \
             expected {lo} .. {hi} s, an IMU recording at 1 Hz or more; {cause}",
            profile.origin,
            show_number(median),
            show_number(1.0 / median)
        ),
    ))
}

/// Every converted rate and specific force (increments over their own interval) must be below
/// [`MAX_GYRO_RAD_S`] and [`MAX_ACCEL_M_S2`]: the first one beyond is refused with its column,
/// line and the likely cause.
fn check_magnitudes(
    profile: &Profile,
    imu: &ImuData,
    median: f64,
    sources: [&Source; 2],
) -> Result<(), ImportError> {
    let mut previous: Option<f64> = None;
    for (k, r) in imu.records.iter().enumerate() {
        let dt = previous.map_or(median, |p| r.t - p);
        previous = Some(r.t);
        if let Some((s, i, v)) = beyond_magnitude(profile.form, r, dt) {
            let src = &sources[s].table;
            return Err(magnitude_error(profile, s, i, v, &src.file, src.lines[k]));
        }
    }
    Ok(())
}

/// The first sensor (0 gyro, 1 accelerometer), axis and value of a record beyond the plausible
/// magnitude (`dt`: its interval, for increments).
fn beyond_magnitude(form: Form, r: &ImuRecord, dt: f64) -> Option<(usize, usize, f64)> {
    let scale = if form == Form::Increments {
        1.0 / dt
    } else {
        1.0
    };
    for (s, (values, max)) in [(r.gyro, MAX_GYRO_RAD_S), (r.accel, MAX_ACCEL_M_S2)]
        .into_iter()
        .enumerate()
    {
        for (i, v) in values.iter().enumerate() {
            let v = v * scale;
            if v.abs() >= max {
                return Some((s, i, v));
            }
        }
    }
    None
}

/// The refusal of a converted value `v` of sensor `s` (0 gyro, 1 accelerometer), axis `i`,
/// beyond the plausible magnitude, on `line` of `file`.
fn magnitude_error(
    profile: &Profile,
    s: usize,
    i: usize,
    v: f64,
    file: &str,
    line: usize,
) -> ImportError {
    let increments = profile.form == Form::Increments;
    let (name, sensor, max, unit) = if s == 0 {
        ("gyro", &profile.gyro, MAX_GYRO_RAD_S, "rad/s")
    } else {
        ("accel", &profile.accel, MAX_ACCEL_M_S2, "m/s^2")
    };
    let source = sensor.axes[i].source;
    let conversion = if sensor.unit == Unit::Counts {
        format!(
            "check [{name}] offset and sensitivity (counts per {}, here {:e}) and \
             sensitivity_unit",
            sensor.sensitivity_unit.map_or("?", Unit::name),
            sensor.sensitivity.map_or(f64::NAN, |s| s[source])
        )
    } else {
        format!(
            "the values look like raw counts: set [{name}] unit = \"counts\" with offset and \
             sensitivity (unit is \"{}\")",
            sensor.unit.name()
        )
    };
    ImportError::line(
        file,
        line,
        format!(
            "{name} {} ({}) gives {:.4e} {unit}{} after conversion: expected a magnitude below \
             {max} {unit}; {conversion}; check the columns in {}",
            ["x", "y", "z"][i],
            sensor.columns[source],
            v,
            if increments {
                " (increment over its interval)"
            } else {
                ""
            },
            profile.origin
        ),
    )
}

/// Stage 4: the saturation reports of the sensors with a range (gyro, then accelerometer).
fn saturation_reports(
    profile: &Profile,
    found: [(&Saturation, &Source); 2],
) -> Vec<SaturationReport> {
    let line_g = |k: usize| found[0].1.table.lines[k];
    let line_a = |k: usize| found[1].1.table.lines[k];
    saturation_reports_of(
        profile,
        [
            (found[0].0, &found[0].1.table.file, &line_g),
            (found[1].0, &found[1].1.table.file, &line_a),
        ],
    )
}

/// A sensor's saturation, its file, and the source line of a record.
type SaturationOf<'a> = (&'a Saturation, &'a str, &'a dyn Fn(usize) -> usize);

/// [`saturation_reports`] with each sensor's file and the source line of a record.
fn saturation_reports_of(profile: &Profile, found: [SaturationOf<'_>; 2]) -> Vec<SaturationReport> {
    [&profile.gyro, &profile.accel]
        .into_iter()
        .zip(["gyro", "accel"])
        .zip(found)
        .filter_map(|((sensor, name), (s, file, line))| {
            sensor.range.map(|range| SaturationReport {
                sensor: name.into(),
                range,
                count: s.count,
                file: file.to_string(),
                first_line: s.first.map(line),
                stretches: s.stretches.clone(),
            })
        })
        .collect()
}

/// Stage 5: the turntable angles of the gyro file, when the profile has them (degrees).
fn turntable_of(profile: &Profile, gs: &Source, gl: &Layout) -> Option<TurntableData> {
    profile.angles.as_ref().zip(gl.angles).map(|(a, at)| {
        let f = match a.unit {
            AngleUnit::Deg => 1.0,
            AngleUnit::Rad => 180.0 / std::f64::consts::PI,
        };
        TurntableData {
            records: (0..gs.t.len())
                .map(|k| TurntableRecord {
                    t: gs.t[k],
                    k_deg: triad(&gs.table, k, at).map(|v| v * f),
                })
                .collect(),
        }
    })
}

/// An input file of the report.
fn input_file(s: &Source) -> InputFile {
    InputFile {
        role: s.role.into(),
        file: s.table.file.clone(),
        rows: s.table.rows(),
        first_line: s.table.lines[0],
        last_line: *s.table.lines.last().expect("rows"),
    }
}

/// Rounded to 4 significant digits, for messages.
fn round_sig(x: f64) -> f64 {
    round_to(x, 4)
}

/// Rounded to `digits` significant digits (shown without the float noise of sums such as
/// `1.0600000000000001`).
fn round_to(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    if !scale.is_finite() || scale == 0.0 {
        return x;
    }
    (x * scale).round() / scale
}

/// A number for messages: 4 significant digits, in exponent form when very large or small
/// (`1e300` rather than 301 digits).
fn show_number(x: f64) -> String {
    if x != 0.0 && !(1e-4..1e7).contains(&x.abs()) {
        format!("{x:.3e}")
    } else {
        format!("{}", round_sig(x))
    }
}

/// A time stamp for messages: 10 significant digits.
fn show_t(t: f64) -> f64 {
    round_to(t, 10)
}

/// The specific force in the quietest window must be near g; else the import is refused with
/// the likely cause.
fn check_static_force(
    profile: &Profile,
    imu: &ImuData,
    gaps: &[GapAt],
    src: &Source,
) -> Result<StaticForce, ImportError> {
    let (t, _, f) = detect::rates_of(imu);
    let (a, b, std) = detect::quietest_window(&t, &f, QUIET_WINDOW_S, gaps);
    let mut norms: Vec<f64> = f[a..b]
        .iter()
        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
        .collect();
    static_force(
        profile,
        timing::median_of(&mut norms),
        std,
        [t[a], t[b - 1]],
        &src.table.file,
        [src.table.lines[a], src.table.lines[b - 1]],
    )
}

/// The check of the median specific force `median` over the quietest window (`window_s`, on
/// `lines` of `file`) against g.
fn static_force(
    profile: &Profile,
    median: f64,
    std: f64,
    window_s: [f64; 2],
    file: &str,
    lines: [usize; 2],
) -> Result<StaticForce, ImportError> {
    let ratio = median / STANDARD_GRAVITY;
    let found = StaticForce {
        median_norm_m_s2: median,
        ratio_to_g: ratio,
        window_s,
        std_m_s2: std,
    };
    if (G_BAND.0..=G_BAND.1).contains(&ratio) {
        return Ok(found);
    }
    let cause = force_cause(&profile.accel, profile.form, ratio);
    Err(ImportError::line(
        file,
        lines[0],
        format!(
            "the specific force at rest has a median magnitude of {} m/s^2 ({} g) over lines \
             {}..{} (t = {} .. {} s, the quietest {} s of the recording): expected g = {} m/s^2 \
             within {} to {} g; {cause}",
            round_sig(median),
            round_sig(ratio),
            lines[0],
            lines[1],
            show_t(window_s[0]),
            show_t(window_s[1]),
            QUIET_WINDOW_S,
            STANDARD_GRAVITY,
            G_BAND.0,
            G_BAND.1
        ),
    ))
}

/// The likely cause of a specific force at rest of `ratio` g.
fn force_cause(accel: &Sensor, form: Form, ratio: f64) -> String {
    let near = |x: f64| (0.8 * x..=1.2 * x).contains(&ratio);
    let per = |u: Option<Unit>| u.map_or("?", Unit::name);
    let increments = if form == Form::Increments {
        " (increments are divided by their record interval: check that the file holds velocity \
         increments, not specific force)"
    } else {
        ""
    };
    let cause = if ratio < 0.01 {
        "the accelerometers read almost nothing: check [accel] columns (a gyro or a counter \
         column?) and, for counts, the offset"
            .to_string()
    } else if accel.unit == Unit::Counts {
        let su = accel.sensitivity_unit;
        if su == Some(Unit::MPerS2) && near(1.0 / STANDARD_GRAVITY) {
            "about 1/9.81 of g: the sensitivity looks given in counts per g, not per m/s^2 \
             (sensitivity_unit = \"g\")"
                .to_string()
        } else if su == Some(Unit::G) && near(STANDARD_GRAVITY) {
            "about 9.81 g: the sensitivity looks given in counts per m/s^2, not per g \
             (sensitivity_unit = \"m/s^2\")"
                .to_string()
        } else {
            format!(
                "check the accelerometer offset (counts at zero) and sensitivity (counts per {}), \
                 and the columns",
                per(su)
            )
        }
    } else if ratio > 100.0 {
        format!(
            "the values look like raw counts: set unit = \"counts\" with offset and sensitivity \
             (unit is \"{}\")",
            accel.unit.name()
        )
    } else if accel.unit == Unit::MPerS2 && near(1.0 / STANDARD_GRAVITY) {
        "the accelerometers look given in g, not m/s^2: set unit = \"g\"".to_string()
    } else if accel.unit == Unit::G && near(STANDARD_GRAVITY) {
        "the accelerometers look given in m/s^2, not g: set unit = \"m/s^2\"".to_string()
    } else {
        format!(
            "check the accelerometer unit (unit = \"{}\") and columns",
            accel.unit.name()
        )
    };
    cause + increments
}

/// The files [`write_outputs`] wrote.
#[derive(Clone, Debug)]
pub struct Written {
    /// `imu.csv`.
    pub imu: PathBuf,
    /// `turntable.csv`, when the source has angles.
    pub turntable: Option<PathBuf>,
    /// `sections.json`, when the profile has a section list.
    pub sections: Option<PathBuf>,
    /// `import.json`.
    pub report: PathBuf,
}

/// Write `imu.csv`, `turntable.csv` (with angles), `sections.json` (with a section list) and
/// `import.json` into `dir` (created when missing; files there are overwritten).
pub fn write_outputs(imported: &Imported, dir: &Path) -> Result<Written, ImportError> {
    std::fs::create_dir_all(dir).map_err(|source| ImportError::Write {
        file: dir.display().to_string(),
        source,
    })?;
    let imu = dir.join("imu.csv");
    calib::io::write_imu_csv(&imu, &imported.imu)?;
    let turntable = match &imported.turntable {
        Some(tt) => {
            let p = dir.join("turntable.csv");
            calib::io::write_turntable_csv(&p, tt)?;
            Some(p)
        }
        None => None,
    };
    let json = |path: &Path, text: String| {
        std::fs::write(path, text + "\n").map_err(|source| ImportError::Write {
            file: path.display().to_string(),
            source,
        })
    };
    let sections = match &imported.sections {
        Some(s) => {
            let p = dir.join("sections.json");
            json(&p, serde_json::to_string_pretty(s).expect("plain data"))?;
            Some(p)
        }
        None => None,
    };
    let report = dir.join("import.json");
    json(
        &report,
        serde_json::to_string_pretty(&imported.report).expect("plain data"),
    )?;
    Ok(Written {
        imu,
        turntable,
        sections,
        report,
    })
}
