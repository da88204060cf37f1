//! Consistency statistics of an estimate against a truth: the normalised estimation error
//! squared (NEES) and the bands a consistent estimator keeps to. Used by the command-line
//! report and by the Monte-Carlo tests alike.

use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

/// NEES `e^T P^-1 e` of the errors `errors` (estimate minus truth) against their covariance
/// `cov`, computed on the correlation matrix: the calibration's states span 1e-9 rad/s to
/// 0.05 s and the SI covariance has a condition number near 1e15, which its direct inverse
/// does not survive. `None` if the covariance is not positive definite.
pub fn nees(errors: &[f64], cov: &DMatrix<f64>) -> Option<f64> {
    let n = errors.len();
    if cov.nrows() != n || cov.ncols() != n {
        return None;
    }
    let sigma: Vec<f64> = (0..n).map(|i| cov[(i, i)].sqrt()).collect();
    if sigma.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return None;
    }
    let corr = DMatrix::from_fn(n, n, |i, j| cov[(i, j)] / (sigma[i] * sigma[j]));
    let z = DVector::from_iterator(n, errors.iter().zip(&sigma).map(|(e, s)| e / s));
    let chol = corr.cholesky()?;
    let y = chol.solve(&z);
    Some(z.dot(&y))
}

/// The two-sided band that holds a chi-square variable with `dof` degrees of freedom with
/// probability `p` (e.g. 0.95).
pub fn chi_square_band(dof: f64, p: f64) -> (f64, f64) {
    let d = ChiSquared::new(dof).expect("positive degrees of freedom");
    let a = 0.5 * (1.0 - p);
    (d.inverse_cdf(a), d.inverse_cdf(1.0 - a))
}

/// The bound for the largest of `k` standard normal variables at family-wise level `alpha`
/// (two-sided, Bonferroni): `Phi^-1(1 - alpha / (2 k))`.
pub fn bonferroni_bound(k: usize, alpha: f64) -> f64 {
    let n = Normal::standard();
    n.inverse_cdf(1.0 - alpha / (2.0 * k.max(1) as f64))
}

/// A p-value as every report prints it: `{:.3}` from 1e-3 up, `{:.2e}` below (three figures
/// that mean something either way), `0` for one computed as exactly 0 (an underflow, or a
/// `1 - F` that lost every digit: how small it is, the caller's method says).
pub fn p_value_text(p: f64) -> String {
    if p.is_nan() {
        "NaN".into()
    } else if p == 0.0 {
        "0".into()
    } else if p.abs() >= 1e-3 {
        format!("{p:.3}")
    } else {
        format!("{p:.2e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        // chi2(100): 2.5 % 74.222, 97.5 % 129.561.
        let (lo, hi) = chi_square_band(100.0, 0.95);
        assert!((lo - 74.222).abs() < 1e-3 && (hi - 129.561).abs() < 1e-3);
        // One variable at 5 %: 1.95996; 21 of them: Phi^-1(1 - 0.05 / 42) = 3.0381.
        assert!((bonferroni_bound(1, 0.05) - 1.959964).abs() < 1e-5);
        assert!((bonferroni_bound(21, 0.05) - 3.0381).abs() < 1e-3);
    }

    #[test]
    fn nees_survives_scales_far_apart() {
        // Two correlated states, one in 1e-9 and one in 1e-2 units: the NEES is the same as in
        // unit scales.
        let (s1, s2, r) = (1e-9, 1e-2, 0.9);
        let cov = DMatrix::from_row_slice(2, 2, &[s1 * s1, r * s1 * s2, r * s1 * s2, s2 * s2]);
        let e = [1.0 * s1, -0.5 * s2];
        let expected = (1.0 + 0.25 + 2.0 * r * 0.5) / (1.0 - r * r);
        assert!((nees(&e, &cov).unwrap() - expected).abs() < 1e-9 * expected);
        assert!(nees(&e, &DMatrix::zeros(2, 2)).is_none());
    }
}
