//! Static detection: a recording split into static intervals and motion.
//!
//! For every record, a window of `window_s` centred on it (cut at the ends of the recording and
//! at gaps) gives three numbers: the standard deviation of the specific force (the root of the
//! sum of the three axes' variances), the same for the angular rate, and the magnitude of the
//! mean angular rate. A record is static when all three are below their thresholds
//! ([`DetectorSettings`]); a run of static records lasting at least `min_duration_s` (from the
//! first to the last record's time stamp) is a static interval. Runs end at gaps (intervals
//! longer than `gap_factor` median intervals). Everything between static intervals is motion.
//!
//! The mean-rate threshold keeps a constant-rate rotation (small variances) from passing for rest;
//! it is loose enough for uncalibrated gyro biases of a few deg/s. The defaults find the 38 static
//! intervals of the Xsens MTi recording shipped in `data/real/xsens_mti` (and the same 38 over a
//! wide range of each threshold), and on the Ferraris session every static face of its section
//! list lies within a detected interval while no rotation touches one.
//!
//! **Window and minimum duration from the data.** A fixed 1-s window and 2-s minimum lose rests
//! of 2 to 3 s (the window trims half a window off each end of a rest, and what is left is
//! shorter than the minimum). So unless they are given ([`DetectorSettings::adapt_window`],
//! [`DetectorSettings::adapt_min_duration`]), a first pass with a short window
//! ([`FIRST_PASS_WINDOW_S`]) finds the quiet stretches; the lower quartile of their durations is
//! the typical rest `D`, and the window is `D / 4`, the minimum duration `D / 2` (so any rest of
//! at least 3/4 `D` is kept), never above the settings' values (the defaults, which suit long
//! rests) and never below the first pass's window, nor below the time the noise needs for a
//! usable mean ([`USABLE_MEAN_SE_M_S2`]). [`Segmentation::adaptation`] says what was chosen and
//! why.
//!
//! **Rests the motion suggests.** The first pass also counts the motion events (stretches where
//! the windowed deviations or the mean rate clearly exceed the thresholds, [`CLEAR_FACTOR`]) and
//! the quiet stretches between them; one that holds no static interval is listed in
//! [`Segmentation::missed_quiet_stretches`] with the reason (too short, too noisy), and
//! [`Segmentation::missed_suggestion`] gives settings that would take them, tried on the same
//! data. [`Segmentation::missed_report`] words both for a printout.

use crate::io::source::ImuSource;
use crate::io::timing::{self, GapAt};
use crate::io::{ImuData, ImuKind, ImuRecord};
use serde::{Deserialize, Serialize};

pub mod select;
mod stream;
pub use stream::{Reading, detect_static_streamed};

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
    /// The two standard-deviation thresholds are at least this many times the recording's own
    /// noise floor ([`Segmentation::noise_floor_f_m_s2`]): a noisy unit's rests pass for rest
    /// (as imu_tk scales its threshold by the variance of an initial rest, Tedaldi et al.
    /// 2014). 0 turns it off. Default 3.
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

/// A static interval.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StaticInterval {
    /// 0-based index of its first record.
    pub first_record: usize,
    /// 0-based index of its last record.
    pub last_record: usize,
    /// Time stamp of the first record (s).
    pub start_s: f64,
    /// Time stamp of the last record (s).
    pub end_s: f64,
    /// `end_s - start_s` (s).
    pub duration_s: f64,
    /// Number of records.
    pub records: usize,
    /// Mean specific force, body axes (m/s^2).
    pub mean_f_m_s2: [f64; 3],
    /// Magnitude of the mean specific force (m/s^2).
    pub norm_f_m_s2: f64,
    /// Mean angular rate, body axes (rad/s) (the gyro bias plus Earth rate, uncalibrated).
    pub mean_w_rad_s: [f64; 3],
    /// Standard deviation of the specific force over the interval (root of the summed variances),
    /// in m/s^2.
    pub std_f_m_s2: f64,
    /// Standard deviation of the angular rate over the interval (rad/s).
    pub std_w_rad_s: f64,
}

/// A stretch of motion (or of anything not static) between static intervals.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// 0-based index of the first record.
    pub first_record: usize,
    /// 0-based index of the last record.
    pub last_record: usize,
    /// Time stamp of the first record (s).
    pub start_s: f64,
    /// Time stamp of the last record (s).
    pub end_s: f64,
    /// `end_s - start_s` (s).
    pub duration_s: f64,
}

/// A gap in the recording.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// 0-based index of the record after the gap.
    pub record: usize,
    /// Time of the record before the gap (s).
    pub t_before_s: f64,
    /// Time of the record after the gap (s).
    pub t_after_s: f64,
    /// Length of the interval (s).
    pub length_s: f64,
}

