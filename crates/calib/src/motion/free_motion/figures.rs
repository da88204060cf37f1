//! The figures of a calibration of a recording of rests: the records corrected as `apply`
//! corrects them beside the raw ones, every rest's `|f| - g`, the known turns and the held-out
//! validation.

use super::FreeMotionError;
use super::poses::{Means, Pose, PoseStat, Scatter, carry_records, increment, poses_of};
use crate::io::ImuRecord;
use crate::io::source::{ImuSource, read_records};
use crate::model::correction::{Correction, CorrectionError, CorrectionWindow};
use crate::motion::rests::{Rest, Turn, held_out};
use crate::motion::stamps::{RangeWalk, Stamps};
use nalgebra::{Matrix3, Vector3};
use sins_model::attitude::exp_so3;
use sins_model::earth::EARTH_RATE;
use std::ops::Range;

/// One rest, before and after calibration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseResidual {
    /// The rest.
    pub rest: Rest,
    /// Held out of the fit.
    pub held_out: bool,
    /// `|f'| - g` of the uncalibrated mean (m/s^2).
    pub before_m_s2: f64,
    /// `|f| - g` of the calibrated mean (m/s^2).
    pub after_m_s2: f64,
    /// The uncalibrated mean specific force (m/s^2).
    pub raw_mean_f_m_s2: Vector3<f64>,
}

/// A known turn, before and after calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct TurnCheck {
    /// Name of the turn.
    pub name: String,
    /// Expected angle (rad).
    pub expected_rad: f64,
    /// Raw gyro integrated about the axis (rad).
    pub before_rad: f64,
    /// Calibrated gyro integrated about the axis (rad).
    pub after_rad: f64,
}

/// Held-out validation: errors on the held-out rests only, and the same figures on the fitted
/// ones to compare them with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Validation {
    /// Held-out rests.
    pub intervals: usize,
    /// Pairs of consecutive held-out rests in the rotation check.
    pub rotation_pairs: usize,
    /// RMS of `|f| - g` uncalibrated (m/s^2).
    pub static_rms_before_m_s2: f64,
    /// RMS of `|f| - g` calibrated (m/s^2).
    pub static_rms_after_m_s2: f64,
    /// RMS angle between the gravity direction predicted by the raw gyros from one held-out
    /// pose to the next and the one measured there (raw accelerometers) (rad).
    pub rotation_rms_before_rad: f64,
    /// The same with the calibrated gyros and accelerometers, the Earth's rotation over the
    /// pair taken out where the calibrated gyros resolve the heading (rad).
    pub rotation_rms_after_rad: f64,
    /// Fitted rests (not held out).
    pub fitted_intervals: usize,
    /// RMS of `|f| - g` calibrated over the fitted rests (m/s^2): what the held-out figure is
    /// compared with.
    pub fitted_static_rms_m_s2: f64,
    /// Single motions into or out of a held-out rest (from the rest before it, or to the one
    /// after it).
    pub held_out_motions: usize,
    /// RMS gravity-direction error over those single motions, calibrated (rad).
    pub held_out_motion_rms_rad: f64,
    /// Single motions between two fitted rests.
    pub fitted_motions: usize,
    /// RMS gravity-direction error over those, calibrated (rad): what the held-out motions'
    /// figure is compared with.
    pub fitted_motion_rms_rad: f64,
    /// The Earth's rotation in the calibrated rotation figures.
    pub earth_rate: EarthRateTreatment,
}

