//! The instrument-error parameters navigation carries over from a calibration, and their
//! covariance.
//!
//! Sensor models (design.md): gyro `w' = w - nu`, `nu = nu0 + Theta w + white`; accelerometer
//! `f' = f + df`, `df = df0 + Gamma f + white`, Theta full 3x3, Gamma lower-triangular. The
//! calibration's body (instrument) frame is the aircraft's, so the parameters apply directly.
//!
//! Navigation's instrument state is the 21 parameters in [`INSTRUMENT_NAMES`] order, all SI:
//! `gyro.bias.{x,y,z}` (rad/s), `gyro.theta.<i><j>` (row-major, i, j in x, y, z) (-),
//! `accel.bias.{x,y,z}` (m/s^2), `accel.gamma.{xx,yx,yy,zx,zy,zz}` (-).

use nalgebra::{DMatrix, SMatrix};
use sins_model::candidates::Candidate;
use sins_model::terms::{ErrorModel, PaperPriors};
use std::ops::Range;

use crate::NavError;

/// Number of instrument parameters navigation propagates.
pub const INSTRUMENT_DIM: usize = 21;

/// Names of the instrument parameters in navigation's state order: the parameters of the
/// paper's instrument model, [`sins_model::terms::ErrorModel::paper`], in its order (the one
/// owner of the names; navigation only takes them over).
pub static INSTRUMENT_NAMES: std::sync::LazyLock<[&'static str; INSTRUMENT_DIM]> =
    std::sync::LazyLock::new(|| {
        let names: Vec<&'static str> = paper_model()
            .params()
            .into_iter()
            .map(|p| &*Box::leak(p.name.into_boxed_str()))
            .collect();
        names
            .try_into()
            .expect("the paper's model has INSTRUMENT_DIM parameters")
    });

/// The paper's instrument model (gyro bias, Theta, accelerometer bias, lower-triangular Gamma),
/// whose parameters are navigation's instrument state and whose Jacobians navigation uses
/// (their values do not depend on the priors it is built with).
pub fn paper_model() -> &'static ErrorModel {
    static MODEL: std::sync::OnceLock<ErrorModel> = std::sync::OnceLock::new();
    MODEL.get_or_init(|| ErrorModel::paper(&PaperPriors::paper()))
}

/// Index of the first gyro bias in the instrument state.
pub const GYRO_BIAS: usize = 0;
/// Index of the first Theta element (row-major) in the instrument state.
pub const GYRO_THETA: usize = 3;
/// Index of the first accelerometer bias in the instrument state.
pub const ACCEL_BIAS: usize = 12;
/// Index of the first Gamma element (xx, yx, yy, zx, zy, zz) in the instrument state.
pub const ACCEL_GAMMA: usize = 15;

/// Name prefixes of calibration parameters that navigation ignores without complaint
/// (installation misalignment on the turntable, turntable data delay).
pub const IGNORED_PREFIXES: [&str; 3] = [
    sins_model::names::INSTALL_PREFIX,
    sins_model::names::TURNTABLE_PREFIX,
    sins_model::names::BASE_PREFIX,
];

pub use sins_model::units::{ARCMIN, DEG_PER_HOUR};

/// 21x21 covariance of the instrument parameters in [`INSTRUMENT_NAMES`] order.
pub type InstrumentMatrix = SMatrix<f64, INSTRUMENT_DIM, INSTRUMENT_DIM>;

/// How to treat instrument parameters missing from, or unknown to, a calibration result.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NamePolicy {
    /// Treat parameters absent from the calibration as perfectly known (zero variance) instead of
    /// failing. Off by default: a missing name is usually a mistake, and zero variance would
    /// flatter the calibration.
    pub allow_missing: bool,
    /// Ignore names navigation does not know instead of failing (names under
    /// [`IGNORED_PREFIXES`] are always ignored).
    pub ignore_unknown: bool,
}

/// Covariance of the instrument-error parameters left by a calibration, with names (SI units).
#[derive(Clone, Debug, PartialEq)]
pub struct InstrumentCovariance {
    /// Parameter names (see the module doc), one per row/column of `cov`.
    pub names: Vec<String>,
    /// Covariance matrix, SI units.
    pub cov: DMatrix<f64>,
}

impl InstrumentCovariance {
    /// A checked covariance: square, matching the names, finite, symmetric, non-negative
    /// diagonal, no duplicate names.
    pub fn new(names: Vec<String>, cov: DMatrix<f64>) -> Result<Self, NavError> {
        let c = Self { names, cov };
        c.check()?;
        Ok(c)
    }

