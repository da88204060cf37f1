//! One pass of the estimation over the data, as an explicit engine with named stages:
//! compensate the increments (the sensor models inverted: [`Compensation`], whose home is
//! [`crate::model::correction`] with the rest of the inverse), propagate (strapdown and error
//! model), read the turntable angles, update at the measurement instants, feed back.
//! [`Pass::step`] is the whole state machine.

use super::angles::AngleInterpolator;
use super::{EstimateError, FitStatistics};
use crate::check::diagnostics::Innovation;
use crate::io::{ImuKind, ImuRecord};
use crate::model::correction::{CompensatedMeans, Compensation};
use crate::model::engine::{Engine, InstantReport, Phase, RateChanges};
use crate::model::layout::StateLayout;
use crate::model::{AngleSample, MeasurementKind};
use crate::motion::rests::RestGate;
use nalgebra::{Matrix3, Vector3};
use sins_model::attitude::{attitude_error, exp_so3, log_so3, orthonormalize, right_jacobian_inv};
use sins_model::terms::{Sensor, SensorInput};
use turntable::gimbal::gimbal_frame_sin_cos;

/// The point the pass linearises about: the current totals of every non-attitude state.
#[derive(Clone, Debug)]
pub(super) struct Linearisation {
    /// Instrument parameters (SI), in the error model's order.
    pub p: Vec<f64>,
    /// Installation misalignment `delta_z` (rad).
    pub delta: Vector3<f64>,
    /// Delay of the turntable data (s).
    pub tau: f64,
    /// Base misalignment `gamma_p` (rad).
    pub gamma: Vector3<f64>,
    /// `exp(delta)`, kept with it.
    pub c_install: Matrix3<f64>,
    /// `exp(gamma)`, kept with it.
    pub c_base: Matrix3<f64>,
    /// The compensation of the increments with `p`, kept with it.
    pub compensation: Compensation,
}

impl Linearisation {
    /// From a full state vector of totals (attitude entries unused).
    pub fn from_totals(layout: &StateLayout, totals: &[f64]) -> Self {
        let v3 = |k: Option<usize>| {
            k.map_or(Vector3::zeros(), |k| {
                Vector3::new(totals[k], totals[k + 1], totals[k + 2])
            })
        };
        let off = StateLayout::INSTRUMENT;
        let (delta, gamma) = (v3(layout.install), v3(layout.base));
        let p = totals[off..off + layout.n_instrument()].to_vec();
        Self {
            compensation: Compensation::new(&layout.model, &p),
            p,
            delta,
            tau: layout.tau.map_or(0.0, |k| totals[k]),
            gamma,
            c_install: exp_so3(&delta),
            c_base: exp_so3(&gamma),
        }
    }

    /// Add the error estimates `x` (a full state vector, SI) of every non-attitude state.
    pub fn absorb(&mut self, layout: &StateLayout, x: &[f64]) {
        for (k, p) in self.p.iter_mut().enumerate() {
            *p += x[StateLayout::INSTRUMENT + k];
        }
        self.compensation = Compensation::new(&layout.model, &self.p);
        // The mounting errors are small rotations about the current mountings, as the
        // turntable measurement's Jacobian takes them: body-frame for the installation
        // (`exp(dz) = exp(dz_hat) exp(d)`, Jacobian `-C`), ENU for the base
        // (`exp(g) exp(g_hat)`, Jacobian `-I`). Adding rotation vectors instead is wrong by
        // `dz_hat x d / 2`, a few per cent for degree-level mountings.
        if let Some(k) = layout.install {
            self.c_install *= exp_so3(&Vector3::new(x[k], x[k + 1], x[k + 2]));
            self.delta = log_so3(&self.c_install);
        }
        if let Some(k) = layout.tau {
            self.tau += x[k];
        }
        if let Some(k) = layout.base {
            self.c_base = exp_so3(&Vector3::new(x[k], x[k + 1], x[k + 2])) * self.c_base;
            self.gamma = log_so3(&self.c_base);
        }
    }
}

/// The strapdown attitude (body to ENU) at the IMU rate, with the coning and sculling terms.
#[derive(Clone, Debug)]
pub(super) struct Strapdown {
    /// Computed attitude at the end of the last step.
    pub c: Matrix3<f64>,
    /// Earth rotation over one step, `exp(-skew(u dt))`.
    a_step: Matrix3<f64>,
    /// The Earth rotation vector of one step, `u dt` (ENU).
    zeta: Vector3<f64>,
    dth_prev: Vector3<f64>,
    dv_prev: Vector3<f64>,
}

