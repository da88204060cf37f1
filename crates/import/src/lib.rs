//! # import
//!
//! Recordings in other layouts turned into the project's interchange files. (Static detection
//! on them is calib's: [`calib::motion::detect`].)
//!
//! - [`profile`]: the import profile (TOML): input files, delimiter, skipped lines, which column
//!   is which, the time base, rates or increments, units (physical or counts with offset and
//!   sensitivity), axis mapping with sign flips, sensor ranges, turntable angles, a section list;
//! - [`import_into`]: reads the files a profile names, converts and checks them and writes the
//!   interchange files into a directory, in memory independent of the recording's length: time
//!   strictly increasing, jitter kept (every record keeps its own time stamp), gaps refused
//!   unless allowed (then recorded), saturated samples counted, a specific force at rest nowhere
//!   near g refused with the likely cause; it writes `imu.csv` (in `calib::io`'s text),
//!   `turntable.csv` when the source has angles, `sections.json` when the profile has a section
//!   list, and the report `import.json` ([`ImportReport`]);
//! - [`sections`]: section lists (static faces, rotations) carried onto the imported records.
//! - [`bag`]: ROS 1 bags and MCAP files ([`import_bag`]): the `sensor_msgs/Imu` messages on a
//!   topic into `imu.csv` at their header stamps, streamed, with the same checks.
//!
//! Every refusal is an [`ImportError`] naming the file, the line where there is one, and what was
//! expected; nothing panics on user data. Formats: `docs/formats.md`.
//!
//! ```no_run
//! use calib::motion::detect::{RateSource, segment_streamed};
//! use import::{ImportOptions, import_into, profile::Profile};
//! use std::path::Path;
//!
//! let profile = Profile::load(Path::new("examples/xsens_mti.toml"))?;
//! let dir = Path::new("out/xsens");
//! std::fs::create_dir_all(dir)?;
//! let imported = import_into(&profile, &ImportOptions::default(), dir)?;
//! let mut imu = calib::io::source::FileImu::open(&imported.written.imu)?;
//! let mut records = RateSource::new(&mut imu)?;
//! let segmentation = segment_streamed(&mut records, &Default::default())?;
//! assert_eq!(segmentation.static_intervals.len(), 38);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod bag;
mod checks;
mod columns;
mod error;
mod fields;
pub mod profile;
mod profile_import;
mod report;
pub mod sections;
mod text;

pub use bag::import_bag;
pub use calib::estimate::data_checks::Stuck;
pub use error::ImportError;
pub use profile_import::{ImportedFiles, import_into};
pub use report::{GapReport, ImportReport, InputFile, SaturationReport, StaticForce, Written};

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
