//! Candidate error terms beyond the paper's model (issue 10): effects a real unit may show that
//! the paper's four terms do not describe. Each is an [`ErrorTerm`] like the paper's (parameters
//! with names, units and prior sigma; `error()` for the truth simulator; `jacobian()` for the
//! filter), except the gyro bias drift, which is not a constant error but process noise on the
//! gyro-bias states (a model option, see [`Candidate::GyroBiasDrift`]).
//!
//! Sign conventions as everywhere: gyro output `w' = w - nu`, accelerometer output
//! `f' = f + df`; a gyro term contributes to `nu`, an accelerometer term to `df`. SI inside.
//!
//! | id | parameters | unit | effect | default prior |
//! | --- | --- | --- | --- | --- |
//! | `gyro_g_sensitivity` | `gyro.gsens.<ij>` (9) | rad/s per m/s^2 | `nu_i += G_ij f_j` | 1e-6 |
//! | `gyro_scale_asymmetry` | `gyro.asym.<i>` (3) | - | `nu_i += a_i abs(w_i)` | 1e-5 |
//! | `accel_quadratic` | `accel.k2.<i>` (3) | 1/(m/s^2) | `df_i += k2_i f_i^2` | 1e-5 |
//! | `accel_size_effect` | `accel.lever.<i><j>` (9) | m | `df_i += (dw/dt x r_i + w x (w x r_i))_i` | 0.02 |
//! | `gyro_bias_drift` | `gyro.drift.<i>` (3, not states) | rad/s/sqrt(s) | `d(nu0_i)/dt` white, PSD `drift_i^2` | 0.1 deg/h/sqrt(h) |
//! | `gyro_accel_time_offset` | `time.gyro_accel` (1) | s | `f'(t) = f(t - d)`: `df -= d df/dt` | 1e-3 |
//! | `gyro_temp_bias` | `gyro.tbias.<i>` (3) | rad/s/K | `nu_i += b_i dT` | 0.01 deg/h/K |
//! | `accel_temp_bias` | `accel.tbias.<i>` (3) | m/s^2/K | `df_i += a_i dT` | 1e-4 m/s^2/K |
//! | `gyro_temp_scale` | `gyro.tscale.<i>` (3) | 1/K | `nu_i += s_i dT w_i` | 1e-5 /K |
//! | `accel_temp_scale` | `accel.tscale.<i>` (3) | 1/K | `df_i += s_i dT f_i` | 5e-5 /K |
//!
//! `dT` is [`SensorInput::temp_delta`], the unit's temperature less the reference temperature of
//! the run (the thermal terms' parameters are coefficients about it; the paper's biases and
//! scale factors are then their values at the reference).

use crate::names;
use crate::terms::{AxisColumn, ErrorTerm, Feature, ParamSpec, Sensor, SensorInput, Unit};
use nalgebra::{Matrix3, Vector3};

const AXES: [&str; 3] = ["x", "y", "z"];

/// The grade of a unit, which sets the priors of the candidate terms
/// ([`Candidate::prior_sigma`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnitGrade {
    /// Gyro biases up to 1 deg/h (ring lasers, navigation FOGs; the paper's unit).
    Navigation,
    /// Gyro biases up to 100 deg/h (tactical FOGs and MEMS).
    Tactical,
    /// Gyro biases above 100 deg/h (consumer and industrial MEMS).
    Consumer,
}

impl UnitGrade {
    /// The grade whose gyro biases are of the order of `sigma` (rad/s), the prior sigma of the
    /// gyro biases a configuration gives.
    pub fn from_gyro_bias_prior(sigma: f64) -> Self {
        let deg_h = sigma * 3600.0 * 180.0 / std::f64::consts::PI;
        if deg_h <= 1.0 {
            UnitGrade::Navigation
        } else if deg_h <= 100.0 {
            UnitGrade::Tactical
        } else {
            UnitGrade::Consumer
        }
    }

    /// Lower-case name for reports.
    pub fn name(self) -> &'static str {
        match self {
            UnitGrade::Navigation => "navigation",
            UnitGrade::Tactical => "tactical",
            UnitGrade::Consumer => "consumer",
        }
    }
}

/// A candidate extension of the paper's model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Candidate {
    /// Gyro error proportional to the specific force (full 3x3), [`GyroGSensitivity`].
    GyroGSensitivity,
    /// Gyro scale-factor error that differs for positive and negative rates,
    /// [`GyroScaleAsymmetry`].
    GyroScaleAsymmetry,
    /// Accelerometer error quadratic in the specific force along its axis, [`AccelQuadratic`].
    AccelQuadratic,
    /// Offsets of the accelerometers from the common point (size effect), [`AccelSizeEffect`].
    AccelSizeEffect,
    /// Random walk of the gyro biases: process noise of intensity `drift_i^2` on the states
    /// `gyro.bias.i`. Not a term (no constant parameters): [`Candidate::term`] gives `None`.
    GyroBiasDrift,
    /// The accelerometers sample late against the gyros, [`GyroAccelTimeOffset`].
    GyroAccelTimeOffset,
    /// Gyro biases that change with temperature, [`TempBias`].
    GyroTempBias,
    /// Accelerometer biases that change with temperature, [`TempBias`].
    AccelTempBias,
    /// Gyro scale factors that change with temperature, [`TempScale`].
    GyroTempScale,
    /// Accelerometer scale factors that change with temperature, [`TempScale`].
    AccelTempScale,
}

