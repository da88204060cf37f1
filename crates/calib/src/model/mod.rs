//! The linear error model the filter runs on, built from IMU-rate samples.
//!
//! Between two filter instants the attitude error obeys `d(beta)/dt = beta x u + C nu(p)`, and
//! every other state is constant. [`LinearModel::substep`] integrates this over one IMU interval
//! (midpoint rule for `C nu`, exact rotation for `beta x u`) into the first three rows of the
//! transition matrix, `phi_top = [Phi_bb | Phi_bp]`, and the attitude process noise `q_top`.
//!
//! Measurements (x = ENU frame) average their window of IMU steps, and `beta` moves within a
//! window (a 1e-3 scale error at 10 deg/s moves it by 1.7e-4 rad/s, as much as the noise of a
//! one-second measurement), so every measurement matrix carries the window mean of `beta`,
//! expressed in the state at the measurement instant through the transition of each sample
//! ([`PhiMean`]):
//! - specific force: `z = mean(f'_x) - f_x = f_x x mean(beta) + mean(C df)`, noise variance
//!   `psd_a / T` per axis for a window of length `T`;
//! - turntable angles, as the small rotation `y` with `C_imu * C_tt^T = exp(-skew(y))`:
//!   `y = beta - gamma_p - C delta_z - Omega_x tau + J rho` at each sample, averaged over the
//!   window; `J` is the gimbal Jacobian and `rho` the angle-sensor noise, which reaches a sample
//!   through the interpolation weights of the records it was interpolated from.
//!
//! The window mean of `beta` is not a function of the state at the instant alone: the gyro
//! white noise `n_i` of each step moves `beta` after the samples before it, so that
//! `mean(beta) = (the above) - sum_i c_i n_i`, `c_i` the share of the window's weight before
//! step `i` ([`WindowNoise`]). That part is measurement noise (variance `sum c_i^2 q_i` per
//! axis) correlated with the state's error, which holds every `n_i` (cross-covariance
//! `-sum c_i q_i` on the attitude rows). Left out, the filter counts the window's gyro noise
//! in full against a measurement that sees only part of it: on a MEMS unit (120 deg/h in a 1-s
//! average, ten times the accelerometer noise in tilt) the mean NIS of the specific force came out
//! 2.2-2.7 for 3 and the NEES 71 per run for 24 states (tests/tests/rests.rs, consumer grade).

pub mod correction;
pub mod engine;
pub mod extension;
pub mod layout;

use crate::model::layout::StateLayout;
use faer::{Mat, MatRef};
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::errors;
use sins_model::terms::{AxisJacobian, Sensor, SensorInput};

/// The columns of `phi_top` that can be non-zero (the layout's dynamic columns, in order), held
/// as three rows of consecutive values: the others are always zero and are not stored, and the
/// work at every IMU step (the Earth-rate rotation, the window sums) is a loop over contiguous
/// slices with no index list. (Measured: about as fast as one 3-vector per column; the change
/// was kept for the smaller state, not for speed.)
#[derive(Clone, Debug, PartialEq)]
struct DynamicRows {
    /// Row 0, row 1, row 2, each `len` long.
    v: Vec<f64>,
    len: usize,
}

impl DynamicRows {
    fn zeros(len: usize) -> Self {
        Self {
            v: vec![0.0; 3 * len],
            len,
        }
    }

    fn rows(&self) -> [&[f64]; 3] {
        let (r0, rest) = self.v.split_at(self.len);
        let (r1, r2) = rest.split_at(self.len);
        [r0, r1, r2]
    }

    fn rows_mut(&mut self) -> [&mut [f64]; 3] {
        let (r0, rest) = self.v.split_at_mut(self.len);
        let (r1, r2) = rest.split_at_mut(self.len);
        [r0, r1, r2]
    }

    fn col(&self, c: usize) -> Vector3<f64> {
        Vector3::new(self.v[c], self.v[self.len + c], self.v[2 * self.len + c])
    }

    /// Entry `(row, c)`.
    fn at_mut(&mut self, row: usize, c: usize) -> &mut f64 {
        &mut self.v[row * self.len + c]
    }

    fn set_col(&mut self, c: usize, x: &Vector3<f64>) {
        for (i, x) in x.iter().enumerate() {
            self.v[i * self.len + c] = *x;
        }
    }

    /// `self = a * self`.
    fn rotate(&mut self, a: &Matrix3<f64>) {
        let [r0, r1, r2] = self.rows_mut();
        for ((x, y), z) in r0.iter_mut().zip(r1.iter_mut()).zip(r2.iter_mut()) {
            let (x0, y0, z0) = (*x, *y, *z);
            *x = a[(0, 0)] * x0 + a[(0, 1)] * y0 + a[(0, 2)] * z0;
            *y = a[(1, 0)] * x0 + a[(1, 1)] * y0 + a[(1, 2)] * z0;
            *z = a[(2, 0)] * x0 + a[(2, 1)] * y0 + a[(2, 2)] * z0;
        }
    }

