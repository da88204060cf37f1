//! The estimated instrument model inverted: raw IMU output in, corrected output out. The one
//! place the sensor models are solved for the true rate and specific force: the filter's pass
//! ([`Compensation`]), `apply` and the held-out figures of a hand-turned calibration
//! ([`Correction`] of the result file), and the coarse start of such a recording
//! ([`Correction::paper`]) all take it from here.
//!
//! A calibration estimates how the sensors corrupt the true rate `w` and specific force `f`
//! (`docs/formats.md`, "Correction"): `w' = w - nu`, `f' = f + df` with
//!
//! ```text
//! nu = nu0 + Theta w + G f + diag(a) |w|
//! df = df0 + Gamma f + diag(k2) (f o f) + s(w, dw/dt) - d df/dt
//! ```
//!
//! (`Theta` full, `Gamma` lower-triangular, and the extension terms of
//! [`sins_model::candidates`] where the result names them: g-sensitivity `G`, scale asymmetry `a`,
//! quadratic `k2`, size effect `s_i = e_i . ((skew(dw/dt) + skew(w)^2) r_i)`, time offset `d`).
//! A [`Correction`] solves these exactly for `w` and `f`:
//!
//! ```text
//! w = M_g (w' + b_g + G f + diag(a) |w|),                       M_g = (I - Theta)^-1, b_g = nu0
//! f = M_a (f' + b_a - diag(k2) (f o f) - s(w, dw/dt) + d df/dt), M_a = (I + Gamma)^-1, b_a = -df0
//! ```
//!
//! The linear part is the exact inverse (no first-order expansion). Terms that make the inverse
//! non-linear (scale asymmetry, quadratic, the size effect's `w x (w x r)`, and the
//! g-sensitivity, whose `f` is the corrected one) are solved by fixed-point iteration on both
//! triads together until the change is below 1e-15 of the values ([`FIXED_POINT_TOLERANCE`]).
//!
//! Result files of earlier versions (the batch fit that `calibrate --free-motion` ran before the
//! filter) fit the g-sensitivity on the *measured* specific force and the asymmetry on the
//! *measured* rate (`nu = nu0 + Theta w + G f' + diag(a) |w'|`); their block says so, and their
//! correction is `w = M_g (w' + b_g + G f' + diag(a) |w'|)`, linear in the unknown
//! ([`ExtensionInputs::Measured`]). Nothing in this program fits that form any more.
//!
//! The filter's pass inverts the same models ([`Compensation`]) on increments and on the terms
//! of its layout (the terms' own effects, as the simulator applies them), at every IMU step:
//! with affine terms in closed form, `x = n raw + m dt`; for errors of a per cent and more `n`
//! is the exact inverse, below that the three fixed-point passes the programmed results were
//! made with (`I + B + B^2 + B^3`, which differs from the exact inverse by `B^4`, 1e-12 of the
//! increment for the paper's errors: kept so that those results stay as they are to the last
//! digit). `compensation_and_correction_agree` tests the two against each other.
//!
//! Records: a rate record is the mean over its interval; an increment record is corrected as
//! its mean rate (`dth / dt`, `dv / dt`, `dt` the interval to the previous record's time stamp;
//! the first record takes the interval to the second) corrected and times `dt`. This is exact
//! for the terms linear in the rate and specific force; for the non-linear ones it neglects the
//! difference between the mean of the term over the interval and the term of the mean (e.g.
//! `k2 var(f)` over the interval; zero at rest and, for the asymmetry, while no rate changes
//! sign within the interval). The derivative terms (size effect's `dw/dt x r`, the time offset)
//! take `dw/dt` and `df/dt` from the neighbouring records' linearly corrected mean rates
//! ([`correct_records`]): a central difference, first order.

pub use crate::io::correction_block::{
    AccelBlock, CONVENTION_MEASURED, CONVENTION_TRUE, CorrectionBlock, ExtensionInputs, GyroBlock,
    ThermalBlock,
};
use crate::io::{ImuKind, ImuRecord, ResultParameter};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use sins_model::candidates::{Candidate, CorrectionPart, Solved, SolvedEffect, ThermalPart};
use sins_model::names;
use sins_model::terms::{AffineError, ErrorModel, GAMMA_INDEX, Sensor, SensorInput};

mod compensation;
pub use compensation::{CompensatedMeans, Compensation};

/// Relative change below which the fixed-point iteration stops.
pub const FIXED_POINT_TOLERANCE: f64 = 1e-15;

/// Iterations after which a fixed point that has not settled is an error.
const MAX_ITERATIONS: usize = 200;

/// Why a correction cannot be built or applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CorrectionError {
    /// A parameter the correction does not know.
    #[error(
        "parameter `{0}` is not an instrument parameter this program can correct: expected the \
         paper's (gyro.bias, gyro.theta, accel.bias, accel.gamma), the extension terms \
         ({solved}) or parameters that do not act on the sensor output (install.delta, \
         turntable.*, base.gamma, gyro.drift)",
        solved = solved_prefixes()
    )]
    Unknown(String),
    /// A required parameter, or one of a term's, is missing.
    #[error("{group}: parameter(s) {missing} missing: expected {expected}")]
    Incomplete {
        /// The group (`the paper's model`, or a term's id).
        group: String,
        /// The missing names.
        missing: String,
        /// What was expected.
        expected: String,
    },
    /// A parameter in a unit other than its SI unit.
    #[error(
        "parameter `{name}` is in `{unit}`: expected `{expected}` (result files hold SI values)"
    )]
    Unit {
        /// Parameter.
        name: String,
        /// Unit found.
        unit: String,
        /// SI unit expected.
        expected: String,
    },
    /// A parameter value is not a finite number.
    #[error("parameter `{0}`: expected a finite value")]
    NotFinite(String),
    /// A sensor matrix `I - Theta` or `I + Gamma` cannot be inverted.
    #[error("the {0} matrix cannot be inverted: expected scale factors well away from -1")]
    Singular(&'static str),
    /// The fixed-point iteration of the non-linear terms does not settle for a record.
    #[error(
        "the non-linear terms do not settle at w' = {gyro:?}, f' = {accel:?}: the extension \
         terms are too large for the record's rate and specific force"
    )]
    NoFixedPoint {
        /// Raw rate (rad/s).
        gyro: [f64; 3],
        /// Raw specific force (m/s^2).
        accel: [f64; 3],
    },
    /// A result with thermal terms but no reference temperature.
    #[error(
        "the result has temperature coefficients ({0}) but no reference temperature \
         (`temperature.reference_c`): they are coefficients about it"
    )]
    NoReferenceTemperature(String),
    /// A correction with thermal terms applied to a record without a temperature.
    #[error(
        "the calibration has temperature coefficients: expected a `temp` column (deg C) in the \
         records to correct"
    )]
    NoTemperature,
    /// Increments need an interval for the first record.
    #[error(
        "an increments file needs at least two records (the first record's interval is the one to the second)"
    )]
    TooFewRecords,
}

