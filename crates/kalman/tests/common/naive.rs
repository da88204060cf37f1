//! The naive dense reference filter: plain loops on row-major `Vec<f64>`, obviously correct and
//! slow (`O(n^3)` per update), the literal Joseph form. The ground truth of the tests. It
//! allocates only in [`NaiveFilter::new`].
//!
//! Row-major means element `(i, j)` of an `r x c` matrix is `a[i * c + j]`.

use kalman::KalmanError;

/// `c = a b` with `a` `rows x inner`, `b` `inner x cols`, all row-major.
pub fn matmul(c: &mut [f64], a: &[f64], b: &[f64], rows: usize, inner: usize, cols: usize) {
    assert_eq!(a.len(), rows * inner);
    assert_eq!(b.len(), inner * cols);
    assert_eq!(c.len(), rows * cols);
    for i in 0..rows {
        for j in 0..cols {
            let mut acc = 0.0;
            for l in 0..inner {
                acc += a[i * inner + l] * b[l * cols + j];
            }
            c[i * cols + j] = acc;
        }
    }
}

/// `t = a^T` with `a` `rows x cols`, row-major (so `t` is `cols x rows`).
pub fn transpose(t: &mut [f64], a: &[f64], rows: usize, cols: usize) {
    assert_eq!(a.len(), rows * cols);
    assert_eq!(t.len(), rows * cols);
    for i in 0..rows {
        for j in 0..cols {
            t[j * rows + i] = a[i * cols + j];
        }
    }
}

/// Inverts the `m x m` row-major matrix `a` into `inv` by Gauss-Jordan elimination with partial
/// pivoting; `a` is destroyed. A zero pivot is reported as
/// [`KalmanError::NotPositiveDefinite`] (the reference only inverts `S`).
pub fn invert(a: &mut [f64], inv: &mut [f64], m: usize) -> Result<(), KalmanError> {
    assert_eq!(a.len(), m * m);
    assert_eq!(inv.len(), m * m);
    for i in 0..m {
        for j in 0..m {
            inv[i * m + j] = if i == j { 1.0 } else { 0.0 };
        }
    }
    for col in 0..m {
        let mut piv = col;
        for row in (col + 1)..m {
            if a[row * m + col].abs() > a[piv * m + col].abs() {
                piv = row;
            }
        }
        let pv = a[piv * m + col];
        if pv == 0.0 || !pv.is_finite() {
            return Err(KalmanError::NotPositiveDefinite {
                m,
                pivot: col,
                value: pv,
            });
        }
        if piv != col {
            for j in 0..m {
                a.swap(piv * m + j, col * m + j);
                inv.swap(piv * m + j, col * m + j);
            }
        }
        for j in 0..m {
            a[col * m + j] /= pv;
            inv[col * m + j] /= pv;
        }
        for row in 0..m {
            if row != col {
                let f = a[row * m + col];
                for j in 0..m {
                    a[row * m + j] -= f * a[col * m + j];
                    inv[row * m + j] -= f * inv[col * m + j];
                }
            }
        }
    }
    Ok(())
}

/// The naive reference filter: state `x` (`n`) and row-major covariance `p` (`n x n`), with
/// preallocated work arrays for measurements of up to `m_max` components.
#[derive(Debug, Clone)]
pub struct NaiveFilter {
    /// State dimension.
    pub n: usize,
    /// State estimate.
    pub x: Vec<f64>,
    /// Covariance, row-major `n x n`.
    pub p: Vec<f64>,
    m_max: usize,
    nn1: Vec<f64>,
    nn2: Vec<f64>,
    nn3: Vec<f64>,
    nm1: Vec<f64>,
    nm2: Vec<f64>,
    nm3: Vec<f64>,
    mn: Vec<f64>,
    mm1: Vec<f64>,
    mm2: Vec<f64>,
    nu: Vec<f64>,
}

impl NaiveFilter {
    /// A filter with state `x0` and row-major covariance `p0`.
    ///
    /// # Panics
    /// If `p0.len() != x0.len()^2`.
    pub fn new(x0: &[f64], p0: &[f64], m_max: usize) -> Self {
        let n = x0.len();
        assert_eq!(p0.len(), n * n);
        Self {
            n,
            x: x0.to_vec(),
            p: p0.to_vec(),
            m_max,
            nn1: vec![0.0; n * n],
            nn2: vec![0.0; n * n],
            nn3: vec![0.0; n * n],
            nm1: vec![0.0; n * m_max],
            nm2: vec![0.0; n * m_max],
            nm3: vec![0.0; n * m_max],
            mn: vec![0.0; n * m_max],
            mm1: vec![0.0; m_max * m_max],
            mm2: vec![0.0; m_max * m_max],
            nu: vec![0.0; m_max],
        }
    }

