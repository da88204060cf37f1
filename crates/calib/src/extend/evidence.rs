//! The evidence for extending the model by a candidate term, from fits and covariance analyses
//! (the statistics behind the model-extension loop, `docs/model-extension.md`).
//!
//! - [`score_test`]: whether the data call for a term, from the fit of the model extended by it.
//!   With a Gaussian prior `N(0, P0)` on the term's parameters `theta` (independent of the other
//!   states) the posterior of `theta` is `P = (P0^-1 + I)^-1`, where `I` is the information the
//!   data hold on `theta` once every other state is marginalised (`I = P^-1 - P0^-1`), and its
//!   mean is `theta_hat = P s` with `s` the efficient score at `theta = 0`. When the term is
//!   absent, `s ~ N(0, I)` exactly in the linear-Gaussian model, so `T = s^T I^+ s` is
//!   chi-square with `rank(I)` degrees of freedom. Directions in which the data hold less than
//!   [`MIN_INFORMATION_SHARE`] of the prior's information are left out of the rank: there the
//!   statistic would rest on the prior alone.
//! - [`chi_bar_square_sf`]: the p-value of a likelihood-ratio statistic for variance
//!   parameters on the boundary (a random walk's intensity cannot be negative).
//! - [`separability`]: whether a covariance analysis of the extended model on the recorded
//!   program can tell the term from the base parameters (posterior sigma against prior), and
//!   which base parameters it is confounded with.
//! - [`InformationGain`]: what an accepted term gains (log-likelihood, AIC, BIC).

pub use crate::check::score::{
    MIN_INFORMATION_SHARE, ScoreTest, chi_square_sf, ln_chi_square_sf, score_test,
};
use nalgebra::DMatrix;
use serde::Serialize;

/// Upper tail of the chi-bar-square distribution of a likelihood-ratio statistic for `k`
/// non-negative parameters on the boundary of their space, taken as orthogonal: the mixture
/// `sum_j C(k, j) 2^-k chi2_j` (`chi2_0` a point mass at zero).
pub fn chi_bar_square_sf(lr: f64, k: usize) -> f64 {
    let mut p = 0.0;
    let mut binom = 1.0;
    for j in 0..=k {
        if j > 0 {
            binom *= (k - j + 1) as f64 / j as f64;
            p += binom * chi_square_sf(lr, j);
        }
    }
    (p / 2f64.powi(k as i32)).clamp(0.0, 1.0)
}

/// How well a covariance analysis separates one candidate parameter.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParameterSeparation {
    /// Parameter name.
    pub name: String,
    /// Posterior sigma over prior sigma (1 = the program says nothing about it).
    pub sigma_ratio: f64,
    /// The base parameters it is most correlated with in the posterior, largest first
    /// (`|correlation| >= CONFOUNDING_CORRELATION`).
    pub confounded_with: Vec<(String, f64)>,
    /// Its posterior sigma over its prior sigma with the base parameters' priors removed: what
    /// the data say of it once the base parameters are free. A parameter nearly collinear with
    /// a base parameter can have a small posterior sigma only because that base parameter's
    /// prior holds it (the accelerometer quadratic term of a 19-position recording whose rests
    /// lose their horizontal information to a large motion noise: seen only through `|f|`,
    /// correlation 0.9997 with the bias, yet at a fifth of its prior); without the prior it is
    /// not determined. Infinite where the data leave it free.
    pub data_sigma_ratio: f64,
}

/// Posterior sigma over prior sigma at or below which a parameter counts as separated.
pub const SEPARATED_SIGMA_RATIO: f64 = 0.5;

/// Posterior correlation from which a base parameter is named as confounded with a candidate.
pub const CONFOUNDING_CORRELATION: f64 = 0.5;

impl ParameterSeparation {
    /// The largest `|correlation|` with a base parameter (0 when none reaches
    /// [`CONFOUNDING_CORRELATION`]).
    pub fn largest_correlation(&self) -> f64 {
        self.confounded_with
            .iter()
            .map(|(_, r)| r.abs())
            .fold(0.0, f64::max)
    }

    /// Separated: its posterior sigma at most [`SEPARATED_SIGMA_RATIO`] of its prior, with the
    /// base parameters' priors as given and with them removed ([`Self::data_sigma_ratio`]).
    pub fn separated(&self) -> bool {
        self.sigma_ratio <= SEPARATED_SIGMA_RATIO && self.data_sigma_ratio <= SEPARATED_SIGMA_RATIO
    }
}

