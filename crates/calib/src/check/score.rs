//! Score (Lagrange-multiplier) tests of candidate terms, from the posterior of a fit of the
//! model extended by them.
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
//! - [`term_scores`]: the score test of every candidate term from one pass of the model extended
//!   by all of them at once ([`ExtendedPosterior`]), without a fit per term. In the posterior of
//!   all candidates `C` (the base parameters marginalised) the information is `J = P_CC^-1`, the
//!   efficient score at `C = 0` is `s_C = J m_C` and the data's information `E = J - I` (prior
//!   units). Leaving the other candidates out of the model is conditioning on them being zero,
//!   which in information form keeps the term's own block: its statistic is
//!   `s_c^T E_cc^+ s_c`, exactly that of a fit of the base model extended by the term alone
//!   (linear-Gaussian model). The same conditioning gives how far the term, at the size the
//!   data alone give it (`E_cc^+ s_c`, no prior), moves the base parameters
//!   ([`TermScore::largest_shift`]).

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Share of the prior's information below which the data are taken to say nothing about a
/// direction of the parameter space (see [`score_test`]).
pub const MIN_INFORMATION_SHARE: f64 = 0.01;

/// Result of a score test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScoreTest {
    /// The statistic `s^T I^+ s`.
    pub statistic: f64,
    /// Degrees of freedom (the rank of the data's information).
    pub dof: usize,
    /// Probability of a statistic at least this large when the term is absent.
    pub p_value: f64,
    /// Its natural logarithm (finite where the p-value underflows).
    pub ln_p_value: f64,
}

/// Upper tail of the chi-square distribution with `dof` degrees of freedom (1 for `dof = 0`).
pub fn chi_square_sf(x: f64, dof: usize) -> f64 {
    if dof == 0 {
        return 1.0;
    }
    let d = ChiSquared::new(dof as f64).expect("positive degrees of freedom");
    if !x.is_finite() {
        return if x > 0.0 { 0.0 } else { 1.0 };
    }
    d.sf(x.max(0.0)).clamp(0.0, 1.0)
}

/// Natural logarithm of [`chi_square_sf`], finite far into the tail where the p-value itself
/// underflows (statistics of thousands): there the leading term of the incomplete gamma
/// function's asymptotic series, `ln Q(a, y) = (a - 1) ln y - y - ln Gamma(a)` with `a = dof/2`,
/// `y = x/2`. The loop ranks candidates by it: p-values of 0 would tie.
pub fn ln_chi_square_sf(x: f64, dof: usize) -> f64 {
    let p = chi_square_sf(x, dof);
    if p > 1e-300 || dof == 0 || !x.is_finite() {
        return p.ln();
    }
    let (a, y) = (0.5 * dof as f64, 0.5 * x);
    (a - 1.0) * y.ln() - y - statrs::function::gamma::ln_gamma(a)
}

/// The score test of a term whose parameters have prior sigmas `prior_sigma`, posterior mean
/// `theta_hat` and posterior covariance `post_cov` (SI) in the fit of the extended model.
///
/// Computed in prior-normalised coordinates (`u = theta / sigma0`), where the prior is the
/// identity and the parameters' scales (1e-9 to 1e-2) do not matter.
pub fn score_test(theta_hat: &[f64], post_cov: &DMatrix<f64>, prior_sigma: &[f64]) -> ScoreTest {
    let k = theta_hat.len();
    let pn = DMatrix::from_fn(k, k, |i, j| {
        post_cov[(i, j)] / (prior_sigma[i] * prior_sigma[j])
    });
    let u = DVector::from_iterator(k, theta_hat.iter().zip(prior_sigma).map(|(t, s)| t / s));
    // Posterior information in normalised units: Pn^-1 = I_n + identity.
    let eig = SymmetricEigen::new(pn);
    let mut statistic = 0.0;
    let mut dof = 0;
    for (i, &lambda) in eig.eigenvalues.iter().enumerate() {
        // Along an eigenvector v of Pn: posterior variance lambda, data information
        // 1/lambda - 1, score s = (v . u) / lambda, statistic s^2 / info.
        if !(lambda > 0.0 && lambda.is_finite()) {
            continue;
        }
        let info = 1.0 / lambda - 1.0;
        if info < MIN_INFORMATION_SHARE {
            continue;
        }
        let s = eig.eigenvectors.column(i).dot(&u) / lambda;
        statistic += s * s / info;
        dof += 1;
    }
    ScoreTest::of(statistic, dof)
}

