//! The coarse start of a recording of rests: the batch fit's values of the paper's parameters,
//! which the first pass linearises about where the priors are wide.

use super::{EstimateError, ImuSource, SitePriors};
use crate::config::RunConfig;
use crate::io::{ImuData, ImuKind, ImuRecord, IoError};
use crate::model::layout::StateLayout;
use crate::motion::rests::{Rest, RestError};
use nalgebra::{Matrix3, Vector3};
use sins_model::attitude::{exp_so3, log_so3};

/// The coarse start of a fit of a recording of rests (`at_rests::fit_at_rests`) where the priors
/// call for one ([`needs_coarse_start`]), from the rests the fit does not hold out; `None`
/// otherwise.
///
/// The batch fit of [`crate::motion::free_motion`] (the paper's 21 parameters from the rests'
/// mean specific forces and the rotations between them), whose values the filter's first pass
/// linearises about. Without it the first closed-loop pass runs away on a consumer-grade unit:
/// on the shipped Xsens recording the accelerometer bias and scale factor of the vertical axis,
/// which one rest cannot tell apart, went to -19.8 m/s^2 and +2.0 within the first rest, and the
/// filter diverged after the first turn.
pub(crate) fn coarse_start_at_rests(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
) -> Result<Option<Vec<f64>>, EstimateError> {
    if !needs_coarse_start(config) {
        return Ok(None);
    }
    // A held-out rest is not seen by the coarse start either: its values are the prior
    // mean of the passes.
    let fitted: Vec<Rest> = rests
        .iter()
        .enumerate()
        .filter(|(i, _)| !crate::motion::rests::held_out(*i, config.filter.hold_out_every))
        .map(|(_, r)| *r)
        .collect();
    let plan = SitePriors::of(config);
    Ok(Some(coarse_start(&plan, layout, imu, &fitted, turns)?))
}

/// Whether the priors are wide enough that the first pass needs a coarse start: a gyro or
/// accelerometer scale factor above 1 %, a misalignment above 10 arcmin, a gyro bias above
/// 0.1 deg/s or an accelerometer bias above 0.1 m/s^2. The paper's priors (1e-3, 3 arcmin,
/// 0.5 deg/h, 0.02 m/s^2) need none (tests/tests/rests.rs).
pub fn needs_coarse_start(config: &RunConfig) -> bool {
    let p = &config.priors;
    p.gyro_scale > 0.01
        || p.accel_scale > 0.01
        || p.gyro_misalignment_arcmin > 10.0
        || p.accel_misalignment_arcmin > 10.0
        || p.gyro_bias_deg_h > 360.0
        || p.accel_bias_m_s2 > 0.1
}

/// The coarse start of a fit of a recording of rests (`at_rests::fit_at_rests`): the batch fit's
/// values of the paper's parameters (by name; the extension terms at zero).
pub(super) fn coarse_start(
    plan: &SitePriors,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
) -> Result<Vec<f64>, EstimateError> {
    use crate::motion::free_motion::{CoarseSettings, coarse_fit};
    let file = imu.file().to_string();
    // The rests and turns on the grouped records: a rest's groups are those that lie wholly in
    // it, a turn's those that hold any of it (a group reaches up to COARSE_GROUP_S into the
    // rest before): `Rest::records`, `Turn::records`. Held: the batch fit integrates them
    // about 25 times an iteration (a tenth of the records at 100 Hz: 7 bytes a record).
    let grouped = coarse_records(imu)?;
    let data = &grouped;
    // The paper's 21 parameters only: the terms beyond them start at zero. A consumer unit's
    // g-sensitivity turns its attitude by degrees in a hand turn, but the first pass feeds
    // back only the tilt, which each rest's first window corrects (with the batch fit's
    // g-sensitivity and asymmetry in the coarse start the Xsens and Ferraris results moved by
    // hundredths of their sigmas, and the start took twice as long: 0.47 against 0.24 s of
    // CPU on a 324-s, 200-Hz recording).
    let settings = CoarseSettings {
        gravity_m_s2: plan.gravity_m_s2,
        priors: plan.priors,
    };
    let fit = coarse_fit(data, rests, turns, &settings).map_err(|e| EstimateError::Rests {
        file,
        source: RestError::CoarseFit(e.to_string()),
    })?;
    let names = layout.entries();
    Ok(
        (StateLayout::INSTRUMENT..StateLayout::INSTRUMENT + layout.n_instrument())
            .map(|i| {
                fit.parameters
                    .iter()
                    .find(|p| p.name == names[i].name)
                    .map_or(0.0, |p| p.value)
            })
            .collect(),
    )
}

