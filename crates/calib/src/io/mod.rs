//! The interchange formats (`docs`/design notes): `imu.csv`, `turntable.csv` and result JSON.
//!
//! - `imu.csv`: a header row, then `t,dthx,dthy,dthz,dvx,dvy,dvz` (increments over the interval
//!   ending at `t`, rad and m/s) or `t,wx,wy,wz,fx,fy,fz` (rates, rad/s and m/s^2), with an
//!   optional `temp` column (deg C). Columns may come in any order; `t` is on the IMU clock.
//! - `turntable.csv`: a header row, then `t,k1,k2,k3` (turntable clock, gimbal angles in degrees,
//!   heading-bank-pitch).
//! - results: `{"parameters": [{"name", "value", "sigma", "unit"}...]}`, SI units; `sigma` is
//!   left out for a truth file.
//!
//! Bad input is refused with an [`IoError`] naming the file, the 1-based line (the header is
//! line 1) and what was expected; nothing is dropped silently. Writers use the shortest text that
//! reads back to the identical `f64`.
//!
//! The CSV files are read by hand, not with the `csv` crate (about 1.8 times as fast for the
//! same checks and messages: `docs/performance.md`, "readers"): in large blocks, lines found
//! with `memchr`, UTF-8 checked a block at a time, fields split at commas and parsed with the
//! `fast-float2` crate, which gives the `f64` that `str::parse` gives and refuses what it
//! refuses. The reader takes no more than the format allows (`docs/formats.md`): no quoting and
//! no comments, `\n` or `\r\n` line ends, fields trimmed of spaces; every line is checked (UTF-8,
//! blank lines, a line end after the last one, number of fields, numbers).

pub mod angle_records;
pub mod correction_block;
mod csv_lines;
mod csv_rows;
mod imu_csv;
pub mod posterior;
mod result_json;
pub mod schema;
pub mod source;
pub mod timing;
mod turntable_csv;
pub use imu_csv::{
    ImuCsvWriter, ImuReader, TEMP_RANGE_DEG_C, format_imu_csv, parse_imu_csv, read_imu_csv,
    write_imu_csv,
};
pub use result_json::{
    RESULT_KINDS, ResultFile, ResultParameter, ResultTemperature, ResultVerdict, read_result_json,
    write_result_json, write_truth_json,
};
pub use turntable_csv::{
    TurntableCsvWriter, TurntableReader, format_turntable_csv, parse_turntable_csv,
    read_turntable_csv, write_turntable_csv,
};

/// The shortest recording calibrated (s, first to last time stamp).
pub const MIN_RECORDING_S: f64 = 1.0;

use serde::{Deserialize, Serialize};
use std::path::Path;
use turntable::simulate::{ImuSample, TurntableSample};

/// Errors reading or writing interchange files.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Read {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{file}: cannot write: {source}")]
    Write {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// A line does not have the expected form.
    #[error("{file}: line {line}: {message}")]
    Line {
        /// File name.
        file: String,
        /// 1-based line number (header = 1).
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// The file as a whole is unusable (e.g. it does not overlap the IMU data in time).
    #[error("{file}: {message}")]
    File {
        /// File name.
        file: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A JSON file of another kind, or of a newer layout than this program reads (the message
    /// names the file).
    #[error("{message}")]
    Stamp {
        /// What was found and what was expected, with the file.
        message: String,
    },
    /// JSON that is not a result file.
    #[error("{file}: not a result file: {source}")]
    Json {
        /// File name.
        file: String,
        /// Cause (with line and column).
        source: serde_json::Error,
    },
}

/// What the IMU file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ImuKind {
    /// `dthx..dvz`: angle increments (rad) and velocity increments (m/s) over the interval ending
    /// at `t`.
    Increments,
    /// `wx..fz`: angular rate (rad/s) and specific force (m/s^2) at `t`.
    Rates,
}

impl ImuKind {
    /// The six data columns, gyro triad first.
    pub fn columns(self) -> [&'static str; 6] {
        match self {
            ImuKind::Increments => ["dthx", "dthy", "dthz", "dvx", "dvy", "dvz"],
            ImuKind::Rates => ["wx", "wy", "wz", "fx", "fy", "fz"],
        }
    }
}

/// One IMU row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuRecord {
    /// Time on the IMU clock (s) (end of the interval for increments).
    pub t: f64,
    /// `dth` (rad) or `w` (rad/s), body axes.
    pub gyro: [f64; 3],
    /// `dv` (m/s) or `f` (m/s^2), body axes.
    pub accel: [f64; 3],
    /// Temperature (deg C), when the file has a `temp` column.
    pub temp: Option<f64>,
}

impl ImuRecord {
    /// An increments record from the truth simulator.
    pub fn from_sample(s: &ImuSample) -> Self {
        Self {
            t: s.t,
            gyro: [s.dtheta.x, s.dtheta.y, s.dtheta.z],
            accel: [s.dv.x, s.dv.y, s.dv.z],
            temp: s.temp,
        }
    }
}

/// The contents of an `imu.csv`.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuData {
    /// Increments or rates.
    pub kind: ImuKind,
    /// Rows in time order (strictly increasing `t`).
    pub records: Vec<ImuRecord>,
}

