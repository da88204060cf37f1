//! Checks of an IMU file's units against what an IMU at rest on the Earth measures, shared by
//! the commands that read records (`segment`, `noise`): time stamps in seconds, a specific
//! force of g at rest (not g units, not the gyro columns), magnitudes an IMU gives.

use crate::Error;
use crate::render::table;
use ::calib::motion::detect::Segmentation;

/// Refuse records no IMU gives before segmenting: a median interval outside
/// [`import::MEDIAN_INTERVAL_RANGE_S`] (1 Hz at the slowest: stamps in milliseconds read as
/// seconds are beyond it), a window longer than the recording, a rate or specific
/// force (increments over their interval) beyond [`import::MAX_GYRO_RAD_S`] /
/// [`import::MAX_ACCEL_M_S2`], named by line. The held form, for records already in memory
/// (`apply`'s first records, a recording of rests); the reference of the streamed one in tests.
pub(crate) fn check_plausible(
    data: &calib::io::ImuData,
    file: &str,
    window_s: f64,
) -> Result<(), Error> {
    let mut memory = calib::estimate::MemoryImu::new(data, file);
    let mut source = ::calib::motion::detect::RateSource::new(&mut memory)?;
    check_plausible_streamed(&mut source, file, window_s)
}

/// [`check_plausible`] of records read again from their source: one reading, two more for
/// the medians of the magnitudes only when the rates' median could be that of g.
pub(crate) fn check_plausible_streamed(
    source: &mut ::calib::motion::detect::RateSource,
    file: &str,
    window_s: f64,
) -> Result<(), Error> {
    let n = source.records;
    if n < 2 {
        return Err(
            format!("{file}: {n} record(s): expected at least two records to segment").into(),
        );
    }
    let median = source.median;
    let (lo, hi) = ::import::MEDIAN_INTERVAL_RANGE_S;
    if !(lo..=hi).contains(&median) {
        return Err(format!(
            "{file}: the time stamps advance by a median {median:e} s between records: expected \
             {lo} .. {hi} s (t in seconds; stamps in milliseconds need `import` with [time] unit \
             = \"ms\")"
        )
        .into());
    }
    const G: f64 = ::import::profile::STANDARD_GRAVITY;
    let (mut t0, mut t1) = (f64::NAN, f64::NAN);
    let mut k = 0usize;
    let mut bad: Option<String> = None;
    // Rates below the band of g: more than half of them put the median below it.
    let mut w_below = 0usize;
    let mut stuck = ::import::Stuck::default();
    source.read(&mut |t, w, f| {
        stuck.push_values(&w, &f);
        if k == 0 {
            t0 = t;
        }
        t1 = t;
        if bad.is_none() {
            bad = magnitude_error(file, k + 2, &w, &f);
        }
        if norm(&w) < G_AT_REST.0 * G {
            w_below += 1;
        }
        k += 1;
    })?;
    let span = t1 - t0;
    if window_s > span {
        return Err(format!(
            "--rest-window {window_s:e}: longer than the recording in {file} ({span:e} s): expected a \
             window of a few records up to the recording's length"
        )
        .into());
    }
    if let Some(message) = bad {
        return Err(message.into());
    }
    // A stuck sensor: a column that never changes (the records' lines from 2 on).
    stuck.check(2, n + 1).map_err(|m| format!("{file}: {m}"))?;
    // Gyro and accelerometer columns swapped: the "angular rate" has the magnitude of gravity
    // in m/s^2 for most of the recording (560 deg/s, which no calibration turns at for long)
    // while the "specific force" is far below g. Medians, so the turns of a program or a hand
    // do not decide it. (The median, the element of rank n / 2, is below the band when more
    // than n / 2 values are: then nothing more is read.)
    if w_below > n / 2 {
        return Ok(());
    }
    check_columns_streamed(source, file)
}