    /// The covariance `D R D` of standard deviations `D` and a correlation matrix `R` (rows and
    /// columns in the order of `names`), as a calibration result file gives them; checked like
    /// [`InstrumentCovariance::new`], and `R` must be square of the names' size with entries in
    /// [-1, 1].
    pub fn from_sigmas_and_correlation(
        names: Vec<String>,
        sigmas: &[f64],
        correlation: &[Vec<f64>],
    ) -> Result<Self, NavError> {
        let n = names.len();
        if sigmas.len() != n || correlation.len() != n || correlation.iter().any(|r| r.len() != n) {
            return Err(NavError::BadCovariance(format!(
                "{n} names, {} sigmas and a correlation matrix of {} rows: expected one of each \
                 per parameter",
                sigmas.len(),
                correlation.len()
            )));
        }
        if let Some((i, j)) = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .find(|&(i, j)| !(correlation[i][j].is_finite() && correlation[i][j].abs() <= 1.0))
        {
            return Err(NavError::BadCovariance(format!(
                "correlation of `{}` and `{}` is {}: expected a value in [-1, 1]",
                names[i], names[j], correlation[i][j]
            )));
        }
        let cov = DMatrix::from_fn(n, n, |i, j| sigmas[i] * correlation[i][j] * sigmas[j]);
        Self::new(names, cov)
    }

    /// A diagonal covariance from per-parameter standard deviations.
    pub fn from_sigmas(names_and_sigmas: &[(&str, f64)]) -> Self {
        let names = names_and_sigmas
            .iter()
            .map(|(n, _)| n.to_string())
            .collect();
        let d = nalgebra::DVector::from_iterator(
            names_and_sigmas.len(),
            names_and_sigmas.iter().map(|(_, s)| s * s),
        );
        Self {
            names,
            cov: DMatrix::from_diagonal(&d),
        }
    }

    /// All 21 navigation parameters with zero covariance (an error-free IMU).
    pub fn zeros() -> Self {
        Self::from_sigmas(&INSTRUMENT_NAMES.map(|n| (n, 0.0)))
    }

    /// The diagonal covariance of one row of the paper's result tables, in the paper's units,
    /// every value taken as the standard deviation of each parameter of its kind:
    /// `nu0_deg_h` gyro bias (deg/h), `theta_ii` gyro scale-factor errors (-), `theta_ij_arcmin`
    /// gyro off-diagonal terms \[arcmin\], `df0_m_s2` accelerometer bias (m/s^2), `gamma_ii`
    /// accelerometer scale-factor errors (-), `gamma_ij_arcmin` accelerometer off-diagonal terms
    /// \[arcmin\] (the three below the diagonal).
    ///
    /// Paper, without turntable angles: `(0.01, 5.1e-7, 0.1, 9e-5, 1.36e-5, 0.1)`; with them:
    /// `(0.003, 9.7e-8, 0.05, 7.7e-5, 1.36e-5, 0.05)`.
    pub fn diagonal_from_paper_table(
        nu0_deg_h: f64,
        theta_ii: f64,
        theta_ij_arcmin: f64,
        df0_m_s2: f64,
        gamma_ii: f64,
        gamma_ij_arcmin: f64,
    ) -> Self {
        let sig: Vec<(&str, f64)> = INSTRUMENT_NAMES
            .iter()
            .map(|&n| {
                let s = match n {
                    _ if n.starts_with("gyro.bias.") => nu0_deg_h * DEG_PER_HOUR,
                    "gyro.theta.xx" | "gyro.theta.yy" | "gyro.theta.zz" => theta_ii,
                    _ if n.starts_with("gyro.theta.") => theta_ij_arcmin * ARCMIN,
                    _ if n.starts_with("accel.bias.") => df0_m_s2,
                    "accel.gamma.xx" | "accel.gamma.yy" | "accel.gamma.zz" => gamma_ii,
                    _ => gamma_ij_arcmin * ARCMIN,
                };
                (n, s)
            })
            .collect();
        Self::from_sigmas(&sig)
    }

    /// The paper's result table without the turntable angles (diagonal).
    pub fn paper_without_turntable() -> Self {
        Self::from_paper(&sins_model::paper::TABLE_IMU_ONLY)
    }

    /// The paper's result table with the turntable angles (diagonal).
    pub fn paper_with_turntable() -> Self {
        Self::from_paper(&sins_model::paper::TABLE_WITH_TURNTABLE)
    }

