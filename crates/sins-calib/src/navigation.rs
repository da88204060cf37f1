//! The navigation figure every calibration result carries (`navsim::figure`): rho after the
//! flight (the paper's snake, or `--flight FLIGHT.toml`) at the horizon of the unit's grade,
//! from the result's full covariance, beside the figure from the priors, with a budget by
//! parameter group. One type, [`Navigation`], for `calibrate`, `diagnose`, `analyse` and
//! `design`: its JSON block (docs/formats.md, "navigation"), its console line and its report
//! section.

use crate::Error;
use calib::config::RunConfig;
use navsim::{CalibrationCovariance, FlightSetting, NavigationFigure, SnakeConfig};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `--flight`, on every command that gives a navigation figure.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct FlightArgs {
    /// The flight the navigation figure is of: a snake flight as TOML (docs/navsim.md, the
    /// fields of `crates/navsim/config/snake_default.toml`, with an optional `temperature_c`
    /// at which the thermal terms act); default: the paper's one-hour snake. The horizon is
    /// the unit's grade's (1 h navigation, 10 min tactical, 1 min consumer) or the flight's
    /// end, whichever comes first.
    #[arg(long, value_name = "FLIGHT.toml")]
    pub flight: Option<PathBuf>,
}

/// The flight of the figures: the default snake or a file's.
#[derive(Clone, Debug)]
pub struct Flight {
    /// The flight.
    pub config: SnakeConfig,
    /// The file it came from (`None`: the default snake).
    pub file: Option<PathBuf>,
}

impl Flight {
    /// The flight of `--flight` (read and checked now, before any work), or the default snake.
    pub fn load(args: &FlightArgs) -> Result<Self, Error> {
        let Some(path) = &args.flight else {
            return Ok(Self {
                config: SnakeConfig::default_config(),
                file: None,
            });
        };
        let text = sins_model::text::read_text_bounded(
            path,
            sins_model::text::CONFIGURATION_MAX_BYTES,
            "flight",
        )
        .map_err(|e| format!("--flight {}: {e}", path.display()))?;
        let config = SnakeConfig::from_toml_str(&text)
            .map_err(|e| format!("--flight {}: {e}", path.display()))?;
        Ok(Self {
            config,
            file: Some(path.clone()),
        })
    }

    /// The flight in words: "the paper's snake" or "the flight in FILE".
    pub fn name(&self) -> String {
        match &self.file {
            None => "the paper's snake".to_string(),
            Some(p) => format!("the flight in {}", p.display()),
        }
    }
}

/// A navigation figure with what the command knows about it: the flight's name, whether the
/// model fits the data (none for an analysis), what navigation leaves out beyond the figure's
/// own list (random walks). A figure that could not be made says why.
#[derive(Clone, Debug)]
pub struct Navigation {
    /// The figure, or why there is none.
    pub figure: Result<NavigationFigure, String>,
    /// The flight in words.
    pub flight_name: String,
    /// The flight's file.
    pub flight_file: Option<PathBuf>,
    /// Whether the data contradict the model the figure is of (`None`: no data).
    pub model_fits: Option<bool>,
    /// What navigation leaves out beyond the figure's terms (one sentence each).
    pub left_out: Vec<String>,
}

/// The sensors' white noise in flight from a configuration's `[noise]` (the levels at 1 Hz
/// are noise densities times one second's square root).
fn noise_densities(config: &RunConfig) -> (f64, f64) {
    (
        config.noise.gyro_deg_h * sins_model::units::DEG_PER_HOUR,
        config.noise.accel_m_s2,
    )
}

/// What navigation leaves out of a configuration's noise and the terms without parameters.
fn walks_left_out(config: &RunConfig, terms: &[&str]) -> Vec<String> {
    let mut v = Vec::new();
    let n = &config.noise;
    if n.gyro_bias_walk_deg_h_sqrt_h > 0.0 || n.accel_bias_walk_m_s2_sqrt_s > 0.0 {
        v.push(
            "the bias random walks of [noise]: navigation propagates constant instrument \
             errors, so the biases' walk during the flight is not in the figure"
                .to_string(),
        );
    }
    if terms.contains(&sins_model::candidates::Candidate::GyroBiasDrift.id()) {
        v.push(
            "gyro_bias_drift: a random walk of the gyro biases, not a constant error: not in \
             the figure (its effect on the biases' sigmas at the end of the calibration is)"
                .to_string(),
        );
    }
    v
}

