//! The turntable angle records read onto the IMU time line.

use crate::config::ClockConfig;
use crate::io::TurntableData;
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

/// What the interpolation needs of each record, worked out once for all passes: the sines and
/// cosines of its angles and the angle differences to the next record, wrapped the short way
/// (trigonometry and a floating-point remainder per record and pass were 4 % of a calibration).
#[derive(Clone, Debug)]
pub(crate) struct RecordTable {
    sin_cos: Vec<[(f64, f64); 3]>,
    /// Zero after the last record.
    d_deg: Vec<[f64; 3]>,
}

/// Records between two whose sines and cosines are computed directly: those in between come
/// from the record before by [`sin_cos_near`] (under 4e-16 each, so under 1e-14 at the end of a
/// run of them), where the angles moved less than 1e-2 rad.
const SIN_COS_ANCHOR: usize = 16;

impl RecordTable {
    pub fn new(data: &TurntableData) -> Self {
        let r = &data.records;
        // Three sines and cosines per record directly were 3 % of a calibration's time.
        let mut sin_cos: Vec<[(f64, f64); 3]> = Vec::with_capacity(r.len());
        let mut k_prev = [0.0; 3];
        for (i, rec) in r.iter().enumerate() {
            let k = rec.k_deg.map(f64::to_radians);
            let sc = match sin_cos.last() {
                Some(prev) if i % SIN_COS_ANCHOR != 0 => {
                    std::array::from_fn(|g| sin_cos_near(prev[g], k[g] - k_prev[g], k[g]))
                }
                _ => k.map(f64::sin_cos),
            };
            sin_cos.push(sc);
            k_prev = k;
        }
        Self {
            sin_cos,
            d_deg: (0..r.len())
                .map(|i| match r.get(i + 1) {
                    Some(b) => std::array::from_fn(|g| wrap_deg(b.k_deg[g] - r[i].k_deg[g])),
                    None => [0.0; 3],
                })
                .collect(),
        }
    }
}

/// Interpolates the turntable records at IMU times (linearly, wrap-aware in the angles).
#[derive(Clone, Debug)]
pub(crate) struct AngleInterpolator<'a> {
    data: &'a TurntableData,
    table: &'a RecordTable,
    clock: ClockConfig,
    /// Index of the record at or before the last query.
    cursor: usize,
    /// Largest record spacing (turntable clock) still interpolated across.
    max_gap: f64,
    /// The pair of records at the cursor: records are interpolated from at several IMU steps,
    /// and between them the angles move by milliradians, so the sines and cosines come from
    /// the first record's by a short series (no trigonometry per IMU step).
    pair: Option<PairCache>,
}

impl<'a> AngleInterpolator<'a> {
    /// Records `data` (with their [`RecordTable`]) on the turntable clock `clock`; spacings
    /// above 2.5 median spacings are gaps and not interpolated across.
    pub fn new(
        data: &'a TurntableData,
        table: &'a RecordTable,
        clock: ClockConfig,
        median_interval: f64,
    ) -> Self {
        Self {
            data,
            table,
            clock,
            cursor: 0,
            max_gap: 2.5 * median_interval,
            pair: None,
        }
    }

    /// Angles at IMU-clock time `t_imu`; `None` outside the records or across a gap. Queries
    /// must not go back in time by more than a record or two (they advance with the IMU).
    #[inline(always)]
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
        let cursor = self.cursor;
        if self.pair.as_ref().is_none_or(|p| p.index != cursor) {
            let span = b.t - a.t;
            self.pair = Some(PairCache {
                index: cursor,
                inv_span: (span <= self.max_gap).then(|| 1.0 / span),
                k_a: a.k_deg.map(f64::to_radians),
                sin_cos_a: self.table.sin_cos[cursor],
                d_deg: self.table.d_deg[cursor],
                t_imu: [self.clock.imu_time(a.t), self.clock.imu_time(b.t)],
            });
        }
        let pair = self.pair.as_ref().expect("set above");
        // Beyond the largest spacing interpolated across: a gap.
        let w = ((t_tt - a.t) * pair.inv_span?).clamp(0.0, 1.0);
        let k: [f64; 3] = std::array::from_fn(|g| (a.k_deg[g] + w * pair.d_deg[g]).to_radians());
        let sin_cos =
            std::array::from_fn(|g| sin_cos_near(pair.sin_cos_a[g], k[g] - pair.k_a[g], k[g]));
        Some(AngleSet {
            sin_cos,
            records: [(cursor, 1.0 - w), (cursor + 1, w)],
            t_records_imu: pair.t_imu,
        })
    }
}

/// Median interval of the times (NaN for fewer than two): [`sins_model::timing::median_interval`].
pub(crate) fn median_interval(times: impl Iterator<Item = f64>) -> f64 {
    let t: Vec<f64> = times.collect();
    sins_model::timing::median_interval(&t)
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
    fn the_records_sines_and_cosines_equal_the_direct_ones() {
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
        let data = TurntableData { records };
        let table = RecordTable::new(&data);
        for (rec, sc) in data.records.iter().zip(&table.sin_cos) {
            for (k, (s, c)) in rec.k_deg.iter().zip(sc) {
                let (s0, c0) = k.to_radians().sin_cos();
                assert!((s - s0).abs() < 1e-14 && (c - c0).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn the_median_spacing_is_the_sorted_one() {
        let times = [0.0, 0.02, 0.05, 0.06, 0.1, 0.13, 0.2, 0.21];
        let mut d: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_by(f64::total_cmp);
        assert_eq!(median_interval(times.into_iter()), d[d.len() / 2]);
        assert!(median_interval([1.0].into_iter()).is_nan());
    }
}