/// Whether a term is separable from the base parameters under a program.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Separability {
    /// Every parameter of the term is separated ([`ParameterSeparation::separated`]).
    pub separable: bool,
    /// Per parameter.
    pub parameters: Vec<ParameterSeparation>,
}

impl Separability {
    /// The base parameters the inseparable part of the term is confounded with (unique, in order
    /// of the largest correlation).
    pub fn confounded(&self) -> Vec<String> {
        let mut all: Vec<(String, f64)> = self
            .parameters
            .iter()
            .filter(|p| !p.separated())
            .flat_map(|p| p.confounded_with.iter().cloned())
            .collect();
        all.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        let mut names: Vec<String> = Vec::new();
        for (n, _) in all {
            if !names.contains(&n) {
                names.push(n);
            }
        }
        names
    }
}

/// Separability of the parameters `candidate` from the parameters `base` in a posterior
/// (`names`, `prior_sigma`, `cov`, SI) of a covariance analysis of the extended model.
pub fn separability(
    names: &[String],
    prior_sigma: &[f64],
    cov: &DMatrix<f64>,
    candidate: &[String],
    base: &[String],
) -> Separability {
    let index = |n: &str| names.iter().position(|m| m == n);
    let sd = |i: usize| cov[(i, i)].max(0.0).sqrt();
    let free = without_base_priors(
        prior_sigma,
        cov,
        &base.iter().filter_map(|b| index(b)).collect::<Vec<_>>(),
    );
    let parameters: Vec<ParameterSeparation> = candidate
        .iter()
        .filter_map(|c| index(c).map(|i| (c, i)))
        .map(|(c, i)| {
            let mut conf: Vec<(String, f64)> = base
                .iter()
                .filter_map(|b| index(b).map(|j| (b, j)))
                .map(|(b, j)| {
                    (
                        b.clone(),
                        cov[(i, j)] / (sd(i) * sd(j)).max(f64::MIN_POSITIVE),
                    )
                })
                .filter(|(_, r)| r.abs() >= CONFOUNDING_CORRELATION)
                .collect();
            conf.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
            conf.truncate(4);
            ParameterSeparation {
                name: c.clone(),
                sigma_ratio: sd(i) / prior_sigma[i],
                confounded_with: conf,
                data_sigma_ratio: free
                    .as_ref()
                    .map_or(f64::INFINITY, |f| f[(i, i)].max(0.0).sqrt()),
            }
        })
        .collect();
    Separability {
        separable: !parameters.is_empty() && parameters.iter().all(|p| p.separated()),
        parameters,
    }
}

/// A posterior (`names`, `prior_sigma`, `cov`, SI) of a model extended by several terms,
/// conditioned on the parameters `fixed` being zero: the posterior covariance of the model
/// without them (leaving a term out of a linear-Gaussian model is knowing it is zero), so one
/// covariance analysis of the model extended by every candidate gives each candidate's
/// separability as an analysis of the model extended by it alone would. The Schur complement
/// `P_kk - P_kf P_ff^-1 P_fk`, in prior units (the scales run from 1e-9 to 1); `None` where
/// `P_ff` is not positive definite. Returns the kept names, prior sigmas and covariance.
pub fn without_parameters(
    names: &[String],
    prior_sigma: &[f64],
    cov: &DMatrix<f64>,
    fixed: &[String],
) -> Option<(Vec<String>, Vec<f64>, DMatrix<f64>)> {
    let (drop, keep): (Vec<usize>, Vec<usize>) =
        (0..names.len()).partition(|&i| fixed.contains(&names[i]));
    let scale = |i: usize| {
        if prior_sigma[i] > 0.0 {
            prior_sigma[i]
        } else {
            1.0
        }
    };
    let pn = |rows: &[usize], cols: &[usize]| {
        DMatrix::from_fn(rows.len(), cols.len(), |a, b| {
            cov[(rows[a], cols[b])] / (scale(rows[a]) * scale(cols[b]))
        })
    };
    let mut kept = pn(&keep, &keep);
    if !drop.is_empty() {
        let c = pn(&drop, &drop);
        let chol = ((&c + c.transpose()) * 0.5).cholesky()?;
        let b = pn(&keep, &drop);
        kept -= &b * chol.solve(&b.transpose());
    }
    let cov = DMatrix::from_fn(keep.len(), keep.len(), |a, b| {
        kept[(a, b)] * scale(keep[a]) * scale(keep[b])
    });
    Some((
        keep.iter().map(|&i| names[i].clone()).collect(),
        keep.iter().map(|&i| prior_sigma[i]).collect(),
        (&cov + cov.transpose()) * 0.5,
    ))
}