/// Length of the record groups of the coarse start (s).
pub(super) const COARSE_GROUP_S: f64 = 0.1;

/// The records of `data` combined in groups of about [`COARSE_GROUP_S`], for the coarse start:
/// the batch fit integrates every record about 25 times per Gauss-Newton iteration (a central
/// difference per gyro parameter), which was most of a consumer-grade calibration's time (0.47 s
/// of CPU for a 324-s, 200-Hz recording: 150 times `wc -l`). A group's rotation is the exact
/// product of its records' raw rotations, its velocity increment their sum, stamped with its
/// last record's time. The calibration is then applied to the group rather than to each record:
/// the difference is the commutator of the calibration error with the rotation within a group,
/// at 100 deg/s and 5 % about 8e-4 rad per 0.1-s group, well inside the linear reach of the
/// filter passes that follow (they see every record). From 50 ms to 0.1 s the coarse start's
/// share of a `calibrate --free-motion` of that recording went from 18 % to about 9 % of its
/// CPU, and the Xsens and Ferraris results moved by hundredths of their sigmas.
pub(super) fn coarse_records(imu: &mut dyn ImuSource) -> Result<ImuData, IoError> {
    let mut chunk = Vec::new();
    let dt = sins_model::timing::median_interval_streamed(|visit| {
        crate::io::source::read_records(imu, &mut chunk, &mut |r, _| {
            visit(r.t);
            true
        })
    })?;
    let size = if dt.is_finite() && dt > 0.0 {
        ((COARSE_GROUP_S / dt).round() as usize).max(1)
    } else {
        1
    };
    let increments = matches!(imu.kind(), ImuKind::Increments);
    let mut records = Vec::with_capacity(imu.len_hint().unwrap_or(0) / size + 1);
    if size == 1 {
        // The records as they are.
        crate::io::source::read_records(imu, &mut chunk, &mut |r, _| {
            records.push(*r);
            true
        })?;
        return Ok(ImuData {
            kind: imu.kind(),
            records,
        });
    }
    // The open group: its rotation, velocity increment, last stamp and records; the stamp
    // before it.
    let mut group = (Matrix3::identity(), Vector3::zeros(), f64::NAN, 0usize);
    let mut t_prev = f64::NAN;
    let mut last: Option<ImuRecord> = None;
    let close = |records: &mut Vec<ImuRecord>,
                 c: &Matrix3<f64>,
                 dv: &Vector3<f64>,
                 last: &ImuRecord,
                 t_prev: f64| {
        let span = if increments { 1.0 } else { last.t - t_prev };
        records.push(ImuRecord {
            t: last.t,
            gyro: (log_so3(c) / span).into(),
            accel: (dv / span).into(),
            temp: last.temp,
        });
    };
    crate::io::source::read_records(imu, &mut chunk, &mut |r, _| {
        if last.is_none() {
            t_prev = r.t - dt;
        }
        let (c, dv, t0, n) = &mut group;
        if *n == 0 {
            (*c, *dv, *t0) = (Matrix3::identity(), Vector3::zeros(), t_prev);
        }
        let h = if increments { 1.0 } else { r.t - *t0 };
        *c *= exp_so3(&(Vector3::from(r.gyro) * h));
        *dv += Vector3::from(r.accel) * h;
        *t0 = r.t;
        *n += 1;
        last = Some(*r);
        if *n == size {
            close(&mut records, c, dv, r, t_prev);
            t_prev = r.t;
            *n = 0;
        }
        true
    })?;
    if let (Some(r), true) = (last, group.3 > 0) {
        close(&mut records, &group.0, &group.1, &r, t_prev);
    }
    Ok(ImuData {
        kind: imu.kind(),
        records,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::MemoryImu;

    /// Records of a tumbling body at 200 Hz with jittered stamps, as increments and as rates.
    fn tumbling(kind: ImuKind) -> ImuData {
        let mut t = 0.0;
        let records = (0..997)
            .map(|k| {
                let h = 0.005 * (1.0 + 0.2 * ((k as f64) * 0.7).sin());
                t += h;
                let w = [
                    1.5 * (t * 0.9).sin(),
                    -0.8 + 0.3 * t.cos(),
                    2.0 * (t * 0.4).cos(),
                ];
                let f = [0.3 * t.sin(), 0.1, 9.8 + 0.01 * t];
                let scale = if matches!(kind, ImuKind::Increments) {
                    h
                } else {
                    1.0
                };
                ImuRecord {
                    t,
                    gyro: w.map(|x| x * scale),
                    accel: f.map(|x| x * scale),
                    temp: None,
                }
            })
            .collect();
        ImuData { kind, records }
    }

    /// The groups of `size` records of `data` from the records held (the form before they were
    /// read group by group): the reference of [`coarse_records`].
    fn held_groups(data: &ImuData, size: usize) -> Vec<ImuRecord> {
        let dt = sins_model::timing::median_interval_of(data.records.iter().map(|r| r.t));
        let increments = matches!(data.kind, ImuKind::Increments);
        let mut records = Vec::new();
        let mut t_prev = data.records.first().map_or(0.0, |r| r.t - dt);
        for group in data.records.chunks(size) {
            let mut c = Matrix3::identity();
            let mut dv = Vector3::zeros();
            let mut t0 = t_prev;
            for r in group {
                let h = if increments { 1.0 } else { r.t - t0 };
                c *= exp_so3(&(Vector3::from(r.gyro) * h));
                dv += Vector3::from(r.accel) * h;
                t0 = r.t;
            }
            let last = group.last().unwrap();
            let span = if increments { 1.0 } else { last.t - t_prev };
            t_prev = last.t;
            records.push(ImuRecord {
                t: last.t,
                gyro: (log_so3(&c) / span).into(),
                accel: (dv / span).into(),
                temp: last.temp,
            });
        }
        records
    }

    /// The whole rotation and velocity change of the grouped records equal those of the
    /// records (to rounding), for increments and rates alike; the last group is a remainder.
    #[test]
    fn grouped_records_keep_the_rotation_and_the_velocity_change() {
        for kind in [ImuKind::Increments, ImuKind::Rates] {
            let data = tumbling(kind);
            let grouped = coarse_records(&mut MemoryImu::new(&data, "imu.csv")).unwrap();
            // 0.1-s groups of 5-ms records: 20 each.
            assert_eq!(grouped.records.len(), 997usize.div_ceil(20), "{kind:?}");
            // The records read group by group are those of the records held, to the bit.
            assert_eq!(grouped.records, held_groups(&data, 20), "{kind:?}");
            // Both start where the first record's interval starts (one median interval back).
            let dt = sins_model::timing::median_interval_of(data.records.iter().map(|r| r.t));
            let start = data.records[0].t - dt;
            let total = |d: &ImuData| {
                let (mut c, mut dv) = (Matrix3::<f64>::identity(), Vector3::<f64>::zeros());
                let mut t0 = start;
                for r in &d.records {
                    let h = if matches!(d.kind, ImuKind::Increments) {
                        1.0
                    } else {
                        r.t - t0
                    };
                    c *= exp_so3(&(Vector3::from(r.gyro) * h));
                    dv += Vector3::from(r.accel) * h;
                    t0 = r.t;
                }
                (c, dv)
            };
            let ((c1, v1), (c2, v2)) = (total(&data), total(&grouped));
            assert!((c1 - c2).norm() < 1e-12, "{kind:?}: rotation");
            assert!((v1 - v2).norm() < 1e-9 * v1.norm(), "{kind:?}: velocity");
            assert_eq!(
                grouped.records.last().map(|r| r.t),
                data.records.last().map(|r| r.t)
            );
        }
    }
}
