//! The turntable's angle sensors: what they report, when, and on which clock.
//!
//! The sensors read the gimbal angles `k* + rho` (`rho` white noise). Their data carry time stamps
//! of the turntable's own clock, `t_tt = offset + (1 + rate_error) * t_imu`, and are late by the
//! delay `tau`: the record stamped `t_tt` holds the angles at IMU time `t_imu(t_tt) - tau`.

use serde::{Deserialize, Serialize};

/// How the turntable clock relates to the IMU clock: `t_tt = offset_s + (1 + rate_error) t_imu`.
/// The one definition of the relation: the run configuration's `[clock]` section is this type
/// (`calib::config::ClockConfig`), and the simulator stamps the angle records with it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Clock {
    /// Turntable clock reading at IMU time zero (s).
    pub turntable_offset_s: f64,
    /// Relative rate error of the turntable clock against the IMU clock (dimensionless).
    pub turntable_rate_error: f64,
}

impl Clock {
    /// Turntable clock reading at IMU time `t_imu`.
    pub fn turntable_time(&self, t_imu: f64) -> f64 {
        self.turntable_offset_s + (1.0 + self.turntable_rate_error) * t_imu
    }
    /// IMU time at turntable clock reading `t_tt`.
    pub fn imu_time(&self, t_tt: f64) -> f64 {
        (t_tt - self.turntable_offset_s) / (1.0 + self.turntable_rate_error)
    }
}

/// Angle-sensor model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AngleSensor {
    /// Standard deviation of each gimbal-angle reading (rad), per sample.
    pub sigma: [f64; 3],
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Delay of the turntable data relative to the IMU data (s).
    pub tau: f64,
    /// The turntable clock against the IMU clock.
    pub clock: Clock,
}

impl AngleSensor {
    /// Turntable clock reading at IMU time `t_imu`.
    pub fn turntable_time(&self, t_imu: f64) -> f64 {
        self.clock.turntable_time(t_imu)
    }
    /// IMU time at turntable clock reading `t_tt`.
    pub fn imu_time(&self, t_tt: f64) -> f64 {
        self.clock.imu_time(t_tt)
    }
    /// The IMU time whose true angles the record stamped `t_tt` holds.
    pub fn true_time_of_record(&self, t_tt: f64) -> f64 {
        self.imu_time(t_tt) - self.tau
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clocks_round_trip_and_delay_makes_records_late() {
        let s = AngleSensor {
            sigma: [1e-5; 3],
            rate_hz: 50.0,
            tau: 0.02,
            clock: Clock {
                turntable_offset_s: 1000.0,
                turntable_rate_error: 1e-4,
            },
        };
        let t = 123.456;
        assert!((s.imu_time(s.turntable_time(t)) - t).abs() < 1e-12);
        assert!((s.true_time_of_record(s.turntable_time(t)) - (t - 0.02)).abs() < 1e-12);
    }
}
