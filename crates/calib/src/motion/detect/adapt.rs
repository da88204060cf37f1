//! The window and minimum duration taken from the recording's rests (the module's "Window and
//! minimum duration from the data"), and the settings suggested for the rests missed.

use super::segmentation::{Adaptation, Source};
use super::select::quantile;
use super::settings::{
    DetectorSettings, MIN_DURATION_PER_REST, TYPICAL_REST_QUANTILE, USABLE_MEAN_SE_M_S2,
    WINDOW_PER_REST,
};

/// Half-window in records for a window of `window_s` at this median interval.
pub(crate) fn half_window(window_s: f64, median: f64) -> usize {
    ((window_s / median / 2.0).round() as usize).max(1)
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
