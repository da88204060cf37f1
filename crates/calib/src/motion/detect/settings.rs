//! The detector's settings ([`DetectorSettings`]: thresholds, window, minimum duration, gap
//! factor, noise factor, merging, adaptation) and its fixed constants.

use serde::{Deserialize, Serialize};

/// Thresholds of the static detector.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectorSettings {
    /// Length of the sliding window, centred on each record (s). Default 1.0: with
    /// `adapt_window`, the longest window the recording's rests may choose.
    pub window_s: f64,
    /// Largest standard deviation of the specific force over the window (root of the summed
    /// variances of the three axes), in m/s^2. Default 0.1.
    pub max_std_f_m_s2: f64,
    /// Largest standard deviation of the angular rate over the window (rad/s). Default 0.05
    /// (2.9 deg/s).
    pub max_std_w_rad_s: f64,
    /// Largest magnitude of the mean angular rate over the window (rad/s). Default 0.1
    /// (5.7 deg/s): above any plausible gyro bias, below a deliberate rotation.
    pub max_rate_rad_s: f64,
    /// Shortest static interval (s). Default 2.0: with `adapt_min_duration`, the longest
    /// minimum the recording's rests may choose.
    pub min_duration_s: f64,
    /// An interval between records longer than this many median intervals is a gap. Default 1.5.
    pub gap_factor: f64,
    /// The two standard-deviation thresholds are at least this many times the recording's own noise
    /// floor ([`Segmentation::noise_floor_f_m_s2`](super::Segmentation::noise_floor_f_m_s2)): a
    /// noisy unit's rests pass for rest (as imu_tk scales its threshold by the variance of an
    /// initial rest, Tedaldi et al. 2014). 0 turns it off. Default 3.
    #[serde(default = "default_noise_factor")]
    pub noise_factor: f64,
    /// Two static intervals separated only by a gap of at most [`MERGE_GAP_INTERVALS`] median
    /// intervals (a dropped sample or a few) whose mean specific forces agree within
    /// [`MERGE_MAX_ANGLE_RAD`] are one pose, one interval. Default true.
    #[serde(default = "default_true")]
    pub merge_across_short_gaps: bool,
    /// Whether the window is taken from the recording's rests (`window_s` is then the longest
    /// it may be): false when a window was given. Default true; false when absent from a file
    /// (segmentations written before the window adapted used `window_s` as it was).
    #[serde(default)]
    pub adapt_window: bool,
    /// The same for the shortest static interval (`min_duration_s` is then the longest it may
    /// be). Default true; false when absent from a file.
    #[serde(default)]
    pub adapt_min_duration: bool,
}

fn default_noise_factor() -> f64 {
    3.0
}

fn default_true() -> bool {
    true
}

/// The longest gap (in median intervals) that two static intervals of one pose may straddle.
pub const MERGE_GAP_INTERVALS: f64 = 5.0;

/// Largest angle between the mean specific forces of two static intervals of one pose (rad,
/// 1 deg).
pub const MERGE_MAX_ANGLE_RAD: f64 = 0.017453292519943295;

/// The quantile of the windowed standard deviations taken as the noise floor: at least a
/// tenth of any recording worth segmenting is at rest.
pub const NOISE_FLOOR_QUANTILE: f64 = 0.1;

/// Window of the first pass, which finds the quiet stretches whose durations set the window and
/// minimum duration (s): short enough to see rests of a second, long enough (25 records at
/// 100 Hz) for a standard deviation good to about 10 %.
pub const FIRST_PASS_WINDOW_S: f64 = 0.25;

/// Fewest records on each side of the centre of any window: below 5 the windowed deviation is
/// too uncertain to compare with a threshold.
pub const MIN_HALF_WINDOW_RECORDS: usize = 5;

/// The quantile of the quiet stretches' durations taken as the typical rest: the lower quartile,
/// so that the shorter rests of a recording set the window, while a few brief pauses do not.
pub const TYPICAL_REST_QUANTILE: f64 = 0.25;

/// The adapted window as a fraction of the typical rest: a rest loses about one window (half at
/// each end) to the centred window.
pub const WINDOW_PER_REST: f64 = 0.25;

/// The adapted minimum duration as a fraction of the typical rest: with the window at a quarter,
/// every rest of at least three quarters of the typical one is kept.
pub const MIN_DURATION_PER_REST: f64 = 0.5;

/// A rest must last long enough for the standard error of its mean specific force (each axis)
/// to be below this (m/s^2, about 0.2 mg): a tenth of a consumer unit's specific-force errors
/// after calibration, and far below a navigation-grade unit's noise over a second. The
/// adapted minimum duration is not shorter (but never longer than `min_duration_s`).
pub const USABLE_MEAN_SE_M_S2: f64 = 0.002;

/// A record moves clearly when its first-pass standard deviations or mean rate reach this many
/// times their thresholds: motion events are runs of such records.
pub const CLEAR_FACTOR: f64 = 2.0;

/// Quiet stretches shorter than this (s, between two clear motions, so about a first-pass window
/// shorter than the pause) are pauses of the hand, not rests the detector missed: a pose held
/// for a calibration lasts a second or more. Two motions closer than this are one motion event.
pub const MIN_QUIET_STRETCH_S: f64 = 0.75;

impl Default for DetectorSettings {
    fn default() -> Self {
        Self {
            window_s: 1.0,
            max_std_f_m_s2: 0.1,
            max_std_w_rad_s: 0.05,
            max_rate_rad_s: 0.1,
            min_duration_s: 2.0,
            gap_factor: 1.5,
            noise_factor: default_noise_factor(),
            merge_across_short_gaps: true,
            adapt_window: true,
            adapt_min_duration: true,
        }
    }
}

impl DetectorSettings {
    /// Refuse settings that are not finite and positive (`gap_factor` above 1); the message
    /// names the setting.
    pub fn check(&self) -> Result<(), String> {
        for (name, v) in [
            ("window_s", self.window_s),
            ("max_std_f_m_s2", self.max_std_f_m_s2),
            ("max_std_w_rad_s", self.max_std_w_rad_s),
            ("max_rate_rad_s", self.max_rate_rad_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} = {v}: expected a positive number"));
            }
        }
        if !(self.min_duration_s.is_finite() && self.min_duration_s >= 0.0) {
            return Err(format!(
                "min_duration_s = {}: expected a number of seconds, 0 or more",
                self.min_duration_s
            ));
        }
        if !(self.noise_factor.is_finite() && self.noise_factor >= 0.0) {
            return Err(format!(
                "noise_factor = {}: expected a number, 0 (off) or more",
                self.noise_factor
            ));
        }
        if !(self.gap_factor.is_finite() && self.gap_factor > 1.0) {
            return Err(format!(
                "gap_factor = {}: expected a number above 1",
                self.gap_factor
            ));
        }
        Ok(())
    }
}
