//! Truth simulation of a calibration run: what the IMU and the turntable's angle sensors record.
//!
//! - IMU records on the IMU clock: increments `dtheta`, `dv` over `[t - dt, t]` (`t` the end of
//!   the interval), the exact integrals of the measured rate `w' = w - nu(p; w, f)` and specific
//!   force `f' = f + df(p; w, f)` in body axes (coning and sculling included), plus white noise
//!   with variance `PSD * dt` per axis. The integrals use Gauss-Legendre quadrature on each
//!   sub-interval between program piece boundaries, where the integrand is analytic.
//! - Turntable records on the turntable clock ([`AngleSensor`]): stamps on a regular grid of the
//!   turntable clock covering the IMU run; the record stamped `t_tt` holds the true gimbal angles
//!   at IMU time [`AngleSensor::true_time_of_record`] (late by `tau`) plus white noise, in degrees.
//! - [`Truth`]: the true parameter values, for checking an estimate.

use crate::kinematics::Kinematics;
use crate::sensor::AngleSensor;
use nalgebra::Vector3;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use sins_model::names;
use sins_model::terms::{ErrorModel, Sensor, SensorInput, Unit};

/// One IMU record: increments over `[t - dt, t]`, body axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// End of the interval on the IMU clock (s).
    pub t: f64,
    /// Angle increment (rad).
    pub dtheta: Vector3<f64>,
    /// Velocity increment (m/s).
    pub dv: Vector3<f64>,
    /// The instrument's temperature over the interval (at its middle; deg C), when the run has
    /// a temperature profile.
    pub temp: Option<f64>,
}

/// One turntable record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TurntableSample {
    /// Stamp on the turntable clock (s).
    pub t_tt: f64,
    /// Gimbal angles (heading, bank, pitch) as read by the angle sensors (deg).
    pub k_deg: [f64; 3],
}

/// Settings of the IMU part of a simulation (serde, so a run configuration can hold it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimConfig {
    /// IMU output rate (Hz).
    pub imu_rate_hz: f64,
    /// Gyro white-noise PSD [rad^2/s]: an angle increment gets noise of variance `psd * dt`.
    pub gyro_psd: f64,
    /// Accelerometer white-noise PSD [(m/s^2)^2 s]: a velocity increment gets `psd * dt`.
    pub accel_psd: f64,
    /// Gauss-Legendre points per smooth sub-interval (1..=64).
    pub quadrature_points: usize,
    /// Length of the IMU run (s); `None` = the program's duration.
    pub duration_s: Option<f64>,
    /// Seed of the random generator (noise).
    pub seed: u64,
    /// The instrument's temperature over the run and the reference temperature (deg C) the
    /// thermal terms of the model are about; `None`: no temperature (the thermal terms then
    /// contribute nothing, the records have none).
    pub temperature: Option<(crate::temperature::TemperatureProfile, f64)>,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            imu_rate_hz: 100.0,
            gyro_psd: 0.0,
            accel_psd: 0.0,
            quadrature_points: 6,
            duration_s: None,
            seed: 0,
            temperature: None,
        }
    }
}

/// Errors of the simulator (bad settings, never user data).
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// `p_true` does not match the error model.
    #[error("true parameter vector has {got} values, the error model has {expected} parameters")]
    ParameterCount {
        /// Parameters of the model.
        expected: usize,
        /// Values given.
        got: usize,
    },
    /// A setting is out of range.
    #[error("invalid simulation setting: {0}")]
    Invalid(String),
}

/// One true parameter value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TruthParameter {
    /// Documented name, e.g. `gyro.bias.x`.
    pub name: String,
    /// Value in SI units.
    pub value: f64,
    /// SI unit name ([`Unit::si_name`]).
    pub unit: String,
}

/// True values of everything the simulation was built from; JSON `{"parameters": [...]}`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// Parameters in order: the error model's, then `install.delta.*`, `turntable.tau`,
    /// `base.gamma.*`, `turntable.clock.offset`, `turntable.clock.rate_error`.
    pub parameters: Vec<TruthParameter>,
    /// The temperature the thermal terms' coefficients are about (deg C): the biases and scale
    /// factors above hold there. Absent for a run without a temperature.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature_reference_c: Option<f64>,
}