impl Candidate {
    /// Every candidate, in the order of the issue.
    pub const ALL: [Candidate; 10] = [
        Candidate::GyroGSensitivity,
        Candidate::GyroScaleAsymmetry,
        Candidate::AccelQuadratic,
        Candidate::AccelSizeEffect,
        Candidate::GyroBiasDrift,
        Candidate::GyroAccelTimeOffset,
        Candidate::GyroTempBias,
        Candidate::AccelTempBias,
        Candidate::GyroTempScale,
        Candidate::AccelTempScale,
    ];

    /// The thermal candidates: their effect is proportional to the temperature's departure from
    /// the reference, so only a recording with a temperature column that moves can show them.
    pub const THERMAL: [Candidate; 4] = [
        Candidate::GyroTempBias,
        Candidate::AccelTempBias,
        Candidate::GyroTempScale,
        Candidate::AccelTempScale,
    ];

    /// Whether the candidate's effect scales with the temperature ([`Candidate::THERMAL`]).
    pub fn is_thermal(self) -> bool {
        Self::THERMAL.contains(&self)
    }

    /// The candidate's id (fixed by the issue).
    pub fn id(self) -> &'static str {
        match self {
            Candidate::GyroGSensitivity => "gyro_g_sensitivity",
            Candidate::GyroScaleAsymmetry => "gyro_scale_asymmetry",
            Candidate::AccelQuadratic => "accel_quadratic",
            Candidate::AccelSizeEffect => "accel_size_effect",
            Candidate::GyroBiasDrift => "gyro_bias_drift",
            Candidate::GyroAccelTimeOffset => "gyro_accel_time_offset",
            Candidate::GyroTempBias => "gyro_temp_bias",
            Candidate::AccelTempBias => "accel_temp_bias",
            Candidate::GyroTempScale => "gyro_temp_scale",
            Candidate::AccelTempScale => "accel_temp_scale",
        }
    }

    /// The candidate with id `id`.
    pub fn from_id(id: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.id() == id)
    }

    /// Names of the candidate's parameters (for the drift: of its three intensities, which are
    /// not states).
    pub fn param_names(self) -> Vec<String> {
        let per_axis = |prefix: &str| AXES.iter().map(|a| format!("{prefix}{a}")).collect();
        let pairs = |prefix: &str| {
            AXES.iter()
                .flat_map(|a| AXES.iter().map(move |b| format!("{prefix}{a}{b}")))
                .collect()
        };
        match self {
            Candidate::GyroGSensitivity => pairs(names::GYRO_GSENS_PREFIX),
            Candidate::GyroScaleAsymmetry => per_axis(names::GYRO_ASYM_PREFIX),
            Candidate::AccelQuadratic => per_axis(names::ACCEL_K2_PREFIX),
            Candidate::AccelSizeEffect => pairs(names::ACCEL_LEVER_PREFIX),
            Candidate::GyroBiasDrift => names::GYRO_DRIFT.iter().map(|s| s.to_string()).collect(),
            Candidate::GyroAccelTimeOffset => vec![names::TIME_GYRO_ACCEL.to_string()],
            Candidate::GyroTempBias => per_axis(names::GYRO_TBIAS_PREFIX),
            Candidate::AccelTempBias => per_axis(names::ACCEL_TBIAS_PREFIX),
            Candidate::GyroTempScale => per_axis(names::GYRO_TSCALE_PREFIX),
            Candidate::AccelTempScale => per_axis(names::ACCEL_TSCALE_PREFIX),
        }
    }

    /// Unit of the candidate's parameters (SI inside).
    pub fn unit(self) -> Unit {
        match self {
            Candidate::GyroGSensitivity => Unit::RadPerSecondPerMeterPerSecond2,
            Candidate::GyroScaleAsymmetry => Unit::Ratio,
            Candidate::AccelQuadratic => Unit::PerMeterPerSecond2,
            Candidate::AccelSizeEffect => Unit::Meter,
            Candidate::GyroBiasDrift => Unit::RadPerSecondPerSqrtSecond,
            Candidate::GyroAccelTimeOffset => Unit::Second,
            Candidate::GyroTempBias => Unit::RadPerSecondPerKelvin,
            Candidate::AccelTempBias => Unit::MeterPerSecond2PerKelvin,
            Candidate::GyroTempScale | Candidate::AccelTempScale => Unit::PerKelvin,
        }
    }

    /// The sensor triad the candidate corrupts.
    pub fn sensor(self) -> Sensor {
        match self {
            Candidate::GyroGSensitivity
            | Candidate::GyroScaleAsymmetry
            | Candidate::GyroBiasDrift
            | Candidate::GyroTempBias
            | Candidate::GyroTempScale => Sensor::Gyro,
            Candidate::AccelQuadratic
            | Candidate::AccelSizeEffect
            | Candidate::GyroAccelTimeOffset
            | Candidate::AccelTempBias
            | Candidate::AccelTempScale => Sensor::Accel,
        }
    }

    /// Default prior sigma (SI), magnitudes typical of tactical- to navigation-grade units:
    /// - g-sensitivity 1e-6 rad/s per m/s^2 (2 deg/h/g: dynamically tuned gyros and FOGs of
    ///   that class quote 0.1 to 10 deg/h/g; ring lasers much less);
    /// - scale asymmetry 1e-5 (10 ppm: RLG/FOG data sheets give 1 to 50 ppm);
    /// - quadratic 1e-5 per m/s^2 (1e-4/g, 100 micro-g/g^2: pendulous quartz accelerometers
    ///   quote 10 to 100 micro-g/g^2 uncompensated);
    /// - size effect 0.02 m (offset of each accelerometer's proof mass from the common point in
    ///   a navigation-grade cluster of pendulous accelerometers: centimetres);
    /// - time offset 1e-3 s (a sample at 1 kHz, or the group delay difference of the two
    ///   channels' anti-alias filters);
    /// - drift: not a prior but the default random-walk intensity, 0.1 deg/h/sqrt(h)
    ///   (between navigation grade, 0.001 to 0.01, and tactical grade, about 1);
    /// - gyro bias temperature coefficient 0.01 deg/h/K (navigation FOGs and RLGs quote 0.001 to
    ///   0.01 deg/h/K after their own compensation, several times that before it);
    /// - accelerometer bias temperature coefficient 1e-4 m/s^2/K (10 micro-g/K: quartz
    ///   pendulous accelerometers 5 to 50 micro-g/K uncompensated);
    /// - scale-factor temperature coefficients 10 ppm/K (gyros) and 50 ppm/K (accelerometers;
    ///   quartz pendulous 100 to 200 ppm/K before their own compensation).
    pub fn default_prior_sigma(self) -> f64 {
        match self {
            Candidate::GyroTempBias => 0.01 / Unit::RadPerSecondPerKelvin.report_factor(),
            Candidate::AccelTempBias => 1e-4,
            Candidate::GyroTempScale => 1e-5,
            Candidate::AccelTempScale => 5e-5,
            Candidate::GyroGSensitivity => 1e-6,
            Candidate::GyroScaleAsymmetry => 1e-5,
            Candidate::AccelQuadratic => 1e-5,
            Candidate::AccelSizeEffect => 0.02,
            Candidate::GyroBiasDrift => 0.1 / Unit::RadPerSecondPerSqrtSecond.report_factor(),
            Candidate::GyroAccelTimeOffset => 1e-3,
        }
    }

    /// Prior sigma (SI) of the term for a unit of `grade`: the navigation grade's is
    /// [`Candidate::default_prior_sigma`]; the others are the upper ends of what
    /// [`Candidate::typical`] quotes for the grade (a wide prior costs a term little; one too
    /// narrow leaves it "not observed" where the data show it plainly: a consumer unit's
    /// g-sensitivity of 0.05 deg/s/g against a prior of 2 deg/h/g).
    ///
    /// | id | navigation | tactical | consumer |
    /// | --- | --- | --- | --- |
    /// | `gyro_g_sensitivity` (rad/s per m/s^2) | 1e-6 | 1e-5 (20 deg/h/g) | 1.75e-4 (0.1 deg/s/g) |
    /// | `gyro_scale_asymmetry` | 1e-5 | 1e-3 | 1e-2 |
    /// | `accel_quadratic` (1/(m/s^2)) | 1e-5 | 2e-5 (200 micro-g/g^2) | 1e-4 (1000 micro-g/g^2) |
    /// | `accel_size_effect` (m) | 0.02 | 0.02 | 0.02 |
    /// | `gyro_bias_drift` (deg/h/sqrt(h)) | 0.1 | 1 | 10 |
    /// | `gyro_accel_time_offset` (s) | 1e-3 | 1e-3 | 1e-2 (a sample at 100 Hz) |
    /// | `gyro_temp_bias` (deg/h/K) | 0.01 | 1 | 36 (0.01 deg/s/K) |
    /// | `accel_temp_bias` (m/s^2/K) | 1e-4 | 5e-4 (50 micro-g/K) | 5e-3 (0.5 mg/K) |
    /// | `gyro_temp_scale` (ppm/K) | 10 | 100 | 500 |
    /// | `accel_temp_scale` (ppm/K) | 50 | 200 | 500 |
    pub fn prior_sigma(self, grade: UnitGrade) -> f64 {
        let deg = std::f64::consts::PI / 180.0;
        let walk = 1.0 / Unit::RadPerSecondPerSqrtSecond.report_factor();
        match (grade, self) {
            (UnitGrade::Navigation, _) => self.default_prior_sigma(),
            (UnitGrade::Tactical, Candidate::GyroGSensitivity) => 1e-5,
            (UnitGrade::Tactical, Candidate::GyroScaleAsymmetry) => 1e-3,
            (UnitGrade::Tactical, Candidate::AccelQuadratic) => 2e-5,
            (UnitGrade::Tactical, Candidate::GyroBiasDrift) => walk,
            (UnitGrade::Consumer, Candidate::GyroGSensitivity) => 0.1 * deg / 9.80665,
            (UnitGrade::Consumer, Candidate::GyroScaleAsymmetry) => 1e-2,
            (UnitGrade::Consumer, Candidate::AccelQuadratic) => 1e-4,
            (UnitGrade::Consumer, Candidate::GyroBiasDrift) => 10.0 * walk,
            (UnitGrade::Consumer, Candidate::GyroAccelTimeOffset) => 1e-2,
            (UnitGrade::Tactical, Candidate::GyroTempBias) => {
                1.0 / Unit::RadPerSecondPerKelvin.report_factor()
            }
            (UnitGrade::Consumer, Candidate::GyroTempBias) => {
                36.0 / Unit::RadPerSecondPerKelvin.report_factor()
            }
            (UnitGrade::Tactical, Candidate::AccelTempBias) => 5e-4,
            (UnitGrade::Consumer, Candidate::AccelTempBias) => 5e-3,
            (UnitGrade::Tactical, Candidate::GyroTempScale) => 1e-4,
            (UnitGrade::Consumer, Candidate::GyroTempScale) => 5e-4,
            (UnitGrade::Tactical, Candidate::AccelTempScale) => 2e-4,
            (UnitGrade::Consumer, Candidate::AccelTempScale) => 5e-4,
            (_, Candidate::AccelSizeEffect | Candidate::GyroAccelTimeOffset) => {
                self.default_prior_sigma()
            }
        }
    }

    /// Typical magnitudes of the term by grade of unit, with where they come from, for reports
    /// that set an estimate against them (the same sources as [`Candidate::default_prior_sigma`]).
    pub fn typical(self) -> &'static str {
        match self {
            Candidate::GyroGSensitivity => {
                "ring lasers well below 0.1 deg/h/g; dynamically tuned gyros and FOGs 0.1 to 10 \
                 deg/h/g (5e-8 to 5e-6 rad/s per m/s^2); MEMS gyros 0.01 to 0.1 deg/s/g \
                 (data sheets)"
            }
            Candidate::GyroScaleAsymmetry => {
                "RLG/FOG data sheets 1 to 50 ppm; tactical MEMS 100 to 1000 ppm"
            }
            Candidate::AccelQuadratic => {
                "pendulous quartz accelerometers 10 to 100 micro-g/g^2 uncompensated (1e-6 to \
                 1e-5 per m/s^2); tactical MEMS about 200 micro-g/g^2 (2e-5 per m/s^2)"
            }
            Candidate::AccelSizeEffect => {
                "proof-mass offsets of a few centimetres in a navigation-grade cluster; \
                 millimetres in a MEMS package"
            }
            Candidate::GyroBiasDrift => {
                "navigation grade 0.001 to 0.01 deg/h/sqrt(h); tactical about 0.1 to 1; \
                 consumer MEMS tens"
            }
            Candidate::GyroAccelTimeOffset => {
                "a sample at the output rate (1 ms at 1 kHz) or the group-delay difference of \
                 the two channels' anti-alias filters"
            }
            Candidate::GyroTempBias => {
                "navigation FOGs and RLGs 0.001 to 0.01 deg/h/K after their own compensation; \
                 tactical FOGs and MEMS 0.1 to 1 deg/h/K; consumer MEMS 0.001 to 0.01 deg/s/K \
                 (data sheets)"
            }
            Candidate::AccelTempBias => {
                "quartz pendulous accelerometers 5 to 50 micro-g/K uncompensated; MEMS 0.1 to \
                 0.5 mg/K (data sheets)"
            }
            Candidate::GyroTempScale => {
                "navigation gyros a few ppm/K; MEMS gyros 100 to 500 ppm/K (data sheets)"
            }
            Candidate::AccelTempScale => {
                "quartz pendulous accelerometers 100 to 200 ppm/K before their own \
                 compensation; MEMS 100 to 500 ppm/K (data sheets)"
            }
        }
    }

    /// The candidate's error term with `prior_sigma` on every parameter; `None` for the drift,
    /// which is process noise, not a term.
    pub fn term(self, prior_sigma: f64) -> Option<Box<dyn ErrorTerm>> {
        let specs = |c: Candidate| {
            c.param_names()
                .into_iter()
                .map(|n| ParamSpec::new(n, c.unit(), prior_sigma))
                .collect::<Vec<_>>()
        };
        let params = specs(self);
        Some(match self {
            Candidate::GyroGSensitivity => Box::new(GyroGSensitivity { params }),
            Candidate::GyroScaleAsymmetry => Box::new(GyroScaleAsymmetry { params }),
            Candidate::AccelQuadratic => Box::new(AccelQuadratic { params }),
            Candidate::AccelSizeEffect => Box::new(AccelSizeEffect { params }),
            Candidate::GyroAccelTimeOffset => Box::new(GyroAccelTimeOffset { params }),
            Candidate::GyroTempBias | Candidate::AccelTempBias => Box::new(TempBias {
                sensor: self.sensor(),
                params,
            }),
            Candidate::GyroTempScale | Candidate::AccelTempScale => Box::new(TempScale {
                sensor: self.sensor(),
                params,
            }),
            Candidate::GyroBiasDrift => return None,
        })
    }
}

