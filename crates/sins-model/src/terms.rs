//! Instrument errors as composable terms.
//!
//! A term owns a group of parameters (names, units, prior sigma), says how they change a sensor's
//! output (used by the truth simulator) and gives the Jacobian of that change with respect to its
//! parameters (used by the filter). The paper's model is four terms: the gyro [`Bias`], [`GyroMatrix`]
//! (full 3x3 `Theta`), the accelerometer [`Bias`] and [`AccelLowerTriangular`] (`Gamma`). Further effects are
//! more terms, implemented against the same trait and added to an [`ErrorModel`] without touching
//! the filter.
//!
//! Sign conventions (paper, design notes): the gyro output is `w' = w - nu`, the accelerometer
//! output `f' = f + df`; a gyro term contributes to `nu`, an accelerometer term to `df`.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// Which sensor triad a term corrupts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Sensor {
    /// Gyros: the term contributes to `nu` in `w' = w - nu`.
    Gyro,
    /// Accelerometers: the term contributes to `df` in `f' = f + df`.
    Accel,
}

/// Physical unit of a parameter together with the unit it is reported in.
///
/// Values are SI inside; `report_factor` converts an SI value into the report unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Unit {
    /// rad/s, reported in deg/h.
    RadPerSecond,
    /// m/s^2, reported in m/s^2.
    MeterPerSecond2,
    /// Dimensionless scale-factor error, reported in ppm (parts per million).
    Ratio,
    /// Small angle (rad) such as a misalignment, reported in arcmin.
    SmallAngle,
    /// Angle (rad), reported in degrees.
    Angle,
    /// Time (s), reported in s.
    Second,
    /// Gyro g-sensitivity (rad/s per m/s^2), reported in deg/h per g (9.80665 m/s^2).
    RadPerSecondPerMeterPerSecond2,
    /// Second-order accelerometer coefficient (1/(m/s^2)), reported in 1/g.
    PerMeterPerSecond2,
    /// Length (m), reported in mm.
    Meter,
    /// Random-walk intensity of a gyro bias (rad/s/sqrt(s)), reported in deg/h/sqrt(h).
    RadPerSecondPerSqrtSecond,
    /// Temperature coefficient of a gyro bias (rad/s/K), reported in deg/h/K.
    RadPerSecondPerKelvin,
    /// Temperature coefficient of an accelerometer bias (m/s^2/K), reported in m/s^2/K.
    MeterPerSecond2PerKelvin,
    /// Temperature coefficient of a scale factor (1/K), reported in ppm/K.
    PerKelvin,
}

/// Standard gravity (m/s^2), the `g` of report units such as deg/h/g.
pub const STANDARD_GRAVITY: f64 = 9.80665;

impl Unit {
    /// SI unit name as written in result files.
    pub fn si_name(self) -> &'static str {
        match self {
            Unit::RadPerSecond => "rad/s",
            Unit::MeterPerSecond2 => "m/s^2",
            Unit::Ratio => "1",
            Unit::SmallAngle | Unit::Angle => "rad",
            Unit::Second => "s",
            Unit::RadPerSecondPerMeterPerSecond2 => "rad/s/(m/s^2)",
            Unit::PerMeterPerSecond2 => "1/(m/s^2)",
            Unit::Meter => "m",
            Unit::RadPerSecondPerSqrtSecond => "rad/s/sqrt(s)",
            Unit::RadPerSecondPerKelvin => "rad/s/K",
            Unit::MeterPerSecond2PerKelvin => "m/s^2/K",
            Unit::PerKelvin => "1/K",
        }
    }
    /// Report (paper) unit name.
    pub fn report_name(self) -> &'static str {
        match self {
            Unit::RadPerSecond => "deg/h",
            Unit::MeterPerSecond2 => "m/s^2",
            Unit::Ratio => "ppm",
            Unit::SmallAngle => "arcmin",
            Unit::Angle => "deg",
            Unit::Second => "s",
            Unit::RadPerSecondPerMeterPerSecond2 => "deg/h/g",
            Unit::PerMeterPerSecond2 => "1/g",
            Unit::Meter => "mm",
            Unit::RadPerSecondPerSqrtSecond => "deg/h/sqrt(h)",
            Unit::RadPerSecondPerKelvin => "deg/h/K",
            Unit::MeterPerSecond2PerKelvin => "m/s^2/K",
            Unit::PerKelvin => "ppm/K",
        }
    }
    /// Multiply an SI value by this to get it in the report unit.
    pub const fn report_factor(self) -> f64 {
        match self {
            Unit::RadPerSecond => 1.0 / crate::units::DEG_PER_HOUR,
            Unit::MeterPerSecond2 | Unit::Second => 1.0,
            Unit::Ratio => 1e6,
            Unit::SmallAngle => 1.0 / crate::units::ARCMIN,
            Unit::Angle => 1.0 / crate::units::DEG,
            Unit::RadPerSecondPerMeterPerSecond2 => STANDARD_GRAVITY / crate::units::DEG_PER_HOUR,
            Unit::PerMeterPerSecond2 => STANDARD_GRAVITY,
            Unit::Meter => 1e3,
            // rad/s/sqrt(s) -> deg/h/sqrt(h): x / (deg/h) * sqrt(3600 s/h).
            Unit::RadPerSecondPerSqrtSecond => 60.0 / crate::units::DEG_PER_HOUR,
            Unit::RadPerSecondPerKelvin => 1.0 / crate::units::DEG_PER_HOUR,
            Unit::MeterPerSecond2PerKelvin => 1.0,
            Unit::PerKelvin => 1e6,
        }
    }
}

