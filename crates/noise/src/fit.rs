//! The fit of the IEEE noise terms to an Allan variance curve, with uncertainties.
//!
//! Each term adds a power of `tau` to the Allan variance (IEEE Std 952-1997, annex C; Std
//! 1554-2005):
//!
//! | term ([`Term`]) | parameter (SI, gyro / accelerometer) | `AVAR(tau)` |
//! |---|---|---|
//! | quantisation `Q` | rad, m/s | `3 Q^2 / tau^2` |
//! | white noise `N` | rad/s/sqrt(Hz), m/s^2/sqrt(Hz) | `N^2 / tau` |
//! | bias instability `B` | rad/s, m/s^2 | `(2 ln 2 / pi) B^2` |
//! | bias random walk `K` | rad/s/sqrt(s), m/s^2/sqrt(s) | `K^2 tau / 3` |
//! | rate ramp `R` | rad/s^2, m/s^3 | `R^2 tau^2 / 2` |
//!
//! `N` is the deviation of a 1-s average of the rate, the `[noise]` convention of the run
//! configuration; `B` is the flicker floor, whose Allan deviation is `0.664 B`.
//!
//! The model is linear in the coefficients `c_j` of the powers of `tau`, and each estimate
//! `s^2(tau_i)` is `AVAR(tau_i) chi^2(edf_i) / edf_i`: unbiased, with variance
//! `2 AVAR(tau_i)^2 / edf_i`. So the fit is weighted least squares on the variance (not on the
//! deviation, whose estimate is biased low at few degrees of freedom, and not on its logarithm,
//! biased likewise), with the weights from the degrees of freedom. The weights use the model's
//! variance, not the measured one: weights from the data give the points that came out low
//! the larger weight and bias the fit low. The model's variance needs the model, so the fit
//! iterates: a first pass weighted by the data, then passes weighted by the last pass's model,
//! which also names the term that dominates at each `tau` and with it the noise type of that
//! point's degrees of freedom ([`crate::edf`]), until the terms and coefficients settle.
//!
//! Coefficients are non-negative (a variance is a sum of non-negative terms). With five terms
//! the constrained problem is solved exactly by trying every subset of terms (31): the
//! non-negative least-squares solution is the unconstrained solution on one subset whose
//! coefficients are all positive. Among the feasible subsets the one with the smallest
//! `chi^2 + 2 k` (Akaike's criterion, `k` terms) is taken, so a term enters only where the data
//! show it: the "rate ramp where visible" of the standards, and no quantisation invented from a
//! white curve.
//!
//! The covariance of the coefficients is `(A^T W A)^-1` of the chosen subset, scaled by
//! `chi^2 / dof` when that is above 1 (the data scatter more than their degrees of freedom
//! say: the model misses something, and the uncertainties grow with it). A parameter's sigma is
//! its coefficient's, propagated through the square root. A term left out has value 0, and as
//! its sigma the level whose coefficient is one sigma of that coefficient in the fit with the
//! term added: the most the data could hide at one sigma. `chi^2` against the
//! `dof = points - terms` degrees of freedom (and its p-value) is the check of the model
//! against the data. Neighbouring octave estimates are correlated (they share data), which the
//! fit ignores: `docs/noise.md` reports what a Monte-Carlo over seeds says of the stated
//! uncertainties.

use crate::NoiseError;
use crate::allan::AllanCurve;
use crate::edf::NoiseType;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// A noise term of the Allan variance model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Term {
    /// Quantisation `Q` (rad or m/s): `3 Q^2 / tau^2`.
    Quantisation,
    /// White rate noise `N` (rad/s or m/s^2 at 1 Hz, i.e. of a 1-s average): `N^2 / tau`.
    White,
    /// Bias instability `B` (rad/s or m/s^2): `(2 ln 2 / pi) B^2`.
    BiasInstability,
    /// Bias random walk `K` (rad/s/sqrt(s) or m/s^2/sqrt(s)): `K^2 tau / 3`.
    RandomWalk,
    /// Rate ramp `R` (rad/s^2 or m/s^3): `R^2 tau^2 / 2`.
    RateRamp,
}

impl Term {
    /// The five terms, in increasing power of `tau`.
    pub const ALL: [Term; 5] = [
        Term::Quantisation,
        Term::White,
        Term::BiasInstability,
        Term::RandomWalk,
        Term::RateRamp,
    ];

