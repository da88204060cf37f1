//! Checks of the IMU data before any filter runs: values no sensor gives, and a specific force
//! or rate that cannot be a turntable run in SI units. Each refusal names the file, the line or
//! time, and the likely cause (units, column order, a dead sensor).

use crate::io::{ImuKind, ImuRecord, IoError};
use crate::motion::align::RateBin;

/// Largest angular rate accepted (rad/s): 100 rad/s is 5700 deg/s, beyond any turntable and
/// beyond the range of navigation and tactical gyros (up to about 1000 deg/s).
pub const MAX_RATE_RAD_S: f64 = 100.0;

/// Largest specific force accepted (m/s^2): 100 g, beyond any turntable run.
pub const MAX_SPECIFIC_FORCE_M_S2: f64 = 981.0;

/// Values of a column closer than this (relative) to its first are the same value.
const STUCK_RELATIVE: f64 = 1e-9;

/// Whether each of the six data columns (gyro x, y, z, accelerometer x, y, z) ever changes: a
/// triad holding one value over a whole recording is a stuck sensor (or constants written in
/// its place), whose records would be imported as one long rest without a word.
#[derive(Default)]
pub struct Stuck {
    first: Option<[f64; 6]>,
    varies: [bool; 6],
    records: usize,
}

impl Stuck {
    /// Recordings of at least this many records are checked: a few hundred identical records
    /// can be a hand-made example or a short excerpt quantised flat; a stuck sensor shows over
    /// seconds (10 s at 100 Hz).
    const MIN_RECORDS: usize = 1000;

    /// One record.
    pub fn push(&mut self, r: &ImuRecord) {
        self.push_values(&r.gyro, &r.accel);
    }

    /// One record's gyro and accelerometer values.
    pub fn push_values(&mut self, gyro: &[f64; 3], accel: &[f64; 3]) {
        let v = [gyro[0], gyro[1], gyro[2], accel[0], accel[1], accel[2]];
        self.records += 1;
        match &self.first {
            None => self.first = Some(v),
            Some(f) => {
                // Relative to the first value: rates computed from stuck increments over
                // intervals whose stamps carry rounding still differ in the 15th digit.
                for k in 0..6 {
                    self.varies[k] |= (v[k] - f[k]).abs() > STUCK_RELATIVE * f[k].abs();
                }
            }
        }
    }

    /// Refuse a recording (lines `first_line` .. `last_line`) with a sensor triad (gyro or
    /// accelerometer) none of whose columns ever changes: `Err` holds the message, which names
    /// the lines, the columns and their value (the caller adds the file).
    pub fn check(&self, first_line: usize, last_line: usize) -> Result<(), String> {
        const NAMES: [&str; 6] = [
            "gyro x", "gyro y", "gyro z", "accel x", "accel y", "accel z",
        ];
        let (Some(first), true) = (self.first, self.records >= Self::MIN_RECORDS) else {
            return Ok(());
        };
        // A whole triad frozen: a sensor (or the recording) stuck. One constant axis alone is
        // left to the other checks (synthetic and hand-made files hold zero columns), and so is
        // a triad of zeros, which they name better (accelerometers that read zero, gyros that
        // read nothing while the program turns).
        let frozen = |range: std::ops::Range<usize>| {
            range.clone().all(|k| !self.varies[k]) && range.clone().any(|k| first[k] != 0.0)
        };
        let stuck: Vec<String> = [0..3, 3..6]
            .into_iter()
            .filter(|r| frozen(r.clone()))
            .flatten()
            .map(|k| format!("{} = {}", NAMES[k], first[k]))
            .collect();
        if stuck.is_empty() {
            return Ok(());
        }
        Err(format!(
            "lines {first_line} .. {last_line}: the columns are the same in all {} records \
                 ({}): expected values that change (a sensor's noise moves every axis); a \
                 constant triad is a stuck sensor or values written in its place, and would be \
                 read as one long rest",
            self.records,
            stuck.join(", ")
        ))
    }
}

