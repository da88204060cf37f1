//! Candidate error terms beyond the paper's model (issue 10): effects a real unit may show that
//! the paper's four terms do not describe. Each is an [`ErrorTerm`] like the paper's (parameters
//! with names, units and prior sigma; `error()` for the truth simulator; `jacobian()` for the
//! filter), except the gyro bias drift, which is not a constant error but process noise on the
//! gyro-bias states (a model option, see [`Candidate::GyroBiasDrift`]).
//!
//! Sign conventions as everywhere: gyro output `w' = w - nu`, accelerometer output
//! `f' = f + df`; a gyro term contributes to `nu`, an accelerometer term to `df`. SI inside.
//!
//! Each candidate is declared once, in its own file of this module (named for its parameters:
//! `gyro_gsens.rs` declares `gyro.gsens.*`): a static [`Declaration`]
//! (its id, parameters and unit, sensor, the title of its group in the reports, its help text,
//! its priors by grade, the sizes typical of each grade, its part in the correction) and its
//! [`Effect`] (the error and its Jacobian). Every other crate reads them through [`Candidate`].
//! Adding a term touches its file, the registry (a variant of [`Candidate`], its place in
//! [`Candidate::ALL`] and its arm in [`Candidate::declaration`]) and the table of the terms in
//! `docs/model-extension.md` (the test `every_term_has_every_part` checks all of them).
//!
//! The thermal terms' effect is proportional to `dT`, [`SensorInput::temp_delta`], the unit's
//! temperature less the reference temperature of the run (their parameters are coefficients
//! about it; the paper's biases and scale factors are then their values at the reference).

mod accel_k2;
mod accel_lever;
mod accel_tbias;
mod accel_tscale;
mod gyro_asym;
mod gyro_drift;
mod gyro_gsens;
mod gyro_tbias;
mod gyro_tscale;
mod thermal;
mod time_gyro_accel;

pub use crate::terms::Effect;
use crate::terms::{AxisColumn, ErrorTerm, ParamSpec, Sensor, SensorInput, Unit};
use nalgebra::Vector3;
use std::fmt::Debug;

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
    /// Every grade, best first.
    pub const ALL: [UnitGrade; 3] = [
        UnitGrade::Navigation,
        UnitGrade::Tactical,
        UnitGrade::Consumer,
    ];

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

/// How a term's parameters are named: a prefix and a shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamNames {
    /// One per axis, `<prefix><i>` (`gyro.asym.x`, ...).
    PerAxis(&'static str),
    /// A 3x3 matrix row by row, `<prefix><i><j>` (`gyro.gsens.xy`: row x, column y).
    Matrix(&'static str),
    /// A single parameter named as it is (`time.gyro_accel`).
    Single(&'static str),
}

impl ParamNames {
    /// The names in parameter order.
    pub fn names(self) -> Vec<String> {
        match self {
            ParamNames::PerAxis(prefix) => AXES.iter().map(|a| format!("{prefix}{a}")).collect(),
            ParamNames::Matrix(prefix) => AXES
                .iter()
                .flat_map(|a| AXES.iter().map(move |b| format!("{prefix}{a}{b}")))
                .collect(),
            ParamNames::Single(name) => vec![name.to_string()],
        }
    }

    /// What every name starts with (the whole name of a single parameter): what the reports
    /// group the parameters by.
    pub fn prefix(self) -> &'static str {
        match self {
            ParamNames::PerAxis(p) | ParamNames::Matrix(p) | ParamNames::Single(p) => p,
        }
    }
}

/// Prior sigma (SI) of a term's parameters for a unit of each grade.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradePriors {
    /// [`UnitGrade::Navigation`]: the default.
    pub navigation: f64,
    /// [`UnitGrade::Tactical`].
    pub tactical: f64,
    /// [`UnitGrade::Consumer`].
    pub consumer: f64,
}