    /// The power of `tau` in the term's Allan variance.
    pub fn exponent(self) -> i32 {
        match self {
            Term::Quantisation => -2,
            Term::White => -1,
            Term::BiasInstability => 0,
            Term::RandomWalk => 1,
            Term::RateRamp => 2,
        }
    }

    /// The factor `f` in `AVAR = f p^2 tau^exponent` for the parameter `p`.
    pub fn factor(self) -> f64 {
        match self {
            Term::Quantisation => 3.0,
            Term::White => 1.0,
            Term::BiasInstability => 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI,
            Term::RandomWalk => 1.0 / 3.0,
            Term::RateRamp => 0.5,
        }
    }

    /// The term's Allan variance at `tau_s` for the parameter `value`.
    pub fn avar(self, value: f64, tau_s: f64) -> f64 {
        self.factor() * value * value * tau_s.powi(self.exponent())
    }

    /// The noise type whose degrees of freedom apply where this term dominates.
    pub fn noise_type(self) -> NoiseType {
        match self {
            Term::Quantisation => NoiseType::WhitePhase,
            Term::White => NoiseType::WhiteRate,
            Term::BiasInstability => NoiseType::Flicker,
            Term::RandomWalk | Term::RateRamp => NoiseType::RandomWalk,
        }
    }

    /// A short name: `quantisation`, `white`, `bias_instability`, `random_walk`, `rate_ramp`.
    pub fn name(self) -> &'static str {
        match self {
            Term::Quantisation => "quantisation",
            Term::White => "white",
            Term::BiasInstability => "bias_instability",
            Term::RandomWalk => "random_walk",
            Term::RateRamp => "rate_ramp",
        }
    }

    fn index(self) -> usize {
        Term::ALL.iter().position(|t| *t == self).expect("a term")
    }
}

/// One term of a fit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TermEstimate {
    /// Which term.
    pub term: Term,
    /// Whether the chosen model has it (else its value is 0).
    pub included: bool,
    /// The parameter (SI; see [`Term`]).
    pub value: f64,
    /// Its one-sigma uncertainty; for a term left out, the level the data could hide at one
    /// sigma (module docs).
    pub sigma: f64,
    /// Coefficient of `tau^exponent` in the Allan variance.
    pub coefficient: f64,
    /// Its one-sigma uncertainty.
    pub coefficient_sigma: f64,
}

/// A fit of the noise terms to an Allan variance curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseFit {
    /// The five terms in [`Term::ALL`] order.
    pub terms: Vec<TermEstimate>,
    /// Weighted sum of squared residuals of the variance, `sum (s^2 - model)^2 / var`, with
    /// `var = 2 model^2 / edf`.
    pub chi2: f64,
    /// Degrees of freedom of the fit: points minus terms.
    pub dof: usize,
    /// Probability of a `chi2` this large or larger if the model were right.
    pub p_value: f64,
    /// Factor applied to the sigmas: `sqrt(chi2 / dof)` when above 1, else 1.
    pub sigma_scale: f64,
    /// Passes of the iteration (weights and noise types from the last model).
    pub iterations: usize,
}

impl NoiseFit {
    /// The estimate of a term.
    pub fn term(&self, term: Term) -> &TermEstimate {
        &self.terms[term.index()]
    }

    /// The fitted Allan variance at `tau_s`.
    pub fn avar(&self, tau_s: f64) -> f64 {
        self.terms
            .iter()
            .filter(|t| t.included)
            .map(|t| t.coefficient * tau_s.powi(t.term.exponent()))
            .sum()
    }

    /// The term that contributes most to the fitted variance at `tau_s`.
    pub fn dominant(&self, tau_s: f64) -> Term {
        self.terms
            .iter()
            .filter(|t| t.included)
            .map(|t| (t.term, t.coefficient * tau_s.powi(t.term.exponent())))
            .fold((Term::White, f64::NEG_INFINITY), |best, x| {
                if x.1 > best.1 { x } else { best }
            })
            .0
    }
}

/// Weighted least squares on the terms of `mask`: coefficients, their covariance (unscaled)
/// and chi^2; `None` when the columns are (numerically) dependent.
struct SubsetFit {
    mask: u32,
    coef: [f64; 5],
    cov: [[f64; 5]; 5],
    chi2: f64,
    k: usize,
}

