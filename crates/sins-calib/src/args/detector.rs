//! The static detector's settings as command-line options, declared once and shared by every
//! command that finds rests in a recording: `segment`, `noise`, and `calibrate` / `diagnose`
//! on a recording without a program (and with `--free-motion`). One spelling everywhere
//! (`--rest-*`); `segment`'s and `noise`'s former spellings (`--window`, `--max-std-f`, ...)
//! stay accepted as hidden aliases so that existing scripts keep working.

use ::calib::motion::detect::DetectorSettings;
use calib::motion::rests::Rest;

/// Options of the static detector (`calib::motion::detect`; the defaults are
/// `DetectorSettings::default()`). Their help heading is set where they are flattened.
#[derive(Debug, Clone, clap::Args)]
pub struct DetectorArgs {
    /// Length of the sliding window centred on each record, in seconds. Default: a quarter of
    /// the typical rest (the lower quartile of the quiet stretches a 0.25-s window finds), at
    /// most 1 s and at least 0.25 s.
    #[arg(long = "rest-window", alias = "window", value_name = "SECONDS")]
    pub window: Option<f64>,
    /// Largest standard deviation of the specific force over the window (root of the summed
    /// variances of the three axes), m/s^2 (default 0.1); raised to --rest-noise-factor times
    /// the recording's own noise floor where that is larger.
    #[arg(long = "rest-max-std-f", alias = "max-std-f", value_name = "M_S2")]
    pub max_std_f: Option<f64>,
    /// Largest standard deviation of the angular rate over the window, rad/s (default 0.05;
    /// raised likewise).
    #[arg(long = "rest-max-std-w", alias = "max-std-w", value_name = "RAD_S")]
    pub max_std_w: Option<f64>,
    /// Largest magnitude of the mean angular rate over the window, rad/s (default 0.1: keeps a
    /// steady rotation from passing for rest; above any plausible gyro bias).
    #[arg(long = "rest-max-rate", alias = "max-rate", value_name = "RAD_S")]
    pub max_rate: Option<f64>,
    /// Shortest rest (static interval, first to last record), in seconds. Default: half the
    /// typical rest, at most 2 s, at least the window and the time the noise needs for a mean
    /// good to 0.002 m/s^2 on each axis.
    #[arg(
        long = "rest-min-duration",
        alias = "min-duration",
        value_name = "SECONDS"
    )]
    pub min_duration: Option<f64>,
    /// The deviation thresholds are at least this many times the recording's noise floor (the
    /// tenth percentile of the windowed deviations; default 3); 0 keeps them as given.
    #[arg(
        long = "rest-noise-factor",
        alias = "noise-factor",
        value_name = "FACTOR"
    )]
    pub noise_factor: Option<f64>,
}

impl DetectorArgs {
    /// Whether any option was given.
    pub fn any(&self) -> bool {
        [
            self.window,
            self.max_std_f,
            self.max_std_w,
            self.max_rate,
            self.min_duration,
            self.noise_factor,
        ]
        .iter()
        .any(Option::is_some)
    }

    /// The settings: the defaults with the options given, checked (the message names the
    /// option).
    pub fn settings(&self) -> Result<DetectorSettings, String> {
        self.settings_over(DetectorSettings::default())
    }

    /// The settings: `base` (the defaults with a command's own settings, e.g. `segment
    /// --gap-factor`) with the options given, checked (the message names the option).
    pub fn settings_over(&self, base: DetectorSettings) -> Result<DetectorSettings, String> {
        let d = base;
        let s = DetectorSettings {
            window_s: self.window.unwrap_or(d.window_s),
            max_std_f_m_s2: self.max_std_f.unwrap_or(d.max_std_f_m_s2),
            max_std_w_rad_s: self.max_std_w.unwrap_or(d.max_std_w_rad_s),
            max_rate_rad_s: self.max_rate.unwrap_or(d.max_rate_rad_s),
            min_duration_s: self.min_duration.unwrap_or(d.min_duration_s),
            noise_factor: self.noise_factor.unwrap_or(d.noise_factor),
            // A window or minimum given is used as it is; otherwise the recording's rests set it.
            adapt_window: self.window.is_none(),
            adapt_min_duration: self.min_duration.is_none(),
            ..d
        };
        s.check().map_err(|e| {
            let option = e
                .split(' ')
                .next()
                .map(option_name)
                .unwrap_or_else(|| "a detector option".to_string());
            format!("{option}: {e}")
        })?;
        check_bounds(&s, &option_name)?;
        Ok(s)
    }
}

/// Upper bounds of the detector's settings, beyond which nothing is told from a rest (the
/// detector itself only asks for finite positive values): a window of at most 600 s; standard
/// deviations of at most 10 m/s^2 (a shaking of 1 g is no rest) and 1 rad/s; a mean rate of at
/// most 1 rad/s (57 deg/s); a shortest rest of at most 1e6 s; factors of at most 1000. The
/// message names the option (`option` maps a setting's field name to it).
pub fn check_bounds(s: &DetectorSettings, option: &dyn Fn(&str) -> String) -> Result<(), String> {
    for (field, v, max, unit) in [
        ("window_s", s.window_s, 600.0, " s"),
        ("max_std_f_m_s2", s.max_std_f_m_s2, 10.0, " m/s^2"),
        ("max_std_w_rad_s", s.max_std_w_rad_s, 1.0, " rad/s"),
        ("max_rate_rad_s", s.max_rate_rad_s, 1.0, " rad/s"),
        ("min_duration_s", s.min_duration_s, 1e6, " s"),
        ("noise_factor", s.noise_factor, 1000.0, ""),
        ("gap_factor", s.gap_factor, 1000.0, ""),
    ] {
        if v > max {
            return Err(format!(
                "{} {}: expected at most {max}{unit} (beyond it nothing is told from a rest)",
                option(field),
                crate::render::table::compact(v)
            ));
        }
    }
    Ok(())
}

