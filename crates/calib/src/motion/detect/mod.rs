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
//!
//! **One detector, records read again.** The detector ([`detect_static_streamed`],
//! [`segment_streamed`] for an `imu.csv`'s [`RateSource`]) reads the records again from their
//! start at every pass and holds nothing per record, so a recording of any length segments in
//! the same memory; [`segment`] gives it records already in memory.

mod adapt;
mod detector;
mod rate_source;
mod segmentation;
pub mod select;
mod settings;
#[cfg(test)]
mod tests;

pub use detector::{Reading, detect_static_streamed};
pub use rate_source::RateSource;
pub use segmentation::{
    Adaptation, Gap, MissReason, QuietStretch, Segmentation, Source, Span, StaticInterval,
    Suggestion,
};
pub use settings::{
    CLEAR_FACTOR, DetectorSettings, FIRST_PASS_WINDOW_S, MERGE_GAP_INTERVALS, MERGE_MAX_ANGLE_RAD,
    MIN_DURATION_PER_REST, MIN_HALF_WINDOW_RECORDS, MIN_QUIET_STRETCH_S, NOISE_FLOOR_QUANTILE,
    TYPICAL_REST_QUANTILE, USABLE_MEAN_SE_M_S2, WINDOW_PER_REST,
};

use crate::io::ImuData;
use crate::io::source::MemoryImu;

/// Rates and specific forces of records held in memory (an `imu.csv` read whole): rate-form
/// records as they are, increments divided by their own interval (the first record by the
/// median interval), as [`RateSource::read`] gives them.
pub fn rates_of(data: &ImuData) -> (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let n = data.records.len();
    let (mut t, mut w, mut f) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut memory = MemoryImu::new(data, "records in memory");
    // Records in memory are read without fail: a reading gives no error.
    let mut source = RateSource::new(&mut memory).expect("records in memory");
    source
        .read(&mut |ti, wi, fi| {
            t.push(ti);
            w.push(wi);
            f.push(fi);
        })
        .expect("records in memory");
    (t, w, f)
}

/// Split records held in memory (an `imu.csv` read whole) into static intervals and motion: the
/// detector ([`segment_streamed`]) reading them from memory.
pub fn segment(data: &ImuData, settings: &DetectorSettings) -> Result<Segmentation, String> {
    let mut memory = MemoryImu::new(data, "records in memory");
    let mut source = RateSource::new(&mut memory)?;
    segment_streamed(&mut source, settings)
}

/// Split an `imu.csv`'s records, read again from their source at every reading, into static
/// intervals and motion ([`detect_static_streamed`] with the source's median interval), in memory
/// independent of their number.
pub fn segment_streamed(
    source: &mut RateSource,
    settings: &DetectorSettings,
) -> Result<Segmentation, String> {
    let median = source.median;
    detect_static_streamed(&mut |visit| source.read(visit), Some(median), settings)
}