impl ImuData {
    /// Increments from the truth simulator.
    pub fn from_samples(samples: &[ImuSample]) -> Self {
        Self {
            kind: ImuKind::Increments,
            records: samples.iter().map(ImuRecord::from_sample).collect(),
        }
    }

    /// First and last time stamp, `None` without records.
    pub fn span(&self) -> Option<(f64, f64)> {
        Some((self.records.first()?.t, self.records.last()?.t))
    }
}

/// One turntable row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurntableRecord {
    /// Time on the turntable clock (s).
    pub t: f64,
    /// Gimbal angles (heading, bank, pitch) (deg).
    pub k_deg: [f64; 3],
}

impl TurntableRecord {
    /// A record from the truth simulator.
    pub fn from_sample(s: &TurntableSample) -> Self {
        Self {
            t: s.t_tt,
            k_deg: s.k_deg,
        }
    }
}

/// The contents of a `turntable.csv`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TurntableData {
    /// Rows in time order (strictly increasing `t`).
    pub records: Vec<TurntableRecord>,
}

impl TurntableData {
    /// Records from the truth simulator.
    pub fn from_samples(samples: &[TurntableSample]) -> Self {
        Self {
            records: samples.iter().map(TurntableRecord::from_sample).collect(),
        }
    }

    /// First and last time stamp (turntable clock), `None` without records.
    pub fn span(&self) -> Option<(f64, f64)> {
        Some((self.records.first()?.t, self.records.last()?.t))
    }
}

/// Turntable columns.
pub const TURNTABLE_COLUMNS: [&str; 4] = ["t", "k1", "k2", "k3"];

fn line_error(file: &str, line: usize, message: String) -> IoError {
    IoError::Line {
        file: file.to_string(),
        line,
        message,
    }
}

/// A result or truth JSON, bounded ([`sins_model::text::RESULT_MAX_BYTES`]).
fn read_text(path: &Path) -> Result<String, IoError> {
    sins_model::text::read_text_bounded(
        path,
        sins_model::text::RESULT_MAX_BYTES,
        "result or truth JSON",
    )
    .map_err(|source| IoError::Read {
        file: path.display().to_string(),
        source,
    })
}

fn write_text(path: &Path, text: &str) -> Result<(), IoError> {
    std::fs::write(path, text).map_err(|source| IoError::Write {
        file: path.display().to_string(),
        source,
    })
}

/// The size of a file in bytes, to reserve its records from (0 if unknown: nothing reserved).
pub(crate) fn file_size(path: &Path) -> usize {
    std::fs::metadata(path).map_or(0, |m| usize::try_from(m.len()).unwrap_or(usize::MAX))
}

/// Shortest text that parses back to the identical `f64` (plain or exponent form).
pub fn format_f64(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// Refuse a turntable file that does not overlap the IMU file in time. `imu_span` is the IMU
/// file's first and last stamp, `turntable_span_on_imu_clock` the turntable file's span mapped to
/// the IMU clock by the caller; `file` names the turntable file.
pub fn check_overlap(
    imu_span: (f64, f64),
    turntable_span_on_imu_clock: (f64, f64),
    file: &str,
) -> Result<(), IoError> {
    let (a0, a1) = imu_span;
    let (b0, b1) = turntable_span_on_imu_clock;
    if !(b0 <= a1 && b1 >= a0 && b0 <= b1 && a0 <= a1) {
        return Err(IoError::File {
            file: file.to_string(),
            message: format!(
                "the turntable data span {b0} s to {b1} s on the IMU clock and do not overlap \
                 the IMU data ({a0} s to {a1} s): expected turntable records during the IMU run \
                 (check the clock offset and the files)"
            ),
        });
    }
    // Two records, or a file cut after its first lines: the angles would be measured nowhere
    // and the refusal would blame the motion ("the angles stay constant").
    let overlap = b1.min(a1) - b0.max(a0);
    let least = MIN_RECORDING_S.min(a1 - a0);
    if overlap < least {
        return Err(IoError::File {
            file: file.to_string(),
            message: format!(
                "the turntable records overlap the IMU data for {overlap:.3} s only ({b0} s to \
                 {b1} s on the IMU clock, the IMU data {a0} s to {a1} s): expected turntable \
                 records over at least {least} s of the IMU run (a file cut short?)"
            ),
        });
    }
    Ok(())
}
