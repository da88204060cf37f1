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
