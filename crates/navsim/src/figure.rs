//! The navigation figure of a calibration, as the paper judges one: rho at a horizon after the
//! flight, propagated from the instrument-error covariance the calibration leaves
//! (correlations kept), beside the same figure from the priors (the unit uncalibrated), with a
//! budget by parameter group.
//!
//! The horizon follows the unit's grade ([`horizon`]): one hour of unaided navigation is the
//! paper's figure for a navigation-grade unit and means nothing for a consumer one. So does the
//! alignment: a navigation-grade unit gyrocompasses, a lesser one is levelled and takes its
//! heading from elsewhere (taken as exact, so that the figure is the calibration's).
//!
//! Every instrument parameter the calibration estimated acts in flight through its own effect
//! on the sensors ([`crate::InstrumentModel`]): the paper's four terms and the candidate terms
//! (g-sensitivity, scale asymmetry, quadratic term, size effect, time offset, and the thermal
//! terms at the flight's temperature when the flight gives one). Parameters of the turntable
//! and of the mounting on it do not act in flight and are listed as such.

use nalgebra::DMatrix;
use serde::Serialize;
use sins_model::candidates::{Candidate, UnitGrade};

use crate::NavError;
use crate::config::SnakeConfig;
use crate::instruments::{IGNORED_PREFIXES, InstrumentCovariance, InstrumentModel, NamePolicy};
use crate::model::BETA;
use crate::propagate::{InitialAttitude, NavOptions, block};
use crate::response::{NavResponse, Part};
use crate::trajectory::SnakeTrajectory;

/// How far ahead the figure looks, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Horizon {
    /// Seconds of flight.
    pub seconds: f64,
    /// The unit's grade it follows.
    #[serde(serialize_with = "grade_name")]
    pub grade: UnitGrade,
    /// Why this horizon (one sentence).
    pub reason: String,
}

fn grade_name<S: serde::Serializer>(g: &UnitGrade, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(g.name())
}

/// The horizon of a unit of `grade` on a flight of `flight_duration_s`: the grade's (one hour
/// for navigation grade, ten minutes for tactical, one minute for consumer) or the flight's
/// end, whichever comes first.
pub fn horizon(grade: UnitGrade, flight_duration_s: f64) -> Horizon {
    let (seconds, why) = match grade {
        UnitGrade::Navigation => (
            3600.0,
            "a navigation-grade unit (gyro-bias prior up to 1 deg/h) navigates unaided for \
             hours: the paper's figure, after one hour",
        ),
        UnitGrade::Tactical => (
            600.0,
            "a tactical-grade unit (gyro-bias prior 1 to 100 deg/h) bridges minutes without \
             aiding, not hours: after an hour its errors (tens of kilometres, attitude errors of \
             degrees, beyond the linear error model) say nothing; after 10 min",
        ),
        UnitGrade::Consumer => (
            60.0,
            "a consumer-grade unit (gyro-bias prior above 100 deg/h) dead-reckons for seconds \
             between fixes: its error after an hour says nothing; after 1 min",
        ),
    };
    let mut h = Horizon {
        seconds,
        grade,
        reason: why.to_string(),
    };
    if flight_duration_s < seconds {
        h.seconds = flight_duration_s;
        h.reason = format!(
            "{why}; the flight ends sooner, after {} s",
            trim(flight_duration_s)
        );
    }
    h
}