/// A recording split into static intervals and motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Segmentation {
    /// The settings used: `window_s` and `min_duration_s` as chosen ([`Self::adaptation`] says
    /// how), the `adapt_*` flags as given.
    pub settings: DetectorSettings,
    /// Number of records.
    pub records: usize,
    /// First time stamp (s).
    pub t_first_s: f64,
    /// Last time stamp (s).
    pub t_last_s: f64,
    /// Median interval between records (s).
    pub median_interval_s: f64,
    /// Records in a window: `2 h + 1` with `h = round(window_s / (2 median))`.
    pub window_records: usize,
    /// Static intervals in time order.
    #[serde(rename = "static")]
    pub static_intervals: Vec<StaticInterval>,
    /// Everything else, between and around the static intervals, in time order.
    pub motion: Vec<Span>,
    /// Gaps (a static interval spans one only when it joins two parts of one pose:
    /// [`DetectorSettings::merge_across_short_gaps`]).
    pub gaps: Vec<Gap>,
    /// The recording's noise floor of the specific force: the [`NOISE_FLOOR_QUANTILE`] of the
    /// windowed standard deviations (m/s^2).
    pub noise_floor_f_m_s2: f64,
    /// The same for the angular rate (rad/s).
    pub noise_floor_w_rad_s: f64,
    /// The threshold on the specific force's standard deviation in force: the setting, or
    /// `noise_factor` times the noise floor where that is larger (m/s^2).
    pub threshold_std_f_m_s2: f64,
    /// The same for the angular rate (rad/s).
    pub threshold_std_w_rad_s: f64,
    /// How the window and minimum duration in `settings` were chosen.
    #[serde(default)]
    pub adaptation: Adaptation,
    /// Motion events: stretches where the first pass's deviations or mean rate reach
    /// [`CLEAR_FACTOR`] times their thresholds, two closer than [`MIN_QUIET_STRETCH_S`] counted
    /// as one.
    #[serde(default)]
    pub motion_events: usize,
    /// The stretches between (and before and after) the motion events that last at least
    /// [`MIN_QUIET_STRETCH_S`] yet hold no static interval: rests the motion suggests and the
    /// detector did not accept.
    #[serde(default)]
    pub missed_quiet_stretches: Vec<QuietStretch>,
    /// Settings that would take the missed stretches, tried on the same data (none when nothing
    /// was missed).
    #[serde(default)]
    pub missed_suggestion: Option<Suggestion>,
}

/// Where a setting of the detector came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Given (an option, or a setting with its `adapt_*` flag off).
    #[default]
    Given,
    /// The setting's value (the default) kept: the rests are long enough for it, or the first
    /// pass found no quiet stretch.
    Default,
    /// The fraction of the typical rest ([`WINDOW_PER_REST`], [`MIN_DURATION_PER_REST`]).
    Rests,
    /// Raised to its lower bound: the first pass's window (window), or the window and the time
    /// the noise needs for a usable mean (minimum duration).
    LowerBound,
}

/// How the window and minimum duration were chosen ([`DetectorSettings::adapt_window`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Adaptation {
    /// The first pass's window (s, records of it times the median interval less one).
    pub first_pass_window_s: f64,
    /// Quiet stretches of the first pass (runs of static records at its window lasting at least
    /// that window).
    pub quiet_stretches: usize,
    /// The typical rest: the [`TYPICAL_REST_QUANTILE`] of the quiet stretches' durations, each
    /// with the first pass's window added back (the centred window trims half of it off each
    /// end), in s; none without a quiet stretch.
    pub typical_rest_s: Option<f64>,
    /// The time the noise needs for a usable mean (s): [`USABLE_MEAN_SE_M_S2`] reached with the
    /// first pass's noise floor of the specific force.
    pub noise_min_duration_s: f64,
    /// Where the window came from.
    pub window: Source,
    /// Where the minimum duration came from.
    pub min_duration: Source,
}

/// Why a quiet stretch holds no static interval.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissReason {
    /// Quiet at the first pass's window, but shorter than the window and minimum duration in use
    /// need.
    TooShort,
    /// Its deviations (at the first pass's window) are above the thresholds over most of it.
    TooNoisy,
}

/// A stretch between motion events that holds no static interval.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct QuietStretch {
    /// 0-based index of its first record.
    pub first_record: usize,
    /// 0-based index of its last record.
    pub last_record: usize,
    /// Time stamp of the first record (s).
    pub start_s: f64,
    /// Time stamp of the last record (s).
    pub end_s: f64,
    /// `end_s - start_s` (s): between the motions, as the first pass's window sees them, so
    /// about that window shorter than the pause itself.
    pub duration_s: f64,
    /// Why it is not a static interval.
    pub reason: MissReason,
}

/// Settings that would take the missed quiet stretches, and what they give on the same data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Suggestion {
    /// Window (s).
    pub window_s: f64,
    /// Shortest static interval (s).
    pub min_duration_s: f64,
    /// Noise factor (raised only when stretches were missed as too noisy).
    pub noise_factor: f64,
    /// How many of the missed stretches then hold a static interval.
    pub would_take: usize,
    /// Static intervals in all with these settings.
    pub static_intervals: usize,
}

impl Segmentation {
    /// Total time at rest (s).
    pub fn static_s(&self) -> f64 {
        self.static_intervals
            .iter()
            .fold(0.0, |sum, s| sum + s.duration_s)
    }

    /// The report of rests the motion suggests and the detector did not accept, in lines for a
    /// printout (none when every quiet stretch between motions holds a static interval).
    /// `option` names the command's option for a setting (`"window_s"`, `"min_duration_s"`,
    /// `"noise_factor"`), e.g. `--rest-window` for `"window_s"`.
    pub fn missed_report(&self, option: impl Fn(&str) -> String) -> Option<Vec<String>> {
        let missed = &self.missed_quiet_stretches;
        if missed.is_empty() {
            return None;
        }
        let mut lines = Vec::new();
        let d: Vec<f64> = missed.iter().map(|m| m.duration_s).collect();
        let (lo, hi) = d
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(*x), b.max(*x))
            });
        let k = missed.len();
        lines.push(format!(
            "fewer rests than the motion suggests: {} motion event{}, {} static interval{}; {k} \
             quiet stretch{} between motions not taken as rest{} ({} .. {} s, median {} s)",
            self.motion_events,
            plural(self.motion_events),
            self.static_intervals.len(),
            plural(self.static_intervals.len()),
            if k == 1 { "" } else { "es" },
            plural(k),
            fmt3(lo),
            fmt3(hi),
            fmt3(quantile(&d, 0.5)),
        ));
        let short = missed
            .iter()
            .filter(|m| m.reason == MissReason::TooShort)
            .count();
        if short > 0 {
            lines.push(format!(
                "  {short} too short for a {}-s window and {}-s minimum",
                fmt3(self.settings.window_s),
                fmt3(self.settings.min_duration_s)
            ));
        }
        if short < k {
            lines.push(format!(
                "  {} too noisy: deviations above the thresholds (std f {} m/s^2, std w {} rad/s) \
                 over most of the stretch",
                k - short,
                fmt3(self.threshold_std_f_m_s2),
                fmt3(self.threshold_std_w_rad_s)
            ));
        }
        // The first few by time; all of them are in `missed_quiet_stretches`.
        let list: Vec<String> = missed
            .iter()
            .take(MISSED_LISTED)
            .map(|m| format!("{:.2} .. {:.2}", m.start_s, m.end_s))
            .collect();
        let more = match k.saturating_sub(MISSED_LISTED) {
            0 => String::new(),
            rest => format!(" and {rest} more"),
        };
        lines.push(format!("  at t = {} s{more}", list.join(", ")));
        match &self.missed_suggestion {
            Some(g) if g.would_take > 0 => {
                let mut given = format!(
                    "{} {} {} {}",
                    option("window_s"),
                    fmt3(g.window_s),
                    option("min_duration_s"),
                    fmt3(g.min_duration_s)
                );
                if g.noise_factor != self.settings.noise_factor {
                    given += &format!(" {} {}", option("noise_factor"), fmt3(g.noise_factor));
                }
                lines.push(format!(
                    "  {given} would take {} of them ({} static interval{} in all)",
                    g.would_take,
                    g.static_intervals,
                    plural(g.static_intervals)
                ));
            }
            _ => lines.push(
                "  no shorter window, minimum or higher noise factor tried takes them".to_string(),
            ),
        }
        Some(lines)
    }
}

