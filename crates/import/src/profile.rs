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
use serde::{Deserialize, Deserializer};
use std::path::{Path, PathBuf};

/// Standard gravity (m/s^2), the value of the unit `g` (ISO 80000-3).
pub const STANDARD_GRAVITY: f64 = 9.80665;

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

/// Rates or increments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Form {
    /// Angular rate and specific force: written as `t,wx,wy,wz,fx,fy,fz`.
    Rates,
    /// Angle and velocity increments: written as `t,dthx,dthy,dthz,dvx,dvy,dvz`.
    Increments,
}

/// The input files and their text layout.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Input {
    /// One file holding every column.
    #[serde(default)]
    pub file: Option<String>,
    /// The gyro file, when the gyro and accelerometer come in separate files.
    #[serde(default)]
    pub gyro_file: Option<String>,
    /// The accelerometer file, with `gyro_file`.
    #[serde(default)]
    pub accel_file: Option<String>,
    /// Field separator: `"whitespace"` (any run of spaces and tabs) or one character such as
    /// `","`, `";"`, `"\t"`, `"|"`. Default `","`.
    #[serde(default)]
    pub delimiter: Delimiter,
    /// Lines at the top of each file that hold no data (a header, a preamble). Default 0.
    #[serde(default)]
    pub skip_lines: usize,
    /// The line (1-based, among the skipped lines) that names the columns; needed when columns
    /// are given by name.
    #[serde(default)]
    pub header_line: Option<usize>,
    /// Lines starting with this text (after leading spaces) are comments and skipped anywhere.
    #[serde(default)]
    pub comment: Option<String>,
    /// How two files are paired: `"time"` (records with the same time stamp, within
    /// `join_tolerance_s`) or `"row"` (the n-th data row of one with the n-th of the other).
    /// Default `"time"`.
    #[serde(default)]
    pub join: Join,
    /// Largest difference of two time stamps taken as the same record when joining (s);
    /// default a tenth of the gyro file's median interval.
    #[serde(default)]
    pub join_tolerance_s: Option<f64>,
}

/// Field separator of the input files.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Delimiter {
    /// One character (fields are trimmed of spaces).
    Char(char),
    /// A comma, the default (fields are trimmed of spaces).
    #[default]
    Comma,
    /// Any run of spaces and tabs; leading and trailing ones are ignored.
    Whitespace,
}

impl Delimiter {
    /// The separator as a message names it.
    pub fn describe(self) -> String {
        match self {
            Delimiter::Comma => "','".into(),
            Delimiter::Char('\t') => "tabs".into(),
            Delimiter::Char(c) => format!("'{c}'"),
            Delimiter::Whitespace => "whitespace".into(),
        }
    }

    /// Split a line into its fields (trimmed).
    pub fn split<'a>(self, line: &'a str) -> Box<dyn Iterator<Item = &'a str> + 'a> {
        match self {
            Delimiter::Comma => Box::new(line.split(',').map(str::trim)),
            Delimiter::Char(c) => Box::new(line.split(c).map(str::trim)),
            Delimiter::Whitespace => Box::new(line.split_whitespace()),
        }
    }
}

impl<'de> Deserialize<'de> for Delimiter {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        let mut chars = s.chars();
        match (s.as_str(), chars.next(), chars.next()) {
            ("whitespace", _, _) => Ok(Delimiter::Whitespace),
            (_, Some(','), None) => Ok(Delimiter::Comma),
            (_, Some(c), None)
                if !(c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '+' | ' ')) =>
            {
                Ok(Delimiter::Char(c))
            }
            _ => Err(serde::de::Error::custom(format!(
                "delimiter `{s}`: expected \"whitespace\" or one character that cannot be part of \
                 a number, such as \",\", \";\", \"\\t\" or \"|\""
            ))),
        }
    }
}

/// Pairing of two input files.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Join {
    /// Records with the same time stamp (within the tolerance); a row of either file without a
    /// partner is refused.
    #[default]
    Time,
    /// The n-th data row of one file with the n-th of the other; both must have as many rows,
    /// and where there are time stamps they must agree within the tolerance.
    Row,
}

/// A column: its 1-based number, or its name on the header line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Column {
    /// 1-based column number.
    Number(usize),
    /// Name on the profile's `input.header_line`.
    Name(String),
}