/// What one strapdown step hands to the error model.
pub(super) struct StepKinematics {
    /// Attitude at the middle of the step (mean of its ends).
    pub c_mid: Matrix3<f64>,
    /// Velocity increment of the step in ENU (with rotation and sculling terms).
    pub dv_enu: Vector3<f64>,
}

impl Strapdown {
    pub fn new(c0: Matrix3<f64>, u_enu: &Vector3<f64>, dt: f64) -> Self {
        Self {
            c: c0,
            a_step: exp_so3(&(-u_enu * dt)),
            zeta: u_enu * dt,
            dth_prev: Vector3::zeros(),
            dv_prev: Vector3::zeros(),
        }
    }

    /// Advance by the true increments of one step.
    #[inline(always)]
    pub fn advance(&mut self, dth: &Vector3<f64>, dv: &Vector3<f64>) -> StepKinematics {
        // The previous-sample coning and sculling corrections assume rates that vary smoothly
        // across the two samples; across a jump of the rate (a reversal or the start or stop of
        // a turn) they are wrong by (w dt)^2-sized terms, so that step goes without them.
        // (Squared norms: no square roots per step.)
        let jump2 = (dth - self.dth_prev).norm_squared();
        if jump2 > 0.01 * dth.norm_squared().max(self.dth_prev.norm_squared()) {
            self.dth_prev = Vector3::zeros();
            self.dv_prev = Vector3::zeros();
        }
        // Products with reciprocal constants rather than divisions (one step each).
        const TWELFTH: f64 = 1.0 / 12.0;
        const SIXTH: f64 = 1.0 / 6.0;
        let phi = dth + self.dth_prev.cross(dth) * TWELFTH;
        // The rotation of the velocity increment to the step's start frame in full
        // (`exp(skew(dth) s)` integrated over the step: `dv + dth x dv / 2 + dth x (dth x dv) / 6`;
        // without the last term every accelerometer scale factor came out (w dt)^2 / 6 off,
        // 5e-7 at 10 deg/s and 100 Hz), and the sculling term.
        let dv_body = dv
            + 0.5 * dth.cross(dv)
            + dth.cross(&dth.cross(dv)) * SIXTH
            + (self.dth_prev.cross(dv) + self.dv_prev.cross(dth)) * TWELFTH;
        let c_prev = self.c;
        self.c = self.a_step * c_prev * exp_so3(&phi);
        (self.dth_prev, self.dv_prev) = (*dth, *dv);
        // In the ENU frame, which turns by zeta = u dt against inertial space over the step:
        // dv_enu = (I - skew(zeta) / 2) C_prev dv_body.
        let dv_start = c_prev * dv_body;
        StepKinematics {
            c_mid: (c_prev + self.c) * 0.5,
            dv_enu: dv_start - 0.5 * self.zeta.cross(&dv_start),
        }
    }

    /// Rotate the computed attitude by the estimated attitude error `beta` (feedback).
    pub fn correct(&mut self, beta: &Vector3<f64>) {
        self.c = orthonormalize(&(exp_so3(beta) * self.c));
    }
}

/// The turntable side of a pass: the interpolator and what the samples need.
pub(super) struct AngleReader<'a> {
    pub interp: AngleInterpolator<'a>,
    /// The platform's rate changes (program time) and the program's start on the IMU clock.
    pub rate_changes: &'a RateChanges,
    pub program_start: f64,
    /// Take one sample per angle record (at the IMU step nearest to the time the record holds)
    /// rather than one per IMU step: set when the records are more than two IMU steps apart.
    pub per_record: bool,
    /// Where the last sample's span fell among the rate changes
    /// ([`RateChanges::clear_near`]).
    pub rate_change_hint: usize,
}

/// What a pass feeds back after each update.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Feedback {
    /// Every estimate: the attitude error into the attitude, the others into their totals
    /// (closed loop: the first pass from the prior).
    All,
    /// The attitude error only: the parameters stay errors about the linearisation point (the
    /// first pass from a coarse start, whose parameters are good enough to linearise about but
    /// whose attitude drifts).
    Attitude,
    /// Nothing: a pass linearised about the pass before keeps its trajectory.
    None,
    /// The tilt only (the horizontal attitude errors): a pass linearised about the pass before
    /// on a recording of rests, whose trajectory the gyro noise walks (`iterate_passes`). After
    /// a specific-force update the trajectory is re-levelled to that window's measured specific
    /// force and the tilt states move by the same rotation ([`level_rotation`]); after any other
    /// update (a known turn, a held-out window) the tilt estimate is fed back.
    Tilt,
}