/// The Euclidean norm of a triad.
fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// The message on a record (at `line`) whose rate or specific force is beyond what an IMU
/// gives, or `None`.
fn magnitude_error(file: &str, line: usize, w: &[f64; 3], f: &[f64; 3]) -> Option<String> {
    [
        ("angular rate", norm(w), ::import::MAX_GYRO_RAD_S, "rad/s"),
        ("specific force", norm(f), ::import::MAX_ACCEL_M_S2, "m/s^2"),
    ]
    .into_iter()
    .find(|(_, v, max, _)| v.is_nan() || v >= max)
    .map(|(what, v, max, unit)| {
        format!(
            "{file}: line {line}: the {what} has magnitude {v:e} {unit}: expected below {max} \
             {unit} (check the units the file was written with)"
        )
    })
}

/// Refuse swapped gyro and accelerometer columns, from the medians of the magnitudes.
fn check_columns_streamed(
    source: &mut ::calib::motion::detect::RateSource,
    file: &str,
) -> Result<(), Error> {
    const G: f64 = ::import::profile::STANDARD_GRAVITY;
    let medians = ::calib::motion::detect::select::select_streamed(
        2,
        |_, len| len / 2,
        |visit| {
            source.read(&mut |_, w, f| {
                visit(0, norm(&w));
                visit(1, norm(&f));
            })
        },
    )?;
    let (w_median, f_median) = (medians[0], medians[1]);
    if (G_AT_REST.0 * G..=G_AT_REST.1 * G).contains(&w_median) && f_median < G_AT_REST.0 * G {
        return Err(format!(
            "{file}: the median angular rate is {} rad/s and the median specific force {} \
             m/s^2: expected about g = {G} m/s^2 of specific force and rates far below g's \
             number in rad/s; the gyro and accelerometer columns look swapped (wx, wy, wz come \
             before fx, fy, fz)",
            table::significant(w_median, 4),
            table::significant(f_median, 4),
        )
        .into());
    }
    Ok(())
}

/// The median specific force of a recording (at rest, on a turntable or turned by hand) is
/// about g: outside [`G_AT_REST`] times g the accelerometer values are not in m/s^2 (in g, or
/// not an accelerometer's). For commands that find no rests (`apply`).
pub(crate) fn check_median_gravity(data: &calib::io::ImuData, file: &str) -> Result<(), Error> {
    const G: f64 = ::import::profile::STANDARD_GRAVITY;
    let (_, _, f) = ::calib::motion::detect::rates_of(data);
    let mut norms: Vec<f64> = f
        .iter()
        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
        .collect();
    if norms.is_empty() {
        return Ok(());
    }
    let m = median(&mut norms);
    if !(G_AT_REST.0 * G..=G_AT_REST.1 * G).contains(&m) {
        return Err(format!(
            "{file}: the median specific force is {} m/s^2 ({} g): expected about g = {G} m/s^2 \
             (within {} .. {} g); the accelerometer values are not in m/s^2 (in g?) or the \
             records are not of an IMU",
            table::significant(m, 4),
            table::significant(m / G, 4),
            G_AT_REST.0,
            G_AT_REST.1
        )
        .into());
    }
    Ok(())
}

/// The specific force at rest is gravity: a static interval whose mean |f| is outside
/// [`G_AT_REST`] times g is refused (the file's accelerometers are not in m/s^2, or read
/// nothing).
pub(crate) fn check_static_force(seg: &Segmentation, file: &str) -> Result<(), Error> {
    const G: f64 = ::import::profile::STANDARD_GRAVITY;
    for (i, x) in seg.static_intervals.iter().enumerate() {
        let ratio = x.norm_f_m_s2 / G;
        if !(G_AT_REST.0..=G_AT_REST.1).contains(&ratio) {
            return Err(format!(
                "{file}: static interval {} (t = {} .. {} s, line {} ..) has a mean specific \
                 force of {} m/s^2 ({} g): expected g = {G} m/s^2 at rest, within {} .. {} g; \
                 the accelerometer values are not in m/s^2 or the records are not of an IMU",
                i + 1,
                x.start_s,
                x.end_s,
                x.first_record + 2,
                table::significant(x.norm_f_m_s2, 4),
                table::significant(ratio, 4),
                G_AT_REST.0,
                G_AT_REST.1
            )
            .into());
        }
    }
    Ok(())
}