/// Refuse a record whose rate or specific force no sensor on a turntable gives (e.g. `1e308`),
/// naming its line.
pub fn check_record(
    rec: &ImuRecord,
    kind: ImuKind,
    dt: f64,
    file: &str,
    line: usize,
) -> Result<(), IoError> {
    let scale = match kind {
        ImuKind::Increments => 1.0 / dt,
        ImuKind::Rates => 1.0,
    };
    let rate = rec
        .gyro
        .iter()
        .map(|v| (v * scale).abs())
        .fold(0.0, f64::max);
    let force = rec
        .accel
        .iter()
        .map(|v| (v * scale).abs())
        .fold(0.0, f64::max);
    let what = match kind {
        ImuKind::Increments => "increment",
        ImuKind::Rates => "value",
    };
    // NaN never gets here (the readers refuse it), infinity does.
    if rate.is_nan() || rate > MAX_RATE_RAD_S {
        return Err(IoError::Line {
            file: file.to_string(),
            line,
            message: format!(
                "a gyro {what} amounts to {rate:.4e} rad/s: expected at most {MAX_RATE_RAD_S} rad/s \
                 (5700 deg/s, beyond any gyro on a turntable); check the units (rad, rad/s) and the \
                 column order"
            ),
        });
    }
    if force.is_nan() || force > MAX_SPECIFIC_FORCE_M_S2 {
        return Err(IoError::Line {
            file: file.to_string(),
            line,
            message: format!(
                "an accelerometer {what} amounts to {force:.4e} m/s^2: expected at most \
                 {MAX_SPECIFIC_FORCE_M_S2} m/s^2 (100 g); check the units (m/s, m/s^2) and the \
                 column order"
            ),
        });
    }
    Ok(())
}

/// Refuse data whose specific force is not gravity's: on a turntable its magnitude is `g` (the
/// centripetal part is below 1e-3 g), whatever the attitude. The median over the bins is
/// compared with the site's `g`, and the likely cause is named.
pub fn check_specific_force(bins: &[RateBin], g: f64, file: &str) -> Result<(), IoError> {
    check_specific_force_within(bins, g, 0.05, file)
}

/// [`check_specific_force`] with the relative tolerance `tol` (at least 5 %): a unit whose
/// priors allow per-cent scale factors and biases of a sizeable fraction of g reads a median
/// `|f|` further from g.
pub fn check_specific_force_within(
    bins: &[RateBin],
    g: f64,
    tol: f64,
    file: &str,
) -> Result<(), IoError> {
    let tol = tol.max(0.05);
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let f = median(bins.iter().map(|b| b.f.norm()).collect());
    let w = median(bins.iter().map(|b| b.rate.norm()).collect());
    if (f / g - 1.0).abs() <= tol {
        return Ok(());
    }
    let (t0, t1) = (
        bins.first().map_or(0.0, |b| b.t0),
        bins.last().map_or(0.0, |b| b.t1),
    );
    let cause = if (w / g - 1.0).abs() <= 0.05 {
        "the gyro columns hold about g: the gyro and accelerometer columns look swapped".to_string()
    } else if f < 1e-3 * g {
        "the accelerometers read zero".to_string()
    } else if (f - 1.0).abs() <= 0.05 {
        "it is 1: the accelerometers look given in g, not m/s^2".to_string()
    } else {
        format!(
            "it is {:.3} g: check the accelerometer units and scale",
            f / g
        )
    };
    Err(IoError::File {
        file: file.to_string(),
        message: format!(
            "the specific force has a median magnitude of {f:.4} m/s^2 over t = {t0:.3} .. \
             {t1:.3} s: expected g = {g:.4} m/s^2 at rest (within {:.0} %); {cause}",
            100.0 * tol
        ),
    })
}

/// Refuse gyros that read (almost) nothing while the data are long enough for a program that
/// turns: the median rate is compared with the Earth rate.
pub fn check_gyros_alive(bins: &[RateBin], program_turns: bool, file: &str) -> Result<(), IoError> {
    let max = bins.iter().map(|b| b.rate.norm()).fold(0.0, f64::max);
    // A tenth of the Earth rate: even a static unit's gyros see more than that.
    if program_turns && max < 7.3e-6 {
        return Err(IoError::File {
            file: file.to_string(),
            message: format!(
                "the gyros read at most {max:.3e} rad/s over the whole file while the program \
                 turns the platform: expected rates that follow the program (all-zero gyro \
                 columns, or a dead gyro triad)"
            ),
        });
    }
    Ok(())
}
