//! The sections of a run configuration (`[site]`, `[priors]`, `[noise]`, `[filter]`, `[truth]`,
//! `[temperature]`, `[unit]`), as the TOML reads them.

use super::values;
use serde::{Deserialize, Serialize};
use sins_model::units::DEG_PER_HOUR as DEG_H;

/// Site of the turntable.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SiteConfig {
    /// Geodetic latitude (deg).
    #[serde(deserialize_with = "values::latitude_deg")]
    pub latitude_deg: f64,
    /// Longitude (deg).
    #[serde(deserialize_with = "values::longitude_deg")]
    pub longitude_deg: f64,
    /// Height (m).
    #[serde(deserialize_with = "values::height_m")]
    pub height_m: f64,
}

/// Prior standard deviations, in the paper's units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PriorsConfig {
    /// Gyro bias (deg/h).
    #[serde(deserialize_with = "values::sigma")]
    pub gyro_bias_deg_h: f64,
    /// Gyro scale-factor errors (-).
    #[serde(deserialize_with = "values::sigma")]
    pub gyro_scale: f64,
    /// Gyro misalignments (arcmin).
    #[serde(deserialize_with = "values::sigma")]
    pub gyro_misalignment_arcmin: f64,
    /// Accelerometer bias (m/s^2).
    #[serde(deserialize_with = "values::sigma")]
    pub accel_bias_m_s2: f64,
    /// Accelerometer scale-factor errors (-).
    #[serde(deserialize_with = "values::sigma")]
    pub accel_scale: f64,
    /// Accelerometer non-orthogonality (arcmin).
    #[serde(deserialize_with = "values::sigma")]
    pub accel_misalignment_arcmin: f64,
    /// Installation misalignment delta_z (deg).
    #[serde(deserialize_with = "values::sigma")]
    pub install_misalignment_deg: f64,
    /// Turntable data delay tau (s).
    #[serde(deserialize_with = "values::sigma")]
    pub tau_s: f64,
    /// Initial attitude error of the computed frame about the horizontal axes (tilt) (deg).
    #[serde(deserialize_with = "values::sigma")]
    pub initial_tilt_deg: f64,
    /// Initial attitude error of the computed frame about the vertical (heading) (deg).
    #[serde(deserialize_with = "values::sigma")]
    pub initial_heading_deg: f64,
    /// Base misalignment gamma_p (arcsec).
    #[serde(deserialize_with = "values::sigma")]
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
    /// Gyro noise (deg/h at 1 Hz).
    #[serde(deserialize_with = "values::sigma")]
    pub gyro_deg_h: f64,
    /// Accelerometer noise (m/s^2 at 1 Hz).
    #[serde(deserialize_with = "values::sigma")]
    pub accel_m_s2: f64,
    /// Angle-sensor noise, each gimbal (arcsec at 1 Hz).
    #[serde(deserialize_with = "values::sigma")]
    pub angle_arcsec: f64,
    /// Random walk of each gyro bias (deg/h/sqrt(h)): after an hour a bias has moved by this
    /// much (one sigma). Optional, default 0 (constant biases). Simulated in the truth, process
    /// noise on the gyro-bias states of the filter and of the covariance analysis.
    #[serde(
        default,
        deserialize_with = "values::walk",
        skip_serializing_if = "is_zero"
    )]
    pub gyro_bias_walk_deg_h_sqrt_h: f64,
    /// Random walk of each accelerometer bias (m/s^2/sqrt(s)): after a second a bias has moved
    /// by this much (one sigma). Optional, default 0. Simulated in the truth, process noise on
    /// the accelerometer-bias states.
    #[serde(
        default,
        deserialize_with = "values::walk",
        skip_serializing_if = "is_zero"
    )]
    pub accel_bias_walk_m_s2_sqrt_s: f64,
}

pub(super) fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl NoiseConfig {
    /// The gyro-bias random walk in SI (rad/s/sqrt(s)): `d(nu0)/dt` white with this square
    /// root of its PSD; `None` when zero (or not a finite positive number).
    pub fn gyro_bias_walk(&self) -> Option<[f64; 3]> {
        let q = self.gyro_bias_walk_deg_h_sqrt_h * DEG_H / 60.0;
        (q.is_finite() && q > 0.0).then_some([q; 3])
    }

    /// The accelerometer-bias random walk in SI (m/s^2/sqrt(s)); `None` when zero (or not a
    /// finite positive number).
    pub fn accel_bias_walk(&self) -> Option<[f64; 3]> {
        let q = self.accel_bias_walk_m_s2_sqrt_s;
        (q.is_finite() && q > 0.0).then_some([q; 3])
    }
}

