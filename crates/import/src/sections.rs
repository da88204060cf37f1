//! Section lists: the labelled parts of a calibration session (static faces, rotations) carried
//! from the source's list into `sections.json` beside `imu.csv`, on the records and axes of the
//! imported file (format: `docs/formats.md`, "Sections file").

use crate::error::ImportError;
use crate::fields::{SectionsSource, Sensor};
use crate::text::excerpt;
use calib::io::{ImuData, ImuKind};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What a section is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SectionKind {
    /// The unit at rest with one axis up or down.
    Static,
    /// A turn about one axis.
    Rotation,
}

/// One section, on the imported records.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Section {
    /// Name in the source list (`x_p`, `y_rot`, ...).
    pub name: String,
    /// Static face or rotation.
    pub kind: SectionKind,
    /// First data row in the source list's terms (0-based row position).
    pub source_start: usize,
    /// End in the source list's terms (0-based row position, exclusive).
    pub source_end: usize,
    /// 0-based index of the section's first record in `imu.csv` (line `first_record + 2`).
    pub first_record: usize,
    /// 0-based index of its last record.
    pub last_record: usize,
    /// Time stamp of the first record (s).
    pub start_s: f64,
    /// Time stamp of the last record (s).
    pub end_s: f64,
    /// Static faces: the body axis that points up (unit vector in the axes of `imu.csv`): the
    /// specific force at rest is `g` times this.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f64; 3]>,
    /// Rotations: the body axis of the turn (unit vector in the axes of `imu.csv`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f64; 3]>,
    /// Rotations: the turn the section was meant to make about `axis`, right-handed (deg) (the
    /// profile's `expected_turn_deg`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expected_turn_deg: Option<f64>,
    /// Rotations: the uncalibrated gyro about `axis` integrated over the section's records (each
    /// rate times its own interval) (deg).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured_turn_deg: Option<f64>,
    /// Mean specific force over the section, body axes (m/s^2).
    pub mean_f_m_s2: [f64; 3],
}

/// The contents of `sections.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SectionsFile {
    /// The source list, as the profile named it (resolved path).
    pub source: String,
    /// Its format (`"imucal"`).
    pub format: String,
    /// The sections in time order.
    pub sections: Vec<Section>,
}

/// The largest turn a section may make (deg, either sign): ten turns, far above a hand-made
/// turn (one) and below what a typing error gives (`1e300`, whose radians no filter takes).
pub const MAX_TURN_DEG: f64 = 3600.0;