impl ScoreTest {
    /// A chi-square statistic with `dof` degrees of freedom and its p-value.
    fn of(statistic: f64, dof: usize) -> Self {
        Self {
            statistic,
            dof,
            p_value: chi_square_sf(statistic, dof),
            ln_p_value: ln_chi_square_sf(statistic, dof),
        }
    }
}

/// The statistic `s^T E^+ s` of a score `s` against the data's information `E` (prior units),
/// over the directions in which the data hold at least [`MIN_INFORMATION_SHARE`] of the
/// prior's information.
fn statistic_of(score: &DVector<f64>, information: &DMatrix<f64>) -> ScoreTest {
    let eig = SymmetricEigen::new((information + information.transpose()) * 0.5);
    let mut statistic = 0.0;
    let mut dof = 0;
    for (i, &e) in eig.eigenvalues.iter().enumerate() {
        if !(e.is_finite() && e >= MIN_INFORMATION_SHARE) {
            continue;
        }
        let s = eig.eigenvectors.column(i).dot(score);
        statistic += s * s / e;
        dof += 1;
    }
    ScoreTest::of(statistic, dof)
}

/// The posterior of one pass of the model extended by every candidate term (SI): the
/// parameters (the attitude errors left out), their prior sigmas, means and covariance, and
/// which of them are each candidate's. Candidates' prior means are zero.
#[derive(Clone, Debug, Default)]
pub struct ExtendedPosterior {
    /// Parameter names.
    pub names: Vec<String>,
    /// Prior sigmas (SI).
    pub prior_sigma: Vec<f64>,
    /// Posterior means (SI).
    pub values: Vec<f64>,
    /// Posterior covariance (SI).
    pub cov: DMatrix<f64>,
    /// Each candidate term: its id and the indices of its parameters.
    pub terms: Vec<(String, Vec<usize>)>,
}

/// A parameter of a candidate term as a fit with the term alone would estimate it (SI).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TermParameter {
    /// Name.
    pub name: String,
    /// Estimate.
    pub value: f64,
    /// Posterior sigma.
    pub sigma: f64,
}

/// The base parameter a candidate term would move most if carried.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BaseShift {
    /// Its name.
    pub name: String,
    /// How far it moves, in its posterior sigmas with the term carried (signed).
    pub sigmas: f64,
}

/// The score test of one candidate term against the model without it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TermScore {
    /// Term id.
    pub term: String,
    /// The test ([`ScoreTest`]; `dof` 0: the data say nothing of the term), against the base
    /// model carrying the terms [`TermScore::given`].
    pub test: ScoreTest,
    /// The terms called for before this one, carried in its test and its shift.
    pub given: Vec<String>,
    /// Its parameters as the model extended by it alone estimates them.
    pub parameters: Vec<TermParameter>,
    /// The base parameter the term moves most at the size the data alone give it (its fit
    /// without a prior on it, in the directions the data inform), in that parameter's sigmas
    /// with the term carried (`None` without base parameters).
    pub largest_shift: Option<BaseShift>,
    /// The blind spot: the largest error (in its sigmas without the term) that the term could
    /// put into a base parameter while its own score test stays below the per-term level's
    /// critical value (non-centrality) and its size within its prior sigma (a plausible unit).
    /// Large where the program hardly separates the term from the base parameters: the term
    /// then biases them without the data calling for it.
    pub blind_shift: Option<BaseShift>,
    /// Whether [`TermScore::test`] and [`TermScore::largest_shift`] are a likelihood ratio's
    /// ([`TermRatio`]) rather than the score test's.
    pub likelihood_ratio: bool,
}