/// Gyro g-sensitivity, full 3x3 `G` (row-major parameters `gyro.gsens.xx, .xy, ...`; `xy` is the
/// effect on gyro x of the specific force along y): `nu += G f_body`. Affine in the input.
#[derive(Clone, Debug)]
pub struct GyroGSensitivity {
    params: Vec<ParamSpec>,
}

impl ErrorTerm for GyroGSensitivity {
    fn is_affine(&self) -> bool {
        true
    }
    fn sensor(&self) -> Sensor {
        Sensor::Gyro
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        Matrix3::from_row_slice(&p[..9]) * input.f_body
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let f = input.f_body;
        for i in 0..3 {
            for j in 0..3 {
                let mut col = Vector3::zeros();
                col[i] = f[j];
                out[3 * i + j] = col;
            }
        }
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some(
            (0..9)
                .map(|k| AxisColumn::new(k / 3, Feature::Force(k % 3)))
                .collect(),
        )
    }
}

/// Gyro scale-factor asymmetry (`gyro.asym.x, .y, .z`): the scale-factor error is `Theta_ii +
/// a_i` for positive and `Theta_ii - a_i` for negative rates, `nu_i += a_i abs(w_i)`.
#[derive(Clone, Debug)]
pub struct GyroScaleAsymmetry {
    params: Vec<ParamSpec>,
}