/// How the prior of the initial attitude error is formed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AttitudePrior {
    /// The paper's covariance analysis: `beta_0` independent of everything, with the
    /// `initial_tilt_deg` / `initial_heading_deg` sigmas.
    Independent,
    /// What estimation does: the start attitude is computed from the program's start angles with
    /// the nominal mounting, so its error is the installation misalignment seen in ENU,
    /// `beta_0 = C_0 delta_z + eps`, correlated with `delta_z`; `eps` (independent) has the
    /// `initial_tilt_deg` / `initial_heading_deg` sigmas.
    #[default]
    Installation,
}

/// Filter settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterConfig {
    /// IMU integration rate (Hz).
    #[serde(deserialize_with = "values::rate_hz")]
    pub imu_rate_hz: f64,
    /// Specific-force measurement rate (Hz).
    #[serde(deserialize_with = "values::positive")]
    pub accel_rate_hz: f64,
    /// Turntable-angle measurement rate (Hz).
    #[serde(deserialize_with = "values::positive")]
    pub turntable_rate_hz: f64,
    /// Estimate the base misalignment gamma_p (3 more states).
    pub estimate_base_misalignment: bool,
    /// Prior of the initial attitude error (absent: `installation`).
    #[serde(default)]
    pub attitude_prior: AttitudePrior,
    /// IMU time at which the rotation program starts (s); absent: found from the data (the
    /// measured rate magnitude matched against the program's).
    #[serde(default, deserialize_with = "values::program_start_s")]
    pub program_start_s: Option<f64>,
    /// A recording of rests: white noise added to each axis of the attitude error at the end
    /// of every motion, one sigma in degrees (absent: 0). What the gyros' model misses in a
    /// hand turn (sensor bandwidth, scale-factor nonlinearity at hundreds of deg/s, the hand's
    /// vibration) is otherwise read as calibration errors: on the Ferraris session, turned at
    /// up to 900 deg/s, the x gyro's scale factor followed the rests around the turns and missed
    /// its known 360-degree turn by 2.4 deg. `calibrate --free-motion` measures it from the
    /// innovations ([`crate::estimate::hand_turned`]); no effect on a program.
    #[serde(default, deserialize_with = "values::attitude_noise_deg")]
    pub motion_attitude_noise_deg: f64,
    /// A recording of rests: the error every specific-force window of one rest shares (m/s^2,
    /// one sigma per axis; absent: 0), beyond the white noise that averages down with the
    /// rest's length: a hand-placed unit settles, its mount is not the same twice, a slow
    /// drift moves from one rest to the next. The windows of a rest then carry at most the
    /// information of one measurement of this sigma, so a long rest no longer outweighs short
    /// ones by its length alone. `calibrate --free-motion` measures it from the rests'
    /// least-squares `|f| = g` residuals ([`crate::estimate::hand_turned`]); no effect on a
    /// program.
    #[serde(
        default,
        deserialize_with = "values::rest_error_m_s2",
        skip_serializing_if = "is_zero"
    )]
    pub rest_error_m_s2: f64,
    /// Hold out the measurements of every `k`-th segment that has measurements (the program's
    /// segments; the rests of a recording without a program), counted from 1 so the first is
    /// never held out: each is evaluated as a prediction (its innovation and innovation
    /// covariance, [`crate::check::diagnostics::Innovation::held_out`]) and not used. Not a file
    /// setting: the model-extension loop sets it for its held-out check ([`crate::extend`]).
    #[serde(skip)]
    pub hold_out_every: Option<usize>,
    /// What `calibrate` adds to a fit: after it, one more pass with every candidate term the
    /// recording can test appended to the model, for the score tests of the verdict
    /// ([`crate::estimate::score_pass`]). Not a file setting: `calibrate` sets it, and the
    /// model-extension loop for its final model; the loop's other fits do not.
    #[serde(skip)]
    pub score_terms: bool,
    /// Along a program whose records' temperature moved, carry the thermal bias terms the
    /// model lacks at the grade's prior ([`crate::estimate::score_pass`]).
    /// Not a file setting: `calibrate` sets it; the loop, which tests the thermal terms
    /// itself, does not.
    #[serde(skip)]
    pub carry_thermal: bool,
}

