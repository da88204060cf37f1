//! The part of the filter loop that the covariance analysis and the estimation share: when
//! measurements are taken, which IMU steps their windows average, and the predict-update at a
//! measurement instant. The two differ only in where the attitude and the residuals come from
//! (the true motion, or the strapdown solution and the recorded data).

use crate::config::RunConfig;
use crate::model::layout::StateLayout;
use crate::model::{LinearModel, Measurement};
use faer::{Mat, MatRef};
use kalman::{KalmanError, KalmanFilter};
use nalgebra::{DMatrix, Matrix3, Vector3};
use turntable::program::Program;

/// Measurement instants and windows, in IMU steps (step `j` ends at `j * dt`, `j >= 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    /// Steps between specific-force measurements.
    pub accel_interval: usize,
    /// Steps averaged by one specific-force measurement (the last ones of its interval).
    pub accel_window: usize,
    /// Steps between turntable-angle measurements.
    pub turntable_interval: usize,
    /// Steps averaged by one turntable-angle measurement.
    pub turntable_window: usize,
}

impl Schedule {
    /// The schedule of a configuration.
    pub fn new(config: &RunConfig) -> Self {
        let accel_interval = config.accel_interval_steps();
        let turntable_interval = config.turntable_interval_steps();
        Self {
            accel_interval,
            accel_window: config.window_steps(accel_interval),
            turntable_interval,
            turntable_window: config.window_steps(turntable_interval),
        }
    }

    /// Where step `j` (from 1) falls in the two cycles.
    pub fn phase_of(&self, j: usize) -> Phase {
        Phase {
            accel: (j - 1) % self.accel_interval,
            turntable: (j - 1) % self.turntable_interval,
        }
    }

    /// The phase of the step after one at `p`.
    pub fn next_phase(&self, p: Phase) -> Phase {
        let wrap = |k: usize, n: usize| if k + 1 == n { 0 } else { k + 1 };
        Phase {
            accel: wrap(p.accel, self.accel_interval),
            turntable: wrap(p.turntable, self.turntable_interval),
        }
    }

    /// A step at phase `p` belongs to a specific-force window.
    pub fn in_accel_window_at(&self, p: Phase) -> bool {
        p.accel >= self.accel_interval - self.accel_window
    }

    /// A step at phase `p` belongs to a turntable-angle window.
    pub fn in_turntable_window_at(&self, p: Phase) -> bool {
        p.turntable >= self.turntable_interval - self.turntable_window
    }

    /// A specific-force measurement is taken at the end of a step at phase `p`.
    pub fn accel_due_at(&self, p: Phase) -> bool {
        p.accel + 1 == self.accel_interval
    }

    /// A turntable-angle measurement is taken at the end of a step at phase `p`.
    pub fn turntable_due_at(&self, p: Phase) -> bool {
        p.turntable + 1 == self.turntable_interval
    }

    /// Step `j` belongs to a specific-force window.
    pub fn in_accel_window(&self, j: usize) -> bool {
        self.in_accel_window_at(self.phase_of(j))
    }

    /// Step `j` belongs to a turntable-angle window.
    pub fn in_turntable_window(&self, j: usize) -> bool {
        self.in_turntable_window_at(self.phase_of(j))
    }

    /// A specific-force measurement is taken at the end of step `j`.
    pub fn accel_due(&self, j: usize) -> bool {
        self.accel_due_at(self.phase_of(j))
    }

    /// A turntable-angle measurement is taken at the end of step `j`.
    pub fn turntable_due(&self, j: usize) -> bool {
        self.turntable_due_at(self.phase_of(j))
    }
}

/// Where an IMU step falls in the two measurement cycles: `(j - 1) % interval` of each kind
/// for step `j`. A pass keeps it by counting ([`Schedule::next_phase`]), so that the schedule
/// costs no integer division at every IMU step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Phase {
    accel: usize,
    turntable: usize,
}

/// The instants at which the platform rate changes (segment boundaries of the program where
/// the gimbal rates differ on the two sides), in program time.
///
/// A turntable-angle sample compares the IMU attitude at `t` with the angles interpolated
/// between two records at `t + tau_hat`. Within one program piece the gimbal angles are linear in
/// time, so the linear interpolation is exact and the delay acts as `-Omega_x tau`. A sample is
/// left out only when the span it depends on (the IMU time `t`, the two records it is
/// interpolated from, and three sigma of the delay about `t + tau_hat`) contains a rate change:
/// there the angles are not `k(t) - k_dot tau`, and the error is the change of rate times the
/// time offset (with an unknown 0.044 s delay, 1e-2 rad at a reversal of the paper's program).
#[derive(Clone, Debug, PartialEq)]
pub struct RateChanges {
    /// Program times of the rate changes, increasing.
    times: Vec<f64>,
}