impl std::fmt::Display for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Column::Number(n) => write!(f, "column {n}"),
            Column::Name(s) => write!(f, "column `{s}`"),
        }
    }
}

impl<'de> Deserialize<'de> for Column {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Column;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a 1-based column number or a column name from the header line")
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Column, E> {
                if v >= 1 {
                    Ok(Column::Number(v as usize))
                } else {
                    Err(E::custom(format!(
                        "column {v}: expected a 1-based column number (1 is the first column) or \
                         a column name"
                    )))
                }
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Column, E> {
                self.visit_i64(i64::try_from(v).unwrap_or(i64::MAX))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Column, E> {
                if v.trim().is_empty() {
                    return Err(E::custom(
                        "empty column name: expected a column name from the header line or a \
                         1-based column number",
                    ));
                }
                Ok(Column::Name(v.trim().to_string()))
            }
        }
        d.deserialize_any(V)
    }
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

/// A unit of sensor values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum Unit {
    /// Radians per second (gyro rates).
    #[serde(rename = "rad/s")]
    RadPerS,
    /// Degrees per second (gyro rates).
    #[serde(rename = "deg/s")]
    DegPerS,
    /// Metres per second squared (specific force).
    #[serde(rename = "m/s^2")]
    MPerS2,
    /// Standard gravity, 9.80665 m/s^2 (specific force).
    #[serde(rename = "g")]
    G,
    /// Radians (angle increments).
    #[serde(rename = "rad")]
    Rad,
    /// Degrees (angle increments).
    #[serde(rename = "deg")]
    Deg,
    /// Metres per second (velocity increments).
    #[serde(rename = "m/s")]
    MPerS,
    /// Raw counts: converted with `offset` and `sensitivity` (counts per `sensitivity_unit`).
    #[serde(rename = "counts")]
    Counts,
}

impl Unit {
    /// The unit as written in a profile.
    pub fn name(self) -> &'static str {
        match self {
            Unit::RadPerS => "rad/s",
            Unit::DegPerS => "deg/s",
            Unit::MPerS2 => "m/s^2",
            Unit::G => "g",
            Unit::Rad => "rad",
            Unit::Deg => "deg",
            Unit::MPerS => "m/s",
            Unit::Counts => "counts",
        }
    }

    /// SI value of one unit (rad/s, m/s^2, rad, m/s); `None` for counts.
    pub fn si_factor(self) -> Option<f64> {
        Some(match self {
            Unit::RadPerS | Unit::MPerS2 | Unit::Rad | Unit::MPerS => 1.0,
            Unit::DegPerS | Unit::Deg => std::f64::consts::PI / 180.0,
            Unit::G => STANDARD_GRAVITY,
            Unit::Counts => return None,
        })
    }

    /// The physical units a sensor of this kind may have in this form.
    pub fn allowed(sensor: SensorKind, form: Form) -> &'static [Unit] {
        match (sensor, form) {
            (SensorKind::Gyro, Form::Rates) => &[Unit::RadPerS, Unit::DegPerS],
            (SensorKind::Accel, Form::Rates) => &[Unit::MPerS2, Unit::G],
            (SensorKind::Gyro, Form::Increments) => &[Unit::Rad, Unit::Deg],
            (SensorKind::Accel, Form::Increments) => &[Unit::MPerS],
        }
    }
}

/// Which sensor triad.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorKind {
    /// The gyros.
    Gyro,
    /// The accelerometers.
    Accel,
}

impl SensorKind {
    /// `"gyro"` or `"accel"`, as the profile's tables are named.
    pub fn name(self) -> &'static str {
        match self {
            SensorKind::Gyro => "gyro",
            SensorKind::Accel => "accel",
        }
    }
}

/// One output axis: which source axis, and its sign.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    /// Source axis 0, 1, 2 (x, y, z of the file's columns).
    pub source: usize,
    /// +1 or -1.
    pub sign: f64,
}

impl Axis {
    /// The identity mapping: output x, y, z = source x, y, z.
    pub const IDENTITY: [Axis; 3] = [
        Axis {
            source: 0,
            sign: 1.0,
        },
        Axis {
            source: 1,
            sign: 1.0,
        },
        Axis {
            source: 2,
            sign: 1.0,
        },
    ];
}