/// How the rotation figures treat the Earth's rotation: over a pair of rests `t` apart the
/// gravity direction turns by up to `Omega cos(latitude) t` relative to inertial space, which
/// the gyros measure (0.54 deg over 150 s at 45 deg). Taking it out needs the heading, which the
/// calibrated gyros give in each rest (gyrocompassing) only where their bias uncertainty and
/// noise are well below the Earth rate's horizontal part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EarthRateTreatment {
    /// Taken out in every rotation figure (the heading gyrocompassed in the first rest of each
    /// pair).
    Compensated,
    /// Not taken out: the calibrated gyros do not resolve the heading. `floor_rad` is the RMS
    /// over the held-out pairs of the largest turn of gravity by the Earth's rotation, a floor
    /// under the rotation figure for a unit whose gyros would be perfect.
    NotResolved {
        /// RMS of `Omega cos(latitude) t` over the held-out pairs (rad).
        floor_rad: f64,
    },
}

/// The site's Earth rotation and how well the calibrated gyros know their biases: what the
/// rotation checks need to take the Earth's rotation out ([`EarthRateTreatment`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EarthRotation {
    /// Horizontal part of the Earth rate at the site, `Omega cos(latitude)` (rad/s).
    pub horizontal_rad_s: f64,
    /// Vertical part, `Omega sin(latitude)` (rad/s).
    pub vertical_rad_s: f64,
    /// Posterior sigma of the calibrated gyro biases (rad/s, largest axis).
    pub gyro_bias_sigma_rad_s: f64,
}

impl EarthRotation {
    /// At `latitude_rad` with gyro biases known to `gyro_bias_sigma_rad_s`.
    pub fn at(latitude_rad: f64, gyro_bias_sigma_rad_s: f64) -> Self {
        Self {
            horizontal_rad_s: EARTH_RATE * latitude_rad.cos(),
            vertical_rad_s: EARTH_RATE * latitude_rad.sin(),
            gyro_bias_sigma_rad_s,
        }
    }

    /// The Earth rate in body axes at a rest whose calibrated mean rate is
    /// `w` (rad/s, noise of the mean `sigma_w`) and calibrated gravity direction `up`: the
    /// heading gyrocompassed (the horizontal Earth rate points North). `None` where the gyros
    /// do not resolve it: their bias sigma and the mean's noise together above
    /// [`GYROCOMPASS_FRACTION`] of the horizontal Earth rate (a heading sigma above about 11 deg).
    pub(super) fn in_body(
        &self,
        w: &Vector3<f64>,
        sigma_w: f64,
        up: &Vector3<f64>,
    ) -> Option<Vector3<f64>> {
        let sigma = self.gyro_bias_sigma_rad_s.hypot(sigma_w);
        if self.horizontal_rad_s <= 0.0 || sigma > GYROCOMPASS_FRACTION * self.horizontal_rad_s {
            return None;
        }
        let h = w - up * up.dot(w);
        h.try_normalize(0.0)
            .map(|north| north * self.horizontal_rad_s + up * self.vertical_rad_s)
    }
}

/// The largest ratio of the gyros' bias-and-noise sigma to the horizontal Earth rate at which
/// a rest's heading counts as gyrocompassed for the rotation checks ([`EarthRotation`]).
pub const GYROCOMPASS_FRACTION: f64 = 0.2;

/// What a calibration does to a recording's rests and known turns: [`PoseResidual`] of every
/// rest, [`TurnCheck`] of every known turn, and the held-out [`Validation`] with a hold-out.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// Every rest, before and after.
    pub poses: Vec<PoseResidual>,
    /// Known turns, before and after.
    pub turns: Vec<TurnCheck>,
    /// Held-out validation, with a hold-out.
    pub validation: Option<Validation>,
    /// The least-squares `|f| = g` baseline ([`super::accel_baseline`]) fitted to the same rests,
    /// judged on the same held-out ones: what the calibration must not lose to (set by the
    /// caller that fitted it; `None` without a hold-out).
    pub baseline: Option<BaselineFigures>,
    /// What the fitted rests' `|f| = g` residuals scatter beyond their white noise (m/s^2,
    /// [`crate::estimate::hand_turned::rest_error_m_s2`]; set by the caller that measured the
    /// noise; `None` where the rests are too few to tell).
    pub rest_excess_m_s2: Option<f64>,
    /// Its degrees of freedom (fitted rests less the parameters they determine).
    pub rest_excess_dof: f64,
}