impl RateChanges {
    /// The rate changes of `program`, including its start and end when it moves there (the
    /// platform is taken to rest at the start angles before the program and at the end angles
    /// after it).
    pub fn new(program: &Program) -> Self {
        let mut times = Vec::new();
        let mut rate_before = [0.0; 3];
        let mut t_end = 0.0;
        for piece in program.pieces() {
            if piece.rate != rate_before {
                times.push(piece.t0);
            }
            rate_before = piece.rate;
            t_end = piece.t1;
        }
        if rate_before != [0.0; 3] {
            times.push(t_end);
        }
        Self { times }
    }

    /// The program times of the rate changes, increasing.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Whether the open program-time interval `(t0, t1)` is free of rate changes.
    pub fn clear(&self, t0: f64, t1: f64) -> bool {
        let k = self.times.partition_point(|&c| c <= t0);
        self.times.get(k).is_none_or(|&c| c >= t1)
    }

    /// [`Self::clear`] for intervals that move forward a little at a time (one per IMU step):
    /// `hint` holds the index of the first rate change after the last `t0` and is walked from
    /// there, in place of a binary search per step. Any `hint` gives the right answer.
    pub fn clear_near(&self, hint: &mut usize, t0: f64, t1: f64) -> bool {
        let mut k = (*hint).min(self.times.len());
        while k > 0 && self.times[k - 1] > t0 {
            k -= 1;
        }
        while k < self.times.len() && self.times[k] <= t0 {
            k += 1;
        }
        *hint = k;
        self.times.get(k).is_none_or(|&c| c >= t1)
    }
}

/// Noise levels of the measurements.
#[derive(Clone, Copy, Debug)]
pub struct MeasurementNoise {
    /// Accelerometer PSD ((m/s^2)^2 s).
    pub accel_psd: f64,
    /// Variance of one angle record, each gimbal (rad^2); `None` without turntable angles.
    pub angle_var_per_record: Option<f64>,
}

/// One measurement update as the filter saw it: the innovation, its covariance and the NIS.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateRecord {
    /// Normalised innovation squared `nu^T S^-1 nu`.
    pub nis: f64,
    /// `ln det S`.
    pub log_det_s: f64,
    /// Innovation `nu = z - H x_prior` (measurement units: m/s^2 or rad).
    pub nu: Vector3<f64>,
    /// Innovation covariance `S = H P_prior H^T + R`.
    pub s: Matrix3<f64>,
    /// What the NIS averages when the model fits: `3 - tr(S^-1 R_shared)`, 3 less the share
    /// of `S` that is the covariance with the measurement before
    /// ([`crate::model::Measurement::r_shared`]), which the innovation's own scatter lacks.
    /// With 50-Hz angle records and 1-s windows that share is about 1 % of `S` (0.026 of
    /// the turntable NIS over the paper's program repeated to 10 h, seed 1), invisible
    /// against the band of a 45-min run (0.14) but two thirds of a 10-h run's (0.039).
    pub expected_nis: f64,
}

/// A scalar measurement of the error state's parameters alone, `z = h x + v`, `v` of variance
/// `variance` (a known turn: `z` the expected angle less the integrated one, `h` the integrated
/// gyro Jacobian about the axis).
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterMeasurement {
    /// The measurement.
    pub z: f64,
    /// Its row of `H` (the state's length; entries past its end are 0).
    pub h: Vec<f64>,
    /// Variance of its noise.
    pub variance: f64,
}

/// What happened at a measurement instant.
#[derive(Clone, Copy, Debug, Default)]
pub struct InstantReport {
    /// The queued parameter measurements made at this instant
    /// ([`Engine::queue_parameter_measurement`]).
    pub parameter_updates: usize,
    /// Their normalised innovations squared, summed (1 degree of freedom each).
    pub parameter_nis_sum: f64,
    /// Normalised innovation squared of the specific-force update (3 degrees of freedom).
    pub accel_nis: Option<f64>,
    /// Normalised innovation squared of the turntable update.
    pub turntable_nis: Option<f64>,
    /// The specific-force update in full (estimation only).
    pub accel_update: Option<UpdateRecord>,
    /// The turntable update in full (estimation only).
    pub turntable_update: Option<UpdateRecord>,
    /// The specific-force measurement of the update, `z = mean(f'_x) - f_x` (ENU, m/s^2), when
    /// one was made on the filter itself (not held out): what a recording of rests re-levels its
    /// trajectory to ([`crate::estimate`]).
    pub accel_z: Option<Vector3<f64>>,
}