impl ErrorTerm for GyroScaleAsymmetry {
    fn is_affine_in_orthant(&self) -> bool {
        true
    }
    fn sensor(&self) -> Sensor {
        Sensor::Gyro
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let w = input.omega_body;
        Vector3::new(p[0] * w.x.abs(), p[1] * w.y.abs(), p[2] * w.z.abs())
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let w = input.omega_body;
        out[0] = Vector3::new(w.x.abs(), 0.0, 0.0);
        out[1] = Vector3::new(0.0, w.y.abs(), 0.0);
        out[2] = Vector3::new(0.0, 0.0, w.z.abs());
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some(
            (0..3)
                .map(|k| AxisColumn::new(k, Feature::AbsOmega(k)))
                .collect(),
        )
    }
}

/// Accelerometer second-order nonlinearity (`accel.k2.x, .y, .z`): `df_i += k2_i f_i^2`.
#[derive(Clone, Debug)]
pub struct AccelQuadratic {
    params: Vec<ParamSpec>,
}

impl ErrorTerm for AccelQuadratic {
    fn sensor(&self) -> Sensor {
        Sensor::Accel
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let f = input.f_body;
        Vector3::new(p[0] * f.x * f.x, p[1] * f.y * f.y, p[2] * f.z * f.z)
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let f = input.f_body;
        out[0] = Vector3::new(f.x * f.x, 0.0, 0.0);
        out[1] = Vector3::new(0.0, f.y * f.y, 0.0);
        out[2] = Vector3::new(0.0, 0.0, f.z * f.z);
    }
}