/// The parameter prefixes of the candidate terms the correction solves with the sensor
/// equations ([`CorrectionPart::Solved`]), for a message: `gyro.gsens, ..., time.gyro_accel`.
fn solved_prefixes() -> String {
    Candidate::ALL
        .into_iter()
        .filter(|c| matches!(c.declaration().correction, CorrectionPart::Solved(_)))
        .map(|c| c.declaration().params.prefix().trim_end_matches('.'))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The inverse of an estimated instrument model.
#[derive(Clone, Debug, PartialEq)]
pub struct Correction {
    /// `M_g = (I - Theta)^-1`.
    pub gyro_matrix: Matrix3<f64>,
    /// `b_g = nu0` (rad/s).
    pub gyro_offset: Vector3<f64>,
    /// `M_a = (I + Gamma)^-1`.
    pub accel_matrix: Matrix3<f64>,
    /// `b_a = -df0` (m/s^2).
    pub accel_offset: Vector3<f64>,
    /// The estimated candidate terms solved with the sensor equations
    /// ([`CorrectionPart::Solved`]: g-sensitivity, scale asymmetry, quadratic, size effect,
    /// time offset), in [`Candidate::ALL`] order.
    pub extension: Vec<ExtensionTerm>,
    /// What the gyro extension terms are evaluated at.
    pub extension_inputs: ExtensionInputs,
    /// The thermal terms, when estimated: the correction then depends on each record's
    /// temperature ([`Correction::at_temperature`]).
    pub thermal: Option<ThermalCorrection>,
}

/// A candidate term of a [`Correction`] with its values (SI, in its parameters' order).
#[derive(Clone, Debug, PartialEq)]
pub struct ExtensionTerm {
    /// The term.
    pub candidate: Candidate,
    /// Its parameters' values.
    pub values: Vec<f64>,
}

impl ExtensionTerm {
    /// Its part in the correction (the terms of [`Correction::extension`] are all solved).
    fn solved(&self) -> &'static Solved {
        match &self.candidate.declaration().correction {
            CorrectionPart::Solved(s) => s,
            CorrectionPart::None | CorrectionPart::Thermal(_) => {
                unreachable!("only solved terms are in a correction's extension")
            }
        }
    }
}

/// The temperature dependence of a [`Correction`]: at temperature `T` (deg C), with
/// `dT = T - reference_c`, the biases are `nu0 + tb_g dT` and `df0 + tb_a dT`, and the scale
/// factors `Theta_ii + ts_g,i dT` and `Gamma_ii + ts_a,i dT`.
#[derive(Clone, Debug, PartialEq)]
pub struct ThermalCorrection {
    /// The temperature the coefficients are about (deg C).
    pub reference_c: f64,
    /// Gyro bias coefficients `tb_g` (rad/s/K; zero when not estimated).
    pub gyro_bias: Vector3<f64>,
    /// Accelerometer bias coefficients `tb_a` (m/s^2/K).
    pub accel_bias: Vector3<f64>,
    /// Gyro scale-factor coefficients `ts_g` (1/K).
    pub gyro_scale: Vector3<f64>,
    /// Accelerometer scale-factor coefficients `ts_a` (1/K).
    pub accel_scale: Vector3<f64>,
    /// `I - Theta` before inversion: the scale coefficients change its diagonal.
    gyro_sensor: Matrix3<f64>,
    /// `I + Gamma` before inversion.
    accel_sensor: Matrix3<f64>,
}

impl ThermalCorrection {
    /// The thermal terms given (in [`Candidate::ALL`] order, with their coefficients) about
    /// `reference_c`, with the sensor matrices before inversion; `None` without any, refused
    /// without a reference.
    fn of(
        terms: &[(Candidate, Vector3<f64>)],
        reference_c: Option<f64>,
        gyro_sensor: Matrix3<f64>,
        accel_sensor: Matrix3<f64>,
    ) -> Result<Option<Self>, CorrectionError> {
        if terms.is_empty() {
            return Ok(None);
        }
        let given: Vec<&str> = terms.iter().map(|(c, _)| c.id()).collect();
        let reference_c = reference_c
            .filter(|t| t.is_finite())
            .ok_or_else(|| CorrectionError::NoReferenceTemperature(given.join(", ")))?;
        let mut th = Self {
            reference_c,
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            gyro_scale: Vector3::zeros(),
            accel_scale: Vector3::zeros(),
            gyro_sensor,
            accel_sensor,
        };
        for (c, v) in terms {
            let CorrectionPart::Thermal(part) = c.declaration().correction else {
                continue;
            };
            let slot = match (c.sensor(), part) {
                (Sensor::Gyro, ThermalPart::Bias) => &mut th.gyro_bias,
                (Sensor::Accel, ThermalPart::Bias) => &mut th.accel_bias,
                (Sensor::Gyro, ThermalPart::Scale) => &mut th.gyro_scale,
                (Sensor::Accel, ThermalPart::Scale) => &mut th.accel_scale,
            };
            *slot = *v;
        }
        Ok(Some(th))
    }
}

fn rows(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// Rows of a 3x3 matrix given row by row (nine values).
fn rows_of(values: &[f64]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| values[3 * i + j]))
}

/// Expected SI unit of every parameter the correction uses.
fn expected_unit(name: &str) -> Option<&'static str> {
    let paper = sins_model::terms::ErrorModel::paper(&sins_model::terms::PaperPriors::paper());
    if let Some(p) = paper.params().into_iter().find(|p| p.name == name) {
        return Some(p.unit.si_name());
    }
    Candidate::ALL
        .into_iter()
        .filter(|c| !matches!(c.declaration().correction, CorrectionPart::None))
        .find(|c| c.param_names().iter().any(|n| n == name))
        .map(|c| c.unit().si_name())
}

/// Whether a parameter does not act on the sensor output (turntable, mounting, drift intensity).
fn is_inert(name: &str) -> bool {
    name.starts_with(names::INSTALL_PREFIX)
        || name.starts_with(names::TURNTABLE_PREFIX)
        || name.starts_with(names::BASE_PREFIX)
        || names::GYRO_DRIFT.contains(&name)
}

impl Correction {
    /// The correction of the parameters of a result file (SI; names of `docs/formats.md`).
    /// The paper's 21 parameters are required; an extension term is used when any of its
    /// parameters is given, and then all of them must be. Parameters that do not act on the
    /// sensor output (`install.delta.*`, `turntable.*`, `base.gamma.*`, `gyro.drift.*`) are
    /// ignored; any other name is refused.
    pub fn from_parameters(
        parameters: &[ResultParameter],
        inputs: ExtensionInputs,
    ) -> Result<Self, CorrectionError> {
        Self::from_parameters_at(parameters, inputs, None)
    }

