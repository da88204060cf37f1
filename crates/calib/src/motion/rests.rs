//! Recordings without a rotation program: the unit rests in several orientations and is turned
//! between them by hand (or by a turntable whose program is not known). The filter is the same
//! as for a program ([`crate::estimate`]); what the program gave, the rests give:
//!
//! - **where the specific force is known**: a specific-force window is used only when every
//!   IMU step of it lies inside a rest, shrunk by [`REST_MARGIN_S`] at both ends (the unit
//!   still settles there, and the detector's edges are a window wide);
//! - **the start attitude**: levelled from the mean specific force of the first rest, and its
//!   heading from the mean rate (gyrocompassing) where the gyros resolve the Earth rate's
//!   horizontal part to better than [`GYROCOMPASS_MAX_SIGMA_RAD`]; otherwise the heading is
//!   free, with the prior sigma [`FREE_HEADING_SIGMA_RAD`]; the prior is wide and independent
//!   of the parameters ([`RestAlignment`]);
//! - **the segments of the diagnostics**: rests and the motions between them, by name.
//!
//! The attitude is carried by the gyros through every motion with the Earth rate in the model,
//! exactly as through a program's rotations.

use crate::check::diagnostics::Segment;
use crate::motion::align::RateBin;
use crate::motion::stamps::Stamps;
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::earth::Site;
use sins_model::terms::{ErrorModel, Sensor, SensorInput};

/// A stretch of a recording in which the unit is at rest, on the IMU clock (s): the one type of
/// a static interval (the filter's gate, the coarse fit, the held-out figures and the noise
/// measured in the rests all take it). Its records are those whose whole interval lies in it
/// ([`Rest::records`], a range whose end is exclusive).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Rest {
    /// First instant at rest (s).
    pub t0: f64,
    /// Last instant at rest (s), included.
    pub t1: f64,
}

impl Rest {
    /// The records of the rest in the increasing time stamps `t`: those whose whole interval
    /// (from the stamp before, excluded, to their own) lies in it, i.e. from the first record
    /// whose previous stamp is at or after `t0` to the last one stamped at or before `t1`.
    /// 0-based indices into `t`, the end exclusive; empty when no record's interval lies in the
    /// rest (the first record, whose interval is not known, never counts). The record that
    /// straddles `t0` (stamped after it, its interval begun before it) belongs to the motion
    /// before the rest; a grouped record (the coarse fit's) likewise belongs to the rest only
    /// when all of it does. A detector's rest begins at the start of its first record's
    /// interval, the stamp before it, so that record is the first.
    /// The stamps are held or counted in a reading ([`Stamps`]).
    pub fn records<S: Stamps + ?Sized>(&self, t: &S) -> std::ops::Range<usize> {
        let end = t.through(self.t1);
        let start = (t.before(self.t0) + 1).min(end);
        start..end
    }

    /// The rest with [`REST_MARGIN_S`] cut from both ends (empty, `t1 < t0`, for a rest
    /// shorter than the two margins).
    pub fn less_margins(&self) -> Rest {
        Rest {
            t0: self.t0 + REST_MARGIN_S,
            t1: self.t1 - REST_MARGIN_S,
        }
    }
}

/// What is cut from both ends of a rest before its specific force is used (s): a static
/// detector's edges are uncertain by about its window, and a hand-placed unit settles.
pub const REST_MARGIN_S: f64 = 0.25;

/// The heading comes from the gyros (gyrocompassing) when its sigma from the gyro priors and
/// the noise of the first rest's mean rate is below this (rad, about 6 deg); otherwise it is
/// free.
pub const GYROCOMPASS_MAX_SIGMA_RAD: f64 = 0.1;

/// Prior sigma of a heading the gyros cannot resolve (rad): wide. Where the gyros cannot see
/// the Earth rate the heading enters the model only through it, so its linearisation error is
/// below the gyro noise.
pub const FREE_HEADING_SIGMA_RAD: f64 = std::f64::consts::PI;

/// Shortest rest whose mean fixes the start attitude (s, after the margins).
pub const MIN_START_REST_S: f64 = 0.5;