    /// [`Self::diagonal_from_paper_table`] of one of the paper's tables.
    pub fn from_paper(t: &sins_model::paper::ResultTable) -> Self {
        Self::diagonal_from_paper_table(
            t.nu0_deg_h,
            t.theta_ii,
            t.theta_ij_arcmin,
            t.df0_m_s2,
            t.gamma_ii,
            t.gamma_ij_arcmin,
        )
    }

    /// Standard deviation of a named parameter, if present.
    pub fn sigma(&self, name: &str) -> Option<f64> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.cov[(i, i)].max(0.0).sqrt())
    }

    fn check(&self) -> Result<(), NavError> {
        let n = self.names.len();
        if self.cov.nrows() != n || self.cov.ncols() != n {
            return Err(NavError::BadCovariance(format!(
                "{} names but a {}x{} matrix",
                n,
                self.cov.nrows(),
                self.cov.ncols()
            )));
        }
        for (i, a) in self.names.iter().enumerate() {
            if self.names[..i].contains(a) {
                return Err(NavError::BadCovariance(format!(
                    "parameter `{a}` appears twice"
                )));
            }
        }
        for i in 0..n {
            let d = self.cov[(i, i)];
            if !d.is_finite() || d < 0.0 {
                return Err(NavError::BadCovariance(format!(
                    "variance of `{}` is {d}",
                    self.names[i]
                )));
            }
            for j in 0..i {
                let (a, b) = (self.cov[(i, j)], self.cov[(j, i)]);
                if !a.is_finite() || !b.is_finite() {
                    return Err(NavError::BadCovariance(format!(
                        "covariance of `{}` and `{}` is not finite",
                        self.names[i], self.names[j]
                    )));
                }
                let scale = (d * self.cov[(j, j)]).sqrt();
                if (a - b).abs() > 1e-9 * scale.max(f64::MIN_POSITIVE) && (a - b).abs() > 0.0 {
                    return Err(NavError::BadCovariance(format!(
                        "not symmetric at `{}`, `{}`: {a} vs {b}",
                        self.names[i], self.names[j]
                    )));
                }
            }
        }
        Ok(())
    }

    /// The 21x21 covariance in [`INSTRUMENT_NAMES`] order (symmetrised): [`Self::in_model_order`]
    /// of the paper's model, whose parameters are the only ones known here (a candidate term's
    /// are unknown).
    pub fn to_navigation_order(&self, policy: NamePolicy) -> Result<InstrumentMatrix, NavError> {
        let p = self.in_model_order(&InstrumentModel::paper(), policy)?;
        Ok(InstrumentMatrix::from_fn(|i, j| p[(i, j)]))
    }

    /// The covariance in the order of `model`'s parameters ([`InstrumentModel::names`]),
    /// symmetrised. Parameters under [`IGNORED_PREFIXES`] are dropped; missing and unknown
    /// names are errors unless `policy` allows them (a missing parameter then gets zero variance
    /// and no correlation).
    pub fn in_model_order(
        &self,
        model: &InstrumentModel,
        policy: NamePolicy,
    ) -> Result<DMatrix<f64>, NavError> {
        self.check()?;
        let n = model.len();
        let mut idx = vec![None; n];
        let mut unknown = Vec::new();
        for (i, name) in self.names.iter().enumerate() {
            if let Some(k) = model.names.iter().position(|m| m == name) {
                idx[k] = Some(i);
            } else if !IGNORED_PREFIXES.iter().any(|p| name.starts_with(p)) {
                unknown.push(name.clone());
            }
        }
        if !unknown.is_empty() && !policy.ignore_unknown {
            return Err(NavError::UnknownParameters(unknown));
        }
        let missing: Vec<String> = model
            .names
            .iter()
            .zip(idx.iter())
            .filter(|(_, i)| i.is_none())
            .map(|(n, _)| n.clone())
            .collect();
        if !missing.is_empty() && !policy.allow_missing {
            return Err(NavError::MissingParameters(missing));
        }
        Ok(DMatrix::from_fn(n, n, |a, b| match (idx[a], idx[b]) {
            (Some(i), Some(j)) => 0.5 * (self.cov[(i, j)] + self.cov[(j, i)]),
            _ => 0.0,
        }))
    }
}