/// The prior weight left on a base parameter whose prior is removed: enough to keep the
/// information matrix invertible where the data leave a base parameter free (its prior then
/// 1000 times wider), far below any prior's own weight.
const REMOVED_PRIOR_WEIGHT: f64 = 1e-6;

/// The posterior covariance in prior sigmas (`cov_ij / (s_i s_j)`) with the priors of the
/// parameters `base` removed: the information `P^-1` less each one's unit prior information
/// (the parameters' priors are independent; the remaining prior weight is
/// [`REMOVED_PRIOR_WEIGHT`]). `None` where `cov` is not positive definite.
fn without_base_priors(
    prior_sigma: &[f64],
    cov: &DMatrix<f64>,
    base: &[usize],
) -> Option<DMatrix<f64>> {
    let n = cov.nrows();
    let normalised = DMatrix::from_fn(n, n, |i, j| cov[(i, j)] / (prior_sigma[i] * prior_sigma[j]));
    let mut info = normalised.cholesky()?.inverse();
    for &b in base {
        info[(b, b)] -= 1.0 - REMOVED_PRIOR_WEIGHT;
    }
    let info = (&info + info.transpose()) * 0.5;
    Some(info.cholesky()?.inverse())
}

/// What extending a model gains, from the innovation log-likelihoods of the two fits.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct InformationGain {
    /// `ln L(extended) - ln L(base)`.
    pub log_likelihood: f64,
    /// Parameters added.
    pub parameters: usize,
    /// Scalar innovations behind the likelihoods.
    pub observations: usize,
    /// `AIC(extended) - AIC(base)` (negative: the extension is worth its parameters).
    pub delta_aic: f64,
    /// `BIC(extended) - BIC(base)`.
    pub delta_bic: f64,
}