/// Fixed settings of a pass.
pub(super) struct PassSettings {
    pub kind: ImuKind,
    pub dt: f64,
    /// `1 / dt`.
    pub inv_dt: f64,
    pub u_enu: Vector3<f64>,
    pub f_enu: Vector3<f64>,
    /// Feed every estimate back (closed loop, the first pass) or nothing (a pass linearised
    /// about the one before).
    pub feedback: Feedback,
    /// Number of IMU records.
    pub n_steps: usize,
    /// Integrate each record over its own interval (from the time stamp before; the first over
    /// `dt`): a recording with jittered time stamps. Otherwise every record spans `dt`.
    pub own_intervals: bool,
    /// White noise added to each attitude-error axis at the first measurement after a motion
    /// (a recording of rests; rad).
    pub motion_attitude_noise_rad: f64,
    /// The variance every specific-force window of one rest shares ((m/s^2)^2 per axis;
    /// `filter.rest_error_m_s2` squared), and the measurement rate (Hz): a window of a rest of
    /// `m` windows is weighted as one of white noise plus `m` times it ([`Pass::step`]).
    pub rest_error_var: f64,
    /// See `rest_error_var`.
    pub accel_rate_hz: f64,
    /// The reference temperature of the thermal terms (deg C), when the records have a
    /// temperature: each record's departure from it is the terms' input.
    pub temp_reference_c: Option<f64>,
}

/// One pass over the data.
pub(super) struct Pass<'a> {
    pub layout: &'a StateLayout,
    pub settings: PassSettings,
    pub engine: Engine,
    pub nav: Strapdown,
    pub lin: Linearisation,
    pub angles: Option<AngleReader<'a>>,
    pub stats: FitStatistics,
    /// A recording of rests: the specific force is measured only in windows that lie wholly
    /// in a rest ([`crate::motion::rests`]); `None` for a program, where it is known throughout.
    pub rest_gate: Option<RestGate>,
    /// Whether every step of the open specific-force window so far lay in a rest.
    window_at_rest: bool,
    /// A window was left out for motion since the last measurement instant.
    moved: bool,
    nis_sum: (f64, f64),
    /// Sum of the turntable updates' expected NIS (`UpdateRecord::expected_nis`).
    expected_turntable_nis_sum: f64,
    /// Every update of the pass in order (segments assigned by the caller).
    innovations: Vec<Innovation>,
    /// Steps done.
    j: usize,
    /// The phase of the next step in the measurement cycles.
    phase: Phase,
    /// The filter's sigma of the delay (s), read again after every predict and update (a
    /// turntable sample needs it at every IMU step).
    tau_sigma: f64,
    /// The step before, as the compensation of the rate-derivative terms takes it.
    prev_compensated: Option<CompensatedMeans>,
    /// The current record's temperature less the thermal terms' reference (K; zero without a
    /// temperature).
    temp_delta: f64,
    /// The step before, as the error Jacobians took it: the mean rate and the specific force
    /// from the computed attitude (the rate derivatives of the Jacobians are differences to it).
    prev_jacobian: Option<(Vector3<f64>, Vector3<f64>)>,
    /// Space for the filter state at a feedback (no allocation per measurement instant).
    state: Vec<f64>,
    /// Time stamp of the record before (s; NaN before the first).
    prev_t: f64,
    /// IMU-time intervals whose measurements are held out (`filter.hold_out_every`), in
    /// order, and the first not yet passed.
    pub held_out: Vec<(f64, f64)>,
    held_out_next: usize,
    /// Known turns in time order ([`crate::motion::rests::Turn`]), the first not yet measured, and
    /// the one under way: its integrated angle and its row of `H`.
    pub turns: Vec<crate::motion::rests::Turn>,
    turn_next: usize,
    turn_angle: f64,
    turn_h: Vec<f64>,
    turn_nis_sum: f64,
    /// Space for the gyro Jacobian of a step of a known turn.
    turn_jac: Vec<Vector3<f64>>,
}