/// Missed stretches named in [`Segmentation::missed_report`]; the rest are counted.
const MISSED_LISTED: usize = 8;

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// Three significant digits at most, without trailing zeros.
fn fmt3(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{x:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Windowed statistics of every record.
struct Windowed {
    std_f: Vec<f64>,
    std_w: Vec<f64>,
    rate: Vec<f64>,
}

/// Prefix sums of a triad and of its squares, relative to a reference value (for precision).
struct Prefix {
    sum: Vec<[f64; 3]>,
    sq: Vec<[f64; 3]>,
    reference: [f64; 3],
}

impl Prefix {
    fn new(x: &[[f64; 3]]) -> Self {
        let reference = x.first().copied().unwrap_or([0.0; 3]);
        let mut sum = Vec::with_capacity(x.len() + 1);
        let mut sq = Vec::with_capacity(x.len() + 1);
        let (mut s, mut q) = ([0.0; 3], [0.0; 3]);
        sum.push(s);
        sq.push(q);
        for v in x {
            for k in 0..3 {
                let d = v[k] - reference[k];
                s[k] += d;
                q[k] += d * d;
            }
            sum.push(s);
            sq.push(q);
        }
        Self { sum, sq, reference }
    }

    /// Mean and summed variance over `[a, b)`.
    fn stats(&self, a: usize, b: usize) -> ([f64; 3], f64) {
        let m = (b - a) as f64;
        let mut mean = [0.0; 3];
        let mut var = 0.0;
        for (k, mean_k) in mean.iter_mut().enumerate() {
            let mu = (self.sum[b][k] - self.sum[a][k]) / m;
            var += ((self.sq[b][k] - self.sq[a][k]) / m - mu * mu).max(0.0);
            *mean_k = mu + self.reference[k];
        }
        (mean, var)
    }
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Half-window in records for a window of `window_s` at this median interval.
fn half_window(window_s: f64, median: f64) -> usize {
    ((window_s / median / 2.0).round() as usize).max(1)
}

fn windowed(w: &[[f64; 3]], f: &[[f64; 3]], blocks: &[(usize, usize)], h: usize) -> Windowed {
    let n = w.len();
    let mut out = Windowed {
        std_f: vec![0.0; n],
        std_w: vec![0.0; n],
        rate: vec![0.0; n],
    };
    for &(b0, b1) in blocks {
        let pf = Prefix::new(&f[b0..b1]);
        let pw = Prefix::new(&w[b0..b1]);
        let len = b1 - b0;
        for i in 0..len {
            let a = i.saturating_sub(h);
            let b = (i + h + 1).min(len);
            let (_, vf) = pf.stats(a, b);
            let (mw, vw) = pw.stats(a, b);
            out.std_f[b0 + i] = vf.sqrt();
            out.std_w[b0 + i] = vw.sqrt();
            out.rate[b0 + i] = norm(mw);
        }
    }
    out
}

/// One pass of the detector at one window: the windowed statistics and the thresholds in force.
struct Pass {
    win: Windowed,
    floor_f: f64,
    floor_w: f64,
    max_std_f: f64,
    max_std_w: f64,
    max_rate: f64,
}

impl Pass {
    /// Windowed statistics with `h` records on each side, the deviation thresholds raised to
    /// `noise_factor` times the recording's noise floor at this window.
    fn new(
        w: &[[f64; 3]],
        f: &[[f64; 3]],
        blocks: &[(usize, usize)],
        h: usize,
        settings: &DetectorSettings,
        noise_factor: f64,
    ) -> Self {
        let win = windowed(w, f, blocks, h);
        let floor_f = quantile(&win.std_f, NOISE_FLOOR_QUANTILE);
        let floor_w = quantile(&win.std_w, NOISE_FLOOR_QUANTILE);
        Self {
            max_std_f: settings.max_std_f_m_s2.max(noise_factor * floor_f),
            max_std_w: settings.max_std_w_rad_s.max(noise_factor * floor_w),
            max_rate: settings.max_rate_rad_s,
            win,
            floor_f,
            floor_w,
        }
    }

    fn is_static(&self, i: usize) -> bool {
        self.win.std_f[i] < self.max_std_f
            && self.win.std_w[i] < self.max_std_w
            && self.win.rate[i] < self.max_rate
    }

    /// Whether record `i` moves clearly: a statistic at [`CLEAR_FACTOR`] times its threshold.
    fn is_clear_motion(&self, i: usize) -> bool {
        self.win.std_f[i] >= CLEAR_FACTOR * self.max_std_f
            || self.win.std_w[i] >= CLEAR_FACTOR * self.max_std_w
            || self.win.rate[i] >= CLEAR_FACTOR * self.max_rate
    }

    /// Maximal runs `(first, last)` of records for which `keep` holds, within the blocks.
    fn runs(&self, blocks: &[(usize, usize)], keep: impl Fn(usize) -> bool) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for &(b0, b1) in blocks {
            let mut i = b0;
            while i < b1 {
                if !keep(i) {
                    i += 1;
                    continue;
                }
                let mut j = i;
                while j + 1 < b1 && keep(j + 1) {
                    j += 1;
                }
                out.push((i, j));
                i = j + 1;
            }
        }
        out
    }
}

/// The value of an adapted setting: `x` raised to `lower`, at most `cap` (the setting's value),
/// with where it came from.
fn bounded(x: f64, lower: f64, cap: f64) -> (f64, Source) {
    if x.max(lower) >= cap {
        (cap, Source::Default)
    } else if x < lower {
        (lower, Source::LowerBound)
    } else {
        (x, Source::Rests)
    }
}

/// The static intervals of one pass: runs of static records of at least `min_duration_s`,
/// joined across short gaps when the settings say so.
fn intervals_of(
    t: &[f64],
    w: &[[f64; 3]],
    f: &[[f64; 3]],
    pass: &Pass,
    blocks: &[(usize, usize)],
    settings: &DetectorSettings,
    median: f64,
) -> Vec<StaticInterval> {
    let n = t.len();
    let mut intervals = Vec::new();
    for (i, j) in pass.runs(blocks, |i| pass.is_static(i)) {
        let (b0, b1) = *blocks
            .iter()
            .find(|&&(b0, b1)| b0 <= i && j < b1)
            .expect("a run lies in one block");
        // A run ending at a short gap may continue after it: judged when merged.
        let at_short_gap = settings.merge_across_short_gaps
            && j + 1 == b1
            && b1 < n
            && t[b1] - t[j] <= MERGE_GAP_INTERVALS * median;
        let starts_after_short_gap = settings.merge_across_short_gaps
            && i == b0
            && b0 > 0
            && t[b0] - t[b0 - 1] <= MERGE_GAP_INTERVALS * median;
        if t[j] - t[i] >= settings.min_duration_s || at_short_gap || starts_after_short_gap {
            intervals.push(interval(t, w, f, i, j));
        }
    }
    if settings.merge_across_short_gaps {
        intervals = merge_across_gaps(t, w, f, intervals, median);
    }
    intervals.retain(|s| s.duration_s >= settings.min_duration_s);
    intervals
}

/// Whether a static interval shares a record with `first ..= last`.
fn holds_rest(intervals: &[StaticInterval], first: usize, last: usize) -> bool {
    intervals
        .iter()
        .any(|s| s.first_record <= last && first <= s.last_record)
}

/// The window and minimum duration of the detecting pass, chosen from the first pass's quiet
/// stretches (`quiet_s`: their durations) as the module's doc says ("Window and minimum duration
/// from the data"), and what was chosen and why.
pub(crate) fn adapt(
    settings: &DetectorSettings,
    quiet_s: &[f64],
    first_window_s: f64,
    floor_f: f64,
    median: f64,
) -> (DetectorSettings, Adaptation) {
    let quiet: Vec<f64> = quiet_s
        .iter()
        .filter(|&&d| d >= first_window_s)
        .map(|d| d + first_window_s)
        .collect();
    let typical = (!quiet.is_empty()).then(|| quantile(&quiet, TYPICAL_REST_QUANTILE));
    // Records for a standard error of USABLE_MEAN_SE_M_S2 on each axis of the mean specific
    // force, at the first pass's noise floor (the root of the three axes' summed variances).
    let sigma_axis = floor_f / 3f64.sqrt();
    let noise_min_duration_s = (sigma_axis / USABLE_MEAN_SE_M_S2).powi(2) * median;
    let (window_s, window_source) = match typical {
        _ if !settings.adapt_window => (settings.window_s, Source::Given),
        None => (settings.window_s, Source::Default),
        Some(d) => bounded(d * WINDOW_PER_REST, first_window_s, settings.window_s),
    };
    let (min_duration_s, min_duration_source) = match typical {
        _ if !settings.adapt_min_duration => (settings.min_duration_s, Source::Given),
        None => (settings.min_duration_s, Source::Default),
        Some(d) => bounded(
            d * MIN_DURATION_PER_REST,
            window_s.max(noise_min_duration_s),
            settings.min_duration_s,
        ),
    };
    let used = DetectorSettings {
        window_s,
        min_duration_s,
        ..*settings
    };
    let adaptation = Adaptation {
        first_pass_window_s: first_window_s,
        quiet_stretches: quiet.len(),
        typical_rest_s: typical,
        noise_min_duration_s,
        window: window_source,
        min_duration: min_duration_source,
    };
    (used, adaptation)
}

/// The motion: every record outside the static intervals, as spans.
fn motion_between(t: &[f64], intervals: &[StaticInterval]) -> Vec<Span> {
    let mut motion = Vec::new();
    let mut next = 0;
    for s in intervals {
        if s.first_record > next {
            motion.push(span(t, next, s.first_record - 1));
        }
        next = s.last_record + 1;
    }
    if next < t.len() {
        motion.push(span(t, next, t.len() - 1));
    }
    motion
}

/// The window and minimum duration that would take the missed rests (`rests`: the longest quiet
/// run in each, s), chosen as [`adapt`] chooses them from all rests; `used`'s without any.
pub(crate) fn suggested_lengths(
    rests: &[f64],
    used: &DetectorSettings,
    first_window_s: f64,
    noise_min_duration_s: f64,
) -> (f64, f64) {
    if rests.is_empty() {
        return (used.window_s, used.min_duration_s);
    }
    let d = quantile(rests, TYPICAL_REST_QUANTILE);
    let window = bounded(d * WINDOW_PER_REST, first_window_s, used.window_s).0;
    let min = bounded(
        d * MIN_DURATION_PER_REST,
        window.max(noise_min_duration_s),
        used.min_duration_s,
    )
    .0;
    (window, min)
}

/// The noise factor that puts a too-noisy stretch's median deviation ratio (to the floor) a
/// quarter below the threshold, rounded up to a half.
pub(crate) fn noise_factor_for(median_ratio: f64) -> f64 {
    (median_ratio * 1.25 * 2.0).ceil() / 2.0
}

/// Split a recording (time stamps, angular rates (rad/s), specific forces (m/s^2), at least two
/// records with strictly increasing time) into static intervals and motion.
pub fn detect_static(
    t: &[f64],
    w: &[[f64; 3]],
    f: &[[f64; 3]],
    settings: &DetectorSettings,
) -> Result<Segmentation, String> {
    settings.check()?;
    let n = t.len();
    if n < 2 || w.len() != n || f.len() != n {
        return Err(format!(
            "expected at least two records with a time, a rate and a specific force each, found \
             {n}"
        ));
    }
    let (timing, gaps) = timing::analyse(t, settings.gap_factor);
    let median = timing.median_interval_s;
    let blocks = timing::blocks(n, &gaps);

    // First pass: a short window sees the quiet stretches, however short the rests.
    let h1 = half_window(FIRST_PASS_WINDOW_S, median).max(MIN_HALF_WINDOW_RECORDS);
    let first = Pass::new(w, f, &blocks, h1, settings, settings.noise_factor);
    let first_window_s = 2.0 * h1 as f64 * median;
    let quiet = first
        .runs(&blocks, |i| first.is_static(i))
        .iter()
        .map(|&(i, j)| t[j] - t[i])
        .collect::<Vec<_>>();
    let (used, adaptation) = adapt(settings, &quiet, first_window_s, first.floor_f, median);
    let noise_min_duration_s = adaptation.noise_min_duration_s;
    let h = half_window(used.window_s, median);
    let pass = Pass::new(w, f, &blocks, h, settings, settings.noise_factor);
    let intervals = intervals_of(t, w, f, &pass, &blocks, &used, median);
    let motion = motion_between(t, &intervals);

    let (motion_events, missed) = missed_stretches(t, &first, &blocks, &intervals);
    let missed_suggestion = (!missed.is_empty()).then(|| {
        suggest(
            t,
            w,
            f,
            &first,
            &blocks,
            &used,
            &missed,
            first_window_s,
            noise_min_duration_s,
            median,
        )
    });
    Ok(Segmentation {
        settings: used,
        records: n,
        t_first_s: t[0],
        t_last_s: t[n - 1],
        median_interval_s: median,
        window_records: 2 * h + 1,
        static_intervals: intervals,
        motion,
        gaps: gaps.iter().map(gap).collect(),
        noise_floor_f_m_s2: pass.floor_f,
        noise_floor_w_rad_s: pass.floor_w,
        threshold_std_f_m_s2: pass.max_std_f,
        threshold_std_w_rad_s: pass.max_std_w,
        adaptation,
        motion_events,
        missed_quiet_stretches: missed,
        missed_suggestion,
    })
}

/// The motion events of the first pass (runs of clearly moving records, two closer than
/// [`MIN_QUIET_STRETCH_S`] joined) and the quiet stretches between them (and before the first
/// and after the last, within each gap-free block) that hold no static interval.
fn missed_stretches(
    t: &[f64],
    first: &Pass,
    blocks: &[(usize, usize)],
    intervals: &[StaticInterval],
) -> (usize, Vec<QuietStretch>) {
    let mut events = 0;
    let mut missed = Vec::new();
    for &(b0, b1) in blocks {
        let mut moving: Vec<(usize, usize)> = Vec::new();
        for (i, j) in first.runs(&[(b0, b1)], |i| first.is_clear_motion(i)) {
            match moving.last_mut() {
                Some(last) if t[i] - t[last.1] < MIN_QUIET_STRETCH_S => last.1 = j,
                _ => moving.push((i, j)),
            }
        }
        events += moving.len();
        // The stretches around the motions: [a, b] between the end of one and the start of the
        // next (the block's ends count as ends of motion).
        let mut stretches = Vec::new();
        let mut a = b0;
        for &(i, j) in &moving {
            if i > a {
                stretches.push((a, i - 1));
            }
            a = j + 1;
        }
        if a < b1 {
            stretches.push((a, b1 - 1));
        }
        for (a, b) in stretches {
            if t[b] - t[a] < MIN_QUIET_STRETCH_S || holds_rest(intervals, a, b) {
                continue;
            }
            // Too short when at least half its records are quiet at the first pass's window.
            let quiet = (a..=b).filter(|&i| first.is_static(i)).count();
            let records = b - a + 1;
            missed.push(QuietStretch {
                first_record: a,
                last_record: b,
                start_s: t[a],
                end_s: t[b],
                duration_s: t[b] - t[a],
                reason: if 2 * quiet >= records {
                    MissReason::TooShort
                } else {
                    MissReason::TooNoisy
                },
            });
        }
    }
    (events, missed)
}

/// Settings that would take the missed stretches: the adaptive rule applied to the too-short
/// ones (their longest quiet run at the first pass's window, that window added back), the noise
/// factor raised past the too-noisy ones' deviations; tried on the same data.
#[allow(clippy::too_many_arguments)]
fn suggest(
    t: &[f64],
    w: &[[f64; 3]],
    f: &[[f64; 3]],
    first: &Pass,
    blocks: &[(usize, usize)],
    used: &DetectorSettings,
    missed: &[QuietStretch],
    first_window_s: f64,
    noise_min_duration_s: f64,
    median: f64,
) -> Suggestion {
    let runs = first.runs(blocks, |i| first.is_static(i));
    let rests: Vec<f64> = missed
        .iter()
        .filter(|m| m.reason == MissReason::TooShort)
        .map(|m| {
            let longest = runs
                .iter()
                .filter(|&&(i, j)| i >= m.first_record && j <= m.last_record)
                .map(|&(i, j)| t[j] - t[i])
                .fold(0.0, f64::max);
            longest + first_window_s
        })
        .collect();
    let (window_s, min_duration_s) =
        suggested_lengths(&rests, used, first_window_s, noise_min_duration_s);
    // The noise factor that puts the too-noisy stretches' typical (median) deviation, relative
    // to the floor, a quarter below the threshold; rounded up to a half.
    let mut noise_factor = used.noise_factor;
    for m in missed.iter().filter(|m| m.reason == MissReason::TooNoisy) {
        let ratios: Vec<f64> = (m.first_record..=m.last_record)
            .map(|i| (first.win.std_f[i] / first.floor_f).max(first.win.std_w[i] / first.floor_w))
            .collect();
        let needed = noise_factor_for(quantile(&ratios, 0.5));
        if needed.is_finite() {
            noise_factor = noise_factor.max(needed);
        }
    }
    let tried = DetectorSettings {
        window_s,
        min_duration_s,
        noise_factor,
        adapt_window: false,
        adapt_min_duration: false,
        ..*used
    };
    let h = half_window(window_s, median);
    let pass = Pass::new(w, f, blocks, h, &tried, noise_factor);
    let intervals = intervals_of(t, w, f, &pass, blocks, &tried, median);
    Suggestion {
        window_s,
        min_duration_s,
        noise_factor,
        would_take: missed
            .iter()
            .filter(|m| holds_rest(&intervals, m.first_record, m.last_record))
            .count(),
        static_intervals: intervals.len(),
    }
}

/// The `q` quantile of `v` (by selection; NaN for an empty slice).
fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut c = v.to_vec();
    let k = ((c.len() - 1) as f64 * q).round() as usize;
    let (_, x, _) = c.select_nth_unstable_by(k, f64::total_cmp);
    *x
}

/// Join consecutive static intervals that one short gap separates and whose mean specific
/// forces agree: one pose whose records lost a sample or a few.
fn merge_across_gaps(
    t: &[f64],
    w: &[[f64; 3]],
    f: &[[f64; 3]],
    intervals: Vec<StaticInterval>,
    median: f64,
) -> Vec<StaticInterval> {
    let mut out: Vec<StaticInterval> = Vec::with_capacity(intervals.len());
    for s in intervals {
        if let Some(prev) = out.last() {
            let adjacent = s.first_record == prev.last_record + 1
                && t[s.first_record] - t[prev.last_record] <= MERGE_GAP_INTERVALS * median;
            let (a, b) = (prev.mean_f_m_s2, s.mean_f_m_s2);
            let cos = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (norm(a) * norm(b));
            if adjacent && cos >= MERGE_MAX_ANGLE_RAD.cos() {
                let first = prev.first_record;
                out.pop();
                out.push(interval(t, w, f, first, s.last_record));
                continue;
            }
        }
        out.push(s);
    }
    out
}

fn gap(g: &GapAt) -> Gap {
    Gap {
        record: g.index,
        t_before_s: g.t_before_s,
        t_after_s: g.t_after_s,
        length_s: g.length_s(),
    }
}

fn span(t: &[f64], a: usize, b: usize) -> Span {
    Span {
        first_record: a,
        last_record: b,
        start_s: t[a],
        end_s: t[b],
        duration_s: t[b] - t[a],
    }
}

fn interval(t: &[f64], w: &[[f64; 3]], f: &[[f64; 3]], a: usize, b: usize) -> StaticInterval {
    let (mf, vf) = Prefix::new(&f[a..=b]).stats(0, b - a + 1);
    let (mw, vw) = Prefix::new(&w[a..=b]).stats(0, b - a + 1);
    StaticInterval {
        first_record: a,
        last_record: b,
        start_s: t[a],
        end_s: t[b],
        duration_s: t[b] - t[a],
        records: b - a + 1,
        mean_f_m_s2: mf,
        norm_f_m_s2: norm(mf),
        mean_w_rad_s: mw,
        std_f_m_s2: vf.sqrt(),
        std_w_rad_s: vw.sqrt(),
    }
}

/// Rates and specific forces of an `imu.csv`: rate-form records as they are, increments divided
/// by their own interval (the first record by the median interval).
pub fn rates_of(data: &ImuData) -> (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let t: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    let median = timing::median_interval(&t);
    let mut w = Vec::with_capacity(t.len());
    let mut f = Vec::with_capacity(t.len());
    for (i, r) in data.records.iter().enumerate() {
        match data.kind {
            ImuKind::Rates => {
                w.push(r.gyro);
                f.push(r.accel);
            }
            ImuKind::Increments => {
                let dt = if i == 0 { median } else { t[i] - t[i - 1] };
                w.push(r.gyro.map(|x| x / dt));
                f.push(r.accel.map(|x| x / dt));
            }
        }
    }
    (t, w, f)
}

/// Split an `imu.csv`'s records into static intervals and motion.
pub fn segment(data: &ImuData, settings: &DetectorSettings) -> Result<Segmentation, String> {
    let (t, w, f) = rates_of(data);
    detect_static(&t, &w, &f, settings)
}

/// The records of an `imu.csv` in rate form ([`rates_of`]), read again from the source at every
/// reading: nothing is held but the source's own buffer (a file's, or its cache when short).
pub struct RateSource<'a> {
    source: &'a mut dyn ImuSource,
    chunk: Vec<(ImuRecord, usize)>,
    /// Median interval of the records' time stamps (s), as [`timing::median_interval`].
    pub median: f64,
    /// Number of records.
    pub records: usize,
}