impl InstantReport {
    /// Whether any update was made.
    pub fn updated(&self) -> bool {
        self.accel_nis.is_some() || self.turntable_nis.is_some() || self.parameter_updates > 0
    }
}

/// The filter of a calibration: zero initial state, prior covariance `p0` (SI; the filter
/// works on the states divided by their prior sigma), measurements of 3 components.
pub fn prior_filter(p0: &DMatrix<f64>) -> Result<KalmanFilter, KalmanError> {
    let (n, p0) = (
        p0.nrows(),
        MatRef::from_column_major_slice(p0.as_slice(), p0.nrows(), p0.ncols()),
    );
    KalmanFilter::new(&vec![0.0; n], p0, 3)
}

/// The sensitivity `S = dx/d delta` (`n x 3`, SI) of the filter's state estimate to a constant
/// offset `delta` added to every specific-force residual, carried through the pass beside the
/// estimate: `S <- Phi S` at a predict, `S <- S + K (D - H S)` at an update whose residual
/// holds the offset with derivative `D`, `S <- S - K H S` at any other update of the main
/// filter. It is the consider sensitivity of [`crate::estimate`]'s second-order
/// specific-force error: the response the estimate would show if the pass were run again with
/// the offset (which is what was done before, one pass per direction: two of the five passes
/// of a consumer-grade recording of rests).
///
/// A feedback does not change it: the fed-back amount leaves the state and enters the
/// trajectory, and `S` is the sensitivity of their sum (the total), which the fed-back
/// trajectory carries as the transition carries the state (to first order, as the pass run
/// again saw it).
#[derive(Debug, Clone)]
pub struct OffsetSensitivity {
    /// `dx/d delta` (`n x 3`, SI).
    pub s: Mat<f64>,
    /// Scratch: `Phi_top S` (`n x 3`, the top rows used).
    top: Mat<f64>,
    /// Scratch: `D - H S` (`m_max x 3`).
    rhs: Mat<f64>,
    /// Scratch: `K (D - H S)` (`n x 3`).
    k_rhs: Mat<f64>,
}

impl OffsetSensitivity {
    /// Zero sensitivity (the prior does not hold the offset) for `n` states and measurements
    /// of up to `m_max` components.
    pub fn new(n: usize, m_max: usize) -> Self {
        Self {
            s: Mat::zeros(n, 3),
            top: Mat::zeros(n, 3),
            rhs: Mat::zeros(m_max, 3),
            k_rhs: Mat::zeros(n, 3),
        }
    }

    /// `S <- Phi S` for `Phi` the identity but its top rows `phi_top` (`k x n`).
    fn predict(&mut self, phi_top: MatRef<'_, f64>) {
        let (k, n) = (phi_top.nrows(), phi_top.ncols());
        for c in 0..3 {
            for i in 0..k {
                let mut v = 0.0;
                for j in 0..n {
                    v += phi_top[(i, j)] * self.s[(j, c)];
                }
                self.top[(i, c)] = v;
            }
        }
        for c in 0..3 {
            for i in 0..k {
                self.s[(i, c)] = self.top[(i, c)];
            }
        }
    }

    /// `S <- S + K (D - H S)` after `filter`'s update with `h` (`m x n`); `d`: `None` for a
    /// measurement that does not hold the offset (`D = 0`).
    fn update(&mut self, filter: &KalmanFilter, h: MatRef<'_, f64>, d: Option<&Matrix3<f64>>) {
        let (m, n) = (h.nrows(), h.ncols());
        for c in 0..3 {
            for a in 0..m {
                let mut v = d.map_or(0.0, |d| d[(a, c)]);
                for j in 0..n {
                    v -= h[(a, j)] * self.s[(j, c)];
                }
                self.rhs[(a, c)] = v;
            }
        }
        filter.gain_times(self.rhs.as_mut().subrows_mut(0, m), self.k_rhs.as_mut());
        for c in 0..3 {
            for i in 0..n {
                self.s[(i, c)] += self.k_rhs[(i, c)];
            }
        }
    }
}