/// A candidate term tested by the likelihood ratio of a fit with it against the fit without
/// it, each with its noise measured from its own innovations: where the noise is measured, a
/// motion's attitude noise takes in what a gyro term would explain, and the score test, made at
/// the noise of the fit without the term, loses its power (a 0.5 % scale asymmetry on 270-degree
/// hand turns of a consumer unit: p = 0.007 by the score test, 1e-25 by the ratio).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TermRatio {
    /// Term id.
    pub term: String,
    /// `2 (l1 - l0)` against the chi-square with the score test's degrees of freedom (the rank
    /// of the data's information on the term). The log-likelihoods are the innovations' (the
    /// prior on the term integrated), so the ratio carries an Occam penalty and the chi-square
    /// is conservative.
    pub test: ScoreTest,
    /// The base parameter the fit with the term moves most from the fit without it, in its
    /// sigmas with the term.
    pub largest_shift: Option<BaseShift>,
    /// The log-likelihoods of the fitted windows without and with the term.
    pub log_likelihoods: (f64, f64),
}

impl TermRatio {
    /// The ratio of `term` from the two fits' log-likelihoods, with `dof` degrees of freedom
    /// and the largest shift of the base parameters `shift`.
    pub fn new(term: &str, (l0, l1): (f64, f64), dof: usize, shift: Option<BaseShift>) -> Self {
        let statistic = (2.0 * (l1 - l0)).max(0.0);
        TermRatio {
            term: term.to_string(),
            test: ScoreTest {
                statistic,
                dof,
                p_value: chi_square_sf(statistic, dof),
                ln_p_value: ln_chi_square_sf(statistic, dof),
            },
            largest_shift: shift,
            log_likelihoods: (l0, l1),
        }
    }
}

/// `scores` with the terms of `ratios` tested by their likelihood ratio in place of the score
/// test.
pub fn with_ratios(scores: &mut [TermScore], ratios: &[TermRatio]) {
    for r in ratios {
        if let Some(t) = scores.iter_mut().find(|t| t.term == r.term) {
            t.test = r.test.clone();
            t.largest_shift = r.largest_shift.clone();
            t.likelihood_ratio = true;
        }
    }
}

/// Symmetric inverse through the eigen-decomposition (`None` if not positive definite).
fn spd_inverse(m: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let sym = (m + m.transpose()) * 0.5;
    let chol = sym.cholesky()?;
    Some(chol.inverse())
}

fn select(m: &DMatrix<f64>, rows: &[usize], cols: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), cols.len(), |i, j| m[(rows[i], cols[j])])
}

fn select_vec(v: &DVector<f64>, rows: &[usize]) -> DVector<f64> {
    DVector::from_fn(rows.len(), |i, _| v[rows[i]])
}

/// The score test of every candidate term of `p` ([`ExtendedPosterior`]), in forward order:
/// the terms ranked by their test against the base model alone, then each tested against the
/// base model carrying the terms called for before it (at the per-term level, `level` divided
/// by the number of terms the data hold information on; Bonferroni), so that a term called for
/// only through its correlation with a stronger one is not called again
/// ([`TermScore::given`]). `level` also sets the non-centrality of [`TermScore::blind_shift`].
/// Empty where the candidates' posterior covariance is not positive definite.
pub fn term_scores(p: &ExtendedPosterior, level: f64) -> Vec<TermScore> {
    let Some(joint) = Joint::of(p) else {
        return Vec::new();
    };
    let solo: Vec<ScoreTest> = (0..p.terms.len()).map(|k| joint.test(k, &[])).collect();
    let per_term = level / solo.iter().filter(|t| t.dof > 0).count().max(1) as f64;
    let mut order: Vec<usize> = (0..p.terms.len()).collect();
    order.sort_by(|&a, &b| solo[a].ln_p_value.total_cmp(&solo[b].ln_p_value));
    let mut carried: Vec<usize> = Vec::new();
    let mut out = Vec::new();
    for k in order {
        let test = joint.test(k, &carried);
        let largest = |shifts: Vec<f64>| {
            shifts
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .map(|(q, &z)| BaseShift {
                    name: p.names[joint.base[q]].clone(),
                    sigmas: z,
                })
        };
        let critical = critical_value(per_term, solo[k].dof.max(1));
        out.push(TermScore {
            term: p.terms[k].0.clone(),
            given: carried.iter().map(|&c| p.terms[c].0.clone()).collect(),
            parameters: joint.parameters(k, p),
            largest_shift: joint.shift(k, &carried).and_then(largest),
            blind_shift: joint.blind(k, critical).and_then(largest),
            test,
            likelihood_ratio: false,
        });
        if out
            .last()
            .is_some_and(|t| t.test.dof > 0 && t.test.p_value < per_term)
        {
            carried.push(k);
        }
    }
    out
}