impl<'a> RateSource<'a> {
    /// Records per chunk read from the source.
    const CHUNK: usize = 4096;

    /// The records of `source`; its median interval is found now, in four readings of the
    /// time stamps ([`sins_model::timing::StreamedIntervalMedian`]).
    pub fn new(source: &'a mut dyn ImuSource) -> Result<Self, String> {
        let mut me = Self {
            source,
            chunk: Vec::with_capacity(Self::CHUNK),
            median: f64::NAN,
            records: 0,
        };
        let mut median = sins_model::timing::StreamedIntervalMedian::new();
        let mut n = 0;
        me.records_of(&mut |r, _| {
            median.push(r.t);
            n += 1;
        })?;
        me.records = n;
        me.median = median.finish(|visit| me.records_of(&mut |r, _| visit(r.t)))?;
        Ok(me)
    }

    /// The file's name, for messages.
    pub fn file(&self) -> &str {
        self.source.file()
    }

    /// Increments or rates, as in the file.
    pub fn kind(&self) -> ImuKind {
        self.source.kind()
    }

    /// One reading of the records as they are in the file, with their lines.
    pub fn records_of(&mut self, visit: &mut dyn FnMut(&ImuRecord, usize)) -> Result<(), String> {
        crate::io::source::read_records(self.source, &mut self.chunk, &mut |r, line| {
            visit(r, line);
            true
        })
        .map_err(|e| e.to_string())
    }