/// How a term enters the inverse of the sensor models (the correction `apply` applies, written
/// as the `correction` block of a result file: `docs/formats.md`, "Correction"): the true rate
/// and specific force solve `w = M_g (w' + b_g + sum of the gyro terms' effects)` and
/// `f = M_a (f' + b_a - sum of the accelerometer terms' effects)`.
#[derive(Clone, Copy, Debug)]
pub enum CorrectionPart {
    /// No constant effect on the sensor output (the drift, a noise process).
    None,
    /// Solved with its triad's equation ([`Solved`]).
    Solved(Solved),
    /// A temperature coefficient, folded into its triad's offset (a bias coefficient) or the
    /// diagonal of its matrix (a scale-factor coefficient) at each record's temperature; in
    /// the block's `thermal` part as `<sensor>_bias` or `<sensor>_scale`.
    Thermal(ThermalPart),
}

/// A term the correction solves with its triad's equation ([`CorrectionPart::Solved`]).
#[derive(Clone, Copy, Debug)]
pub struct Solved {
    /// Its key in its triad's part of the block (a matrix row by row for nine parameters, an
    /// array for three, a number for one).
    pub key: &'static str,
    /// Its effect (`nu` or `df`) at the rate and specific force it is evaluated at: the
    /// term's error in the order of operations of the correction.
    pub effect: SolvedEffect,
    /// Whether the effect depends on the rate derivatives alone, so that it is evaluated once
    /// per record rather than in the fixed point of the non-linear terms.
    pub derivatives_only: bool,
}

/// A solved term's effect ([`Solved::effect`]): its values and the inputs in, `nu` or `df` out.
pub type SolvedEffect = fn(&[f64], &SensorInput) -> Vector3<f64>;

/// Which coefficient a thermal term is ([`CorrectionPart::Thermal`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThermalPart {
    /// Of the triad's biases.
    Bias,
    /// Of the triad's scale factors.
    Scale,
}

/// Everything about a candidate term, declared once in its file.
#[derive(Debug)]
pub struct Declaration {
    /// The id of `--terms`, of the reports and of the result files.
    pub id: &'static str,
    /// What the term is, in one line (help texts).
    pub help: &'static str,
    /// The title of its parameters' group in the reports' tables.
    pub group_title: &'static str,
    /// Its parameters' names (for the drift: of its intensities, which are not states).
    pub params: ParamNames,
    /// Unit of its parameters (SI inside).
    pub unit: Unit,
    /// The sensor triad it corrupts.
    pub sensor: Sensor,
    /// Whether its effect scales with the temperature's departure from the reference, so that
    /// only a recording with a temperature column that moves can show it.
    pub thermal: bool,
    /// Prior sigma by grade: the navigation grade's is the default (magnitudes of tactical- to
    /// navigation-grade units); the others the upper ends of what [`Declaration::typical`]
    /// quotes for the grade (a wide prior costs a term little; one too narrow leaves it "not
    /// observed" where the data show it plainly).
    pub priors: GradePriors,
    /// Typical magnitudes by grade of unit, with where they come from, for reports that set an
    /// estimate against them.
    pub typical: &'static str,
    /// Its error and Jacobian; `None` for the drift, which is process noise, not a term.
    pub effect: Option<&'static dyn Effect>,
    /// Its part in the correction.
    pub correction: CorrectionPart,
}

/// A candidate's [`ErrorTerm`]: its declaration's sensor, its parameters, its declaration's
/// [`Effect`].
#[derive(Debug)]
struct CandidateTerm {
    declaration: &'static Declaration,
    params: Vec<ParamSpec>,
    effect: &'static dyn Effect,
}

impl ErrorTerm for CandidateTerm {
    fn sensor(&self) -> Sensor {
        self.declaration.sensor
    }
    fn params(&self) -> &[ParamSpec] {
        &self.params
    }
}