impl Truth {
    /// Collect the truth of a run. `p_true` must match `model` (checked by [`simulate`]).
    pub fn new(model: &ErrorModel, p_true: &[f64], kin: &Kinematics, sensor: &AngleSensor) -> Self {
        let mut parameters: Vec<TruthParameter> = model
            .params()
            .into_iter()
            .zip(p_true)
            .map(|(spec, &value)| TruthParameter {
                name: spec.name,
                value,
                unit: spec.unit.si_name().to_string(),
            })
            .collect();
        let mut push = |name: String, value: f64, unit: Unit| {
            parameters.push(TruthParameter {
                name,
                value,
                unit: unit.si_name().to_string(),
            })
        };
        for (i, n) in names::INSTALL_DELTA.iter().enumerate() {
            push(n.to_string(), kin.mounting.delta_z[i], names::ANGLE_UNIT);
        }
        push(names::TURNTABLE_TAU.into(), sensor.tau, names::TAU_UNIT);
        for (i, n) in names::BASE_GAMMA.iter().enumerate() {
            push(n.to_string(), kin.mounting.gamma_p[i], names::ANGLE_UNIT);
        }
        push(
            names::CLOCK_OFFSET.into(),
            sensor.clock.turntable_offset_s,
            Unit::Second,
        );
        push(
            names::CLOCK_RATE_ERROR.into(),
            sensor.clock.turntable_rate_error,
            Unit::Ratio,
        );
        Self {
            parameters,
            temperature_reference_c: None,
        }
    }

    /// Value of a parameter by name.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.parameters
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.value)
    }

    /// Pretty JSON `{"parameters": [{"name", "value", "unit"}...]}`.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("truth is plain data")
    }
}

/// A simulated run.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// IMU records.
    pub imu: Vec<ImuSample>,
    /// Turntable records.
    pub turntable: Vec<TurntableSample>,
    /// True values.
    pub truth: Truth,
}

/// The random generator used by the simulator (portable: same seed, same numbers everywhere).
pub type SimRng = Xoshiro256PlusPlus;

/// Draw true parameters from the priors: `Normal(0, prior_sigma)` for each parameter.
pub fn draw_parameters<R: Rng + ?Sized>(model: &ErrorModel, rng: &mut R) -> Vec<f64> {
    model
        .params()
        .iter()
        .map(|spec| {
            let n: f64 = StandardNormal.sample(rng);
            spec.prior_sigma * n
        })
        .collect()
}

/// Gauss-Legendre rule on `[-1, 1]`: `n` nodes and weights (Newton on the Legendre polynomial).
#[derive(Clone, Debug, PartialEq)]
pub struct GaussLegendre {
    nodes: Vec<f64>,
    weights: Vec<f64>,
}

impl GaussLegendre {
    /// The `n`-point rule, `1 <= n <= 64`.
    pub fn new(n: usize) -> Result<Self, SimulateError> {
        if !(1..=64).contains(&n) {
            return Err(SimulateError::Invalid(format!(
                "quadrature_points must be in 1..=64, got {n}"
            )));
        }
        let mut nodes = Vec::with_capacity(n);
        let mut weights = Vec::with_capacity(n);
        let nf = n as f64;
        for i in 0..n {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (p, d) = legendre(n, x);
                dp = d;
                let dx = p / d;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            let (_, d) = legendre(n, x);
            if d.is_finite() {
                dp = d;
            }
            nodes.push(x);
            weights.push(2.0 / ((1.0 - x * x) * dp * dp));
        }
        Ok(Self { nodes, weights })
    }

    /// Integrate `f` over `[a, b]`, accumulating into a pair of vectors.
    fn integrate2<F>(&self, a: f64, b: f64, mut f: F) -> (Vector3<f64>, Vector3<f64>)
    where
        F: FnMut(f64) -> (Vector3<f64>, Vector3<f64>),
    {
        let h = 0.5 * (b - a);
        let m = 0.5 * (a + b);
        let mut s1 = Vector3::zeros();
        let mut s2 = Vector3::zeros();
        for (&x, &w) in self.nodes.iter().zip(&self.weights) {
            let (v1, v2) = f(m + h * x);
            s1 += v1 * w;
            s2 += v2 * w;
        }
        (s1 * h, s2 * h)
    }
}

/// Legendre polynomial `P_n(x)` and its derivative.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let kf = k as f64;
        let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
        p0 = p1;
        p1 = p2;
    }
    let nf = n as f64;
    (p1, nf * (x * p1 - p0) / (x * x - 1.0))
}