impl Navigation {
    /// The figure of a posterior (`names`, `cov`, the prior sigmas) under `config` (its grade
    /// and noise) on `flight`; `reference_c`: the thermal terms' reference temperature;
    /// `terms`: the candidate terms of the model (ids).
    pub fn of(
        cal: CalibrationCovariance,
        config: &RunConfig,
        flight: &Flight,
        terms: &[&str],
        model_fits: Option<bool>,
    ) -> Self {
        let setting = FlightSetting {
            flight: flight.config.clone(),
            grade: config.unit_grade(),
            noise_densities: noise_densities(config),
        };
        Self {
            figure: navsim::navigation_figure(&cal, &setting).map_err(|e| e.to_string()),
            flight_name: flight.name(),
            flight_file: flight.file.clone(),
            model_fits,
            left_out: walks_left_out(config, terms),
        }
    }

    /// The figure of a fit's estimate (its posterior and priors) under the configuration the
    /// fit used.
    pub fn of_estimate(
        est: &calib::estimate::Estimate,
        config: &RunConfig,
        flight: &Flight,
        terms: &[&str],
        model_fits: bool,
    ) -> Self {
        let cal = CalibrationCovariance {
            names: est.names.clone(),
            posterior: est.cov.clone(),
            prior_sigma: est.prior_sigma.clone(),
            reference_temperature_c: est.temperature.as_ref().map(|t| t.reference_c),
        };
        Self::of(cal, config, flight, terms, Some(model_fits))
    }

    /// rho at the horizon (m), when there is a figure.
    pub fn rho_m(&self) -> Option<f64> {
        self.figure.as_ref().ok().map(|f| f.rho_m)
    }

    /// The console's line: `navigation: 713 m after 1 h of the paper's snake (uncalibrated
    /// 25 km)`, with what a misfit means for it.
    pub fn line(&self) -> String {
        let f = match &self.figure {
            Ok(f) => f,
            Err(e) => return format!("navigation: no figure ({e})"),
        };
        let mut s = format!(
            "navigation: {} after {} of {} (uncalibrated {})",
            distance(f.rho_m),
            duration(f.horizon.seconds),
            self.flight_name,
            distance(f.uncalibrated_rho_m)
        );
        if self.model_fits == Some(false) {
            s += "; the data contradict the model: this is the model's figure, not the unit's";
        }
        s
    }
}

/// A distance as `713 m`, `2470 m` or `25 km` (metres below 10 km).
pub fn distance(m: f64) -> String {
    if m.is_finite() && m >= 10_000.0 {
        format!("{:.0} km", m / 1000.0)
    } else {
        format!("{m:.0} m")
    }
}

/// A duration as `1 h`, `10 min`, `1 min` or `45 s`.
pub fn duration(s: f64) -> String {
    let whole = |x: f64| (x - x.round()).abs() < 1e-9;
    if s >= 3600.0 && whole(s / 3600.0) {
        format!("{} h", (s / 3600.0).round())
    } else if s >= 60.0 && whole(s / 60.0) {
        format!("{} min", (s / 60.0).round())
    } else {
        format!("{} s", crate::render::table::compact(s))
    }
}

/// Points of the series in the JSON (the report's plot draws every one).
const SERIES_POINTS: usize = 60;

/// The `navigation` block of a JSON result (docs/formats.md).
#[derive(Serialize)]
#[serde(untagged)]
pub enum NavigationJson<'a> {
    /// The figure.
    Figure(Box<FigureJson<'a>>),
    /// No figure, and why.
    NotMade {
        /// Why.
        not_made: &'a str,
    },
}

/// The figure's block.
#[derive(Serialize)]
pub struct FigureJson<'a> {
    flight: FlightJson<'a>,
    horizon: &'a navsim::Horizon,
    alignment: &'a str,
    rho_m: f64,
    uncalibrated_rho_m: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    model_fits: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    temperature_delta_k: Option<f64>,
    budget: &'a [navsim::GroupRho],
    terms: &'a [navsim::TermNote],
    left_out: &'a [String],
    not_in_flight: &'a [String],
    #[serde(skip_serializing_if = "<[String]>::is_empty")]
    unknown: &'a [String],
    attitude_sigma_deg: [f64; 2],
    notes: &'a [String],
    series: SeriesJson,
}

#[derive(Serialize)]
struct FlightJson<'a> {
    name: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    file: Option<String>,
    /// The flight as flown (cut to the horizon).
    config: &'a SnakeConfig,
}

#[derive(Serialize)]
struct SeriesJson {
    t_s: Vec<f64>,
    calibrated_m: Vec<f64>,
    uncalibrated_m: Vec<f64>,
}

