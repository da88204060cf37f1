//! Range checks run while the TOML is read, so that a value out of range is reported with the
//! line and column of the file (toml attaches them to a deserializer's error). `validate`
//! repeats them for configurations built in code.

use serde::de::{Deserialize, Deserializer, Error};

/// A value as written in a message: plain for ordinary magnitudes, in exponent form for
/// the extremes (`1e-300` rather than three hundred zeros).
pub(super) fn shown(v: f64) -> String {
    if v == 0.0 || (1e-4..1e7).contains(&v.abs()) || !v.is_finite() {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

fn in_range<'de, D: Deserializer<'de>>(
    d: D,
    lo: f64,
    hi: f64,
    what: &str,
) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("{}: expected {what}", shown(v))))
    }
}

/// A finite number above zero (a sigma, a rate).
pub fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "{v}: expected a finite positive number"
        )))
    }
}

/// An IMU rate: above zero, at most 100 kHz (no IMU's; it would only exhaust memory).
pub fn rate_hz<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v > 0.0 && v <= super::MAX_RATE_HZ {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "{}: expected a rate above 0 and at most 1e5 Hz",
            shown(v)
        )))
    }
}

/// The length of a simulated run: above zero, at most the longest program.
pub fn duration_s<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && v > 0.0 && v <= turntable::program::MAX_PROGRAM_DURATION_S {
        Ok(Some(v))
    } else {
        Err(D::Error::custom(format!(
            "{}: expected a duration above 0 and at most {} s (10 days)",
            shown(v),
            turntable::program::MAX_PROGRAM_DURATION_S
        )))
    }
}

/// A latitude in degrees.
pub fn latitude_deg<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, -90.0, 90.0, "a latitude in -90 .. 90 deg")
}

/// A longitude in degrees.
pub fn longitude_deg<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, -180.0, 360.0, "a longitude in -180 .. 360 deg")
}

/// A height: from the Dead Sea shore to above any laboratory on a mountain.
pub fn height_m<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, -500.0, 10_000.0, "a height in -500 .. 10000 m")
}

/// A noise level or a prior sigma, in the units its name gives: within
/// [`super::SIGMA_MIN`] .. [`super::SIGMA_MAX`].
pub fn sigma<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(
        d,
        super::SIGMA_MIN,
        super::SIGMA_MAX,
        "a standard deviation in 1e-12 .. 1e6 of the units the field's name gives",
    )
}

/// A bias random walk: 0 (none) or at most [`super::SIGMA_MAX`] of its units.
pub fn walk<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v == 0.0 || (super::SIGMA_MIN..=super::SIGMA_MAX).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "{}: expected 0 or a random walk in 1e-12 .. 1e6 of the units the field's name \
             gives",
            shown(v)
        )))
    }
}

/// An attitude noise in degrees: 0 .. 180 (beyond it every attitude is equally likely).
pub fn attitude_noise_deg<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, 0.0, 180.0, "an attitude noise in 0 .. 180 deg")
}

/// A rest's shared specific-force error: 0 .. 1 m/s^2.
pub fn rest_error_m_s2<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, 0.0, 1.0, "a specific-force error in 0 .. 1 m/s^2")
}

/// The IMU time at which the program starts, within +-[`super::PROGRAM_START_MAX_S`].
pub fn program_start_s<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    in_range(
        d,
        -super::PROGRAM_START_MAX_S,
        super::PROGRAM_START_MAX_S,
        "an IMU time in -1e7 .. 1e7 s",
    )
    .map(Some)
}

/// `[temperature] steps`: pairs `[t_s, temp_c]`, each of exactly two numbers (the array's own
/// deserializer would take the first two of a longer one and ignore the rest).
pub(super) fn pairs<'de, D>(d: D) -> Result<Option<Vec<[f64; 2]>>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    let v = Vec::<Vec<f64>>::deserialize(d)?;
    v.into_iter()
        .enumerate()
        .map(|(k, p)| {
            let n = p.len();
            p.try_into().map_err(|_| {
                serde::de::Error::custom(format!(
                    "step {}: a list of {n} numbers: expected exactly 2, [t_s, temp_c]",
                    k + 1
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}