/// Errors of a rest list.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RestError {
    /// No rest at all.
    #[error("no rest was found in the recording: the specific force is known only at rest")]
    None,
    /// Rests out of order, overlapping or not finite.
    #[error("rest {index} ({t0} .. {t1} s) is empty, overlaps the one before or is not finite")]
    Order {
        /// 1-based index.
        index: usize,
        /// Start (s).
        t0: f64,
        /// End (s).
        t1: f64,
    },
    /// The recording does not start at rest.
    #[error(
        "the recording starts at {start} s but its first rest at {first_rest} s: the start \
         attitude is levelled in a rest at the start of the recording (cut the records before \
         the first rest, or record a rest first)"
    )]
    NoStartRest {
        /// First record's start (s).
        start: f64,
        /// First rest (s).
        first_rest: f64,
    },
    /// Rests need an IMU-only model.
    #[error(
        "a recording of rests is calibrated from the IMU data alone: turntable angles need \
         their program (or a configuration with `program = \"from-angles\"`)"
    )]
    WithTurntable,
    /// No data in the first rest.
    #[error("no IMU data in the first rest ({t0} .. {t1} s, less its margins)")]
    NoData {
        /// Start (s).
        t0: f64,
        /// End (s).
        t1: f64,
    },
    /// A coarse start of the wrong length.
    #[error("a coarse start of {got} parameters: expected {expected}")]
    CoarseStart {
        /// Given.
        got: usize,
        /// The layout's instrument parameters.
        expected: usize,
    },
    /// A hold-out that holds out no rest, or the first.
    #[error(
        "holdout K = {every} (--holdout): the recording has {rests} rests; every K-th rest is held out, so K \
         must be at least 2 (the first rest levels the start attitude) and at most {rests}"
    )]
    HoldOut {
        /// K.
        every: usize,
        /// Rests in the recording.
        rests: usize,
    },
    /// Records too far apart for a hand-turned recording.
    #[error(
        "the records come every {interval_s} s on average: a hand-turned recording's IMU \
         records come at 10 Hz or more (time stamps in milliseconds read as seconds?)"
    )]
    SlowRecords {
        /// Mean record interval (s).
        interval_s: f64,
    },
    /// The rests cannot separate the accelerometer parameters (too few, or all pointing
    /// gravity one way).
    #[error("{0}")]
    Poses(String),
    /// The batch fit that gives the coarse start failed.
    #[error("the coarse start (batch fit of the rests) failed: {0}")]
    CoarseFit(String),
    /// The calibration's correction cannot be applied to the records for its figures.
    #[error("the calibration's correction cannot be applied to the records: {0}")]
    Evaluation(String),
    /// The first rest is too short to level in.
    #[error(
        "the first rest ({t0} .. {t1} s) is shorter than {min} s after its margins of \
         {margin} s: too short to level the start attitude"
    )]
    StartRestTooShort {
        /// Start (s).
        t0: f64,
        /// End (s).
        t1: f64,
        /// Shortest usable (s).
        min: f64,
        /// Margin cut at both ends (s).
        margin: f64,
    },
}

/// Check a rest list against the recording that starts at `t_start` (start of the first
/// record's interval): in order, not overlapping, the first at the start of the recording and
/// long enough to level in. A rest beginning within [`REST_MARGIN_S`] plus `slack_s` of the
/// start counts as at the start.
pub fn check_rests(rests: &[Rest], t_start: f64, slack_s: f64) -> Result<(), RestError> {
    let first = rests.first().ok_or(RestError::None)?;
    let mut prev_end = f64::NEG_INFINITY;
    for (i, r) in rests.iter().enumerate() {
        if !(r.t0.is_finite() && r.t1.is_finite() && r.t1 > r.t0 && r.t0 >= prev_end) {
            return Err(RestError::Order {
                index: i + 1,
                t0: r.t0,
                t1: r.t1,
            });
        }
        prev_end = r.t1;
    }
    if first.t0 > t_start + REST_MARGIN_S + slack_s {
        return Err(RestError::NoStartRest {
            start: t_start,
            first_rest: first.t0,
        });
    }
    if first.t1 - REST_MARGIN_S - first.t0.max(t_start) < MIN_START_REST_S {
        return Err(RestError::StartRestTooShort {
            t0: first.t0,
            t1: first.t1,
            min: MIN_START_REST_S,
            margin: REST_MARGIN_S,
        });
    }
    Ok(())
}