/// How the turntable clock relates to the IMU clock, as the laboratory's synchronisation knows
/// it (`[clock]`): `t_tt = turntable_offset_s + (1 + turntable_rate_error) * t_imu`. The filter
/// estimates the remaining delay `tau` of the turntable data relative to this relation; a
/// constant clock offset and `tau` act alike, so only their sum can be learnt from data. The
/// type is [`turntable::sensor::Clock`], the relation's one definition.
pub type ClockConfig = turntable::sensor::Clock;

/// The truth of a simulated run (`sins-calib simulate`): rates, seed and true values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TruthConfig {
    /// Seed of the random generator (parameter draws and noise).
    pub seed: u64,
    /// IMU output rate (Hz).
    #[serde(deserialize_with = "values::rate_hz")]
    pub imu_rate_hz: f64,
    /// Turntable angle-sensor output rate (Hz) (its own clock).
    #[serde(deserialize_with = "values::rate_hz")]
    pub turntable_rate_hz: f64,
    /// Length of the run (s); absent = the program's duration.
    #[serde(deserialize_with = "values::duration_s")]
    pub duration_s: Option<f64>,
    /// Draw every parameter that `values` does not set from its prior (instrument errors,
    /// installation misalignment, delay, and the base misalignment when it is estimated);
    /// otherwise such parameters are zero.
    pub draw_from_priors: bool,
    /// Add the sensor noises of `[noise]` to the records (absent: true); false gives noiseless
    /// records, where a consistent calibration's errors are far below its sigmas.
    pub noise: bool,
    /// True values in SI units by documented name (`gyro.bias.x`, `install.delta.z`,
    /// `turntable.tau`, `base.gamma.x`, ...), overriding the draws; each within its physical
    /// bound ([`crate::config::plausible`]).
    pub values: std::collections::BTreeMap<String, f64>,
}

impl Default for TruthConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            imu_rate_hz: 100.0,
            turntable_rate_hz: 100.0,
            duration_s: None,
            draw_from_priors: true,
            noise: true,
            values: Default::default(),
        }
    }
}

/// The instrument's temperature over a run (`[temperature]`): a profile on the program's clock
/// for `simulate` (the thermal truth terms act on it, and the records get a `temp` column) and
/// for `analyse`/`design` (what the thermal terms' covariance analysis sees), and the reference
/// temperature the thermal terms are about.
///
/// ```toml
/// [temperature]
/// profile = "warmup"        # constant | warmup | ramp | steps
/// start_c = 20.0
/// end_c = 35.0
/// time_constant_s = 900.0
/// # reference_c = 27.5      # absent: the mean temperature of the run's records
/// ```
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemperatureConfig {
    /// `constant` (`temp_c`), `warmup` (`start_c`, `end_c`, `time_constant_s`), `ramp`
    /// (`start_c`, `end_c`, `rate_c_per_min`) or `steps` (`steps = [[t_s, temp_c], ...]`).
    pub profile: String,
    /// Constant temperature (deg C).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temp_c: Option<f64>,
    /// Temperature at the start (deg C).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_c: Option<f64>,
    /// Temperature approached or reached (deg C).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_c: Option<f64>,
    /// Time constant of a warm-up (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_constant_s: Option<f64>,
    /// Rate of a ramp (deg C per minute).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_c_per_min: Option<f64>,
    /// Steps: `[t_s, temp_c]`, each temperature held from its time on.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "values::pairs"
    )]
    pub steps: Option<Vec<[f64; 2]>>,
    /// The temperature the thermal terms are about (deg C); absent: the mean of the run's
    /// records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_c: Option<f64>,
}

