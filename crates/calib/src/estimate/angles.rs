//! The turntable angle records read onto the IMU time line.

use crate::config::ClockConfig;
use crate::io::TurntableData;

/// Wrap an angle difference into (-180, 180] degrees.
pub(crate) fn wrap_deg(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// One interpolated set of gimbal angles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AngleSet {
    /// Gimbal angles (rad).
    pub k: [f64; 3],
    /// The two records interpolated between, with their weights.
    pub records: [(usize, f64); 2],
    /// IMU-clock times of the two records (s).
    pub t_records_imu: [f64; 2],
}

/// Interpolates the turntable records at IMU times (linearly, wrap-aware in the angles).
#[derive(Clone, Debug)]
pub(crate) struct AngleInterpolator<'a> {
    data: &'a TurntableData,
    clock: ClockConfig,
    /// Index of the record at or before the last query.
    cursor: usize,
    /// Largest record spacing (turntable clock) still interpolated across.
    max_gap: f64,
}

impl<'a> AngleInterpolator<'a> {
    /// Records `data` on the turntable clock `clock`; spacings above 2.5 median spacings are
    /// gaps and not interpolated across.
    pub fn new(data: &'a TurntableData, clock: ClockConfig, median_interval: f64) -> Self {
        Self {
            data,
            clock,
            cursor: 0,
            max_gap: 2.5 * median_interval,
        }
    }

    /// Angles at IMU-clock time `t_imu`; `None` outside the records or across a gap. Queries
    /// must not go back in time by more than a record or two (they advance with the IMU).
    pub fn at(&mut self, t_imu: f64) -> Option<AngleSet> {
        let t_tt = self.clock.turntable_time(t_imu);
        let r = &self.data.records;
        if r.len() < 2 || t_tt < r[0].t || t_tt > r[r.len() - 1].t {
            return None;
        }
        while self.cursor > 0 && r[self.cursor].t > t_tt {
            self.cursor -= 1;
        }
        while self.cursor + 2 < r.len() && r[self.cursor + 1].t < t_tt {
            self.cursor += 1;
        }
        let (a, b) = (&r[self.cursor], &r[self.cursor + 1]);
        let span = b.t - a.t;
        if span > self.max_gap {
            return None;
        }
        let w = ((t_tt - a.t) / span).clamp(0.0, 1.0);
        let k = std::array::from_fn(|g| {
            (a.k_deg[g] + w * wrap_deg(b.k_deg[g] - a.k_deg[g])).to_radians()
        });
        Some(AngleSet {
            k,
            records: [(self.cursor, 1.0 - w), (self.cursor + 1, w)],
            t_records_imu: [self.clock.imu_time(a.t), self.clock.imu_time(b.t)],
        })
    }
}

/// Median of the spacings of increasing times; NaN for fewer than two.
pub(crate) fn median_interval(times: impl Iterator<Item = f64>) -> f64 {
    let t: Vec<f64> = times.collect();
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return f64::NAN;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_differences_wrap_the_short_way() {
        assert_eq!(wrap_deg(350.0), -10.0);
        assert_eq!(wrap_deg(-350.0), 10.0);
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(10.0), 10.0);
    }
}
