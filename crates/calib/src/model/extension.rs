//! Extensions of the paper's model by candidate terms (issue 10): which extra terms the filter
//! carries ([`ModelExtension`]) and which extra effects a simulated unit has
//! ([`HiddenEffects`]). The terms themselves live in [`sins_model::candidates`].
//!
//! The entry points that take an extension: [`crate::model::layout::layout_with`],
//! [`crate::estimate::covariance::covariance_analysis_ext`], [`crate::estimate::run`] and
//! [`crate::simulate::simulate_run_hidden`].

use sins_model::candidates::{Candidate, UnitGrade};
use sins_model::terms::ErrorModel;

/// What the filter carries beyond the paper's model: extra terms (their parameters become states
/// after the paper's instrument parameters) and, optionally, a random walk of the gyro biases
/// (process noise on the states `gyro.bias.*`, not a state).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ModelExtension {
    /// Extra terms with the prior sigma of their parameters (SI). A
    /// [`Candidate::GyroBiasDrift`] here is ignored: the drift is [`ModelExtension::gyro_drift`].
    pub terms: Vec<(Candidate, f64)>,
    /// Random-walk intensity of each gyro bias (rad/s/sqrt(s)).
    pub gyro_drift: Option<[f64; 3]>,
}

impl ModelExtension {
    /// The extension by `candidates` with their default priors
    /// ([`Candidate::default_prior_sigma`]); [`Candidate::GyroBiasDrift`] sets
    /// [`ModelExtension::gyro_drift`] to its default intensity on every axis.
    pub fn with(candidates: &[Candidate]) -> Self {
        Self::with_grade(candidates, UnitGrade::Navigation)
    }

    /// [`ModelExtension::with`] at the priors of a unit of `grade`
    /// ([`Candidate::prior_sigma`]).
    pub fn with_grade(candidates: &[Candidate], grade: UnitGrade) -> Self {
        let mut ext = Self::default();
        for &c in candidates {
            if c == Candidate::GyroBiasDrift {
                ext.gyro_drift = Some([c.prior_sigma(grade); 3]);
            } else if !ext.terms.iter().any(|(t, _)| *t == c) {
                ext.terms.push((c, c.prior_sigma(grade)));
            }
        }
        ext
    }

    /// [`ModelExtension::with`] by ids ([`Candidate::id`]); `Err` names the first unknown id.
    pub fn from_ids(ids: &[&str]) -> Result<Self, String> {
        let candidates = ids
            .iter()
            .map(|id| Candidate::from_id(id).ok_or_else(|| id.to_string()))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self::with(&candidates))
    }

    /// No extra terms and no drift: the paper's model.
    pub fn is_empty(&self) -> bool {
        self.term_candidates().next().is_none() && self.gyro_drift.is_none()
    }

    fn term_candidates(&self) -> impl Iterator<Item = (Candidate, f64)> + '_ {
        self.terms
            .iter()
            .copied()
            .filter(|(c, _)| *c != Candidate::GyroBiasDrift)
    }

    /// Append the extra terms to `model`, in the order of [`ModelExtension::terms`].
    pub fn extend(&self, model: &mut ErrorModel) {
        for (c, sigma) in self.term_candidates() {
            model.push(
                c.term(sigma)
                    .expect("every candidate but the drift is a term"),
            );
        }
    }
}

/// Extra effects of a simulated unit: true values of extra terms' parameters by name (e.g.
/// `gyro.gsens.xy`, `accel.lever.zx`, `time.gyro_accel`; the rest of a term's parameters are
/// zero) and, optionally, a random walk of the gyro biases (rad/s/sqrt(s)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HiddenEffects {
    /// Named true values (SI) of extra terms' parameters.
    pub values: Vec<(String, f64)>,
    /// Random-walk intensity of each gyro bias (rad/s/sqrt(s)).
    pub gyro_drift: Option<[f64; 3]>,
}

impl HiddenEffects {
    /// The candidate whose parameter is `name`.
    pub fn candidate_of(name: &str) -> Option<Candidate> {
        Candidate::ALL
            .into_iter()
            .filter(|c| *c != Candidate::GyroBiasDrift)
            .find(|c| c.param_names().iter().any(|n| n == name))
    }

    /// The candidates the values belong to, in [`Candidate::ALL`] order, or the first name
    /// that belongs to none.
    pub fn candidates(&self) -> Result<Vec<Candidate>, String> {
        let mut found = Vec::new();
        for (name, _) in &self.values {
            let c = Self::candidate_of(name).ok_or_else(|| name.clone())?;
            if !found.contains(&c) {
                found.push(c);
            }
        }
        Ok(Candidate::ALL
            .into_iter()
            .filter(|c| found.contains(c))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn with_uses_default_priors_and_drift_is_an_option() {
        let e = ModelExtension::with(&[
            Candidate::AccelQuadratic,
            Candidate::GyroBiasDrift,
            Candidate::AccelQuadratic,
        ]);
        assert_eq!(e.terms, vec![(Candidate::AccelQuadratic, 1e-5)]);
        assert!(e.gyro_drift.is_some());
        assert!(!e.is_empty());
        assert!(ModelExtension::default().is_empty());
        assert_eq!(
            ModelExtension::from_ids(&[
                Candidate::AccelQuadratic.id(),
                Candidate::GyroBiasDrift.id()
            ]),
            Ok(e)
        );
        assert_eq!(ModelExtension::from_ids(&["bogus"]), Err("bogus".into()));
        let mut m = ErrorModel::new();
        ModelExtension::with(&[Candidate::AccelSizeEffect, Candidate::GyroGSensitivity])
            .extend(&mut m);
        assert_eq!(m.n_params(), 18);
        assert_eq!(m.params()[0].name, "accel.lever.xx");
    }

    #[test]
    fn hidden_values_name_their_candidates() {
        let h = HiddenEffects {
            values: vec![
                ("time.gyro_accel".into(), 1e-3),
                ("gyro.asym.y".into(), 1e-5),
            ],
            gyro_drift: None,
        };
        assert_eq!(
            h.candidates(),
            Ok(vec![
                Candidate::GyroScaleAsymmetry,
                Candidate::GyroAccelTimeOffset
            ])
        );
        let bad = HiddenEffects {
            values: vec![("gyro.bias.x".into(), 1.0)],
            gyro_drift: None,
        };
        assert_eq!(bad.candidates(), Err("gyro.bias.x".into()));
    }
}
