//! Shared test helpers: a seeded normal generator, matrix builders and comparisons, and the
//! naive reference filter ([`naive`]).
#![allow(dead_code)]

pub mod naive;

use faer::Mat;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

/// Standard normal numbers from a seeded [`StdRng`].
pub struct Rng(StdRng);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(StdRng::seed_from_u64(seed))
    }

    pub fn normal(&mut self) -> f64 {
        StandardNormal.sample(&mut self.0)
    }

    pub fn mat(&mut self, r: usize, c: usize) -> Mat<f64> {
        Mat::from_fn(r, c, |_, _| self.normal())
    }

    pub fn vec(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.normal()).collect()
    }

    /// Random SPD matrix A A^T / n + 0.1 I, well conditioned.
    pub fn spd(&mut self, n: usize) -> Mat<f64> {
        let a = self.mat(n, n);
        let mut p = &a * a.transpose() * (1.0 / n as f64);
        for i in 0..n {
            p[(i, i)] += 0.1;
        }
        sym(p)
    }
}

pub fn sym(p: Mat<f64>) -> Mat<f64> {
    let n = p.nrows();
    Mat::from_fn(n, n, |i, j| 0.5 * (p[(i, j)] + p[(j, i)]))
}

pub fn diag(v: &[f64]) -> Mat<f64> {
    Mat::from_fn(v.len(), v.len(), |i, j| if i == j { v[i] } else { 0.0 })
}

pub fn to_row_major(m: &Mat<f64>) -> Vec<f64> {
    let mut v = Vec::with_capacity(m.nrows() * m.ncols());
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            v.push(m[(i, j)]);
        }
    }
    v
}

pub fn from_row_major(v: &[f64], r: usize, c: usize) -> Mat<f64> {
    assert_eq!(v.len(), r * c);
    Mat::from_fn(r, c, |i, j| v[i * c + j])
}

pub fn max_abs(m: &Mat<f64>) -> f64 {
    let mut a = 0.0f64;
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            a = a.max(m[(i, j)].abs());
        }
    }
    a
}

/// max |a - b| / max |b|
pub fn rel_diff(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
    let d = a - b;
    max_abs(&d) / max_abs(b).max(f64::MIN_POSITIVE)
}

pub fn rel_diff_vec(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let d = a
        .iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    d / scale.max(f64::MIN_POSITIVE)
}

pub fn assert_symmetric(p: &Mat<f64>, what: &str) {
    for j in 0..p.ncols() {
        for i in 0..j {
            assert_eq!(p[(i, j)], p[(j, i)], "{what}: P[{i}, {j}] != P[{j}, {i}]");
        }
    }
}

/// The structured system used by several tests: k dynamic states driven by
/// phi_top = [I + dt A | dt G] and q_top = dt * Qc.
pub struct Structured {
    pub phi_top: Mat<f64>,
    pub q_top: Mat<f64>,
}

impl Structured {
    pub fn random(rng: &mut Rng, k: usize, n: usize, dt: f64) -> Self {
        let phi_top = Mat::from_fn(k, n, |i, j| {
            let id = if i == j { 1.0 } else { 0.0 };
            id + dt * rng.normal()
        });
        let b = rng.mat(k, k);
        let q_top = sym(&b * b.transpose() * dt);
        Self { phi_top, q_top }
    }

    /// The equivalent full Phi (n x n) and Q (n x n).
    pub fn full(&self, n: usize) -> (Mat<f64>, Mat<f64>) {
        let k = self.phi_top.nrows();
        let phi = Mat::from_fn(n, n, |i, j| {
            if i < k {
                self.phi_top[(i, j)]
            } else if i == j {
                1.0
            } else {
                0.0
            }
        });
        let q = Mat::from_fn(n, n, |i, j| {
            if i < k && j < k {
                self.q_top[(i, j)]
            } else {
                0.0
            }
        });
        (phi, q)
    }
}

/// Lower Cholesky factor (naive), `None` if not positive definite.
pub fn try_cholesky(p: &Mat<f64>) -> Option<Mat<f64>> {
    let n = p.nrows();
    let mut l = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        let mut d = p[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        l[(j, j)] = d.sqrt();
        for i in (j + 1)..n {
            let mut v = p[(i, j)];
            for k in 0..j {
                v -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = v / l[(j, j)];
        }
    }
    Some(l)
}

/// Lower Cholesky factor (naive); panics if not positive definite.
pub fn cholesky(p: &Mat<f64>) -> Mat<f64> {
    try_cholesky(p).expect("not positive definite")
}

/// Whether a symmetric matrix is positive definite (Cholesky succeeds).
pub fn is_pd(p: &Mat<f64>) -> bool {
    try_cholesky(p).is_some()
}

/// Inverse by the naive Gauss-Jordan of the reference.
pub fn inv(a: &Mat<f64>) -> Mat<f64> {
    let n = a.nrows();
    let mut work = to_row_major(a);
    let mut out = vec![0.0; n * n];
    naive::invert(&mut work, &mut out, n).expect("singular");
    from_row_major(&out, n, n)
}
