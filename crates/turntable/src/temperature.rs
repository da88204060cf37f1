//! The temperature of the instrument over a run: a profile on the run's clock (s, the program's
//! time in a simulation), for the truth simulator's thermal terms and the covariance analysis of
//! a program with a temperature.

use serde::{Deserialize, Serialize};

/// The instrument's temperature as a function of time (deg C).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "profile", rename_all = "snake_case", deny_unknown_fields)]
pub enum TemperatureProfile {
    /// Constant.
    Constant {
        /// Temperature (deg C).
        temp_c: f64,
    },
    /// A warm-up after power-on: `end + (start - end) exp(-t / time_constant)`.
    Warmup {
        /// Temperature at `t = 0` (deg C).
        start_c: f64,
        /// Temperature approached (deg C).
        end_c: f64,
        /// Time constant (s).
        time_constant_s: f64,
    },
    /// A chamber ramp: `start + rate t`, held at `end` once reached.
    Ramp {
        /// Temperature at `t = 0` (deg C).
        start_c: f64,
        /// Temperature held once reached (deg C).
        end_c: f64,
        /// Rate of change (deg C per minute, of either sign: the sign is taken from start to end).
        rate_c_per_min: f64,
    },
    /// Steps of a chamber: each temperature held from its time on (the first from `t = 0`).
    Steps {
        /// `[t_s, temp_c]` in increasing time.
        steps: Vec<[f64; 2]>,
    },
    /// Points linearly interpolated, held constant before the first and after the last (a
    /// recording's own temperatures).
    Table {
        /// `[t_s, temp_c]` in increasing time.
        points: Vec<[f64; 2]>,
    },
}

/// The temperatures an instrument profile may take (deg C): a thermal chamber's range and
/// more; anything outside is a unit mistake (kelvin, Fahrenheit).
pub const TEMPERATURE_RANGE_C: std::ops::RangeInclusive<f64> = -100.0..=200.0;

impl TemperatureProfile {
    /// The temperature at time `t` (s).
    pub fn at(&self, t: f64) -> f64 {
        match self {
            Self::Constant { temp_c } => *temp_c,
            Self::Warmup {
                start_c,
                end_c,
                time_constant_s,
            } => end_c + (start_c - end_c) * (-t.max(0.0) / time_constant_s).exp(),
            Self::Ramp {
                start_c,
                end_c,
                rate_c_per_min,
            } => {
                let reach = (end_c - start_c).abs() / (rate_c_per_min.abs() / 60.0);
                let s = t.clamp(0.0, reach) / reach.max(f64::MIN_POSITIVE);
                if reach == 0.0 {
                    *end_c
                } else {
                    start_c + (end_c - start_c) * s
                }
            }
            Self::Steps { steps } => steps
                .iter()
                .take_while(|s| s[0] <= t)
                .last()
                .or(steps.first())
                .map_or(f64::NAN, |s| s[1]),
            Self::Table { points } => {
                let k = points.partition_point(|p| p[0] <= t);
                match (k.checked_sub(1).map(|i| points[i]), points.get(k)) {
                    (Some(a), Some(b)) if b[0] > a[0] => {
                        a[1] + (b[1] - a[1]) * (t - a[0]) / (b[0] - a[0])
                    }
                    (Some(a), _) => a[1],
                    (None, Some(b)) => b[1],
                    (None, None) => f64::NAN,
                }
            }
        }
    }

    /// The mean of the temperature at `n` times `t0 + i dt`, `i = 1..=n` (the records of a
    /// run): the reference temperature a calibration of the run takes by default.
    pub fn mean_at_records(&self, t0: f64, dt: f64, n: usize) -> f64 {
        let sum: f64 = (1..=n).map(|i| self.at(t0 + i as f64 * dt)).sum();
        sum / n.max(1) as f64
    }

    /// Check the profile's numbers: `Err` names the field and what was expected.
    pub fn check(&self) -> Result<(), String> {
        let temp = |name: &str, v: f64| {
            if TEMPERATURE_RANGE_C.contains(&v) {
                Ok(())
            } else {
                Err(format!(
                    "{name} = {v}: expected a temperature in deg C within {} .. {}",
                    TEMPERATURE_RANGE_C.start(),
                    TEMPERATURE_RANGE_C.end()
                ))
            }
        };
        let positive = |name: &str, v: f64, max: f64| {
            if v.is_finite() && v > 0.0 && v <= max {
                Ok(())
            } else {
                Err(format!("{name} = {v}: expected > 0 and <= {max}"))
            }
        };
        let series = |name: &str, pts: &[[f64; 2]]| {
            if pts.is_empty() {
                return Err(format!("{name}: expected at least one [t_s, temp_c] pair"));
            }
            for (i, p) in pts.iter().enumerate() {
                if !(p[0].is_finite() && p[0].abs() <= 1e7) {
                    return Err(format!(
                        "{name}[{i}]: time {} s: expected within +-1e7 s",
                        p[0]
                    ));
                }
                temp(&format!("{name}[{i}] temperature"), p[1])?;
                if i > 0 && p[0] <= pts[i - 1][0] {
                    return Err(format!("{name}[{i}]: times must increase"));
                }
            }
            Ok(())
        };
        match self {
            Self::Constant { temp_c } => temp("temp_c", *temp_c),
            Self::Warmup {
                start_c,
                end_c,
                time_constant_s,
            } => {
                temp("start_c", *start_c)?;
                temp("end_c", *end_c)?;
                positive("time_constant_s", *time_constant_s, 1e7)
            }
            Self::Ramp {
                start_c,
                end_c,
                rate_c_per_min,
            } => {
                temp("start_c", *start_c)?;
                temp("end_c", *end_c)?;
                positive(
                    "rate_c_per_min (its magnitude)",
                    rate_c_per_min.abs(),
                    100.0,
                )
            }
            Self::Steps { steps } => series("steps", steps),
            Self::Table { points } => series("points", points),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profiles_follow_their_formulas() {
        let w = TemperatureProfile::Warmup {
            start_c: 20.0,
            end_c: 35.0,
            time_constant_s: 900.0,
        };
        assert_eq!(w.at(0.0), 20.0);
        assert!((w.at(900.0) - (20.0 + 15.0 * (1.0 - (-1.0f64).exp()))).abs() < 1e-12);
        let r = TemperatureProfile::Ramp {
            start_c: 20.0,
            end_c: 10.0,
            rate_c_per_min: 1.0,
        };
        assert!((r.at(300.0) - 15.0).abs() < 1e-12);
        assert_eq!(r.at(1e5), 10.0);
        let s = TemperatureProfile::Steps {
            steps: vec![[0.0, 20.0], [100.0, 40.0]],
        };
        assert_eq!((s.at(-1.0), s.at(99.0), s.at(100.0)), (20.0, 20.0, 40.0));
        let t = TemperatureProfile::Table {
            points: vec![[0.0, 20.0], [10.0, 30.0]],
        };
        assert_eq!((t.at(-5.0), t.at(5.0), t.at(50.0)), (20.0, 25.0, 30.0));
        assert!(t.check().is_ok() && w.check().is_ok());
        let bad = TemperatureProfile::Constant { temp_c: 300.0 };
        assert!(bad.check().unwrap_err().contains("temp_c = 300"));
        let c = TemperatureProfile::Constant { temp_c: 21.0 };
        assert_eq!(c.mean_at_records(0.0, 0.01, 100), 21.0);
    }
}