/// Exact (to quadrature precision) noise-free increments over `[a, b]`: the integrals of the
/// measured body rate `w - nu(p)` and specific force `f + df(p)`, with the instrument
/// `temp_delta` (K) from the thermal terms' reference over the interval (a temperature moves by
/// millikelvin within one; 0 without thermal terms). The interval is split at program piece
/// boundaries (and at `t = 0`, before which the program holds its start).
pub fn increments_at(
    kin: &Kinematics,
    model: &ErrorModel,
    p_true: &[f64],
    rule: &GaussLegendre,
    a: f64,
    b: f64,
    temp_delta: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let integrand = |t: f64| {
        let s = kin.sample(t);
        let input = SensorInput {
            omega_body: s.omega_body,
            f_body: s.f_body,
            temp_delta,
            ..SensorInput::default()
        };
        (
            s.omega_body - model.error(Sensor::Gyro, p_true, &input),
            s.f_body + model.error(Sensor::Accel, p_true, &input),
        )
    };
    let mut breaks = vec![a];
    if a < 0.0 && b > 0.0 {
        breaks.push(0.0);
    }
    let pieces = kin.program.pieces();
    if !pieces.is_empty() {
        let mut i = kin.program.piece_index(a.max(0.0));
        while i < pieces.len() && pieces[i].t1 < b {
            if pieces[i].t1 > a {
                breaks.push(pieces[i].t1);
            }
            i += 1;
        }
    }
    breaks.push(b);
    let mut dtheta = Vector3::zeros();
    let mut dv = Vector3::zeros();
    for w in breaks.windows(2) {
        if w[1] > w[0] {
            let (x, y) = rule.integrate2(w[0], w[1], integrand);
            dtheta += x;
            dv += y;
        }
    }
    if model.uses_rate_derivatives() {
        // The part of the errors that is linear in the rate derivatives (the quadrature above
        // evaluates the terms with zero derivatives) integrates exactly to a function of the
        // changes of the rate and specific force over the interval, jumps of the program's
        // rates included (a delta function in dw/dt that no quadrature sees). Left limits at
        // both ends, so that a jump at an interval's end belongs to the next interval, as a
        // finite difference of consecutive increments puts it.
        let (sa, sb) = (kin.sample_left(a), kin.sample_left(b));
        let (d_omega, d_f) = (sb.omega_body - sa.omega_body, sb.f_body - sa.f_body);
        dtheta -= model.derivative_error_integral(Sensor::Gyro, p_true, &d_omega, &d_f);
        dv += model.derivative_error_integral(Sensor::Accel, p_true, &d_omega, &d_f);
    }
    (dtheta, dv)
}

/// A random walk of the gyro biases on top of the constant ones: `d(nu0_i)/dt` white with PSD
/// `intensity_i^2` ((rad/s)^2/s), from zero at `t = 0`, drawn from its own random stream.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GyroDrift {
    /// Random-walk intensity of each gyro's bias (rad/s/sqrt(s)).
    pub intensity: [f64; 3],
    /// Seed of the walk's own random stream.
    pub seed: u64,
}

/// A random walk of the accelerometer biases on top of the constant ones: `d(df0_i)/dt` white
/// with PSD `intensity_i^2` ((m/s^2)^2/s), from zero at `t = 0`, drawn from its own random
/// stream.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelDrift {
    /// Random-walk intensity of each accelerometer's bias (m/s^2/sqrt(s)).
    pub intensity: [f64; 3],
    /// Seed of the walk's own random stream.
    pub seed: u64,
}

/// The drifting part of the gyro biases at `i * dt`, `i = 0..=n` (zero at 0): independent
/// increments of variance `intensity_i^2 dt`.
pub fn gyro_bias_walk(drift: &GyroDrift, dt: f64, n: usize) -> Vec<Vector3<f64>> {
    bias_walk(drift.intensity, drift.seed, dt, n)
}

/// The drifting part of the accelerometer biases at `i * dt`, `i = 0..=n` (zero at 0), as
/// [`gyro_bias_walk`].
pub fn accel_bias_walk(drift: &AccelDrift, dt: f64, n: usize) -> Vec<Vector3<f64>> {
    bias_walk(drift.intensity, drift.seed, dt, n)
}

fn bias_walk(intensity: [f64; 3], seed: u64, dt: f64, n: usize) -> Vec<Vector3<f64>> {
    let mut walk = BiasWalk::new(intensity, seed, dt);
    let mut out = Vec::with_capacity(n + 1);
    out.push(walk.value());
    for _ in 0..n {
        out.push(walk.step());
    }
    out
}

/// A bias random walk generated step by step: the values of [`gyro_bias_walk`] /
/// [`accel_bias_walk`] one at a time (same seeded stream, same draws in the same order), holding
/// only the current value.
#[derive(Clone, Debug)]
pub struct BiasWalk {
    rng: SimRng,
    s: Vector3<f64>,
    b: Vector3<f64>,
}