    /// The source itself, for readings of its own kind (the records of a hand-turned
    /// recording's rests, its filter's passes) between those of the detector.
    pub fn source(&mut self) -> &mut dyn ImuSource {
        self.source
    }

    /// One reading of the records in rate form `(t, w, f)`, as [`rates_of`] gives them.
    pub fn read(&mut self, visit: &mut dyn FnMut(f64, [f64; 3], [f64; 3])) -> Result<(), String> {
        let kind = self.kind();
        let median = self.median;
        let mut previous = f64::NAN;
        let mut first = true;
        self.records_of(&mut |r, _| {
            match kind {
                ImuKind::Rates => visit(r.t, r.gyro, r.accel),
                ImuKind::Increments => {
                    let dt = if first { median } else { r.t - previous };
                    visit(r.t, r.gyro.map(|x| x / dt), r.accel.map(|x| x / dt));
                }
            }
            first = false;
            previous = r.t;
        })
    }
}

/// [`segment`] of records read again from their source at every reading, in memory
/// independent of their number ([`detect_static_streamed`]); the same segmentation.
pub fn segment_streamed(
    source: &mut RateSource,
    settings: &DetectorSettings,
) -> Result<Segmentation, String> {
    let median = source.median;
    detect_static_streamed(&mut |visit| source.read(visit), Some(median), settings)
}