/// One scalar parameter of a term.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamSpec {
    /// Documented dotted name, e.g. `gyro.theta.xy`.
    pub name: String,
    /// Unit (SI inside, report unit for humans).
    pub unit: Unit,
    /// Prior standard deviation in SI units.
    pub prior_sigma: f64,
}

impl ParamSpec {
    /// A parameter spec.
    pub fn new(name: impl Into<String>, unit: Unit, prior_sigma: f64) -> Self {
        Self {
            name: name.into(),
            unit,
            prior_sigma,
        }
    }
}

/// What a sensor is exposed to at one instant, in the instrument (body) frame.
///
/// The two derivatives are zero by default (the paper's terms do not use them). A term that uses
/// them ([`Effect::uses_rate_derivatives`]) must be affine in them with a slope that does not
/// depend on the other inputs, `e = e0(p; w, f) + A(p) dw/dt + B(p) df/dt`: the turntable
/// programs have rate jumps, and the truth simulator integrates that part exactly from the
/// values of `w` and `f` at the ends of an interval (`integral of dw/dt = w(b) - w(a)`, jumps
/// included), not by quadrature.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorInput {
    /// True angular rate of the body relative to inertial space (rad/s).
    pub omega_body: Vector3<f64>,
    /// True specific force (m/s^2).
    pub f_body: Vector3<f64>,
    /// Time derivative of [`SensorInput::omega_body`] (body axes) (rad/s^2).
    pub omega_dot_body: Vector3<f64>,
    /// Time derivative of [`SensorInput::f_body`] (its body-axis components) (m/s^3).
    pub f_dot_body: Vector3<f64>,
    /// The unit's temperature less the reference temperature of the thermal terms (K); zero
    /// where the data have no temperature (the thermal terms then contribute nothing).
    pub temp_delta: f64,
}

/// An instrument error term: an [`Effect`] on one sensor triad, with named parameters.
pub trait ErrorTerm: Effect {
    /// The triad this term corrupts.
    fn sensor(&self) -> Sensor;
    /// The term's parameters, in the order used by [`Effect::error`] and the Jacobian.
    fn params(&self) -> &[ParamSpec];
}

/// What a term does to its sensor's output: its error and the error's Jacobian for given
/// parameter values, and the form of the error (the part of an [`ErrorTerm`] that is the
/// term's own; a candidate term's sensor and parameters come from its declaration,
/// [`crate::candidates::Declaration`]).
pub trait Effect: Debug + Send + Sync {
    /// The term's contribution to the sensor error (`nu` or `df`) for parameter values `p`.
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64>;
    /// Jacobian of [`Effect::error`] with respect to `p`, one column per parameter, written
    /// into `out` (length = number of parameters).
    fn jacobian(&self, p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]);
    /// Whether the error is affine in the input (`a + B w + C f` for fixed parameters), so that
    /// a model of such terms can be compensated with precomputed matrices
    /// ([`ErrorModel::affine`]). False unless a term says otherwise.
    fn is_affine(&self) -> bool {
        false
    }
    /// Whether the error is affine in the input within each orthant of the rate (the signs of
    /// `w`'s components fixed): a scale factor that differs with the sign of the rate
    /// ([`ErrorModel::affine_in_orthant`]). An affine term is.
    fn is_affine_in_orthant(&self) -> bool {
        self.is_affine()
    }
    /// The Jacobian's columns as [`AxisColumn`]s (column `k` is the unit vector of an axis times
    /// one input feature, whatever the parameters), when they have that form. The estimator
    /// then accumulates the rotated Jacobian column by column without calling
    /// [`Effect::jacobian`] at every IMU step ([`AxisJacobian`]). `None` (the default) keeps
    /// the general path; a term that says `Some` is checked against its `jacobian` by the tests.
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        None
    }
    /// Whether the error depends on [`SensorInput::omega_dot_body`] or
    /// [`SensorInput::f_dot_body`] (then affine in them, see [`SensorInput`]). False unless a
    /// term says otherwise.
    fn uses_rate_derivatives(&self) -> bool {
        false
    }
}