impl BiasWalk {
    /// The walk of intensities `intensity` (per sqrt(s)) over steps of `dt`, from its own stream
    /// seeded with `seed`; it starts at zero.
    pub fn new(intensity: [f64; 3], seed: u64, dt: f64) -> Self {
        Self {
            rng: SimRng::seed_from_u64(seed),
            s: Vector3::from(intensity) * dt.sqrt(),
            b: Vector3::zeros(),
        }
    }

    /// The current value (zero before the first step).
    pub fn value(&self) -> Vector3<f64> {
        self.b
    }

    /// Advance one step and return the new value.
    pub fn step(&mut self) -> Vector3<f64> {
        self.b += normal3(&mut self.rng).component_mul(&self.s);
        self.b
    }
}

fn check(
    model: &ErrorModel,
    p_true: &[f64],
    config: &SimConfig,
) -> Result<(GaussLegendre, f64), SimulateError> {
    if p_true.len() != model.n_params() {
        return Err(SimulateError::ParameterCount {
            expected: model.n_params(),
            got: p_true.len(),
        });
    }
    if p_true.iter().any(|v| !v.is_finite()) {
        return Err(SimulateError::Invalid(
            "true parameter values must be finite".into(),
        ));
    }
    if !(config.imu_rate_hz.is_finite() && config.imu_rate_hz > 0.0) {
        return Err(SimulateError::Invalid(format!(
            "imu_rate_hz must be > 0, got {}",
            config.imu_rate_hz
        )));
    }
    for (name, v) in [
        ("gyro_psd", config.gyro_psd),
        ("accel_psd", config.accel_psd),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(SimulateError::Invalid(format!(
                "{name} must be >= 0, got {v}"
            )));
        }
    }
    let dt = 1.0 / config.imu_rate_hz;
    let rule = GaussLegendre::new(config.quadrature_points)?;
    Ok((rule, dt))
}

/// Length of the IMU run for a configuration.
pub fn run_duration(kin: &Kinematics, config: &SimConfig) -> f64 {
    config.duration_s.unwrap_or_else(|| kin.program.duration())
}

/// The IMU records of a run: `n = floor(duration * rate)` intervals ending at `i * dt`.
pub fn simulate_imu<R: Rng + ?Sized>(
    kin: &Kinematics,
    model: &ErrorModel,
    p_true: &[f64],
    config: &SimConfig,
    rng: &mut R,
) -> Result<Vec<ImuSample>, SimulateError> {
    simulate_imu_drifting(kin, model, p_true, config, None, rng)
}

/// [`simulate_imu`] with the gyro biases drifting ([`gyro_bias_walk`]; the walk's integral
/// over each interval by the trapezoid rule). The noise draws from `rng` are those of the run
/// without the drift.
pub fn simulate_imu_drifting<R: Rng + ?Sized>(
    kin: &Kinematics,
    model: &ErrorModel,
    p_true: &[f64],
    config: &SimConfig,
    drift: Option<&GyroDrift>,
    rng: &mut R,
) -> Result<Vec<ImuSample>, SimulateError> {
    simulate_imu_walking(kin, model, p_true, config, drift, None, rng)
}

/// [`simulate_imu_drifting`] with the accelerometer biases drifting too ([`accel_bias_walk`];
/// its integral over each interval by the trapezoid rule, added to the velocity increment).
/// The noise draws from `rng` and the gyro walk are those of the run without the
/// accelerometer walk.
pub fn simulate_imu_walking<R: Rng + ?Sized>(
    kin: &Kinematics,
    model: &ErrorModel,
    p_true: &[f64],
    config: &SimConfig,
    drift: Option<&GyroDrift>,
    accel_drift: Option<&AccelDrift>,
    rng: &mut R,
) -> Result<Vec<ImuSample>, SimulateError> {
    let stream = ImuStream::new(kin, model, p_true, config, drift, accel_drift, rng)?;
    let mut out = Vec::with_capacity(stream.len());
    out.extend(stream);
    Ok(out)
}