    /// The correction a result file's parameters make, with the extension terms evaluated as its
    /// `correction` block says (corrected values without one) and its thermal terms about its
    /// reference temperature: what `apply` applies.
    pub fn of_result(result: &crate::io::ResultFile) -> Result<Self, CorrectionError> {
        let inputs = result
            .correction
            .as_ref()
            .map_or(ExtensionInputs::True, |b| b.extension_inputs);
        let reference = result.temperature.as_ref().map(|t| t.reference_c);
        Self::from_parameters_at(&result.parameters, inputs, reference)
    }

    /// The correction of the paper's 21 parameters alone (`p` in the paper model's order: gyro
    /// bias, `Theta` row by row, accelerometer bias, `Gamma` in [`GAMMA_INDEX`] order; SI).
    pub fn paper(p: &[f64]) -> Result<Self, CorrectionError> {
        let (theta, gamma) = sensor_matrices(p);
        Ok(Self {
            gyro_matrix: invert(&theta).ok_or(CorrectionError::Singular("gyro I - Theta"))?,
            gyro_offset: Vector3::new(p[0], p[1], p[2]),
            accel_matrix: invert(&gamma)
                .ok_or(CorrectionError::Singular("accelerometer I + Gamma"))?,
            accel_offset: -Vector3::new(p[12], p[13], p[14]),
            extension: Vec::new(),
            extension_inputs: ExtensionInputs::True,
            thermal: None,
        })
    }

    /// [`Correction::from_parameters`] of a result whose thermal terms (if any) are about
    /// `reference_c` (deg C); thermal terms without a reference are refused.
    pub fn from_parameters_at(
        parameters: &[ResultParameter],
        inputs: ExtensionInputs,
        reference_c: Option<f64>,
    ) -> Result<Self, CorrectionError> {
        for p in parameters {
            if is_inert(&p.name) {
                continue;
            }
            let unit =
                expected_unit(&p.name).ok_or_else(|| CorrectionError::Unknown(p.name.clone()))?;
            if p.unit != unit {
                return Err(CorrectionError::Unit {
                    name: p.name.clone(),
                    unit: p.unit.clone(),
                    expected: unit.into(),
                });
            }
            if !p.value.is_finite() {
                return Err(CorrectionError::NotFinite(p.name.clone()));
            }
        }
        let value = |n: &str| parameters.iter().find(|p| p.name == n).map(|p| p.value);
        // All of a group, none of it (None), or an error naming the missing ones.
        let group = |group: &str,
                     list: &[String],
                     required: bool|
         -> Result<Option<Vec<f64>>, CorrectionError> {
            let got: Vec<Option<f64>> = list.iter().map(|n| value(n)).collect();
            if !required && got.iter().all(Option::is_none) {
                return Ok(None);
            }
            let missing: Vec<&str> = list
                .iter()
                .zip(&got)
                .filter(|(_, v)| v.is_none())
                .map(|(n, _)| n.as_str())
                .collect();
            if !missing.is_empty() {
                return Err(CorrectionError::Incomplete {
                    group: group.into(),
                    missing: missing.join(", "),
                    expected: format!("all of {}", list.join(", ")),
                });
            }
            Ok(Some(got.into_iter().flatten().collect()))
        };
        let paper: Vec<String> =
            sins_model::terms::ErrorModel::paper(&sins_model::terms::PaperPriors::paper())
                .params()
                .into_iter()
                .map(|p| p.name)
                .collect();
        let p = group("the paper's model", &paper, true)?.unwrap_or_default();
        let term = |c: Candidate| group(c.id(), &c.param_names(), false);
        let (theta, gamma) = sensor_matrices(&p);
        let gyro_matrix = invert(&theta).ok_or(CorrectionError::Singular("gyro I - Theta"))?;
        let accel_matrix =
            invert(&gamma).ok_or(CorrectionError::Singular("accelerometer I + Gamma"))?;
        // The thermal terms first, then the solved ones (the order their errors are found in).
        let of_part = |thermal: bool| {
            Candidate::ALL
                .into_iter()
                .filter(move |c| match c.declaration().correction {
                    CorrectionPart::None => false,
                    CorrectionPart::Thermal(_) => thermal,
                    CorrectionPart::Solved(_) => !thermal,
                })
        };
        let mut thermal_terms = Vec::new();
        for c in of_part(true) {
            if let Some(v) = term(c)? {
                thermal_terms.push((c, Vector3::from_column_slice(&v)));
            }
        }
        let thermal = ThermalCorrection::of(&thermal_terms, reference_c, theta, gamma)?;
        let mut extension = Vec::new();
        for candidate in of_part(false) {
            if let Some(values) = term(candidate)? {
                extension.push(ExtensionTerm { candidate, values });
            }
        }
        Ok(Self {
            gyro_matrix,
            gyro_offset: Vector3::new(p[0], p[1], p[2]),
            accel_matrix,
            accel_offset: -Vector3::new(p[12], p[13], p[14]),
            extension,
            extension_inputs: inputs,
            thermal,
        })
    }

    /// The correction at temperature `temp_c` (deg C): the thermal terms folded into the
    /// offsets and matrices (`None` for a correction without them, which holds at every
    /// temperature). A correction with thermal terms needs the temperature.
    pub fn at_temperature(&self, temp_c: Option<f64>) -> Result<Option<Self>, CorrectionError> {
        let Some(th) = &self.thermal else {
            return Ok(None);
        };
        let t = temp_c.ok_or(CorrectionError::NoTemperature)?;
        let d = t - th.reference_c;
        let gyro = th.gyro_sensor - Matrix3::from_diagonal(&(th.gyro_scale * d));
        let accel = th.accel_sensor + Matrix3::from_diagonal(&(th.accel_scale * d));
        Ok(Some(Self {
            gyro_matrix: invert(&gyro).ok_or(CorrectionError::Singular("gyro I - Theta(T)"))?,
            gyro_offset: self.gyro_offset + th.gyro_bias * d,
            accel_matrix: invert(&accel)
                .ok_or(CorrectionError::Singular("accelerometer I + Gamma(T)"))?,
            accel_offset: self.accel_offset - th.accel_bias * d,
            thermal: None,
            ..self.clone()
        }))
    }

    /// The values of candidate term `c`, when the correction has it.
    pub fn values(&self, c: Candidate) -> Option<&[f64]> {
        self.extension
            .iter()
            .find(|t| t.candidate == c)
            .map(|t| t.values.as_slice())
    }

    /// Whether the correction has candidate term `c` (a thermal one: [`Correction::thermal`]).
    pub fn has(&self, c: Candidate) -> bool {
        self.values(c).is_some()
    }