/// The band of the mean specific force of a static interval, in units of g.
const G_AT_REST: (f64, f64) = (0.5, 1.5);

#[cfg(test)] // the held form, the reference of the streamed one in tests
/// A recording said to be at rest throughout (`noise --all-at-rest`) must be: refused when its
/// median specific force is not g (g units, swapped columns), or when it moves in more than
/// [`MAX_MOVING_FRACTION`] of its windows of `window` records. A window moves when its
/// gyro spread (root of the summed axis variances) exceeds [`MOTION_SPREAD_FACTOR`] times the
/// median window's, or its mean specific force leaves the recording's median by more than
/// [`MAX_TILT_M_S2`]. Both measures ignore a constant gyro bias or a slow drift, which at rest
/// can pass the detector's rate threshold and are why a recording is declared at rest.
pub(crate) fn check_at_rest(
    data: &calib::io::ImuData,
    file: &str,
    window: usize,
    window_s: f64,
) -> Result<(), Error> {
    let (_, w, f) = ::calib::motion::detect::rates_of(data);
    let mut norms: Vec<f64> = f.iter().map(norm).collect();
    check_median_force_at_rest(median(&mut norms), file)?;
    let window = window.max(2);
    let windows = f.len() / window;
    if windows < 2 {
        return Ok(());
    }
    let mut f_all = [Vec::new(), Vec::new(), Vec::new()];
    for x in &f {
        for a in 0..3 {
            f_all[a].push(x[a]);
        }
    }
    let f_median = [
        median(&mut f_all[0]),
        median(&mut f_all[1]),
        median(&mut f_all[2]),
    ];
    let spreads: Vec<f64> = w.chunks_exact(window).map(spread_of).collect();
    let typical = median(&mut spreads.clone());
    let spinning = spreads
        .iter()
        .filter(|s| **s > MOTION_SPREAD_FACTOR * typical)
        .count();
    let tilted = f
        .chunks_exact(window)
        .filter(|c| {
            let m = mean_of(c);
            norm(&[m[0] - f_median[0], m[1] - f_median[1], m[2] - f_median[2]]) > MAX_TILT_M_S2
        })
        .count();
    check_moving(file, (windows, spinning, tilted), window_s, typical)
}

/// `check_at_rest` (the held form, in tests) of records read again from their source: the
/// medians by streamed selection ([`::calib::motion::detect::select`]), the windows' spreads from a window of
/// records; the same verdict and message.
pub(crate) fn check_at_rest_streamed(
    source: &mut ::calib::motion::detect::RateSource,
    file: &str,
    window: usize,
    window_s: f64,
) -> Result<(), Error> {
    let medians = ::calib::motion::detect::select::select_streamed(
        5,
        |_, len| len / 2,
        |visit| {
            source.read(&mut |_, w, f| {
                visit(0, norm(&f));
                for (a, x) in f.into_iter().enumerate() {
                    visit(1 + a, x);
                }
                visit(4, norm(&w));
            })
        },
    )?;
    check_median_force_at_rest(medians[0], file)?;
    check_median_rate_at_rest(medians[4], file)?;
    let window = window.max(2);
    let windows = source.records / window;
    if windows < 2 {
        return Ok(());
    }
    let f_median = [medians[1], medians[2], medians[3]];
    // Every full window of records, as `chunks_exact` gives them: (gyro spread, whether its
    // mean specific force is tilted from the median).
    let mut windows_of = |visit: &mut dyn FnMut(f64, bool)| {
        let (mut w_buf, mut f_buf) = (Vec::with_capacity(window), Vec::with_capacity(window));
        source.read(&mut |_, w, f| {
            w_buf.push(w);
            f_buf.push(f);
            if w_buf.len() == window {
                let m = mean_of(&f_buf);
                let tilted = norm(&[m[0] - f_median[0], m[1] - f_median[1], m[2] - f_median[2]])
                    > MAX_TILT_M_S2;
                visit(spread_of(&w_buf), tilted);
                w_buf.clear();
                f_buf.clear();
            }
        })
    };
    let typical = ::calib::motion::detect::select::select_streamed(
        1,
        |_, len| len / 2,
        |visit| windows_of(&mut |spread, _| visit(0, spread)),
    )?[0];
    let (mut spinning, mut tilted) = (0usize, 0usize);
    windows_of(&mut |spread, tilt| {
        if spread > MOTION_SPREAD_FACTOR * typical {
            spinning += 1;
        }
        if tilt {
            tilted += 1;
        }
    })?;
    check_moving(file, (windows, spinning, tilted), window_s, typical)
}