impl Effect for CandidateTerm {
    fn error(&self, p: &[f64], input: &SensorInput) -> Vector3<f64> {
        self.effect.error(p, input)
    }
    fn jacobian(&self, p: &[f64], input: &SensorInput, out: &mut [Vector3<f64>]) {
        self.effect.jacobian(p, input, out)
    }
    fn is_affine(&self) -> bool {
        self.effect.is_affine()
    }
    fn is_affine_in_orthant(&self) -> bool {
        self.effect.is_affine_in_orthant()
    }
    fn axis_columns(&self) -> Option<Vec<AxisColumn>> {
        self.effect.axis_columns()
    }
    fn uses_rate_derivatives(&self) -> bool {
        self.effect.uses_rate_derivatives()
    }
}

/// A candidate extension of the paper's model: the registry of the declarations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Candidate {
    /// Gyro error proportional to the specific force (full 3x3).
    GyroGSensitivity,
    /// Gyro scale-factor error that differs for positive and negative rates.
    GyroScaleAsymmetry,
    /// Accelerometer error quadratic in the specific force along its axis.
    AccelQuadratic,
    /// Offsets of the accelerometers from the common point (size effect).
    AccelSizeEffect,
    /// Random walk of the gyro biases: process noise of intensity `drift_i^2` on the states
    /// `gyro.bias.i`. Not a term (no constant parameters): [`Candidate::term`] gives `None`.
    GyroBiasDrift,
    /// The accelerometers sample late against the gyros.
    GyroAccelTimeOffset,
    /// Gyro biases that change with temperature.
    GyroTempBias,
    /// Accelerometer biases that change with temperature.
    AccelTempBias,
    /// Gyro scale factors that change with temperature.
    GyroTempScale,
    /// Accelerometer scale factors that change with temperature.
    AccelTempScale,
}

impl Candidate {
    /// Every candidate, in the order of the issue (the order of the reports and of the
    /// parameters of a model with several).
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

