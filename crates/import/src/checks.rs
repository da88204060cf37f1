//! The checks of an import and their refusals, each naming the file, the line and what was
//! expected: times finite and increasing, two files joined row by row, temperatures in range,
//! the time base, gaps, magnitudes, the specific force at rest against g; and the rounding of
//! the numbers the messages show.

use crate::profile::{self, Form, Join, Profile, STANDARD_GRAVITY, Sensor, Unit};
use crate::report::GapReport;
use crate::{
    G_BAND, ImportError, MAX_ACCEL_M_S2, MAX_GYRO_RAD_S, MEDIAN_INTERVAL_RANGE_S, QUIET_WINDOW_S,
    StaticForce,
};
use calib::io::ImuRecord;
use calib::io::timing::Timing;

/// A time that is not finite, refused.
pub(crate) fn time_not_finite(file: &str, line: usize, ti: f64) -> ImportError {
    ImportError::line(
        file,
        line,
        format!(
            "the time comes out as {ti} s: expected a finite time (check the profile's [time])"
        ),
    )
}

/// A time not after the previous row's (`p`, on line `previous_line`), refused.
pub(crate) fn time_not_increasing(
    profile: &Profile,
    file: &str,
    line: usize,
    ti: f64,
    p: f64,
    previous_line: usize,
) -> ImportError {
    let what = if profile.time.counter_column.is_some() {
        "sample counter"
    } else {
        "time"
    };
    ImportError::line(
        file,
        line,
        format!(
            "t = {} s is not after the previous row's t = {} s (line {}): expected a strictly \
             increasing {what}",
            show_t(ti),
            show_t(p),
            previous_line
        ),
    )
}

/// The join's tolerance: the profile's, or a tenth of the gyro file's median interval.
pub(crate) fn join_tolerance(
    profile: &Profile,
    g_file: &str,
    median: f64,
) -> Result<f64, ImportError> {
    let tol = profile.input.join_tolerance_s.unwrap_or(0.1 * median);
    let tol = if tol.is_finite() { tol } else { 0.0 };
    if profile.input.join_tolerance_s.is_some() && tol >= 0.5 * median {
        return Err(ImportError::profile(
            &profile.origin,
            format!(
                "[input] join_tolerance_s = {tol}: expected less than half the median interval \
                 of {g_file} ({} s), so that a row pairs only with the row of its own time",
                round_sig(median)
            ),
        ));
    }
    Ok(tol)
}

/// A data row as the join names it.
#[derive(Clone, Copy)]
pub(crate) struct JoinRow<'a> {
    pub(crate) file: &'a str,
    pub(crate) line: usize,
    pub(crate) t: f64,
}

/// The error of a gyro row and an accelerometer row of the same position that do not pair.
pub(crate) fn join_pair(
    profile: &Profile,
    tol: f64,
    g: JoinRow<'_>,
    a: JoinRow<'_>,
    roles: [&str; 2],
) -> Option<ImportError> {
    let has_time = profile.time.column.is_some() || profile.time.counter_column.is_some();
    match profile.input.join {
        Join::Time => {
            let d = g.t - a.t;
            if d.abs() > tol {
                // The file whose time is earlier has a row the other lacks.
                let (lone, other) = if d < 0.0 { (g, a) } else { (a, g) };
                return Some(ImportError::line(
                    lone.file,
                    lone.line,
                    format!(
                        "t = {} s has no row with the same time in {} (its row there, line {}, \
                         has t = {} s): expected the {} and {} files to hold the same time \
                         stamps, within join_tolerance_s = {tol} s",
                        show_t(lone.t),
                        other.file,
                        other.line,
                        show_t(other.t),
                        roles[0],
                        roles[1]
                    ),
                ));
            }
        }
        Join::Row => {
            if has_time && (g.t - a.t).abs() > tol {
                return Some(ImportError::line(
                    a.file,
                    a.line,
                    format!(
                        "t = {} s, but line {} of {} has t = {} s: expected rows joined by \
                         position to have the same time within join_tolerance_s = {tol} s",
                        show_t(a.t),
                        g.line,
                        g.file,
                        show_t(g.t)
                    ),
                ));
            }
        }
    }
    None
}

