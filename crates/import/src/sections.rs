//! A source's section list (imucal) carried into `sections.json` beside `imu.csv`, on the
//! records and axes of the imported file; the file's types, reader and checks are calib's
//! ([`calib::motion::sections`]).

use crate::error::ImportError;
use crate::fields::{SectionsSource, Sensor};
use crate::text::excerpt;
use calib::io::ImuKind;
pub use calib::motion::sections::{MAX_TURN_DEG, Section, SectionKind, SectionsFile, check_turn};
use serde::Deserialize;
use std::path::Path;

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
        .map_err(|source| ImportError::read(&file, source))?;
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