/// The instrument errors navigation propagates for a calibration: the paper's 21 parameters
/// ([`INSTRUMENT_NAMES`], in that order), then every candidate term of
/// [`sins_model::candidates`] that the calibration estimated, in [`Candidate::ALL`] order. Each
/// term acts in flight through its own effect on the sensors (its Jacobian at the flight's body
/// rate, specific force, their rates of change and the temperature), as in the calibration.
/// The gyro bias random walk is no term (it has no constant parameters) and is never part.
#[derive(Debug)]
pub struct InstrumentModel {
    model: ErrorModel,
    names: Vec<String>,
    terms: Vec<(Candidate, Range<usize>)>,
}

impl InstrumentModel {
    /// The paper's model alone.
    pub fn paper() -> Self {
        Self::with_terms(&[])
    }

    /// The paper's model and the candidate terms `terms` (in [`Candidate::ALL`] order,
    /// whatever the order given; the random walk is skipped).
    pub fn with_terms(terms: &[Candidate]) -> Self {
        let mut model = ErrorModel::paper(&PaperPriors::paper());
        let mut with = Vec::new();
        for c in Candidate::ALL.into_iter().filter(|c| terms.contains(c)) {
            let Some(term) = c.term(c.default_prior_sigma()) else {
                continue;
            };
            let start = model.n_params();
            model.push(term);
            with.push((c, start..model.n_params()));
        }
        let names = model.params().into_iter().map(|p| p.name).collect();
        Self {
            model,
            names,
            terms: with,
        }
    }

    /// The paper's model and every candidate term one of whose parameters `names` holds.
    pub fn for_names<'a>(names: impl IntoIterator<Item = &'a str>) -> Self {
        let names: Vec<&str> = names.into_iter().collect();
        let terms: Vec<Candidate> = Candidate::ALL
            .into_iter()
            .filter(|c| c.term(1.0).is_some())
            .filter(|c| c.param_names().iter().any(|p| names.contains(&p.as_str())))
            .collect();
        Self::with_terms(&terms)
    }

    /// The parameters' names in state order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Whether the model has no parameters (never: the paper's 21 are always there).
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// The sensor-error model whose Jacobians navigation takes.
    pub fn error_model(&self) -> &ErrorModel {
        &self.model
    }

    /// The candidate terms beyond the paper's model, with their parameters' state indices.
    pub fn terms(&self) -> &[(Candidate, Range<usize>)] {
        &self.terms
    }

    /// The parameters in groups: gyro bias, gyro matrix, accelerometer bias, accelerometer
    /// matrix (the paper's four terms), then each candidate term by its id.
    pub fn groups(&self) -> Vec<ParameterGroup> {
        let paper = [
            ("gyro_bias", "gyro bias nu0", GYRO_BIAS..GYRO_THETA),
            ("gyro_matrix", "gyro matrix Theta", GYRO_THETA..ACCEL_BIAS),
            (
                "accel_bias",
                "accelerometer bias df0",
                ACCEL_BIAS..ACCEL_GAMMA,
            ),
            (
                "accel_matrix",
                "accelerometer matrix Gamma",
                ACCEL_GAMMA..INSTRUMENT_DIM,
            ),
        ];
        let mut groups: Vec<ParameterGroup> = paper
            .into_iter()
            .map(|(id, label, r)| ParameterGroup {
                id: id.to_string(),
                label: label.to_string(),
                indices: r.collect(),
            })
            .collect();
        groups.extend(self.terms.iter().map(|(c, r)| ParameterGroup {
            id: c.id().to_string(),
            label: c.id().replace('_', " "),
            indices: r.clone().collect(),
        }));
        groups
    }
}