impl std::fmt::Display for Axis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = if self.sign < 0.0 { '-' } else { '+' };
        write!(f, "{s}{}", ["x", "y", "z"][self.source])
    }
}

impl<'de> Deserialize<'de> for Axis {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        let t = s.trim();
        let (sign, rest) = match t.as_bytes().first() {
            Some(b'-') => (-1.0, &t[1..]),
            Some(b'+') => (1.0, &t[1..]),
            _ => (1.0, t),
        };
        let source = match rest {
            "x" | "X" => 0,
            "y" | "Y" => 1,
            "z" | "Z" => 2,
            _ => {
                return Err(serde::de::Error::custom(format!(
                    "axis `{s}`: expected a source axis with an optional sign: \"+x\", \"-x\", \
                     \"+y\", \"-y\", \"+z\" or \"-z\""
                )));
            }
        };
        Ok(Axis { source, sign })
    }
}

/// A sensor triad: its columns and their conversion to SI.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sensor {
    /// The x, y, z columns of the source (in the gyro or accelerometer file with two files).
    #[serde(deserialize_with = "exactly")]
    pub columns: [Column; 3],
    /// Unit of the values: for rates `"rad/s"`, `"deg/s"` (gyro), `"m/s^2"`, `"g"` (accel); for
    /// increments `"rad"`, `"deg"` (gyro), `"m/s"` (accel); or `"counts"`.
    pub unit: Unit,
    /// Counts only: the reading at zero, per source axis (counts).
    #[serde(default, deserialize_with = "some_exactly")]
    pub offset: Option<[f64; 3]>,
    /// Counts only: counts per `sensitivity_unit`, per source axis.
    #[serde(default, deserialize_with = "some_exactly")]
    pub sensitivity: Option<[f64; 3]>,
    /// Counts only: the physical unit the sensitivity is given per (one of the units above).
    #[serde(default)]
    pub sensitivity_unit: Option<Unit>,
    /// Output axes x, y, z from the source axes, with sign flips, e.g. `["+y", "+x", "-z"]`: the
    /// output x is the source y, the output z the negated source z. Default `["+x","+y","+z"]`.
    #[serde(default = "identity_axes", deserialize_with = "exactly")]
    pub axes: [Axis; 3],
    /// The sensor's range `[lowest, highest]` in the file's values (counts for counts): a record
    /// with any axis at or beyond either end is counted as saturated.
    #[serde(default, deserialize_with = "some_exactly")]
    pub range: Option<[f64; 2]>,
}

/// A list of exactly `N` values (a longer or shorter one is refused, not cut or padded).
fn exactly<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    let v = Vec::<T>::deserialize(d)?;
    let n = v.len();
    v.try_into().map_err(|_| {
        serde::de::Error::custom(format!(
            "a list of {n} values: expected exactly {N} (one per axis)"
        ))
    })
}

/// [`exactly`] for an optional field.
fn some_exactly<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    exactly(d).map(Some)
}

fn identity_axes() -> [Axis; 3] {
    Axis::IDENTITY
}

impl Sensor {
    /// SI value of source axis `k` from the file's value.
    pub fn to_si(&self, k: usize, raw: f64) -> f64 {
        match (
            self.unit.si_factor(),
            self.offset,
            self.sensitivity,
            self.sensitivity_unit,
        ) {
            (Some(f), _, _, _) => raw * f,
            (None, Some(o), Some(s), Some(u)) => (raw - o[k]) / s[k] * u.si_factor().unwrap_or(1.0),
            _ => f64::NAN, // excluded by `check`
        }
    }

    /// The output triad (SI, output axes) from the file's values of the source axes.
    pub fn convert(&self, raw: [f64; 3]) -> [f64; 3] {
        let si = [
            self.to_si(0, raw[0]),
            self.to_si(1, raw[1]),
            self.to_si(2, raw[2]),
        ];
        self.axes.map(|a| a.sign * si[a.source])
    }

    /// The output-frame vector of a source axis direction (`sign` times the source unit vector).
    pub fn map_direction(&self, source: usize, sign: f64) -> [f64; 3] {
        let mut v = [0.0; 3];
        for (i, a) in self.axes.iter().enumerate() {
            if a.source == source {
                v[i] = a.sign * sign;
            }
        }
        v
    }