/// Row `n` of the longer file (`long`) has no partner: the other file (`short_file`) has `n`
/// rows.
pub(crate) fn unpartnered(
    long: JoinRow<'_>,
    n: usize,
    short_file: &str,
    roles: [&str; 2],
) -> ImportError {
    ImportError::line(
        long.file,
        long.line,
        format!(
            "row {} (t = {} s) has no partner: {} ends after {} rows; expected the {} and {} files \
             to have as many rows",
            n + 1,
            show_t(long.t),
            short_file,
            n,
            roles[0],
            roles[1]
        ),
    )
}

/// A file's temperature value in deg C, refused outside [`profile::TEMP_RANGE_C`] with the
/// file, the line and the field (`place`, as the reader names it).
pub(crate) fn celsius(
    tc: &profile::Temperature,
    raw: f64,
    file: &str,
    line: usize,
    place: &str,
) -> Result<f64, ImportError> {
    let c = tc.to_celsius(raw);
    let (lo, hi) = profile::TEMP_RANGE_C;
    if (lo..=hi).contains(&c) {
        return Ok(c);
    }
    let conversion = match tc.unit {
        profile::TempUnit::Counts => format!(
            "check [temperature] offset ({}) and sensitivity ({} counts per deg C)",
            tc.offset.unwrap_or(f64::NAN),
            tc.sensitivity.unwrap_or(f64::NAN)
        ),
        u => format!(
            "check [temperature] unit (\"{}\"; \"degC\", \"K\", \"degF\", or \"counts\" with \
             offset and sensitivity)",
            u.name()
        ),
    };
    Err(ImportError::line(
        file,
        line,
        format!(
            "temperature ({}){place}: `{}` {} gives {} deg C: expected {lo} .. {hi} deg C; \
             {conversion} and column",
            tc.column,
            raw,
            tc.unit.name(),
            show_number(c)
        ),
    ))
}

/// A recording of one row, refused.
pub(crate) fn too_short(file: &str, line: usize) -> ImportError {
    ImportError::line(
        file,
        line,
        "expected at least two data rows (a recording), found one",
    )
}

/// Gaps refused (without `--allow-gaps`), at the first.
pub(crate) fn check_gaps(
    profile: &Profile,
    timing: &Timing,
    gap_reports: &[GapReport],
    line: impl Fn(usize) -> usize,
) -> Result<(), ImportError> {
    let Some(g) = gap_reports.first() else {
        return Ok(());
    };
    Err(ImportError::line(
        &g.file,
        g.line,
        format!(
            "a gap of {} s ({:.1} median intervals of {} s) between t = {} s (line {}) and t = {} \
             s: expected intervals of at most {} median intervals ({} gap{} in all); gaps are \
             never bridged: import with gaps allowed (sins-calib import --allow-gaps) to keep \
             the records as they are with the gaps recorded in import.json",
            round_sig(g.length_s),
            g.median_intervals,
            round_sig(timing.median_interval_s),
            show_t(g.t_before_s),
            line(g.record - 1),
            show_t(g.t_after_s),
            profile.checks.gap_factor,
            gap_reports.len(),
            if gap_reports.len() == 1 { "" } else { "s" }
        ),
    ))
}

