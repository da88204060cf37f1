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
//! Correlated estimates: the estimates at neighbouring octaves share data and are correlated,
//! strongly where a random walk dominates (0.88 an octave apart, 0.67 two octaves apart) and
//! less where white noise does (0.52, 0.19) ([`octave_correlation`], measured by Monte-Carlo).
//! Taken as independent they make the long-tau terms look far better determined than they are
//! (a first version did: its walk sigmas were too small by a factor of two and more). So the
//! least squares are generalised: `Sigma_ij = s_i s_j rho_ij` with `s_i^2 = 2 AVAR_i^2 / edf_i`
//! and `rho_ij` from the points' noise types and their distance in octaves; the problem is
//! whitened by the Cholesky factor of `Sigma` and solved as above. `chi^2` is the generalised
//! one, `r^T Sigma^-1 r`.
//!
//! The covariance of the coefficients is `(A^T Sigma^-1 A)^-1` of the chosen subset, scaled by
//! `chi^2 / dof` when that is above 1 (the data scatter more than their degrees of freedom
//! say: the model misses something, and the uncertainties grow with it). A parameter's sigma is
//! its coefficient's, propagated through the square root (first order: poor where the
//! coefficient is not well above its sigma). A term left out has value 0, and as its sigma the
//! level whose coefficient is one sigma of that coefficient in the fit with the term added:
//! the most the data could hide at one sigma. `chi^2` against the `dof = points - terms`
//! degrees of freedom (and its p-value) is the check of the model against the data.
//! `docs/noise.md` reports what a Monte-Carlo over seeds says of the stated uncertainties: on
//! short recordings the selection of terms confuses a bias walk with a bias instability.

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

/// The problem whitened by the covariance of the estimates: `L^-1 A` (all five columns) and
/// `L^-1 y`, with `L L^T = Sigma` (module docs, "correlated estimates").
struct Whitened {
    a: DMatrix<f64>,
    b: DVector<f64>,
}

/// Correlation of the Allan variance estimates at octaves `lag` apart when `noise` dominates
/// both (`lag >= 1`), for the overlapping estimator at octave spacing: measured by Monte-Carlo
/// (400 runs of 32768 records, `m = 1 .. 8192`; `tests/octave_correlation.rs` checks the
/// values) and nearly independent of `m`. Flicker noise, which that check does not generate,
/// takes the geometric mean of the white and random-walk values.
pub fn octave_correlation(noise: NoiseType, lag: usize) -> f64 {
    const WHITE: [f64; 6] = [0.52, 0.19, 0.08, 0.03, 0.0, 0.0];
    const WALK: [f64; 6] = [0.88, 0.67, 0.49, 0.34, 0.23, 0.17];
    const PHASE: [f64; 6] = [0.40, 0.50, 0.50, 0.50, 0.50, 0.50];
    let at = |t: &[f64; 6]| {
        if lag == 0 {
            1.0
        } else if lag <= 6 {
            t[lag - 1]
        } else {
            t[5] * 0.7f64.powi(lag as i32 - 6)
        }
    };
    match noise {
        NoiseType::WhiteRate => at(&WHITE),
        NoiseType::RandomWalk => at(&WALK),
        NoiseType::WhitePhase => at(&PHASE),
        NoiseType::Flicker => (at(&WHITE) * at(&WALK)).sqrt(),
    }
}

/// Whiten the problem: `Sigma_ij = s_i s_j rho_ij` with `rho_ij` the geometric mean of the
/// two points' [`octave_correlation`]s at their distance in octaves (`log2` of the ratio of
/// their `m`). Should that not be positive definite, the correlations are shrunk towards 0
/// until it is.
fn whiten(curve: &AllanCurve, y: &[f64], s: &[f64]) -> Option<Whitened> {
    let p = &curve.points;
    let m = p.len();
    let octave = |i: usize| (p[i].m as f64).log2().round() as i64;
    let rho = |i: usize, j: usize| {
        if i == j {
            return 1.0;
        }
        let lag = (octave(i) - octave(j)).unsigned_abs() as usize;
        (octave_correlation(p[i].noise_type, lag) * octave_correlation(p[j].noise_type, lag)).sqrt()
    };
    let mut shrink = 1.0;
    for _ in 0..40 {
        let sigma = DMatrix::from_fn(m, m, |i, j| {
            let r = if i == j { 1.0 } else { shrink * rho(i, j) };
            s[i] * s[j] * r
        });
        if let Some(ch) = sigma.cholesky() {
            let l = ch.l();
            let a = DMatrix::from_fn(m, 5, |i, c| p[i].tau_s.powi(Term::ALL[c].exponent()));
            let a = l.solve_lower_triangular(&a)?;
            let b = l.solve_lower_triangular(&DVector::from_column_slice(y))?;
            return Some(Whitened { a, b });
        }
        shrink *= 0.9;
    }
    None
}

fn solve(w: &Whitened, mask: u32) -> Option<SubsetFit> {
    let cols: Vec<usize> = (0..5).filter(|j| mask & (1 << j) != 0).collect();
    let (m, k) = (w.a.nrows(), cols.len());
    if k == 0 || k > m {
        return None;
    }
    let mut a = DMatrix::from_fn(m, k, |i, c| w.a[(i, cols[c])]);
    let b = &w.b;
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
    let x = r.solve_upper_triangular(&(q.transpose() * b))?;
    let r_inv = r.solve_upper_triangular(&DMatrix::identity(k, k))?;
    let inv = &r_inv * r_inv.transpose();
    let r = b - &a * &x;
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

/// Penalty per term of the selection (Akaike: 2).
const PENALTY: f64 = 2.0;

/// The feasible subset (all coefficients positive) with the smallest `chi2 + 2 k`.
fn select(w: &Whitened) -> Option<SubsetFit> {
    let m = w.a.nrows();
    let mut best: Option<SubsetFit> = None;
    for mask in 1u32..32 {
        let k = mask.count_ones() as usize;
        if k >= m.max(2) {
            continue;
        }
        let Some(f) = solve(w, mask) else {
            continue;
        };
        if (0..5).any(|j| mask & (1 << j) != 0 && (f.coef[j].is_nan() || f.coef[j] <= 0.0)) {
            continue;
        }
        let score = f.chi2 + PENALTY * f.k as f64;
        if best
            .as_ref()
            .is_none_or(|b| score < b.chi2 + PENALTY * b.k as f64)
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
    let mut w = whiten(curve, &y, &s).ok_or(NoiseError::NoFit)?;
    let mut fit = select(&w).ok_or(NoiseError::NoFit)?;
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
        w = whiten(curve, &y, &s).ok_or(NoiseError::NoFit)?;
        let next = select(&w).ok_or(NoiseError::NoFit)?;
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
                let cs = solve(&w, fit.mask | (1 << j))
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