/// [`Evaluation`] of a calibration: its `correction` (the one `apply` applies,
/// [`Correction::of_result`]) applied to every record ([`CorrectionWindow`]), and the figures of
/// the rests and turns on the raw and on the corrected records set side by side. Every
/// `holdout`-th rest is held out ([`held_out`]); rests with fewer than two records are left out
/// (and keep their place in the count). `Err` where the correction cannot be applied to a
/// record (non-linear terms that do not settle, thermal terms without a temperature), or the
/// records cannot be read again.
///
/// The records are read from `imu` (stamped `t`), not held: one reading for the rests' means,
/// the turns and the rotations carried between the rests, and with a hold-out one more for the
/// scatter of the corrected rests about their means. The sums are those of the records held,
/// term by term in the same order, so the figures are the same to the last bit.
#[allow(clippy::too_many_arguments)]
pub fn evaluate(
    imu: &mut dyn ImuSource,
    t: &dyn Stamps,
    rests: &[Rest],
    turns: &[Turn],
    holdout: Option<usize>,
    gravity_m_s2: f64,
    earth: &EarthRotation,
    correction: &Correction,
) -> Result<Evaluation, FreeMotionError> {
    let poses = poses_of(t, rests);
    let held: Vec<bool> = poses.iter().map(|p| held_out(p.index, holdout)).collect();
    let plan = FigureRanges::of(&poses, turns, t, &held, holdout.is_some());
    let read = plan.read(imu, t.median_interval(), correction)?;
    let residuals: Vec<PoseResidual> = (0..poses.len())
        .map(|i| PoseResidual {
            rest: poses[i].rest,
            held_out: held[i],
            before_m_s2: read.raw_f[i].norm() - gravity_m_s2,
            raw_mean_f_m_s2: read.raw_f[i],
            after_m_s2: read.cal[i].f.norm() - gravity_m_s2,
        })
        .collect();
    let turns = turns
        .iter()
        .zip(&read.turns)
        .map(|(turn, &(before_rad, after_rad))| TurnCheck {
            name: turn.name.clone(),
            expected_rad: turn.angle_rad,
            before_rad,
            after_rad,
        })
        .collect();
    let validation = holdout.map(|_| Figures { read: &read, earth }.validate(&residuals));
    Ok(Evaluation {
        poses: residuals,
        turns,
        validation,
        baseline: None,
        rest_excess_m_s2: None,
        rest_excess_dof: 0.0,
    })
}

/// The ranges of records the figures read, in one list: the poses, the known turns, the
/// carries between consecutive held-out poses (raw and corrected), and with a hold-out the
/// carries between consecutive poses (corrected).
pub(super) struct FigureRanges {
    pub(super) ranges: Vec<Range<usize>>,
    pub(super) poses: usize,
    /// The known turns' axes (unit vectors).
    pub(super) turn_axes: Vec<Vector3<f64>>,
    pub(super) held_pairs: usize,
    /// With a hold-out: the carries and the corrected poses' scatter are read too.
    pub(super) validate: bool,
}

/// What a reading of the raw and the corrected records gives the figures.
pub(super) struct ReadFigures {
    /// Mean specific force of every pose, raw.
    pub(super) raw_f: Vec<Vector3<f64>>,
    /// The same corrected, with its rate and (with a hold-out) their noise.
    pub(super) cal: Vec<PoseStat>,
    /// Every pose's corrected rate summed over its records' intervals, and their span: its
    /// mean rate over its own intervals (the Earth rate's direction in the rotation checks).
    pub(super) cal_rate: Vec<(Vector3<f64>, f64)>,
    /// Every known turn integrated about its axis, raw and corrected (rad).
    pub(super) turns: Vec<(f64, f64)>,
    /// The rotation carried from one held-out pose to the next, raw and corrected, and its
    /// span (s).
    pub(super) held_pairs: Vec<(Matrix3<f64>, Matrix3<f64>, f64)>,
    /// The corrected rotation carried from each pose to the next, and its span (s).
    pub(super) consecutive: Vec<(Matrix3<f64>, f64)>,
}