/// Every candidate term of `p` tested alone against the model without any of them (the other
/// candidates at zero), with its parameters as the model extended by it alone estimates them:
/// what a fit of the base model extended by the one term gives in the linear-Gaussian model,
/// from one pass (the model-extension loop's evidence, `crate::extend`). `None` where the
/// candidates' posterior covariance is not positive definite.
pub fn solo_scores(p: &ExtendedPosterior) -> Option<Vec<(ScoreTest, Vec<TermParameter>)>> {
    let joint = Joint::of(p)?;
    Some(
        (0..p.terms.len())
            .map(|k| (joint.test(k, &[]), joint.parameters(k, p)))
            .collect(),
    )
}

/// The candidates' joint posterior in prior units, from which every term's test comes.
struct Joint {
    /// Normalised means and covariance of every parameter.
    u: DVector<f64>,
    pn: DMatrix<f64>,
    /// The candidates' parameters, term after term, and the base parameters.
    cand: Vec<usize>,
    base: Vec<usize>,
    /// The candidates' posterior information `J = P_CC^-1`, efficient score `s = J m_C` and
    /// data information `E = J - I`.
    j: DMatrix<f64>,
    s: DVector<f64>,
    e: DMatrix<f64>,
    /// Each term's parameters: positions in the candidate block, and indices in `p`.
    positions: Vec<Vec<usize>>,
    indices: Vec<Vec<usize>>,
}

impl Joint {
    fn of(p: &ExtendedPosterior) -> Option<Self> {
        let n = p.names.len();
        let u = DVector::from_fn(n, |i, _| p.values[i] / p.prior_sigma[i]);
        let pn = DMatrix::from_fn(n, n, |i, j| {
            p.cov[(i, j)] / (p.prior_sigma[i] * p.prior_sigma[j])
        });
        let cand: Vec<usize> = p.terms.iter().flat_map(|(_, ix)| ix.clone()).collect();
        let base: Vec<usize> = (0..n).filter(|i| !cand.contains(i)).collect();
        let j = spd_inverse(&select(&pn, &cand, &cand))?;
        let s = &j * select_vec(&u, &cand);
        let e = &j - DMatrix::identity(cand.len(), cand.len());
        let positions = p
            .terms
            .iter()
            .scan(0, |at, (_, ix)| {
                let pos: Vec<usize> = (*at..*at + ix.len()).collect();
                *at += ix.len();
                Some(pos)
            })
            .collect();
        let indices = p.terms.iter().map(|(_, ix)| ix.clone()).collect();
        Some(Self {
            u,
            pn,
            cand,
            base,
            j,
            s,
            e,
            positions,
            indices,
        })
    }

    /// The positions (candidate block) of the terms `terms`.
    fn block(&self, terms: &[usize]) -> Vec<usize> {
        terms
            .iter()
            .flat_map(|&t| self.positions[t].clone())
            .collect()
    }

    /// The indices (in `p`) of the terms `terms`.
    fn params(&self, terms: &[usize]) -> Vec<usize> {
        terms
            .iter()
            .flat_map(|&t| self.indices[t].clone())
            .collect()
    }

    /// The score test of term `k` against the base model carrying the terms `carried` with
    /// their priors: efficient score `s_k - E_kA J_AA^-1 s_A` and data information
    /// `E_kk - E_kA J_AA^-1 E_Ak` (`J_AA = I + E_AA`, the carried terms' posterior information).
    fn test(&self, k: usize, carried: &[usize]) -> ScoreTest {
        let pos = &self.positions[k];
        let mut score = select_vec(&self.s, pos);
        let mut info = select(&self.e, pos, pos);
        let a = self.block(carried);
        if let Some(inv) = (!a.is_empty())
            .then(|| spd_inverse(&select(&self.j, &a, &a)))
            .flatten()
        {
            let gain = select(&self.e, pos, &a) * inv;
            score -= &gain * select_vec(&self.s, &a);
            info -= &gain * select(&self.e, &a, pos);
        }
        statistic_of(&score, &info)
    }

