//! What an import read, found and wrote: the report (`import.json`) and its parts, the
//! saturation and gap bookkeeping that fills them, and the files written.

use crate::bag;
use crate::profile::Profile;
use calib::io::timing::{GapAt, Timing};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

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
    /// Gaps (only with [`crate::ImportOptions::allow_gaps`]; otherwise the import is refused).
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

/// Saturation bookkeeping of one sensor.
pub(crate) struct Saturation {
    pub(crate) count: usize,
    pub(crate) first: Option<usize>,
    pub(crate) stretches: Vec<[f64; 2]>,
    pub(crate) open: bool,
}

impl Saturation {
    pub(crate) fn new() -> Self {
        Self {
            count: 0,
            first: None,
            stretches: Vec::new(),
            open: false,
        }
    }

    pub(crate) fn push(&mut self, k: usize, t: f64, saturated: bool) {
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

/// The gaps as the report lists them (`line`: the source line of a record).
pub(crate) fn gap_reports(
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

/// A sensor's saturation, its file, and the source line of a record.
pub(crate) type SaturationOf<'a> = (&'a Saturation, &'a str, &'a dyn Fn(usize) -> usize);

/// The saturation reports of the sensors with a range (gyro, then accelerometer), from each
/// sensor's bookkeeping, file and the source line of a record.
pub(crate) fn saturation_reports_of(
    profile: &Profile,
    found: [SaturationOf<'_>; 2],
) -> Vec<SaturationReport> {
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

/// The files an import wrote ([`crate::import_into`], [`crate::import_bag`]).
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
