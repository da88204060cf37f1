//! Generalised least-squares regression of the innovations on candidate regressors: a
//! score-type test of whether an unmodelled term explains them.

use super::{DiagnosticsError, Innovation, whitening_factor};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::{Deserialize, Serialize};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// The result of [`regression_test`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegressionTest {
    /// `b^T A^-1 b`: chi-square with `dof` degrees of freedom when the regressors explain
    /// nothing.
    pub statistic: f64,
    /// Number of regressor columns.
    pub dof: usize,
    /// `P(chi2(dof) > statistic)`.
    pub p_value: f64,
    /// GLS coefficients `A^-1 b`, one per column (units: innovation over regressor).
    pub coefficients: Vec<f64>,
    /// Their standard deviations, `sqrt(diag A^-1)`.
    pub sigma: Vec<f64>,
    /// Innovations used (those with a positive definite `S`).
    pub used: usize,
}

/// GLS regression `nu_k = sum_j a_j r_jk + e_k`, `e_k ~ N(0, S_k)` independent: with
/// `A = sum_k R_k^T S_k^-1 R_k`, `b = sum_k R_k^T S_k^-1 nu_k`, the coefficients are `A^-1 b` and
/// `b^T A^-1 b` is chi-square with as many degrees of freedom as columns when the true
/// coefficients are zero. `regressors[j][k]` is column `j` at innovation `k` (same units as the
/// innovation per unit coefficient). Innovations whose `S` is not positive definite are left
/// out.
///
/// The filter has already partly absorbed an unmodelled effect into its states, so the
/// coefficients are not the effect's size; the test is of whether the innovations still carry
/// it.
pub fn regression_test(
    innov: &[Innovation],
    regressors: &[Vec<Vector3<f64>>],
) -> Result<RegressionTest, DiagnosticsError> {
    let p = regressors.len();
    if p == 0 {
        return Err(DiagnosticsError::NoRegressors);
    }
    for (j, col) in regressors.iter().enumerate() {
        if col.len() != innov.len() {
            return Err(DiagnosticsError::LengthMismatch {
                column: j,
                len: col.len(),
                expected: innov.len(),
            });
        }
    }
    let mut a = DMatrix::<f64>::zeros(p, p);
    let mut b = DVector::<f64>::zeros(p);
    let mut g = DMatrix::<f64>::zeros(3, p);
    let mut used = 0;
    for (k, inn) in innov.iter().enumerate() {
        let Some(l) = whitening_factor(&inn.s) else {
            continue;
        };
        let Some(w) = l
            .solve_lower_triangular(&inn.nu)
            .filter(|w| w.iter().all(|v| v.is_finite()))
        else {
            continue;
        };
        let mut finite = true;
        for (j, col) in regressors.iter().enumerate() {
            match l.solve_lower_triangular(&col[k]) {
                Some(v) if v.iter().all(|x| x.is_finite()) => g.set_column(j, &v),
                _ => finite = false,
            }
        }
        if !finite {
            return Err(DiagnosticsError::NonFiniteRegressor { row: k });
        }
        a += g.transpose() * &g;
        b += g.transpose() * w;
        used += 1;
    }
    if used == 0 {
        return Err(DiagnosticsError::NoUsableInnovations);
    }
    let chol = a.clone().cholesky().ok_or(DiagnosticsError::Singular)?;
    let coef = chol.solve(&b);
    let inv = chol.inverse();
    let statistic = b.dot(&coef);
    let p_value = ChiSquared::new(p as f64).map_or(f64::NAN, |d| d.sf(statistic));
    Ok(RegressionTest {
        statistic,
        dof: p,
        p_value,
        coefficients: coef.iter().copied().collect(),
        sigma: (0..p).map(|i| inv[(i, i)].max(0.0).sqrt()).collect(),
        used,
    })
}