    /// `P <- Phi P Phi^T + Q` with row-major `n x n` `phi` and `q`.
    pub fn predict_covariance(&mut self, phi: &[f64], q: &[f64]) {
        let n = self.n;
        matmul(&mut self.nn1, phi, &self.p, n, n, n);
        transpose(&mut self.nn2, phi, n, n);
        matmul(&mut self.p, &self.nn1, &self.nn2, n, n, n);
        for (p, q) in self.p.iter_mut().zip(q) {
            *p += q;
        }
    }

    /// `x <- Phi x`, `P <- Phi P Phi^T + Q`.
    pub fn predict(&mut self, phi: &[f64], q: &[f64]) {
        let n = self.n;
        self.predict_covariance(phi, q);
        matmul(&mut self.nn1[..n], phi, &self.x, n, n, 1);
        self.x.copy_from_slice(&self.nn1[..n]);
    }

    /// Computes `S^{-1}` (into `mm2`) and the optimal gain `K = P H^T S^{-1}` (into `nm2`).
    fn gain(&mut self, h: &[f64], r: &[f64], m: usize) -> Result<(), KalmanError> {
        let n = self.n;
        assert!(m <= self.m_max);
        // nm1 = H^T, mn = H P, mm1 = H P H^T + R
        transpose(&mut self.nm1[..n * m], h, m, n);
        matmul(&mut self.mn[..m * n], h, &self.p, m, n, n);
        matmul(
            &mut self.mm1[..m * m],
            &self.mn[..m * n],
            &self.nm1[..n * m],
            m,
            n,
            m,
        );
        for (s, r) in self.mm1[..m * m].iter_mut().zip(r) {
            *s += r;
        }
        invert(&mut self.mm1[..m * m], &mut self.mm2[..m * m], m)?;
        // K = (P H^T) S^-1; nm3 holds P H^T (n x m)
        matmul(&mut self.nm3[..n * m], &self.p, &self.nm1[..n * m], n, n, m);
        matmul(
            &mut self.nm2[..n * m],
            &self.nm3[..n * m],
            &self.mm2[..m * m],
            n,
            m,
            m,
        );
        Ok(())
    }

    /// The literal Joseph form `P <- (I - K H) P (I - K H)^T + K R K^T` for the given (any)
    /// gain `k` (row-major `n x m`).
    pub fn joseph_with_gain(&mut self, k: &[f64], h: &[f64], r: &[f64], m: usize) {
        let n = self.n;
        // nn1 = A = I - K H
        matmul(&mut self.nn1, k, h, n, m, n);
        for i in 0..n {
            for j in 0..n {
                let id = if i == j { 1.0 } else { 0.0 };
                self.nn1[i * n + j] = id - self.nn1[i * n + j];
            }
        }
        // nn2 = A P, nn3 = A^T, p = A P A^T
        matmul(&mut self.nn2, &self.nn1, &self.p, n, n, n);
        transpose(&mut self.nn3, &self.nn1, n, n);
        matmul(&mut self.p, &self.nn2, &self.nn3, n, n, n);
        // + K R K^T: nm1 = K R, mn = K^T, nn1 = K R K^T
        matmul(&mut self.nm1[..n * m], k, r, n, m, m);
        transpose(&mut self.mn[..m * n], k, n, m);
        matmul(
            &mut self.nn1,
            &self.nm1[..n * m],
            &self.mn[..m * n],
            n,
            m,
            n,
        );
        for (p, a) in self.p.iter_mut().zip(&self.nn1) {
            *p += a;
        }
    }

    /// Optimal-gain update of the covariance only, in the literal Joseph form.
    pub fn update_covariance(&mut self, h: &[f64], r: &[f64]) -> Result<(), KalmanError> {
        let m = r.len().isqrt();
        let n = self.n;
        self.gain(h, r, m)?;
        let k = core::mem::take(&mut self.nm2);
        self.joseph_with_gain(&k[..n * m], h, r, m);
        self.nm2 = k;
        Ok(())
    }

    /// Full update: Joseph-form covariance, `x <- x + K (z - H x)`; returns the NIS
    /// `nu^T S^{-1} nu`.
    pub fn update(&mut self, z: &[f64], h: &[f64], r: &[f64]) -> Result<f64, KalmanError> {
        let n = self.n;
        let m = z.len();
        self.gain(h, r, m)?;
        for i in 0..m {
            let mut v = z[i];
            for j in 0..n {
                v -= h[i * n + j] * self.x[j];
            }
            self.nu[i] = v;
        }
        let mut nis = 0.0;
        for i in 0..m {
            for j in 0..m {
                nis += self.nu[i] * self.mm2[i * m + j] * self.nu[j];
            }
        }
        for i in 0..n {
            for j in 0..m {
                self.x[i] += self.nm2[i * m + j] * self.nu[j];
            }
        }
        let k = core::mem::take(&mut self.nm2);
        self.joseph_with_gain(&k[..n * m], h, r, m);
        self.nm2 = k;
        Ok(nis)
    }
}