fn trim(x: f64) -> String {
    let s = format!("{x:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The alignment before the flight of a unit of `grade`, and its description.
pub fn alignment(grade: UnitGrade) -> (InitialAttitude, &'static str) {
    match grade {
        UnitGrade::Navigation => (
            InitialAttitude::Aligned,
            "levelled and gyrocompassed at the start, its errors from the same instrument \
             errors (the paper's alignment)",
        ),
        _ => (
            InitialAttitude::Levelled,
            "levelled at the start, its tilt from the same instrument errors; the heading from \
             an external reference, taken as exact (gyrocompassing needs gyro biases well below \
             the Earth rate)",
        ),
    }
}

/// What a calibration left: the posterior covariance of its parameters (SI, any order, with
/// or without the turntable's and the attitude's states) and their prior sigmas.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationCovariance {
    /// Parameter names, one per row of `posterior`.
    pub names: Vec<String>,
    /// Posterior covariance (SI).
    pub posterior: DMatrix<f64>,
    /// Prior sigma of each parameter (SI): the unit before the calibration.
    pub prior_sigma: Vec<f64>,
    /// The temperature the thermal terms' coefficients are about (deg C), when the
    /// calibration has one.
    pub reference_temperature_c: Option<f64>,
}

/// Where and how the unit flies.
#[derive(Clone, Debug, PartialEq)]
pub struct FlightSetting {
    /// The flight (its duration is cut to the horizon).
    pub flight: SnakeConfig,
    /// The unit's grade (sets the horizon and the alignment).
    pub grade: UnitGrade,
    /// The sensors' white noise in flight: gyro [rad/s/sqrt(Hz)], accelerometer
    /// [m/s^2/sqrt(Hz)].
    pub noise_densities: (f64, f64),
}

/// rho of one group of parameters alone.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupRho {
    /// `gyro_bias`, `gyro_matrix`, `accel_bias`, `accel_matrix`, a candidate term's id,
    /// `alignment` or `sensor_noise`.
    pub group: String,
    /// Label for tables.
    pub label: String,
    /// rho at the horizon with this group alone \[m\].
    pub rho_m: f64,
}

/// What navigation does with a candidate term the calibration estimated.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TermNote {
    /// The term's id.
    pub term: &'static str,
    /// Whether it acts in the figure.
    pub propagated: bool,
    /// How it acts in flight, or why it is left out.
    pub how: String,
}

/// The navigation figure of a calibration.
#[derive(Clone, Debug, PartialEq)]
pub struct NavigationFigure {
    /// How far ahead, and why.
    pub horizon: Horizon,
    /// The flight as flown (cut to the horizon).
    pub flight: SnakeConfig,
    /// The alignment before the flight.
    pub alignment: &'static str,
    /// The flight's temperature less the thermal terms' reference (K), when both are known.
    pub temperature_delta_k: Option<f64>,
    /// rho at the horizon from the posterior, correlations kept \[m\].
    pub rho_m: f64,
    /// rho at the horizon from the priors (the unit uncalibrated) \[m\].
    pub uncalibrated_rho_m: f64,
    /// Time of the series \[s\].
    pub t_s: Vec<f64>,
    /// rho(t) from the posterior \[m\].
    pub calibrated_m: Vec<f64>,
    /// rho(t) from the priors \[m\].
    pub uncalibrated_m: Vec<f64>,
    /// rho at the horizon of each group alone: the paper's four terms, each candidate term, the
    /// alignment, the sensors' noise (not independent: their root-sum-square is not the total).
    pub budget: Vec<GroupRho>,
    /// Each candidate term: propagated, or left out and why.
    pub terms: Vec<TermNote>,
    /// Parameters that do not act in flight (the turntable's, the mounting on it).
    pub not_in_flight: Vec<String>,
    /// Parameters navigation does not know (left out).
    pub unknown: Vec<String>,
    /// The attitude error's largest sigma at the horizon (deg), calibrated and uncalibrated.
    pub attitude_sigma_deg: (f64, f64),
    /// Where the linear error model stops holding (attitude errors of degrees), one line each.
    pub notes: Vec<String>,
}

/// Above this attitude sigma (deg) the linear error model's figure is an order of magnitude,
/// not a number (second-order terms of `beta` reach `beta^2 / 2`, 0.4 % at 5 deg).
pub const LINEAR_ATTITUDE_LIMIT_DEG: f64 = 5.0;

/// The figure of a calibration on one flight, for any number of calibrations of the same
/// parameters (one propagation: [`NavResponse`]).
pub struct Judge {
    horizon: Horizon,
    flight: SnakeConfig,
    alignment: &'static str,
    model: InstrumentModel,
    temperature_delta_k: Option<f64>,
    response: NavResponse,
}