/// Size effect: accelerometer `i` sits at `r_i` from the common point (the point whose specific
/// force `f` the unit reports, and the rotation centre of the turntable), parameters
/// `accel.lever.<i><j>` = component `j` of `r_i`. It senses component `i` of
/// `f + dw/dt x r_i + w x (w x r_i)`, so `df_i += e_i . (M r_i)` with
/// `M = skew(dw/dt) + skew(w)^2`. The tangential part is linear in `dw/dt` (the contract of
/// [`SensorInput`]).
#[derive(Clone, Debug)]
pub struct AccelSizeEffect {
    params: Vec<ParamSpec>,
}

impl AccelSizeEffect {
    /// `M = skew(dw/dt) + skew(w)^2`: `M r = dw/dt x r + w x (w x r)`.
    fn lever_matrix(input: &SensorInput) -> Matrix3<f64> {
        let sw = input.omega_body.cross_matrix();
        input.omega_dot_body.cross_matrix() + sw * sw
    }
}

impl ErrorTerm for AccelSizeEffect {
    fn uses_rate_derivatives(&self) -> bool {
        true
    }
    fn sensor(&self) -> Sensor {
        Sensor::Accel
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let m = Self::lever_matrix(input);
        Vector3::from_fn(|i, _| (0..3).map(|j| m[(i, j)] * p[3 * i + j]).sum())
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let m = Self::lever_matrix(input);
        for i in 0..3 {
            for j in 0..3 {
                let mut col = Vector3::zeros();
                col[i] = m[(i, j)];
                out[3 * i + j] = col;
            }
        }
    }
}