/// A number as written in a message: plain for ordinary magnitudes, in exponent form for the
/// extremes.
fn shown(v: f64) -> String {
    if v == 0.0 || (1e-4..1e7).contains(&v.abs()) || !v.is_finite() {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Check a turn's angle: finite, not zero, at most [`MAX_TURN_DEG`] in magnitude; `Err` holds
/// the value and the range, for a message that names the field.
pub fn check_turn(deg: f64) -> Result<(), String> {
    if deg.is_finite() && deg != 0.0 && deg.abs() <= MAX_TURN_DEG {
        Ok(())
    } else {
        Err(format!(
            "{}: expected a turn in degrees, not 0 and at most {MAX_TURN_DEG} (ten turns) in \
             magnitude",
            shown(deg)
        ))
    }
}

impl SectionsFile {
    /// A section by name.
    pub fn get(&self, name: &str) -> Option<&Section> {
        self.sections.iter().find(|s| s.name == name)
    }

    /// Read a `sections.json`.
    pub fn read(path: &Path) -> Result<Self, ImportError> {
        let file = path.display().to_string();
        let text = sins_model::text::read_text_bounded(
            path,
            sins_model::text::SECTIONS_MAX_BYTES,
            "section list",
        )
        .map_err(|source| ImportError::Read {
            file: file.clone(),
            source,
        })?;
        let list: Self = serde_json::from_str(&text).map_err(|e| {
            ImportError::line(
                &file,
                e.line(),
                format!("expected a sections file (docs/formats.md): {e}"),
            )
        })?;
        list.check_values()
            .map_err(|message| ImportError::file(&file, message))?;
        Ok(list)
    }

    /// Refuse numbers no section has, naming the section and the field: a turn beyond
    /// [`MAX_TURN_DEG`] (or 0), times and forces that are not finite, a specific force beyond
    /// [`crate::MAX_ACCEL_M_S2`]. (The records and unit vectors are checked against the IMU
    /// file by [`Self::check_records`].)
    fn check_values(&self) -> Result<(), String> {
        for s in &self.sections {
            for (field, v) in [
                ("expected_turn_deg", s.expected_turn_deg),
                ("measured_turn_deg", s.measured_turn_deg),
            ] {
                if let Some(v) = v
                    && let Err(e) = check_turn(v)
                {
                    // A measured turn may be 0 (a turn that did not happen is the data's to
                    // show); only its size is bounded.
                    if field == "expected_turn_deg" || v.is_nan() || v.abs() > MAX_TURN_DEG {
                        return Err(format!("section `{}`: {field} = {e}", s.name));
                    }
                }
            }
            for (field, v) in [("start_s", s.start_s), ("end_s", s.end_s)] {
                if !v.is_finite() {
                    return Err(format!(
                        "section `{}`: {field} = {v}: expected a finite time stamp",
                        s.name
                    ));
                }
            }
            if s.mean_f_m_s2
                .iter()
                .any(|f| f.is_nan() || f.abs() >= crate::MAX_ACCEL_M_S2)
            {
                return Err(format!(
                    "section `{}`: mean_f_m_s2 = {:?}: expected a specific force below {} m/s^2 \
                     on each axis",
                    s.name,
                    s.mean_f_m_s2.map(shown),
                    crate::MAX_ACCEL_M_S2
                ));
            }
        }
        Ok(())
    }
}

impl SectionsFile {
    /// The known turns of the list on the records stamped `t`: its rotations with an expected
    /// angle and an axis, each widened to the whole motion between the `rests` around it (a
    /// list's bounds may cut off the start or end of the turn; the rest on either side adds only
    /// the bias, which is calibrated): from the first record after the rest before it through
    /// the first record of the rest after it ([`calib::motion::rests::Rest::records`]; the
    /// span the coarse fit carries the attitude over from one rest to the next); never from the
    /// first record.
    pub fn known_turns(
        &self,
        rests: &[calib::motion::rests::Rest],
        t: &[f64],
    ) -> Vec<calib::motion::rests::Turn> {
        let rest_records: Vec<std::ops::Range<usize>> = rests
            .iter()
            .map(|r| r.records(t))
            .filter(|r| !r.is_empty())
            .collect();
        self.sections
            .iter()
            .filter(|s| s.kind == SectionKind::Rotation)
            .filter_map(|s| {
                let first = rest_records
                    .iter()
                    .filter(|r| r.end <= s.first_record)
                    .map(|r| r.end)
                    .next_back()
                    .unwrap_or(s.first_record);
                let last = rest_records
                    .iter()
                    .find(|r| r.start > s.last_record)
                    .map_or(s.last_record, |r| r.start);
                calib::motion::rests::Turn::about(
                    &s.name,
                    (*t.get(first.max(1))?, *t.get(last)?),
                    s.axis?,
                    s.expected_turn_deg?.to_radians(),
                )
            })
            .collect()
    }

    /// Check the sections against the records they are said to index (`times`: the time stamps
    /// of `imu.csv`): every section's records inside the file, in order, and its stamped start and
    /// end on those records' time stamps (within half the median interval). A section list of
    /// another recording, or of an earlier import of this one, is refused here rather than
    /// silently used or skipped. `Err` holds the message: which section, and what was expected.
    pub fn check_records(&self, times: &[f64]) -> Result<(), String> {
        let n = times.len();
        let tolerance = 0.5 * calib::io::timing::median_interval(times);
        for s in &self.sections {
            for (what, v) in [("up", s.up), ("axis", s.axis)] {
                let Some(v) = v else { continue };
                let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                // A unit vector as written by `import` (to 17 digits); a zero axis gave 39
                // parameters of 0 +- 0 and nulls in the result.
                if !(norm - 1.0).abs().le(&1e-6) {
                    return Err(format!(
                        "section `{}`: `{what}` = {v:?} has length {norm}: expected a unit \
                         vector in the axes of the IMU file",
                        s.name
                    ));
                }
            }
            if s.first_record > s.last_record || s.last_record >= n {
                return Err(format!(
                    "section `{}` spans records {} .. {}, but the IMU file has {n} records \
                     (0 .. {}): a section list of another recording?",
                    s.name,
                    s.first_record,
                    s.last_record,
                    n.saturating_sub(1)
                ));
            }
            let (t0, t1) = (times[s.first_record], times[s.last_record]);
            let off = (t0 - s.start_s).abs().max((t1 - s.end_s).abs());
            // A NaN (a non-finite stamp) is refused too.
            if off.is_nan() || off > tolerance {
                return Err(format!(
                    "section `{}`: start_s .. end_s = {} .. {} s, but its records are stamped \
                     {t0} .. {t1} s in the IMU file: a section list of another recording, or of \
                     another import?",
                    s.name,
                    shown(s.start_s),
                    shown(s.end_s)
                ));
            }
        }
        Ok(())
    }
}

/// The entries of a JSON object in file order, a key given twice refused (a map would keep
/// the last one silently).
struct Entries(Vec<(String, serde_json::Value)>);

impl<'de> Deserialize<'de> for Entries {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Entries;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a JSON object of sections")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut m: A,
            ) -> Result<Entries, A::Error> {
                let mut v: Vec<(String, serde_json::Value)> = Vec::new();
                while let Some((k, value)) = m.next_entry::<String, serde_json::Value>()? {
                    if v.iter().any(|(n, _)| *n == k) {
                        return Err(serde::de::Error::custom(format!(
                            "section `{}` is listed twice: expected each section once",
                            excerpt(&k)
                        )));
                    }
                    v.push((k, value));
                }
                Ok(Entries(v))
            }
        }
        d.deserialize_map(V)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Bounds {
    start: usize,
    end: usize,
}

/// What an imucal name says: kind, source axis (0..3) and, for static faces, the sign of the
/// axis that points up.
fn parse_name(name: &str) -> Option<(SectionKind, usize, f64)> {
    let (axis, rest) = name.split_once('_')?;
    let axis = match axis {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        _ => return None,
    };
    match rest {
        "p" => Some((SectionKind::Static, axis, 1.0)),
        "a" => Some((SectionKind::Static, axis, -1.0)),
        "rot" => Some((SectionKind::Rotation, axis, 1.0)),
        _ => None,
    }
}

/// Read an imucal section list and put it on the imported records (`data`, whose record `k` is
/// data row `k` of the source) with the sensors' axis mappings.
pub(crate) fn carry(
    source: &SectionsSource,
    path: &Path,
    data: &ImuData,
    gyro: &Sensor,
    accel: &Sensor,
) -> Result<SectionsFile, ImportError> {
    let t: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    let median = calib::io::timing::median_interval(&t);
    let mut carried = Carry::new(source, path, data.records.len(), data.kind, median, gyro)?;
    for r in &data.records {
        carried.push(r.t, r.gyro, r.accel);
    }
    Ok(carried.finish(accel))
}

/// One section of the list as it is being carried.
struct Open {
    name: String,
    kind: SectionKind,
    axis: usize,
    sign: f64,
    bounds: Bounds,
    /// Rotations: the gyro axis of the turn in the output axes.
    dir: [f64; 3],
    count: f64,
    mean_f: [f64; 3],
    turn: f64,
    start_s: f64,
    end_s: f64,
    dt0: f64,
}

/// A section list put on the records given one at a time, in order ([`Carry::push`]): what is
/// summed over each section is summed as the records come, so the records need not be held.
pub(crate) struct Carry {
    file: String,
    expected_turn_deg: f64,
    kind: ImuKind,
    median: f64,
    sections: Vec<Open>,
    k: usize,
    previous: f64,
}

impl Carry {
    /// Read and check the list against `n` records of this `kind` (`median`: their median
    /// interval, the first record's own).
    pub(crate) fn new(
        source: &SectionsSource,
        path: &Path,
        n: usize,
        kind: ImuKind,
        median: f64,
        gyro: &Sensor,
    ) -> Result<Self, ImportError> {
        let file = path.display().to_string();
        let text = sins_model::text::read_text_bounded(
            path,
            sins_model::text::SECTIONS_MAX_BYTES,
            "section list",
        )
        .map_err(|source| ImportError::Read {
            file: file.clone(),
            source,
        })?;
        let Entries(list) = serde_json::from_str(&text).map_err(|e| {
            ImportError::line(
                &file,
                e.line(),
                format!(
                    "expected an imucal section list, a JSON object {{\"x_p\": {{\"start\": 540, \
                     \"end\": 1271}}, ...}}: {e}"
                ),
            )
        })?;
        let mut sections = Vec::new();
        for (name, value) in list {
            let Some((kind, axis, sign)) = parse_name(&name) else {
                return Err(ImportError::file(
                    &file,
                    format!(
                        "section `{}`: expected imucal's names x_p, x_a, y_p, y_a, z_p, z_a \
                         (static faces: that axis up or down) and x_rot, y_rot, z_rot \
                         (rotations)",
                        excerpt(&name)
                    ),
                ));
            };
            let b: Bounds = serde_json::from_value(value).map_err(|e| {
                ImportError::file(
                    &file,
                    format!(
                        "section `{name}`: expected {{\"start\": row, \"end\": row}} (0-based \
                         data rows, end exclusive): {e}"
                    ),
                )
            })?;
            if !(b.start < b.end && b.end <= n) {
                return Err(ImportError::file(
                    &file,
                    format!(
                        "section `{name}`: start {} and end {}: expected 0 <= start < end <= \
                         {n}, the number of data rows imported (rows are 0-based, end \
                         exclusive)",
                        b.start, b.end
                    ),
                ));
            }
            sections.push(Open {
                name,
                kind,
                axis,
                sign,
                dir: gyro.map_direction(axis, 1.0),
                count: (b.end - b.start) as f64,
                bounds: b,
                mean_f: [0.0; 3],
                turn: 0.0,
                start_s: f64::NAN,
                end_s: f64::NAN,
                dt0: f64::NAN,
            });
        }
        Ok(Self {
            file,
            expected_turn_deg: source.expected_turn_deg,
            kind,
            median,
            sections,
            k: 0,
            previous: f64::NAN,
        })
    }

    /// The next record.
    pub(crate) fn push(&mut self, t: f64, gyro: [f64; 3], accel: [f64; 3]) {
        let k = self.k;
        let dt = if k == 0 {
            self.median
        } else {
            t - self.previous
        };
        for s in &mut self.sections {
            if k < s.bounds.start || k >= s.bounds.end {
                continue;
            }
            if k == s.bounds.start {
                s.start_s = t;
                s.dt0 = dt;
            }
            s.end_s = t;
            for (m, a) in s.mean_f.iter_mut().zip(accel) {
                *m += a / s.count;
            }
            if s.kind == SectionKind::Rotation {
                let d = s.dir;
                let along = gyro[0] * d[0] + gyro[1] * d[1] + gyro[2] * d[2];
                s.turn += match self.kind {
                    ImuKind::Rates => along * dt,
                    ImuKind::Increments => along,
                };
            }
        }
        self.previous = t;
        self.k += 1;
    }

    /// The sections, in time order.
    pub(crate) fn finish(self, accel: &Sensor) -> SectionsFile {
        let mut sections: Vec<Section> = self
            .sections
            .into_iter()
            .map(|s| {
                let (a, z) = (s.bounds.start, s.bounds.end - 1);
                let mut mean_f = s.mean_f;
                if self.kind == ImuKind::Increments {
                    // Velocity increments: the mean force is their sum over the section's span.
                    let span = s.end_s - s.start_s + s.dt0;
                    mean_f = mean_f.map(|v| v * s.count / span);
                }
                let mut section = Section {
                    name: s.name,
                    kind: s.kind,
                    source_start: s.bounds.start,
                    source_end: s.bounds.end,
                    first_record: a,
                    last_record: z,
                    start_s: s.start_s,
                    end_s: s.end_s,
                    up: None,
                    axis: None,
                    expected_turn_deg: None,
                    measured_turn_deg: None,
                    mean_f_m_s2: mean_f,
                };
                match s.kind {
                    SectionKind::Static => section.up = Some(accel.map_direction(s.axis, s.sign)),
                    SectionKind::Rotation => {
                        section.axis = Some(s.dir);
                        section.expected_turn_deg = Some(self.expected_turn_deg);
                        section.measured_turn_deg = Some(s.turn.to_degrees());
                    }
                }
                section
            })
            .collect();
        sections.sort_by_key(|s| s.first_record);
        SectionsFile {
            source: self.file,
            format: "imucal".into(),
            sections,
        }
    }
}