impl Judge {
    /// The flight of `setting` cut to the horizon, propagated for the instrument parameters
    /// among `names` (the temperature's departure `temperature_delta_k` from the thermal
    /// terms' reference, when known).
    pub fn new(
        setting: &FlightSetting,
        names: &[String],
        temperature_delta_k: Option<f64>,
    ) -> Result<Self, NavError> {
        let horizon = horizon(setting.grade, setting.flight.duration_s);
        let mut flight = setting.flight.clone();
        flight.duration_s = horizon.seconds;
        let traj = SnakeTrajectory::new(&flight)?;
        let (initial_attitude, alignment) = alignment(setting.grade);
        let opts = NavOptions {
            gyro_noise_density: setting.noise_densities.0,
            accel_noise_density: setting.noise_densities.1,
            initial_attitude,
            temperature_delta_k: temperature_delta_k.unwrap_or(0.0),
            ..NavOptions::default()
        };
        let model = InstrumentModel::for_names(names.iter().map(String::as_str));
        let response = NavResponse::new(&traj, &model, &opts)?;
        Ok(Self {
            horizon,
            flight,
            alignment,
            model,
            temperature_delta_k,
            response,
        })
    }

    /// rho at the horizon \[m\] for a covariance of the parameters (names and matrix).
    pub fn rho_m(&self, names: &[String], cov: &DMatrix<f64>) -> Result<f64, NavError> {
        let p = self.in_order(names, cov)?;
        Ok(self.response.rho_m(self.last(), &p, Part::All))
    }

    /// The figure of `cal` (whose names must be those the judge was made for, in any order).
    pub fn figure(&self, cal: &CalibrationCovariance) -> Result<NavigationFigure, NavError> {
        let p = self.in_order(&cal.names, &cal.posterior)?;
        let prior = DMatrix::from_diagonal(&nalgebra::DVector::from_iterator(
            cal.prior_sigma.len(),
            cal.prior_sigma.iter().map(|s| s * s),
        ));
        let q = self.in_order(&cal.names, &prior)?;
        let r = &self.response;
        let calibrated = r.rho_series(&p, Part::All);
        let uncalibrated = r.rho_series(&q, Part::All);
        let attitude = |m: &DMatrix<f64>| {
            let c = r.covariance(self.last(), m, Part::All);
            (BETA..BETA + 3)
                .map(|i| c[(i, i)].max(0.0).sqrt().to_degrees())
                .fold(0.0, f64::max)
        };
        let attitude_sigma_deg = (attitude(&p), attitude(&q));
        let (not_in_flight, unknown) = self.names_left(&cal.names);
        Ok(NavigationFigure {
            horizon: self.horizon.clone(),
            flight: self.flight.clone(),
            alignment: self.alignment,
            temperature_delta_k: self.temperature_delta_k,
            rho_m: calibrated.final_rho_m(),
            uncalibrated_rho_m: uncalibrated.final_rho_m(),
            t_s: calibrated.t,
            calibrated_m: calibrated.rho_m,
            uncalibrated_m: uncalibrated.rho_m,
            budget: self.budget(&p),
            terms: self.term_notes(),
            not_in_flight,
            unknown,
            attitude_sigma_deg,
            notes: linear_notes(attitude_sigma_deg),
        })
    }

    fn last(&self) -> usize {
        self.response.points().len() - 1
    }

    /// A covariance over `names` in the model's order (the attitude's, turntable's and
    /// mounting's states and unknown names dropped).
    fn in_order(&self, names: &[String], cov: &DMatrix<f64>) -> Result<DMatrix<f64>, NavError> {
        let keep: Vec<usize> = (0..names.len())
            .filter(|&i| !is_attitude(&names[i]))
            .collect();
        let c = InstrumentCovariance::new(
            keep.iter().map(|&i| names[i].clone()).collect(),
            DMatrix::from_fn(keep.len(), keep.len(), |a, b| cov[(keep[a], keep[b])]),
        )?;
        let policy = NamePolicy {
            allow_missing: false,
            ignore_unknown: true,
        };
        c.in_model_order(&self.model, policy)
    }

