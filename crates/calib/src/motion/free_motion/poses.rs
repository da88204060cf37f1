//! The rests as poses on the records: their mean specific forces and rates, the increments
//! carried between them, and the check that they point in enough directions.

use super::FreeMotionError;
use crate::io::source::ImuSource;
use crate::io::{ImuData, ImuKind, ImuRecord};
use crate::model::correction::Correction;
use crate::motion::rests::{Rest, held_out};
use crate::motion::stamps::{Stamps, read_ranges};
use nalgebra::{Matrix3, Vector3};
use sins_model::attitude::exp_so3;
use std::ops::Range;

/// A rest as the records hold it: its place in the rest list (what a hold-out counts), the
/// rest, and its records ([`Rest::records`]).
#[derive(Clone, Debug)]
pub(super) struct Pose {
    pub(super) index: usize,
    pub(super) rest: Rest,
    pub(super) records: Range<usize>,
}

/// Fewest records of a rest that counts as a pose (the noise of its mean needs two).
pub(super) const MIN_POSE_RECORDS: usize = 2;

/// The rests of `rests` with at least [`MIN_POSE_RECORDS`] records stamped `t`, in order.
pub(super) fn poses_of<S: Stamps + ?Sized>(t: &S, rests: &[Rest]) -> Vec<Pose> {
    rests
        .iter()
        .enumerate()
        .map(|(index, rest)| Pose {
            index,
            rest: *rest,
            records: rest.records(t),
        })
        .filter(|p| p.records.len() >= MIN_POSE_RECORDS)
        .collect()
}

/// The records the gyros carry the attitude over from pose `a` to pose `b`: from the record
/// after `a` through the first record of `b` (the motion between them, the record that
/// straddles `b`'s start included, and one record at rest).
pub(super) fn carry_records(a: &Pose, b: &Pose) -> std::ops::RangeInclusive<usize> {
    a.records.end..=b.records.start
}

/// The records as angle increments over their own intervals, and the specific force.
pub(super) struct Increments {
    pub(super) dth: Vec<Vector3<f64>>,
    pub(super) dt: Vec<f64>,
    pub(super) f: Vec<Vector3<f64>>,
}

/// Record `r`'s angle increment over its own interval `h`, and its specific force: rates times
/// the interval, increments over it. The one rule of every figure of the rests, held
/// ([`Increments`]) or read ([`evaluate`]).
pub(super) fn increment(kind: ImuKind, r: &ImuRecord, h: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (g, a) = (Vector3::from(r.gyro), Vector3::from(r.accel));
    match kind {
        ImuKind::Rates => (g * h, a),
        ImuKind::Increments => (g, a / h),
    }
}

impl Increments {
    /// Held: the coarse fit integrates its (grouped) records many times over.
    pub(super) fn new(data: &ImuData) -> Self {
        let t: Vec<f64> = data.records.iter().map(|r| r.t).collect();
        let median = sins_model::timing::median_interval(&t);
        let mut dth = Vec::with_capacity(t.len());
        let mut dt = Vec::with_capacity(t.len());
        let mut f = Vec::with_capacity(t.len());
        for (k, r) in data.records.iter().enumerate() {
            let h = if k == 0 { median } else { t[k] - t[k - 1] };
            let (inc, force) = increment(data.kind, r, h);
            dth.push(inc);
            dt.push(h);
            f.push(force);
        }
        Self { dth, dt, f }
    }

    /// Record `k`'s angle increment, through the gyros' linear correction of `cal` where given
    /// ([`Correction::linear_gyro_increment`]; the coarse fit's paper model).
    pub(super) fn increment(&self, k: usize, cal: Option<&Correction>) -> Vector3<f64> {
        match cal {
            Some(c) => c.linear_gyro_increment(&self.dth[k], self.dt[k]),
            None => self.dth[k],
        }
    }

    /// Rotation of the body from before the first of `records` to after the last:
    /// `c_end_to_start`, the product of the steps' rotations.
    pub(super) fn rotation(
        &self,
        records: impl Iterator<Item = usize>,
        cal: Option<&Correction>,
    ) -> Matrix3<f64> {
        let mut c = Matrix3::identity();
        for k in records {
            c *= exp_so3(&self.increment(k, cal));
        }
        c
    }

    /// The increments integrated about `axis` over `records`.
    pub(super) fn turn(
        &self,
        records: Range<usize>,
        axis: &Vector3<f64>,
        cal: Option<&Correction>,
    ) -> f64 {
        records.map(|k| axis.dot(&self.increment(k, cal))).sum()
    }
}

/// Mean specific force and rate of a rest with the noise of the means.
#[derive(Clone, Copy, Debug)]
pub(super) struct PoseStat {
    pub(super) f: Vector3<f64>,
    pub(super) sigma_f: f64,
    pub(super) w: Vector3<f64>,
    pub(super) sigma_w: f64,
}

/// The sums of a rest's means, record by record in order ([`pose_stat`], [`evaluate`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Means {
    pub(super) n: usize,
    pub(super) sf: Vector3<f64>,
    pub(super) sw: Vector3<f64>,
}