    /// `self += w * other`.
    fn add_scaled(&mut self, other: &DynamicRows, w: f64) {
        for (s, o) in self.v.iter_mut().zip(&other.v) {
            *s += o * w;
        }
    }

    /// Add `m * J` for a Jacobian in axis-column form whose columns are given by their index
    /// here (`(column, axis, feature slot)`).
    fn add_axis_product(
        &mut self,
        columns: &[(usize, usize, usize)],
        m: &Matrix3<f64>,
        f: &[f64; sins_model::terms::N_FEATURES],
    ) {
        let [r0, r1, r2] = self.rows_mut();
        for &(c, axis, slot) in columns {
            let x = f[slot];
            r0[c] += m[(0, axis)] * x;
            r1[c] += m[(1, axis)] * x;
            r2[c] += m[(2, axis)] * x;
        }
    }
}

/// Weighted sum of `phi_top` over the sample instants of a measurement window, kept relative to
/// the last filter instant and re-expressed at every predict (`PhiMean::rebase`).
#[derive(Clone, Debug)]
pub struct PhiMean {
    sum: DynamicRows,
    /// Space for the re-expressed sum (no allocation per predict).
    spare: DynamicRows,
    weight: f64,
}

impl PhiMean {
    fn new(n_dynamic: usize) -> Self {
        Self {
            sum: DynamicRows::zeros(n_dynamic),
            spare: DynamicRows::zeros(n_dynamic),
            weight: 0.0,
        }
    }

    fn clear(&mut self) {
        self.sum.v.fill(0.0);
        self.weight = 0.0;
    }

    /// Add `w` times `phi`.
    fn add(&mut self, phi: &DynamicRows, w: f64) {
        self.sum.add_scaled(phi, w);
        self.weight += w;
    }

    /// The sum in terms of the state at the end of `phi_end` (the transition from the last
    /// filter instant): with `phi_end = [A | B]` and `x_0 = [A^T (beta_end - B p); p]`,
    /// `sum [A_i | B_i] x_0 = [S_A A^T | S_B - S_A A^T B] x_end` (A is a rotation).
    fn expressed_at(&self, phi_end: &DynamicRows, out: &mut DynamicRows) {
        Self::express(&self.sum, phi_end, out);
    }

    fn express(sum: &DynamicRows, phi_end: &DynamicRows, out: &mut DynamicRows) {
        let col3 = |r: &DynamicRows| Matrix3::from_columns(&[r.col(0), r.col(1), r.col(2)]);
        let m = col3(sum) * col3(phi_end).transpose();
        for i in 0..3 {
            out.set_col(i, &m.column(i).into_owned());
        }
        for c in 3..sum.len {
            out.set_col(c, &(sum.col(c) - m * phi_end.col(c)));
        }
    }

    /// Re-express the sum in the state at the end of `phi_end` (called before a predict).
    fn rebase(&mut self, phi_end: &DynamicRows) {
        Self::express(&self.sum, phi_end, &mut self.spare);
        std::mem::swap(&mut self.sum, &mut self.spare);
    }
}

/// The gyro white noise of a measurement window's steps as the window mean of `beta` sees it:
/// `sum q_i w_i` and `sum q_i w_i^2`, with `q_i` the noise variance of step `i` and `w_i` the
/// window's weight of the samples before it (divided by the total weight at the end: `c_i`).
/// The Earth-rate rotation of the noise within one window (7e-5 rad over 1 s) is neglected.
#[derive(Clone, Copy, Debug, Default)]
pub struct WindowNoise {
    q_w: f64,
    q_w2: f64,
}

impl WindowNoise {
    fn add(&mut self, q: f64, weight_before: f64) {
        self.q_w += q * weight_before;
        self.q_w2 += q * weight_before * weight_before;
    }

    /// `(sum c_i q_i, sum c_i^2 q_i)` for a window of total weight `total`.
    pub fn moments(&self, total: f64) -> (f64, f64) {
        (self.q_w / total, self.q_w2 / (total * total))
    }
}

/// Accumulators of the specific-force measurement window.
#[derive(Clone, Debug)]
struct AccelWindow {
    beta: PhiMean,
    /// The gyro noise of the window's steps ([`WindowNoise`]).
    noise: WindowNoise,
    /// `sum C dDf/dp dt` over the window (instrument parameters).
    c_jac: Vec<Vector3<f64>>,
    /// `sum C f' dt`: the measured velocity increment in ENU (estimation only).
    dv_enu: Vector3<f64>,
    /// Window length (s).
    t: f64,
}

