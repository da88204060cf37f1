//! Run configuration: site, priors, noises and filter settings, read from TOML.
//!
//! Values are in the paper's units at this edge (field names carry the unit) and converted to SI by
//! [`RunConfig::priors_si`] and friends.

use serde::{Deserialize, Serialize};
use sins_model::earth::Site;
use sins_model::terms::PaperPriors;
use std::path::{Path, PathBuf};
use turntable::program::Program;

/// The paper's run configuration, embedded.
pub const PAPER_CONFIG_TOML: &str = include_str!("../configs/paper.toml");

const ARCMIN: f64 = std::f64::consts::PI / 180.0 / 60.0;
const ARCSEC: f64 = ARCMIN / 60.0;
const DEG_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;

/// Errors reading a configuration.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// File path.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// Not a valid configuration.
    #[error("{origin}: {message}")]
    Invalid {
        /// File path or "<embedded>".
        origin: String,
        /// What is wrong (toml's message carries line and column).
        message: String,
    },
    /// The program could not be read.
    #[error(transparent)]
    Program(#[from] turntable::program::ProgramError),
}

/// Site of the turntable.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SiteConfig {
    /// Geodetic latitude [deg].
    pub latitude_deg: f64,
    /// Longitude [deg].
    pub longitude_deg: f64,
    /// Height [m].
    pub height_m: f64,
}

/// Prior standard deviations, in the paper's units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorsConfig {
    /// Gyro bias [deg/h].
    pub gyro_bias_deg_h: f64,
    /// Gyro scale-factor errors [-].
    pub gyro_scale: f64,
    /// Gyro misalignments [arcmin].
    pub gyro_misalignment_arcmin: f64,
    /// Accelerometer bias [m/s^2].
    pub accel_bias_m_s2: f64,
    /// Accelerometer scale-factor errors [-].
    pub accel_scale: f64,
    /// Accelerometer non-orthogonality [arcmin].
    pub accel_misalignment_arcmin: f64,
    /// Installation misalignment delta_z [deg].
    pub install_misalignment_deg: f64,
    /// Turntable data delay tau [s].
    pub tau_s: f64,
    /// Initial attitude error of the computed frame about the horizontal axes (tilt) [deg].
    pub initial_tilt_deg: f64,
    /// Initial attitude error of the computed frame about the vertical (heading) [deg].
    pub initial_heading_deg: f64,
    /// Base misalignment gamma_p [arcsec].
    pub base_misalignment_arcsec: f64,
}

/// How a measurement at rate `f` sees a white noise given as "sigma at 1 Hz".
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseReading {
    /// The measurement is the average over its interval `1/f`: variance `sigma^2 * f / 1 Hz`
    /// (sigma at 1 Hz = square root of the PSD times 1 s). No information is thrown away.
    Average,
    /// The measurement is one sample with the 1-Hz sigma whatever the rate: at rates below 1 Hz
    /// the data between measurements are thrown away.
    Sample,
}

/// White-noise levels: standard deviation at 1 Hz (square root of the PSD times 1 s).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseConfig {
    /// How measurements read the accelerometer and angle-sensor noise.
    pub reading: NoiseReading,
    /// Gyro noise [deg/h at 1 Hz].
    pub gyro_deg_h: f64,
    /// Accelerometer noise [m/s^2 at 1 Hz].
    pub accel_m_s2: f64,
    /// Angle-sensor noise, each gimbal [arcsec at 1 Hz].
    pub angle_arcsec: f64,
}

/// Filter settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterConfig {
    /// IMU integration rate [Hz].
    pub imu_rate_hz: f64,
    /// Specific-force measurement rate [Hz].
    pub accel_rate_hz: f64,
    /// Turntable-angle measurement rate [Hz].
    pub turntable_rate_hz: f64,
    /// Estimate the base misalignment gamma_p (3 more states).
    pub estimate_base_misalignment: bool,
}

/// A whole run configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// `"paper"` for the embedded program, or a path relative to the configuration file.
    pub program: String,
    /// Site.
    pub site: SiteConfig,
    /// Priors.
    pub priors: PriorsConfig,
    /// Noises.
    pub noise: NoiseConfig,
    /// Filter settings.
    pub filter: FilterConfig,
    /// Directory the configuration was read from (for relative program paths).
    #[serde(skip)]
    pub base_dir: Option<PathBuf>,
}

impl RunConfig {
    /// The embedded configuration of the paper's covariance analysis.
    pub fn paper() -> Self {
        Self::from_toml_str(PAPER_CONFIG_TOML, "<embedded paper config>")
            .expect("embedded configuration is valid")
    }

    /// Parse a configuration; `origin` names the source in error messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ConfigError> {
        let c: RunConfig = toml::from_str(text).map_err(|e| ConfigError::Invalid {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        c.validate(origin)?;
        Ok(c)
    }

    /// Read a configuration file.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let mut c = Self::from_toml_str(&text, &path.display().to_string())?;
        c.base_dir = path.parent().map(Path::to_path_buf);
        Ok(c)
    }

    fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        let bad = |what: &str| ConfigError::Invalid {
            origin: origin.to_string(),
            message: format!("{what} must be a finite positive number"),
        };
        let f = &self.filter;
        for (name, v) in [
            ("filter.imu_rate_hz", f.imu_rate_hz),
            ("filter.accel_rate_hz", f.accel_rate_hz),
            ("filter.turntable_rate_hz", f.turntable_rate_hz),
            ("noise.gyro_deg_h", self.noise.gyro_deg_h),
            ("noise.accel_m_s2", self.noise.accel_m_s2),
            ("noise.angle_arcsec", self.noise.angle_arcsec),
            ("priors.gyro_bias_deg_h", self.priors.gyro_bias_deg_h),
            ("priors.gyro_scale", self.priors.gyro_scale),
            (
                "priors.gyro_misalignment_arcmin",
                self.priors.gyro_misalignment_arcmin,
            ),
            ("priors.accel_bias_m_s2", self.priors.accel_bias_m_s2),
            ("priors.accel_scale", self.priors.accel_scale),
            (
                "priors.accel_misalignment_arcmin",
                self.priors.accel_misalignment_arcmin,
            ),
            (
                "priors.install_misalignment_deg",
                self.priors.install_misalignment_deg,
            ),
            ("priors.tau_s", self.priors.tau_s),
            ("priors.initial_tilt_deg", self.priors.initial_tilt_deg),
            (
                "priors.initial_heading_deg",
                self.priors.initial_heading_deg,
            ),
            (
                "priors.base_misalignment_arcsec",
                self.priors.base_misalignment_arcsec,
            ),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name));
            }
        }
        for (name, r) in [
            ("filter.accel_rate_hz", f.accel_rate_hz),
            ("filter.turntable_rate_hz", f.turntable_rate_hz),
        ] {
            let ratio = f.imu_rate_hz / r;
            if (ratio - ratio.round()).abs() > 1e-9 || ratio.round() < 1.0 {
                return Err(ConfigError::Invalid {
                    origin: origin.to_string(),
                    message: format!(
                        "{name} = {r} must divide filter.imu_rate_hz = {} into a whole number of IMU samples",
                        f.imu_rate_hz
                    ),
                });
            }
        }
        Ok(())
    }

    /// The site.
    pub fn site(&self) -> Site {
        Site::from_degrees(
            self.site.latitude_deg,
            self.site.longitude_deg,
            self.site.height_m,
        )
    }

    /// The rotation program.
    pub fn program(&self) -> Result<Program, ConfigError> {
        if self.program == "paper" {
            return Ok(Program::paper());
        }
        let p = match &self.base_dir {
            Some(d) => d.join(&self.program),
            None => PathBuf::from(&self.program),
        };
        Ok(Program::from_file(&p)?)
    }

    /// Instrument-error priors in SI.
    pub fn priors_si(&self) -> PaperPriors {
        let p = &self.priors;
        PaperPriors {
            gyro_bias: p.gyro_bias_deg_h * DEG_H,
            gyro_scale: p.gyro_scale,
            gyro_misalignment: p.gyro_misalignment_arcmin * ARCMIN,
            accel_bias: p.accel_bias_m_s2,
            accel_scale: p.accel_scale,
            accel_misalignment: p.accel_misalignment_arcmin * ARCMIN,
        }
    }

    /// Gyro white-noise PSD [rad^2/s].
    pub fn gyro_psd(&self) -> f64 {
        (self.noise.gyro_deg_h * DEG_H).powi(2)
    }
    /// Accelerometer white-noise PSD [(m/s^2)^2 s].
    pub fn accel_psd(&self) -> f64 {
        self.noise.accel_m_s2.powi(2)
    }
    /// Angle-sensor white-noise PSD [rad^2 s].
    pub fn angle_psd(&self) -> f64 {
        (self.noise.angle_arcsec * ARCSEC).powi(2)
    }
    /// Initial attitude-error sigma [rad] about East, North, Up.
    pub fn initial_attitude_sigma(&self) -> [f64; 3] {
        let t = self.priors.initial_tilt_deg.to_radians();
        [t, t, self.priors.initial_heading_deg.to_radians()]
    }

    /// Per-measurement noise variance for a white noise of PSD `psd` read at `rate_hz`.
    pub fn measurement_variance(&self, psd: f64, rate_hz: f64) -> f64 {
        match self.noise.reading {
            NoiseReading::Average => psd * rate_hz,
            NoiseReading::Sample => psd * 1.0,
        }
    }
    /// Installation-misalignment sigma [rad].
    pub fn install_sigma(&self) -> f64 {
        self.priors.install_misalignment_deg.to_radians()
    }
    /// Base-misalignment sigma [rad].
    pub fn base_sigma(&self) -> f64 {
        self.priors.base_misalignment_arcsec * ARCSEC
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_config_reads_and_converts() {
        let c = RunConfig::paper();
        assert!((c.priors_si().gyro_bias - 0.5 * DEG_H).abs() < 1e-20);
        assert!(c.program().is_ok());
        assert!((c.site().latitude.to_degrees() - 55.7).abs() < 1e-12);
    }

    #[test]
    fn errors_name_the_origin_and_field() {
        let text = PAPER_CONFIG_TOML.replace("gyro_scale = 1e-3", "gyro_scale = -1.0");
        let e = RunConfig::from_toml_str(&text, "run.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("run.toml") && e.contains("priors.gyro_scale"),
            "{e}"
        );
        let text = PAPER_CONFIG_TOML.replace("accel_rate_hz = 1.0", "accel_rate_hz = 3.0");
        let e = RunConfig::from_toml_str(&text, "run.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("accel_rate_hz"), "{e}");
        let text = PAPER_CONFIG_TOML.replace("[noise]", "[noise]\nbogus = 1");
        let e = RunConfig::from_toml_str(&text, "run.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bogus") && e.contains("line"), "{e}");
    }
}