/// Standard deviation of a known turn's angle (rad): a hand-made turn against a box edge
/// (the filter's and the coarse fit's, [`crate::motion::free_motion::coarse_fit`]).
pub const TURN_SIGMA_RAD: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// A turn of known angle in a recording of rests (a section list's 360-degree turns): a
/// measurement of the gyros' integrated angle about `axis` over the records stamped `t0` to
/// `t1` (each record's increment over its own interval ending at its stamp), against
/// `angle_rad`, with the sigma [`TURN_SIGMA_RAD`]. The one type of a known turn: the filter,
/// the coarse fit and the held-out figures take it, each on its own records
/// ([`Turn::records`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Turn {
    /// Name for reports (`x_rot`).
    pub name: String,
    /// Stamp of the turn's first record (s, IMU clock).
    pub t0: f64,
    /// Stamp of its last record.
    pub t1: f64,
    /// Body axis of the turn (unit vector).
    pub axis: Vector3<f64>,
    /// Angle about `axis`, right-handed (rad).
    pub angle_rad: f64,
}

impl Turn {
    /// The turn `name` over the records stamped `t0` to `t1` (`stamps`) about `axis` (body
    /// axes, made a unit vector) by `angle_rad`; `None` for an axis of zero length.
    pub fn about(name: &str, stamps: (f64, f64), axis: [f64; 3], angle_rad: f64) -> Option<Self> {
        Some(Self {
            name: name.to_string(),
            t0: stamps.0,
            t1: stamps.1,
            axis: Vector3::from(axis).try_normalize(0.0)?,
            angle_rad,
        })
    }

    /// The records of the turn in the increasing time stamps `t`: those that hold any of it,
    /// from the first stamped at or after `t0` to the first stamped at or after `t1` (or the
    /// last record). 0-based indices into `t`, the end exclusive; empty when the turn lies
    /// after the records. On the records the turn was given on these are the ones stamped `t0`
    /// to `t1`; on records grouped into longer ones (the coarse fit's) the groups that hold them.
    /// The stamps are held or counted in a reading ([`Stamps`]).
    pub fn records<S: Stamps + ?Sized>(&self, t: &S) -> std::ops::Range<usize> {
        let Some(last) = t.count().checked_sub(1) else {
            return 0..0;
        };
        let end = t.before(self.t1).min(last) + 1;
        let start = t.before(self.t0).min(end);
        start..end
    }
}

/// The rests with their margins cut, as the specific-force gate of a pass uses them; rests
/// shorter than twice the margin are dropped.
pub fn usable(rests: &[Rest]) -> Vec<Rest> {
    rests
        .iter()
        .filter(|r| r.t1 - r.t0 > 2.0 * REST_MARGIN_S)
        .map(Rest::less_margins)
        .collect()
}

/// Whether the `i`-th segment with measurements (counted from 0; on a recording of rests the
/// `i`-th rest) is held out by a fit with `filter.hold_out_every = every`: every `every`-th,
/// counted from 1. The one rule of a hold-out: the filter's held-out windows, the rests the
/// coarse start leaves out and the held-out figures all take it. `None` and `Some(0)` hold out
/// nothing (no caller passes 0: `--holdout` below 2 is refused before; `Some(0)` is not "every
/// rest", which would hold out the first, whose windows level the start attitude).
pub fn held_out(i: usize, every: Option<usize>) -> bool {
    every.is_some_and(|k| k > 0 && (i + 1).is_multiple_of(k))
}

/// The segments of a recording of rests for the diagnostics: `rest 1`, `motion 1-2`,
/// `rest 2`, ... on the IMU clock.
pub fn segments(rests: &[Rest]) -> Vec<Segment> {
    let mut out = Vec::with_capacity(2 * rests.len());
    for (i, r) in rests.iter().enumerate() {
        if i > 0 {
            out.push(Segment {
                levels_start: false,
                index: out.len(),
                cycle: None,
                label: format!("motion {}-{}", i, i + 1),
                t0: rests[i - 1].t1,
                t1: r.t0,
                rotation_hz: 0.0,
            });
        }
        out.push(Segment {
            levels_start: i == 0,
            index: out.len(),
            cycle: None,
            label: format!("rest {}", i + 1),
            t0: r.t0,
            t1: r.t1,
            rotation_hz: 0.0,
        });
    }
    out
}