/// The accelerometers sample `d` seconds late against the gyros (`time.gyro_accel`):
/// `f'(t) = f(t - d)`, to first order `df = -d df/dt` (body-axis derivative).
#[derive(Clone, Debug)]
pub struct GyroAccelTimeOffset {
    params: Vec<ParamSpec>,
}

impl ErrorTerm for GyroAccelTimeOffset {
    fn uses_rate_derivatives(&self) -> bool {
        true
    }
    fn sensor(&self) -> Sensor {
        Sensor::Accel
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        -input.f_dot_body * p[0]
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        out[0] = -input.f_dot_body;
    }
}

/// Biases that change linearly with temperature (`gyro.tbias.<i>` or `accel.tbias.<i>`):
/// `e_i += b_i dT`, `dT` = [`SensorInput::temp_delta`]. Affine in the rate and force for a fixed
/// temperature but not for a fixed set of parameters, so not [`ErrorTerm::is_affine`].
#[derive(Clone, Debug)]
pub struct TempBias {
    sensor: Sensor,
    params: Vec<ParamSpec>,
}

impl ErrorTerm for TempBias {
    fn sensor(&self) -> Sensor {
        self.sensor
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        Vector3::new(p[0], p[1], p[2]) * input.temp_delta
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let d = input.temp_delta;
        out[0] = Vector3::new(d, 0.0, 0.0);
        out[1] = Vector3::new(0.0, d, 0.0);
        out[2] = Vector3::new(0.0, 0.0, d);
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        Some((0..3).map(|k| AxisColumn::new(k, Feature::Temp)).collect())
    }
}

/// Scale factors that change linearly with temperature (`gyro.tscale.<i>` or
/// `accel.tscale.<i>`): `e_i += s_i dT x_i`, `x` the body rate (gyros) or specific force
/// (accelerometers).
#[derive(Clone, Debug)]
pub struct TempScale {
    sensor: Sensor,
    params: Vec<ParamSpec>,
}

impl TempScale {
    fn input_of(&self, input: &SensorInput) -> Vector3<f64> {
        match self.sensor {
            Sensor::Gyro => input.omega_body,
            Sensor::Accel => input.f_body,
        }
    }
}