impl Navigation {
    /// The JSON block.
    pub fn json(&self) -> NavigationJson<'_> {
        let f = match &self.figure {
            Ok(f) => f,
            Err(e) => return NavigationJson::NotMade { not_made: e },
        };
        let step = (f.t_s.len().saturating_sub(1))
            .div_ceil(SERIES_POINTS)
            .max(1);
        let pick = |v: &[f64]| -> Vec<f64> {
            let mut out: Vec<f64> = v.iter().step_by(step).copied().collect();
            if !(v.len() - 1).is_multiple_of(step) {
                out.extend(v.last());
            }
            out
        };
        NavigationJson::Figure(Box::new(FigureJson {
            flight: FlightJson {
                name: &self.flight_name,
                file: self.flight_file.as_ref().map(|p| p.display().to_string()),
                config: &f.flight,
            },
            horizon: &f.horizon,
            alignment: f.alignment,
            rho_m: f.rho_m,
            uncalibrated_rho_m: f.uncalibrated_rho_m,
            model_fits: self.model_fits,
            temperature_delta_k: f.temperature_delta_k,
            budget: &f.budget,
            terms: &f.terms,
            left_out: &self.left_out,
            not_in_flight: &f.not_in_flight,
            unknown: &f.unknown,
            attitude_sigma_deg: [f.attitude_sigma_deg.0, f.attitude_sigma_deg.1],
            notes: &f.notes,
            series: SeriesJson {
                t_s: pick(&f.t_s),
                calibrated_m: pick(&f.calibrated_m),
                uncalibrated_m: pick(&f.uncalibrated_m),
            },
        }))
    }

    /// The report's section (Markdown) with its plot written into `dir` as `navigation.png`;
    /// counts the plot into `plots`.
    pub fn report_md(&self, dir: &Path, plots: &mut usize) -> Result<String, Error> {
        let mut s = String::from("## Navigation\n\n");
        let f = match &self.figure {
            Ok(f) => f,
            Err(e) => {
                let _ = writeln!(s, "No navigation figure: {e}.\n");
                return Ok(s);
            }
        };
        let _ = writeln!(
            s,
            "What the calibration buys in navigation (docs/navsim.md): the horizontal position \
             error `rho = a sqrt(s2(dLambda cos phi) + s2(dPhi))` after {} of {}, propagated \
             from the instrument-error covariance: **{}** from the posterior (correlations \
             kept), {} from the priors (the unit uncalibrated).{}\n",
            duration(f.horizon.seconds),
            self.flight_name,
            distance(f.rho_m),
            distance(f.uncalibrated_rho_m),
            if self.model_fits == Some(false) {
                " **The data contradict the model: this is the model's figure, not the unit's.**"
            } else {
                ""
            }
        );
        let _ = writeln!(
            s,
            "Horizon: {} ({} grade). Alignment: {}.\n",
            f.horizon.reason,
            f.horizon.grade.name(),
            f.alignment
        );
        crate::plots::navigation::rho_png(&dir.join("navigation.png"), f, &self.flight_name)?;
        *plots += 1;
        s += "![rho(t), calibrated and uncalibrated](navigation.png)\n\n";
        s += &budget_md(f);
        s += &self.left_out_md(f);
        Ok(s)
    }

    /// The terms navigation propagates or leaves out, and the notes.
    fn left_out_md(&self, f: &NavigationFigure) -> String {
        let mut s = String::new();
        for t in &f.terms {
            let _ = writeln!(
                s,
                "- {}: {}{}",
                t.term,
                if t.propagated { "propagated, " } else { "" },
                t.how
            );
        }
        for l in &self.left_out {
            let _ = writeln!(s, "- left out: {l}");
        }
        if !f.not_in_flight.is_empty() {
            let _ = writeln!(
                s,
                "- not in flight (the turntable's and the mounting's): {}",
                f.not_in_flight.join(", ")
            );
        }
        for n in &f.notes {
            let _ = writeln!(s, "- {n}");
        }
        if !s.is_empty() {
            s.push('\n');
        }
        s
    }
}

/// The budget table.
fn budget_md(f: &NavigationFigure) -> String {
    let mut s = String::from("| group alone | rho at the horizon [m] |\n|---|---:|\n");
    for g in &f.budget {
        let _ = writeln!(s, "| {} | {:.0} |", g.label, g.rho_m);
    }
    let _ = writeln!(
        s,
        "| **all** | **{:.0}** |\n\nEach group keeps its own block of the covariance (the \
         alignment errors it causes included); the groups are not independent, so their \
         root-sum-square is not the total.\n",
        f.rho_m
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_and_durations_read_as_the_console_says() {
        assert_eq!(distance(713.2), "713 m");
        assert_eq!(distance(2470.4), "2470 m");
        assert_eq!(distance(25_400.0), "25 km");
        assert_eq!(duration(3600.0), "1 h");
        assert_eq!(duration(600.0), "10 min");
        assert_eq!(duration(60.0), "1 min");
        assert_eq!(duration(45.0), "45 s");
    }
}
