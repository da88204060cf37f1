//! What the detector finds ([`Segmentation`]): the static intervals, the motion between them,
//! the gaps, the thresholds in force, how the window and minimum duration were chosen, and the
//! rests the motion suggests that were not taken, with their report for a printout.

use super::select::quantile;
use super::settings::DetectorSettings;
use crate::io::timing::GapAt;
use serde::{Deserialize, Serialize};

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
    /// The recording's noise floor of the specific force: the
    /// [`NOISE_FLOOR_QUANTILE`](super::NOISE_FLOOR_QUANTILE) of the windowed standard deviations
    /// (m/s^2).
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
    /// [`CLEAR_FACTOR`](super::CLEAR_FACTOR) times their thresholds, two closer than
    /// [`MIN_QUIET_STRETCH_S`](super::MIN_QUIET_STRETCH_S) counted as one.
    #[serde(default)]
    pub motion_events: usize,
    /// The stretches between (and before and after) the motion events that last at least
    /// [`MIN_QUIET_STRETCH_S`](super::MIN_QUIET_STRETCH_S) yet hold no static interval: rests the
    /// motion suggests and the detector did not accept.
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
    /// The fraction of the typical rest ([`WINDOW_PER_REST`](super::WINDOW_PER_REST),
    /// [`MIN_DURATION_PER_REST`](super::MIN_DURATION_PER_REST)).
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
    /// The typical rest: the [`TYPICAL_REST_QUANTILE`](super::TYPICAL_REST_QUANTILE) of the quiet
    /// stretches' durations, each with the first pass's window added back (the centred window trims
    /// half of it off each end), in s; none without a quiet stretch.
    pub typical_rest_s: Option<f64>,
    /// The time the noise needs for a usable mean (s):
    /// [`USABLE_MEAN_SE_M_S2`](super::USABLE_MEAN_SE_M_S2) reached with the first pass's noise
    /// floor of the specific force.
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

pub(crate) fn gap(g: &GapAt) -> Gap {
    Gap {
        record: g.index,
        t_before_s: g.t_before_s,
        t_after_s: g.t_after_s,
        length_s: g.length_s(),
    }
}