impl AccelWindow {
    /// An empty window over `nd` dynamic columns and `n_instr` instrument parameters.
    fn new(nd: usize, n_instr: usize) -> Self {
        Self {
            beta: PhiMean::new(nd),
            noise: WindowNoise::default(),
            c_jac: vec![Vector3::zeros(); n_instr],
            dv_enu: Vector3::zeros(),
            t: 0.0,
        }
    }
}

/// Accumulators of the turntable-angle measurement window.
#[derive(Clone, Debug)]
struct TurntableWindow {
    beta: PhiMean,
    /// The gyro noise of the window's steps ([`WindowNoise`]; sample counts as weights).
    noise: WindowNoise,
    c_sum: Matrix3<f64>,
    omega_sum: Vector3<f64>,
    y_sum: Vector3<f64>,
    count: usize,
    /// Noise map of each angle record the window's samples were interpolated from:
    /// `(record index, sum of weight * J)`.
    records: Vec<(usize, Matrix3<f64>)>,
    /// The records and sample count of the window before: records interpolated into both make
    /// the two measurements' noises correlated.
    prev_records: Vec<(usize, Matrix3<f64>)>,
    prev_count: usize,
}

impl TurntableWindow {
    /// An empty window over `nd` dynamic columns, room for 64 records reserved.
    fn new(nd: usize) -> Self {
        Self {
            beta: PhiMean::new(nd),
            noise: WindowNoise::default(),
            c_sum: Matrix3::zeros(),
            omega_sum: Vector3::zeros(),
            y_sum: Vector3::zeros(),
            count: 0,
            records: Vec::with_capacity(64),
            prev_records: Vec::with_capacity(64),
            prev_count: 0,
        }
    }
}

/// Accumulates the transition and measurement matrices of one filter interval.
#[derive(Debug)]
pub struct LinearModel {
    n: usize,
    n_instr: usize,
    /// Rotation of beta over one IMU step due to `beta x u`.
    a_step: Matrix3<f64>,
    /// Gyro white-noise PSD (rad^2/s).
    psd_gyro: f64,
    /// The columns of `phi_top` that can be non-zero: the attitude errors and the parameters
    /// of the gyro terms (nothing else drives `beta`), in order. The others are always zero
    /// and are not stored ([`DynamicRows`]).
    dynamic: Vec<usize>,
    /// The gyro terms' parameters: (index into the instrument parameters, column of
    /// `phi_top` among the dynamic ones).
    gyro_params: Vec<(usize, usize)>,
    /// The gyro and accelerometer Jacobians in axis-column form, when the model's terms give
    /// it: then a sub-step adds `C dt e_axis feature` per column, with no call through the
    /// terms and no products with zero columns. The gyro's columns are given by their
    /// dynamic column: `(column, axis, feature slot)`.
    gyro_axis: Option<Vec<(usize, usize, usize)>>,
    accel_axis: Option<AxisJacobian>,
    /// IMU steps since the last reset of the transition: `q_top = steps * psd dt I`, since the
    /// Earth-rate rotation leaves a multiple of the identity unchanged.
    q_steps: usize,
    phi_top: DynamicRows,
    jac: Vec<Vector3<f64>>,
    dt: f64,
    acc: AccelWindow,
    tt: TurntableWindow,
    scratch: DynamicRows,
    /// `phi_top` and `q_top` as dense matrices for the filter (filled at each predict).
    phi_mat: Mat<f64>,
    q_mat: Mat<f64>,
    /// Measurement matrices of the two kinds, filled when a measurement is formed.
    h_accel: Mat<f64>,
    h_turntable: Mat<f64>,
    /// The gyro biases' random walk, when the layout carries one.
    drift: Option<DriftNoise>,
    /// The accelerometer biases' random walk, when the layout carries one: the index of the
    /// state `accel.bias.x` and the PSD of each bias's walk ((m/s^2)^2/s). The biases do not
    /// drive the attitude error, so their process noise is `q T` on their diagonal over an
    /// interval `T`, uncorrelated with the rest.
    accel_drift: Option<(usize, Vector3<f64>)>,
}

/// The gyro terms' parameters of `layout`: (index into the instrument parameters, column of
/// `phi_top` among the dynamic ones, after the three attitude errors).
fn gyro_params_of(layout: &StateLayout) -> Vec<(usize, usize)> {
    (0..layout.model.terms().len())
        .filter(|&k| layout.model.terms()[k].sensor() == Sensor::Gyro)
        .flat_map(|k| {
            let o = layout.model.offset(k);
            o..o + layout.model.terms()[k].params().len()
        })
        .enumerate()
        .map(|(c, i)| (i, 3 + c))
        .collect()
}

