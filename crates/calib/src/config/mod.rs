//! Run configuration: site, priors, noises and filter settings, read from TOML.
//!
//! Values are in the paper's units at this edge (field names carry the unit) and converted to SI by
//! [`RunConfig::priors_si`] and friends.

pub mod plausible;

use serde::{Deserialize, Serialize};
use sins_model::earth::Site;
use sins_model::terms::PaperPriors;
use std::path::{Path, PathBuf};
use turntable::program::{PAPER_PROGRAM_TOML, Program, ProgramSpec};

/// The paper's run configuration, embedded.
pub const PAPER_CONFIG_TOML: &str = include_str!("../../configs/paper.toml");

use sins_model::units::{ARCMIN, ARCSEC, DEG_PER_HOUR as DEG_H};

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
        /// File path or `"<embedded>"`.
        origin: String,
        /// What is wrong (toml's message carries line and column).
        message: String,
    },
    /// The program could not be read.
    #[error(transparent)]
    Program(#[from] turntable::program::ProgramError),
}

mod sections;
mod values;
use sections::program_from_angles;
pub use sections::{
    AttitudePrior, ClockConfig, FilterConfig, NoiseConfig, NoiseReading, PROGRAM_FROM_ANGLES,
    PriorsConfig, SiteConfig, TemperatureConfig, TruthConfig, UnitIdentity,
};

/// The smallest noise level or prior sigma accepted, in the units of the field's name.
///
/// Sigmas are squared into variances and divided by one another (Kalman gains, normalised
/// innovations): between 1e-12 and 1e6 the variances (1e-24 .. 1e12) and their ratios stay far
/// inside the range of `f64` and the filter keeps its digits. The paper's levels (0.1 deg/h,
/// 1e-3 m/s^2, 15 arcsec, priors 1e-3 .. 10) sit in the middle; 1e-12 of any of these units is
/// below every instrument and every known value (1e-12 deg/h is 5e-18 rad/s), and a value like
/// `1e-300` only makes a variance underflow to zero and the covariance singular.
pub const SIGMA_MIN: f64 = 1e-12;

/// The largest noise level or prior sigma accepted, in the units of the field's name: 1e6
/// deg/h is 280 deg/s, 1e6 m/s^2 a hundred thousand g, 1e6 arcmin or arcsec many turns, 1e6 s
/// of delay eleven days; beyond it a value is a typing error (`1e300`) that would overflow the
/// variances.
pub const SIGMA_MAX: f64 = 1e6;

/// The largest program start accepted (s, either sign): 1e7 s is 116 days of IMU time, above
/// any recording's clock offset; the covariance analysis and the simulator also step through
/// the time before the start.
pub const PROGRAM_START_MAX_S: f64 = 1e7;

/// The largest record rate accepted (Hz): 100 kHz is no IMU's and would only exhaust memory.
pub const MAX_RATE_HZ: f64 = 1e5;

/// The largest turntable clock offset accepted (s, either sign): 1e10 s (317 years) takes a
/// turntable clock in Unix time (1.7e9 s) and refuses a typing error like `1e300`, whose time
/// stamps would lose every digit of the run.
pub const CLOCK_OFFSET_MAX_S: f64 = 1e10;

/// The largest turntable clock rate error accepted (either sign, exclusive): a clock 10 %
/// fast is already no laboratory's.
pub const CLOCK_RATE_ERROR_MAX: f64 = 0.1;