/// The horizontal rotation that turns a window's measured specific force `f_x + z` (ENU, the
/// computed attitude) onto the expected `f_x`, to first order: `skew(f_x) d = z` in its
/// horizontal rows, `d_z = 0`. `None` when `f_x` has no vertical component.
///
/// Why the trajectory is re-levelled to the data rather than to the filter's tilt estimate:
/// on a recording of rests the tilt and the horizontal accelerometer errors are told apart only
/// across turns, so in the first rest and after each turn the tilt estimate swings by the share
/// of that combination the filter gives it (up to 5e-3 rad on a consumer-grade run). Fed back,
/// those swings put the trajectory off by as much, and the products of that attitude error
/// with the accelerometer errors still at their priors are second-order terms the linear model
/// does not carry: with the gyro noise all but removed, one pass linearised about the true
/// parameters put `accel.gamma.xx` 2.4 sigma off (0.4 open loop), and over seeds 850-899 of
/// `tests/tests/rests.rs` the consumer-grade NEES was 36.5 per run for 24 states with
/// `accel.gamma.xx` biased by -5.3 standard errors. Re-levelled to the data, the trajectory's
/// tilt error stays at the noise of one window; the estimate does not move (to first order,
/// the states shift by the same rotation) and the linear model holds.
fn level_rotation(f_enu: &Vector3<f64>, z: &Vector3<f64>) -> Option<Vector3<f64>> {
    let a = sins_model::errors::specific_force_beta_jacobian(f_enu);
    let d = nalgebra::Matrix2::new(a[(0, 0)], a[(0, 1)], a[(1, 0)], a[(1, 1)]).try_inverse()?
        * nalgebra::Vector2::new(z.x, z.y);
    Some(Vector3::new(d.x, d.y, 0.0))
}

impl<'a> Pass<'a> {
    pub fn new(
        layout: &'a StateLayout,
        settings: PassSettings,
        engine: Engine,
        nav: Strapdown,
        lin: Linearisation,
        angles: Option<AngleReader<'a>>,
    ) -> Self {
        // One slot per measurement instant, reserved once.
        let sched = &engine.schedule;
        let updates = settings.n_steps / sched.accel_interval.max(1)
            + angles
                .as_ref()
                .map_or(0, |_| settings.n_steps / sched.turntable_interval.max(1))
            + 2;
        let tau_sigma = layout.tau.map_or(0.0, |k| engine.filter.std_dev(k));
        Self {
            phase: engine.schedule.phase_of(1),
            tau_sigma,
            layout,
            settings,
            engine,
            nav,
            lin,
            angles,
            stats: FitStatistics::default(),
            rest_gate: None,
            window_at_rest: true,
            moved: false,
            nis_sum: (0.0, 0.0),
            expected_turntable_nis_sum: 0.0,
            innovations: Vec::with_capacity(updates),
            j: 0,
            prev_compensated: None,
            temp_delta: 0.0,
            prev_jacobian: None,
            state: vec![0.0; layout.dim()],
            prev_t: f64::NAN,
            held_out: Vec::new(),
            held_out_next: 0,
            turns: Vec::new(),
            turn_next: 0,
            turn_angle: 0.0,
            turn_h: vec![0.0; layout.dim()],
            turn_nis_sum: 0.0,
            turn_jac: vec![Vector3::zeros(); layout.n_instrument()],
        }
    }

    /// A step of a known turn: its compensated increment about the axis, and the gyro
    /// Jacobian's, into the turn under way; at its last record the measurement is queued
    /// (`z = angle - integrated`, `h = sum axis . J dt`: the state holds the parameters less
    /// their linearisation point, and the compensated increment is the raw one plus
    /// `nu(p) dt`).
    fn turn_step(&mut self, t: f64, dth: &Vector3<f64>, input: &SensorInput) {
        let Some(turn) = self.turns.get(self.turn_next) else {
            return;
        };
        let eps = 1e-9;
        if t < turn.t0 - eps {
            return;
        }
        let axis = turn.axis;
        self.turn_angle += axis.dot(dth);
        self.layout
            .model
            .jacobian(Sensor::Gyro, &self.lin.p, input, &mut self.turn_jac);
        let off = StateLayout::INSTRUMENT;
        for (i, j) in self.turn_jac.iter().enumerate() {
            self.turn_h[off + i] += axis.dot(j) * self.settings.dt;
        }
        if t >= turn.t1 - eps {
            let h = std::mem::replace(&mut self.turn_h, vec![0.0; self.layout.dim()]);
            self.engine
                .queue_parameter_measurement(crate::model::engine::ParameterMeasurement {
                    z: turn.angle_rad - self.turn_angle,
                    h,
                    variance: crate::motion::rests::TURN_SIGMA_RAD.powi(2),
                });
            self.turn_angle = 0.0;
            self.turn_next += 1;
        }
    }