/// The gyro Jacobian in axis-column form when the model's terms give it, each column given by
/// its dynamic column: `(column, axis, feature slot)`.
fn gyro_axis_columns(
    layout: &StateLayout,
    gyro_params: &[(usize, usize)],
) -> Option<Vec<(usize, usize, usize)>> {
    layout.model.axis_jacobian(Sensor::Gyro).map(|ax| {
        ax.entries()
            .iter()
            .map(|&(k, axis, slot)| {
                let c = gyro_params
                    .iter()
                    .find(|p| p.0 == k)
                    .expect("a gyro parameter")
                    .1;
                (c, axis, slot)
            })
            .collect()
    })
}

/// The accelerometer biases' random walk of `layout`, when it carries one: the index of the
/// state `accel.bias.x` and the PSD of each bias's walk ((m/s^2)^2/s).
fn accel_drift_of(layout: &StateLayout) -> Option<(usize, Vector3<f64>)> {
    layout.accel_drift.map(|d| {
        let bias = layout
            .index(sins_model::names::ACCEL_BIAS[0])
            .expect("a drifting accelerometer bias needs the states accel.bias.*");
        (bias, Vector3::from(d).component_mul(&Vector3::from(d)))
    })
}

/// Process noise of the attitude error and the drifting gyro biases (states 3..6) over one
/// transition interval, accumulated step by step exactly as the discrete model
/// `beta' = A beta + C dt b`, `b' = b + w` (`w` of variance `q dt`) propagates it.
#[derive(Clone, Debug)]
struct DriftNoise {
    /// PSD of each bias's random walk ((rad/s)^2/s).
    q: Vector3<f64>,
    q_bb: Matrix3<f64>,
    q_beta_b: Matrix3<f64>,
    q_beta_beta: Matrix3<f64>,
}

impl DriftNoise {
    /// The gyro biases' random walk of `layout`, when it carries one (its biases must be the
    /// first instrument term).
    fn of(layout: &StateLayout) -> Option<Self> {
        layout.gyro_drift.map(|d| {
            let bias = layout.index(sins_model::names::GYRO_BIAS[0]);
            assert_eq!(
                bias,
                Some(StateLayout::INSTRUMENT),
                "a drifting gyro bias must be the first instrument term"
            );
            DriftNoise {
                q: Vector3::from(d).component_mul(&Vector3::from(d)),
                q_bb: Matrix3::zeros(),
                q_beta_b: Matrix3::zeros(),
                q_beta_beta: Matrix3::zeros(),
            }
        })
    }

    fn reset(&mut self) {
        self.q_bb = Matrix3::zeros();
        self.q_beta_b = Matrix3::zeros();
        self.q_beta_beta = Matrix3::zeros();
    }

    /// One step with the attitude rotation `a`, `c_dt = C dt` and the gyro white-noise
    /// variance `white` of the step.
    fn step(&mut self, a: &Matrix3<f64>, c_dt: &Matrix3<f64>, white: f64, dt: f64) {
        let cross = a * self.q_beta_b * c_dt.transpose();
        self.q_beta_beta = a * self.q_beta_beta * a.transpose()
            + cross
            + cross.transpose()
            + c_dt * self.q_bb * c_dt.transpose()
            + Matrix3::identity() * white;
        self.q_beta_b = a * self.q_beta_b + c_dt * self.q_bb;
        self.q_bb += Matrix3::from_diagonal(&(self.q * dt));
    }
}

/// Which measurement a [`Measurement`] is, and where its matrix lives in the [`LinearModel`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeasurementKind {
    /// Specific force at rest (window mean).
    Accel,
    /// Turntable angles (window mean).
    Turntable,
}

/// One averaged measurement, ready for the filter: `z = H x + v`, `v ~ N(0, R)`. The matrix `H`
/// (3 x n, in terms of the state at the measurement instant) stays in the model that formed it:
/// [`LinearModel::h`].
#[derive(Clone, Copy, Debug)]
pub struct Measurement {
    /// Which measurement.
    pub kind: MeasurementKind,
    /// Measured value (zero in a covariance analysis).
    pub z: Vector3<f64>,
    /// Noise covariance.
    pub r: Matrix3<f64>,
    /// Number of IMU steps (specific force) or angle samples (turntable) averaged.
    pub samples: usize,
    /// The part of `r` that is not this measurement's own noise variance: the covariance with
    /// the window before through the angle records the two share, added to `r` for the
    /// parameters' sake ([`LinearModel::turntable_measurement`]). The innovation then scatters
    /// by `S - r_shared`, not `S`, and its NIS averages `3 - tr(S^-1 r_shared)`
    /// ([`crate::model::engine::UpdateRecord::expected_nis`]). Zero for the specific force.
    pub r_shared: Matrix3<f64>,
    /// Cross-covariance `E[beta v^T]` of the attitude error at the instant and the noise (the
    /// gyro noise within the window: module docs); the other states' rows are zero.
    pub cross_beta: Matrix3<f64>,
}

