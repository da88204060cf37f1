//! The filter's state vector, assembled from the error terms.
//!
//! Order: attitude error `beta` (3), the instrument terms' parameters in the order of the
//! [`ErrorModel`], then the turntable terms when the turntable angles are used: installation
//! misalignment `delta_z` (3), delay `tau` (1) and, optionally, base misalignment `gamma_p` (3).
//! With the paper's four terms that is 24 states without and 28 with the turntable angles.
//!
//! The layout of a run configuration ([`layout_for`]) and the prior covariance of its states
//! ([`initial_covariance`]) are set up here for the covariance analysis, the estimation and the
//! simulation alike.

use crate::config::{AttitudePrior, RunConfig};
use crate::model::extension::ModelExtension;
use nalgebra::{DMatrix, DVector, Matrix3};
use sins_model::names;
use sins_model::terms::{ErrorModel, PaperPriors, ParamSpec, Unit};
use std::sync::Arc;

/// Which states the filter carries.
#[derive(Debug)]
pub struct StateLayout {
    entries: Vec<ParamSpec>,
    /// The instrument error model; its parameters start at [`StateLayout::INSTRUMENT`].
    pub model: Arc<ErrorModel>,
    /// Index of a constant copy of the start attitude error (3 states), when carried: the
    /// estimation's first pass estimates the start attitude with it (a fixed-point smoother),
    /// and its second pass starts from that estimate.
    pub start_attitude: Option<usize>,
    /// Index of `delta_z` (3 states), when the turntable angles are used.
    pub install: Option<usize>,
    /// Index of `tau`, when the turntable angles are used.
    pub tau: Option<usize>,
    /// Index of `gamma_p` (3 states), when estimated.
    pub base: Option<usize>,
    /// Random-walk intensity of each gyro bias (rad/s/sqrt(s)): process noise on the states
    /// `gyro.bias.*` ([`crate::model::extension::ModelExtension::gyro_drift`]); `None`: constant biases.
    pub gyro_drift: Option<[f64; 3]>,
    /// Random-walk intensity of each accelerometer bias (m/s^2/sqrt(s)): process noise on the
    /// states `accel.bias.*` (`[noise] accel_bias_walk_m_s2_sqrt_s`); `None`: constant biases.
    pub accel_drift: Option<[f64; 3]>,
}

/// Prior sigmas of the states that are not instrument errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NonInstrumentPriors {
    /// Initial attitude error (rad) about East, North, Up.
    pub attitude: [f64; 3],
    /// Installation misalignment (rad).
    pub install: f64,
    /// Delay (s).
    pub tau: f64,
    /// Base misalignment (rad).
    pub base: f64,
}

impl StateLayout {
    /// Index of the first attitude-error state.
    pub const BETA: usize = 0;
    /// Index of the first instrument-error parameter.
    pub const INSTRUMENT: usize = 3;

    /// Layout of an instrument model, with or without the turntable states.
    pub fn new(
        model: ErrorModel,
        priors: &NonInstrumentPriors,
        with_turntable: bool,
        with_base: bool,
    ) -> Self {
        let mut entries: Vec<ParamSpec> = names::ATTITUDE_BETA
            .iter()
            .zip(priors.attitude)
            .map(|(n, s)| ParamSpec::new(*n, names::ANGLE_UNIT, s))
            .collect();
        entries.extend(model.params());
        let (mut install, mut tau, mut base) = (None, None, None);
        if with_turntable {
            install = Some(entries.len());
            for n in names::INSTALL_DELTA {
                entries.push(ParamSpec::new(n, names::ANGLE_UNIT, priors.install));
            }
            tau = Some(entries.len());
            entries.push(ParamSpec::new(
                names::TURNTABLE_TAU,
                names::TAU_UNIT,
                priors.tau,
            ));
            if with_base {
                base = Some(entries.len());
                for n in names::BASE_GAMMA {
                    entries.push(ParamSpec::new(n, names::ANGLE_UNIT, priors.base));
                }
            }
        }
        Self {
            entries,
            model: Arc::new(model),
            start_attitude: None,
            install,
            tau,
            base,
            gyro_drift: None,
            accel_drift: None,
        }
    }

    /// The same layout with a constant copy of the start attitude error appended
    /// (`attitude.start.{x,y,z}`, the attitude's prior sigma); see
    /// [`StateLayout::start_attitude`].
    pub fn with_start_attitude(&self) -> Self {
        let mut entries = self.entries.clone();
        let start = entries.len();
        for (i, a) in ["x", "y", "z"].iter().enumerate() {
            entries.push(ParamSpec::new(
                format!("attitude.start.{a}"),
                Unit::SmallAngle,
                self.entries[Self::BETA + i].prior_sigma,
            ));
        }
        Self {
            entries,
            model: Arc::clone(&self.model),
            start_attitude: Some(start),
            install: self.install,
            tau: self.tau,
            base: self.base,
            gyro_drift: self.gyro_drift,
            accel_drift: self.accel_drift,
        }
    }

    /// The paper's 24-state (IMU only) or 28-state (with turntable angles) layout.
    pub fn paper(priors: &PaperPriors, other: &NonInstrumentPriors, with_turntable: bool) -> Self {
        Self::new(ErrorModel::paper(priors), other, with_turntable, false)
    }