impl InformationGain {
    /// From the two log-likelihoods, the parameters added and the scalar observations.
    pub fn new(ll_base: f64, ll_extended: f64, parameters: usize, observations: usize) -> Self {
        let d = ll_extended - ll_base;
        let k = parameters as f64;
        Self {
            log_likelihood: d,
            parameters,
            observations,
            delta_aic: 2.0 * k - 2.0 * d,
            delta_bic: k * (observations.max(1) as f64).ln() - 2.0 * d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;
    use rand::{SeedableRng, rngs::StdRng};
    use rand_distr::{Distribution, StandardNormal};

    /// A linear-Gaussian batch problem: `y = A b + G theta + v`, priors `b ~ N(0, 1)`,
    /// `theta ~ N(0, diag(s0^2))`, `v ~ N(0, 1)`; the posterior of the joint state.
    fn posterior(
        a: &DMatrix<f64>,
        g: &DMatrix<f64>,
        s0: &[f64],
        y: &DVector<f64>,
    ) -> (DVector<f64>, DMatrix<f64>) {
        let h = DMatrix::from_fn(a.nrows(), a.ncols() + g.ncols(), |i, j| {
            if j < a.ncols() {
                a[(i, j)]
            } else {
                g[(i, j - a.ncols())]
            }
        });
        let mut info = h.transpose() * &h;
        for j in 0..a.ncols() {
            info[(j, j)] += 1.0;
        }
        for (k, s) in s0.iter().enumerate() {
            info[(a.ncols() + k, a.ncols() + k)] += 1.0 / (s * s);
        }
        let cov = info.try_inverse().unwrap();
        let mean = &cov * h.transpose() * y;
        (mean, cov)
    }

    #[test]
    fn score_statistic_is_chi_square_when_the_term_is_absent() {
        // Seed and bound fixed before the run: 400 draws of a 2-parameter term (one direction
        // well observed, one barely, one confounded with a base parameter); the mean of a
        // chi2(2) over 400 draws has standard error sqrt(4/400) = 0.1: accept 2 +- 0.4.
        let mut rng = StdRng::seed_from_u64(20_261_123);
        let m = 60;
        let a = DMatrix::from_fn(m, 2, |i, j| ((i + 3 * j) as f64 * 0.37).sin());
        let g = DMatrix::from_fn(m, 2, |i, j| {
            if j == 0 {
                0.8 * ((i as f64) * 0.37).sin() + 0.3 * ((i as f64) * 1.1).cos()
            } else {
                ((i as f64) * 0.05).cos() * 0.2
            }
        });
        let s0 = [2.0, 5.0];
        let (mut sum, mut rejected) = (0.0, 0);
        let n = 400;
        for _ in 0..n {
            let b = DVector::from_fn(2, |_, _| StandardNormal.sample(&mut rng));
            let v = DVector::from_fn(m, |_, _| StandardNormal.sample(&mut rng));
            let y = &a * b + v;
            let (mean, cov) = posterior(&a, &g, &s0, &y);
            let theta = [mean[2], mean[3]];
            let pc = cov.view((2, 2), (2, 2)).into_owned();
            let t = score_test(&theta, &pc, &s0);
            assert_eq!(t.dof, 2);
            sum += t.statistic;
            rejected += usize::from(t.p_value < 0.05);
        }
        let mean = sum / n as f64;
        assert!((mean - 2.0).abs() < 0.4, "mean statistic {mean}");
        // Rejections at 5 %: binomial(400, 0.05) = 20 +- 4.4; accept 6..=36.
        assert!((6..=36).contains(&rejected), "{rejected} rejections");
    }

    #[test]
    fn score_statistic_sees_a_present_term_and_ignores_unobserved_directions() {
        let mut rng = StdRng::seed_from_u64(7);
        let m = 60;
        let a = DMatrix::from_fn(m, 2, |i, j| ((i + 3 * j) as f64 * 0.37).sin());
        // Second column zero: the data say nothing about theta_2.
        let g = DMatrix::from_fn(m, 2, |i, j| {
            if j == 0 {
                ((i as f64) * 0.9).cos()
            } else {
                0.0
            }
        });
        let s0 = [2.0, 5.0];
        let theta_true = DVector::from_vec(vec![1.0, 3.0]);
        let v = DVector::from_fn(m, |_, _| StandardNormal.sample(&mut rng));
        let y = &g * &theta_true + v;
        let (mean, cov) = posterior(&a, &g, &s0, &y);
        let pc = cov.view((2, 2), (2, 2)).into_owned();
        let t = score_test(&[mean[2], mean[3]], &pc, &s0);
        assert_eq!(t.dof, 1);
        // theta_1 = 1 against a noise of about 1/sqrt(30): a statistic near 30.
        assert!(t.statistic > 10.0 && t.p_value < 1e-3, "{t:?}");
    }

    #[test]
    fn chi_bar_square_mixes_the_chi_squares() {
        // k = 1: half a point mass at zero, half chi2(1): P(> 2.706) = 0.05.
        assert!((chi_bar_square_sf(2.7055, 1) - 0.05).abs() < 1e-4);
        // k = 3 at zero: everything but the point mass 1/8.
        assert!((chi_bar_square_sf(0.0, 3) - 7.0 / 8.0).abs() < 1e-12);
        assert!(chi_bar_square_sf(50.0, 3) < 1e-9);
    }

    #[test]
    fn log_p_value_continues_past_underflow() {
        // Where both are representable they agree; far out the series keeps the order.
        for (x, k) in [(30.0, 1), (153.9, 9), (600.0, 3)] {
            let exact = chi_square_sf(x, k).ln();
            assert!(
                (ln_chi_square_sf(x, k) - exact).abs() < 1e-9 * exact.abs(),
                "{x} {k}"
            );
        }
        // chi2(1) at 5000: ln p = -0.5 ln(2 pi) - 0.5 ln 2500 - 2500 ... about -2505.
        let far = ln_chi_square_sf(5000.0, 1);
        assert!(far < -2500.0 && far > -2510.0, "{far}");
        assert!(ln_chi_square_sf(5000.0, 1) < ln_chi_square_sf(3000.0, 1));
    }

    #[test]
    fn separability_names_the_confounded_base_parameters() {
        let names: Vec<String> = ["b", "c", "t"].iter().map(|s| s.to_string()).collect();
        // t is 0.95 correlated with b and barely known; c is independent.
        let (sb, sc, st) = (1.0, 1.0, 0.9);
        let cov = DMatrix::from_row_slice(
            3,
            3,
            &[
                sb * sb,
                0.0,
                0.95 * sb * st,
                0.0,
                sc * sc,
                0.0,
                0.95 * sb * st,
                0.0,
                st * st,
            ],
        );
        let s = separability(
            &names,
            &[1.0, 1.0, 1.0],
            &cov,
            &["t".to_string()],
            &["b".to_string(), "c".to_string()],
        );
        assert!(!s.separable);
        assert_eq!(s.confounded(), vec!["b".to_string()]);
        let gain = InformationGain::new(-100.0, -90.0, 3, 1000);
        assert!((gain.delta_aic - (6.0 - 20.0)).abs() < 1e-12);
    }
}