/// One turntable-angle sample at the end of an IMU step.
#[derive(Clone, Copy, Debug)]
pub struct AngleSample<'a> {
    /// `y` with `C_imu * C_tt^T = exp(-skew(y))` (zero in a covariance analysis).
    pub y: Vector3<f64>,
    /// Attitude used for the linearisation.
    pub c_body_to_enu: Matrix3<f64>,
    /// Platform rate relative to the base, ENU (rad/s).
    pub platform_rate_enu: Vector3<f64>,
    /// Gimbal Jacobian at the sample's angles.
    pub gimbal_jacobian: Matrix3<f64>,
    /// The angle records the sample was interpolated from, with their weights.
    pub records: &'a [(usize, f64)],
}

impl LinearModel {
    /// A model for `layout`, IMU step `dt` (s), Earth rate `u_enu` and gyro PSD (rad^2/s).
    pub fn new(layout: &StateLayout, dt: f64, u_enu: &Vector3<f64>, psd_gyro: f64) -> Self {
        let n = layout.dim();
        let n_instr = layout.n_instrument();
        let gyro_params = gyro_params_of(layout);
        let dynamic: Vec<usize> = (0..3)
            .chain(
                gyro_params
                    .iter()
                    .map(|&(i, _)| StateLayout::INSTRUMENT + i),
            )
            .collect();
        let nd = dynamic.len();
        let gyro_axis = gyro_axis_columns(layout, &gyro_params);
        let drift = DriftNoise::of(layout);
        let accel_drift = accel_drift_of(layout);
        // The dynamic rows: the attitude error, and the drifting biases with it (the
        // transition's rows down to the last drifting bias; the rows between are identity).
        let k = match (&accel_drift, drift.is_some()) {
            (Some((a, _)), _) => a + 3,
            (None, true) => 6,
            (None, false) => 3,
        };
        let mut m = Self {
            n,
            n_instr,
            a_step: errors::beta_transition(u_enu, dt),
            psd_gyro,
            dynamic,
            gyro_params,
            gyro_axis,
            accel_axis: layout.model.axis_jacobian(Sensor::Accel),
            q_steps: 0,
            phi_top: DynamicRows::zeros(nd),
            jac: vec![Vector3::zeros(); n_instr],
            dt,
            acc: AccelWindow::new(nd, n_instr),
            tt: TurntableWindow::new(nd),
            scratch: DynamicRows::zeros(nd),
            phi_mat: Mat::zeros(k, n),
            q_mat: Mat::zeros(k, k),
            h_accel: Mat::zeros(3, n),
            h_turntable: Mat::zeros(3, n),
            drift,
            accel_drift,
        };
        for i in 3..k {
            m.phi_mat[(i, i)] = 1.0;
        }
        m.reset_transition();
        m
    }

    /// IMU step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Start a new transition interval: `phi_top = [I 0]`, `q_top = 0`. Open measurement windows
    /// are re-expressed in the state at this instant first.
    pub fn reset_transition(&mut self) {
        if self.acc.beta.weight > 0.0 {
            self.acc.beta.rebase(&self.phi_top);
        }
        if self.tt.beta.weight > 0.0 {
            self.tt.beta.rebase(&self.phi_top);
        }
        self.phi_top.v.fill(0.0);
        for i in 0..3 {
            *self.phi_top.at_mut(i, i) = 1.0;
        }
        self.q_steps = 0;
        if let Some(d) = &mut self.drift {
            d.reset();
        }
    }

    /// Start a new specific-force window.
    pub fn reset_accel(&mut self) {
        self.acc.beta.clear();
        self.acc.noise = WindowNoise::default();
        self.acc.c_jac.fill(Vector3::zeros());
        self.acc.dv_enu = Vector3::zeros();
        self.acc.t = 0.0;
    }

    /// Start a new turntable-angle window.
    pub fn reset_turntable(&mut self) {
        let w = &mut self.tt;
        w.beta.clear();
        w.noise = WindowNoise::default();
        w.c_sum = Matrix3::zeros();
        w.omega_sum = Vector3::zeros();
        w.y_sum = Vector3::zeros();
        if w.count > 0 {
            std::mem::swap(&mut w.records, &mut w.prev_records);
            w.prev_count = w.count;
        }
        w.count = 0;
        w.records.clear();
    }

    /// Whether a specific-force window holds data.
    pub fn accel_open(&self) -> bool {
        self.acc.t > 0.0
    }

    /// Whether a turntable window holds samples.
    pub fn turntable_open(&self) -> bool {
        self.tt.count > 0
    }