    /// The candidate's declaration (its file in this module).
    pub fn declaration(self) -> &'static Declaration {
        match self {
            Candidate::GyroGSensitivity => &gyro_gsens::DECLARATION,
            Candidate::GyroScaleAsymmetry => &gyro_asym::DECLARATION,
            Candidate::AccelQuadratic => &accel_k2::DECLARATION,
            Candidate::AccelSizeEffect => &accel_lever::DECLARATION,
            Candidate::GyroBiasDrift => &gyro_drift::DECLARATION,
            Candidate::GyroAccelTimeOffset => &time_gyro_accel::DECLARATION,
            Candidate::GyroTempBias => &gyro_tbias::DECLARATION,
            Candidate::AccelTempBias => &accel_tbias::DECLARATION,
            Candidate::GyroTempScale => &gyro_tscale::DECLARATION,
            Candidate::AccelTempScale => &accel_tscale::DECLARATION,
        }
    }

    /// The thermal candidates ([`Candidate::is_thermal`]), in [`Candidate::ALL`] order.
    pub fn thermal() -> impl Iterator<Item = Candidate> {
        Self::ALL.into_iter().filter(|c| c.is_thermal())
    }

    /// Whether the candidate's effect scales with the temperature ([`Declaration::thermal`]).
    pub fn is_thermal(self) -> bool {
        self.declaration().thermal
    }

    /// The candidate's id (fixed by the issue).
    pub fn id(self) -> &'static str {
        self.declaration().id
    }

    /// The candidate with id `id`.
    pub fn from_id(id: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.id() == id)
    }

    /// Every id, in [`Candidate::ALL`] order.
    pub fn ids() -> impl Iterator<Item = &'static str> {
        Self::ALL.into_iter().map(Candidate::id)
    }

    /// Names of the candidate's parameters (for the drift: of its three intensities, which are
    /// not states).
    pub fn param_names(self) -> Vec<String> {
        self.declaration().params.names()
    }

    /// Unit of the candidate's parameters (SI inside).
    pub fn unit(self) -> Unit {
        self.declaration().unit
    }

    /// The sensor triad the candidate corrupts.
    pub fn sensor(self) -> Sensor {
        self.declaration().sensor
    }

    /// Default prior sigma (SI): the navigation grade's ([`Declaration::priors`]).
    pub fn default_prior_sigma(self) -> f64 {
        self.prior_sigma(UnitGrade::Navigation)
    }

    /// Prior sigma (SI) of the term for a unit of `grade` ([`Declaration::priors`]; the table
    /// of them is in `docs/model-extension.md`).
    pub fn prior_sigma(self, grade: UnitGrade) -> f64 {
        let p = &self.declaration().priors;
        match grade {
            UnitGrade::Navigation => p.navigation,
            UnitGrade::Tactical => p.tactical,
            UnitGrade::Consumer => p.consumer,
        }
    }

    /// Typical magnitudes of the term by grade of unit ([`Declaration::typical`]).
    pub fn typical(self) -> &'static str {
        self.declaration().typical
    }

    /// The candidate's error term with `prior_sigma` on every parameter; `None` for the drift,
    /// which is process noise, not a term.
    pub fn term(self, prior_sigma: f64) -> Option<Box<dyn ErrorTerm>> {
        let d = self.declaration();
        let params = d
            .params
            .names()
            .into_iter()
            .map(|n| ParamSpec::new(n, d.unit, prior_sigma))
            .collect();
        Some(Box::new(CandidateTerm {
            declaration: d,
            params,
            effect: d.effect?,
        }))
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

    /// Every term has every part of its declaration: an id unique and parsed back, parameters
    /// with a unit, a group title of its own, a prior for every grade, a help text, typical
    /// sizes, a part in the correction that matches its effect, and a row in the table of
    /// the terms of `docs/model-extension.md`.
    #[test]
    fn every_term_has_every_part() {
        let docs = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../docs/model-extension.md"
        ))
        .expect("docs/model-extension.md");
        let mut titles = Vec::new();
        for c in Candidate::ALL {
            let d = c.declaration();
            assert_eq!(Candidate::from_id(d.id), Some(c));
            assert_eq!(Candidate::ALL.iter().filter(|o| o.id() == d.id).count(), 1);
            assert!(d.id.bytes().all(|b| b.is_ascii_lowercase() || b == b'_'));
            let names = c.param_names();
            assert!(!names.is_empty(), "{}", d.id);
            assert!(names.iter().all(|n| n.starts_with(d.params.prefix())));
            assert!(!d.unit.si_name().is_empty() && !d.unit.report_name().is_empty());
            assert!(!d.group_title.is_empty() && d.group_title != "Other parameters");
            assert!(!titles.contains(&d.group_title), "{}: title", d.id);
            titles.push(d.group_title);
            for g in UnitGrade::ALL {
                let s = c.prior_sigma(g);
                assert!(s.is_finite() && s > 0.0, "{} {g:?}", d.id);
            }
            assert!(!d.help.is_empty() && !d.typical.is_empty(), "{}", d.id);
            let row = format!("| `{}` |", d.id);
            assert!(docs.contains(&row), "docs/model-extension.md: no row {row}");
            match (d.effect, d.correction) {
                (None, CorrectionPart::None) => {}
                (Some(_), CorrectionPart::Thermal(_)) => assert!(d.thermal, "{}", d.id),
                (Some(e), CorrectionPart::Solved(s)) => {
                    assert!(!d.thermal && !s.key.is_empty(), "{}", d.id);
                    assert_eq!(
                        s.derivatives_only,
                        e.uses_rate_derivatives()
                            && e.error(
                                &vec![1.0; names.len()],
                                &SensorInput {
                                    f_dot_body: Vector3::zeros(),
                                    ..input()
                                }
                            ) == Vector3::zeros(),
                        "{}",
                        d.id
                    );
                    let p: Vec<f64> = (0..names.len()).map(|i| 1e-3 * (i as f64 + 1.0)).collect();
                    let (a, b) = ((s.effect)(&p, &input()), e.error(&p, &input()));
                    assert!((a - b).norm() <= 1e-15 * b.norm(), "{}: {a} {b}", d.id);
                }
                _ => panic!("{}: its effect and its correction part disagree", d.id),
            }
        }
    }

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
        for c in Candidate::thermal() {
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
