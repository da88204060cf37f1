//! The published figures of the paper (Vavilova, Golovan, Parusnikov, Vasineva), in its units,
//! in one place: the covariance analysis's result tables and the navigation errors after the
//! one-hour snake flight. Everything that compares against the paper (the paper-check, the
//! navigation budget, the report) reads them from here.

/// One of the paper's result tables: the largest sigma of each group of parameters (also the
/// same table computed from a covariance analysis, `calib::report::paper_table`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ResultTable {
    /// Gyro bias nu0 (deg/h).
    pub nu0_deg_h: f64,
    /// Gyro scale-factor errors, the diagonal of Theta (-).
    pub theta_ii: f64,
    /// Gyro misalignments, the off-diagonal of Theta (arcmin).
    pub theta_ij_arcmin: f64,
    /// Accelerometer bias df0 (m/s^2).
    pub df0_m_s2: f64,
    /// Accelerometer scale-factor errors, the diagonal of Gamma (-).
    pub gamma_ii: f64,
    /// Accelerometer non-orthogonality, below the diagonal of Gamma (arcmin).
    pub gamma_ij_arcmin: f64,
}

impl ResultTable {
    /// The entries in the order of the fields (the order of `calib::report::COLUMNS`).
    pub fn values(&self) -> [f64; 6] {
        [
            self.nu0_deg_h,
            self.theta_ii,
            self.theta_ij_arcmin,
            self.df0_m_s2,
            self.gamma_ii,
            self.gamma_ij_arcmin,
        ]
    }
}

/// The paper's table without the turntable angles (IMU data alone).
pub const TABLE_IMU_ONLY: ResultTable = ResultTable {
    nu0_deg_h: 0.01,
    theta_ii: 5.1e-7,
    theta_ij_arcmin: 0.1,
    df0_m_s2: 9e-5,
    gamma_ii: 1.36e-5,
    gamma_ij_arcmin: 0.1,
};

/// The paper's table with the turntable angles.
pub const TABLE_WITH_TURNTABLE: ResultTable = ResultTable {
    nu0_deg_h: 0.003,
    theta_ii: 9.7e-8,
    theta_ij_arcmin: 0.05,
    df0_m_s2: 7.7e-5,
    gamma_ii: 1.36e-5,
    gamma_ij_arcmin: 0.05,
};

/// The paper's position error after the one-hour snake flight, calibrated without the
/// turntable angles (m).
pub const RHO_IMU_ONLY_M: f64 = 1900.0;
/// The same, calibrated with the turntable angles (m).
pub const RHO_WITH_TURNTABLE_M: f64 = 1100.0;