    /// Term `k`'s parameters as the base model extended by it alone estimates them (SI).
    fn parameters(&self, k: usize, p: &ExtendedPosterior) -> Vec<TermParameter> {
        let pos = &self.positions[k];
        let Some(pk) = spd_inverse(&select(&self.j, pos, pos)) else {
            return Vec::new();
        };
        let theta = &pk * select_vec(&self.s, pos);
        self.indices[k]
            .iter()
            .enumerate()
            .map(|(q, &i)| TermParameter {
                name: p.names[i].clone(),
                value: theta[q] * p.prior_sigma[i],
                sigma: pk[(q, q)].max(0.0).sqrt() * p.prior_sigma[i],
            })
            .collect()
    }

    /// How far term `k`, at the size the data alone give it, moves each base parameter from
    /// where the base model carrying `carried` has it, in its sigmas with `k` carried (the other
    /// candidates at zero). The data's own estimate, not the posterior mean with the term's
    /// prior: the prior shrinks a weakly determined term toward zero, and with it the shift, so
    /// a term several times its grade's prior (the size that moves a base parameter by ten
    /// sigma) would be judged by a fraction of its effect. Directions the data hold less than
    /// [`MIN_INFORMATION_SHARE`] of the prior's information on are left at zero, as in the test.
    fn shift(&self, k: usize, carried: &[usize]) -> Option<Vec<f64>> {
        let kept: Vec<usize> = self
            .base
            .iter()
            .copied()
            .chain(self.params(carried))
            .collect();
        let all: Vec<usize> = carried.iter().copied().chain([k]).collect();
        let rest: Vec<usize> = (0..self.positions.len())
            .filter(|t| !all.contains(t))
            .collect();
        let (mean, cov) = conditional(
            &self.pn,
            &self.u,
            &kept,
            &self.indices[k],
            &self.params(&rest),
        )?;
        let (nx, nt) = (kept.len(), self.indices[k].len());
        let c_tt = cov.view((nx, nx), (nt, nt)).into_owned();
        let c_tt_inv = spd_inverse(&c_tt)?;
        // The x-on-t regression is the same with any prior on t (independent of x), so the
        // base mean at the data's estimate is the mean at t = 0 plus the regression times it.
        let regression = cov.view((0, nx), (nx, nt)) * &c_tt_inv;
        let score = &c_tt_inv * mean.rows(nx, nt);
        let information = c_tt_inv - DMatrix::identity(nt, nt);
        let theta = informed_solve(&information, &score);
        let moved = regression * theta;
        Some(
            (0..self.base.len())
                .map(|q| moved[q] / cov[(q, q)].max(f64::MIN_POSITIVE).sqrt())
                .collect(),
        )
    }

    /// Term `k`'s blind spot against the base model alone ([`blind_shifts`]).
    fn blind(&self, k: usize, critical: f64) -> Option<Vec<f64>> {
        let others: Vec<usize> = self
            .cand
            .iter()
            .copied()
            .filter(|i| !self.indices[k].contains(i))
            .collect();
        let (_, cov) = conditional(&self.pn, &self.u, &self.base, &self.indices[k], &others)?;
        let pos = &self.positions[k];
        blind_shifts(&cov, self.base.len(), &select(&self.e, pos, pos), critical)
    }
}

/// The chi-square critical value with `dof` degrees of freedom at the upper-tail level `level`.
pub fn critical_value(level: f64, dof: usize) -> f64 {
    ChiSquared::new(dof as f64)
        .map(|d| d.inverse_cdf((1.0 - level).clamp(0.0, 1.0 - 1e-16)))
        .unwrap_or(f64::INFINITY)
}