    /// The motion over the interval before the first record, as the program says (body rate
    /// and specific force): the rate-derivative terms of the first step are differences to it.
    /// Without it a program that starts with the data (a jump of the rate inside the first
    /// interval) left its size-effect spike uncompensated (0.17 sigma in `accel.gamma.zz` on a
    /// noiseless run).
    pub fn set_motion_before(&mut self, omega_body: Vector3<f64>, f_body: Vector3<f64>) {
        self.prev_compensated = Some(CompensatedMeans { omega_body, f_body });
        self.prev_jacobian = Some((omega_body, f_body));
    }

    /// Process one IMU record (on `line` of its file).
    #[inline(always)]
    pub fn step(&mut self, rec: &ImuRecord, line: usize) -> Result<(), EstimateError> {
        self.j += 1;
        let phase = self.phase;
        self.phase = self.engine.schedule.next_phase(phase);
        let (dth, dv) = self.compensate(rec);
        let dt = self.settings.dt;
        let at_rest = self
            .rest_gate
            .as_mut()
            .is_some_and(|g| g.step_at_rest(rec.t, dt));
        let input = self.propagate(&dth, &dv, phase, at_rest);
        if self.turn_next < self.turns.len() {
            self.turn_step(rec.t, &dth, &input);
        }
        if self.angles.is_some() && self.engine.schedule.in_turntable_window_at(phase) {
            self.read_angles(rec.t, &input);
        }
        let last = self.j == self.settings.n_steps;
        let sched = &self.engine.schedule;
        if self.rest_gate.is_some() {
            if sched.in_accel_window_at(phase) && !at_rest {
                self.window_at_rest = false;
            }
            if (sched.accel_due_at(phase) || last) && !self.window_at_rest {
                // A window that saw motion is no measurement of the specific force at rest.
                self.engine.model.reset_accel();
                self.window_at_rest = true;
                self.stats.accel_windows_in_motion += 1;
                self.moved = true;
                if last {
                    self.engine
                        .predict_to_now()
                        .map_err(|source| EstimateError::Filter {
                            t: rec.t,
                            line,
                            source,
                        })?;
                }
                return Ok(());
            }
        }
        let sched = &self.engine.schedule;
        if !(last || sched.accel_due_at(phase) || sched.turntable_due_at(phase)) {
            return Ok(());
        }
        if !self.held_out.is_empty() {
            let t = rec.t;
            while self
                .held_out
                .get(self.held_out_next)
                .is_some_and(|&(_, t1)| t1 < t)
            {
                self.held_out_next += 1;
            }
            let on = self
                .held_out
                .get(self.held_out_next)
                .is_some_and(|&(t0, t1)| (t0..=t1).contains(&t));
            self.engine.set_holding_out(on);
        }
        if self.moved {
            self.moved = false;
            let sigma = self.settings.motion_attitude_noise_rad;
            if sigma > 0.0 {
                self.engine
                    .add_attitude_noise(sigma * sigma)
                    .map_err(|source| EstimateError::Filter {
                        t: rec.t,
                        line,
                        source,
                    })?;
            }
        }
        let report = self.measurement_instant(last);
        let report = report.map_err(|source| EstimateError::Filter {
            t: rec.t,
            line,
            source,
        })?;
        self.count(&report, rec.t);
        if let Some(k) = self.layout.tau {
            self.tau_sigma = self.engine.filter.std_dev(k);
        }
        let model = &self.engine.model;
        if (report.updated() || last) && !model.accel_open() && !model.turntable_open() {
            self.feed_back(report.accel_z.as_ref());
        }
        Ok(())
    }

    /// The engine's measurement instant at the current step. A rest's windows share an error
    /// of variance `v` (`rest_error_var`): each of its `m` windows is weighted as white noise
    /// plus `m v` (the equicorrelated block's information on what all its windows see alike is
    /// that of the rest's mean with variance white / m + v).
    fn measurement_instant(&mut self, last: bool) -> Result<InstantReport, kalman::KalmanError> {
        let white_psd = self.engine.noise.accel_psd;
        if self.settings.rest_error_var > 0.0
            && let Some(rest) = self.rest_gate.as_ref().and_then(RestGate::current)
        {
            let windows = ((rest.t1 - rest.t0) * self.settings.accel_rate_hz)
                .floor()
                .max(1.0);
            self.engine.noise.accel_psd +=
                windows * self.settings.rest_error_var / self.settings.accel_rate_hz;
        }
        let report =
            self.engine
                .measurement_instant(self.layout, self.j, &self.settings.f_enu, last);
        self.engine.noise.accel_psd = white_psd;
        report
    }