    /// Whether term `t` is evaluated at the measured values, once per record (the gyro terms
    /// of [`ExtensionInputs::Measured`]), not at the corrected ones.
    fn on_measured(&self, t: &ExtensionTerm) -> bool {
        self.extension_inputs == ExtensionInputs::Measured && t.candidate.sensor() == Sensor::Gyro
    }

    /// Whether the inverse needs the fixed-point iteration (a term not linear in the unknowns).
    pub fn is_nonlinear(&self) -> bool {
        self.extension.iter().any(|t| {
            let affine = t
                .candidate
                .declaration()
                .effect
                .is_some_and(|e| e.is_affine());
            !affine && !t.solved().derivatives_only && !self.on_measured(t)
        })
    }

    /// Whether the correction uses the rate derivatives (size effect, time offset).
    pub fn uses_derivatives(&self) -> bool {
        self.extension.iter().any(|t| {
            let effect = t.candidate.declaration().effect;
            effect.is_some_and(|e| e.uses_rate_derivatives())
        })
    }

    /// The terms of `sensor` in the fixed point (`iterated`) or evaluated once per record.
    fn terms_of(
        &self,
        sensor: Sensor,
        iterated: bool,
    ) -> impl Iterator<Item = (SolvedEffect, &[f64])> {
        self.extension
            .iter()
            .filter(move |t| {
                let once = t.solved().derivatives_only || self.on_measured(t);
                t.candidate.sensor() == sensor && once != iterated
            })
            .map(|t| (t.solved().effect, t.values.as_slice()))
    }

    /// The linear part alone: `(M_g (w' + b_g), M_a (f' + b_a))`.
    pub fn linear(
        &self,
        gyro: &Vector3<f64>,
        accel: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        (
            self.gyro_matrix * (gyro + self.gyro_offset),
            self.linear_accel(accel),
        )
    }

    /// The accelerometers' linear part: `M_a (f' + b_a)`.
    pub fn linear_accel(&self, accel: &Vector3<f64>) -> Vector3<f64> {
        self.accel_matrix * (accel + self.accel_offset)
    }

    /// The gyros' linear part on an angle increment `dth'` over `dt`: `M_g (dth' + b_g dt)`,
    /// [`Correction::linear`] times `dt` with one rounding less (the coarse fit's form).
    pub fn linear_gyro_increment(&self, dth: &Vector3<f64>, dt: f64) -> Vector3<f64> {
        self.gyro_matrix * (dth + self.gyro_offset * dt)
    }

    /// Correct one rate record: measured mean rate `w'` (rad/s) and specific force `f'`
    /// (m/s^2) in, `(w, f)` out. `derivatives` are `(dw/dt, df/dt)` (true, body axes), used only
    /// by the size effect and the time offset (zero when `None`).
    pub fn apply_rates(
        &self,
        gyro: &Vector3<f64>,
        accel: &Vector3<f64>,
        derivatives: Option<(Vector3<f64>, Vector3<f64>)>,
    ) -> Result<(Vector3<f64>, Vector3<f64>), CorrectionError> {
        let (w_dot, f_dot) = derivatives.unwrap_or_default();
        // The part of each right-hand side that does not depend on the unknowns: the terms on
        // the measured values and those of the rate derivatives alone.
        let once = SensorInput {
            omega_body: *gyro,
            f_body: *accel,
            omega_dot_body: w_dot,
            f_dot_body: f_dot,
            temp_delta: 0.0,
        };
        let mut gyro_rhs = gyro + self.gyro_offset;
        for (effect, p) in self.terms_of(Sensor::Gyro, false) {
            gyro_rhs += effect(p, &once);
        }
        let mut accel_rhs = accel + self.accel_offset;
        for (effect, p) in self.terms_of(Sensor::Accel, false) {
            accel_rhs -= effect(p, &once);
        }
        // The accelerometers' terms at the iterate, then the gyros' at it and the new force.
        let step = |w: &Vector3<f64>, f: &Vector3<f64>| {
            let mut at = SensorInput {
                omega_body: *w,
                f_body: *f,
                ..once
            };
            let mut fr = accel_rhs;
            for (effect, p) in self.terms_of(Sensor::Accel, true) {
                fr -= effect(p, &at);
            }
            let f_new = self.accel_matrix * fr;
            at.f_body = f_new;
            let mut gr = gyro_rhs;
            for (effect, p) in self.terms_of(Sensor::Gyro, true) {
                gr += effect(p, &at);
            }
            (self.gyro_matrix * gr, f_new)
        };
        let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
        // A genuine solution: finite, and a further step moves it by rounding only (relative
        // to the magnitudes that enter the formulas, so that a rate near zero is no exception).
        let solved = |w: &Vector3<f64>, f: &Vector3<f64>| {
            let (w2, f2) = step(w, f);
            let tol = 1e-12;
            finite(w)
                && finite(f)
                && (w2 - w).norm() <= tol * (w.norm() + gyro_rhs.norm())
                && (f2 - f).norm() <= tol * (f.norm() + accel_rhs.norm())
        };
        let no_fixed_point = CorrectionError::NoFixedPoint {
            gyro: [gyro.x, gyro.y, gyro.z],
            accel: [accel.x, accel.y, accel.z],
        };
        let (mut w, mut f) = self.linear(gyro, accel);
        let mut last_change = f64::INFINITY;
        let mut stalled = 0;
        for _ in 0..MAX_ITERATIONS {
            let (w_new, f_new) = step(&w, &f);
            if !(finite(&w_new) && finite(&f_new)) {
                return Err(no_fixed_point);
            }
            let dw = (w_new - w).norm();
            let df = (f_new - f).norm();
            (w, f) = (w_new, f_new);
            let settled_w = dw <= FIXED_POINT_TOLERANCE * w.norm();
            let settled_f = df <= FIXED_POINT_TOLERANCE * f.norm();
            // Rounding may keep the last bit moving: stop also once the change no longer
            // shrinks and is at the level of rounding.
            let change = dw.max(df);
            let rounding = 8.0 * f64::EPSILON * w.norm().max(f.norm());
            if change >= last_change && change <= rounding {
                stalled += 1;
            }
            if (settled_w && settled_f) || stalled >= 3 {
                return if solved(&w, &f) {
                    Ok((w, f))
                } else {
                    Err(no_fixed_point)
                };
            }
            last_change = change;
        }
        Err(no_fixed_point)
    }