impl ErrorTerm for TempScale {
    fn sensor(&self) -> Sensor {
        self.sensor
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        let x = self.input_of(input) * input.temp_delta;
        Vector3::new(p[0] * x.x, p[1] * x.y, p[2] * x.z)
    }
    fn jacobian(&self, _p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        let x = self.input_of(input) * input.temp_delta;
        out[0] = Vector3::new(x.x, 0.0, 0.0);
        out[1] = Vector3::new(0.0, x.y, 0.0);
        out[2] = Vector3::new(0.0, 0.0, x.z);
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        let feature = |k| match self.sensor {
            Sensor::Gyro => Feature::TempOmega(k),
            Sensor::Accel => Feature::TempForce(k),
        };
        Some((0..3).map(|k| AxisColumn::new(k, feature(k))).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_orthant_form_of_a_model_with_asymmetry_is_its_error() {
        let mut m = crate::terms::ErrorModel::paper(&crate::terms::PaperPriors::paper());
        m.push(Candidate::GyroScaleAsymmetry.term(1e-2).expect("a term"));
        m.push(Candidate::GyroGSensitivity.term(1e-4).expect("a term"));
        let p: Vec<f64> = (0..m.n_params()).map(|i| 1e-3 * (i as f64 - 7.3)).collect();
        let x = input();
        let signs = x.omega_body.map(f64::signum);
        assert!(m.affine(Sensor::Gyro, &p).is_none());
        let a = m
            .affine_in_orthant(Sensor::Gyro, &p, &signs)
            .expect("orthant-affine");
        let d = a.at(&x) - m.error(Sensor::Gyro, &p, &x);
        assert!(d.norm() < 1e-15, "{d}");
        // Another orthant gives another form, exact there.
        let mut y = x;
        y.omega_body.x = -y.omega_body.x;
        let b = m
            .affine_in_orthant(Sensor::Gyro, &p, &y.omega_body.map(f64::signum))
            .expect("orthant-affine");
        assert!((b.at(&y) - m.error(Sensor::Gyro, &p, &y)).norm() < 1e-15);
        assert!((a.at(&y) - m.error(Sensor::Gyro, &p, &y)).norm() > 1e-6);
    }

    #[test]
    fn grades_follow_the_gyro_bias_prior_and_navigation_keeps_the_defaults() {
        let deg_h = std::f64::consts::PI / 180.0 / 3600.0;
        assert_eq!(
            UnitGrade::from_gyro_bias_prior(0.5 * deg_h),
            UnitGrade::Navigation
        );
        assert_eq!(
            UnitGrade::from_gyro_bias_prior(10.0 * deg_h),
            UnitGrade::Tactical
        );
        assert_eq!(
            UnitGrade::from_gyro_bias_prior(3600.0 * deg_h),
            UnitGrade::Consumer
        );
        for c in Candidate::ALL {
            assert_eq!(
                c.prior_sigma(UnitGrade::Navigation),
                c.default_prior_sigma()
            );
            // Wider for a lesser grade, never narrower.
            let (n, t, k) = (
                c.prior_sigma(UnitGrade::Navigation),
                c.prior_sigma(UnitGrade::Tactical),
                c.prior_sigma(UnitGrade::Consumer),
            );
            assert!(n <= t && t <= k, "{c:?}: {n} {t} {k}");
        }
        // 0.1 deg/s/g in rad/s per m/s^2.
        let g = Candidate::GyroGSensitivity.prior_sigma(UnitGrade::Consumer);
        assert!((g * 9.80665 * 180.0 / std::f64::consts::PI - 0.1).abs() < 1e-12);
    }
    use crate::terms::ErrorModel;

    fn input() -> SensorInput {
        SensorInput {
            omega_body: Vector3::new(0.17, -0.02, 0.05),
            f_body: Vector3::new(1.2, -3.4, 8.9),
            omega_dot_body: Vector3::new(0.3, 0.7, -0.4),
            f_dot_body: Vector3::new(-0.8, 1.1, 0.2),
            temp_delta: 7.5,
        }
    }

    fn terms() -> Vec<(Candidate, Box<dyn ErrorTerm>)> {
        Candidate::ALL
            .into_iter()
            .filter_map(|c| c.term(c.default_prior_sigma()).map(|t| (c, t)))
            .collect()
    }

    /// Every candidate term's Jacobian equals central finite differences of its effect, at
    /// parameters of the size of its prior.
    #[test]
    fn jacobians_match_finite_differences() {
        let inp = input();
        for (c, t) in terms() {
            let n = t.params().len();
            let s = c.default_prior_sigma();
            let p: Vec<f64> = (0..n).map(|i| s * (1.0 + i as f64 * 0.7).sin()).collect();
            let mut jac = vec![Vector3::zeros(); n];
            t.jacobian(&p, &inp, &mut jac);
            for k in 0..n {
                let h = 1e-3 * s;
                let (mut pp, mut pm) = (p.clone(), p.clone());
                pp[k] += h;
                pm[k] -= h;
                let fd = (t.error(&pp, &inp) - t.error(&pm, &inp)) / (2.0 * h);
                let tol = 1e-9 * jac[k].norm().max(1.0);
                assert!(
                    (fd - jac[k]).norm() < tol,
                    "{} parameter {k}: fd {fd:?} vs jacobian {:?}",
                    c.id(),
                    jac[k]
                );
            }
        }
    }

    #[test]
    fn ids_names_and_terms_are_consistent() {
        for c in Candidate::ALL {
            assert_eq!(Candidate::from_id(c.id()), Some(c));
            let names = c.param_names();
            match c.term(1.0) {
                Some(t) => {
                    let got: Vec<String> = t.params().iter().map(|p| p.name.clone()).collect();
                    assert_eq!(got, names, "{}", c.id());
                    assert!(t.params().iter().all(|p| p.unit == c.unit()));
                    assert_eq!(t.sensor(), c.sensor());
                }
                None => assert_eq!(c, Candidate::GyroBiasDrift),
            }
        }
        assert_eq!(Candidate::from_id("nonsense"), None);
        let g = Candidate::GyroGSensitivity.param_names();
        assert_eq!(g[1], "gyro.gsens.xy");
        assert_eq!(
            Candidate::AccelSizeEffect.param_names()[5],
            "accel.lever.yz"
        );
        assert_eq!(Candidate::AccelQuadratic.param_names()[2], "accel.k2.z");
        assert_eq!(
            Candidate::GyroAccelTimeOffset.param_names(),
            vec!["time.gyro_accel"]
        );
        assert_eq!(Candidate::GyroBiasDrift.param_names()[0], "gyro.drift.x");
        // 0.1 deg/h/sqrt(h) in SI.
        let d = Candidate::GyroBiasDrift.default_prior_sigma();
        assert!((d - 0.1 * crate::units::DEG_PER_HOUR / 60.0).abs() < 1e-20);
    }

    /// The effects are the formulas.
    #[test]
    fn effects_are_the_formulas() {
        let x = input();
        let g = Candidate::GyroGSensitivity.term(1.0).unwrap();
        let mut p = vec![0.0; 9];
        p[1] = 2e-6; // xy: gyro x, force along y
        assert!((g.error(&p, &x) - Vector3::new(2e-6 * x.f_body.y, 0.0, 0.0)).norm() < 1e-20);
        let a = Candidate::GyroScaleAsymmetry.term(1.0).unwrap();
        let e = a.error(&[1e-5, 2e-5, 3e-5], &x);
        assert!((e.y - 2e-5 * 0.02).abs() < 1e-20 && e.y > 0.0);
        let k = Candidate::AccelQuadratic.term(1.0).unwrap();
        let e = k.error(&[0.0, 0.0, 1e-5], &x);
        assert!((e.z - 1e-5 * 8.9 * 8.9).abs() < 1e-18);
        // Size effect: accelerometer y at r_y senses component y of the rigid-body formula.
        let s = Candidate::AccelSizeEffect.term(1.0).unwrap();
        let r_y = Vector3::new(0.01, -0.02, 0.03);
        let mut p = vec![0.0; 9];
        p[3..6].copy_from_slice(r_y.as_slice());
        let w = x.omega_body;
        let expect = x.omega_dot_body.cross(&r_y) + w.cross(&w.cross(&r_y));
        let e = s.error(&p, &x);
        assert!((e - Vector3::new(0.0, expect.y, 0.0)).norm() < 1e-15);
        let d = Candidate::GyroAccelTimeOffset.term(1.0).unwrap();
        assert!((d.error(&[1e-3], &x) + x.f_dot_body * 1e-3).norm() < 1e-18);
        // Thermal terms: coefficient times the temperature's departure from the reference.
        let b = Candidate::GyroTempBias.term(1.0).unwrap();
        let e = b.error(&[1e-7, 2e-7, 3e-7], &x);
        assert!((e - Vector3::new(1e-7, 2e-7, 3e-7) * 7.5).norm() < 1e-20);
        let s = Candidate::AccelTempScale.term(1.0).unwrap();
        let e = s.error(&[0.0, 0.0, 5e-5], &x);
        assert!((e.z - 5e-5 * 7.5 * 8.9).abs() < 1e-15 && e.x == 0.0);
        let s = Candidate::GyroTempScale.term(1.0).unwrap();
        let e = s.error(&[1e-5, 0.0, 0.0], &x);
        assert!((e.x - 1e-5 * 7.5 * 0.17).abs() < 1e-18);
        let cold = SensorInput {
            temp_delta: 0.0,
            ..x
        };
        for c in Candidate::THERMAL {
            let t = c.term(1.0).unwrap();
            assert_eq!(t.error(&[1.0; 3], &cold), Vector3::zeros(), "{}", c.id());
            assert!(c.is_thermal());
        }
    }

    /// Every term's error is zero at zero parameters, whatever the input: what lets
    /// [`ErrorModel::error`] and the affine forms skip an idle term.
    #[test]
    fn every_term_is_zero_at_zero_parameters() {
        let input = SensorInput {
            omega_body: Vector3::new(0.3, -1.2, 0.7),
            f_body: Vector3::new(2.0, -3.0, 9.0),
            omega_dot_body: Vector3::new(1.5, 0.2, -0.8),
            f_dot_body: Vector3::new(-0.4, 0.9, 0.1),
            temp_delta: 7.5,
        };
        let mut m = ErrorModel::paper(&crate::terms::PaperPriors::paper());
        for c in Candidate::ALL {
            if let Some(t) = c.term(1.0) {
                m.push(t);
            }
        }
        for t in m.terms() {
            let zero = vec![0.0; t.params().len()];
            assert_eq!(
                t.error(&zero, &input),
                Vector3::zeros(),
                "{:?}",
                t.params()[0].name
            );
        }
    }

    /// The derivative part of a model is integrated from the changes over an interval: for a
    /// rate that jumps, `integral of dw/dt = w(b) - w(a)`.
    #[test]
    fn derivative_part_comes_from_the_changes() {
        let mut m = ErrorModel::new();
        m.push(Candidate::AccelSizeEffect.term(0.02).unwrap());
        m.push(Candidate::GyroAccelTimeOffset.term(1e-3).unwrap());
        assert!(m.uses_rate_derivatives());
        let p: Vec<f64> = (0..10).map(|i| 0.01 * (i as f64 - 4.0)).collect();
        let (dw, df) = (Vector3::new(0.1, -0.2, 0.05), Vector3::new(0.3, 0.0, -0.1));
        let e = m.derivative_error_integral(Sensor::Accel, &p, &dw, &df);
        let r = |i: usize| Vector3::new(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
        let expect = Vector3::from_fn(|i, _| dw.cross(&r(i))[i]) - df * p[9];
        assert!((e - expect).norm() < 1e-15);
        assert_eq!(
            m.derivative_error_integral(Sensor::Gyro, &p, &dw, &df),
            Vector3::zeros()
        );
    }
}