    /// The true increments of a record under the current parameter estimates.
    #[inline(always)]
    fn compensate(&mut self, rec: &ImuRecord) -> (Vector3<f64>, Vector3<f64>) {
        let (g, a) = (Vector3::from(rec.gyro), Vector3::from(rec.accel));
        let mut dt = self.settings.dt;
        if self.settings.own_intervals {
            let own = rec.t - self.prev_t;
            if own.is_finite() {
                dt = own;
            }
            self.prev_t = rec.t;
        }
        let (raw_dth, raw_dv) = match self.settings.kind {
            ImuKind::Increments => (g, a),
            ImuKind::Rates => (g * dt, a * dt),
        };
        self.temp_delta = match (rec.temp, self.settings.temp_reference_c) {
            (Some(t), Some(r)) => t - r,
            _ => 0.0,
        };
        let lin = &self.lin;
        lin.compensation.apply(
            &self.layout.model,
            &lin.p,
            &raw_dth,
            &raw_dv,
            dt,
            self.temp_delta,
            &mut self.prev_compensated,
        )
    }

    /// Strapdown step and the error model's sub-step; returns the step's mean rate and force.
    #[inline(always)]
    fn propagate(
        &mut self,
        dth: &Vector3<f64>,
        dv: &Vector3<f64>,
        phase: Phase,
        at_rest: bool,
    ) -> SensorInput {
        let step = self.nav.advance(dth, dv);
        // The error Jacobians take the specific force the unit is known to feel (gravity, turned
        // into the body by the computed attitude), not the measured one: the measured one
        // carries the same noise as the residual, and regressing the residual on it biased an
        // accelerometer scale factor whose axis lay near the horizontal by sigma^2 / f^2 (0.6
        // prior sigma on static runs).
        // The same for the rate inside a rest of a recording of rests: there the unit turns with
        // the Earth only, and the measured rate is mostly the gyro noise (a consumer unit's 600
        // deg/h per sample against 15 deg/h). A Jacobian in |omega| (the scale asymmetry) or
        // omega taken from it is then correlated with the innovations that noise drives: the
        // score test called for a scale asymmetry at p = 1e-13 .. 1e-20 on every clean
        // consumer-grade 19-position recording tried (seeds 4001, 4005, 4006).
        let inv_dt = self.settings.inv_dt;
        let omega_body = if at_rest {
            step.c_mid.transpose() * self.settings.u_enu
        } else {
            dth * inv_dt
        };
        let mut input = SensorInput {
            omega_body,
            f_body: step.c_mid.transpose() * self.settings.f_enu,
            temp_delta: self.temp_delta,
            ..SensorInput::default()
        };
        // The rate derivatives as the compensation takes them (differences to the step before),
        // the specific force's from the noise-free one the Jacobians take.
        if let Some((w, f)) = self.prev_jacobian.replace((input.omega_body, input.f_body)) {
            input.omega_dot_body = (input.omega_body - w) * inv_dt;
            input.f_dot_body = (input.f_body - f) * inv_dt;
        }
        let in_acc = self
            .engine
            .schedule
            .in_accel_window_at(phase)
            .then_some(&step.dv_enu);
        self.engine
            .model
            .substep(self.layout, &step.c_mid, &input, &self.lin.p, in_acc);
        input
    }

    /// A turntable-angle sample at the end of the step at IMU time `t`, unless it straddles a
    /// change of the platform rate ([`RateChanges`]).
    #[inline(always)]
    fn read_angles(&mut self, t: f64, input: &SensorInput) {
        let reader = self.angles.as_mut().expect("checked by the caller");
        let t_query = t + self.lin.tau;
        let Some(set) = reader.interp.at(t_query) else {
            self.stats.turntable_samples_missing += 1;
            return;
        };
        let dt = self.settings.dt;
        if reader.per_record {
            // The records hold the angles at their stamps less the delay. Sampling every IMU
            // step between sparse records interpolates each record into every sample of two
            // windows, whose noises the filter would take as independent (1-Hz records: NEES
            // 36.6 per run for 28 states); one sample per record, at the step nearest to the
            // time it holds, uses each record once.
            let held = [
                set.t_records_imu[0] - self.lin.tau,
                set.t_records_imu[1] - self.lin.tau,
            ];
            if !held
                .iter()
                .any(|c| (t - 0.5 * dt..t + 0.5 * dt).contains(c))
            {
                return;
            }
        }
        let band = 3.0 * self.tau_sigma + dt;
        // The two records hold the angles at their stamps less the delay: linear interpolation
        // between them is exact only where the program's rate is constant over that span (the
        // span of the stamps themselves is off by tau: at 1-Hz records and a 0.1-s delay that
        // let samples straddle the reversals, turntable mean NIS 39).
        let lo = t.min(set.t_records_imu[0] - self.lin.tau - band);
        let hi = t.max(set.t_records_imu[1] - self.lin.tau + band);
        let ps = reader.program_start;
        if !reader
            .rate_changes
            .clear_near(&mut reader.rate_change_hint, lo - ps, hi - ps)
        {
            self.stats.turntable_samples_near_rate_changes += 1;
            return;
        }
        let c = self.nav.c;
        let (c_platform, gimbal_jacobian) = gimbal_frame_sin_cos(&set.sin_cos);
        // Without a base misalignment state its rotation is the identity: one product fewer.
        let c_tt = match self.layout.base {
            Some(_) => self.lin.c_base * c_platform * self.lin.c_install,
            None => c_platform * self.lin.c_install,
        };
        self.engine.model.add_angle_sample(&AngleSample {
            y: attitude_error(&c, &c_tt),
            c_body_to_enu: c,
            platform_rate_enu: c * input.omega_body - self.settings.u_enu,
            gimbal_jacobian,
            records: &set.records,
        });
        self.stats.turntable_samples += 1;
    }

