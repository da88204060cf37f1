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

use crate::timing::{self, GapAt};
use calib::io::{ImuData, ImuKind};
use serde::{Deserialize, Serialize};

/// Thresholds of the static detector.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectorSettings {
    /// Length of the sliding window, centred on each record (s). Default 1.0.
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
    /// Shortest static interval (s). Default 2.0.
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
    /// The settings used.
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
}

impl Segmentation {
    /// Total time at rest (s).
    pub fn static_s(&self) -> f64 {
        self.static_intervals
            .iter()
            .fold(0.0, |sum, s| sum + s.duration_s)
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
    let h = half_window(settings.window_s, median);
    let win = windowed(w, f, &blocks, h);
    let floor_f = quantile(&win.std_f, NOISE_FLOOR_QUANTILE);
    let floor_w = quantile(&win.std_w, NOISE_FLOOR_QUANTILE);
    let max_std_f = settings.max_std_f_m_s2.max(settings.noise_factor * floor_f);
    let max_std_w = settings
        .max_std_w_rad_s
        .max(settings.noise_factor * floor_w);
    let is_static = |i: usize| {
        win.std_f[i] < max_std_f
            && win.std_w[i] < max_std_w
            && win.rate[i] < settings.max_rate_rad_s
    };
    let mut intervals = Vec::new();
    for &(b0, b1) in &blocks {
        let mut i = b0;
        while i < b1 {
            if !is_static(i) {
                i += 1;
                continue;
            }
            let mut j = i;
            while j + 1 < b1 && is_static(j + 1) {
                j += 1;
            }
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
            i = j + 1;
        }
    }
    if settings.merge_across_short_gaps {
        intervals = merge_across_gaps(t, w, f, intervals, median);
    }
    intervals.retain(|s| s.duration_s >= settings.min_duration_s);
    let mut motion = Vec::new();
    let mut next = 0;
    for s in &intervals {
        if s.first_record > next {
            motion.push(span(t, next, s.first_record - 1));
        }
        next = s.last_record + 1;
    }
    if next < n {
        motion.push(span(t, next, n - 1));
    }
    Ok(Segmentation {
        settings: *settings,
        records: n,
        t_first_s: t[0],
        t_last_s: t[n - 1],
        median_interval_s: median,
        window_records: 2 * h + 1,
        static_intervals: intervals,
        motion,
        gaps: gaps.iter().map(gap).collect(),
        noise_floor_f_m_s2: floor_f,
        noise_floor_w_rad_s: floor_w,
        threshold_std_f_m_s2: max_std_f,
        threshold_std_w_rad_s: max_std_w,
    })
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