    /// Number of states.
    pub fn dim(&self) -> usize {
        self.entries.len()
    }

    /// Number of instrument-error parameters.
    pub fn n_instrument(&self) -> usize {
        self.model.n_params()
    }

    /// All states in order.
    pub fn entries(&self) -> &[ParamSpec] {
        &self.entries
    }

    /// Prior sigma of every state (SI).
    pub fn prior_sigma(&self) -> Vec<f64> {
        self.entries.iter().map(|e| e.prior_sigma).collect()
    }

    /// Index of a state by name.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.entries.iter().position(|e| e.name == name)
    }
}

/// The non-instrument priors of a configuration.
pub fn non_instrument_priors(config: &RunConfig) -> NonInstrumentPriors {
    NonInstrumentPriors {
        attitude: config.initial_attitude_sigma(),
        install: config.install_sigma(),
        tau: config.priors.tau_s,
        base: config.base_sigma(),
    }
}

/// The paper's layout for a configuration ([`layout_with`] without an extension).
pub fn layout_for(config: &RunConfig, with_turntable: bool) -> StateLayout {
    layout_with(config, with_turntable, &ModelExtension::default())
}

/// The layout of the paper's model extended by `ext`: the paper's instrument parameters first,
/// the extra terms' parameters after them (in the order of [`ModelExtension::terms`]), then the
/// turntable states as in [`layout_for`]. The drift is carried as process noise
/// ([`StateLayout::gyro_drift`]): the extension's when it has one, else the configured
/// `[noise] gyro_bias_walk_deg_h_sqrt_h` when that is above 0; the configured
/// `accel_bias_walk_m_s2_sqrt_s` likewise on the accelerometer biases
/// ([`StateLayout::accel_drift`]). With both walks 0 (the default) the layout is the paper's.
pub fn layout_with(config: &RunConfig, with_turntable: bool, ext: &ModelExtension) -> StateLayout {
    let mut model = ErrorModel::paper(&config.priors_si());
    ext.extend(&mut model);
    let mut layout = StateLayout::new(
        model,
        &non_instrument_priors(config),
        with_turntable,
        config.filter.estimate_base_misalignment,
    );
    layout.gyro_drift = ext.gyro_drift.or(config.noise.gyro_bias_walk());
    layout.accel_drift = config.noise.accel_bias_walk();
    layout
}

/// The prior covariance of all states (SI). `c0_body_to_enu` is the start attitude computed from
/// the program's start angles with the nominal mounting; with [`AttitudePrior::Installation`] the
/// attitude error is `beta_0 = C_0 delta_z + eps`, correlated with `delta_z` when that is a state
/// and carrying its variance when it is not (the installation misalignment is real either way).
pub fn initial_covariance(
    config: &RunConfig,
    layout: &StateLayout,
    c0_body_to_enu: &Matrix3<f64>,
) -> DMatrix<f64> {
    let sigma = layout.prior_sigma();
    let mut p = DMatrix::from_diagonal(&DVector::from_iterator(
        sigma.len(),
        sigma.iter().map(|s| s * s),
    ));
    if config.filter.attitude_prior == AttitudePrior::Installation {
        let var_d = config.install_sigma().powi(2);
        let c = c0_body_to_enu;
        let cc = c * c.transpose() * var_d;
        for i in 0..3 {
            for j in 0..3 {
                p[(i, j)] += cc[(i, j)];
            }
        }
        if let Some(k) = layout.install {
            // cov(beta_0, delta_z) = C_0 P_delta.
            for i in 0..3 {
                for j in 0..3 {
                    p[(i, k + j)] = c[(i, j)] * var_d;
                    p[(k + j, i)] = c[(i, j)] * var_d;
                }
            }
        }
    }
    copy_start_attitude(&mut p, layout);
    p
}

/// Make the rows and columns of the copy of the start attitude error (when the layout carries
/// one) equal to those of the start attitude error: the copy is the error itself.
pub fn copy_start_attitude(p: &mut DMatrix<f64>, layout: &StateLayout) {
    if let Some(s) = layout.start_attitude {
        let n = p.nrows();
        for i in 0..3 {
            for j in 0..n {
                let v = if (s..s + 3).contains(&j) {
                    p[(i, j - s)]
                } else {
                    p[(i, j)]
                };
                p[(s + i, j)] = v;
                p[(j, s + i)] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_layouts_have_24_and_28_states() {
        let o = NonInstrumentPriors {
            attitude: [0.01; 3],
            install: 0.01,
            tau: 0.05,
            base: 1e-5,
        };
        let p = PaperPriors::paper();
        let a = StateLayout::paper(&p, &o, false);
        let b = StateLayout::paper(&p, &o, true);
        assert_eq!(a.dim(), 24);
        assert_eq!(b.dim(), 28);
        assert_eq!(b.index("install.delta.x"), Some(24));
        assert_eq!(b.index("turntable.tau"), Some(27));
        assert_eq!(a.index("gyro.bias.x"), Some(3));
        assert_eq!(a.index("accel.gamma.zz"), Some(23));
    }
}