/// The IMU records of [`simulate_imu_walking`] one at a time, holding only the current state
/// (the bias walks' current values, [`BiasWalk`]): the same records, bit for bit, with the same
/// draws from `rng` in the same order. Once it is done (or dropped), `rng` goes on where the
/// collected run leaves it.
pub struct ImuStream<'a, R: Rng + ?Sized> {
    kin: &'a Kinematics,
    model: &'a ErrorModel,
    p_true: &'a [f64],
    config: &'a SimConfig,
    rule: GaussLegendre,
    dt: f64,
    n: usize,
    i: usize,
    sg: f64,
    sa: f64,
    walk: Option<(BiasWalk, Vector3<f64>)>,
    accel_walk: Option<(BiasWalk, Vector3<f64>)>,
    rng: &'a mut R,
}

impl<'a, R: Rng + ?Sized> ImuStream<'a, R> {
    /// Check the settings (the refusals of [`simulate_imu_walking`]) and start the stream.
    pub fn new(
        kin: &'a Kinematics,
        model: &'a ErrorModel,
        p_true: &'a [f64],
        config: &'a SimConfig,
        drift: Option<&GyroDrift>,
        accel_drift: Option<&AccelDrift>,
        rng: &'a mut R,
    ) -> Result<Self, SimulateError> {
        let (rule, dt) = check(model, p_true, config)?;
        let duration = run_duration(kin, config);
        if !(duration.is_finite() && duration > 0.0) {
            return Err(SimulateError::Invalid(format!(
                "run duration must be > 0, got {duration}"
            )));
        }
        let n = (duration * config.imu_rate_hz * (1.0 + 1e-12)).floor() as usize;
        let sg = (config.gyro_psd * dt).sqrt();
        let sa = (config.accel_psd * dt).sqrt();
        if let Some(d) = drift
            && d.intensity.iter().any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err(SimulateError::Invalid(format!(
                "gyro drift intensities must be >= 0, got {:?}",
                d.intensity
            )));
        }
        if let Some(d) = accel_drift
            && d.intensity.iter().any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err(SimulateError::Invalid(format!(
                "accelerometer drift intensities must be >= 0, got {:?}",
                d.intensity
            )));
        }
        let start = |w: BiasWalk| {
            let b = w.value();
            (w, b)
        };
        let walk = drift.map(|d| start(BiasWalk::new(d.intensity, d.seed, dt)));
        let accel_walk = accel_drift.map(|d| start(BiasWalk::new(d.intensity, d.seed, dt)));
        if let Some((profile, reference)) = &config.temperature {
            profile.check().map_err(SimulateError::Invalid)?;
            if !reference.is_finite() {
                return Err(SimulateError::Invalid(format!(
                    "reference temperature {reference}: expected a finite value"
                )));
            }
        }
        Ok(Self {
            kin,
            model,
            p_true,
            config,
            rule,
            dt,
            n,
            i: 0,
            sg,
            sa,
            walk,
            accel_walk,
            rng,
        })
    }

    /// How many records the whole run has.
    pub fn records(&self) -> usize {
        self.n
    }
}

