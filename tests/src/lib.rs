//! Helpers shared by the workspace-level tests.

#![forbid(unsafe_code)]

use calib::config::{AttitudePrior, RunConfig};

/// The run the calibration tests simulate: the paper's program, priors and noises, the start
/// attitude from the installation (its extra error 0.01 deg: none in the simulation), the
/// turntable clock 12.5 s ahead and 2e-4 fast, angles at 50 Hz against the IMU's 100 Hz, every
/// parameter drawn from its prior (seed 1).
pub fn simulated_run_config() -> RunConfig {
    let mut c = RunConfig::paper();
    c.filter.attitude_prior = AttitudePrior::Installation;
    c.priors.initial_tilt_deg = 0.01;
    c.priors.initial_heading_deg = 0.01;
    c.clock.turntable_offset_s = 12.5;
    c.clock.turntable_rate_error = 2e-4;
    c.truth.imu_rate_hz = 100.0;
    c.truth.turntable_rate_hz = 50.0;
    c.truth.draw_from_priors = true;
    c.truth.seed = 1;
    c
}

/// Quantile of the chi-square distribution with `dof` degrees of freedom (Wilson-Hilferty;
/// relative error below 1e-3 for `dof >= 20`, which is all the tests use).
pub fn chi_square_quantile(p: f64, dof: f64) -> f64 {
    let z = standard_normal_quantile(p);
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Quantile of the standard normal distribution (Acklam's rational approximation, relative
/// error below 1.2e-9).
pub fn standard_normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        assert!((standard_normal_quantile(0.975) - 1.959964).abs() < 1e-5);
        assert!((standard_normal_quantile(0.025) + 1.959964).abs() < 1e-5);
        // chi2(100): 2.5 % 74.222, 97.5 % 129.561.
        assert!((chi_square_quantile(0.025, 100.0) - 74.222).abs() < 0.1);
        assert!((chi_square_quantile(0.975, 100.0) - 129.561).abs() < 0.1);
    }
}
