//! Physical bounds on the parameters of a calibration: what no instrument that can be
//! calibrated on a turntable has, so that a value beyond them is a typing error, a unit mistake
//! (deg/h written as rad/s) or a diverged fit, refused where the value enters: the true values
//! of `simulate` (`[truth.values]` and the priors it draws them from), a result or truth file
//! read back (`apply`, `calibrate --truth`).
//!
//! | parameters | bound (magnitude) |
//! |---|---|
//! | `gyro.bias.*` | 0.2 rad/s (11 deg/s, 4e4 deg/h) |
//! | `accel.bias.*` | 3 m/s^2 (0.3 g) |
//! | `gyro.theta.*`, `accel.gamma.*` | 0.2 (a 20 % scale-factor error, an 11-deg misalignment) |
//! | `install.delta.*` | 0.5 rad (29 deg) |
//! | `turntable.tau` | 10 s |
//! | `base.gamma.*` | 0.1 rad (5.7 deg) |
//!
//! The worst real instruments are far inside: the hand-turned consumer IMU of the Ferraris
//! session (`data/real`) has gyro biases of 0.01 rad/s, accelerometer biases of 0.6 m/s^2 and
//! scale and misalignment terms up to 0.027. With every entry of Theta (or Gamma) within 0.2,
//! the compensation matrices `I - Theta` and `I + Gamma` keep their singular values within
//! 1 -+ 0.6 (the Frobenius norm of a 3x3 matrix of such entries is at most 0.6): they are
//! invertible with a condition number of at most 4 ([`MAX_COMPENSATION_CONDITION`]).

/// A bound on a group of parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bound {
    /// The largest magnitude accepted, SI.
    pub max_abs: f64,
    /// SI unit of the value.
    pub unit: &'static str,
    /// What the parameters are, for messages.
    pub what: &'static str,
}

/// The largest condition number accepted for a compensation matrix (`I - Theta`, `I + Gamma`).
pub const MAX_COMPENSATION_CONDITION: f64 = 4.0;

/// The bound on a parameter by its documented name, `None` for parameters without one (the
/// extension terms).
pub fn bound(name: &str) -> Option<Bound> {
    let table: [(&str, Bound); 7] = [
        (
            "gyro.bias.",
            Bound {
                max_abs: 0.2,
                unit: "rad/s",
                what: "gyro biases",
            },
        ),
        (
            "accel.bias.",
            Bound {
                max_abs: 3.0,
                unit: "m/s^2",
                what: "accelerometer biases",
            },
        ),
        (
            "gyro.theta.",
            Bound {
                max_abs: 0.2,
                unit: "",
                what: "gyro scale-factor or misalignment terms",
            },
        ),
        (
            "accel.gamma.",
            Bound {
                max_abs: 0.2,
                unit: "",
                what: "accelerometer scale-factor or misalignment terms",
            },
        ),
        (
            "install.delta.",
            Bound {
                max_abs: 0.5,
                unit: "rad",
                what: "installation misalignments",
            },
        ),
        (
            "turntable.tau",
            Bound {
                max_abs: 10.0,
                unit: "s",
                what: "turntable data delays",
            },
        ),
        (
            "base.gamma.",
            Bound {
                max_abs: 0.1,
                unit: "rad",
                what: "base misalignments",
            },
        ),
    ];
    table
        .iter()
        .find(|(prefix, _)| name.starts_with(prefix))
        .map(|(_, b)| *b)
}

/// Check a value against its parameter's bound: `Err` with a message naming the parameter,
/// the value and the bound.
pub fn check(name: &str, value: f64) -> Result<(), String> {
    match bound(name) {
        None if !value.is_finite() => Err(format!("{name} = {value}: expected a finite number")),
        Some(b) if value.is_nan() || value.abs() > b.max_abs => {
            let unit = if b.unit.is_empty() {
                String::new()
            } else {
                format!(" {}", b.unit)
            };
            Err(format!(
                "{name} = {}{unit}: expected at most {}{unit} in magnitude (no instrument has such {}: \
                 a typing error, a unit mistake or a diverged fit)",
                shown(value),
                b.max_abs,
                b.what
            ))
        }
        _ => Ok(()),
    }
}

/// A value as written in a message: plain for ordinary magnitudes, in exponent form for the
/// extremes.
fn shown(v: f64) -> String {
    if v == 0.0 || (1e-4..1e7).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// The condition number of a 3x3 matrix (largest over smallest singular value; infinite when
/// singular).
pub fn condition_number(m: &nalgebra::Matrix3<f64>) -> f64 {
    let s = m.singular_values();
    let (lo, hi) = (s.min(), s.max());
    if lo > 0.0 { hi / lo } else { f64::INFINITY }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_name_the_parameter_and_pass_real_instruments() {
        assert!(check("gyro.bias.x", 0.0105).is_ok());
        assert!(check("accel.bias.y", -0.62).is_ok());
        assert!(check("gyro.theta.xy", -0.027).is_ok());
        assert!(
            check("gyro.ggsens.xx", 1e3).is_ok(),
            "no bound on extension terms"
        );
        let e = check("gyro.bias.x", 1e308).unwrap_err();
        assert!(
            e.contains("gyro.bias.x = 1e308 rad/s") && e.contains("0.2 rad/s"),
            "{e}"
        );
        let e = check("gyro.theta.xx", 2.0).unwrap_err();
        assert!(
            e.contains("gyro.theta.xx = 2:") && e.contains("at most 0.2 in"),
            "{e}"
        );
        assert!(check("turntable.tau", f64::NAN).is_err());
    }

    #[test]
    fn compensation_within_the_bounds_is_well_conditioned() {
        let mut worst: f64 = 0.0;
        for signs in 0u32..512 {
            let m = nalgebra::Matrix3::from_fn(|i, j| {
                let s = if signs >> (3 * i + j) & 1 == 1 {
                    0.2
                } else {
                    -0.2
                };
                f64::from(u8::from(i == j)) + s
            });
            worst = worst.max(condition_number(&m));
        }
        assert!(worst <= MAX_COMPENSATION_CONDITION, "{worst}");
        assert!(condition_number(&nalgebra::Matrix3::zeros()).is_infinite());
    }
}
