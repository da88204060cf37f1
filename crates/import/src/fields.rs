//! The parts of an import profile ([`crate::profile`]) that the readers and the section list
//! use as well: the layout of the input files (`Input`, `Delimiter`, `Join`, `Column`), the sensor
//! triads and their units (`Sensor`, `Axis`, `Unit`, `SensorKind`, `Form`) and the section-list
//! source. Here and not in the profile module so that the readers (`text`) and the sections
//! (`sections`) depend on these types alone, while the profile, which checks the section list's
//! turn with `sections::check_turn`, depends on them: one direction only. The profile module
//! re-exports every item, its public paths unchanged.

use crate::error::ImportError;
use serde::{Deserialize, Deserializer};

/// Standard gravity (m/s^2), the value of the unit `g` (ISO 80000-3).
pub const STANDARD_GRAVITY: f64 = 9.80665;

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
pub(crate) fn exactly<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
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

    /// Each source axis once, and the map a rotation.
    fn check_axes(&self) -> Result<(), String> {
        let mut seen = [false; 3];
        for a in &self.axes {
            if seen[a.source] {
                return Err(format!(
                    "axes = [{}]: source axis {} is used twice; expected each of x, y, z once \
                     (with an optional sign)",
                    self.axes.map(|a| format!("\"{a}\"")).join(", "),
                    ["x", "y", "z"][a.source]
                ));
            }
            seen[a.source] = true;
        }
        // The determinant of the map (a signed permutation): -1 is a reflection. A left-handed
        // frame turns every rotation the wrong way, so a calibration of the imported records
        // diverges (scale factors of 100 %) instead of being refused here.
        let det = {
            let m: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    if self.axes[i].source == j {
                        self.axes[i].sign
                    } else {
                        0.0
                    }
                })
            });
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        if det < 0.0 {
            return Err(format!(
                "axes = [{}]: a reflection (determinant -1), not a rotation: expected a map \
                 that keeps the frame right-handed (swapping two axes, or flipping one sign, \
                 needs one more sign flip), else every turn is read the wrong way round",
                self.axes.map(|a| format!("\"{a}\"")).join(", ")
            ));
        }
        Ok(())
    }

    pub(crate) fn check(
        &self,
        kind: SensorKind,
        form: Form,
        file: &str,
    ) -> Result<(), ImportError> {
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
        if let Err(m) = self.check_axes() {
            return err(m);
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
