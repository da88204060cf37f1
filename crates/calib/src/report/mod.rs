//! The paper's tables (each entry the largest posterior sigma over the axes or elements of a
//! group, in the paper's units), the one number format of p-values ([`crate::check::stats::p_value_text`]), and in
//! [`lab`] the figures of the report a laboratory files (`sins-calib calibrate --report`).

use crate::estimate::covariance::Posterior;
use sins_model::terms::GAMMA_INDEX;

pub mod lab;

/// One row of the paper's tables: the paper's own (`sins_model::paper::TABLE_IMU_ONLY`,
/// `TABLE_WITH_TURNTABLE`) or computed from a covariance analysis ([`paper_table`]).
pub use sins_model::paper::ResultTable as PaperTable;

/// The column names, in order, with units.
pub const COLUMNS: [(&str, &str); 6] = [
    ("nu0_deg_h", "deg/h"),
    ("theta_ii", "-"),
    ("theta_ij_arcmin", "arcmin"),
    ("df0_m_s2", "m/s^2"),
    ("gamma_ii", "-"),
    ("gamma_ij_arcmin", "arcmin"),
];

/// Largest posterior sigma per group, in the paper's units.
pub fn paper_table(p: &Posterior) -> PaperTable {
    let max_of = |names: &[String]| {
        names
            .iter()
            .map(|n| p.sigma(n).unwrap_or(f64::NAN))
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let groups = Groups::new();
    let deg_h = 1.0 / sins_model::units::DEG_PER_HOUR;
    let arcmin = 1.0 / sins_model::units::ARCMIN;
    PaperTable {
        nu0_deg_h: max_of(&groups.nu0) * deg_h,
        theta_ii: max_of(&groups.theta_ii),
        theta_ij_arcmin: max_of(&groups.theta_ij) * arcmin,
        df0_m_s2: max_of(&groups.df0),
        gamma_ii: max_of(&groups.gamma_ii),
        gamma_ij_arcmin: max_of(&groups.gamma_ij) * arcmin,
    }
}

/// The parameter names of each table group.
#[derive(Clone, Debug)]
pub struct Groups {
    /// Gyro biases.
    pub nu0: Vec<String>,
    /// Theta diagonal.
    pub theta_ii: Vec<String>,
    /// Theta off-diagonal.
    pub theta_ij: Vec<String>,
    /// Accelerometer biases.
    pub df0: Vec<String>,
    /// Gamma diagonal.
    pub gamma_ii: Vec<String>,
    /// Gamma off-diagonal.
    pub gamma_ij: Vec<String>,
}

impl Groups {
    /// The paper's grouping of the 21 instrument parameters.
    pub fn new() -> Self {
        let ax = ["x", "y", "z"];
        let mut g = Groups {
            nu0: ax.iter().map(|a| format!("gyro.bias.{a}")).collect(),
            theta_ii: vec![],
            theta_ij: vec![],
            df0: ax.iter().map(|a| format!("accel.bias.{a}")).collect(),
            gamma_ii: vec![],
            gamma_ij: vec![],
        };
        for i in 0..3 {
            for j in 0..3 {
                let name = format!("gyro.theta.{}{}", ax[i], ax[j]);
                if i == j {
                    g.theta_ii.push(name)
                } else {
                    g.theta_ij.push(name)
                }
            }
        }
        for &(i, j) in &GAMMA_INDEX {
            let name = format!("accel.gamma.{}{}", ax[i], ax[j]);
            if i == j {
                g.gamma_ii.push(name)
            } else {
                g.gamma_ij.push(name)
            }
        }
        g
    }
}

impl Default for Groups {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use crate::check::stats::p_value_text;

    #[test]
    fn p_values_are_printed_one_way() {
        assert_eq!(p_value_text(0.5), "0.500");
        assert_eq!(p_value_text(1.0), "1.000");
        assert_eq!(p_value_text(1e-3), "0.001");
        assert_eq!(p_value_text(9.99e-4), "9.99e-4");
        assert_eq!(p_value_text(3.14159e-12), "3.14e-12");
        assert_eq!(p_value_text(0.0), "0");
        assert_eq!(p_value_text(f64::NAN), "NaN");
    }
}