/// The filter and the linear model between its instants: what the covariance analysis and the
/// estimation run alike. The caller integrates IMU steps into [`Engine::model`] and calls
/// [`Engine::measurement_instant`] at the end of every step.
#[derive(Debug)]
pub struct Engine {
    /// The Kalman filter (normalised inside, SI outside).
    pub filter: KalmanFilter,
    /// The sensitivity of the state estimate to a constant offset of the specific-force
    /// residual, when asked for ([`OffsetSensitivity`]).
    pub offset_sensitivity: Option<OffsetSensitivity>,
    /// Transition and measurement windows since the last filter instant.
    pub model: LinearModel,
    /// When measurements are taken.
    pub schedule: Schedule,
    /// Their noise.
    pub noise: MeasurementNoise,
    /// Residuals ignored (covariance analysis).
    covariance_only: bool,
    /// Sum of `ln det S` over the covariance-only updates so far: the log-determinant of the
    /// covariance of every measurement of the run (prior included), by the innovations'
    /// factorisation of the data's likelihood.
    pub log_det_data: f64,
    /// While measurements are held out ([`Engine::set_holding_out`]): a copy of the filter
    /// taken when the held-out stretch began, updated with the held-out measurements (each
    /// innovation predicted from the data before the stretch and the stretch's earlier
    /// measurements); the filter itself only predicts through the stretch.
    shadow: Option<KalmanFilter>,
    /// Scalar measurements of the parameters alone (known turns), made at the next
    /// measurement instant right after its predict: the parameters are constant, so the
    /// instant does not matter, and an update between instants would come before the
    /// transition still being accumulated.
    pending: Vec<ParameterMeasurement>,
    /// Take the vertical row of the specific-force measurement to second order in the tilt:
    /// `z_z + |z_h|^2 / (2 g)`, the tilt's own share of the vertical (`g cos|beta_h| - g`)
    /// removed with the tilt the window's horizontal components show. On a recording of rests
    /// the first window after a hand turn finds the attitude degrees off, and the linear row
    /// read that as a vertical misfit: on the shipped Xsens recording those windows had a mean
    /// NIS of 55 (the rest of the windows 5.6), and 13 without the correction once the noise was
    /// fitted; 6.6 with it ([`crate::estimate::hand_turned`]). Where the tilt is small (a program, whose
    /// trajectory knows it) the term is nothing.
    pub vertical_second_order: bool,
    /// Scratch for the measurement noise as a faer matrix.
    r: Mat<f64>,
    /// Scratch for the cross-covariance of the state's error and the measurement noise
    /// (`n x 3`; only the attitude rows are ever non-zero).
    cross: Mat<f64>,
}

impl Engine {
    /// An engine with prior covariance `p0` (SI, zero mean).
    pub fn new(
        filter: KalmanFilter,
        model: LinearModel,
        schedule: Schedule,
        noise: MeasurementNoise,
        covariance_only: bool,
    ) -> Self {
        let n = filter.dim();
        Self {
            filter,
            offset_sensitivity: None,
            model,
            schedule,
            noise,
            covariance_only,
            log_det_data: 0.0,
            shadow: None,
            pending: Vec::new(),
            vertical_second_order: false,
            r: Mat::zeros(3, 3),
            cross: Mat::zeros(n, 3),
        }
    }

    /// Hold out the measurements from now on (`true`) or use them again (`false`). A held-out
    /// stretch's measurements inform nothing that follows it: the filter predicts through the
    /// stretch without them, and their innovations (and so their log predictive density, which
    /// by the chain rule is that of the whole stretch given the data before it) come from a
    /// copy of the filter taken when the stretch began and updated within it only. Allocates
    /// the copy once per stretch.
    pub fn set_holding_out(&mut self, on: bool) {
        match (on, self.shadow.is_some()) {
            (true, false) => self.shadow = Some(self.filter.clone()),
            (false, true) => self.shadow = None,
            _ => {}
        }
    }