/// Whether the IMU steps of a specific-force window all lie in a rest: a pass asks for every
/// step in order ([`RestGate::step_at_rest`]); the gate walks the rests forward.
#[derive(Clone, Debug)]
pub struct RestGate {
    rests: Vec<Rest>,
    next: usize,
}

impl RestGate {
    /// A gate over rests already cut by their margins ([`usable`]).
    pub fn new(rests: Vec<Rest>) -> Self {
        Self { rests, next: 0 }
    }

    /// Whether the step over `(t - dt, t]` lies inside a rest. Steps must come in time order.
    #[inline]
    pub fn step_at_rest(&mut self, t: f64, dt: f64) -> bool {
        while self.next < self.rests.len() && self.rests[self.next].t1 < t {
            self.next += 1;
        }
        self.rests
            .get(self.next)
            .is_some_and(|r| r.t0 <= t - dt && t <= r.t1)
    }

    /// The rest the last step asked about lay in, or else the next one (`None` after the
    /// last).
    pub fn current(&self) -> Option<&Rest> {
        self.rests.get(self.next)
    }
}

/// The start attitude levelled (and, where the gyros resolve it, gyrocompassed) in the first
/// rest, and the sigmas of its prior.
///
/// The prior is wide and independent of the instrument parameters: [`PRIOR_WIDENING`] times
/// what the parameters' priors and the rest's noise make of the levelling and gyrocompassing.
/// The filter then learns the start attitude from the same data the levelling used (the
/// specific-force windows of the first rest, the gyro drift through it); a prior tied to the
/// parameters as `beta_0 = B p + eps`, as a program's alignment is, would count the first rest's
/// data twice (tried: NEES 51.6 per run for 24 states over seeds 500-509 of the 19-position
/// test, sigmas of the gyro matrix half those of the filter that knows the program).
#[derive(Clone, Debug, PartialEq)]
pub struct RestAlignment {
    /// Start attitude (body to ENU) at the start of the first record.
    pub c_start: Matrix3<f64>,
    /// Whether the heading came from the gyros.
    pub gyrocompassed: bool,
    /// Sigma of the gyrocompassed heading from the gyros' priors and the rest's noise (rad);
    /// above [`GYROCOMPASS_MAX_SIGMA_RAD`] the heading is free.
    pub gyrocompass_sigma_rad: f64,
    /// Prior sigma of the start tilt, about East and North (rad).
    pub tilt_prior_rad: f64,
    /// Prior sigma of the start heading (rad).
    pub heading_prior_rad: f64,
}

/// The widest prior of the start tilt (rad): the specific-force measurement is linear in the
/// tilt only for small ones.
pub const MAX_TILT_PRIOR_RAD: f64 = 0.01;

/// How much wider than the levelling's and gyrocompassing's own sigmas the start attitude's
/// prior is ([`RestAlignment`]).
pub const PRIOR_WIDENING: f64 = 10.0;

