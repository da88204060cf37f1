//! Import profiles: how a recording in another layout maps onto `imu.csv` (TOML, documented with
//! a full table in `docs/formats.md`, section "Import profile").
//!
//! A profile names the input files (one file, or separate gyro and accelerometer files joined on
//! time or row), how they are delimited, which lines to skip, which column is which, the time
//! base (a time column, a sample counter and a rate, or a rate alone), whether the sensors give
//! rates or increments, their units (physical, or counts with an offset and a sensitivity per
//! axis), the axis mapping with sign flips, and optionally the sensor ranges (for saturation),
//! turntable angles and a section list. Unknown fields are refused.
//!
//! Relative paths in a profile resolve against the directory of the profile file.

use crate::error::ImportError;
use crate::fields::exactly;
pub use crate::fields::{
    Axis, Column, Delimiter, Form, Input, Join, STANDARD_GRAVITY, SectionsFormat, SectionsSource,
    Sensor, SensorKind, Unit,
};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A parsed and checked import profile.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// Free text naming the instrument or the recording (printed, written to `import.json`).
    #[serde(default)]
    pub description: Option<String>,
    /// The unit recorded (`[unit]`: model, serial), written to `import.json` and from there into
    /// a calibration of the imported records.
    #[serde(default)]
    pub unit: calib::config::UnitIdentity,
    /// Whether the sensors give rates (`"rates"`: angular rate and specific force) or increments
    /// (`"increments"`: angle and velocity increments over the interval ending at the time stamp).
    pub form: Form,
    /// The input files and their text layout.
    pub input: Input,
    /// Where the time of each record comes from.
    pub time: Time,
    /// The gyro columns and their conversion.
    pub gyro: Sensor,
    /// The accelerometer columns and their conversion.
    pub accel: Sensor,
    /// Turntable angle columns, when the recording has them (written to `turntable.csv`).
    #[serde(default)]
    pub angles: Option<Angles>,
    /// A temperature column, written to `imu.csv`'s `temp` column in deg C (in the single
    /// input file, or in the gyro file with two files).
    #[serde(default)]
    pub temperature: Option<Temperature>,
    /// A section list carried into `sections.json`.
    #[serde(default)]
    pub sections: Option<SectionsSource>,
    /// Limits of the timing checks.
    #[serde(default)]
    pub checks: Checks,
    /// The profile's own file name, for messages (set by [`Profile::load`]).
    #[serde(skip)]
    pub origin: String,
    /// The directory relative paths resolve against (set by [`Profile::load`]).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

/// The time base of the records.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Time {
    /// The time-stamp column (in each input file).
    #[serde(default)]
    pub column: Option<Column>,
    /// Unit of the time column: `"s"` (the default), `"ms"`, `"us"` or `"ns"`.
    #[serde(default)]
    pub unit: Option<TimeUnit>,
    /// A sample-counter column: t = counter / `rate_hz`.
    #[serde(default)]
    pub counter_column: Option<Column>,
    /// Sample rate (Hz): with `counter_column`, t = counter / rate_hz; alone (no time column),
    /// the k-th data row (from 0) has t = k / rate_hz.
    #[serde(default)]
    pub rate_hz: Option<f64>,
}

/// Unit of a time column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum TimeUnit {
    /// Seconds.
    #[default]
    #[serde(rename = "s")]
    S,
    /// Milliseconds.
    #[serde(rename = "ms")]
    Ms,
    /// Microseconds.
    #[serde(rename = "us")]
    Us,
    /// Nanoseconds.
    #[serde(rename = "ns")]
    Ns,
}

impl TimeUnit {
    /// Units per second (a value is divided by this: exact for decimal milliseconds).
    pub fn per_second(self) -> f64 {
        match self {
            TimeUnit::S => 1.0,
            TimeUnit::Ms => 1e3,
            TimeUnit::Us => 1e6,
            TimeUnit::Ns => 1e9,
        }
    }
}

/// Turntable angle columns (in the single input file, or in the gyro file with two files).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Angles {
    /// Heading, bank and pitch gimbal-angle columns (`k1, k2, k3`).
    #[serde(deserialize_with = "exactly")]
    pub columns: [Column; 3],
    /// `"deg"` or `"rad"`.
    pub unit: AngleUnit,
}