    /// Integrate one IMU step with the attitude `c_body_to_enu`, body rate and specific force at
    /// its midpoint, and the current parameter estimate `p` (instrument part). When
    /// `accel_dv_enu` is given the step belongs to the specific-force window, with that
    /// measured velocity increment in ENU (zero in a covariance analysis).
    #[inline(always)]
    pub fn substep(
        &mut self,
        layout: &StateLayout,
        c_body_to_enu: &Matrix3<f64>,
        input: &SensorInput,
        p: &[f64],
        accel_dv_enu: Option<&Vector3<f64>>,
    ) {
        let dt = self.dt;
        let in_acc = accel_dv_enu.is_some();
        if in_acc && self.acc.t == 0.0 {
            // Trapezoid rule for the window mean of beta, `dt / 2 (beta_{s-1} + beta_s)` per
            // step: `dt` times every step's end below, plus half a step at the window's start
            // here, less half a step at its end ([`Self::accel_measurement`]).
            self.acc.beta.add(&self.phi_top, 0.5 * dt);
        }
        let a = self.a_step;
        self.phi_top.rotate(&a);
        let c_dt = c_body_to_enu * dt;
        let features = AxisJacobian::features(input);
        match &self.gyro_axis {
            Some(columns) => self.phi_top.add_axis_product(columns, &c_dt, &features),
            None => {
                layout.model.jacobian(Sensor::Gyro, p, input, &mut self.jac);
                for &(i, c) in &self.gyro_params {
                    let j = &self.jac[i];
                    if *j != Vector3::zeros() {
                        let col = self.phi_top.col(c) + c_dt * j;
                        self.phi_top.set_col(c, &col);
                    }
                }
            }
        }
        self.q_steps += 1;
        if let Some(d) = &mut self.drift {
            d.step(&a, &c_dt, self.psd_gyro * dt, dt);
        }
        let q_step = self.psd_gyro * dt;
        if in_acc {
            // Before this step's end is added below: the samples this step's noise misses.
            self.acc.noise.add(q_step, self.acc.beta.weight);
        }
        if self.tt.count > 0 {
            self.tt.noise.add(q_step, self.tt.count as f64);
        }
        if let Some(dv) = accel_dv_enu {
            self.acc.beta.add(&self.phi_top, dt);
            match &self.accel_axis {
                Some(ax) => ax.add_product(&c_dt, &features, &mut self.acc.c_jac),
                None => {
                    layout
                        .model
                        .jacobian(Sensor::Accel, p, input, &mut self.jac);
                    for (i, j) in self.jac.iter().enumerate() {
                        if *j != Vector3::zeros() {
                            self.acc.c_jac[i] += c_dt * j;
                        }
                    }
                }
            }
            self.acc.dv_enu += dv;
            self.acc.t += dt;
        }
    }

    /// Add a turntable-angle sample at the end of the last [`Self::substep`].
    #[inline(always)]
    pub fn add_angle_sample(&mut self, s: &AngleSample) {
        let w = &mut self.tt;
        w.beta.add(&self.phi_top, 1.0);
        w.c_sum += s.c_body_to_enu;
        w.omega_sum += s.platform_rate_enu;
        w.y_sum += s.y;
        w.count += 1;
        for &(k, weight) in s.records {
            match w.records.iter_mut().rev().find(|(i, _)| *i == k) {
                Some((_, m)) => *m += s.gimbal_jacobian * weight,
                None => w.records.push((k, s.gimbal_jacobian * weight)),
            }
        }
    }