/// Level and gyrocompass in `rest` ([`RestAlignment`]): `rest` is the first rest with its
/// margins cut, `bins` the data's rate bins, `p0` the instrument parameters the mean rate and
/// specific force are compensated with (the sensor models inverted), `prior_sigma` the
/// instrument parameters' prior sigmas, the noise levels PSDs (`(rad/s)^2 s`, `(m/s^2)^2 s`).
/// `None` when no bin of the data lies in the rest or the specific force there is zero.
#[allow(clippy::too_many_arguments)]
pub fn align_in_rest(
    bins: &[RateBin],
    rest: &Rest,
    site: &Site,
    model: &ErrorModel,
    p0: &[f64],
    prior_sigma: &[f64],
    gyro_psd: f64,
    accel_psd: f64,
) -> Option<RestAlignment> {
    let (mut w, mut f, mut t) = (Vector3::zeros(), Vector3::zeros(), 0.0);
    for b in bins.iter().filter(|b| b.t0 >= rest.t0 && b.t1 <= rest.t1) {
        let d = b.t1 - b.t0;
        w += b.rate * d;
        f += b.f * d;
        t += d;
    }
    if t <= 0.0 {
        return None;
    }
    let (raw_w, raw_f) = (w / t, f / t);
    // The sensor models inverted at p0 (the filter's compensation, the means as the increments
    // of one second).
    let (w, f) = crate::model::correction::Compensation::new(model, p0)
        .apply(model, p0, &raw_w, &raw_f, 1.0, 0.0, &mut None);
    let up = f.try_normalize(0.0)?;
    let g = site.specific_force_at_rest_enu().norm();
    let omega_h = site.earth_rate_enu().y.abs().max(1e-300);
    // What the parameters' priors and the noise of the rest's means do to the horizontal rate
    // and the horizontal specific force.
    let n = model.n_params();
    let input = SensorInput {
        omega_body: w,
        f_body: f,
        ..SensorInput::default()
    };
    let horizontal_var = |sensor: Sensor, psd: f64| {
        let mut jac = vec![Vector3::zeros(); n];
        model.jacobian(sensor, &vec![0.0; n], &input, &mut jac);
        jac.iter()
            .zip(prior_sigma)
            .map(|(j, s)| ((j - up * up.dot(j)).norm() * s).powi(2))
            .sum::<f64>()
            + psd / t
    };
    let gyrocompass_sigma_rad = horizontal_var(Sensor::Gyro, gyro_psd).sqrt() / omega_h;
    let tilt_sigma = horizontal_var(Sensor::Accel, accel_psd).sqrt() / g;
    let gyrocompassed = gyrocompass_sigma_rad < GYROCOMPASS_MAX_SIGMA_RAD;
    let c_start = level(&w, &f, gyrocompassed)?;
    let heading_prior_rad = if gyrocompassed {
        (PRIOR_WIDENING * gyrocompass_sigma_rad).min(FREE_HEADING_SIGMA_RAD)
    } else {
        FREE_HEADING_SIGMA_RAD
    };
    Some(RestAlignment {
        c_start,
        gyrocompassed,
        gyrocompass_sigma_rad,
        tilt_prior_rad: (PRIOR_WIDENING * tilt_sigma).clamp(1e-6, MAX_TILT_PRIOR_RAD),
        heading_prior_rad,
    })
}

/// The attitude (body to ENU) of a unit at rest that measures the mean rate `w` and specific
/// force `f` (body axes): up along `f`; with `gyrocompass`, East along `w x up` (the Earth
/// rate's horizontal part points North); otherwise East along the body axis nearest the
/// horizontal plane, turned into it. `None` for a zero specific force or a rate along it.
pub fn level(w: &Vector3<f64>, f: &Vector3<f64>, gyrocompass: bool) -> Option<Matrix3<f64>> {
    let up = f.try_normalize(0.0)?;
    let east = if gyrocompass {
        w.cross(&up).try_normalize(0.0)?
    } else {
        // The body axis most nearly horizontal, projected onto the horizontal plane.
        let k = (0..3)
            .min_by(|&a, &b| up[a].abs().total_cmp(&up[b].abs()))
            .expect("three axes");
        let mut e = Vector3::zeros();
        e[k] = 1.0;
        (e - up * up.dot(&e)).try_normalize(0.0)?
    };
    let north = up.cross(&east);
    // Rows: the ENU axes in body coordinates.
    Some(Matrix3::from_rows(&[
        east.transpose(),
        north.transpose(),
        up.transpose(),
    ]))
}