/// The median interval must be plausible for an IMU; stamps in milliseconds (or micro-,
/// nanoseconds) declared as seconds are named as such.
pub(crate) fn check_time_base(
    profile: &Profile,
    file: &str,
    first_line: usize,
    median: f64,
) -> Result<(), ImportError> {
    let (lo, hi) = MEDIAN_INTERVAL_RANGE_S;
    let time = &profile.time;
    let seconds = time.column.is_some() && time.unit.unwrap_or_default() == profile::TimeUnit::S;
    // An IMU records at 10 Hz .. 10 kHz: stamps declared in seconds that advance a thousand
    // (million, billion) times that interval are in a smaller unit.
    let smaller = [(1e3, "ms"), (1e6, "us"), (1e9, "ns")]
        .into_iter()
        .find(|(f, _)| (1e-4..=0.1).contains(&(median / f)));
    let cause = match (seconds, smaller) {
        (true, Some((f, unit))) if median >= 1.0 => format!(
            "the stamps look like {unit} declared as seconds (in {unit} the interval would be {} \
             s, {} Hz): set [time] unit = \"{unit}\"",
            round_sig(median / f),
            round_sig(f / median)
        ),
        _ if (lo..=hi).contains(&median) => return Ok(()),
        _ if time.column.is_some() => format!(
            "check [time] column and unit (unit = \"{}\")",
            match time.unit.unwrap_or_default() {
                profile::TimeUnit::S => "s",
                profile::TimeUnit::Ms => "ms",
                profile::TimeUnit::Us => "us",
                profile::TimeUnit::Ns => "ns",
            }
        ),
        _ => format!(
            "check [time] rate_hz = {} (and counter_column)",
            time.rate_hz.unwrap_or(f64::NAN)
        ),
    };
    Err(ImportError::line(
        file,
        first_line,
        format!(
            "the time stamps (profile {}) advance by a median {} s ({} Hz) between records: \
             expected {lo} .. {hi} s, an IMU recording at 1 Hz or more; {cause}",
            profile.origin,
            show_number(median),
            show_number(1.0 / median)
        ),
    ))
}

/// The first sensor (0 gyro, 1 accelerometer), axis and value of a record beyond the plausible
/// magnitude (`dt`: its interval, for increments).
pub(crate) fn beyond_magnitude(form: Form, r: &ImuRecord, dt: f64) -> Option<(usize, usize, f64)> {
    let scale = if form == Form::Increments {
        1.0 / dt
    } else {
        1.0
    };
    for (s, (values, max)) in [(r.gyro, MAX_GYRO_RAD_S), (r.accel, MAX_ACCEL_M_S2)]
        .into_iter()
        .enumerate()
    {
        for (i, v) in values.iter().enumerate() {
            let v = v * scale;
            if v.abs() >= max {
                return Some((s, i, v));
            }
        }
    }
    None
}

/// The refusal of a converted value `v` of sensor `s` (0 gyro, 1 accelerometer), axis `i`,
/// beyond the plausible magnitude, on `line` of `file`.
pub(crate) fn magnitude_error(
    profile: &Profile,
    s: usize,
    i: usize,
    v: f64,
    file: &str,
    line: usize,
) -> ImportError {
    let increments = profile.form == Form::Increments;
    let (name, sensor, max, unit) = if s == 0 {
        ("gyro", &profile.gyro, MAX_GYRO_RAD_S, "rad/s")
    } else {
        ("accel", &profile.accel, MAX_ACCEL_M_S2, "m/s^2")
    };
    let source = sensor.axes[i].source;
    let conversion = if sensor.unit == Unit::Counts {
        format!(
            "check [{name}] offset and sensitivity (counts per {}, here {:e}) and \
             sensitivity_unit",
            sensor.sensitivity_unit.map_or("?", Unit::name),
            sensor.sensitivity.map_or(f64::NAN, |s| s[source])
        )
    } else {
        format!(
            "the values look like raw counts: set [{name}] unit = \"counts\" with offset and \
             sensitivity (unit is \"{}\")",
            sensor.unit.name()
        )
    };
    ImportError::line(
        file,
        line,
        format!(
            "{name} {} ({}) gives {:.4e} {unit}{} after conversion: expected a magnitude below \
             {max} {unit}; {conversion}; check the columns in {}",
            ["x", "y", "z"][i],
            sensor.columns[source],
            v,
            if increments {
                " (increment over its interval)"
            } else {
                ""
            },
            profile.origin
        ),
    )
}

/// Rounded to 4 significant digits, for messages.
pub(crate) fn round_sig(x: f64) -> f64 {
    round_to(x, 4)
}

/// Rounded to `digits` significant digits (shown without the float noise of sums such as
/// `1.0600000000000001`).
fn round_to(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    if !scale.is_finite() || scale == 0.0 {
        return x;
    }
    (x * scale).round() / scale
}

