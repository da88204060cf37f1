//! What `sins-calib noise` reports and plots share: the units of each sensor's terms, the
//! analysis of a sensor's three axes, and the configured noise model as term levels. Its own
//! module so that the command (`noise`) and its plot (`crate::plots::allan_deviation`) both use
//! it and the plot does not reach back into the command.

use ::noise::AxisNoise;
use ::noise::fit::Term;
use ::noise::likelihood::MlFit;
use calib::config::NoiseConfig;
use sins_model::units::DEG_PER_HOUR;

/// Units of one sensor's terms in reports (`Term::ALL` order).
pub(crate) struct Sensor {
    /// The sensor as reports name it.
    pub(crate) name: &'static str,
    /// Its key in the JSON file.
    pub(crate) key: &'static str,
    /// JSON key (with unit) of each term.
    pub(crate) keys: [&'static str; 5],
    /// Column heading (with unit) of each term.
    pub(crate) labels: [&'static str; 5],
    /// SI to report unit, each term.
    pub(crate) factors: [f64; 5],
    /// SI to report unit of the deviation, and its name.
    pub(crate) adev_factor: f64,
    pub(crate) adev_unit: &'static str,
    pub(crate) adev_key: &'static str,
}

pub(crate) const GYRO: Sensor = Sensor {
    name: "gyro",
    key: "gyro",
    keys: [
        "quantisation_rad",
        "white_deg_h",
        "bias_instability_deg_h",
        "bias_walk_deg_h_sqrt_h",
        "rate_ramp_deg_h_h",
    ],
    labels: [
        "quantisation [rad]",
        "white [deg/h]",
        "bias instab. [deg/h]",
        "bias walk [deg/h/sqrt(h)]",
        "rate ramp [deg/h/h]",
    ],
    factors: [
        1.0,
        1.0 / DEG_PER_HOUR,
        1.0 / DEG_PER_HOUR,
        60.0 / DEG_PER_HOUR,
        3600.0 / DEG_PER_HOUR,
    ],
    adev_factor: 1.0 / DEG_PER_HOUR,
    adev_unit: "deg/h",
    adev_key: "deg_h",
};

pub(crate) const ACCEL: Sensor = Sensor {
    name: "accelerometer",
    key: "accel",
    keys: [
        "quantisation_m_s",
        "white_m_s2",
        "bias_instability_m_s2",
        "bias_walk_m_s2_sqrt_s",
        "rate_ramp_m_s3",
    ],
    labels: [
        "quantisation [m/s]",
        "white [m/s^2]",
        "bias instab. [m/s^2]",
        "bias walk [m/s^2/sqrt(s)]",
        "rate ramp [m/s^3]",
    ],
    factors: [1.0; 5],
    adev_factor: 1.0,
    adev_unit: "m/s^2",
    adev_key: "m_s2",
};

pub(crate) const AXES: [&str; 3] = ["x", "y", "z"];

/// The analysis of one sensor: three axes, each with its Allan curve and fit and its
/// maximum-likelihood fit (the white level and walk reported).
pub(crate) struct SensorNoise {
    pub(crate) axes: Vec<AxisNoise>,
    pub(crate) ml: Vec<MlFit>,
}

/// The configured noise model of a sensor as term levels (SI): white and walk.
pub(crate) fn configured(noise: &NoiseConfig, gyro: bool) -> [(Term, f64); 2] {
    if gyro {
        [
            (Term::White, noise.gyro_deg_h * DEG_PER_HOUR),
            (
                Term::RandomWalk,
                noise.gyro_bias_walk_deg_h_sqrt_h * DEG_PER_HOUR / 60.0,
            ),
        ]
    } else {
        [
            (Term::White, noise.accel_m_s2),
            (Term::RandomWalk, noise.accel_bias_walk_m_s2_sqrt_s),
        ]
    }
}

/// Names of the plot: each sensor's deviation unit.
pub(crate) fn adev_units() -> [(&'static str, &'static str, f64); 2] {
    [
        (GYRO.name, GYRO.adev_unit, GYRO.adev_factor),
        (ACCEL.name, ACCEL.adev_unit, ACCEL.adev_factor),
    ]
}