/// The prior covariance of all states with the start attitude error of a rest alignment:
/// independent of the other states, with the alignment's tilt and heading sigmas.
pub fn rest_covariance(p0: &DMatrix<f64>, al: &RestAlignment) -> DMatrix<f64> {
    let mut p = crate::motion::align::without_attitude(p0);
    p[(0, 0)] = al.tilt_prior_rad.powi(2);
    p[(1, 1)] = al.tilt_prior_rad.powi(2);
    p[(2, 2)] = al.heading_prior_rad.powi(2);
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use sins_model::attitude::{exp_so3, log_so3};

    #[test]
    fn levelling_and_gyrocompassing_recover_the_attitude() {
        let site = Site {
            latitude: 55.7_f64.to_radians(),
            longitude: 0.6,
            height: 200.0,
        };
        let c_true = exp_so3(&Vector3::new(0.3, -1.2, 2.5));
        let w = c_true.transpose() * site.earth_rate_enu();
        let f = c_true.transpose() * site.specific_force_at_rest_enu();
        let c = level(&w, &f, true).unwrap();
        assert!(log_so3(&(c * c_true.transpose())).norm() < 1e-12);
        // Without the gyros the tilt is right and the heading anything.
        let c = level(&w, &f, false).unwrap();
        let e = log_so3(&(c * c_true.transpose()));
        assert!(e.x.abs() < 1e-12 && e.y.abs() < 1e-12, "{e}");
    }

    #[test]
    fn the_gate_answers_for_steps_in_order() {
        let mut g = RestGate::new(vec![Rest { t0: 1.0, t1: 2.0 }, Rest { t0: 3.0, t1: 4.0 }]);
        let cases = [
            (0.5, false),
            (1.05, false), // starts before the rest
            (1.55, true),
            (2.0, true),
            (2.05, false), // ends after it
            (2.5, false),
            (3.5, true),
            (4.2, false),
        ];
        for (t, at_rest) in cases {
            assert_eq!(g.step_at_rest(t, 0.1), at_rest, "t = {t}");
        }
    }

    /// A rest's records are those whose whole interval lies in it; a turn's those that hold
    /// any of it, on the records it was given on and on grouped ones.
    #[test]
    fn rests_and_turns_have_one_rule_for_their_records() {
        // Records stamped 1, 2, ..., 20 s (record k at k + 1).
        let t: Vec<f64> = (1..=20).map(f64::from).collect();
        // Record 4, over (4, 5], straddles the start: the rest's records are 5 (over (5, 6])
        // to 11 (stamped 12).
        assert_eq!(Rest { t0: 4.5, t1: 12.0 }.records(&t), 5..12);
        // From the stamp of record 3 on, record 4's interval lies in the rest.
        assert_eq!(Rest { t0: t[3], t1: 12.0 }.records(&t), 4..12);
        assert!(Rest { t0: 25.0, t1: 30.0 }.records(&t).is_empty());
        assert!(Rest { t0: 4.2, t1: 4.8 }.records(&t).is_empty());
        let turn = |t0: f64, t1: f64| Turn {
            name: "x".into(),
            t0,
            t1,
            axis: Vector3::x(),
            angle_rad: 1.0,
        };
        assert_eq!(turn(t[4], t[9]).records(&t), 4..10);
        assert_eq!(turn(t[4], 90.0).records(&t), 4..20);
        assert!(turn(90.0, 100.0).records(&t).is_empty());
        assert!(turn(0.0, 1.0).records(&[][..]).is_empty());
        // Grouped by five (stamps 5, 10, 15, 20): the groups that hold records 4 .. 9, 5 .. 10.
        let grouped: Vec<f64> = t.iter().skip(4).step_by(5).copied().collect();
        assert_eq!(turn(t[4], t[9]).records(&grouped), 0..2);
        assert_eq!(turn(t[5], t[10]).records(&grouped), 1..3);
        // A turn's axis is made a unit vector; a zero one is no turn.
        let about = Turn::about("y", (t[4], t[9]), [0.0, 2.0, 0.0], 1.0).unwrap();
        assert_eq!(about.axis, Vector3::y());
        assert!(Turn::about("z", (t[4], t[9]), [0.0; 3], 1.0).is_none());
    }

    /// Every K-th counted from 1; no K (or K = 0) holds out nothing.
    #[test]
    fn held_out_is_every_kth_from_one() {
        let held = |every| (0..7).filter(|&i| held_out(i, every)).collect::<Vec<_>>();
        assert_eq!(held(Some(3)), vec![2, 5]);
        assert_eq!(held(Some(1)), (0..7).collect::<Vec<_>>());
        assert!(held(Some(0)).is_empty());
        assert!(held(None).is_empty());
    }

    #[test]
    fn rest_lists_are_checked() {
        let r = |t0, t1| Rest { t0, t1 };
        assert_eq!(check_rests(&[], 0.0, 0.0), Err(RestError::None));
        assert!(check_rests(&[r(0.0, 5.0), r(6.0, 9.0)], 0.0, 0.0).is_ok());
        assert!(matches!(
            check_rests(&[r(0.0, 5.0), r(4.0, 9.0)], 0.0, 0.0),
            Err(RestError::Order { index: 2, .. })
        ));
        assert!(matches!(
            check_rests(&[r(3.0, 5.0)], 0.0, 0.0),
            Err(RestError::NoStartRest { .. })
        ));
        assert!(matches!(
            check_rests(&[r(0.0, 0.6)], 0.0, 0.0),
            Err(RestError::StartRestTooShort { .. })
        ));
    }
}
