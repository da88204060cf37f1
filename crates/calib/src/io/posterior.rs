//! The full posterior in a result file: the correlation matrix of the parameters, next to their
//! sigmas (`docs/formats.md`, "Result file"). A covariance is `D R D` with `D` the sigmas and `R`
//! the correlation; [`covariance`] rebuilds it.

/// Decimal places the correlations are written with. Rounding to 1e-6 moves the matrix by at
/// most `n / 2 * 1e-6` in norm (1.4e-5 for 28 parameters), far below the smallest eigenvalue of
/// the posteriors met so far (7.3e-4 for the paper's calibration with the turntable angles,
/// whose largest correlation is 0.9993), and the navigation figure computed from the rounded
/// matrix stays within 0.1 % (`cargo xtask nav-error`'s test).
pub const CORRELATION_DECIMALS: i32 = 6;

fn round(x: f64) -> f64 {
    let s = 10f64.powi(CORRELATION_DECIMALS);
    (x * s).round() / s
}

/// The correlation matrix of the rows and columns `range` of the covariance `cov` (any type
/// indexed by `(row, column)`), rounded to [`CORRELATION_DECIMALS`], with an exact 1 on the
/// diagonal. A parameter of zero variance has zero correlation with the others.
pub fn correlation(
    n: usize,
    range: std::ops::Range<usize>,
    cov: impl Fn(usize, usize) -> f64,
) -> Vec<Vec<f64>> {
    debug_assert!(range.end <= n);
    let idx: Vec<usize> = range.collect();
    let sd: Vec<f64> = idx.iter().map(|&i| cov(i, i).max(0.0).sqrt()).collect();
    idx.iter()
        .enumerate()
        .map(|(a, &i)| {
            idx.iter()
                .enumerate()
                .map(|(b, &j)| {
                    if a == b {
                        1.0
                    } else if sd[a] > 0.0 && sd[b] > 0.0 {
                        let c = 0.5 * (cov(i, j) + cov(j, i)) / (sd[a] * sd[b]);
                        round(c.clamp(-1.0, 1.0))
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect()
}

/// The covariance `D R D` of sigmas `D` and correlation `R`.
pub fn covariance(sigma: &[f64], correlation: &[Vec<f64>]) -> nalgebra::DMatrix<f64> {
    nalgebra::DMatrix::from_fn(sigma.len(), sigma.len(), |i, j| {
        sigma[i] * correlation[i][j] * sigma[j]
    })
}

/// Check a correlation matrix read from `file` for `n` parameters: square, finite, symmetric,
/// ones on the diagonal, entries within [-1, 1]. The message names what is wrong.
pub fn check_correlation(correlation: &[Vec<f64>], n: usize) -> Result<(), String> {
    if correlation.len() != n || correlation.iter().any(|r| r.len() != n) {
        let rows = correlation.len();
        let shape = match correlation.iter().find(|r| r.len() != rows) {
            Some(r) => format!("{rows} rows, one of {} entries", r.len()),
            None => format!("{rows} x {rows}"),
        };
        return Err(format!(
            "`correlation` is {shape} for the {n} entries of `parameters`: expected one row and \
             column per parameter, in the order of `parameters` (a parameter removed from or \
             added to `parameters` by hand leaves them apart: give the file `calibrate --json` \
             wrote)"
        ));
    }
    for (i, row) in correlation.iter().enumerate() {
        if row[i] != 1.0 {
            return Err(format!(
                "`correlation` row {}: expected 1 on the diagonal, found {}",
                i + 1,
                row[i]
            ));
        }
        for (j, &a) in row.iter().enumerate().take(i) {
            let b = correlation[j][i];
            if !(a.is_finite() && a.abs() <= 1.0 && a == b) {
                return Err(format!(
                    "`correlation` rows {} and {}: expected a symmetric entry within [-1, 1], \
                     found {a} and {b}",
                    j + 1,
                    i + 1
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_of_a_covariance_and_back() {
        let c = nalgebra::DMatrix::from_row_slice(
            3,
            3,
            &[4.0, 1.2, -0.6, 1.2, 9.0, 0.0, -0.6, 0.0, 1.0],
        );
        let r = correlation(3, 0..3, |i, j| c[(i, j)]);
        assert_eq!(r[0][1], 0.2);
        assert_eq!(r[0][2], -0.3);
        assert_eq!(r[1][1], 1.0);
        let back = covariance(&[2.0, 3.0, 1.0], &r);
        assert!((back - &c).norm() < 1e-12);
        assert!(check_correlation(&r, 3).is_ok());
        let sub = correlation(3, 1..3, |i, j| c[(i, j)]);
        assert_eq!(sub, vec![vec![1.0, 0.0], vec![0.0, 1.0]]);
        let mut bad = r.clone();
        bad[2][0] = 0.5;
        assert!(
            check_correlation(&bad, 3)
                .unwrap_err()
                .contains("rows 1 and 3")
        );
        assert!(check_correlation(&r, 4).is_err());
    }
}
