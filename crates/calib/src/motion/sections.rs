//! Section lists: the labelled parts of a calibration session (static faces, rotations) on the
//! records and axes of `imu.csv` (`sections.json`; format: `docs/formats.md`, "Sections file"),
//! read and checked, and their rotations as known turns. `import` writes them from a source's
//! list.

use crate::io::IoError;
use crate::motion::rests::{Rest, Turn};
use crate::motion::stamps::Stamps;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The largest plausible specific force (m/s^2, about 200 g): a section's mean beyond it is
/// refused, and `import` refuses records beyond it.
pub const MAX_ACCEL_M_S2: f64 = 2000.0;

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
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let file = path.display().to_string();
        let text = sins_model::text::read_text_bounded(
            path,
            sins_model::text::SECTIONS_MAX_BYTES,
            "section list",
        )
        .map_err(|source| IoError::Read {
            file: file.clone(),
            source,
        })?;
        let list: Self = serde_json::from_str(&text).map_err(|e| IoError::Line {
            file: file.clone(),
            line: e.line(),
            message: format!("expected a sections file (docs/formats.md): {e}"),
        })?;
        list.check_values()
            .map_err(|message| IoError::File { file, message })?;
        Ok(list)
    }

    /// Refuse numbers no section has, naming the section and the field: a turn beyond
    /// [`MAX_TURN_DEG`] (or 0), times and forces that are not finite, a specific force beyond
    /// [`MAX_ACCEL_M_S2`]. (The records and unit vectors are checked against the IMU
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
                .any(|f| f.is_nan() || f.abs() >= MAX_ACCEL_M_S2)
            {
                return Err(format!(
                    "section `{}`: mean_f_m_s2 = {:?}: expected a specific force below {} m/s^2 \
                     on each axis",
                    s.name,
                    s.mean_f_m_s2.map(shown),
                    MAX_ACCEL_M_S2
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
    /// the first record of the rest after it ([`Rest::records`]; the
    /// span the coarse fit carries the attitude over from one rest to the next); never from the
    /// first record. The stamps may be counted in a reading ([`Stamps`]): they are asked for the
    /// rests' times and the records of [`Self::turn_records`].
    pub fn known_turns(&self, rests: &[Rest], t: &dyn Stamps) -> Vec<Turn> {
        self.turn_bounds(rests, t)
            .into_iter()
            .filter_map(|(s, first, last)| {
                Turn::about(
                    &s.name,
                    (t.stamp(first)?, t.stamp(last)?),
                    s.axis?,
                    s.expected_turn_deg?.to_radians(),
                )
            })
            .collect()
    }

    /// The records whose stamps [`Self::known_turns`] takes (on stamps that answer for the
    /// rests' times).
    pub fn turn_records(&self, rests: &[Rest], t: &dyn Stamps) -> Vec<usize> {
        self.turn_bounds(rests, t)
            .into_iter()
            .flat_map(|(_, first, last)| [first, last])
            .collect()
    }

    /// Every rotation of the list with the first and last record of its known turn.
    fn turn_bounds(&self, rests: &[Rest], t: &dyn Stamps) -> Vec<(&Section, usize, usize)> {
        let rest_records: Vec<std::ops::Range<usize>> = rests
            .iter()
            .map(|r| r.records(t))
            .filter(|r| !r.is_empty())
            .collect();
        self.sections
            .iter()
            .filter(|s| s.kind == SectionKind::Rotation)
            .map(|s| {
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
                (s, first.max(1), last)
            })
            .collect()
    }

    /// Check the sections against the records they are said to index (`times`: the time stamps
    /// of `imu.csv`): every section's records inside the file, in order, and its stamped start and
    /// end on those records' time stamps (within half the median interval). A section list of
    /// another recording, or of an earlier import of this one, is refused here rather than
    /// silently used or skipped. `Err` holds the message: which section, and what was expected.
    ///
    /// The stamps may be counted in a reading ([`Stamps`]): they are asked for the sections'
    /// first and last records, and the median interval.
    pub fn check_records(&self, times: &dyn Stamps) -> Result<(), String> {
        let n = times.count();
        let tolerance = 0.5 * times.median_interval();
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
            let stamp = |k: usize| times.stamp(k).unwrap_or(f64::NAN);
            let (t0, t1) = (stamp(s.first_record), stamp(s.last_record));
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