/// The quietest window of the specific force: `[start, end)` of the `window_s` window with the
/// smallest standard deviation within one gap-free stretch, and that deviation (m/s^2). A
/// recording shorter than the window gives its longest gap-free stretch.
pub fn quietest_window(
    t: &[f64],
    f: &[[f64; 3]],
    window_s: f64,
    gaps: &[GapAt],
) -> (usize, usize, f64) {
    let n = t.len();
    let median = timing::median_interval(t);
    let len = if median.is_finite() && median > 0.0 {
        ((window_s / median).round() as usize).max(2)
    } else {
        n
    };
    let mut best = (0, n.min(len), f64::INFINITY);
    let mut longest = (0, 0);
    for (b0, b1) in timing::blocks(n, gaps) {
        if b1 - b0 > longest.1 - longest.0 {
            longest = (b0, b1);
        }
        if b1 - b0 < len {
            continue;
        }
        let p = Prefix::new(&f[b0..b1]);
        for a in 0..=(b1 - b0 - len) {
            let (_, v) = p.stats(a, a + len);
            if v < best.2 {
                best = (b0 + a, b0 + a + len, v);
            }
        }
    }
    if best.2.is_finite() {
        (best.0, best.1, best.2.sqrt())
    } else {
        let (a, b) = longest;
        let (_, v) = Prefix::new(&f[a..b]).stats(0, b - a);
        (a, b, v.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The detector on the records held, checked against the streamed detector (the same
    /// segmentation to the last bit).
    fn detect_static(
        t: &[f64],
        w: &[[f64; 3]],
        f: &[[f64; 3]],
        settings: &DetectorSettings,
    ) -> Result<Segmentation, String> {
        let held = super::detect_static(t, w, f, settings);
        let mut readings = 0;
        let streamed = detect_static_streamed(
            &mut |visit| {
                readings += 1;
                for i in 0..t.len() {
                    visit(t[i], w[i], f[i]);
                }
                Ok(())
            },
            None,
            settings,
        );
        assert_eq!(held, streamed);
        held
    }

    /// 10 s at rest, 3 s turning, 10 s at rest, at 100 Hz.
    fn synthetic() -> (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let mut t = Vec::new();
        let mut w = Vec::new();
        let mut f = Vec::new();
        for i in 0..2300 {
            let ti = i as f64 * 0.01;
            let moving = (10.0..13.0).contains(&ti);
            let a = if moving { (ti - 10.0) * 1.0 } else { 0.0 };
            let angle = if ti >= 13.0 { 3.0 } else { a };
            t.push(ti);
            w.push(if moving { [1.0, 0.0, 0.0] } else { [0.0; 3] });
            f.push([0.0, 9.81 * angle.sin(), 9.81 * angle.cos()]);
        }
        (t, w, f)
    }

    /// Six poses of 4 s joined by 1.5-s turns of 90 degrees about x at 200 Hz, with white noise
    /// of `sigma_f` (m/s^2) and `sigma_w` (rad/s) per sample (a fixed pseudo-random stream).
    fn noisy_poses(sigma_f: f64, sigma_w: f64) -> (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut gauss = move || {
            // Box-Muller on a xorshift stream.
            let mut u = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
        };
        let (mut t, mut w, mut f) = (vec![], vec![], vec![]);
        let (rest, turn, dt) = (4.0, 1.5, 0.005);
        let rate = std::f64::consts::FRAC_PI_2 / turn;
        let n = ((6.0 * rest + 5.0 * turn) / dt) as usize;
        for i in 0..n {
            let ti = i as f64 * dt;
            let k = (ti / (rest + turn)).floor();
            let phase = ti - k * (rest + turn);
            let moving = phase >= rest && k < 5.0;
            let angle = rate * (k * turn + if moving { phase - rest } else { 0.0 });
            t.push(ti);
            let wx = if moving { rate } else { 0.0 };
            w.push([wx + sigma_w * gauss(), sigma_w * gauss(), sigma_w * gauss()]);
            f.push([
                sigma_f * gauss(),
                9.81 * angle.sin() + sigma_f * gauss(),
                9.81 * angle.cos() + sigma_f * gauss(),
            ]);
        }
        (t, w, f)
    }

    #[test]
    fn a_noisy_units_rests_are_found_with_thresholds_from_its_noise() {
        // Accelerometer noise per sample at the fixed threshold (a consumer unit, 0.12 m/s^2).
        let (t, w, f) = noisy_poses(0.12, 0.01);
        let fixed = DetectorSettings {
            noise_factor: 0.0,
            ..DetectorSettings::default()
        };
        let s = detect_static(&t, &w, &f, &fixed).unwrap();
        assert!(s.static_intervals.len() < 6, "{}", s.static_intervals.len());
        let s = detect_static(&t, &w, &f, &DetectorSettings::default()).unwrap();
        assert_eq!(s.static_intervals.len(), 6, "{s:?}");
        assert!((s.noise_floor_f_m_s2 / (0.12 * 3f64.sqrt()) - 1.0).abs() < 0.1);
        assert!(s.threshold_std_f_m_s2 > 0.3, "{}", s.threshold_std_f_m_s2);
        // No rest reaches into a turn.
        for r in &s.static_intervals {
            let k = (r.start_s / 5.5).floor();
            assert!(
                r.start_s >= k * 5.5 - 1e-9 && r.end_s <= k * 5.5 + 4.0 + 1e-9,
                "{r:?}"
            );
        }
    }

    #[test]
    fn a_pose_that_lost_a_sample_is_one_interval() {
        let (mut t, mut w, mut f) = noisy_poses(0.01, 0.001);
        // Drop one sample in the middle of the third pose (t = 13 s).
        let k = t.iter().position(|&x| x >= 13.0).unwrap();
        t.remove(k);
        w.remove(k);
        f.remove(k);
        let s = detect_static(&t, &w, &f, &DetectorSettings::default()).unwrap();
        assert_eq!(s.gaps.len(), 1);
        assert_eq!(s.static_intervals.len(), 6, "{:?}", s.static_intervals);
        let third = &s.static_intervals[2];
        assert!(third.start_s < 13.0 && third.end_s > 13.0, "{third:?}");
        // Without merging the pose is two runs of 1.5 s, each too short: the pose is lost.
        let split = DetectorSettings {
            merge_across_short_gaps: false,
            ..DetectorSettings::default()
        };
        let s = detect_static(&t, &w, &f, &split).unwrap();
        assert_eq!(s.static_intervals.len(), 5, "{:?}", s.static_intervals);
    }

    #[test]
    fn two_rests_around_a_turn() {
        let (t, w, f) = synthetic();
        let s = detect_static(&t, &w, &f, &DetectorSettings::default()).unwrap();
        assert_eq!(s.static_intervals.len(), 2, "{s:?}");
        let a = &s.static_intervals[0];
        assert!(a.start_s == 0.0 && (a.end_s - 9.5).abs() < 0.02, "{a:?}");
        assert!((a.norm_f_m_s2 - 9.81).abs() < 1e-9);
        let b = &s.static_intervals[1];
        assert!(
            (b.start_s - 13.5).abs() < 0.02 && b.last_record == 2299,
            "{b:?}"
        );
        assert_eq!(s.motion.len(), 1);
        assert_eq!(s.motion[0].first_record, a.last_record + 1);
        assert_eq!(s.motion[0].last_record, b.first_record - 1);
    }

    #[test]
    fn constant_rate_rotation_about_the_vertical_is_not_rest() {
        let (t, _, f) = synthetic();
        let w = vec![[0.0, 0.0, 0.5]; t.len()];
        let f: Vec<[f64; 3]> = f.iter().map(|_| [0.0, 0.0, 9.81]).collect();
        let s = detect_static(&t, &w, &f, &DetectorSettings::default()).unwrap();
        assert!(s.static_intervals.is_empty());
    }

    #[test]
    fn static_intervals_end_at_gaps() {
        let (mut t, w, f) = synthetic();
        for x in t.iter_mut().skip(500) {
            *x += 0.5;
        }
        let s = detect_static(&t, &w, &f, &DetectorSettings::default()).unwrap();
        assert_eq!(s.gaps.len(), 1);
        assert_eq!(s.static_intervals.len(), 3);
        assert_eq!(s.static_intervals[0].last_record, 499);
        assert_eq!(s.static_intervals[1].first_record, 500);
    }

    #[test]
    fn bad_settings_are_named() {
        let (t, w, f) = synthetic();
        let settings = DetectorSettings {
            window_s: 0.0,
            ..Default::default()
        };
        let e = detect_static(&t, &w, &f, &settings).unwrap_err();
        assert!(e.contains("window_s"), "{e}");
    }
}