/// A whole run configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// `"paper"` for the embedded program, a path relative to the configuration file, or
    /// `"from-angles"` (also when absent): the program is read from the turntable's angle
    /// records ([`crate::motion::angles_program`]), so a turntable file is needed.
    #[serde(default = "program_from_angles")]
    pub program: String,
    /// Site.
    pub site: SiteConfig,
    /// Priors.
    pub priors: PriorsConfig,
    /// Noises.
    pub noise: NoiseConfig,
    /// Filter settings.
    pub filter: FilterConfig,
    /// Turntable clock relation (absent: the same clock as the IMU).
    #[serde(default)]
    pub clock: ClockConfig,
    /// Truth of a simulated run (only `simulate` reads it; absent: defaults).
    #[serde(default)]
    pub truth: TruthConfig,
    /// The instrument's temperature over the run (absent: none; a recording's own
    /// temperatures come from its `temp` column).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<TemperatureConfig>,
    /// The temperature profile of a recording, made from its `temp` column on the program's
    /// clock, with the reference it was calibrated about: what the covariance analyses of the
    /// model-extension loop see. Not a file setting.
    #[serde(skip)]
    pub recorded_temperature: Option<(turntable::temperature::TemperatureProfile, f64)>,
    /// The unit calibrated (model, serial): written into the result and its report, and
    /// checked by `apply` against the data's unit (absent: unknown).
    #[serde(default, skip_serializing_if = "UnitIdentity::is_empty")]
    pub unit: UnitIdentity,
    /// Directory the configuration was read from (for relative program paths).
    #[serde(skip)]
    pub base_dir: Option<PathBuf>,
    /// A program held in memory (e.g. one proposed by `sins-calib design`), used instead of
    /// `program` when set.
    #[serde(skip)]
    pub inline_program: Option<ProgramSpec>,
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
        let text = sins_model::text::read_text_bounded(
            path,
            sins_model::text::CONFIGURATION_MAX_BYTES,
            "configuration",
        )
        .map_err(|source| ConfigError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let mut c = Self::from_toml_str(&text, &path.display().to_string())?;
        c.base_dir = path.parent().map(Path::to_path_buf);
        Ok(c)
    }

    /// Refuse values no run can have, naming the field and its range; the first found (in
    /// the order: filter rates, sigmas, program start, rate ratios, site and record rates,
    /// clock, truth, temperature).
    fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        let f = &self.filter;
        for (name, v) in [
            ("filter.imu_rate_hz", f.imu_rate_hz),
            ("filter.accel_rate_hz", f.accel_rate_hz),
            ("filter.turntable_rate_hz", f.turntable_rate_hz),
        ] {
            check_positive(origin, name, v)?;
        }
        // The same ranges as the deserializers' (`values`), for configurations built in code
        // (`design`'s proposals, tests) that never went through them.
        for (name, v) in self.sigma_fields() {
            check_sigma(origin, name, v)?;
        }
        check_program_start(origin, f.program_start_s)?;
        check_rate_ratios(origin, f)?;
        self.check_site_and_record_rates(origin)?;
        check_clock(origin, &self.clock)?;
        self.check_truth(origin)?;
        if let Some(temp) = &self.temperature {
            temp.profile().map_err(|message| invalid(origin, message))?;
        }
        Ok(())
    }

    /// Every standard deviation of `[noise]` and `[priors]`, by its name in the file.
    fn sigma_fields(&self) -> [(&'static str, f64); 14] {
        let (n, p) = (&self.noise, &self.priors);
        [
            ("noise.gyro_deg_h", n.gyro_deg_h),
            ("noise.accel_m_s2", n.accel_m_s2),
            ("noise.angle_arcsec", n.angle_arcsec),
            ("priors.gyro_bias_deg_h", p.gyro_bias_deg_h),
            ("priors.gyro_scale", p.gyro_scale),
            (
                "priors.gyro_misalignment_arcmin",
                p.gyro_misalignment_arcmin,
            ),
            ("priors.accel_bias_m_s2", p.accel_bias_m_s2),
            ("priors.accel_scale", p.accel_scale),
            (
                "priors.accel_misalignment_arcmin",
                p.accel_misalignment_arcmin,
            ),
            (
                "priors.install_misalignment_deg",
                p.install_misalignment_deg,
            ),
            ("priors.tau_s", p.tau_s),
            ("priors.initial_tilt_deg", p.initial_tilt_deg),
            ("priors.initial_heading_deg", p.initial_heading_deg),
            (
                "priors.base_misalignment_arcsec",
                p.base_misalignment_arcsec,
            ),
        ]
    }

    /// The site, and the record rates within what an IMU or a turntable gives.
    fn check_site_and_record_rates(&self, origin: &str) -> Result<(), ConfigError> {
        let site = &self.site;
        check_range(
            origin,
            "site.latitude_deg",
            site.latitude_deg,
            (-90.0, 90.0),
            "deg",
        )?;
        check_range(
            origin,
            "site.longitude_deg",
            site.longitude_deg,
            (-180.0, 360.0),
            "deg",
        )?;
        // From the Dead Sea shore to above any laboratory on a mountain.
        check_range(
            origin,
            "site.height_m",
            site.height_m,
            (-500.0, 10_000.0),
            "m",
        )?;
        // Rates beyond 100 kHz are no IMU's; they would only exhaust memory.
        let t = &self.truth;
        for (name, v) in [
            ("filter.imu_rate_hz", self.filter.imu_rate_hz),
            ("truth.imu_rate_hz", t.imu_rate_hz),
            ("truth.turntable_rate_hz", t.turntable_rate_hz),
        ] {
            check_range(origin, name, v, (0.0, 1e5), "Hz")?;
        }
        Ok(())
    }

    /// The truth of a simulated run: positive rates, a duration a program can have, and
    /// plausible values.
    fn check_truth(&self, origin: &str) -> Result<(), ConfigError> {
        let t = &self.truth;
        for (name, v) in [
            ("truth.imu_rate_hz", t.imu_rate_hz),
            ("truth.turntable_rate_hz", t.turntable_rate_hz),
        ] {
            check_positive(origin, name, v)?;
        }
        if let Some(d) = t.duration_s {
            check_range(
                origin,
                "truth.duration_s",
                d,
                (
                    f64::MIN_POSITIVE,
                    turntable::program::MAX_PROGRAM_DURATION_S,
                ),
                "s",
            )?;
        }
        let known = truth_value_names();
        for (name, v) in &t.values {
            if !known.contains(name) {
                // Refused on reading, by every command: a misspelt name would otherwise be
                // ignored by all but `simulate`.
                let shown: String = name.chars().take(80).collect();
                return Err(invalid(
                    origin,
                    format!(
                        "truth.values names `{shown}`, which is not a parameter: expected one \
                         of {} (docs/formats.md)",
                        grouped(&known)
                    ),
                ));
            }
            if let Err(message) = crate::config::plausible::check(name, *v) {
                return Err(invalid(origin, format!("truth.values.{message}")));
            }
        }
        Ok(())
    }

    /// The temperature profile over the run and the thermal terms' reference temperature
    /// (deg C): a recording's own ([`RunConfig::recorded_temperature`]) or the configured one,
    /// whose reference is, unless given, the mean of the temperatures at the records of a
    /// run of `n_records` at `rate_hz` from `t = 0`. `None` without a temperature.
    pub fn temperature_profile(
        &self,
        rate_hz: f64,
        n_records: usize,
    ) -> Option<(turntable::temperature::TemperatureProfile, f64)> {
        if let Some(r) = &self.recorded_temperature {
            return Some(r.clone());
        }
        let t = self.temperature.as_ref()?;
        let profile = t.profile().ok()?;
        // The records' temperatures are those at the middle of their intervals.
        let dt = 1.0 / rate_hz;
        let reference = t
            .reference_c
            .unwrap_or_else(|| profile.mean_at_records(-0.5 * dt, dt, n_records));
        Some((profile, reference))
    }

    /// Length of a measurement window in IMU steps for a measurement every `n_interval` steps:
    /// the whole interval when the noise is read as an average, else the last second of it.
    pub fn window_steps(&self, n_interval: usize) -> usize {
        match self.noise.reading {
            NoiseReading::Average => n_interval,
            NoiseReading::Sample => {
                let one_second = (self.filter.imu_rate_hz.round() as usize).max(1);
                one_second.min(n_interval)
            }
        }
    }

    /// IMU steps between specific-force measurements.
    pub fn accel_interval_steps(&self) -> usize {
        (self.filter.imu_rate_hz / self.filter.accel_rate_hz).round() as usize
    }

    /// IMU steps between turntable-angle measurements.
    pub fn turntable_interval_steps(&self) -> usize {
        (self.filter.imu_rate_hz / self.filter.turntable_rate_hz).round() as usize
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
        if let Some(spec) = &self.inline_program {
            return Ok(Program::compile(spec, "<inline program>")?);
        }
        self.check_program_given()?;
        if self.program == "paper" {
            return Ok(Program::paper());
        }
        let p = match &self.base_dir {
            Some(d) => d.join(&self.program),
            None => PathBuf::from(&self.program),
        };
        Ok(Program::from_file(&p)?)
    }

    /// Whether the program is to be read from the turntable's angle records.
    pub fn program_from_angles(&self) -> bool {
        self.inline_program.is_none() && self.program == PROGRAM_FROM_ANGLES
    }

    fn check_program_given(&self) -> Result<(), ConfigError> {
        if self.program_from_angles() {
            return Err(ConfigError::Invalid {
                origin: "program".into(),
                message: format!(
                    "program = \"{PROGRAM_FROM_ANGLES}\" (or no program): the program is read \
                     from the turntable's angle records, so a turntable file is needed; without \
                     one give the program (\"paper\" or a file), or use --free-motion"
                ),
            });
        }
        Ok(())
    }

    /// The rotation program as written (the segments before compilation).
    pub fn program_spec(&self) -> Result<ProgramSpec, ConfigError> {
        if let Some(spec) = &self.inline_program {
            return Ok(spec.clone());
        }
        self.check_program_given()?;
        let (text, origin) = if self.program == "paper" {
            (
                PAPER_PROGRAM_TOML.to_string(),
                "<embedded paper program>".to_string(),
            )
        } else {
            let p = match &self.base_dir {
                Some(d) => d.join(&self.program),
                None => PathBuf::from(&self.program),
            };
            let text = sins_model::text::read_text_bounded(
                &p,
                sins_model::text::PROGRAM_MAX_BYTES,
                "rotation program",
            )
            .map_err(|source| ConfigError::Io {
                path: p.display().to_string(),
                source,
            })?;
            (text, p.display().to_string())
        };
        toml::from_str(&text).map_err(|e| ConfigError::Invalid {
            origin,
            message: e.to_string(),
        })
    }

    /// The configuration as TOML (what a report shows of a configuration made in the program,
    /// such as `calibrate --free-motion`'s from the recording).
    pub fn to_toml(&self) -> Result<String, String> {
        toml::to_string(self).map_err(|e| e.to_string())
    }

    /// The unit's grade, from the prior of its gyro biases: it sets the priors of the
    /// candidate terms ([`sins_model::candidates::Candidate::prior_sigma`]).
    pub fn unit_grade(&self) -> sins_model::candidates::UnitGrade {
        sins_model::candidates::UnitGrade::from_gyro_bias_prior(self.priors_si().gyro_bias)
    }

    /// Set the instrument-error priors to those of `grade` ([`grade_priors`]).
    pub fn set_grade_priors(&mut self, grade: sins_model::candidates::UnitGrade) {
        let p = grade_priors(grade);
        self.priors.gyro_bias_deg_h = p.gyro_bias / DEG_H;
        self.priors.gyro_scale = p.gyro_scale;
        self.priors.gyro_misalignment_arcmin = p.gyro_misalignment / ARCMIN;
        self.priors.accel_bias_m_s2 = p.accel_bias;
        self.priors.accel_scale = p.accel_scale;
        self.priors.accel_misalignment_arcmin = p.accel_misalignment / ARCMIN;
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

    /// Gyro white-noise PSD (rad^2/s).
    pub fn gyro_psd(&self) -> f64 {
        (self.noise.gyro_deg_h * DEG_H).powi(2)
    }
    /// Accelerometer white-noise PSD [(m/s^2)^2 s].
    pub fn accel_psd(&self) -> f64 {
        self.noise.accel_m_s2.powi(2)
    }
    /// Angle-sensor white-noise PSD (rad^2 s).
    pub fn angle_psd(&self) -> f64 {
        (self.noise.angle_arcsec * ARCSEC).powi(2)
    }
    /// Initial attitude-error sigma (rad) about East, North, Up.
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
    /// Installation-misalignment sigma (rad).
    pub fn install_sigma(&self) -> f64 {
        self.priors.install_misalignment_deg.to_radians()
    }
    /// Base-misalignment sigma (rad).
    pub fn base_sigma(&self) -> f64 {
        self.priors.base_misalignment_arcsec * ARCSEC
    }
}

/// A configuration from `origin` refused with `message`.
fn invalid(origin: &str, message: String) -> ConfigError {
    ConfigError::Invalid {
        origin: origin.to_string(),
        message,
    }
}

/// Names listed by family: `gyro.bias.{x,y,z}, turntable.tau, ...` (the families in the order
/// of their first name).
fn grouped(names: &[String]) -> String {
    let mut families: Vec<(&str, Vec<&str>)> = Vec::new();
    for n in names {
        let (family, last) = n.rsplit_once('.').unwrap_or(("", n));
        match families.iter_mut().find(|(f, _)| *f == family) {
            Some((_, v)) => v.push(last),
            None => families.push((family, vec![last])),
        }
    }
    families
        .iter()
        .map(|(f, v)| match (f.is_empty(), v.as_slice()) {
            (true, _) => v.join(", "),
            (false, [one]) => format!("{f}.{one}"),
            (false, _) => format!("{f}.{{{}}}", v.join(",")),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The names `[truth.values]` may set: the paper's parameters, the installation, delay and
/// base misalignment, and the candidate terms' parameters (a hidden effect of the simulated
/// unit; the bias drift is `[noise]`'s, not a value).
fn truth_value_names() -> Vec<String> {
    use sins_model::candidates::Candidate;
    use sins_model::names;
    let mut v: Vec<String> = sins_model::terms::ErrorModel::paper(&PaperPriors::paper())
        .params()
        .into_iter()
        .map(|p| p.name)
        .collect();
    v.extend(names::INSTALL_DELTA.map(String::from));
    v.push(names::TURNTABLE_TAU.to_string());
    v.extend(names::BASE_GAMMA.map(String::from));
    for c in Candidate::ALL {
        if c != Candidate::GyroBiasDrift {
            v.extend(c.param_names());
        }
    }
    v
}

/// `name = v` must be a finite positive number.
fn check_positive(origin: &str, name: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v > 0.0 {
        return Ok(());
    }
    Err(invalid(
        origin,
        format!("{name} must be a finite positive number"),
    ))
}

/// `name = v` must be a standard deviation within [`SIGMA_MIN`] .. [`SIGMA_MAX`].
fn check_sigma(origin: &str, name: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && (SIGMA_MIN..=SIGMA_MAX).contains(&v) {
        return Ok(());
    }
    Err(invalid(
        origin,
        format!(
            "{name} = {} must lie in {SIGMA_MIN:e} .. {SIGMA_MAX:e} (a standard \
             deviation in the units the field's name gives)",
            values::shown(v)
        ),
    ))
}

/// `name = v` must lie in `lo ..= hi` (`unit` in the message).
fn check_range(
    origin: &str,
    name: &str,
    v: f64,
    (lo, hi): (f64, f64),
    unit: &str,
) -> Result<(), ConfigError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        return Ok(());
    }
    Err(invalid(
        origin,
        format!(
            "{name} = {} must lie in {} .. {} {unit}",
            values::shown(v),
            values::shown(lo),
            values::shown(hi)
        ),
    ))
}

/// `filter.program_start_s`, when given, within +-[`PROGRAM_START_MAX_S`].
fn check_program_start(origin: &str, start: Option<f64>) -> Result<(), ConfigError> {
    match start {
        Some(t0) if !(t0.is_finite() && t0.abs() <= PROGRAM_START_MAX_S) => Err(invalid(
            origin,
            format!(
                "filter.program_start_s = {} must lie in -{PROGRAM_START_MAX_S:e} .. \
                 {PROGRAM_START_MAX_S:e} s",
                values::shown(t0)
            ),
        )),
        _ => Ok(()),
    }
}

/// The measurement rates must divide the IMU rate into a whole number of samples.
fn check_rate_ratios(origin: &str, f: &FilterConfig) -> Result<(), ConfigError> {
    for (name, r) in [
        ("filter.accel_rate_hz", f.accel_rate_hz),
        ("filter.turntable_rate_hz", f.turntable_rate_hz),
    ] {
        let ratio = f.imu_rate_hz / r;
        if (ratio - ratio.round()).abs() > 1e-9 || ratio.round() < 1.0 {
            return Err(invalid(
                origin,
                format!(
                    "{name} = {r} must divide filter.imu_rate_hz = {} into a whole number of IMU samples",
                    f.imu_rate_hz
                ),
            ));
        }
    }
    Ok(())
}

/// The turntable clock: an offset within +-[`CLOCK_OFFSET_MAX_S`], a rate error strictly
/// within +-[`CLOCK_RATE_ERROR_MAX`].
fn check_clock(origin: &str, c: &ClockConfig) -> Result<(), ConfigError> {
    check_range(
        origin,
        "clock.turntable_offset_s",
        c.turntable_offset_s,
        (-CLOCK_OFFSET_MAX_S, CLOCK_OFFSET_MAX_S),
        "s",
    )?;
    if c.turntable_rate_error.is_finite() && c.turntable_rate_error.abs() < CLOCK_RATE_ERROR_MAX {
        return Ok(());
    }
    Err(invalid(
        origin,
        format!(
            "clock.turntable_rate_error = {} must lie strictly between -{CLOCK_RATE_ERROR_MAX} \
             and {CLOCK_RATE_ERROR_MAX}",
            values::shown(c.turntable_rate_error)
        ),
    ))
}

/// The instrument-error priors of a unit of `grade` (SI): the one place they are written.
///
/// - navigation: the paper's (0.5 deg/h, 1e-3, 1 arcmin; 1e-3 m/s^2, 1e-3, 1 arcmin: the
///   embedded `paper` configuration);
/// - tactical: gyro biases of 30 deg/h (the middle of the grade's 1..100 deg/h, in
///   [`sins_model::candidates::UnitGrade::from_gyro_bias_prior`]'s terms), scale factors and
///   misalignments of 1e-3 and 5 arcmin, accelerometer biases of 1e-2 m/s^2 (1 mg);
/// - consumer: 1 deg/s, 5 %, 1 deg; accelerometer biases of 1 m/s^2, 5 %, 1 deg (an
///   uncalibrated MEMS unit straight off the board).
pub fn grade_priors(grade: sins_model::candidates::UnitGrade) -> PaperPriors {
    use sins_model::candidates::UnitGrade;
    match grade {
        UnitGrade::Navigation => RunConfig::paper().priors_si(),
        UnitGrade::Tactical => PaperPriors {
            gyro_bias: 30.0 * DEG_H,
            gyro_scale: 1e-3,
            gyro_misalignment: 5.0 * ARCMIN,
            accel_bias: 1e-2,
            accel_scale: 1e-3,
            accel_misalignment: 5.0 * ARCMIN,
        },
        UnitGrade::Consumer => PaperPriors {
            gyro_bias: 3600.0 * DEG_H,
            gyro_scale: 0.05,
            gyro_misalignment: 60.0 * ARCMIN,
            accel_bias: 1.0,
            accel_scale: 0.05,
            accel_misalignment: 60.0 * ARCMIN,
        },
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
        // Read with the line and column of the value (toml's span), and the field named.
        let line = PAPER_CONFIG_TOML
            .lines()
            .position(|l| l.starts_with("gyro_scale = 1e-3"))
            .expect("the embedded config has the line")
            + 1;
        assert!(
            e.contains("run.toml")
                && e.contains(&format!("line {line}, column"))
                && e.contains("gyro_scale = -1.0")
                && e.contains("expected a standard deviation in 1e-12 .. 1e6"),
            "{e}"
        );
        for (from, to) in [
            ("latitude_deg = 55.7", "latitude_deg = 95.7"),
            ("imu_rate_hz = 100.0", "imu_rate_hz = 1e7"),
            ("gyro_deg_h = 0.1", "gyro_deg_h = nan"),
        ] {
            assert!(PAPER_CONFIG_TOML.contains(from), "{from}");
            let e = RunConfig::from_toml_str(&PAPER_CONFIG_TOML.replace(from, to), "run.toml")
                .unwrap_err()
                .to_string();
            assert!(e.contains("line") && e.contains("expected"), "{to}: {e}");
        }
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

    #[test]
    fn noise_priors_and_program_start_outside_their_ranges_are_refused_by_name() {
        let refused = |from: &str, to: &str, expected: &str| {
            assert!(PAPER_CONFIG_TOML.contains(from), "{from}");
            let e = RunConfig::from_toml_str(&PAPER_CONFIG_TOML.replacen(from, to, 1), "run.toml")
                .unwrap_err()
                .to_string();
            // The source line names the field; the message names the range.
            let line = to.lines().last().expect("a line");
            assert!(
                e.contains("run.toml") && e.contains(line) && e.contains(expected),
                "{to}: {e}"
            );
            // Extremes are shown in exponent form, not as hundreds of digits.
            assert!(e.len() < 400, "{e}");
        };
        let sigma = "expected a standard deviation in 1e-12 .. 1e6";
        refused("gyro_deg_h = 0.1", "gyro_deg_h = 1e-300", sigma);
        refused("accel_m_s2 = 0.001", "accel_m_s2 = 2e6", sigma);
        refused("angle_arcsec = 15.0", "angle_arcsec = 1e300", sigma);
        refused("gyro_bias_deg_h = 0.5", "gyro_bias_deg_h = 1e300", sigma);
        refused("tau_s = 0.05", "tau_s = 1e-13", sigma);
        refused(
            "angle_arcsec = 15.0",
            "angle_arcsec = 15.0\ngyro_bias_walk_deg_h_sqrt_h = 1e-300",
            "expected 0 or a random walk in 1e-12 .. 1e6",
        );
        refused(
            "attitude_prior = \"independent\"",
            "attitude_prior = \"independent\"\nprogram_start_s = 1e300",
            "expected an IMU time in -1e7 .. 1e7 s",
        );
        refused(
            "attitude_prior = \"independent\"",
            "attitude_prior = \"independent\"\nmotion_attitude_noise_deg = 400.0",
            "expected an attitude noise in 0 .. 180 deg",
        );
        // The bounds themselves, a zero walk and a negative start are accepted.
        for (from, to) in [
            ("gyro_deg_h = 0.1", "gyro_deg_h = 1e-12"),
            ("tau_s = 0.05", "tau_s = 1e6"),
            (
                "angle_arcsec = 15.0",
                "angle_arcsec = 15.0\naccel_bias_walk_m_s2_sqrt_s = 0.0",
            ),
            (
                "attitude_prior = \"independent\"",
                "attitude_prior = \"independent\"\nprogram_start_s = -1e7",
            ),
        ] {
            RunConfig::from_toml_str(&PAPER_CONFIG_TOML.replacen(from, to, 1), "run.toml")
                .unwrap_or_else(|e| panic!("{to}: {e}"));
        }
        // Configurations built in code are held to the same ranges.
        let mut c = RunConfig::paper();
        c.priors.accel_scale = 1e300;
        let e = c.validate("code").unwrap_err().to_string();
        assert!(
            e.contains("priors.accel_scale = 1e300 must lie in 1e-12 .. 1e6"),
            "{e}"
        );
        let mut c = RunConfig::paper();
        c.filter.program_start_s = Some(-2e7);
        let e = c.validate("code").unwrap_err().to_string();
        assert!(
            e.contains("filter.program_start_s = -2e7 must lie in -1e7 .. 1e7 s"),
            "{e}"
        );
    }

    #[test]
    fn shipped_configurations_load() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        for name in [
            "crates/calib/configs/paper.toml",
            "crates/calib/configs/paper-reconciled.toml",
            "examples/run.toml",
            "examples/static-4h.toml",
        ] {
            let c = RunConfig::from_file(&root.join(name)).unwrap_or_else(|e| panic!("{e}"));
            c.program().unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}
