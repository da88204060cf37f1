//! The turntable angle records read onto the IMU time line.

use crate::config::ClockConfig;
use crate::io::IoError;
use crate::io::angle_records::RecordWindow;
use turntable::gimbal::wrap_deg;

/// One interpolated set of gimbal angles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct AngleSet {
    /// The two records interpolated between, with their weights.
    pub records: [(usize, f64); 2],
    /// IMU-clock times of the two records (s).
    pub t_records_imu: [f64; 2],
    /// `(sin, cos)` of each gimbal angle.
    pub sin_cos: [(f64, f64); 3],
}

/// What the interpolation needs of the pair of records at the cursor, worked out once per pair
/// (each pair serves several IMU steps).
#[derive(Clone, Copy, Debug)]
struct PairCache {
    /// Index of the first record.
    index: usize,
    /// Its stamp (turntable clock, s) and angles (deg).
    t_a: f64,
    k_a_deg: [f64; 3],
    /// The reciprocal of the spacing of the two records; `None` across a gap.
    inv_span: Option<f64>,
    /// The first record's angles (rad) and their `(sin, cos)`.
    k_a: [f64; 3],
    sin_cos_a: [(f64, f64); 3],
    /// The angle differences to the second record, wrapped the short way (deg).
    d_deg: [f64; 3],
    /// IMU-clock times of the two records (s).
    t_imu: [f64; 2],
}

/// `(sin, cos)` of `a + d` from those of `a` and a small `d` (|d| <= 1e-2 rad: the first
/// omitted terms of the series are under 1e-24), else directly.
fn sin_cos_near(a: (f64, f64), d: f64, direct: f64) -> (f64, f64) {
    if d.abs() > 1e-2 {
        return direct.sin_cos();
    }
    let d2 = d * d;
    // Products with the reciprocals rather than divisions (this runs at every IMU step).
    let sd = d * (1.0 - d2 * (1.0 / 6.0) * (1.0 - d2 * (1.0 / 20.0) * (1.0 - d2 * (1.0 / 42.0))));
    let cd = 1.0
        - d2 * 0.5
            * (1.0 - d2 * (1.0 / 12.0) * (1.0 - d2 * (1.0 / 30.0) * (1.0 - d2 * (1.0 / 56.0))));
    (a.0 * cd + a.1 * sd, a.1 * cd - a.0 * sd)
}

/// Pairs whose first record's sines and cosines come from the pair before's by
/// [`sin_cos_near`] (under 4e-16 each, so under 1e-14 at the end of a run of them), where the
/// angles moved less than 1e-2 rad, between pairs where they are computed directly.
const SIN_COS_ANCHOR: usize = 16;

/// Interpolates the turntable records at IMU times (linearly, wrap-aware in the angles).
#[derive(Debug)]
pub(crate) struct AngleInterpolator<'a> {
    records: RecordWindow<'a>,
    clock: ClockConfig,
    /// Index of the record at or before the last query.
    cursor: usize,
    /// Largest record spacing (turntable clock) still interpolated across.
    max_gap: f64,
    /// The pair of records at the cursor: records are interpolated from at several IMU steps,
    /// and between them the angles move by milliradians, so the sines and cosines come from
    /// the first record's by a short series (no trigonometry per IMU step).
    pair: Option<PairCache>,
    /// Pairs since the last whose sines and cosines were computed directly.
    chained: usize,
}

impl<'a> AngleInterpolator<'a> {
    /// Records `data` on the turntable clock `clock`; spacings above 2.5 median spacings are
    /// gaps and not interpolated across. Nothing is worked out per record ahead (a table of
    /// each record's sines, cosines and differences held 72 bytes a record, twice the records
    /// themselves: 307 MB for 45 minutes of 1-kHz angles); a pair's are worked out when the
    /// cursor reaches it, from the pair before's. The records are read in order (a streamed
    /// file keeps only those near the cursor).
    pub fn new(records: RecordWindow<'a>, clock: ClockConfig, median_interval: f64) -> Self {
        Self {
            records,
            clock,
            cursor: 0,
            max_gap: 2.5 * median_interval,
            pair: None,
            chained: 0,
        }
    }