impl FigureRanges {
    pub(super) fn of(
        poses: &[Pose],
        turns: &[Turn],
        t: &dyn Stamps,
        held: &[bool],
        validate: bool,
    ) -> Self {
        let carry = |i: usize, j: usize| {
            let r = carry_records(&poses[i], &poses[j]);
            *r.start()..*r.end() + 1
        };
        let mut ranges: Vec<Range<usize>> = poses.iter().map(|p| p.records.clone()).collect();
        ranges.extend(turns.iter().map(|turn| turn.records(t)));
        let held: Vec<usize> = (0..poses.len()).filter(|&i| held[i]).collect();
        let mut held_pairs = 0;
        if validate {
            for pair in held.windows(2) {
                ranges.push(carry(pair[0], pair[1]));
                held_pairs += 1;
            }
            ranges.extend((1..poses.len()).map(|i| carry(i - 1, i)));
        }
        Self {
            ranges,
            poses: poses.len(),
            turn_axes: turns.iter().map(|turn| turn.axis.normalize()).collect(),
            held_pairs,
            validate,
        }
    }

    /// The readings: the means, turns and carries in one, the corrected poses' scatter in a
    /// second (with a hold-out: the rotation checks take the corrected rates' noise).
    pub(super) fn read(
        &self,
        imu: &mut dyn ImuSource,
        first_interval: f64,
        correction: &Correction,
    ) -> Result<ReadFigures, FreeMotionError> {
        let (p, n_turns) = (self.poses, self.turn_axes.len());
        let consecutive = self.ranges.len() - p - n_turns - self.held_pairs;
        let axes = &self.turn_axes;
        let mut raw = vec![Means::default(); p];
        let mut cal = vec![Means::default(); p];
        let mut cal_rate = vec![(Vector3::zeros(), 0.0); p];
        // As `Iterator::sum` of the held figures: from its own start.
        let zero: f64 = std::iter::empty::<f64>().sum();
        let mut turns = vec![(zero, zero); n_turns];
        let mut held_pairs =
            vec![(Matrix3::identity(), Matrix3::identity(), zero); self.held_pairs];
        let mut next = vec![(Matrix3::identity(), zero); consecutive];
        let kind = imu.kind();
        // Every record corrected, as `apply` would: a record no figure takes may still be one
        // the correction cannot be applied to, which refuses the result.
        let every = Reading::EveryRecord;
        read_corrected(
            imu,
            &self.ranges,
            (first_interval, every),
            correction,
            &mut |i, r, c, h| {
                let (dth, f) = increment(kind, r, h);
                let (cal_dth, cal_f) = increment(kind, c, h);
                if i < p {
                    raw[i].add(&dth, h, &f);
                    cal[i].add(&cal_dth, h, &cal_f);
                    cal_rate[i].0 += cal_dth;
                    cal_rate[i].1 += h;
                } else if i < p + n_turns {
                    let a = &axes[i - p];
                    turns[i - p].0 += a.dot(&dth);
                    turns[i - p].1 += a.dot(&cal_dth);
                } else if i < p + n_turns + self.held_pairs {
                    let pair = &mut held_pairs[i - p - n_turns];
                    pair.0 *= exp_so3(&dth);
                    pair.1 *= exp_so3(&cal_dth);
                    pair.2 += h;
                } else {
                    let step = &mut next[i - p - n_turns - self.held_pairs];
                    step.0 *= exp_so3(&cal_dth);
                    step.1 += h;
                }
            },
        )?;
        let mut scatter: Vec<Scatter> = cal.iter().map(Scatter::about).collect();
        if self.validate {
            let poses = (first_interval, Reading::Ranges);
            read_corrected(
                imu,
                &self.ranges[..p],
                poses,
                correction,
                &mut |i, _, c, h| {
                    let (cal_dth, cal_f) = increment(kind, c, h);
                    scatter[i].add(&cal_dth, h, &cal_f);
                },
            )?;
        }
        Ok(ReadFigures {
            raw_f: raw.iter().map(|m| m.means().0).collect(),
            cal: scatter.iter().map(Scatter::stat).collect(),
            cal_rate,
            turns,
            held_pairs,
            consecutive: next,
        })
    }
}

