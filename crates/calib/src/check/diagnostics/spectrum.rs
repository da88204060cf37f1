//! Periodogram ordinates of a (possibly irregularly sampled) standardised series at chosen
//! frequencies, exact under white noise for any time stamps.
//!
//! At angular frequency `w` the sums `X = sum x_k cos(w t_k)`, `Y = sum x_k sin(w t_k)` of a
//! series of independent `N(0, 1)` values are Gaussian with covariance
//! `M = [[sum c^2, sum c s], [sum c s, sum s^2]]`, so `Q = (X, Y) M^-1 (X, Y)^T` is chi-square with
//! 2 degrees of freedom (1 where `M` is singular: at frequency 0, where `Q = N mean^2`, and at
//! the Nyquist frequency of a regular series). For regular sampling `Q / 2 = |DFT|^2 / N`, the
//! classical periodogram ordinate (chi-square(2) / 2 under white noise). This is the generalised
//! Lomb-Scargle form; it needs no FFT and no regular time line (skipped updates).

use std::f64::consts::TAU;

/// The ordinate at one frequency of three series sharing time stamps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ordinate {
    /// `Q` of each series (chi-square with `dof` under white noise).
    pub q: [f64; 3],
    /// Degrees of freedom (2, or 1 at frequency 0 / Nyquist; 0 if nothing is resolved).
    pub dof: usize,
}

/// `Q` of the three series `x` at frequency `f_hz`, time stamps `t` (s, any origin).
pub fn ordinate(t: &[f64], x: &[[f64; 3]], f_hz: f64) -> Ordinate {
    let t0 = t.first().copied().unwrap_or(0.0);
    let w = TAU * f_hz;
    let (mut cc, mut ss, mut cs) = (0.0, 0.0, 0.0);
    let (mut xs, mut ys) = ([0.0; 3], [0.0; 3]);
    for (tk, xk) in t.iter().zip(x) {
        let (s, c) = (w * (tk - t0)).sin_cos();
        cc += c * c;
        ss += s * s;
        cs += c * s;
        for a in 0..3 {
            xs[a] += xk[a] * c;
            ys[a] += xk[a] * s;
        }
    }
    // Eigen-decomposition of the symmetric 2 x 2 M.
    let tr = cc + ss;
    let half_diff = 0.5 * (cc - ss);
    let r = half_diff.hypot(cs);
    let (l1, l2) = (0.5 * tr + r, 0.5 * tr - r);
    // Eigenvector of l1: (cos phi, sin phi) with tan(2 phi) = 2 cs / (cc - ss).
    let phi = 0.5 * cs.atan2(half_diff);
    let (v1, v2) = ((phi.cos(), phi.sin()), (-phi.sin(), phi.cos()));
    let mut q = [0.0; 3];
    let mut dof = 0;
    for (l, v) in [(l1, v1), (l2, v2)] {
        if l > 1e-9 * tr.max(f64::MIN_POSITIVE) {
            dof += 1;
            for a in 0..3 {
                let p = v.0 * xs[a] + v.1 * ys[a];
                q[a] += p * p / l;
            }
        }
    }
    Ordinate { q, dof }
}

/// `n` frequencies spaced evenly in the logarithm from `lo` to `hi` (Hz).
pub fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && lo.is_finite() && hi.is_finite()) || n == 0 {
        return vec![];
    }
    if n == 1 {
        return vec![lo];
    }
    let r = (hi / lo).ln() / (n - 1) as f64;
    (0..n).map(|i| lo * (r * i as f64).exp()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regular sampling: Q / 2 is |DFT|^2 / N of the classical periodogram.
    #[test]
    fn regular_sampling_matches_the_direct_dft() {
        let n = 64;
        let t: Vec<f64> = (0..n).map(|k| 0.5 * k as f64).collect();
        let x: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let v = ((k * 7919) % 13) as f64 - 6.0;
                [v, 0.3 * v - 1.0, (k as f64 * 0.7).sin()]
            })
            .collect();
        for m in [1usize, 5, 17] {
            let f = m as f64 / (n as f64 * 0.5);
            let o = ordinate(&t, &x, f);
            assert_eq!(o.dof, 2);
            for a in 0..3 {
                let (mut re, mut im) = (0.0, 0.0);
                for (k, xk) in x.iter().enumerate() {
                    let ang = TAU * (m * k) as f64 / n as f64;
                    re += xk[a] * ang.cos();
                    im -= xk[a] * ang.sin();
                }
                let p = (re * re + im * im) / n as f64;
                assert!(
                    (o.q[a] / 2.0 - p).abs() < 1e-9 * (1.0 + p),
                    "{} {p}",
                    o.q[a]
                );
            }
        }
        // Frequency 0: one degree of freedom, N mean^2.
        let o = ordinate(&t, &x, 0.0);
        assert_eq!(o.dof, 1);
        let mean: f64 = x.iter().map(|v| v[0]).sum::<f64>() / n as f64;
        assert!((o.q[0] - n as f64 * mean * mean).abs() < 1e-9);
        // Nyquist of a regular series: one degree of freedom.
        assert_eq!(ordinate(&t, &x, 1.0).dof, 1);
    }

    #[test]
    fn grid_is_logarithmic_and_refuses_nonsense() {
        let g = log_grid(0.01, 1.0, 3);
        assert!((g[1] - 0.1).abs() < 1e-12 && (g[2] - 1.0).abs() < 1e-12);
        assert!(log_grid(1.0, 0.5, 10).is_empty());
        assert!(log_grid(f64::NAN, 0.5, 10).is_empty());
    }
}