    /// Angles at IMU-clock time `t_imu`; `None` outside the records or across a gap. Queries
    /// must not go back in time by more than a record or two (they advance with the IMU).
    #[inline(always)]
    pub fn at(&mut self, t_imu: f64) -> Option<AngleSet> {
        let t_tt = self.clock.turntable_time(t_imu);
        let (n, span) = (self.records.count, self.records.span);
        if n < 2 || t_tt < span.0 || t_tt > span.1 {
            return None;
        }
        while self.cursor > 0 && self.records.get(self.cursor)?.t > t_tt {
            self.cursor -= 1;
        }
        while self.cursor + 2 < n && self.records.get(self.cursor + 1)?.t < t_tt {
            self.cursor += 1;
        }
        let cursor = self.cursor;
        if self.pair.as_ref().is_none_or(|p| p.index != cursor) {
            let (a, b) = (self.records.get(cursor)?, self.records.get(cursor + 1)?);
            let span = b.t - a.t;
            let k_a = a.k_deg.map(f64::to_radians);
            // Three sines and cosines per pair directly were 3 % of a calibration's time.
            let sin_cos_a = match &self.pair {
                Some(prev) if self.chained < SIN_COS_ANCHOR => {
                    self.chained += 1;
                    std::array::from_fn(|g| {
                        sin_cos_near(prev.sin_cos_a[g], k_a[g] - prev.k_a[g], k_a[g])
                    })
                }
                _ => {
                    self.chained = 0;
                    k_a.map(f64::sin_cos)
                }
            };
            self.pair = Some(PairCache {
                index: cursor,
                t_a: a.t,
                k_a_deg: a.k_deg,
                inv_span: (span <= self.max_gap).then(|| 1.0 / span),
                k_a,
                sin_cos_a,
                d_deg: std::array::from_fn(|g| wrap_deg(b.k_deg[g] - a.k_deg[g])),
                t_imu: [self.clock.imu_time(a.t), self.clock.imu_time(b.t)],
            });
        }
        let pair = self.pair.as_ref().expect("set above");
        // Beyond the largest spacing interpolated across: a gap.
        let w = ((t_tt - pair.t_a) * pair.inv_span?).clamp(0.0, 1.0);
        let k: [f64; 3] =
            std::array::from_fn(|g| (pair.k_a_deg[g] + w * pair.d_deg[g]).to_radians());
        let sin_cos =
            std::array::from_fn(|g| sin_cos_near(pair.sin_cos_a[g], k[g] - pair.k_a[g], k[g]));
        Some(AngleSet {
            sin_cos,
            records: [(cursor, 1.0 - w), (cursor + 1, w)],
            t_records_imu: pair.t_imu,
        })
    }

    /// The first error of reading a streamed file during the pass, if any (the queries since
    /// gave no angles).
    pub fn take_error(&mut self) -> Option<IoError> {
        self.records.take_error()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sines_and_cosines_near_a_known_angle_equal_the_direct_ones() {
        for a in [-3.0, -0.4, 0.0, 1.2, 2.9] {
            for d in [-1e-2, -3e-3, -1e-7, 0.0, 2e-5, 4e-3, 1e-2, 0.3] {
                let (s, c) = sin_cos_near(f64::sin_cos(a), d, a + d);
                let (s0, c0) = (a + d).sin_cos();
                assert!((s - s0).abs() < 4e-16 && (c - c0).abs() < 4e-16, "{a} {d}");
            }
        }
    }

    #[test]
    fn the_interpolated_sines_and_cosines_equal_the_direct_ones() {
        use crate::io::TurntableRecord;
        // A walk of small steps with a few jumps, over the +-180 deg wrap.
        let mut k = [170.0, -30.0, 5.0];
        let records: Vec<TurntableRecord> = (0..500)
            .map(|i| {
                for (g, k) in k.iter_mut().enumerate() {
                    *k += if i % 97 == 0 {
                        40.0
                    } else {
                        0.3 * (g as f64 + 0.5)
                    };
                    if *k > 180.0 {
                        *k -= 360.0;
                    }
                }
                TurntableRecord {
                    t: 0.02 * i as f64,
                    k_deg: k,
                }
            })
            .collect();
        let data = crate::io::TurntableData { records };
        let records: crate::io::angle_records::AngleRecords = (&data, "tt.csv").into();
        let mut interp =
            AngleInterpolator::new(records.window().unwrap(), ClockConfig::default(), 0.02);
        // Queries at a third of the record spacing, and one at every record: every pair is
        // worked out, some serve several queries, some are skipped.
        for step in [0.0067, 0.02, 0.05] {
            interp.cursor = 0;
            interp.pair = None;
            let mut t = 0.0;
            while t < 9.9 {
                let set = interp.at(t).expect("inside the records");
                let [(i, wa), (j, wb)] = set.records;
                for g in 0..3 {
                    let (a, b) = (data.records[i].k_deg[g], data.records[j].k_deg[g]);
                    let k = (a + wb * wrap_deg(b - a)).to_radians();
                    let (s0, c0) = k.sin_cos();
                    let (s, c) = set.sin_cos[g];
                    assert!((s - s0).abs() < 1e-13 && (c - c0).abs() < 1e-13, "t {t}");
                    assert!((wa + wb - 1.0).abs() < 1e-15);
                }
                t += step;
            }
        }
    }
}