impl<R: Rng + ?Sized> Iterator for ImuStream<'_, R> {
    type Item = ImuSample;

    fn next(&mut self) -> Option<ImuSample> {
        if self.i >= self.n {
            return None;
        }
        self.i += 1;
        let (i, dt) = (self.i, self.dt);
        let t = i as f64 * dt;
        let (temp, temp_delta) = match &self.config.temperature {
            Some((profile, reference)) => {
                let temp = profile.at(t - 0.5 * dt);
                (Some(temp), temp - reference)
            }
            None => (None, 0.0),
        };
        let (mut dtheta, mut dv) = increments_at(
            self.kin,
            self.model,
            self.p_true,
            &self.rule,
            (i - 1) as f64 * dt,
            t,
            temp_delta,
        );
        if let Some((w, prev)) = &mut self.walk {
            let b = w.step();
            dtheta -= (*prev + b) * (0.5 * dt);
            *prev = b;
        }
        if let Some((w, prev)) = &mut self.accel_walk {
            let b = w.step();
            dv += (*prev + b) * (0.5 * dt);
            *prev = b;
        }
        if self.sg > 0.0 {
            dtheta += normal3(self.rng) * self.sg;
        }
        if self.sa > 0.0 {
            dv += normal3(self.rng) * self.sa;
        }
        Some(ImuSample {
            t,
            dtheta,
            dv,
            temp,
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.n - self.i;
        (left, Some(left))
    }
}

impl<R: Rng + ?Sized> ExactSizeIterator for ImuStream<'_, R> {}

fn normal3<R: Rng + ?Sized>(rng: &mut R) -> Vector3<f64> {
    let mut v = Vector3::zeros();
    for i in 0..3 {
        v[i] = StandardNormal.sample(rng);
    }
    v
}

/// The turntable records covering the IMU run `[0, imu_duration]`: stamps `j / rate_hz` on the
/// turntable clock for every `j` with the stamp within the run's span on that clock, angles = the
/// true gimbal angles at IMU time `sensor.true_time_of_record(t_tt)` plus white noise of
/// `sensor.sigma` (rad, per sample), written in degrees.
pub fn simulate_turntable<R: Rng + ?Sized>(
    kin: &Kinematics,
    sensor: &AngleSensor,
    imu_duration: f64,
    rng: &mut R,
) -> Result<Vec<TurntableSample>, SimulateError> {
    let stream = TurntableStream::new(kin, sensor, imu_duration, rng)?;
    let mut out = Vec::with_capacity(stream.size_hint().1.unwrap_or(0));
    out.extend(stream);
    Ok(out)
}

/// Refuse an angle sensor [`simulate_turntable`] cannot simulate.
pub fn check_sensor(sensor: &AngleSensor) -> Result<(), SimulateError> {
    if !(sensor.rate_hz.is_finite() && sensor.rate_hz > 0.0) {
        return Err(SimulateError::Invalid(format!(
            "angle sensor rate_hz must be > 0, got {}",
            sensor.rate_hz
        )));
    }
    let valid = sensor.sigma.iter().all(|s| s.is_finite() && *s >= 0.0)
        && sensor.tau.is_finite()
        && sensor.clock.turntable_offset_s.is_finite()
        && sensor.clock.turntable_rate_error.is_finite()
        && sensor.clock.turntable_rate_error > -1.0;
    if !valid {
        return Err(SimulateError::Invalid(
            "angle sensor sigma must be >= 0, tau and clock finite, clock rate error > -1".into(),
        ));
    }
    Ok(())
}

/// The turntable records of [`simulate_turntable`] one at a time: the same records, bit for bit,
/// with the same draws from `rng` in the same order.
pub struct TurntableStream<'a, R: Rng + ?Sized> {
    kin: &'a Kinematics,
    sensor: &'a AngleSensor,
    t0: f64,
    t1: f64,
    j: i64,
    j1: i64,
    rng: &'a mut R,
}

impl<'a, R: Rng + ?Sized> TurntableStream<'a, R> {
    /// Check the sensor ([`check_sensor`]) and start the stream.
    pub fn new(
        kin: &'a Kinematics,
        sensor: &'a AngleSensor,
        imu_duration: f64,
        rng: &'a mut R,
    ) -> Result<Self, SimulateError> {
        check_sensor(sensor)?;
        let t0 = sensor.turntable_time(0.0);
        let t1 = sensor.turntable_time(imu_duration);
        let j0 = (t0 * sensor.rate_hz).ceil() as i64;
        let j1 = (t1 * sensor.rate_hz).floor() as i64;
        Ok(Self {
            kin,
            sensor,
            t0,
            t1,
            j: j0,
            j1,
            rng,
        })
    }
}

impl<R: Rng + ?Sized> Iterator for TurntableStream<'_, R> {
    type Item = TurntableSample;

    fn next(&mut self) -> Option<TurntableSample> {
        while self.j <= self.j1 {
            let j = self.j;
            self.j += 1;
            let sensor = self.sensor;
            let t_tt = j as f64 / sensor.rate_hz;
            if t_tt < self.t0 || t_tt > self.t1 {
                continue;
            }
            let (k, _) = self.kin.program.state(sensor.true_time_of_record(t_tt));
            let rng = &mut *self.rng;
            let k_deg = std::array::from_fn(|g| {
                let noise = if sensor.sigma[g] > 0.0 {
                    let n: f64 = StandardNormal.sample(rng);
                    sensor.sigma[g] * n
                } else {
                    0.0
                };
                (k[g] + noise).to_degrees()
            });
            return Some(TurntableSample { t_tt, k_deg });
        }
        None
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (0, Some((self.j1 - self.j + 1).max(0) as usize))
    }
}

/// Simulate a whole run with the seed of `config`: IMU records, turntable records and the truth.
pub fn simulate(
    kin: &Kinematics,
    model: &ErrorModel,
    p_true: &[f64],
    sensor: &AngleSensor,
    config: &SimConfig,
) -> Result<Simulation, SimulateError> {
    simulate_walking(kin, model, p_true, sensor, config, None, None)
}