/// A number for messages: 4 significant digits, in exponent form when very large or small
/// (`1e300` rather than 301 digits).
pub(crate) fn show_number(x: f64) -> String {
    if x != 0.0 && !(1e-4..1e7).contains(&x.abs()) {
        format!("{x:.3e}")
    } else {
        format!("{}", round_sig(x))
    }
}

/// A time stamp for messages: 10 significant digits.
pub(crate) fn show_t(t: f64) -> f64 {
    round_to(t, 10)
}

/// The check of the median specific force `median` over the quietest window (`window_s`, on
/// `lines` of `file`) against g.
pub(crate) fn static_force(
    profile: &Profile,
    median: f64,
    std: f64,
    window_s: [f64; 2],
    file: &str,
    lines: [usize; 2],
) -> Result<StaticForce, ImportError> {
    let ratio = median / STANDARD_GRAVITY;
    let found = StaticForce {
        median_norm_m_s2: median,
        ratio_to_g: ratio,
        window_s,
        std_m_s2: std,
    };
    if (G_BAND.0..=G_BAND.1).contains(&ratio) {
        return Ok(found);
    }
    let cause = force_cause(&profile.accel, profile.form, ratio);
    Err(ImportError::line(
        file,
        lines[0],
        format!(
            "the specific force at rest has a median magnitude of {} m/s^2 ({} g) over lines \
             {}..{} (t = {} .. {} s, the quietest {} s of the recording): expected g = {} m/s^2 \
             within {} to {} g; {cause}",
            round_sig(median),
            round_sig(ratio),
            lines[0],
            lines[1],
            show_t(window_s[0]),
            show_t(window_s[1]),
            QUIET_WINDOW_S,
            STANDARD_GRAVITY,
            G_BAND.0,
            G_BAND.1
        ),
    ))
}

/// The likely cause of a specific force at rest of `ratio` g.
fn force_cause(accel: &Sensor, form: Form, ratio: f64) -> String {
    let near = |x: f64| (0.8 * x..=1.2 * x).contains(&ratio);
    let per = |u: Option<Unit>| u.map_or("?", Unit::name);
    let increments = if form == Form::Increments {
        " (increments are divided by their record interval: check that the file holds velocity \
         increments, not specific force)"
    } else {
        ""
    };
    let cause = if ratio < 0.01 {
        "the accelerometers read almost nothing: check [accel] columns (a gyro or a counter \
         column?) and, for counts, the offset"
            .to_string()
    } else if accel.unit == Unit::Counts {
        let su = accel.sensitivity_unit;
        if su == Some(Unit::MPerS2) && near(1.0 / STANDARD_GRAVITY) {
            "about 1/9.81 of g: the sensitivity looks given in counts per g, not per m/s^2 \
             (sensitivity_unit = \"g\")"
                .to_string()
        } else if su == Some(Unit::G) && near(STANDARD_GRAVITY) {
            "about 9.81 g: the sensitivity looks given in counts per m/s^2, not per g \
             (sensitivity_unit = \"m/s^2\")"
                .to_string()
        } else {
            format!(
                "check the accelerometer offset (counts at zero) and sensitivity (counts per {}), \
                 and the columns",
                per(su)
            )
        }
    } else if ratio > 100.0 {
        format!(
            "the values look like raw counts: set unit = \"counts\" with offset and sensitivity \
             (unit is \"{}\")",
            accel.unit.name()
        )
    } else if accel.unit == Unit::MPerS2 && near(1.0 / STANDARD_GRAVITY) {
        "the accelerometers look given in g, not m/s^2: set unit = \"g\"".to_string()
    } else if accel.unit == Unit::G && near(STANDARD_GRAVITY) {
        "the accelerometers look given in m/s^2, not g: set unit = \"m/s^2\"".to_string()
    } else {
        format!(
            "check the accelerometer unit (unit = \"{}\") and columns",
            accel.unit.name()
        )
    };
    cause + increments
}