/// The largest error, in each base parameter's sigmas of the base model's fit, that a term
/// could cause with its score test's non-centrality at most `critical` and its size within its
/// prior: `max |r_i . theta| / sigma0_i` over `theta^T (E / critical + I) theta <= 1` (prior
/// units; the two ellipsoids' intersection replaced by the one ellipsoid of their summed
/// forms, which lies inside it), `r_i` the regression of base parameter `i` on the term in
/// the posterior `cov` (base first, `nb` of them, then the term), `sigma0_i` its sigma with the
/// term left out. What a base-model fit misses unseen.
fn blind_shifts(
    cov: &DMatrix<f64>,
    nb: usize,
    information: &DMatrix<f64>,
    critical: f64,
) -> Option<Vec<f64>> {
    let nt = cov.nrows() - nb;
    let s_bt = cov.view((0, nb), (nb, nt)).into_owned();
    let s_tt = cov.view((nb, nb), (nt, nt)).into_owned();
    let regression = &s_bt * spd_inverse(&s_tt)?;
    let without = cov.view((0, 0), (nb, nb)) - &regression * s_bt.transpose();
    let form = information / critical.max(f64::MIN_POSITIVE) + DMatrix::identity(nt, nt);
    let reach = spd_inverse(&form)?;
    Some(
        (0..nb)
            .map(|i| {
                let r = regression.row(i).transpose();
                let z = (r.transpose() * &reach * &r)[(0, 0)].max(0.0).sqrt();
                z / without[(i, i)].max(f64::MIN_POSITIVE).sqrt()
            })
            .collect(),
    )
}

/// The posterior of the base parameters and the term `term` with the other candidates
/// `others` at zero (prior units): mean and covariance, base first.
fn conditional(
    pn: &DMatrix<f64>,
    u: &DVector<f64>,
    base: &[usize],
    term: &[usize],
    others: &[usize],
) -> Option<(DVector<f64>, DMatrix<f64>)> {
    let x: Vec<usize> = base.iter().chain(term).copied().collect();
    let (mut mean, mut cov) = (select_vec(u, &x), select(pn, &x, &x));
    if !others.is_empty() {
        let gain = select(pn, &x, others) * spd_inverse(&select(pn, others, others))?;
        mean -= &gain * select_vec(u, others);
        cov -= &gain * select(pn, others, &x);
    }
    Some((mean, cov))
}