fn solve(tau: &[f64], y: &[f64], s: &[f64], mask: u32) -> Option<SubsetFit> {
    let cols: Vec<usize> = (0..5).filter(|j| mask & (1 << j) != 0).collect();
    let (m, k) = (tau.len(), cols.len());
    if k == 0 || k > m {
        return None;
    }
    let mut a = DMatrix::from_fn(m, k, |i, c| {
        tau[i].powi(Term::ALL[cols[c]].exponent()) / s[i]
    });
    let b = DVector::from_fn(m, |i, _| y[i] / s[i]);
    // Columns scaled to unit length: tau^-2 and tau^2 differ by 1e20 over a long recording.
    let scale: Vec<f64> = (0..k).map(|c| a.column(c).norm()).collect();
    if scale.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
        return None;
    }
    for (c, sc) in scale.iter().enumerate() {
        a.column_mut(c).scale_mut(1.0 / sc);
    }
    // Householder QR: A = Q R, x = R^-1 Q^T b, (A^T A)^-1 = R^-1 R^-T.
    let qr = a.clone().qr();
    let (q, r) = (qr.q(), qr.r());
    let diag: Vec<f64> = (0..k).map(|i| r[(i, i)].abs()).collect();
    let (dmax, dmin) = diag
        .iter()
        .fold((0.0f64, f64::INFINITY), |(a, b), d| (a.max(*d), b.min(*d)));
    if dmin.is_nan() || dmin <= 1e-10 * dmax {
        return None;
    }
    let x = r.solve_upper_triangular(&(q.transpose() * &b))?;
    let r_inv = r.solve_upper_triangular(&DMatrix::identity(k, k))?;
    let inv = &r_inv * r_inv.transpose();
    let r = &b - &a * &x;
    let mut out = SubsetFit {
        mask,
        coef: [0.0; 5],
        cov: [[0.0; 5]; 5],
        chi2: r.norm_squared(),
        k,
    };
    for (ci, &i) in cols.iter().enumerate() {
        out.coef[i] = x[ci] / scale[ci];
        for (cj, &j) in cols.iter().enumerate() {
            out.cov[i][j] = inv[(ci, cj)] / (scale[ci] * scale[cj]);
        }
    }
    Some(out)
}

/// The feasible subset (all coefficients positive) with the smallest `chi2 + 2 k`.
fn select(tau: &[f64], y: &[f64], s: &[f64]) -> Option<SubsetFit> {
    let m = tau.len();
    let mut best: Option<SubsetFit> = None;
    for mask in 1u32..32 {
        let k = mask.count_ones() as usize;
        if k >= m.max(2) {
            continue;
        }
        let Some(f) = solve(tau, y, s, mask) else {
            continue;
        };
        if (0..5).any(|j| mask & (1 << j) != 0 && (f.coef[j].is_nan() || f.coef[j] <= 0.0)) {
            continue;
        }
        let score = f.chi2 + 2.0 * f.k as f64;
        if best
            .as_ref()
            .is_none_or(|b| score < b.chi2 + 2.0 * b.k as f64)
        {
            best = Some(f);
        }
    }
    best
}

fn model(f: &SubsetFit, tau: f64) -> f64 {
    (0..5)
        .filter(|j| f.mask & (1 << j) != 0)
        .map(|j| f.coef[j] * tau.powi(Term::ALL[j].exponent()))
        .sum()
}