/// [`simulate`] with the gyro biases drifting ([`simulate_imu_drifting`]) and the
/// accelerometer biases too ([`simulate_imu_walking`]); the noise of the records is that of the
/// run without the drift.
pub fn simulate_walking(
    kin: &Kinematics,
    model: &ErrorModel,
    p_true: &[f64],
    sensor: &AngleSensor,
    config: &SimConfig,
    drift: Option<&GyroDrift>,
    accel_drift: Option<&AccelDrift>,
) -> Result<Simulation, SimulateError> {
    let mut rng = SimRng::seed_from_u64(config.seed);
    let imu = simulate_imu_walking(kin, model, p_true, config, drift, accel_drift, &mut rng)?;
    let duration = imu.last().map_or(0.0, |s| s.t);
    let turntable = simulate_turntable(kin, sensor, duration, &mut rng)?;
    Ok(Simulation {
        imu,
        turntable,
        truth: Truth::new(model, p_true, kin, sensor),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [1usize, 2, 5, 7, 12, 30] {
            let r = GaussLegendre::new(n).unwrap();
            for deg in 0..(2 * n) {
                let (s, _) = r.integrate2(0.0, 2.0, |t| {
                    (Vector3::repeat(t.powi(deg as i32)), Vector3::zeros())
                });
                let exact = 2f64.powi(deg as i32 + 1) / (deg as f64 + 1.0);
                assert!((s.x - exact).abs() < 1e-13 * exact, "n {n} deg {deg}");
            }
        }
        assert!(GaussLegendre::new(0).is_err());
    }

    /// The walk as it was held before [`BiasWalk`].
    fn held_walk(intensity: [f64; 3], seed: u64, dt: f64, n: usize) -> Vec<Vector3<f64>> {
        let mut rng = SimRng::seed_from_u64(seed);
        let s = Vector3::from(intensity) * dt.sqrt();
        let mut b = Vector3::zeros();
        let mut out = Vec::with_capacity(n + 1);
        out.push(b);
        for _ in 0..n {
            b += normal3(&mut rng).component_mul(&s);
            out.push(b);
        }
        out
    }

    /// [`simulate_imu_walking`] as it was before [`ImuStream`]: every record held, the walks too.
    fn held_imu_walking<R: Rng + ?Sized>(
        kin: &Kinematics,
        model: &ErrorModel,
        p_true: &[f64],
        config: &SimConfig,
        drift: Option<&GyroDrift>,
        accel_drift: Option<&AccelDrift>,
        rng: &mut R,
    ) -> Result<Vec<ImuSample>, SimulateError> {
        let (rule, dt) = check(model, p_true, config)?;
        let duration = run_duration(kin, config);
        if !(duration.is_finite() && duration > 0.0) {
            return Err(SimulateError::Invalid(format!(
                "run duration must be > 0, got {duration}"
            )));
        }
        let n = (duration * config.imu_rate_hz * (1.0 + 1e-12)).floor() as usize;
        let sg = (config.gyro_psd * dt).sqrt();
        let sa = (config.accel_psd * dt).sqrt();
        if let Some(d) = drift
            && d.intensity.iter().any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err(SimulateError::Invalid(format!(
                "gyro drift intensities must be >= 0, got {:?}",
                d.intensity
            )));
        }
        if let Some(d) = accel_drift
            && d.intensity.iter().any(|v| !(v.is_finite() && *v >= 0.0))
        {
            return Err(SimulateError::Invalid(format!(
                "accelerometer drift intensities must be >= 0, got {:?}",
                d.intensity
            )));
        }
        let walk = drift.map(|d| held_walk(d.intensity, d.seed, dt, n));
        let accel_walk = accel_drift.map(|d| held_walk(d.intensity, d.seed, dt, n));
        if let Some((profile, reference)) = &config.temperature {
            profile.check().map_err(SimulateError::Invalid)?;
            if !reference.is_finite() {
                return Err(SimulateError::Invalid(format!(
                    "reference temperature {reference}: expected a finite value"
                )));
            }
        }
        let mut out = Vec::with_capacity(n);
        for i in 1..=n {
            let t = i as f64 * dt;
            let (temp, temp_delta) = match &config.temperature {
                Some((profile, reference)) => {
                    let temp = profile.at(t - 0.5 * dt);
                    (Some(temp), temp - reference)
                }
                None => (None, 0.0),
            };
            let (mut dtheta, mut dv) = increments_at(
                kin,
                model,
                p_true,
                &rule,
                (i - 1) as f64 * dt,
                t,
                temp_delta,
            );
            if let Some(b) = &walk {
                dtheta -= (b[i - 1] + b[i]) * (0.5 * dt);
            }
            if let Some(b) = &accel_walk {
                dv += (b[i - 1] + b[i]) * (0.5 * dt);
            }
            if sg > 0.0 {
                dtheta += normal3(rng) * sg;
            }
            if sa > 0.0 {
                dv += normal3(rng) * sa;
            }
            out.push(ImuSample {
                t,
                dtheta,
                dv,
                temp,
            });
        }
        Ok(out)
    }

    /// The streamed records equal the collected ones bit for bit (bias walks and temperature
    /// included), and the rng goes on to the same turntable records.
    #[test]
    fn streamed_records_equal_collected() {
        use crate::kinematics::Mounting;
        use crate::program::Program;
        use crate::temperature::TemperatureProfile;
        use sins_model::earth::Site;
        use sins_model::terms::PaperPriors;
        let kin = Kinematics::new(
            Program::paper(),
            Mounting {
                delta_z: Vector3::new(2e-3, -1e-3, 5e-4),
                gamma_p: Vector3::new(-3e-4, 2e-4, 1e-3),
            },
            Site::from_degrees(55.7, 37.6, 150.0),
        );
        let model = ErrorModel::paper(&PaperPriors::paper());
        let p_true = draw_parameters(&model, &mut SimRng::seed_from_u64(3));
        let sensor = AngleSensor {
            sigma: [1e-5; 3],
            rate_hz: 50.0,
            tau: 0.02,
            clock: crate::sensor::Clock {
                turntable_offset_s: 0.3,
                turntable_rate_error: 1e-5,
            },
        };
        let config = SimConfig {
            gyro_psd: 1e-12,
            accel_psd: 1e-6,
            duration_s: Some(120.0),
            seed: 11,
            temperature: Some((
                TemperatureProfile::Warmup {
                    start_c: 20.0,
                    end_c: 45.0,
                    time_constant_s: 60.0,
                },
                30.0,
            )),
            ..SimConfig::default()
        };
        let drift = GyroDrift {
            intensity: [1e-6, 2e-6, 3e-6],
            seed: 5,
        };
        let accel_drift = AccelDrift {
            intensity: [1e-4, 2e-4, 3e-4],
            seed: 7,
        };
        let held = simulate_walking(
            &kin,
            &model,
            &p_true,
            &sensor,
            &config,
            Some(&drift),
            Some(&accel_drift),
        )
        .unwrap();
        let mut held_rng = SimRng::seed_from_u64(config.seed);
        let held_imu = held_imu_walking(
            &kin,
            &model,
            &p_true,
            &config,
            Some(&drift),
            Some(&accel_drift),
            &mut held_rng,
        )
        .unwrap();
        assert_eq!(held_imu, held.imu);
        let mut rng = SimRng::seed_from_u64(config.seed);
        let stream = ImuStream::new(
            &kin,
            &model,
            &p_true,
            &config,
            Some(&drift),
            Some(&accel_drift),
            &mut rng,
        )
        .unwrap();
        assert_eq!(stream.records(), held.imu.len());
        let mut n = 0;
        let mut last = 0.0;
        for (a, b) in stream.zip(&held.imu) {
            assert_eq!(a.t.to_bits(), b.t.to_bits());
            for k in 0..3 {
                assert_eq!(a.dtheta[k].to_bits(), b.dtheta[k].to_bits());
                assert_eq!(a.dv[k].to_bits(), b.dv[k].to_bits());
            }
            assert_eq!(a.temp.map(f64::to_bits), b.temp.map(f64::to_bits));
            assert!(a.temp.is_some());
            last = a.t;
            n += 1;
        }
        assert_eq!(n, held.imu.len());
        let tt: Vec<_> = TurntableStream::new(&kin, &sensor, last, &mut rng)
            .unwrap()
            .collect();
        assert!(!tt.is_empty());
        assert_eq!(tt.len(), held.turntable.len());
        for (a, b) in tt.iter().zip(&held.turntable) {
            assert_eq!(a.t_tt.to_bits(), b.t_tt.to_bits());
            for g in 0..3 {
                assert_eq!(a.k_deg[g].to_bits(), b.k_deg[g].to_bits());
            }
        }
        // The walks step by step are the held walks.
        let dt = 1.0 / config.imu_rate_hz;
        let held_walk = held_walk(drift.intensity, drift.seed, dt, 1000);
        assert_eq!(gyro_bias_walk(&drift, dt, 1000), held_walk);
        let mut walk = BiasWalk::new(drift.intensity, drift.seed, dt);
        assert_eq!(walk.value(), held_walk[0]);
        for b in &held_walk[1..] {
            assert_eq!(walk.step(), *b);
        }
    }
}