/// `E^+ s` over the directions in which the data hold at least [`MIN_INFORMATION_SHARE`] of the
/// prior's information (prior units): the term's estimate from the data alone.
fn informed_solve(information: &DMatrix<f64>, score: &DVector<f64>) -> DVector<f64> {
    let eig = SymmetricEigen::new((information + information.transpose()) * 0.5);
    let mut theta = DVector::zeros(score.len());
    for (i, &e) in eig.eigenvalues.iter().enumerate() {
        if e.is_finite() && e >= MIN_INFORMATION_SHARE {
            let v = eig.eigenvectors.column(i);
            theta += v * (v.dot(score) / e);
        }
    }
    theta
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{SeedableRng, rngs::StdRng};
    use rand_distr::{Distribution, StandardNormal};

    /// The posterior of `y = H x + v` (`v ~ N(0, 1)`) with prior `x ~ N(0, diag(s0^2))`.
    fn posterior(h: &DMatrix<f64>, s0: &[f64], y: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
        let mut info = h.transpose() * h;
        for (k, s) in s0.iter().enumerate() {
            info[(k, k)] += 1.0 / (s * s);
        }
        let cov = info.try_inverse().unwrap();
        let mean = &cov * h.transpose() * y;
        (mean, cov)
    }

    fn columns(h: &DMatrix<f64>, cols: &[usize]) -> DMatrix<f64> {
        DMatrix::from_fn(h.nrows(), cols.len(), |i, j| h[(i, cols[j])])
    }

    /// One pass with every candidate gives, for each, the statistic and estimate of a fit of
    /// the base model with that candidate alone, and the base shift of that fit with no prior
    /// on the candidate, to rounding.
    #[test]
    fn joint_pass_gives_each_terms_own_fit() {
        let mut rng = StdRng::seed_from_u64(20_261_205);
        let m = 80;
        // Columns 0-2 base, 3-4 term a, 5 term c; c correlated with base 0 and with a.
        let h = DMatrix::from_fn(m, 6, |i, j| {
            let t = i as f64;
            match j {
                0 => (t * 0.31).sin(),
                1 => (t * 0.17).cos(),
                2 => 1.0,
                3 => (t * 0.05).sin() + 0.3 * (t * 0.31).sin(),
                4 => (t * 0.9).cos(),
                _ => 0.6 * (t * 0.31).sin() + 0.2 * (t * 0.9).cos() + 0.4 * (t * 0.4).cos(),
            }
        });
        let s0 = [1.0, 2.0, 0.5, 0.3, 0.2, 0.1];
        let x = DVector::from_vec(vec![0.5, -1.0, 0.2, 1.5, 0.0, 0.0]);
        let v = DVector::from_fn(m, |_, _| StandardNormal.sample(&mut rng));
        let y = &h * &x + v;
        let (mean, cov) = posterior(&h, &s0, &y);
        let names: Vec<String> = ["b0", "b1", "b2", "a0", "a1", "c0"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let joint = ExtendedPosterior {
            names,
            prior_sigma: s0.to_vec(),
            values: mean.iter().copied().collect(),
            cov,
            terms: vec![("a".into(), vec![3, 4]), ("c".into(), vec![5])],
        };
        let scores = term_scores(&joint, 0.01);
        assert_eq!(scores.len(), 2);
        // a is there and strongest: tested first against the base model alone; c then against
        // the base model carrying a.
        assert_eq!(scores[0].term, "a");
        assert_eq!(scores[1].term, "c");
        assert_eq!(scores[1].given, vec!["a".to_string()]);
        for (k, base_cols, cols) in [
            (0, vec![0, 1, 2], vec![3, 4]),
            (1, vec![0, 1, 2, 3, 4], vec![5]),
        ] {
            let nb = base_cols.len();
            let (bm, _) = posterior(
                &columns(&h, &base_cols),
                &base_cols.iter().map(|&i| s0[i]).collect::<Vec<_>>(),
                &y,
            );
            let all: Vec<usize> = base_cols.iter().chain(&cols).copied().collect();
            let sub_s0: Vec<f64> = all.iter().map(|&i| s0[i]).collect();
            let (mk, ck) = posterior(&columns(&h, &all), &sub_s0, &y);
            let nt = cols.len();
            let theta: Vec<f64> = (0..nt).map(|q| mk[nb + q]).collect();
            let pc = ck.view((nb, nb), (nt, nt)).into_owned();
            let alone = score_test(&theta, &pc, &sub_s0[nb..]);
            let t = &scores[k];
            assert!(
                (t.test.statistic - alone.statistic).abs() < 1e-8 * (1.0 + alone.statistic),
                "{k}: {} against {}",
                t.test.statistic,
                alone.statistic
            );
            assert_eq!(t.test.dof, alone.dof);
            if k == 0 {
                for q in 0..nt {
                    assert!((t.parameters[q].value - theta[q]).abs() < 1e-9);
                    assert!((t.parameters[q].sigma - pc[(q, q)].sqrt()).abs() < 1e-9);
                }
            }
            // The data's own estimate of the term: its prior made a million times wider.
            let flat_s0: Vec<f64> = all
                .iter()
                .enumerate()
                .map(|(q, &i)| if q < nb { s0[i] } else { s0[i] * 1e6 })
                .collect();
            let (mf, _) = posterior(&columns(&h, &all), &flat_s0, &y);
            let shifts: Vec<f64> = (0..3)
                .map(|q| (mf[q] - bm[q]) / ck[(q, q)].sqrt())
                .collect();
            let (q, z) = shifts
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                .unwrap();
            let shift = t.largest_shift.as_ref().unwrap();
            assert_eq!(shift.name, ["b0", "b1", "b2"][q]);
            assert!(
                (shift.sigmas - z).abs() < 1e-6 * (1.0 + z.abs()),
                "{} against {z}",
                shift.sigmas
            );
        }
        // The term that is there (a) is called for; the one that is not (c) is not.
        assert!(scores[0].test.p_value < 1e-6, "{:?}", scores[0].test);
        assert!(scores[1].test.p_value > 1e-3, "{:?}", scores[1].test);
    }
}