    /// Count the updates of a measurement instant at IMU time `t` and log their innovations.
    fn count(&mut self, report: &InstantReport, t: f64) {
        let held_out = self.engine.holding_out();
        let updates = [
            (MeasurementKind::Accel, &report.accel_update),
            (MeasurementKind::Turntable, &report.turntable_update),
        ];
        for (kind, u) in updates {
            if let Some(u) = u {
                self.innovations.push(Innovation {
                    t,
                    kind,
                    nu: u.nu,
                    s: u.s,
                    segment: 0,
                    held_out,
                    c_body_to_enu: Some(self.nav.c),
                });
            }
        }
        self.stats.turn_updates += report.parameter_updates;
        self.turn_nis_sum += report.parameter_nis_sum;
        // The statistics describe the updates made.
        if held_out {
            return;
        }
        if let Some(nis) = report.accel_nis {
            self.stats.accel_updates += 1;
            self.nis_sum.0 += nis;
        }
        if let Some(nis) = report.turntable_nis {
            self.stats.turntable_updates += 1;
            self.nis_sum.1 += nis;
            self.expected_turntable_nis_sum +=
                report.turntable_update.map_or(3.0, |u| u.expected_nis);
        }
    }

    /// Feedback (closed-loop pass): the attitude error into the attitude, every other error
    /// estimate into its total, and the filter state back to zero.
    ///
    /// Only a closed-loop pass feeds back. A pass linearised about the pass before keeps its
    /// trajectory: early in a run the filter's attitude estimate is still the prior's (a heading
    /// the data have not reached yet, degrees off when the unit sits degrees off its nominal
    /// mounting), and feeding it back would move the attitude away from the previous pass's
    /// estimate, which is already right (it did, by 1.3 sigma of a gyro misalignment on a
    /// noiseless run with a 120-s dwell before the program).
    fn feed_back(&mut self, accel_z: Option<&Vector3<f64>>) {
        let x = &mut self.state;
        match self.settings.feedback {
            Feedback::None => return,
            Feedback::Tilt => {
                self.engine.filter.state_into(x);
                let d = accel_z
                    .and_then(|z| level_rotation(&self.settings.f_enu, z))
                    .unwrap_or_else(|| Vector3::new(x[0], x[1], 0.0));
                self.nav.correct(&d);
                for k in 0..2 {
                    self.engine.filter.set_state(k, x[k] - d[k]);
                    x[k] = d[k];
                }
                self.engine.shadow_fed_back(x, 0..2);
                return;
            }
            Feedback::Attitude => {
                self.engine.filter.state_into(x);
                self.nav.correct(&Vector3::new(x[0], x[1], x[2]));
                for k in 0..3 {
                    self.engine.filter.set_state(k, 0.0);
                }
                self.engine.shadow_fed_back(x, 0..3);
                return;
            }
            Feedback::All => {}
        }
        self.engine.filter.state_into(x);
        self.nav.correct(&Vector3::new(x[0], x[1], x[2]));
        self.lin.absorb(self.layout, x);
        self.engine.filter.reset_state();
        // The copy of the start attitude error is estimated, not fed back anywhere.
        let copy = self.layout.start_attitude.map_or(0..0, |s| s..s + 3);
        for k in copy.clone() {
            self.engine.filter.set_state(k, x[k]);
        }
        self.engine
            .shadow_fed_back(x, (0..x.len()).filter(|k| !copy.contains(k)));
    }