/// Fit the noise terms to `curve` (module docs) and set the curve's noise types, degrees of
/// freedom and confidence intervals from the fitted model.
pub fn fit_terms(curve: &mut AllanCurve) -> Result<NoiseFit, NoiseError> {
    let tau: Vec<f64> = curve.points.iter().map(|p| p.tau_s).collect();
    let y: Vec<f64> = curve.points.iter().map(|p| p.avar).collect();
    if tau.len() < 2 {
        return Err(NoiseError::TooFewPoints(tau.len()));
    }
    if let Some(p) = curve
        .points
        .iter()
        .find(|p| p.avar.is_nan() || p.avar <= 0.0)
    {
        return Err(NoiseError::NoNoise { tau_s: p.tau_s });
    }
    // First pass: weights from the data.
    let mut s: Vec<f64> = curve
        .points
        .iter()
        .map(|p| p.avar * (2.0 / p.edf).sqrt())
        .collect();
    let mut fit = select(&tau, &y, &s).ok_or(NoiseError::NoFit)?;
    let mut iterations = 1;
    for _ in 0..30 {
        let types: Vec<NoiseType> = tau
            .iter()
            .map(|&t| {
                let j = (0..5)
                    .filter(|j| fit.mask & (1 << j) != 0)
                    .max_by(|&a, &b| {
                        let ca = fit.coef[a] * t.powi(Term::ALL[a].exponent());
                        let cb = fit.coef[b] * t.powi(Term::ALL[b].exponent());
                        ca.total_cmp(&cb)
                    })
                    .expect("a term");
                Term::ALL[j].noise_type()
            })
            .collect();
        curve.set_noise_types(&types);
        s = curve
            .points
            .iter()
            .map(|p| model(&fit, p.tau_s) * (2.0 / p.edf).sqrt())
            .collect();
        let next = select(&tau, &y, &s).ok_or(NoiseError::NoFit)?;
        iterations += 1;
        let settled = next.mask == fit.mask
            && (0..5).all(|j| (next.coef[j] - fit.coef[j]).abs() <= 1e-9 * fit.coef[j].abs());
        fit = next;
        if settled {
            break;
        }
    }
    let dof = tau.len() - fit.k;
    let p_value = if dof > 0 {
        ChiSquared::new(dof as f64).map_or(f64::NAN, |d| 1.0 - d.cdf(fit.chi2))
    } else {
        f64::NAN
    };
    let scale2 = if dof > 0 {
        (fit.chi2 / dof as f64).max(1.0)
    } else {
        1.0
    };
    let terms = Term::ALL
        .iter()
        .enumerate()
        .map(|(j, &term)| {
            let f = term.factor();
            if fit.mask & (1 << j) != 0 {
                let c = fit.coef[j];
                let cs = (fit.cov[j][j] * scale2).sqrt();
                let value = (c / f).sqrt();
                TermEstimate {
                    term,
                    included: true,
                    value,
                    sigma: cs / (2.0 * (c * f).sqrt()),
                    coefficient: c,
                    coefficient_sigma: cs,
                }
            } else {
                let cs = solve(&tau, &y, &s, fit.mask | (1 << j))
                    .map_or(f64::NAN, |g| (g.cov[j][j] * scale2).sqrt());
                TermEstimate {
                    term,
                    included: false,
                    value: 0.0,
                    sigma: (cs / f).sqrt(),
                    coefficient: 0.0,
                    coefficient_sigma: cs,
                }
            }
        })
        .collect();
    Ok(NoiseFit {
        terms,
        chi2: fit.chi2,
        dof,
        p_value,
        sigma_scale: scale2.sqrt(),
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::allan::AllanPoint;

    /// A curve that is exactly a model (no scatter): the fit must give the model back.
    fn exact_curve(values: &[(Term, f64)], n: usize) -> AllanCurve {
        let mut points = Vec::new();
        let mut m = 1;
        while 2 * m <= n {
            let tau = m as f64 * 0.01;
            let avar: f64 = values.iter().map(|(t, v)| t.avar(*v, tau)).sum();
            points.push(AllanPoint {
                m,
                tau_s: tau,
                avar,
                adev: avar.sqrt(),
                terms: n + 1 - 2 * m,
                edf: 0.0,
                noise_type: NoiseType::WhiteRate,
                lower: 0.0,
                upper: 0.0,
            });
            m *= 2;
        }
        let mut c = AllanCurve {
            tau0_s: 0.01,
            interval_records: vec![n],
            points,
        };
        let w = vec![NoiseType::WhiteRate; c.points.len()];
        c.set_noise_types(&w);
        c
    }

    #[test]
    fn an_exact_curve_gives_its_terms_back() {
        let truth = [
            (Term::White, 5e-7),
            (Term::BiasInstability, 3e-7),
            // Dominant from tau = 250 s on: visible to the fit.
            (Term::RandomWalk, 2e-8),
        ];
        let mut c = exact_curve(&truth, 1 << 20);
        let f = fit_terms(&mut c).unwrap();
        for (t, v) in truth {
            let e = f.term(t);
            assert!(e.included, "{t:?}");
            assert!((e.value - v).abs() < 1e-6 * v, "{t:?}: {} {v}", e.value);
        }
        assert!(!f.term(Term::Quantisation).included);
        assert!(!f.term(Term::RateRamp).included);
        assert!(f.chi2 < 1e-12);
        assert_eq!(f.dof, c.points.len() - 3);
        // The dominant term sets the noise type of each point.
        assert_eq!(c.points[0].noise_type, NoiseType::WhiteRate);
        assert_eq!(c.points.last().unwrap().noise_type, NoiseType::RandomWalk);
        assert_eq!(f.dominant(0.01), Term::White);
    }

    #[test]
    fn a_curve_without_noise_is_refused() {
        let mut c = exact_curve(&[(Term::White, 0.0)], 64);
        assert!(matches!(fit_terms(&mut c), Err(NoiseError::NoNoise { .. })));
    }
}