    /// rho at the horizon of each group alone.
    fn budget(&self, p: &DMatrix<f64>) -> Vec<GroupRho> {
        let r = &self.response;
        let k = self.last();
        let mut v: Vec<GroupRho> = self
            .model
            .groups()
            .into_iter()
            .map(|g| GroupRho {
                rho_m: r.rho_m(k, &block(p, &g.indices), Part::Instruments),
                group: g.id,
                label: g.label,
            })
            .collect();
        v.push(GroupRho {
            group: "alignment".into(),
            label: "alignment only".into(),
            rho_m: r.rho_m(k, p, Part::Alignment),
        });
        v.push(GroupRho {
            group: "sensor_noise".into(),
            label: "sensor noise only".into(),
            rho_m: r.rho_m(k, p, Part::Noise),
        });
        v
    }

    /// What navigation does with each candidate term of the model.
    fn term_notes(&self) -> Vec<TermNote> {
        self.model
            .terms()
            .iter()
            .map(|(c, _)| {
                let (propagated, how) =
                    term_note(*c, self.flight.temperature_c, self.temperature_delta_k);
                TermNote {
                    term: c.id(),
                    propagated,
                    how,
                }
            })
            .collect()
    }

    /// The names that do not act in flight (turntable, mounting) and those navigation does not
    /// know.
    fn names_left(&self, names: &[String]) -> (Vec<String>, Vec<String>) {
        let known = self.model.names();
        let mut not_in_flight = Vec::new();
        let mut unknown = Vec::new();
        for n in names {
            if known.contains(n) || is_attitude(n) {
                continue;
            }
            if IGNORED_PREFIXES.iter().any(|p| n.starts_with(p)) {
                not_in_flight.push(n.clone());
            } else {
                unknown.push(n.clone());
            }
        }
        (not_in_flight, unknown)
    }
}

fn is_attitude(name: &str) -> bool {
    sins_model::names::ATTITUDE_BETA.contains(&name)
}

/// Whether a candidate term acts in the figure, and how (or why not).
fn term_note(c: Candidate, flight_c: Option<f64>, delta: Option<f64>) -> (bool, String) {
    if c.is_thermal() {
        return match (flight_c, delta) {
            (Some(t), Some(d)) => (
                true,
                format!(
                    "at the flight's {} deg C, {d:+.2} K from the calibration's reference",
                    trim(t)
                ),
            ),
            (None, _) => (
                false,
                "left out: the flight gives no temperature (temperature_c in a --flight TOML)"
                    .into(),
            ),
            (Some(_), None) => (
                false,
                "left out: the calibration has no reference temperature".into(),
            ),
        };
    }
    let how = match c {
        Candidate::GyroGSensitivity => {
            "gyro error G f from the flight's specific force (gravity, the turns' load factor)"
        }
        Candidate::GyroScaleAsymmetry => "gyro error a |w| from the flight's body rates",
        Candidate::AccelQuadratic => "accelerometer error k2 f^2 from the flight's specific force",
        Candidate::AccelSizeEffect => {
            "accelerometer error from the flight's body rates and their rates of change at the \
             lever arms (the mean change over each step)"
        }
        Candidate::GyroAccelTimeOffset => {
            "accelerometer error -d df/dt from the specific force's change (roll-in, roll-out)"
        }
        _ => "through its effect on the sensors",
    };
    (true, how.to_string())
}

/// The notes on attitude errors beyond the linear error model.
fn linear_notes((calibrated, uncalibrated): (f64, f64)) -> Vec<String> {
    let mut v = Vec::new();
    for (what, s) in [("calibrated", calibrated), ("uncalibrated", uncalibrated)] {
        if s > LINEAR_ATTITUDE_LIMIT_DEG {
            v.push(format!(
                "the {what} figure's attitude error reaches {s:.1} deg (1 sigma) at the horizon, \
                 beyond the linear error model (valid to a few degrees): read it as an order of \
                 magnitude"
            ));
        }
    }
    v
}

/// The figure of `cal` on `setting`'s flight: [`Judge::new`] for its names, then
/// [`Judge::figure`]. The thermal terms act at the flight's temperature less the calibration's
/// reference, when both are known.
pub fn navigation_figure(
    cal: &CalibrationCovariance,
    setting: &FlightSetting,
) -> Result<NavigationFigure, NavError> {
    let delta = setting
        .flight
        .temperature_c
        .zip(cal.reference_temperature_c)
        .map(|(t, r)| t - r);
    Judge::new(setting, &cal.names, delta)?.figure(cal)
}