    /// A feedback made while measurements are held out: the main filter's states `indices`,
    /// whose values were `fed`, went into the trajectory. The held-out copy predicts along
    /// the same trajectory, so its states move by the same amounts; left alone they count the
    /// fed-back error twice (the copy's first innovation after a tilt fed back was off by that
    /// tilt: held-out NIS in the tens of thousands on the shipped Xsens recording).
    pub fn shadow_fed_back(&mut self, fed: &[f64], indices: impl Iterator<Item = usize>) {
        if let Some(shadow) = &mut self.shadow {
            let x = shadow.state();
            for k in indices {
                shadow.set_state(k, x[k] - fed[k]);
            }
        }
    }

    /// Queue a scalar measurement of the parameters ([`ParameterMeasurement`]), made at the
    /// next measurement instant (or [`Engine::predict_to_now`]), after any queued before it.
    pub fn queue_parameter_measurement(&mut self, m: ParameterMeasurement) {
        self.pending.push(m);
    }

    /// The queued parameter measurements, made on the main filter (never held out: they are no
    /// segment's); how many, and the sum of their NIS.
    fn parameter_update(&mut self) -> Result<(usize, f64), KalmanError> {
        let n = self.filter.dim();
        let count = self.pending.len();
        let mut nis = 0.0;
        for m in std::mem::take(&mut self.pending) {
            let h = Mat::from_fn(1, n, |_, j| m.h.get(j).copied().unwrap_or(0.0));
            let r = Mat::from_fn(1, 1, |_, _| m.variance);
            nis += self.filter.update(&[m.z], h.as_ref(), r.as_ref())?.nis;
            if let Some(sens) = &mut self.offset_sensitivity {
                sens.update(&self.filter, h.as_ref(), None);
            }
            // The held-out copy is the main filter with the held-out measurements: it gets
            // this one too.
            if let Some(shadow) = &mut self.shadow {
                shadow.update(&[m.z], h.as_ref(), r.as_ref())?;
            }
        }
        Ok((count, nis))
    }

    /// Add white noise of variance `var` (rad^2) to each axis of the attitude error (the first
    /// three states) now.
    pub fn add_attitude_noise(&mut self, var: f64) -> Result<(), KalmanError> {
        let n = self.filter.dim();
        let phi = Mat::from_fn(3, n, |i, j| if i == j { 1.0 } else { 0.0 });
        let q = Mat::from_fn(3, 3, |i, j| if i == j { var } else { 0.0 });
        self.filter.predict(phi.as_ref(), q.as_ref())?;
        if let Some(shadow) = &mut self.shadow {
            shadow.predict(phi.as_ref(), q.as_ref())?;
        }
        Ok(())
    }

    /// Whether measurements are held out now.
    pub fn holding_out(&self) -> bool {
        self.shadow.is_some()
    }

    /// The filter's covariance (SI).
    pub fn covariance(&self) -> DMatrix<f64> {
        let p = self.filter.covariance();
        DMatrix::from_fn(p.nrows(), p.ncols(), |i, j| p[(i, j)])
    }

    /// At the end of step `j`: if a measurement is due, close its window, predict to now and
    /// update. `f_enu` is the true specific force in ENU. With `close_all` (the last step of the
    /// data) every open window is closed and used.
    pub fn measurement_instant(
        &mut self,
        layout: &StateLayout,
        j: usize,
        f_enu: &Vector3<f64>,
        close_all: bool,
    ) -> Result<InstantReport, KalmanError> {
        let (schedule, model) = (&self.schedule, &mut self.model);
        let accel_due = schedule.accel_due(j) || (close_all && model.accel_open());
        let tt_due = self.noise.angle_var_per_record.is_some()
            && (schedule.turntable_due(j) || (close_all && model.turntable_open()));
        let mut report = InstantReport::default();
        if !accel_due && !tt_due {
            return Ok(report);
        }
        let acc = if accel_due {
            let m = model.accel_measurement(f_enu, self.noise.accel_psd);
            model.reset_accel();
            m
        } else {
            None
        };
        let tt = match (tt_due, self.noise.angle_var_per_record) {
            (true, Some(var)) => {
                let m = model.turntable_measurement(layout, var);
                model.reset_turntable();
                m
            }
            _ => None,
        };
        self.predict_now()?;
        (report.parameter_updates, report.parameter_nis_sum) = self.parameter_update()?;
        // How the residual taken responds to an offset of the window's mean residual: one,
        // and in the vertical row of the second-order correction its derivative.
        let mut d_offset = Matrix3::identity();
        let acc = acc.map(|mut m| {
            if self.vertical_second_order && f_enu.z != 0.0 {
                d_offset[(2, 0)] = m.z.x / f_enu.z;
                d_offset[(2, 1)] = m.z.y / f_enu.z;
                m.z.z += (m.z.x * m.z.x + m.z.y * m.z.y) / (2.0 * f_enu.z);
            }
            m
        });
        if let Some(m) = &acc {
            if self.shadow.is_none() {
                report.accel_z = Some(m.z);
            }
            report.accel_update = self.update(m, Some(&d_offset))?;
            report.accel_nis = report.accel_update.map(|u| u.nis);
        }
        if let Some(m) = &tt {
            report.turntable_update = self.update(m, None)?;
            report.turntable_nis = report.turntable_update.map(|u| u.nis);
        }
        Ok(report)
    }