impl Means {
    pub(super) fn add(&mut self, dth: &Vector3<f64>, dt: f64, f: &Vector3<f64>) {
        self.sf += f;
        self.sw += dth / dt;
        self.n += 1;
    }

    /// The mean specific force and rate.
    pub(super) fn means(&self) -> (Vector3<f64>, Vector3<f64>) {
        let n = self.n as f64;
        (self.sf / n, self.sw / n)
    }
}

/// The scatter of a rest's records about its means ([`Means`]), record by record in order.
#[derive(Clone, Copy, Debug)]
pub(super) struct Scatter {
    pub(super) n: usize,
    pub(super) mf: Vector3<f64>,
    pub(super) mw: Vector3<f64>,
    pub(super) vf: f64,
    pub(super) vw: f64,
}

impl Scatter {
    pub(super) fn about(means: &Means) -> Self {
        let (mf, mw) = means.means();
        Self {
            n: means.n,
            mf,
            mw,
            vf: 0.0,
            vw: 0.0,
        }
    }

    pub(super) fn add(&mut self, dth: &Vector3<f64>, dt: f64, f: &Vector3<f64>) {
        self.vf += (f - self.mf).norm_squared();
        self.vw += (dth / dt - self.mw).norm_squared();
    }

    pub(super) fn stat(&self) -> PoseStat {
        let n = self.n as f64;
        let denom = (n - 1.0).max(1.0);
        PoseStat {
            f: self.mf,
            sigma_f: (self.vf / denom / n).sqrt(),
            w: self.mw,
            sigma_w: (self.vw / denom / n).sqrt(),
        }
    }
}

pub(super) fn pose_stat(inc: &Increments, records: &Range<usize>) -> PoseStat {
    let mut means = Means::default();
    for k in records.clone() {
        means.add(&inc.dth[k], inc.dt[k], &inc.f[k]);
    }
    let mut scatter = Scatter::about(&means);
    for k in records.clone() {
        scatter.add(&inc.dth[k], inc.dt[k], &inc.f[k]);
    }
    scatter.stat()
}

/// Refuse rests that cannot separate the accelerometer parameters, whatever the estimator:
/// fewer than three fitted rests (every `holdout`-th held out, [`held_out`]), or fitted rests
/// whose specific force points in fewer than three directions [`MIN_POSE_SEPARATION_DEG`]
/// apart.
/// One reading of `imu` (records stamped `t`) for the fitted rests' mean specific forces, which
/// it returns (raw, m/s^2, in order; rests with fewer than two records left out).
pub fn check_poses(
    imu: &mut dyn ImuSource,
    t: &dyn Stamps,
    rests: &[Rest],
    holdout: Option<usize>,
) -> Result<Vec<Vector3<f64>>, FreeMotionError> {
    let ranges: Vec<Range<usize>> = poses_of(t, rests)
        .iter()
        .filter(|p| !held_out(p.index, holdout))
        .map(|p| p.records.clone())
        .collect();
    let mut means = vec![Means::default(); ranges.len()];
    let kind = imu.kind();
    read_ranges(imu, &ranges, t.median_interval(), &mut |i, _, r, h| {
        let (dth, f) = increment(kind, r, h);
        means[i].add(&dth, h, &f);
    })?;
    let fitted: Vec<Vector3<f64>> = means.iter().map(|m| m.means().0).collect();
    if fitted.len() < 3 {
        return Err(FreeMotionError::TooFewIntervals(fitted.len()));
    }
    require_directions(fitted.iter().copied(), fitted.len())?;
    Ok(fitted)
}

/// Two rests count as different poses when their specific forces differ in direction by at
/// least this much (deg): five rests on one face do not separate nine accelerometer parameters.
pub const MIN_POSE_SEPARATION_DEG: f64 = 10.0;

/// `Err` where the `intervals` rests' specific forces `f` point in fewer than three
/// [`distinct_directions`].
pub(super) fn require_directions(
    f: impl Iterator<Item = Vector3<f64>>,
    intervals: usize,
) -> Result<(), FreeMotionError> {
    let directions = distinct_directions(f);
    if directions < 3 {
        return Err(FreeMotionError::TooFewDirections {
            intervals,
            directions,
        });
    }
    Ok(())
}

/// How many of the directions `f` lie at least [`MIN_POSE_SEPARATION_DEG`] from each other
/// (each joins the first earlier one within it, or starts a new direction).
pub(super) fn distinct_directions(f: impl Iterator<Item = Vector3<f64>>) -> usize {
    let cos_min = MIN_POSE_SEPARATION_DEG.to_radians().cos();
    let mut seen: Vec<Vector3<f64>> = Vec::new();
    for v in f {
        let Some(u) = v.try_normalize(0.0) else {
            continue;
        };
        if !seen.iter().any(|s| s.dot(&u) >= cos_min) {
            seen.push(u);
        }
    }
    seen.len()
}