/// An input quantity a Jacobian column can be proportional to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// The constant 1 (a bias).
    One,
    /// Component `j` of [`SensorInput::omega_body`].
    Omega(usize),
    /// Component `j` of [`SensorInput::f_body`].
    Force(usize),
    /// The magnitude of component `j` of [`SensorInput::omega_body`] (a scale asymmetry).
    AbsOmega(usize),
    /// [`SensorInput::temp_delta`] (a bias's temperature coefficient).
    Temp,
    /// `temp_delta` times component `j` of `omega_body` (a gyro scale factor's coefficient).
    TempOmega(usize),
    /// `temp_delta` times component `j` of `f_body` (an accelerometer scale factor's).
    TempForce(usize),
}

/// The number of input features of an [`AxisJacobian`] ([`AxisJacobian::features`]).
pub const N_FEATURES: usize = 17;

impl Feature {
    /// Index of the feature in [`AxisJacobian::features`].
    fn slot(self) -> usize {
        match self {
            Feature::One => 0,
            Feature::Omega(j) => 1 + j,
            Feature::Force(j) => 4 + j,
            Feature::AbsOmega(j) => 7 + j,
            Feature::Temp => 10,
            Feature::TempOmega(j) => 11 + j,
            Feature::TempForce(j) => 14 + j,
        }
    }
}

/// A Jacobian column `e_axis * feature(input)`: one sensor axis, scaled by one input feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisColumn {
    /// The sensor axis (0, 1, 2) the parameter acts on.
    pub axis: usize,
    /// The input feature it scales with.
    pub feature: Feature,
}

impl AxisColumn {
    /// `e_axis * feature`.
    pub fn new(axis: usize, feature: Feature) -> Self {
        Self { axis, feature }
    }
}

/// The Jacobian of one triad's error in a model whose terms all have [`AxisColumn`]s
/// ([`ErrorModel::axis_jacobian`]): the non-zero columns as (parameter index in the model,
/// axis, feature slot). `M J` for any 3x3 `M` is then `M e_axis * feature` per column, with no
/// per-step call through the terms and no products with zero columns.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisJacobian {
    columns: Vec<(usize, usize, usize)>,
}

impl AxisJacobian {
    /// The features of `input` in slot order: 1, `omega_body`, `f_body`, `|omega_body|`,
    /// `temp_delta`, `temp_delta omega_body`, `temp_delta f_body`.
    #[inline]
    pub fn features(input: &SensorInput) -> [f64; N_FEATURES] {
        let (w, f, d) = (input.omega_body, input.f_body, input.temp_delta);
        [
            1.0,
            w.x,
            w.y,
            w.z,
            f.x,
            f.y,
            f.z,
            w.x.abs(),
            w.y.abs(),
            w.z.abs(),
            d,
            d * w.x,
            d * w.y,
            d * w.z,
            d * f.x,
            d * f.y,
            d * f.z,
        ]
    }

    /// The non-zero columns: (parameter index in the model, sensor axis, feature slot in
    /// [`AxisJacobian::features`]). For callers that hold the product in another layout.
    pub fn entries(&self) -> &[(usize, usize, usize)] {
        &self.columns
    }

    /// Add `m * J_k` to `out[k]` for every non-zero column `k` (`out` indexed by the model's
    /// parameters), with `features` from [`AxisJacobian::features`].
    #[inline]
    pub fn add_product(
        &self,
        m: &Matrix3<f64>,
        features: &[f64; N_FEATURES],
        out: &mut [Vector3<f64>],
    ) {
        for &(k, axis, slot) in &self.columns {
            out[k] += m.column(axis) * features[slot];
        }
    }
}

/// A triad's error as an affine function of the input, for fixed parameters:
/// `e = offset + d_omega * omega_body + d_f * f_body`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AffineError {
    /// Error at zero input.
    pub offset: Vector3<f64>,
    /// Change of the error per unit of angular rate.
    pub d_omega: Matrix3<f64>,
    /// Change of the error per unit of specific force.
    pub d_f: Matrix3<f64>,
}