impl TemperatureConfig {
    /// The profile the fields describe; `Err` names the missing or misplaced field.
    pub fn profile(&self) -> Result<turntable::temperature::TemperatureProfile, String> {
        use turntable::temperature::TemperatureProfile as P;
        let fields = [
            ("temp_c", self.temp_c.is_some()),
            ("start_c", self.start_c.is_some()),
            ("end_c", self.end_c.is_some()),
            ("time_constant_s", self.time_constant_s.is_some()),
            ("rate_c_per_min", self.rate_c_per_min.is_some()),
            ("steps", self.steps.is_some()),
        ];
        let wants: &[&str] = match self.profile.as_str() {
            "constant" => &["temp_c"],
            "warmup" => &["start_c", "end_c", "time_constant_s"],
            "ramp" => &["start_c", "end_c", "rate_c_per_min"],
            "steps" => &["steps"],
            other => {
                return Err(format!(
                    "temperature.profile = \"{other}\": expected constant, warmup, ramp or steps"
                ));
            }
        };
        for (name, given) in fields {
            if given != wants.contains(&name) {
                return Err(format!(
                    "temperature.profile = \"{}\" {} `temperature.{name}`: it takes {}",
                    self.profile,
                    if given { "does not take" } else { "needs" },
                    wants.join(", ")
                ));
            }
        }
        let v = |x: Option<f64>| x.unwrap_or(f64::NAN);
        let profile = match self.profile.as_str() {
            "constant" => P::Constant {
                temp_c: v(self.temp_c),
            },
            "warmup" => P::Warmup {
                start_c: v(self.start_c),
                end_c: v(self.end_c),
                time_constant_s: v(self.time_constant_s),
            },
            "ramp" => P::Ramp {
                start_c: v(self.start_c),
                end_c: v(self.end_c),
                rate_c_per_min: v(self.rate_c_per_min),
            },
            _ => P::Steps {
                steps: self.steps.clone().unwrap_or_default(),
            },
        };
        profile.check().map_err(|e| format!("temperature.{e}"))?;
        if let Some(r) = self.reference_c
            && !turntable::temperature::TEMPERATURE_RANGE_C.contains(&r)
        {
            return Err(format!(
                "temperature.reference_c = {r}: expected a temperature in deg C within {} .. {}",
                turntable::temperature::TEMPERATURE_RANGE_C.start(),
                turntable::temperature::TEMPERATURE_RANGE_C.end()
            ));
        }
        Ok(profile)
    }
}

/// The `program` value that reads the program from the turntable's angle records.
pub const PROGRAM_FROM_ANGLES: &str = "from-angles";

pub(super) fn program_from_angles() -> String {
    PROGRAM_FROM_ANGLES.to_string()
}

/// The identity of an IMU (`[unit]` of a run configuration or import profile, `--unit-model`
/// and `--unit-serial` of the commands): what a calibration result says it is of, so that it is
/// not applied to another unit's records by mistake. Both fields are optional.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UnitIdentity {
    /// The unit's model (type designation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// The unit's serial number.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<String>,
}

impl UnitIdentity {
    /// Whether neither model nor serial is known.
    pub fn is_empty(&self) -> bool {
        self.model.is_none() && self.serial.is_none()
    }

    /// `self` with the fields `other` has set replacing its own.
    pub fn overridden_by(&self, other: &UnitIdentity) -> UnitIdentity {
        UnitIdentity {
            model: other.model.clone().or_else(|| self.model.clone()),
            serial: other.serial.clone().or_else(|| self.serial.clone()),
        }
    }

    /// Where two identities contradict each other: a field both give, with different values
    /// (`(field, self's, other's)`); a field only one gives is no contradiction.
    pub fn conflicts(&self, other: &UnitIdentity) -> Vec<(&'static str, String, String)> {
        [
            ("model", &self.model, &other.model),
            ("serial", &self.serial, &other.serial),
        ]
        .into_iter()
        .filter_map(|(f, a, b)| match (a, b) {
            (Some(a), Some(b)) if a.trim() != b.trim() => Some((f, a.clone(), b.clone())),
            _ => None,
        })
        .collect()
    }

    /// `model M, serial S` (what is known), or `unknown`.
    pub fn describe(&self) -> String {
        let parts: Vec<String> = [("model", &self.model), ("serial", &self.serial)]
            .into_iter()
            .filter_map(|(f, v)| v.as_ref().map(|v| format!("{f} {v}")))
            .collect();
        if parts.is_empty() {
            "unknown".into()
        } else {
            parts.join(", ")
        }
    }
}