    /// The accumulated `phi_top` as a dense 3 x n matrix.
    pub fn phi_top(&self) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(3, self.n);
        for (c, &j) in self.dynamic.iter().enumerate() {
            m.set_column(j, &self.phi_top.col(c));
        }
        m
    }

    /// The accumulated transition `phi_top` (3 x n) and attitude process noise `q_top` (3 x 3)
    /// as views for the filter (no allocation). With drifting gyro biases the dynamic rows are
    /// six: the attitude error and the biases (identity rows), `q_top` their joint noise.
    pub fn transition(&mut self) -> (MatRef<'_, f64>, MatRef<'_, f64>) {
        for (row, p) in self.phi_top.rows().into_iter().enumerate() {
            for (&j, x) in self.dynamic.iter().zip(p) {
                self.phi_mat[(row, j)] = *x;
            }
        }
        match &self.drift {
            None => {
                for i in 0..3 {
                    for j in 0..3 {
                        self.q_mat[(i, j)] = if i == j { self.q_diagonal() } else { 0.0 };
                    }
                }
            }
            Some(d) => {
                let b = StateLayout::INSTRUMENT;
                for i in 0..3 {
                    self.phi_mat[(b + i, b + i)] = 1.0;
                    for j in 0..3 {
                        self.q_mat[(i, j)] = d.q_beta_beta[(i, j)];
                        self.q_mat[(i, b + j)] = d.q_beta_b[(i, j)];
                        self.q_mat[(b + j, i)] = d.q_beta_b[(i, j)];
                        self.q_mat[(b + i, b + j)] = d.q_bb[(i, j)];
                    }
                }
            }
        }
        if let Some((a, q)) = &self.accel_drift {
            let t = self.q_steps as f64 * self.dt;
            for i in 0..3 {
                self.q_mat[(a + i, a + i)] = q[i] * t;
            }
        }
        (self.phi_mat.as_ref(), self.q_mat.as_ref())
    }

    /// The measurement matrix of the last measurement of `kind` formed.
    pub fn h(&self, kind: MeasurementKind) -> MatRef<'_, f64> {
        match kind {
            MeasurementKind::Accel => self.h_accel.as_ref(),
            MeasurementKind::Turntable => self.h_turntable.as_ref(),
        }
    }

    /// The accumulated attitude process noise.
    pub fn q_top(&self) -> Matrix3<f64> {
        Matrix3::identity() * self.q_diagonal()
    }

    fn q_diagonal(&self) -> f64 {
        self.q_steps as f64 * self.psd_gyro * self.dt
    }

    /// Length of the current specific-force window (s).
    pub fn accel_interval(&self) -> f64 {
        self.acc.t
    }

    /// The specific-force measurement of the window, in terms of the state now (end of the last
    /// sub-step): `z = mean(f'_x) - f_x`, `H = [skew(f_x) mean(beta) | mean(C dDf/dp) | 0]`,
    /// `R = psd / T`. `None` for an empty window.
    pub fn accel_measurement(
        &mut self,
        f_enu: &Vector3<f64>,
        psd_accel: f64,
    ) -> Option<Measurement> {
        let t = self.acc.t;
        if t <= 0.0 {
            return None;
        }
        let h = &mut self.h_accel;
        self.acc.beta.expressed_at(&self.phi_top, &mut self.scratch);
        // Less the trapezoid's half step at the window's end (see `substep`): `phi_top`
        // expressed at itself is `[I | 0]`.
        let half = 0.5 * self.dt;
        for i in 0..3 {
            *self.scratch.at_mut(i, i) -= half;
        }
        let weight = self.acc.beta.weight - half;
        let f_beta = errors::specific_force_beta_jacobian(f_enu);
        let sf = f_beta / weight;
        h.fill(0.0);
        for (c, &j) in self.dynamic.iter().enumerate() {
            let v = sf * self.scratch.col(c);
            for r in 0..3 {
                h[(r, j)] = v[r];
            }
        }
        for i in 0..self.n_instr {
            for r in 0..3 {
                h[(r, StateLayout::INSTRUMENT + i)] += self.acc.c_jac[i][r] / t;
            }
        }
        let (c1, c2) = self.acc.noise.moments(weight);
        Some(Measurement {
            kind: MeasurementKind::Accel,
            z: self.acc.dv_enu / t - f_enu,
            r: Matrix3::identity() * (psd_accel / t) + f_beta * f_beta.transpose() * c2,
            samples: (t / self.dt).round() as usize,
            r_shared: Matrix3::zeros(),
            cross_beta: -f_beta.transpose() * c1,
        })
    }

    /// The turntable-angle measurement of the window, in terms of the state now: the mean of the
    /// samples' `y`, `H = [mean(beta) | -mean(C) | -mean(Omega_x) | -I]` (`beta` columns,
    /// `delta_z`, `tau`, `gamma_p`) and `R = sum_k M_k diag(var) M_k^T / N^2` over the angle
    /// records (`var` per record and gimbal), with a floor of 1e-6 `var / N` so that `R` stays
    /// invertible at gimbal lock. `None` for an empty window.
    pub fn turntable_measurement(
        &mut self,
        layout: &StateLayout,
        var_per_record: f64,
    ) -> Option<Measurement> {
        let w = &self.tt;
        if w.count == 0 {
            return None;
        }
        let nf = w.count as f64;
        let h = &mut self.h_turntable;
        w.beta.expressed_at(&self.phi_top, &mut self.scratch);
        h.fill(0.0);
        for (c, &j) in self.dynamic.iter().enumerate() {
            let col = self.scratch.col(c);
            for r in 0..3 {
                h[(r, j)] = col[r] / w.beta.weight;
            }
        }
        let mut set_block = |col: usize, m: &Matrix3<f64>, ncols: usize| {
            for c in 0..ncols {
                for r in 0..3 {
                    h[(r, col + c)] = m[(r, c)];
                }
            }
        };
        if let Some(i) = layout.install {
            set_block(i, &(-w.c_sum / nf), 3);
        }
        if let Some(i) = layout.tau {
            set_block(
                i,
                &Matrix3::from_columns(&[-w.omega_sum / nf, Vector3::zeros(), Vector3::zeros()]),
                1,
            );
        }
        if let Some(i) = layout.base {
            set_block(i, &(-Matrix3::identity()), 3);
        }
        let mut r = Matrix3::identity() * (1e-6 * var_per_record / nf);
        for (_, m) in &w.records {
            r += m * m.transpose() * (var_per_record / (nf * nf));
        }
        // A record interpolated into this window and the one before correlates the two
        // measurements, which the filter takes as independent. The cross-covariance is added to
        // this window's R (both orderings), so that the R's of a run add up to the variance of
        // the sum of its measurements: exact for what stays constant over two windows (the
        // calibration's parameters), conservative for what changes faster. With angles at
        // 1 Hz against 1-s windows every record sits in two windows, and without this the
        // 28-state NEES came out 36.6 per run for 28 states.
        let np = w.prev_count.max(1) as f64;
        // Only the first record or two of a window were in the window before: the search is
        // skipped for records past the last of those (it made this function quadratic in the
        // records per window).
        let prev_last = w.prev_records.iter().map(|(i, _)| *i).max();
        let mut r_shared = Matrix3::zeros();
        for (k, m) in &w.records {
            if prev_last.is_none_or(|last| *k > last) {
                continue;
            }
            if let Some((_, mp)) = w.prev_records.iter().find(|(i, _)| i == k) {
                let c = mp * m.transpose() * (var_per_record / (np * nf));
                r += c + c.transpose();
                r_shared += c + c.transpose();
            }
        }
        // The samples' `beta` (weight 1 each) with the noise of the steps after them.
        let (c1, c2) = w.noise.moments(nf);
        r += Matrix3::identity() * c2;
        Some(Measurement {
            kind: MeasurementKind::Turntable,
            z: w.y_sum / nf,
            r,
            samples: w.count,
            r_shared,
            cross_beta: -Matrix3::identity() * c1,
        })
    }

    /// Turntable-angle measurement matrix (3 x n) of a single sample, `beta` taken at the sample:
    /// `[I | 0 | -C | -Omega_x | -I]` for `beta`, instrument errors, `delta_z`, `tau`, `gamma_p`.
    pub fn turntable_h(
        layout: &StateLayout,
        c_body_to_enu: &Matrix3<f64>,
        platform_rate_enu: &Vector3<f64>,
    ) -> DMatrix<f64> {
        let mut h = DMatrix::zeros(3, layout.dim());
        h.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&Matrix3::identity());
        if let Some(i) = layout.install {
            h.fixed_view_mut::<3, 3>(0, i).copy_from(&(-c_body_to_enu));
        }
        if let Some(i) = layout.tau {
            h.fixed_view_mut::<3, 1>(0, i)
                .copy_from(&(-platform_rate_enu));
        }
        if let Some(i) = layout.base {
            h.fixed_view_mut::<3, 3>(0, i)
                .copy_from(&(-Matrix3::identity()));
        }
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// The window's gyro noise as [`LinearModel::substep`] accumulates it (trapezoid weights:
    /// half a step at the window's start, a step at every step's end, less half a step at the
    /// end) against the sampled scalar walk: `mean(beta) - beta_end` has variance
    /// `sum c_i^2 q` and covariance `-sum c_i q` with the walk over the window (`beta_end -
    /// beta_start`). 40 000 windows of 10 steps, seed 1, fixed in advance: each figure within
    /// 4 standard errors.
    #[test]
    fn window_noise_moments_match_the_sampled_walk() {
        let (steps, dt, q) = (10usize, 0.1, 2.0);
        let mut noise = WindowNoise::default();
        let mut weight = 0.5 * dt;
        for _ in 0..steps {
            noise.add(q, weight);
            weight += dt;
        }
        let (c1, c2) = noise.moments(weight - 0.5 * dt);
        // Closed form for equal steps: c_i = (i - 1/2) / N.
        let n = steps as f64;
        assert!((c1 - q * n / 2.0).abs() < 1e-12);
        assert!((c2 - q * (n / 3.0 - 1.0 / (12.0 * n))).abs() < 1e-12);

        let mut rng = rand::rngs::StdRng::seed_from_u64(1);
        let normal = Normal::new(0.0, q.sqrt()).unwrap();
        let runs = 40_000;
        let (mut var, mut cov, mut var_walk) = (0.0, 0.0, 0.0);
        for _ in 0..runs {
            // The walk starts at 0 (the window's first instant, weight dt / 2, adds nothing).
            let (mut beta, mut sum) = (0.0, 0.0);
            for i in 0..steps {
                beta += normal.sample(&mut rng);
                sum += if i + 1 == steps { 0.5 * dt } else { dt } * beta;
            }
            let delta = sum / (n * dt) - beta;
            var += delta * delta;
            cov += delta * beta;
            var_walk += beta * beta;
        }
        let (var, cov, var_walk) = (var / runs as f64, cov / runs as f64, var_walk / runs as f64);
        let se = |v: f64| 4.0 * v * (2.0 / runs as f64).sqrt();
        assert!((var - c2).abs() < se(c2), "variance {var} against {c2}");
        assert!(
            (cov + c1).abs() < se(var_walk),
            "covariance {cov} against {}",
            -c1
        );
        assert!((var_walk - q * n).abs() < se(q * n), "walk {var_walk}");
    }
}