impl AffineError {
    /// The error at `input`.
    pub fn at(&self, input: &SensorInput) -> Vector3<f64> {
        self.offset + self.d_omega * input.omega_body + self.d_f * input.f_body
    }
}

const AXES: [&str; 3] = ["x", "y", "z"];

/// The Jacobian of a term whose nine parameters are a 3x3 matrix row by row and whose
/// parameter `(i, j)` acts on axis `i` alone, with slope `slope(i, j)`: column `3 i + j` is
/// `e_i slope(i, j)` (`Theta w`: `slope(i, j) = w_j`).
pub fn matrix_jacobian(slope: impl Fn(usize, usize) -> f64, out: &mut [Vector3<f64>]) {
    for i in 0..3 {
        for j in 0..3 {
            let mut col = Vector3::zeros();
            col[i] = slope(i, j);
            out[3 * i + j] = col;
        }
    }
}

/// The [`AxisColumn`]s of a 3x3 matrix term row by row that multiplies an input vector:
/// column `3 i + j` is `e_i feature(j)` ([`matrix_jacobian`] with `slope(i, j)` that feature).
pub fn matrix_axis_columns(feature: fn(usize) -> Feature) -> Vec<AxisColumn> {
    (0..9)
        .map(|k| AxisColumn::new(k / 3, feature(k % 3)))
        .collect()
}

/// The Jacobian of a term with one parameter per axis, parameter `k` acting on axis `k` with
/// slope `slope_k`: column `k` is `e_k slope_k`.
pub fn diagonal_jacobian(slope: &Vector3<f64>, out: &mut [Vector3<f64>]) {
    out[0] = Vector3::new(slope.x, 0.0, 0.0);
    out[1] = Vector3::new(0.0, slope.y, 0.0);
    out[2] = Vector3::new(0.0, 0.0, slope.z);
}

/// A constant bias of one triad (3 parameters): the gyro bias `nu0` (`gyro.bias.*`, rad/s,
/// `nu += nu0`) or the accelerometer bias `df0` (`accel.bias.*`, m/s^2, `df += df0`).
#[derive(Clone, Debug)]
pub struct Bias {
    sensor: Sensor,
    params: Vec<ParamSpec>,
}

impl Bias {
    /// Gyro bias with prior sigma (rad/s) on each axis.
    pub fn gyro(prior_sigma: f64) -> Self {
        Self::new(Sensor::Gyro, "gyro", Unit::RadPerSecond, prior_sigma)
    }

    /// Accelerometer bias with prior sigma (m/s^2) on each axis.
    pub fn accel(prior_sigma: f64) -> Self {
        Self::new(Sensor::Accel, "accel", Unit::MeterPerSecond2, prior_sigma)
    }

    fn new(sensor: Sensor, prefix: &str, unit: Unit, prior_sigma: f64) -> Self {
        let params = AXES
            .iter()
            .map(|a| ParamSpec::new(format!("{prefix}.bias.{a}"), unit, prior_sigma))
            .collect();
        Self { sensor, params }
    }
}