/// A group of instrument parameters (state indices of an [`InstrumentModel`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParameterGroup {
    /// Identifier: `gyro_bias`, `gyro_matrix`, `accel_bias`, `accel_matrix`, or a candidate
    /// term's id.
    pub id: String,
    /// Label for tables.
    pub label: String,
    /// The parameters' indices in the model's state.
    pub indices: Vec<usize>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand-written name list is the instrument model's own parameter list, in its order.
    #[test]
    fn names_are_the_instrument_models() {
        let model = sins_model::terms::ErrorModel::paper(&sins_model::terms::PaperPriors::paper());
        let names: Vec<String> = model.params().into_iter().map(|p| p.name).collect();
        assert_eq!(names, INSTRUMENT_NAMES.map(String::from).to_vec());
    }

    #[test]
    fn sigmas_and_correlation_make_the_covariance() {
        let names = vec!["gyro.bias.x".to_string(), "gyro.bias.y".to_string()];
        let r = vec![vec![1.0, -0.5], vec![-0.5, 1.0]];
        let c = InstrumentCovariance::from_sigmas_and_correlation(names.clone(), &[2.0, 3.0], &r)
            .unwrap();
        assert_eq!(c.cov[(0, 1)], -3.0);
        assert_eq!(c.cov[(1, 1)], 9.0);
        let bad = vec![vec![1.0, 1.5], vec![1.5, 1.0]];
        assert!(
            InstrumentCovariance::from_sigmas_and_correlation(names.clone(), &[2.0, 3.0], &bad)
                .is_err()
        );
        assert!(InstrumentCovariance::from_sigmas_and_correlation(names, &[2.0], &r).is_err());
    }

    #[test]
    fn paper_rows_convert_to_si() {
        let c = InstrumentCovariance::paper_without_turntable();
        assert_eq!(c.names.len(), 21);
        assert!((c.sigma("gyro.bias.y").unwrap() - 0.01 * DEG_PER_HOUR).abs() < 1e-20);
        assert!((c.sigma("gyro.theta.yy").unwrap() - 5.1e-7).abs() < 1e-20);
        assert!(
            (c.sigma("gyro.theta.zx").unwrap() - 0.1 / 60.0 * std::f64::consts::PI / 180.0).abs()
                < 1e-18
        );
        assert!((c.sigma("accel.bias.z").unwrap() - 9e-5).abs() < 1e-18);
        assert!((c.sigma("accel.gamma.zz").unwrap() - 1.36e-5).abs() < 1e-18);
        assert!((c.sigma("accel.gamma.zy").unwrap() - 0.1 * ARCMIN).abs() < 1e-18);
        let p = c.to_navigation_order(NamePolicy::default()).unwrap();
        assert!((p - InstrumentMatrix::from_diagonal(&p.diagonal())).norm() == 0.0);
    }

    #[test]
    fn names_are_matched_reordered_and_checked() {
        // Shuffled order with an installation parameter and a correlation.
        let mut names: Vec<String> = INSTRUMENT_NAMES
            .iter()
            .rev()
            .map(|s| s.to_string())
            .collect();
        names.push("install.delta.x".into());
        names.push("turntable.tau".into());
        let n = names.len();
        let mut cov = DMatrix::<f64>::identity(n, n) * 4.0;
        // correlate gyro.bias.x (index 20 here) with accel.gamma.xx (index 5 here)
        cov[(20, 5)] = 1.5;
        cov[(5, 20)] = 1.5;
        let ic = InstrumentCovariance::new(names.clone(), cov.clone()).unwrap();
        let p = ic.to_navigation_order(NamePolicy::default()).unwrap();
        assert_eq!(p[(0, 0)], 4.0);
        assert_eq!(p[(GYRO_BIAS, ACCEL_GAMMA)], 1.5);
        assert_eq!(p[(ACCEL_GAMMA, GYRO_BIAS)], 1.5);
        assert_eq!(p.iter().filter(|&&x| x != 0.0).count(), 21 + 2);

        // Missing parameter.
        let ic = InstrumentCovariance::new(
            names[1..].to_vec(),
            cov.view((1, 1), (n - 1, n - 1)).into_owned(),
        )
        .unwrap();
        assert!(
            matches!(ic.to_navigation_order(NamePolicy::default()), Err(NavError::MissingParameters(m)) if m == vec!["accel.gamma.zz".to_string()])
        );
        let p = ic
            .to_navigation_order(NamePolicy {
                allow_missing: true,
                ..Default::default()
            })
            .unwrap();
        assert_eq!(p[(20, 20)], 0.0);
        assert_eq!(p[(19, 19)], 4.0);

        // Unknown parameter.
        let mut names2 = names.clone();
        names2[0] = "gyro.gsens.xy".into();
        let ic = InstrumentCovariance::new(names2, cov.clone()).unwrap();
        assert!(matches!(
            ic.to_navigation_order(NamePolicy {
                allow_missing: true,
                ..Default::default()
            }),
            Err(NavError::UnknownParameters(_))
        ));
        assert!(
            ic.to_navigation_order(NamePolicy {
                allow_missing: true,
                ignore_unknown: true
            })
            .is_ok()
        );

        // Malformed matrices.
        let mut bad = cov.clone();
        bad[(1, 2)] = 1.0;
        assert!(InstrumentCovariance::new(names.clone(), bad).is_err());
        let mut dup = names.clone();
        dup[1] = dup[0].clone();
        assert!(InstrumentCovariance::new(dup, cov.clone()).is_err());
        assert!(InstrumentCovariance::new(names[1..].to_vec(), cov).is_err());
    }
}