    /// The correction as the `correction` block of a result file.
    pub fn block(&self) -> CorrectionBlock {
        CorrectionBlock {
            convention: match self.extension_inputs {
                ExtensionInputs::True => CONVENTION_TRUE,
                ExtensionInputs::Measured => CONVENTION_MEASURED,
            }
            .to_string(),
            extension_inputs: self.extension_inputs,
            gyro: GyroBlock {
                matrix: rows(&self.gyro_matrix),
                offset: self.gyro_offset.into(),
                gsens: self.block_entry(Sensor::Gyro, "gsens").map(rows_of),
                asym: self.block_entry(Sensor::Gyro, "asym").map(axes_of),
            },
            accel: AccelBlock {
                matrix: rows(&self.accel_matrix),
                offset: self.accel_offset.into(),
                k2: self.block_entry(Sensor::Accel, "k2").map(axes_of),
                lever: self.block_entry(Sensor::Accel, "lever").map(rows_of),
                time_offset_s: self
                    .block_entry(Sensor::Accel, "time_offset_s")
                    .map(|v| v[0]),
            },
            thermal: self.thermal.as_ref().map(|t| ThermalBlock {
                reference_c: t.reference_c,
                gyro_bias: t.gyro_bias.into(),
                accel_bias: t.accel_bias.into(),
                gyro_scale: t.gyro_scale.into(),
                accel_scale: t.accel_scale.into(),
            }),
        }
    }
}

/// The values of a per-axis term (three values).
fn axes_of(values: &[f64]) -> [f64; 3] {
    [values[0], values[1], values[2]]
}

impl Correction {
    /// The values of the term whose block key ([`Solved::key`]) is `key` in `sensor`'s part
    /// of the block; the test `every_solved_term_has_its_block_entry` checks that every
    /// declared key is one the block holds.
    fn block_entry(&self, sensor: Sensor, key: &str) -> Option<&[f64]> {
        self.extension
            .iter()
            .find(|t| t.candidate.sensor() == sensor && t.solved().key == key)
            .map(|t| t.values.as_slice())
    }
}

/// `I - Theta` and `I + Gamma` of the paper's 21 parameters (in the paper model's order).
fn sensor_matrices(p: &[f64]) -> (Matrix3<f64>, Matrix3<f64>) {
    let mut theta = Matrix3::identity();
    for i in 0..3 {
        for j in 0..3 {
            theta[(i, j)] -= p[3 + 3 * i + j];
        }
    }
    let mut gamma = Matrix3::identity();
    for (k, &(i, j)) in GAMMA_INDEX.iter().enumerate() {
        gamma[(i, j)] += p[15 + k];
    }
    (theta, gamma)
}

/// Inverse of a sensor matrix, `None` when singular or badly conditioned.
fn invert(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let inv = m.try_inverse()?;
    let cond = m.norm() * inv.norm();
    (cond.is_finite() && cond < 1e8).then_some(inv)
}

/// A record's interval (s): to the previous record, the first record's to the second.
fn interval(records: &[ImuRecord], k: usize) -> f64 {
    if k == 0 {
        records[1].t - records[0].t
    } else {
        records[k].t - records[k - 1].t
    }
}

/// The mean rate and specific force of record `k` (rates as they are, increments over their
/// interval).
fn mean_rates(kind: ImuKind, records: &[ImuRecord], k: usize) -> (Vector3<f64>, Vector3<f64>) {
    let (g, a) = (
        Vector3::from(records[k].gyro),
        Vector3::from(records[k].accel),
    );
    match kind {
        ImuKind::Rates => (g, a),
        ImuKind::Increments => {
            let dt = interval(records, k);
            (g / dt, a / dt)
        }
    }
}

/// Correct a window of records: record `k` of `records`, with its neighbours for the rate
/// derivatives when the correction needs them. Same form as the input (rates or increments,
/// time stamp and temperature kept). `Err` carries the record's index for the caller's message.
pub fn correct_record(
    correction: &Correction,
    kind: ImuKind,
    records: &[ImuRecord],
    k: usize,
) -> Result<ImuRecord, CorrectionError> {
    if kind == ImuKind::Increments && records.len() < 2 {
        return Err(CorrectionError::TooFewRecords);
    }
    // The thermal terms at this record's temperature (its neighbours' rates, for the
    // derivatives, are corrected at it too: a temperature moves by millikelvin between them).
    let at_temp = correction.at_temperature(records[k].temp)?;
    let correction = at_temp.as_ref().unwrap_or(correction);
    let (g, a) = mean_rates(kind, records, k);
    let derivatives = if correction.uses_derivatives() && records.len() >= 2 {
        let (lo, hi) = (k.saturating_sub(1), (k + 1).min(records.len() - 1));
        // Time of the middle of an interval (rates: the stamp stands for its interval too).
        let centre = |j: usize| records[j].t - 0.5 * interval(records, j);
        let (gl, al) = mean_rates(kind, records, lo);
        let (gh, ah) = mean_rates(kind, records, hi);
        let (wl, fl) = correction.linear(&gl, &al);
        let (wh, fh) = correction.linear(&gh, &ah);
        let span = centre(hi) - centre(lo);
        Some(((wh - wl) / span, (fh - fl) / span))
    } else {
        None
    };
    let (w, f) = correction.apply_rates(&g, &a, derivatives)?;
    let scale = match kind {
        ImuKind::Rates => 1.0,
        ImuKind::Increments => interval(records, k),
    };
    Ok(ImuRecord {
        t: records[k].t,
        gyro: (w * scale).into(),
        accel: (f * scale).into(),
        temp: records[k].temp,
    })
}

/// Correct every record of a file's contents ([`correct_record`] for each); `Err` gives the
/// 0-based index of the record that failed.
pub fn correct_records(
    correction: &Correction,
    kind: ImuKind,
    records: &[ImuRecord],
) -> Result<Vec<ImuRecord>, (usize, CorrectionError)> {
    (0..records.len())
        .map(|k| correct_record(correction, kind, records, k).map_err(|e| (k, e)))
        .collect()
}

/// Records corrected one by one as they are read, in memory independent of their number: each
/// record is corrected ([`correct_record`]) on a window of itself, the two records before it
/// and the one after it (the intervals and the neighbours' rates its correction needs), which
/// gives the same record as [`correct_records`] on the whole file (`apply` writes its files
/// so, `tests/apply.rs` compares them). `T` travels with each record (its line, its index).
#[derive(Clone, Debug, Default)]
pub struct CorrectionWindow<T> {
    records: Vec<ImuRecord>,
    tags: Vec<T>,
    /// The record whose correction is ready, in the window.
    ready: Option<usize>,
}

impl<T: Copy> CorrectionWindow<T> {
    /// The most records a window holds.
    const LEN: usize = 4;

    /// No record yet.
    pub fn new() -> Self {
        Self {
            records: Vec::with_capacity(Self::LEN),
            tags: Vec::with_capacity(Self::LEN),
            ready: None,
        }
    }

    /// The next record; returns the tag of the record before it, whose correction is now
    /// ready ([`Self::correct`]): it has its successor.
    pub fn push(&mut self, record: ImuRecord, tag: T) -> Option<T> {
        self.records.push(record);
        self.tags.push(tag);
        if self.records.len() > Self::LEN {
            self.records.remove(0);
            self.tags.remove(0);
        }
        self.ready = self.records.len().checked_sub(2);
        self.ready.map(|k| self.tags[k])
    }