    /// Whether a file value lies at or beyond the range.
    pub fn saturated(&self, raw: &[f64; 3]) -> bool {
        self.range
            .is_some_and(|[lo, hi]| raw.iter().any(|&v| v <= lo || v >= hi))
    }

    fn check(&self, kind: SensorKind, form: Form, file: &str) -> Result<(), ImportError> {
        let name = kind.name();
        let allowed = Unit::allowed(kind, form);
        let list = |units: &[Unit]| {
            units
                .iter()
                .map(|u| format!("\"{}\"", u.name()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let form_name = match form {
            Form::Rates => "rates",
            Form::Increments => "increments",
        };
        let err = |m: String| Err(ImportError::profile(file, format!("[{name}] {m}")));
        if self.unit == Unit::Counts {
            let (Some(o), Some(s), Some(u)) =
                (self.offset, self.sensitivity, self.sensitivity_unit)
            else {
                return err(
                    "unit = \"counts\" needs offset = [x, y, z] (counts at zero), sensitivity = \
                     [x, y, z] (counts per sensitivity_unit) and sensitivity_unit"
                        .into(),
                );
            };
            if !allowed.contains(&u) {
                return err(format!(
                    "sensitivity_unit = \"{}\": expected one of {} for {name} {form_name}",
                    u.name(),
                    list(allowed)
                ));
            }
            if let Some(v) = o.iter().find(|v| !v.is_finite()) {
                return err(format!("offset {v}: expected finite numbers"));
            }
            if let Some(v) = s.iter().find(|v| !(v.is_finite() && **v != 0.0)) {
                return err(format!(
                    "sensitivity {v}: expected finite non-zero counts per {}",
                    u.name()
                ));
            }
        } else {
            if !allowed.contains(&self.unit) {
                return err(format!(
                    "unit = \"{}\": expected one of {} or \"counts\" for {name} {form_name}",
                    self.unit.name(),
                    list(allowed)
                ));
            }
            if self.offset.is_some()
                || self.sensitivity.is_some()
                || self.sensitivity_unit.is_some()
            {
                return err(format!(
                    "offset, sensitivity and sensitivity_unit apply to unit = \"counts\" only \
                     (unit is \"{}\")",
                    self.unit.name()
                ));
            }
        }
        let mut seen = [false; 3];
        for a in &self.axes {
            if seen[a.source] {
                return err(format!(
                    "axes = [{}]: source axis {} is used twice; expected each of x, y, z once \
                     (with an optional sign)",
                    self.axes.map(|a| format!("\"{a}\"")).join(", "),
                    ["x", "y", "z"][a.source]
                ));
            }
            seen[a.source] = true;
        }
        if let Some([lo, hi]) = self.range
            && !(lo.is_finite() && hi.is_finite() && lo < hi)
        {
            return err(format!(
                "range = [{lo}, {hi}]: expected [lowest, highest] with lowest < highest, finite"
            ));
        }
        Ok(())
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

/// A section list to carry into `sections.json`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SectionsSource {
    /// The section-list file.
    pub file: String,
    /// Its format; only `"imucal"` (a JSON object `{"x_p": {"start": 540, "end": 1271}, ...}`
    /// with 0-based data-row positions, end exclusive) for now.
    #[serde(default)]
    pub format: SectionsFormat,
    /// The turn each `*_rot` section was meant to make about its axis (deg), signed (right-hand
    /// rule about the source axis). imucal's convention, and the default: -360.
    #[serde(default = "default_turn")]
    pub expected_turn_deg: f64,
}

fn default_turn() -> f64 {
    -360.0
}

/// Formats of section lists.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SectionsFormat {
    /// imucal's section list as JSON.
    #[default]
    Imucal,
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
        .map_err(|source| ImportError::Read {
            file: file.clone(),
            source,
        })?;
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
        let i = &self.input;
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
        let t = &self.time;
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
        self.gyro.check(SensorKind::Gyro, self.form, file)?;
        self.accel.check(SensorKind::Accel, self.form, file)?;
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
            t.check(file)?;
            columns.push(&t.column);
        }
        self.check_columns_used_once()?;
        if let Some(c) = columns.iter().find(|c| named(c))
            && i.header_line.is_none()
        {
            return err(format!(
                "{c} is given by name: expected [input] header_line, the line that names the \
                 columns (or give columns by 1-based number)"
            ));
        }
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
}