impl ErrorTerm for Bias {
    fn sensor(&self) -> Sensor {
        self.sensor
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
}

impl Effect for Bias {
    fn is_affine(&self) -> bool {
        true
    }
    fn error(&self, p: &[f64], _input: &SensorInput) -> Vector3<f64> {
        Vector3::new(p[0], p[1], p[2])
    }
    fn jacobian(&self, _p: &[f64], _input: &SensorInput, out: &mut [Vector3<f64>]) {
        out[0] = Vector3::x();
        out[1] = Vector3::y();
        out[2] = Vector3::z();
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some((0..3).map(|i| AxisColumn::new(i, Feature::One)).collect())
    }
}

/// Gyro scale-factor and misalignment matrix `Theta` (full 3x3, row-major parameters
/// `gyro.theta.xx, .xy, .xz, .yx, ...`): `nu += Theta * omega_body`.
///
/// Diagonal elements are scale-factor errors (ratios, reported in ppm), off-diagonal elements are
/// misalignments (small angles, reported in arcmin).
#[derive(Clone, Debug)]
pub struct GyroMatrix {
    params: Vec<ParamSpec>,
}

impl GyroMatrix {
    /// With prior sigma on the diagonal (ratio) and off the diagonal (rad).
    pub fn new(sigma_diagonal: f64, sigma_off_diagonal: f64) -> Self {
        let mut params = Vec::with_capacity(9);
        for (i, a) in AXES.iter().enumerate() {
            for (j, b) in AXES.iter().enumerate() {
                params.push(if i == j {
                    ParamSpec::new(format!("gyro.theta.{a}{b}"), Unit::Ratio, sigma_diagonal)
                } else {
                    ParamSpec::new(
                        format!("gyro.theta.{a}{b}"),
                        Unit::SmallAngle,
                        sigma_off_diagonal,
                    )
                });
            }
        }
        Self { params }
    }
}

impl ErrorTerm for GyroMatrix {
    fn sensor(&self) -> Sensor {
        Sensor::Gyro
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
}

impl Effect for GyroMatrix {
    fn is_affine(&self) -> bool {
        true
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let w = input.omega_body;
        Vector3::new(
            p[0] * w.x + p[1] * w.y + p[2] * w.z,
            p[3] * w.x + p[4] * w.y + p[5] * w.z,
            p[6] * w.x + p[7] * w.y + p[8] * w.z,
        )
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let w = input.omega_body;
        matrix_jacobian(|_, j| w[j], out);
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some(matrix_axis_columns(Feature::Omega))
    }
}

/// Accelerometer lower-triangular matrix `Gamma` (6 parameters `accel.gamma.xx, .yx, .yy, .zx,
/// .zy, .zz`): `df += Gamma * f_body`.
///
/// Lower-triangular because the instrument frame is *defined* by the accelerometers (x along the
/// first, y in the plane of the first two): the three upper elements would only rotate the frame.
#[derive(Clone, Debug)]
pub struct AccelLowerTriangular {
    params: Vec<ParamSpec>,
}

/// (row, column) of each `Gamma` parameter, in parameter order.
pub const GAMMA_INDEX: [(usize, usize); 6] = [(0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (2, 2)];

impl AccelLowerTriangular {
    /// With prior sigma on the diagonal (ratio) and off the diagonal (rad).
    pub fn new(sigma_diagonal: f64, sigma_off_diagonal: f64) -> Self {
        let params = GAMMA_INDEX
            .iter()
            .map(|&(i, j)| {
                let name = format!("accel.gamma.{}{}", AXES[i], AXES[j]);
                if i == j {
                    ParamSpec::new(name, Unit::Ratio, sigma_diagonal)
                } else {
                    ParamSpec::new(name, Unit::SmallAngle, sigma_off_diagonal)
                }
            })
            .collect();
        Self { params }
    }
}

impl ErrorTerm for AccelLowerTriangular {
    fn sensor(&self) -> Sensor {
        Sensor::Accel
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
}

impl Effect for AccelLowerTriangular {
    fn is_affine(&self) -> bool {
        true
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let f = input.f_body;
        let mut df = Vector3::zeros();
        for (k, &(i, j)) in GAMMA_INDEX.iter().enumerate() {
            df[i] += p[k] * f[j];
        }
        df
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let f = input.f_body;
        for (k, &(i, j)) in GAMMA_INDEX.iter().enumerate() {
            let mut col = Vector3::zeros();
            col[i] = f[j];
            out[k] = col;
        }
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some(
            GAMMA_INDEX
                .iter()
                .map(|&(i, j)| AxisColumn::new(i, Feature::Force(j)))
                .collect(),
        )
    }
}

/// Prior standard deviations of the paper's four-term model, in SI units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperPriors {
    /// Gyro bias (rad/s).
    pub gyro_bias: f64,
    /// Gyro scale-factor errors (Theta diagonal) (-).
    pub gyro_scale: f64,
    /// Gyro misalignments (Theta off-diagonal) (rad).
    pub gyro_misalignment: f64,
    /// Accelerometer bias (m/s^2).
    pub accel_bias: f64,
    /// Accelerometer scale-factor errors (Gamma diagonal) (-).
    pub accel_scale: f64,
    /// Accelerometer non-orthogonality (Gamma off-diagonal) (rad).
    pub accel_misalignment: f64,
}

impl PaperPriors {
    /// The a priori values of the paper's covariance analysis: 0.5 deg/h, 0.02 m/s^2, 1e-3, 3 arcmin.
    pub fn paper() -> Self {
        let arcmin = crate::units::ARCMIN;
        Self {
            gyro_bias: 0.5 * crate::units::DEG_PER_HOUR,
            gyro_scale: 1e-3,
            gyro_misalignment: 3.0 * arcmin,
            accel_bias: 0.02,
            accel_scale: 1e-3,
            accel_misalignment: 3.0 * arcmin,
        }
    }
}

/// A set of terms with their parameters laid out one after the other.
#[derive(Debug, Default)]
pub struct ErrorModel {
    terms: Vec<Box<dyn ErrorTerm>>,
    offsets: Vec<usize>,
    n_params: usize,
}

impl ErrorModel {
    /// An empty model (no instrument errors).
    pub fn new() -> Self {
        Self::default()
    }

    /// The paper's four-term model with the given priors.
    pub fn paper(priors: &PaperPriors) -> Self {
        let mut m = Self::new();
        m.push(Box::new(Bias::gyro(priors.gyro_bias)));
        m.push(Box::new(GyroMatrix::new(
            priors.gyro_scale,
            priors.gyro_misalignment,
        )));
        m.push(Box::new(Bias::accel(priors.accel_bias)));
        m.push(Box::new(AccelLowerTriangular::new(
            priors.accel_scale,
            priors.accel_misalignment,
        )));
        m
    }

    /// Append a term; its parameters follow those already present.
    pub fn push(&mut self, term: Box<dyn ErrorTerm>) {
        self.offsets.push(self.n_params);
        self.n_params += term.params().len();
        self.terms.push(term);
    }

    /// Total number of parameters.
    pub fn n_params(&self) -> usize {
        self.n_params
    }

    /// The terms in order.
    pub fn terms(&self) -> &[Box<dyn ErrorTerm>] {
        &self.terms
    }

    /// Offset of term `k`'s first parameter in the model's parameter vector.
    pub fn offset(&self, k: usize) -> usize {
        self.offsets[k]
    }

    /// All parameter specs in order.
    pub fn params(&self) -> Vec<ParamSpec> {
        self.terms
            .iter()
            .flat_map(|t| t.params().iter().cloned())
            .collect()
    }

    /// Total error of one triad (`nu` for [`Sensor::Gyro`], `df` for [`Sensor::Accel`]).
    /// Terms whose parameters are all zero are skipped: every term's error is zero there
    /// (tested for every term, `candidates::tests::every_term_is_zero_at_zero_parameters`).
    pub fn error(&self, sensor: Sensor, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let mut e = Vector3::zeros();
        for (k, t) in self.terms.iter().enumerate() {
            if t.sensor() == sensor && !self.idle(k, p) {
                let o = self.offsets[k];
                e += t.error(&p[o..o + t.params().len()], input);
            }
        }
        e
    }

    /// Whether term `k`'s parameters are all zero in `p`: it then adds nothing to the error,
    /// whatever its form (the score tests' extended pass carries every candidate at zero, and
    /// a non-affine candidate there would otherwise force the general compensation on every
    /// step).
    pub fn idle(&self, k: usize, p: &[f64]) -> bool {
        let o = self.offsets[k];
        p[o..o + self.terms[k].params().len()]
            .iter()
            .all(|&x| x == 0.0)
    }

    /// Whether a term that is not idle at `p` ([`ErrorModel::idle`]) uses the rate
    /// derivatives.
    pub fn uses_rate_derivatives_at(&self, p: &[f64]) -> bool {
        self.terms
            .iter()
            .enumerate()
            .any(|(k, t)| t.uses_rate_derivatives() && !self.idle(k, p))
    }

    /// One triad's error as an affine function of the input for parameters `p`, when every term
    /// of that triad is affine in the input ([`Effect::is_affine`]) or idle at `p`
    /// ([`ErrorModel::idle`]); `None` otherwise.
    pub fn affine(&self, sensor: Sensor, p: &[f64]) -> Option<AffineError> {
        let all_affine = self
            .terms
            .iter()
            .enumerate()
            .filter(|(k, t)| t.sensor() == sensor && !self.idle(*k, p))
            .all(|(_, t)| t.is_affine());
        all_affine.then(|| self.affine_form(sensor, p, &Vector3::repeat(1.0)))
    }

    /// One triad's error as an affine function of the input within the orthant of the rate
    /// whose component signs are `signs` (each +1 or -1), when every term of that triad is
    /// affine there ([`Effect::is_affine_in_orthant`]); `None` otherwise. The rate columns
    /// are the error's derivative inside the orthant (`(e(s_i u_i) - e(0)) / s_i`), so the form
    /// is exact for every rate with those signs; on an affine model it is [`ErrorModel::affine`].
    pub fn affine_in_orthant(
        &self,
        sensor: Sensor,
        p: &[f64],
        signs: &Vector3<f64>,
    ) -> Option<AffineError> {
        let all = self
            .terms
            .iter()
            .enumerate()
            .filter(|(k, t)| t.sensor() == sensor && !self.idle(*k, p))
            .all(|(_, t)| t.is_affine_in_orthant());
        all.then(|| self.affine_form(sensor, p, signs))
    }

    /// The affine form of `sensor`'s error about zero input, its rate columns probed inside
    /// the orthant `signs` (the callers check that the terms allow it).
    fn affine_form(&self, sensor: Sensor, p: &[f64], signs: &Vector3<f64>) -> AffineError {
        let zero = SensorInput::default();
        let offset = self.error(sensor, p, &zero);
        let column = |omega: Vector3<f64>, f: Vector3<f64>| {
            let input = SensorInput {
                omega_body: omega,
                f_body: f,
                ..SensorInput::default()
            };
            self.error(sensor, p, &input) - offset
        };
        let (e, z) = (Matrix3::<f64>::identity(), Vector3::zeros());
        AffineError {
            offset,
            d_omega: Matrix3::from_columns(
                &[0, 1, 2].map(|i| column(e.column(i) * signs[i], z) * signs[i]),
            ),
            d_f: Matrix3::from_columns(&[0, 1, 2].map(|i| column(z, e.column(i).into()))),
        }
    }

    /// The Jacobian of `sensor`'s error as [`AxisColumn`]s, when every term of that sensor gives
    /// them ([`Effect::axis_columns`]); `None` otherwise.
    pub fn axis_jacobian(&self, sensor: Sensor) -> Option<AxisJacobian> {
        let mut columns = Vec::new();
        for (t, &o) in self.terms.iter().zip(&self.offsets) {
            if t.sensor() != sensor {
                continue;
            }
            for (k, c) in t.axis_columns()?.into_iter().enumerate() {
                columns.push((o + k, c.axis, c.feature.slot()));
            }
        }
        Some(AxisJacobian { columns })
    }

    /// Whether any term uses the rate derivatives ([`Effect::uses_rate_derivatives`]).
    pub fn uses_rate_derivatives(&self) -> bool {
        self.terms.iter().any(|t| t.uses_rate_derivatives())
    }

    /// The integral over an interval of the part of one triad's error that depends on the rate
    /// derivatives, from the changes of the rate `d_omega = w(b) - w(a)` and of the specific
    /// force `d_f = f(b) - f(a)` over it (exact for terms that keep the contract of
    /// [`SensorInput`], jumps included). Zero when no term uses the derivatives.
    pub fn derivative_error_integral(
        &self,
        sensor: Sensor,
        p: &[f64],
        d_omega: &Vector3<f64>,
        d_f: &Vector3<f64>,
    ) -> Vector3<f64> {
        let mut e = Vector3::zeros();
        let zero = SensorInput::default();
        let change = SensorInput {
            omega_dot_body: *d_omega,
            f_dot_body: *d_f,
            ..zero
        };
        for (k, t) in self.terms.iter().enumerate() {
            if t.sensor() == sensor && t.uses_rate_derivatives() && !self.idle(k, p) {
                let o = self.offsets[k];
                let q = &p[o..o + t.params().len()];
                e += t.error(q, &change) - t.error(q, &zero);
            }
        }
        e
    }

    /// Jacobian of one triad's error with respect to all parameters (zero columns for the other
    /// triad's parameters). `out` has length [`ErrorModel::n_params`].
    pub fn jacobian(
        &self,
        sensor: Sensor,
        p: &[f64],
        input: &SensorInput,
        out: &mut [Vector3<f64>],
    ) {
        for (t, &o) in self.terms.iter().zip(&self.offsets) {
            let n = t.params().len();
            if t.sensor() == sensor {
                t.jacobian(&p[o..o + n], input, &mut out[o..o + n]);
            } else {
                out[o..o + n].fill(Vector3::zeros());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input() -> SensorInput {
        SensorInput {
            omega_body: Vector3::new(0.17, -0.02, 0.05),
            f_body: Vector3::new(1.2, -3.4, 8.9),
            ..SensorInput::default()
        }
    }

    /// Where a model's terms give their Jacobian as axis columns (the paper's four terms, and
    /// with the g-sensitivity and the scale asymmetry), `M J` from [`AxisJacobian::add_product`] equals `M` times the
    /// Jacobian the terms compute, for each sensor; a model with a term that gives none has no
    /// axis Jacobian.
    #[test]
    fn axis_jacobians_equal_the_terms_jacobians() {
        use crate::candidates::Candidate;
        let inp = input();
        let m = Matrix3::new(0.3, -1.1, 0.4, 2.0, 0.7, -0.2, -0.9, 0.5, 1.3);
        let mut model = ErrorModel::paper(&PaperPriors::paper());
        let g = Candidate::GyroGSensitivity;
        model.push(g.term(g.default_prior_sigma()).expect("a constant term"));
        let a = Candidate::GyroScaleAsymmetry;
        model.push(a.term(a.default_prior_sigma()).expect("a constant term"));
        let p: Vec<f64> = (0..model.n_params())
            .map(|i| (1.0 + i as f64).sin())
            .collect();
        for sensor in [Sensor::Gyro, Sensor::Accel] {
            let ax = model
                .axis_jacobian(sensor)
                .expect("all terms give axis columns");
            let mut jac = vec![Vector3::zeros(); model.n_params()];
            model.jacobian(sensor, &p, &inp, &mut jac);
            let mut got = vec![Vector3::zeros(); model.n_params()];
            ax.add_product(&m, &AxisJacobian::features(&inp), &mut got);
            for (k, j) in jac.iter().enumerate() {
                assert!((got[k] - m * j).norm() < 1e-14, "{sensor:?} parameter {k}");
            }
        }
        let q = Candidate::AccelQuadratic;
        model.push(q.term(q.default_prior_sigma()).expect("a constant term"));
        assert!(model.axis_jacobian(Sensor::Accel).is_none());
        assert!(model.axis_jacobian(Sensor::Gyro).is_some());
    }

    /// Every term's Jacobian equals central finite differences of its effect.
    #[test]
    fn jacobians_match_finite_differences() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let n = m.n_params();
        let p: Vec<f64> = (0..n).map(|i| 1e-3 * ((i as f64) * 0.7).sin()).collect();
        let inp = input();
        for sensor in [Sensor::Gyro, Sensor::Accel] {
            let mut jac = vec![Vector3::zeros(); n];
            m.jacobian(sensor, &p, &inp, &mut jac);
            for k in 0..n {
                let h = 1e-4;
                let mut pp = p.clone();
                pp[k] += h;
                let mut pm = p.clone();
                pm[k] -= h;
                let fd = (m.error(sensor, &pp, &inp) - m.error(sensor, &pm, &inp)) / (2.0 * h);
                assert!(
                    (fd - jac[k]).norm() < 1e-9,
                    "{sensor:?} parameter {k}: fd {fd:?} vs jacobian {:?}",
                    jac[k]
                );
            }
        }
    }

    #[test]
    fn paper_model_has_21_parameters_with_documented_names() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let names: Vec<String> = m.params().into_iter().map(|p| p.name).collect();
        assert_eq!(names.len(), 21);
        assert_eq!(names[0], "gyro.bias.x");
        assert_eq!(names[4], "gyro.theta.xy");
        assert_eq!(names[11], "gyro.theta.zz");
        assert_eq!(names[14], "accel.bias.z");
        assert_eq!(names[16], "accel.gamma.yx");
        assert_eq!(names[20], "accel.gamma.zz");
    }

    #[test]
    fn effects_are_the_paper_formulas() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let mut p = vec![0.0; 21];
        p[1] = 2e-6; // gyro bias y
        p[3 + 1] = 1e-3; // Theta_xy
        p[15 + 1] = 5e-4; // Gamma_yx
        let inp = input();
        let nu = m.error(Sensor::Gyro, &p, &inp);
        assert!((nu - Vector3::new(1e-3 * inp.omega_body.y, 2e-6, 0.0)).norm() < 1e-18);
        let df = m.error(Sensor::Accel, &p, &inp);
        assert!((df - Vector3::new(0.0, 5e-4 * inp.f_body.x, 0.0)).norm() < 1e-18);
    }

    #[test]
    fn affine_form_of_the_paper_model_is_its_error() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let p: Vec<f64> = (0..m.n_params()).map(|i| 1e-3 * (i as f64 - 7.3)).collect();
        let x = input();
        for sensor in [Sensor::Gyro, Sensor::Accel] {
            let a = m.affine(sensor, &p).expect("the paper's terms are affine");
            let d = a.at(&x) - m.error(sensor, &p, &x);
            assert!(
                d.norm() < 1e-15 * m.error(sensor, &p, &x).norm().max(1e-3),
                "{d}"
            );
        }
    }

    #[test]
    fn report_units() {
        assert!(
            (Unit::RadPerSecond.report_factor() * PaperPriors::paper().gyro_bias - 0.5).abs()
                < 1e-12
        );
        assert!(
            (Unit::SmallAngle.report_factor() * PaperPriors::paper().accel_misalignment - 3.0)
                .abs()
                < 1e-12
        );
    }
}