/// Which records a reading of [`read_corrected`] corrects.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Reading {
    /// Every record, to the end.
    EveryRecord,
    /// Those a range holds; the reading stops after the last.
    Ranges,
}

/// One reading of `imu` through `ranges` with the records corrected by `correction`
/// ([`CorrectionWindow`]): `visit(i, raw, corrected, h)` for each range `i` that holds a
/// record, in record order, `h` the record's interval (`first_interval` for the first record).
/// `Err` at the first record whose correction fails.
pub(super) fn read_corrected(
    imu: &mut dyn ImuSource,
    ranges: &[Range<usize>],
    (first_interval, which): (f64, Reading),
    correction: &Correction,
    visit: &mut dyn FnMut(usize, &ImuRecord, &ImuRecord, f64),
) -> Result<(), FreeMotionError> {
    type Ready = (usize, f64, ImuRecord);
    let kind = imu.kind();
    let mut walk = RangeWalk::new(ranges);
    let mut window: CorrectionWindow<Ready> = CorrectionWindow::new();
    let mut failed: Option<CorrectionError> = None;
    // The record the window made ready: corrected where asked, its figures where a range
    // holds it; whether to read on.
    let mut take = |window: &CorrectionWindow<Ready>, (k, h, raw): Ready| {
        let holders = walk.at(k);
        if which == Reading::EveryRecord || !holders.is_empty() {
            match window.correct(correction, kind) {
                Some(Ok(c)) => holders.iter().for_each(|&i| visit(i, &raw, &c, h)),
                Some(Err(e)) => {
                    failed = Some(e);
                    return false;
                }
                None => {}
            }
        }
        which == Reading::EveryRecord || !walk.done()
    };
    let (mut k, mut previous, mut going) = (0usize, f64::NAN, true);
    read_records(imu, &mut Vec::new(), &mut |r, _| {
        let h = if k == 0 {
            first_interval
        } else {
            r.t - previous
        };
        if let Some(ready) = window.push(*r, (k, h, *r)) {
            going = take(&window, ready);
        }
        previous = r.t;
        k += 1;
        going
    })?;
    if going && let Some(last) = window.close() {
        take(&window, last);
    }
    failed.map_or(Ok(()), |e| Err(e.into()))
}

/// The figures of the records read ([`ReadFigures`]) for the held-out checks.
pub(super) struct Figures<'a> {
    pub(super) read: &'a ReadFigures,
    pub(super) earth: &'a EarthRotation,
}