/// Refuse a window or a shortest rest longer than the recording (`span_s`, the time from its
/// first to its last record), naming the option: no rest could be found, and the refusal
/// would otherwise blame the rests.
pub fn check_span(
    s: &DetectorSettings,
    span_s: f64,
    file: &str,
    option: &dyn Fn(&str) -> String,
) -> Result<(), String> {
    for (field, v, given) in [
        ("window_s", s.window_s, !s.adapt_window),
        ("min_duration_s", s.min_duration_s, !s.adapt_min_duration),
    ] {
        if given && v > span_s {
            return Err(format!(
                "{} {}: longer than the recording in {file} ({} s): expected at most its length",
                option(field),
                crate::render::table::compact(v),
                crate::render::table::compact(span_s)
            ));
        }
    }
    Ok(())
}

/// [`check_span`] of records read again from their source (one reading for the first and last
/// time stamps; nothing is checked without records).
pub fn check_span_streamed(
    s: &DetectorSettings,
    source: &mut ::calib::motion::detect::RateSource,
    file: &str,
    option: &dyn Fn(&str) -> String,
) -> Result<(), crate::Error> {
    let (mut first, mut last) = (f64::NAN, f64::NAN);
    source.records_of(&mut |r, _| {
        if first.is_nan() {
            first = r.t;
        }
        last = r.t;
    })?;
    if first.is_finite() {
        check_span(s, last - first, file, option)?;
    }
    Ok(())
}

/// The option of a detector setting (`DetectorSettings` field name), for messages and for
/// `Segmentation::missed_report`.
pub fn option_name(setting: &str) -> String {
    match setting {
        "window_s" => "--rest-window",
        "max_std_f_m_s2" => "--rest-max-std-f",
        "max_std_w_rad_s" => "--rest-max-std-w",
        "max_rate_rad_s" => "--rest-max-rate",
        "min_duration_s" => "--rest-min-duration",
        "noise_factor" => "--rest-noise-factor",
        "gap_factor" => "--gap-factor",
        _ => "a detector option",
    }
    .to_string()
}

/// The rests of a recording without a program, by the static detector with `settings`, on the
/// IMU clock (each from the start of its first record's interval to its last record's time
/// stamp), with the segmentation they come from: its `missed_report(option_name)` says when the
/// motion suggests more rests than were found, and which `--rest-*` options would take them.
/// The records are read again from `source` for every step (`segment`'s streamed detector),
/// not held.
pub fn rests_and_segmentation(
    source: &mut ::calib::motion::detect::RateSource,
    file: &str,
    settings: &DetectorSettings,
) -> Result<(Vec<Rest>, ::calib::motion::detect::Segmentation), crate::Error> {
    check_span_streamed(settings, source, file, &option_name)?;
    // The units `segment` checks (time stamps in seconds, specific force in m/s^2, the gyro
    // and accelerometer columns in their places, two records at least): rests found in
    // misread records would blame the rests ("only 2 directions") instead of the units.
    crate::recording_checks::check_plausible_streamed(source, file, settings.window_s)?;
    let seg = ::calib::motion::detect::segment_streamed(source, settings)
        .map_err(|e| format!("{file}: {e}"))?;
    crate::recording_checks::check_static_force(&seg, file)?;
    let dt = seg.median_interval_s;
    let rests = seg
        .static_intervals
        .iter()
        .map(|r| Rest {
            t0: r.start_s - dt,
            t1: r.end_s,
        })
        .collect();
    Ok((rests, seg))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(window: Option<f64>, min_duration: Option<f64>) -> DetectorArgs {
        DetectorArgs {
            window,
            max_std_f: None,
            max_std_w: None,
            max_rate: None,
            min_duration,
            noise_factor: None,
        }
    }

    #[test]
    fn a_given_window_or_minimum_is_not_adapted() {
        let s = args(None, None).settings().unwrap();
        assert!(s.adapt_window && s.adapt_min_duration);
        let s = args(Some(0.5), None).settings().unwrap();
        assert!(!s.adapt_window && s.adapt_min_duration);
        assert_eq!(s.window_s, 0.5);
        let s = args(None, Some(1.0)).settings().unwrap();
        assert!(s.adapt_window && !s.adapt_min_duration);
        assert_eq!(s.min_duration_s, 1.0);
    }

    #[test]
    fn bad_settings_name_the_option() {
        let e = args(Some(-1.0), None).settings().unwrap_err();
        assert!(e.starts_with("--rest-window: window_s = -1"), "{e}");
        let e = args(None, Some(f64::NAN)).settings().unwrap_err();
        assert!(e.starts_with("--rest-min-duration:"), "{e}");
    }
}