/// Unit of turntable angles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AngleUnit {
    /// Degrees.
    Deg,
    /// Radians.
    Rad,
}

/// Temperatures outside this range (deg C, after conversion) are refused: no IMU works there,
/// and a value outside it is a wrong column or unit (a counter, raw counts read as degrees).
pub const TEMP_RANGE_C: (f64, f64) = (-100.0, 200.0);

/// A temperature column and its unit.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Temperature {
    /// The column (in the single input file, or in the gyro file with two files).
    pub column: Column,
    /// `"degC"`, `"K"`, `"degF"` or `"counts"` (with `offset` and `sensitivity`).
    pub unit: TempUnit,
    /// Counts only: the reading at 0 deg C (counts).
    #[serde(default)]
    pub offset: Option<f64>,
    /// Counts only: counts per deg C (signed).
    #[serde(default)]
    pub sensitivity: Option<f64>,
}

/// Unit of a temperature column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum TempUnit {
    /// Degrees Celsius.
    #[serde(rename = "degC")]
    DegC,
    /// Kelvin.
    #[serde(rename = "K")]
    Kelvin,
    /// Degrees Fahrenheit.
    #[serde(rename = "degF")]
    DegF,
    /// Raw counts: `(value - offset) / sensitivity` deg C.
    #[serde(rename = "counts")]
    Counts,
}

impl TempUnit {
    /// The unit as a profile names it.
    pub fn name(self) -> &'static str {
        match self {
            TempUnit::DegC => "degC",
            TempUnit::Kelvin => "K",
            TempUnit::DegF => "degF",
            TempUnit::Counts => "counts",
        }
    }
}

impl Temperature {
    /// The temperature in deg C of a file value.
    pub fn to_celsius(&self, raw: f64) -> f64 {
        match self.unit {
            TempUnit::DegC => raw,
            TempUnit::Kelvin => raw - 273.15,
            TempUnit::DegF => (raw - 32.0) * (5.0 / 9.0),
            TempUnit::Counts => match (self.offset, self.sensitivity) {
                (Some(o), Some(s)) => (raw - o) / s,
                _ => f64::NAN, // excluded by `check`
            },
        }
    }

    fn check(&self, file: &str) -> Result<(), ImportError> {
        let err = |m: String| Err(ImportError::profile(file, m));
        match (self.unit, self.offset, self.sensitivity) {
            (TempUnit::Counts, Some(o), Some(s)) => {
                if !o.is_finite() {
                    return err(format!(
                        "[temperature] offset = {o}: expected the finite reading at 0 deg C                          (counts)"
                    ));
                }
                if !(s.is_finite() && s != 0.0) {
                    return err(format!(
                        "[temperature] sensitivity = {s}: expected finite, non-zero counts per                          deg C"
                    ));
                }
            }
            (TempUnit::Counts, _, _) => {
                return err(
                    "[temperature] unit = \"counts\" needs offset (the reading at 0 deg \
                            C) and sensitivity (counts per deg C): deg C = (value - offset) / \
                            sensitivity"
                        .into(),
                );
            }
            (u, o, s) if o.is_some() || s.is_some() => {
                return err(format!(
                    "[temperature] offset and sensitivity apply to unit = \"counts\" only (unit \
                     is \"{}\")",
                    u.name()
                ));
            }
            _ => {}
        }
        Ok(())
    }
}

/// Limits of the timing checks.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checks {
    /// An interval longer than this many median intervals is a gap. Default 1.5.
    #[serde(default = "default_gap_factor")]
    pub gap_factor: f64,
}

fn default_gap_factor() -> f64 {
    1.5
}

impl Default for Checks {
    fn default() -> Self {
        Self {
            gap_factor: default_gap_factor(),
        }
    }
}

/// Bounds of `[time] rate_hz` (Hz): a record rate from a tenth of a hertz, or the tick rate of
/// a sample counter up to a nanosecond clock.
pub const RATE_HZ_RANGE: (f64, f64) = (1e-3, 1e9);

/// The largest `[input] join_tolerance_s` (s): records of an IMU come at least once every ten
/// seconds (the time-base check), so a tolerance of a second or more pairs unrelated rows.
pub const MAX_JOIN_TOLERANCE_S: f64 = 1.0;