/// A recording said to be at rest has a median specific force of g (`median_f`, m/s^2).
fn check_median_force_at_rest(median_f: f64, file: &str) -> Result<(), Error> {
    const G: f64 = ::import::profile::STANDARD_GRAVITY;
    let ratio = median_f / G;
    if !(G_AT_REST.0..=G_AT_REST.1).contains(&ratio) {
        return Err(format!(
            "{file}: the median specific force of the recording (--all-at-rest) is {} m/s^2 ({} \
             g): expected g = {G} m/s^2 at rest, within {} .. {} g; the accelerometer values are \
             not in m/s^2, or the gyro and accelerometer columns are swapped",
            table::significant(median_f, 4),
            table::significant(ratio, 4),
            G_AT_REST.0,
            G_AT_REST.1
        )
        .into());
    }
    Ok(())
}

/// A recording said to be at rest turns at no more than the rest detector's largest mean
/// rate (`DetectorSettings::max_rate_rad_s`), measured on the median of the records' rate
/// magnitudes (`median_rate`, rad/s; a turn about any axis counts): a unit turning steadily (a
/// turntable at 20 deg/s about the vertical) keeps its gyro spread and its specific force, so
/// the other checks pass it, and its rate would be read as a bias walk.
fn check_median_rate_at_rest(median_rate: f64, file: &str) -> Result<(), Error> {
    let max = ::calib::motion::detect::DetectorSettings::default().max_rate_rad_s;
    let rate = median_rate;
    if rate.is_nan() || rate > max {
        return Err(format!(
            "{file}: --all-at-rest, but the recording turns: its median rate is {} deg/s \
             ({} rad/s): expected a unit at rest, below the rest detector's {} deg/s ({max} \
             rad/s); leave out --all-at-rest to use the static intervals the detector finds",
            table::significant(rate.to_degrees(), 3),
            table::significant(rate, 3),
            table::significant(max.to_degrees(), 3),
        )
        .into());
    }
    Ok(())
}

/// Refuse a recording said to be at rest that moves in more than [`MAX_MOVING_FRACTION`] of
/// its `windows` (`spinning` of them with a gyro spread above [`MOTION_SPREAD_FACTOR`] times
/// the `typical` one, `tilted` with their mean specific force off the median).
fn check_moving(
    file: &str,
    (windows, spinning, tilted): (usize, usize, usize),
    window_s: f64,
    typical: f64,
) -> Result<(), Error> {
    let moving = spinning.max(tilted);
    if moving as f64 > MAX_MOVING_FRACTION * windows as f64 {
        return Err(format!(
            "{file}: --all-at-rest, but the recording moves: of its {windows} windows of {} s, \
             {spinning} have a gyro spread above {MOTION_SPREAD_FACTOR} times the median \
             window's ({} rad/s) and {tilted} a mean specific force more than {MAX_TILT_M_S2} \
             m/s^2 from the recording's median: expected at most a tenth of them; leave out \
             --all-at-rest to use the detector's static intervals",
            table::significant(window_s, 3),
            table::significant(typical, 3),
        )
        .into());
    }
    Ok(())
}