    /// After the last record: its tag, its correction now ready (`None` without records).
    pub fn close(&mut self) -> Option<T> {
        self.ready = self.records.len().checked_sub(1);
        self.ready.map(|k| self.tags[k])
    }

    /// The record made ready by the last [`Self::push`] or [`Self::close`], corrected.
    pub fn correct(
        &self,
        correction: &Correction,
        kind: ImuKind,
    ) -> Option<Result<ImuRecord, CorrectionError>> {
        self.ready
            .map(|k| correct_record(correction, kind, &self.records, k))
    }

    /// How many records the window holds (at most four).
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Whether no record has been pushed.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }
}

/// A calibration's result file: its parameters, their correlation matrix and, when the
/// parameters make a correction (the paper's model complete, no unknown term), its
/// [`CorrectionBlock`] with the extension terms evaluated at `inputs`.
pub fn result_file(
    parameters: Vec<ResultParameter>,
    correlation: Vec<Vec<f64>>,
    inputs: ExtensionInputs,
    temperature: Option<crate::io::ResultTemperature>,
) -> crate::io::ResultFile {
    let reference = temperature.as_ref().map(|t| t.reference_c);
    let correction = Correction::from_parameters_at(&parameters, inputs, reference)
        .ok()
        .map(|c| c.block());
    crate::io::ResultFile {
        parameters,
        correlation: Some(correlation),
        correction,
        verdict: None,
        temperature,
        schema: Some(crate::io::schema::Schema::current(
            crate::io::schema::CALIBRATION,
        )),
        unit: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sins_model::terms::PaperPriors;

    /// The paper's model with every extension term, and parameter values of several times
    /// their priors' size (so that the non-linear terms matter).
    fn full_model() -> (ErrorModel, Vec<f64>) {
        let mut m = ErrorModel::paper(&PaperPriors::paper());
        for c in Candidate::ALL {
            if let Some(t) = c.term(c.default_prior_sigma()) {
                m.push(t);
            }
        }
        let p = m
            .params()
            .iter()
            .enumerate()
            .map(|(k, s)| 30.0 * s.prior_sigma * (1.7 + k as f64 * 0.37).sin())
            .collect();
        (m, p)
    }

    fn parameters(m: &ErrorModel, p: &[f64]) -> Vec<ResultParameter> {
        m.params()
            .into_iter()
            .zip(p)
            .map(|(s, &value)| ResultParameter {
                name: s.name,
                value,
                sigma: None,
                unit: s.unit.si_name().into(),
            })
            .collect()
    }

    /// The inverse of the terms' own effects (the simulator's model) is exact: the true rate
    /// and specific force come back to rounding, linear part and every extension term.
    #[test]
    fn inverts_the_terms_effects_exactly() {
        let (m, p) = full_model();
        let c =
            Correction::from_parameters_at(&parameters(&m, &p), ExtensionInputs::True, Some(20.0))
                .expect("complete parameters");
        assert!(c.is_nonlinear() && c.uses_derivatives());
        assert!(c.thermal.is_some());
        for k in 0..50 {
            let x = k as f64;
            let input = SensorInput {
                omega_body: Vector3::new((0.3 * x).sin(), -(0.7 * x).cos(), 0.2 * (x - 25.0)) * 1.5,
                f_body: Vector3::new(3.0 * (0.1 * x).cos(), -9.0 * (0.2 * x).sin(), 9.8),
                omega_dot_body: Vector3::new(0.4, -1.0, 0.3) * (0.5 * x).sin(),
                f_dot_body: Vector3::new(-2.0, 0.5, 1.0) * (0.9 * x).cos(),
                temp_delta: 0.4 * (x - 25.0),
            };
            let w_raw = input.omega_body - m.error(Sensor::Gyro, &p, &input);
            let f_raw = input.f_body + m.error(Sensor::Accel, &p, &input);
            let c = c
                .at_temperature(Some(20.0 + input.temp_delta))
                .expect("a temperature")
                .expect("thermal terms");
            let (w, f) = c
                .apply_rates(
                    &w_raw,
                    &f_raw,
                    Some((input.omega_dot_body, input.f_dot_body)),
                )
                .expect("settles");
            let ew = (w - input.omega_body).norm() / input.omega_body.norm();
            let ef = (f - input.f_body).norm() / input.f_body.norm();
            assert!(ew < 1e-14 && ef < 1e-14, "record {k}: {ew:e} {ef:e}");
            // The first-order inverse would be wrong by far more.
            let (wl, _) = c.linear(&w_raw, &f_raw);
            assert!((wl - input.omega_body).norm() > 1e3 * (w - input.omega_body).norm());
        }
    }

    /// The linear part is `(I - Theta)^-1` and `(I + Gamma)^-1` exactly, not `I + Theta`.
    #[test]
    fn linear_part_is_the_exact_inverse() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let p: Vec<f64> = (0..21).map(|k| 0.05 * (1.0 + k as f64).cos()).collect();
        let c = Correction::from_parameters(&parameters(&m, &p), ExtensionInputs::True).unwrap();
        assert!(!c.is_nonlinear() && !c.uses_derivatives());
        let theta = Matrix3::from_row_slice(&p[3..12]);
        let i = Matrix3::identity();
        assert!(((i - theta) * c.gyro_matrix - i).norm() < 1e-15);
        assert!((c.gyro_matrix - (i + theta)).norm() > 1e-3);
        let mut gamma = Matrix3::zeros();
        for (k, &(r, col)) in GAMMA_INDEX.iter().enumerate() {
            gamma[(r, col)] = p[15 + k];
        }
        assert!(((i + gamma) * c.accel_matrix - i).norm() < 1e-15);
        assert_eq!(c.gyro_offset, Vector3::new(p[0], p[1], p[2]));
        assert_eq!(c.accel_offset, -Vector3::new(p[12], p[13], p[14]));
    }

    /// The free-motion form evaluates `G` and `a` at the measured values: its inverse is
    /// `M_g (w' + nu0 + G f' + diag(a) |w'|)`, the fit's own calibrated rate.
    #[test]
    fn measured_inputs_are_the_free_motion_form() {
        let (m, p) = full_model();
        let params: Vec<ResultParameter> = parameters(&m, &p)
            .into_iter()
            .filter(|q| {
                q.name.starts_with("gyro.")
                    || q.name.starts_with("accel.bias")
                    || q.name.starts_with("accel.gamma")
            })
            .collect();
        let c = Correction::from_parameters_at(&params, ExtensionInputs::Measured, Some(20.0))
            .unwrap()
            .at_temperature(Some(20.0))
            .unwrap()
            .unwrap();
        assert!(!c.is_nonlinear());
        let (w_raw, f_raw) = (Vector3::new(0.5, -1.0, 0.25), Vector3::new(1.0, -2.0, 9.5));
        let (w, f) = c.apply_rates(&w_raw, &f_raw, None).unwrap();
        let g = Matrix3::from_row_slice(c.values(Candidate::GyroGSensitivity).unwrap());
        let a = Vector3::from_column_slice(c.values(Candidate::GyroScaleAsymmetry).unwrap());
        let expect =
            c.gyro_matrix * (w_raw + c.gyro_offset + g * f_raw + a.component_mul(&w_raw.abs()));
        assert!((w - expect).norm() < 1e-15 * w.norm());
        assert!((f - c.accel_matrix * (f_raw + c.accel_offset)).norm() < 1e-15 * f.norm());
    }

    #[test]
    fn refuses_unknown_incomplete_and_wrong_units() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let good = parameters(&m, &[0.0; 21]);
        let mut bad = good.clone();
        bad.push(ResultParameter {
            name: "gyro.wobble.x".into(),
            value: 0.0,
            sigma: None,
            unit: "1".into(),
        });
        let e = Correction::from_parameters(&bad, ExtensionInputs::True).unwrap_err();
        assert!(e.to_string().contains("`gyro.wobble.x`"), "{e}");
        let e = Correction::from_parameters(&good[1..], ExtensionInputs::True).unwrap_err();
        assert!(e.to_string().contains("gyro.bias.x"), "{e}");
        let mut partial = good.clone();
        partial.push(ResultParameter {
            name: "accel.k2.y".into(),
            value: 1e-5,
            sigma: None,
            unit: "1/(m/s^2)".into(),
        });
        let e = Correction::from_parameters(&partial, ExtensionInputs::True).unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains(Candidate::AccelQuadratic.id())
                && s.contains("accel.k2.x")
                && s.contains("accel.k2.z"),
            "{s}"
        );
        let mut unit = good.clone();
        unit[0].unit = "deg/h".into();
        assert!(matches!(
            Correction::from_parameters(&unit, ExtensionInputs::True),
            Err(CorrectionError::Unit { .. })
        ));
        let mut inert = good.clone();
        inert.push(ResultParameter {
            name: "turntable.tau".into(),
            value: 0.02,
            sigma: None,
            unit: "s".into(),
        });
        assert!(Correction::from_parameters(&inert, ExtensionInputs::True).is_ok());
        let mut singular = good;
        singular[3].value = 1.0; // Theta_xx = 1: the gyro reads nothing
        assert!(matches!(
            Correction::from_parameters(&singular, ExtensionInputs::True),
            Err(CorrectionError::Singular(_))
        ));
    }

    /// Terms too large for the record (here `k2 f^2` beyond `f`) have no fixed point to
    /// settle on: an error naming the record's values, no panic and no NaN out.
    #[test]
    fn a_fixed_point_that_does_not_settle_is_an_error() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let mut params = parameters(&m, &[0.0; 21]);
        for a in ["x", "y", "z"] {
            params.push(ResultParameter {
                name: format!("accel.k2.{a}"),
                value: 1.0,
                sigma: None,
                unit: "1/(m/s^2)".into(),
            });
        }
        let c = Correction::from_parameters(&params, ExtensionInputs::True).unwrap();
        let e = c
            .apply_rates(&Vector3::zeros(), &Vector3::new(0.0, 0.0, 9.8), None)
            .unwrap_err();
        assert!(matches!(e, CorrectionError::NoFixedPoint { .. }), "{e}");
        assert!(e.to_string().contains("9.8"), "{e}");
        // Small values of the same term settle.
        for p in params
            .iter_mut()
            .filter(|p| p.name.starts_with("accel.k2."))
        {
            p.value = 1e-4;
        }
        let c = Correction::from_parameters(&params, ExtensionInputs::True).unwrap();
        let (_, f) = c
            .apply_rates(&Vector3::zeros(), &Vector3::new(0.0, 0.0, 9.8), None)
            .unwrap();
        assert!((f.z + 1e-4 * f.z * f.z - 9.8).abs() < 1e-14);
    }

    /// A true rate of zero with a non-linear gyro term: settles on zero (the relative tests
    /// do not stall on it).
    #[test]
    fn zero_rate_settles() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let mut p = vec![0.0; 21];
        p[0] = 1e-5; // gyro bias x
        let mut params = parameters(&m, &p);
        for a in ["x", "y", "z"] {
            params.push(ResultParameter {
                name: format!("gyro.asym.{a}"),
                value: 1e-3,
                sigma: None,
                unit: "1".into(),
            });
        }
        let c = Correction::from_parameters(&params, ExtensionInputs::True).unwrap();
        // w' = w - nu0 at w = 0.
        let (w, _) = c
            .apply_rates(
                &Vector3::new(-1e-5, 0.0, 0.0),
                &Vector3::new(0.0, 0.0, 9.8),
                None,
            )
            .unwrap();
        assert!(w.norm() < 1e-20, "{w}");
    }

    /// The message of an unknown parameter names the solved terms' prefixes, from their
    /// declarations.
    #[test]
    fn unknown_names_the_solved_prefixes() {
        assert_eq!(
            solved_prefixes(),
            "gyro.gsens, gyro.asym, accel.k2, accel.lever, time.gyro_accel"
        );
    }

    /// Every term the correction solves has its entry in the block, under its declared key
    /// in its triad's part, with its values; every thermal term its coefficients.
    #[test]
    fn every_solved_term_has_its_block_entry() {
        let (m, p) = full_model();
        let c =
            Correction::from_parameters_at(&parameters(&m, &p), ExtensionInputs::True, Some(20.0))
                .unwrap();
        let block = serde_json::to_value(c.block()).unwrap();
        fn flat(v: &serde_json::Value) -> Vec<f64> {
            match v {
                serde_json::Value::Array(a) => a.iter().flat_map(flat).collect(),
                other => vec![other.as_f64().expect("a number")],
            }
        }
        for cand in Candidate::ALL {
            let triad = match cand.sensor() {
                Sensor::Gyro => "gyro",
                Sensor::Accel => "accel",
            };
            match cand.declaration().correction {
                CorrectionPart::Solved(s) => {
                    let entry = &block[triad][s.key];
                    assert!(!entry.is_null(), "{}: no `{triad}.{}`", cand.id(), s.key);
                    assert_eq!(flat(entry), c.values(cand).unwrap(), "{}", cand.id());
                }
                CorrectionPart::Thermal(part) => {
                    let key = match part {
                        ThermalPart::Bias => format!("{triad}_bias"),
                        ThermalPart::Scale => format!("{triad}_scale"),
                    };
                    let entry = flat(&block["thermal"][&key]);
                    let names = cand.param_names();
                    let expect: Vec<f64> = names
                        .iter()
                        .map(|n| {
                            let k = m.params().iter().position(|q| &q.name == n).unwrap();
                            p[k]
                        })
                        .collect();
                    assert_eq!(entry, expect, "{}", cand.id());
                }
                CorrectionPart::None => assert!(cand.term(1.0).is_none()),
            }
        }
    }

    /// The block reads back to itself and carries what the correction holds.
    #[test]
    fn block_round_trips_through_json() {
        let (m, p) = full_model();
        let c =
            Correction::from_parameters_at(&parameters(&m, &p), ExtensionInputs::True, Some(20.0))
                .unwrap();
        let b = c.block();
        assert_eq!(b.thermal.as_ref().map(|t| t.reference_c), Some(20.0));
        // Thermal terms without their reference temperature are refused, with the terms named.
        assert!(matches!(
            Correction::from_parameters(&parameters(&m, &p), ExtensionInputs::True),
            Err(CorrectionError::NoReferenceTemperature(t))
                if t.contains(Candidate::GyroTempBias.id())
        ));
        assert_eq!(c.at_temperature(None), Err(CorrectionError::NoTemperature));
        let text = serde_json::to_string(&b).unwrap();
        let back: CorrectionBlock = serde_json::from_str(&text).unwrap();
        assert_eq!(back, b);
        assert_eq!(b.gyro.matrix[0][1], c.gyro_matrix[(0, 1)]);
        assert_eq!(
            b.accel.lever.unwrap()[2][0],
            c.values(Candidate::AccelSizeEffect).unwrap()[6]
        );
        assert!(
            text.contains("\"extension_inputs\":\"corrected\""),
            "{text}"
        );
        // The name earlier versions wrote reads as the same.
        let old = text.replace("\"corrected\"", "\"true\"");
        let back: CorrectionBlock = serde_json::from_str(&old).unwrap();
        assert_eq!(back.extension_inputs, ExtensionInputs::True);
    }

    /// The orthant forms of a model with a scale asymmetry give the compensation's fixed point,
    /// `x = raw + (nu(x), -df(x)) dt`, in every orthant and where a rate component is smaller
    /// than its own error (its raw and true signs differ).
    #[test]
    fn orthant_forms_give_the_fixed_point() {
        let mut model = ErrorModel::paper(&PaperPriors::paper());
        model.push(Candidate::GyroGSensitivity.term(1e-4).expect("a term"));
        model.push(Candidate::GyroScaleAsymmetry.term(1e-2).expect("a term"));
        // Per-cent errors, a degree per second of bias.
        let p: Vec<f64> = (0..model.n_params())
            .map(|i| 0.02 * ((i as f64 * 1.7).sin()))
            .collect();
        let comp = Compensation::new(&model, &p);
        assert!(comp.orthants.is_some() && comp.closed.is_none());
        let dt = 0.01;
        let cases = [
            (Vector3::new(0.5, -0.3, 0.1), Vector3::new(0.1, -0.2, 9.8)),
            (Vector3::new(-0.5, 0.3, -1.1), Vector3::new(9.8, 0.1, 0.0)),
            // A rate component below the bias: raw and true signs differ.
            (Vector3::new(1e-4, -2e-4, 0.7), Vector3::new(0.0, 9.8, 0.3)),
            (Vector3::zeros(), Vector3::new(0.0, 0.0, 9.8)),
        ];
        for (w, f) in cases {
            let (raw_dth, raw_dv) = (w * dt, f * dt);
            let (dth, dv) = comp.apply(&model, &p, &raw_dth, &raw_dv, dt, 0.0, &mut None);
            let (mut x, mut y) = (raw_dth, raw_dv);
            for _ in 0..200 {
                let input = SensorInput {
                    omega_body: x / dt,
                    f_body: y / dt,
                    ..SensorInput::default()
                };
                x = raw_dth + model.error(Sensor::Gyro, &p, &input) * dt;
                y = raw_dv - model.error(Sensor::Accel, &p, &input) * dt;
            }
            assert!((dth - x).norm() < 1e-15, "{w}: {dth} against {x}");
            assert!((dv - y).norm() < 1e-14, "{w}: {dv} against {y}");
        }
    }

    /// The filter's compensation and the result file's correction solve the same models: with
    /// per-cent errors (the exact inverse in both) they agree to rounding, the g-sensitivity on
    /// the corrected specific force in both; with the paper's errors the filter's three passes
    /// stand within `B^4` of the exact inverse.
    #[test]
    fn compensation_and_correction_agree() {
        let dt = 0.01;
        let cases = [
            (Vector3::new(0.5, -0.3, 0.1), Vector3::new(0.1, -0.2, 9.8)),
            (Vector3::new(-0.5, 0.3, -1.1), Vector3::new(9.8, 0.1, 0.0)),
        ];
        for (scale, with_gsens, tolerance) in [
            (0.02, false, 1e-14),
            (0.02, true, 1e-14),
            (1e-3, false, 1e-11),
        ] {
            let mut model = ErrorModel::paper(&PaperPriors::paper());
            if with_gsens {
                model.push(Candidate::GyroGSensitivity.term(1e-4).expect("a term"));
            }
            let p: Vec<f64> = (0..model.n_params())
                .map(|i| scale * ((i as f64 * 1.7).sin()))
                .collect();
            let comp = Compensation::new(&model, &p);
            let c = Correction::from_parameters(&parameters(&model, &p), ExtensionInputs::True)
                .expect("complete parameters");
            for (w_raw, f_raw) in cases {
                let (dth, dv) =
                    comp.apply(&model, &p, &(w_raw * dt), &(f_raw * dt), dt, 0.0, &mut None);
                let (w, f) = c.apply_rates(&w_raw, &f_raw, None).expect("settles");
                let ew = (dth / dt - w).norm() / w.norm();
                let ef = (dv / dt - f).norm() / f.norm();
                assert!(
                    ew < tolerance && ef < tolerance,
                    "{scale} {with_gsens}: {ew:e} {ef:e}"
                );
            }
        }
    }

    /// The paper's parameters alone make the same correction by value as by name, and the
    /// increment form is the rate form times the interval.
    #[test]
    fn the_paper_correction_by_value() {
        let m = ErrorModel::paper(&PaperPriors::paper());
        let p: Vec<f64> = (0..21).map(|k| 0.03 * (2.0 + k as f64).sin()).collect();
        let by_name = Correction::from_parameters(&parameters(&m, &p), ExtensionInputs::True)
            .expect("complete parameters");
        assert_eq!(Correction::paper(&p).expect("invertible"), by_name);
        let (w, f) = (Vector3::new(0.2, -0.7, 1.1), Vector3::new(0.3, 9.7, -0.4));
        let (lw, lf) = by_name.linear(&w, &f);
        assert_eq!(lf, by_name.linear_accel(&f));
        let dt = 0.005;
        assert!((by_name.linear_gyro_increment(&(w * dt), dt) / dt - lw).norm() < 1e-15);
    }
}