impl Figures<'_> {
    /// The held-out checks: `|f| - g` at rest, and the gravity direction carried by the gyros
    /// from one held-out pose to the next (through everything between) against the measured
    /// one; and the same figures over single motions into and out of held-out poses and
    /// between fitted ones, which compare like with like (one motion each).
    pub(super) fn validate(&self, residuals: &[PoseResidual]) -> Validation {
        let held: Vec<usize> = (0..residuals.len())
            .filter(|&i| residuals[i].held_out)
            .collect();
        let before: Vec<f64> = held.iter().map(|&i| residuals[i].before_m_s2).collect();
        let after: Vec<f64> = held.iter().map(|&i| residuals[i].after_m_s2).collect();
        let fitted: Vec<f64> = (0..residuals.len())
            .filter(|&i| !residuals[i].held_out)
            .map(|i| residuals[i].after_m_s2)
            .collect();
        let (mut rb, mut ra) = (Vec::new(), Vec::new());
        let (mut resolved, mut floor) = (true, Vec::new());
        for (pair, carried) in held.windows(2).zip(&self.read.held_pairs) {
            let (i, j) = (pair[0], pair[1]);
            rb.push(self.raw_carry_error(i, j, &carried.0));
            let (angle, compensated, span_s) = self.carry_error(i, j, &carried.1, carried.2);
            ra.push(angle);
            resolved &= compensated;
            floor.push(self.earth.horizontal_rad_s * span_s);
        }
        let (mut moved_held, mut moved_fitted) = (Vec::new(), Vec::new());
        for (i, carried) in (1..residuals.len()).zip(&self.read.consecutive) {
            let (angle, compensated, _) = self.carry_error(i - 1, i, &carried.0, carried.1);
            resolved &= compensated;
            if residuals[i - 1].held_out || residuals[i].held_out {
                moved_held.push(angle);
            } else {
                moved_fitted.push(angle);
            }
        }
        Validation {
            intervals: held.len(),
            rotation_pairs: rb.len(),
            static_rms_before_m_s2: rms(&before),
            static_rms_after_m_s2: rms(&after),
            rotation_rms_before_rad: rms(&rb),
            rotation_rms_after_rad: rms(&ra),
            fitted_intervals: fitted.len(),
            fitted_static_rms_m_s2: rms(&fitted),
            held_out_motions: moved_held.len(),
            held_out_motion_rms_rad: rms(&moved_held),
            fitted_motions: moved_fitted.len(),
            fitted_motion_rms_rad: rms(&moved_fitted),
            earth_rate: if resolved {
                EarthRateTreatment::Compensated
            } else {
                EarthRateTreatment::NotResolved {
                    floor_rad: rms(&floor),
                }
            },
        }
    }

    /// The angle between the raw gravity direction of rest `i`, carried by the raw gyros
    /// (`c`, the rotation from `i` to `j`) to rest `j`, and the raw one measured there (rad).
    pub(super) fn raw_carry_error(&self, i: usize, j: usize, c: &Matrix3<f64>) -> f64 {
        let (ui, uj) = (
            self.read.raw_f[i].normalize(),
            self.read.raw_f[j].normalize(),
        );
        angle_between(&(c.transpose() * ui), &uj)
    }

    /// The angle between the calibrated gravity direction of rest `i`, carried by the
    /// calibrated gyros (`c`, over `span_s`) to rest `j` (with the Earth's rotation over the
    /// span where the heading is resolved in rest `i`), and the one measured in rest `j`;
    /// whether the Earth's rotation was taken out; the span (s).
    pub(super) fn carry_error(
        &self,
        i: usize,
        j: usize,
        c: &Matrix3<f64>,
        span_s: f64,
    ) -> (f64, bool, f64) {
        let cal = &self.read.cal;
        let (ci, cj) = (cal[i].f, cal[j].f);
        let up = ci.normalize();
        // The calibrated mean rate of rest i.
        let (sum, dt) = self.read.cal_rate[i];
        let w = sum / dt.max(f64::MIN_POSITIVE);
        let earth = self.earth.in_body(&w, cal[i].sigma_w, &up);
        // An Earth-fixed direction turns in inertial space (the gyros' reference) by the Earth
        // rate times the span.
        let carried = match earth {
            Some(h) => exp_so3(&(h * span_s)) * ci,
            None => ci,
        };
        (
            angle_between(&(c.transpose() * carried), &cj),
            earth.is_some(),
            span_s,
        )
    }
}

pub(super) fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// Angle between two vectors (rad).
pub(super) fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// The least-squares baseline's figures beside a calibration's ([`Evaluation::baseline`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaselineFigures {
    /// RMS of `|f| - g` over the held-out rests (m/s^2).
    pub held_out_static_rms_m_s2: f64,
    /// The same over the fitted rests (m/s^2).
    pub fitted_static_rms_m_s2: f64,
}