/// The mean of triads.
fn mean_of(v: &[[f64; 3]]) -> [f64; 3] {
    let mut m = [0.0; 3];
    for x in v {
        for a in 0..3 {
            m[a] += x[a] / v.len() as f64;
        }
    }
    m
}

/// The spread of triads: the root of the summed axis variances.
fn spread_of(v: &[[f64; 3]]) -> f64 {
    let m = mean_of(v);
    let ss: f64 = v
        .iter()
        .map(|x| (0..3).map(|a| (x[a] - m[a]).powi(2)).sum::<f64>())
        .sum();
    (ss / (v.len() - 1) as f64).sqrt()
}

/// A window's gyro spread this many times the median window's is motion: white noise's
/// windowed spread varies by a few per cent over windows of tens of records, vibration from
/// the building by a factor of two or three; a turn by hand or a turntable's start and stop by
/// orders of magnitude.
const MOTION_SPREAD_FACTOR: f64 = 10.0;

/// A window's mean specific force this far from the recording's median is a change of pose
/// (m/s^2): about 3 deg of tilt, far above the thermal drift of an accelerometer bias
/// (milli-g).
const MAX_TILT_M_S2: f64 = 0.5;

/// The largest fraction of windows that may move in a recording declared at rest: a door
/// slammed or a cable touched now and then is still a recording at rest.
const MAX_MOVING_FRACTION: f64 = 0.1;

// The held form's median (`check_median_gravity`, and the references of the streamed checks).
/// The median of `v` (reordered); NaN when empty.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib::io::{ImuData, ImuKind, ImuRecord};

    /// Records at 100 Hz: at rest with noise, or turning now and then, or with the gyro and
    /// accelerometer columns swapped.
    fn records(turning: bool, swapped: bool) -> ImuData {
        let mut state = 5u64;
        let mut u = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64 - 0.5
        };
        let records = (0..20_000)
            .map(|i| {
                let t = 0.01 * (i + 1) as f64;
                let turn = turning && (i / 500) % 3 == 1;
                let w = [1e-3 * u(), 1e-3 * u(), if turn { 0.5 } else { 1e-3 * u() }];
                let f = [0.01 * u(), 0.01 * u(), 9.81 + 0.01 * u()];
                let (gyro, accel) = if swapped { (f, w) } else { (w, f) };
                ImuRecord {
                    t,
                    gyro,
                    accel,
                    temp: None,
                }
            })
            .collect();
        ImuData {
            kind: ImuKind::Rates,
            records,
        }
    }

    /// The streamed checks say what the held ones say, message for message.
    #[test]
    fn streamed_checks_equal_the_held_ones() {
        for (turning, swapped) in [(false, false), (true, false), (false, true)] {
            let data = records(turning, swapped);
            let mut memory = calib::estimate::MemoryImu::new(&data, "imu.csv");
            let mut source = ::calib::motion::detect::RateSource::new(&mut memory).unwrap();
            let held = check_at_rest(&data, "imu.csv", 101, 1.0).map_err(|e| e.to_string());
            let streamed =
                check_at_rest_streamed(&mut source, "imu.csv", 101, 1.0).map_err(|e| e.to_string());
            assert_eq!(held, streamed, "turning {turning} swapped {swapped}");
            assert_eq!(held.is_ok(), !turning && !swapped);
        }
        // The swapped columns, refused by the plausibility check too (from its medians).
        let data = records(false, true);
        let e = check_plausible(&data, "imu.csv", 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("look swapped"), "{e}");
    }
}