    /// Predict to the end of the last step without an update (the end of a recording whose
    /// last window was not used).
    pub fn predict_to_now(&mut self) -> Result<(), KalmanError> {
        self.predict_now()?;
        self.parameter_update()?;
        Ok(())
    }

    /// The time update over the steps since the last one: of the filter and of what rides
    /// along with it (the held-out shadow, the offset sensitivity); in a covariance analysis, of
    /// the covariance alone.
    fn predict_now(&mut self) -> Result<(), KalmanError> {
        let (phi, q) = self.model.transition();
        if self.covariance_only {
            self.filter.predict_covariance(phi, q)?;
        } else {
            self.filter.predict(phi, q)?;
            if let Some(shadow) = &mut self.shadow {
                shadow.predict(phi, q)?;
            }
            if let Some(sens) = &mut self.offset_sensitivity {
                sens.predict(phi);
            }
        }
        self.model.reset_transition();
        Ok(())
    }

    /// The update with `m`; in an estimation, with the innovation and its covariance (copied
    /// from the filter, nothing allocated). `d_offset` is the residual's derivative by the
    /// offset of [`OffsetSensitivity`] (`None`: the residual does not hold it).
    fn update(
        &mut self,
        m: &Measurement,
        d_offset: Option<&Matrix3<f64>>,
    ) -> Result<Option<UpdateRecord>, KalmanError> {
        for i in 0..3 {
            for k in 0..3 {
                self.r[(i, k)] = m.r[(i, k)];
                self.cross[(i, k)] = m.cross_beta[(i, k)];
            }
        }
        let h = self.model.h(m.kind);
        let (r, cross) = (self.r.as_ref(), self.cross.as_ref());
        if self.covariance_only {
            self.log_det_data += self.filter.update_covariance_correlated(h, r, cross)?;
            Ok(None)
        } else {
            let filter = self.shadow.as_mut().unwrap_or(&mut self.filter);
            let info = filter.update_correlated(m.z.as_slice(), h, r, cross)?;
            let (nu, s) = (filter.innovation(), filter.innovation_covariance());
            let s = Matrix3::from_fn(|i, k| {
                if i < s.nrows() && k < s.ncols() {
                    s[(i, k)]
                } else {
                    f64::NAN
                }
            });
            let expected_nis = if m.r_shared == Matrix3::zeros() {
                3.0
            } else {
                // tr(S^-1 R_shared) by a solve (S is symmetric positive definite).
                let shared = s
                    .cholesky()
                    .map_or(Matrix3::zeros(), |c| c.solve(&m.r_shared));
                3.0 - shared.trace()
            };
            let record = UpdateRecord {
                nis: info.nis,
                log_det_s: info.log_det_s,
                nu: Vector3::from_fn(|i, _| nu.get(i).copied().unwrap_or(f64::NAN)),
                s,
                expected_nis,
            };
            // Only the main filter's estimate is the result's (a held-out update is made on
            // the copy alone).
            if let (Some(sens), None) = (&mut self.offset_sensitivity, &self.shadow) {
                sens.update(&self.filter, h, d_offset);
            }
            Ok(Some(record))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Uniform};

    /// The carried sensitivity is the derivative of the filter's estimate by the offset: the
    /// same predicts and updates (plain, correlated, some without the offset) run again with
    /// the residuals offset by `eps D c` move the state by `eps S c`, column by column.
    #[test]
    fn the_offset_sensitivity_is_the_estimate_s_derivative() {
        let (n, k) = (9, 3);
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let unit = Uniform::new(-1.0, 1.0).expect("a valid range");
        let mut r = |s: f64| s * unit.sample(&mut rng);
        // A fixed sequence: (phi_top, q_top), then (z, H, R, cross, D or none).
        type Step = (
            Mat<f64>,
            Mat<f64>,
            Vec<f64>,
            Mat<f64>,
            Mat<f64>,
            Mat<f64>,
            Option<Matrix3<f64>>,
        );
        let steps: Vec<Step> = (0..12)
            .map(|i| {
                let phi = Mat::from_fn(k, n, |a, j| f64::from(a == j) + r(0.2));
                let q = Mat::from_fn(k, k, |a, b| if a == b { 0.01 } else { 0.0 });
                let m = if i % 4 == 3 { 1 } else { 3 };
                let z: Vec<f64> = (0..m).map(|_| r(1.0)).collect();
                let h = Mat::from_fn(m, n, |_, _| r(1.0));
                let rr = Mat::from_fn(m, m, |a, b| if a == b { 0.5 } else { 0.0 });
                let cross = Mat::from_fn(n, m, |i, _| if i < k { r(0.05) } else { 0.0 });
                let d = (m == 3 && i % 3 != 2)
                    .then(|| Matrix3::from_fn(|a, b| f64::from(a == b) + r(0.3)));
                (phi, q, z, h, rr, cross, d)
            })
            .collect();
        let run = |offset: &Vector3<f64>, sens: Option<&mut OffsetSensitivity>| {
            let p0 = Mat::from_fn(n, n, |i, j| if i == j { 1.0 + i as f64 } else { 0.0 });
            let mut f = KalmanFilter::new(&vec![0.0; n], p0.as_ref(), 3).unwrap();
            let mut sens = sens;
            for (phi, q, z, h, rr, cross, d) in &steps {
                f.predict(phi.as_ref(), q.as_ref()).unwrap();
                if let Some(s) = sens.as_deref_mut() {
                    s.predict(phi.as_ref());
                }
                let mut z = z.clone();
                if let Some(d) = d {
                    let dz = d * offset;
                    for (a, v) in z.iter_mut().enumerate() {
                        *v += dz[a];
                    }
                }
                f.update_correlated(&z, h.as_ref(), rr.as_ref(), cross.as_ref())
                    .unwrap();
                if let Some(s) = sens.as_deref_mut() {
                    s.update(&f, h.as_ref(), d.as_ref());
                }
            }
            f.state()
        };
        let mut sens = OffsetSensitivity::new(n, 3);
        let base = run(&Vector3::zeros(), Some(&mut sens));
        let eps = 1e-6;
        for c in 0..3 {
            let shifted = run(&(Vector3::ith(c, eps)), None);
            for i in 0..n {
                let fd = (shifted[i] - base[i]) / eps;
                assert!(
                    (fd - sens.s[(i, c)]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "state {i}, offset {c}: finite difference {fd}, carried {}",
                    sens.s[(i, c)]
                );
            }
        }
        assert!(sens.s.norm_l2() > 0.1, "the offset moved the estimate");
    }

    #[test]
    fn the_walked_rate_change_search_answers_as_the_binary_one() {
        let rc = RateChanges {
            times: vec![1.0, 2.0, 2.0, 3.5, 7.0],
        };
        let mut hint = 0;
        for i in 0..400 {
            // Forward in small steps, with jumps back and forth now and then.
            let t0 = 0.025 * i as f64 - if i % 37 == 0 { 3.0 } else { 0.0 };
            for len in [0.0, 0.01, 0.5, 2.0] {
                for start_hint in [hint, 0, 99] {
                    let mut h = start_hint;
                    assert_eq!(rc.clear_near(&mut h, t0, t0 + len), rc.clear(t0, t0 + len));
                }
            }
            rc.clear_near(&mut hint, t0, t0 + 0.1);
        }
    }

    #[test]
    fn windows_end_at_their_measurement_instants() {
        let s = Schedule {
            accel_interval: 16,
            accel_window: 4,
            turntable_interval: 2,
            turntable_window: 2,
        };
        let acc: Vec<usize> = (1..=32).filter(|&j| s.in_accel_window(j)).collect();
        assert_eq!(acc, vec![13, 14, 15, 16, 29, 30, 31, 32]);
        assert!(s.accel_due(16) && !s.accel_due(15));
        assert!((1..=8).all(|j| s.in_turntable_window(j)));
        // Counting gives the phases the divisions give.
        let mut p = s.phase_of(1);
        for j in 1..200 {
            assert_eq!(p, s.phase_of(j));
            p = s.next_phase(p);
        }
    }
}