impl Profile {
    /// Each column of each input file used for one thing only (the time column is in every
    /// file; with two files the gyro and angle columns are in the gyro file, the accelerometer
    /// columns in the accelerometer file).
    fn check_columns_used_once(&self) -> Result<(), ImportError> {
        let mut time: Vec<(String, &Column)> = Vec::new();
        if let Some(c) = &self.time.column {
            time.push(("[time] column".into(), c));
        }
        if let Some(c) = &self.time.counter_column {
            time.push(("[time] counter_column".into(), c));
        }
        fn triad<'a>(
            table: &str,
            columns: &'a [Column; 3],
            names: [&str; 3],
        ) -> Vec<(String, &'a Column)> {
            columns
                .iter()
                .zip(names)
                .map(|(c, a)| (format!("[{table}] columns ({a})"), c))
                .collect()
        }
        let xyz = ["x", "y", "z"];
        let mut gyro_file = time.clone();
        gyro_file.extend(triad("gyro", &self.gyro.columns, xyz));
        if let Some(a) = &self.angles {
            gyro_file.extend(triad("angles", &a.columns, ["k1", "k2", "k3"]));
        }
        if let Some(t) = &self.temperature {
            gyro_file.push(("[temperature] column".into(), &t.column));
        }
        let accel = triad("accel", &self.accel.columns, xyz);
        let files = if self.input.file.is_some() {
            gyro_file.extend(accel);
            vec![gyro_file]
        } else {
            let mut accel_file = time;
            accel_file.extend(accel);
            vec![gyro_file, accel_file]
        };
        for uses in &files {
            for (i, (what, c)) in uses.iter().enumerate() {
                if let Some((first, _)) = uses[..i].iter().find(|(_, d)| d == c) {
                    return Err(ImportError::profile(
                        &self.origin,
                        format!(
                            "{c} is used twice, as {first} and as {what}: expected each column \
                             to hold one quantity (check the column numbers or names)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Read and check a profile; relative paths in it resolve against its directory.
    pub fn load(path: &Path) -> Result<Self, ImportError> {
        let file = path.display().to_string();
        let text = sins_model::text::read_text_bounded(
            path,
            sins_model::text::PROFILE_MAX_BYTES,
            "import profile",
        )
        .map_err(|source| ImportError::read(&file, source))?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Self::parse(&text, &file, &base)
    }

    /// Parse and check a profile's text; `file` names it in messages, relative paths resolve
    /// against `base_dir`.
    pub fn parse(text: &str, file: &str, base_dir: &Path) -> Result<Self, ImportError> {
        let mut p: Profile = toml::from_str(text)
            .map_err(|e| ImportError::profile(file, e.to_string().trim_end().to_string()))?;
        p.origin = file.to_string();
        p.base_dir = base_dir.to_path_buf();
        p.check()?;
        Ok(p)
    }

    /// A path of the profile resolved against its base directory.
    pub fn resolve(&self, path: &str) -> PathBuf {
        let p = Path::new(path);
        if p.is_absolute() || self.base_dir.as_os_str().is_empty() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    /// The input files: `(role, path)` with role `"imu"` for a single file, else `"gyro"` and
    /// `"accel"`.
    pub fn input_files(&self) -> Vec<(&'static str, PathBuf)> {
        match (
            &self.input.file,
            &self.input.gyro_file,
            &self.input.accel_file,
        ) {
            (Some(f), _, _) => vec![("imu", self.resolve(f))],
            (None, Some(g), Some(a)) => vec![("gyro", self.resolve(g)), ("accel", self.resolve(a))],
            _ => Vec::new(), // excluded by `check`
        }
    }

    fn check(&self) -> Result<(), ImportError> {
        let file = self.origin.as_str();
        let err = |m: String| Err(ImportError::profile(file, m));
        check_input(&self.input, file)?;
        check_time(&self.time, file)?;
        self.gyro.check(SensorKind::Gyro, self.form, file)?;
        self.accel.check(SensorKind::Accel, self.form, file)?;
        self.check_columns()?;
        if !(self.checks.gap_factor.is_finite() && self.checks.gap_factor > 1.0) {
            return err(format!(
                "[checks] gap_factor = {}: expected a number above 1 (an interval longer than \
                 gap_factor median intervals is a gap)",
                self.checks.gap_factor
            ));
        }
        if let Some(s) = &self.sections
            && let Err(e) = crate::sections::check_turn(s.expected_turn_deg)
        {
            return err(format!("[sections] expected_turn_deg = {e}"));
        }
        Ok(())
    }

    /// The temperature's conversion, each column used once, and a header line where a column
    /// is given by name.
    fn check_columns(&self) -> Result<(), ImportError> {
        let t = &self.time;
        let named = |c: &Column| matches!(c, Column::Name(_));
        let mut columns: Vec<&Column> = Vec::new();
        columns.extend(t.column.iter());
        columns.extend(t.counter_column.iter());
        columns.extend(self.gyro.columns.iter());
        columns.extend(self.accel.columns.iter());
        if let Some(a) = &self.angles {
            columns.extend(a.columns.iter());
        }
        if let Some(t) = &self.temperature {
            t.check(&self.origin)?;
            columns.push(&t.column);
        }
        self.check_columns_used_once()?;
        if let Some(c) = columns.iter().find(|c| named(c))
            && self.input.header_line.is_none()
        {
            return Err(ImportError::profile(
                &self.origin,
                format!(
                    "{c} is given by name: expected [input] header_line, the line that names the \
                     columns (or give columns by 1-based number)"
                ),
            ));
        }
        Ok(())
    }
}

/// The `[input]` table: one file or two, a comment marker, the header line among the skipped
/// lines, the join tolerance.
fn check_input(i: &Input, file: &str) -> Result<(), ImportError> {
    let err = |m: String| Err(ImportError::profile(file, m));
    match (&i.file, &i.gyro_file, &i.accel_file) {
        (Some(_), None, None) | (None, Some(_), Some(_)) => {}
        _ => {
            return err(
                "[input] expected either file = \"...\" (one file with every column) \
                        or both gyro_file and accel_file (separate files joined on time or \
                        row)"
                    .into(),
            );
        }
    }
    if let Some(c) = &i.comment
        && c.trim().is_empty()
    {
        return err(
            "[input] comment = \"\": expected the text that starts a comment line, \
                    e.g. \"#\""
                .into(),
        );
    }
    if let Some(h) = i.header_line
        && !(1..=i.skip_lines).contains(&h)
    {
        return err(format!(
            "[input] header_line = {h}: expected one of the {} skipped lines (skip_lines \
             counts the header too)",
            i.skip_lines
        ));
    }
    if let Some(t) = i.join_tolerance_s
        && !(t.is_finite() && t > 0.0 && t <= MAX_JOIN_TOLERANCE_S)
    {
        return err(format!(
            "[input] join_tolerance_s = {t:e}: expected a positive number of seconds, at most \
             {MAX_JOIN_TOLERANCE_S} s (and below half the records' interval: it pairs each \
             gyro row with the accelerometer row of the same time)"
        ));
    }
    Ok(())
}

/// The `[time]` table: one time base, a unit only for a time column, the rate in range.
fn check_time(t: &Time, file: &str) -> Result<(), ImportError> {
    let err = |m: String| Err(ImportError::profile(file, m));
    match (&t.column, &t.counter_column, t.rate_hz) {
        (Some(_), None, None) | (None, Some(_), Some(_)) | (None, None, Some(_)) => {}
        (Some(_), _, Some(_)) | (Some(_), Some(_), None) => {
            return err(
                "[time] expected one time base: column (a time-stamp column), or \
                        counter_column with rate_hz, or rate_hz alone"
                    .into(),
            );
        }
        (None, Some(_), None) => {
            return err("[time] counter_column needs rate_hz (t = counter / rate_hz)".into());
        }
        (None, None, None) => {
            return err(
                "[time] expected column (a time-stamp column), counter_column with \
                        rate_hz, or rate_hz alone"
                    .into(),
            );
        }
    }
    if t.unit.is_some() && t.column.is_none() {
        return err(
            "[time] unit applies to a time column (column = ...) only: a counter \
                    or a row number counts samples at rate_hz"
                .into(),
        );
    }
    if let Some(r) = t.rate_hz
        && !(r.is_finite() && (RATE_HZ_RANGE.0..=RATE_HZ_RANGE.1).contains(&r))
    {
        return err(format!(
            "[time] rate_hz = {r:e}: expected a rate of {} .. {} Hz (the record rate, or the \
             tick rate of a sample counter up to a nanosecond clock)",
            RATE_HZ_RANGE.0, RATE_HZ_RANGE.1
        ));
    }
    Ok(())
}