    /// The pass's estimate of every state (totals, SI; the attitude errors fed back, so zero),
    /// the final attitude, the fit statistics, the covariance and the innovation log.
    pub fn finish(mut self) -> PassResult {
        // Whatever the last windows left in the state (they were still open at the end).
        let x = self.engine.filter.state();
        let c = exp_so3(&Vector3::new(x[0], x[1], x[2])) * self.nav.c;
        let mut values = x.clone();
        values[..3].fill(0.0);
        let mut lin = self.lin.clone();
        lin.absorb(self.layout, &x);
        let off = StateLayout::INSTRUMENT;
        values[off..off + lin.p.len()].copy_from_slice(&lin.p);
        let mut put3 = |k: Option<usize>, v: &Vector3<f64>| {
            if let Some(k) = k {
                values[k..k + 3].copy_from_slice(v.as_slice());
            }
        };
        put3(self.layout.install, &lin.delta);
        put3(self.layout.base, &lin.gamma);
        if let Some(k) = self.layout.tau {
            values[k] = lin.tau;
        }
        self.stats.imu_steps = self.j;
        self.stats.accel_mean_nis = self.nis_sum.0 / self.stats.accel_updates.max(1) as f64;
        self.stats.turntable_mean_nis = self.nis_sum.1 / self.stats.turntable_updates.max(1) as f64;
        self.stats.turntable_expected_nis = if self.stats.turntable_updates == 0 {
            3.0
        } else {
            self.expected_turntable_nis_sum / self.stats.turntable_updates as f64
        };
        self.stats.turn_mean_nis = self.turn_nis_sum / self.stats.turn_updates.max(1) as f64;
        let map = mounting_map(self.layout, &lin);
        let mut cov = self.engine.covariance();
        if let Some(t) = &map {
            cov = t * cov * t.transpose();
        }
        let offset_sensitivity = self.engine.offset_sensitivity.as_ref().map(|o| {
            let s = nalgebra::DMatrix::from_fn(o.s.nrows(), 3, |i, j| o.s[(i, j)]);
            match &map {
                Some(t) => t * s,
                None => s,
            }
        });
        PassResult {
            values,
            c,
            stats: self.stats,
            cov,
            innovations: self.innovations,
            offset_sensitivity,
        }
    }
}

/// What [`Pass::finish`] returns.
pub(super) struct PassResult {
    /// Every state's estimate (totals, SI).
    pub values: Vec<f64>,
    /// The final attitude (body to ENU).
    pub c: Matrix3<f64>,
    pub stats: FitStatistics,
    /// Covariance (SI, mounting in rotation-vector coordinates).
    pub cov: nalgebra::DMatrix<f64>,
    /// Every update in order (segment 0: the caller assigns them).
    pub innovations: Vec<Innovation>,
    /// When the pass carried it: the sensitivity of `values` to a constant offset of the
    /// specific-force residual (`n x 3`; [`crate::model::engine::OffsetSensitivity`], the mounting
    /// rows mapped as `cov`'s), its attitude rows that of the final attitude (`log(C' C^T)`).
    pub offset_sensitivity: Option<nalgebra::DMatrix<f64>>,
}

/// The filter's covariance of the mounting errors is that of small rotations about the
/// estimated mountings (body-frame for the installation, ENU for the base), but the result
/// reports the rotation vectors `delta_z` and `gamma_p` themselves. The two differ by
/// `delta_hat x e / 2` at first order: on a static run the installation heading stays at its
/// 1-degree prior while the tilt is known to microradians, and a 2-degree tilt turns that
/// heading uncertainty into 3e-4 rad of uncertainty in the tilt components of `delta_z` (the
/// filter's own covariance put the truth hundreds of sigmas away). Map it with the inverse
/// right (left) Jacobian: the map from the filter's mounting states to the rotation vectors
/// (`None` without mounting states), applied to the covariance and the offset sensitivity.
fn mounting_map(layout: &StateLayout, lin: &Linearisation) -> Option<nalgebra::DMatrix<f64>> {
    let n = layout.dim();
    let mut t = nalgebra::DMatrix::<f64>::identity(n, n);
    let blocks = [
        (layout.install, right_jacobian_inv(&lin.delta)),
        (layout.base, right_jacobian_inv(&-lin.gamma)),
    ];
    let mut any = false;
    for (k, j) in blocks {
        if let Some(k) = k {
            t.view_mut((k, k), (3, 3)).copy_from(&j);
            any = true;
        }
    }
    any.then_some(t)
}
