//! `--free-motion` (`calibrate` and `diagnose`): a hand-turned multi-position recording without
//! a rotation program or turntable, through the filter of a recording of rests. What this
//! module adds to that path: the configuration from the recording when none is given
//! (`calib::estimate::hand_turned`), the section list's known turns, and the blocks of the report and
//! the JSON that only such a recording has (noise measured in the rests, held-out rests, turns).

use crate::Error;
use crate::table;
use ::import::sections::SectionsFile;
use calib::config::RunConfig;
use calib::estimate::hand_turned::{GradeChoice, HandTurnedResult, NoiseSource, WhiteNoiseAtRest};
use calib::io::ImuData;
use calib::model::extension::ModelExtension;
use calib::model::layout::StateLayout;
use calib::motion::free_motion::{EarthRateTreatment, Evaluation};
use calib::motion::rests::{Rest, Turn};
use serde::Serialize;
use sins_model::candidates::Candidate;
use sins_model::units::DEG_PER_HOUR;
use std::fmt::Write as _;

/// The longest mean record interval of a hand-turned recording without a configuration (s):
/// a 90-degree hand turn takes about a second.
const MAX_RECORD_INTERVAL_S: f64 = 0.1;

/// Latitude (deg) of the site when neither --config nor --latitude gives one.
pub const DEFAULT_LATITUDE_DEG: f64 = 45.0;

/// What a `--free-motion` run needs before the filter: the configuration (given, or from the
/// recording), its origin for the report, the noise measured in the rests when the
/// configuration's came from there, the model, and the known turns.
pub struct Setup {
    /// The configuration the filter starts from.
    pub config: RunConfig,
    /// Where it came from, for the report.
    pub origin: String,
    /// The rests' white noise, when the configuration's levels are it.
    pub measured: Option<WhiteNoiseAtRest>,
    /// The paper's model with the terms asked for, at the unit grade's priors.
    pub layout: StateLayout,
    /// The terms beyond the paper's model.
    pub terms: Vec<Candidate>,
    /// The grade chosen from the data (without a configuration).
    pub grade: Option<GradeChoice>,
    /// Known turns of the section list.
    pub turns: Vec<Turn>,
    /// What the configuration assumed for want of an input (the site's latitude and height,
    /// and the gravity from them).
    pub assumptions: Vec<String>,
}

/// The configuration: `given` (without a program) with its own noise, or the recording's
/// defaults ([`calib::estimate::hand_turned::default_config`]) at the command line's `latitude` and
/// `height` with the noise measured in the rests and the grade from the data
/// ([`calib::estimate::hand_turned::choose_grade`]); the model is the paper's with `terms`.
pub fn setup(
    given: Option<(&RunConfig, &str)>,
    (latitude, height): (Option<f64>, Option<f64>),
    sections: Option<&std::path::Path>,
    terms: &[Candidate],
    data: &ImuData,
    file: &str,
    rests: &[Rest],
) -> Result<Setup, Error> {
    let mut grade = None;
    let mut assumptions = Vec::new();
    let (config, origin, measured) = match given {
        Some((config, origin)) => {
            let config = config.clone();
            if !config.program_from_angles() {
                return Err(format!(
                    "{origin}: --free-motion calibrates a recording without a program; this \
                     configuration has one (leave --free-motion out, or remove `program`)"
                )
                .into());
            }
            (
                config,
                format!("{origin}: [site], [priors] and [noise]"),
                None,
            )
        }
        None => {
            let lat = latitude.unwrap_or(DEFAULT_LATITUDE_DEG);
            if !(-90.0..=90.0).contains(&lat) {
                return Err(format!("--latitude {lat}: expected -90 .. 90 deg").into());
            }
            let noise = calib::estimate::hand_turned::white_noise_at_rest(data, rests).ok_or_else(
                || {
                    format!(
                        "{file}: no rest holds two whole seconds: the white noise cannot be \
                     measured in the rests (give a configuration with [noise], --config)"
                    )
                },
            )?;
            let choice = calib::estimate::hand_turned::choose_grade(data, rests, &noise);
            grade = Some(choice);
            let h = height.unwrap_or(0.0);
            // From the Dead Sea shore to above any laboratory on a mountain, as [site].
            if !(-500.0..=10_000.0).contains(&h) {
                return Err(format!("--height {h}: expected -500 .. 10000 m").into());
            }
            let config =
                calib::estimate::hand_turned::default_config(data, lat, h, &noise, choice.grade)
                    .ok_or_else(|| format!("{file}: fewer than two records"))?;
            if latitude.is_none() {
                assumptions.push(format!(
                    "latitude {lat} deg assumed: no [site] given (--latitude or a \
                     configuration's [site] sets it); normal gravity {} m/s^2 and the Earth \
                     rate's components follow from it",
                    table::significant(config.site().specific_force_at_rest_enu().norm(), 7)
                ));
            }
            if height.is_none() {
                assumptions.push(
                    "height 0 m assumed: no [site] given (--height or a configuration's [site] \
                     sets it); gravity falls 3.1e-6 m/s^2 a metre above it, which the \
                     accelerometers' scale factors take up (0.3 ppm a metre)"
                        .to_string(),
                );
            }
            let interval = 1.0 / config.filter.imu_rate_hz;
            if interval > MAX_RECORD_INTERVAL_S {
                return Err(calib::estimate::EstimateError::Rests {
                    file: file.to_string(),
                    source: calib::motion::rests::RestError::SlowRecords {
                        interval_s: interval,
                    },
                }
                .into());
            }
            (
                config,
                format!(
                    "no configuration: latitude {lat} deg{}, height {h} m{}, {}-grade priors, \
                     white noise and motion noise measured in the rests",
                    if latitude.is_none() {
                        " (assumed: give --latitude)"
                    } else {
                        ""
                    },
                    if height.is_none() {
                        " (assumed: give --height)"
                    } else {
                        ""
                    },
                    choice.grade.name()
                ),
                Some(noise),
            )
        }
    };
    let ext = ModelExtension::with_grade(terms, config.unit_grade());
    let layout = calib::model::layout::layout_with(&config, false, &ext);
    let times: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    let turns = match sections {
        Some(p) => read_sections(p, data)?.known_turns(rests, &times),
        None => Vec::new(),
    };
    Ok(Setup {
        config,
        origin,
        measured,
        layout,
        terms: terms.to_vec(),
        grade,
        turns,
        assumptions,
    })
}

/// The terms of `--terms` and `--terms-from` (a `diagnose --json` result's `accepted_terms`),
/// each once, in the order given.
pub fn terms_asked(
    ids: &[String],
    from: Option<&std::path::Path>,
) -> Result<Vec<Candidate>, Error> {
    let mut all: Vec<String> = ids.to_vec();
    if let Some(path) = from {
        let text = read_bounded(path, "--terms-from", TERMS_FROM_MAX_BYTES)?;
        let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
            format!(
                "{}: not a diagnose result (JSON): {e}; expected the file `sins-calib diagnose \
                 --json` writes",
                path.display()
            )
        })?;
        calib::io::schema::check(
            &path.display().to_string(),
            v.get("schema"),
            &[calib::io::schema::DIAGNOSIS],
            "the file `sins-calib diagnose --json` writes",
        )?;
        let accepted = v
            .get("accepted_terms")
            .and_then(|a| a.as_array())
            .ok_or_else(|| {
                format!(
                    "{}: no `accepted_terms` list: expected the file `sins-calib diagnose --json` \
                     writes",
                    path.display()
                )
            })?;
        for t in accepted {
            let id = t.as_str().ok_or_else(|| {
                format!(
                    "{}: `accepted_terms` holds {t}: expected term ids (strings)",
                    path.display()
                )
            })?;
            if !all.iter().any(|a| a == id) {
                all.push(id.to_string());
            }
        }
    }
    crate::diagnose::parse_terms(&all)
}

/// The largest `--terms-from` file read (a diagnose result is a few tens of kilobytes).
const TERMS_FROM_MAX_BYTES: u64 = 16 << 20;

/// The text of a small file, refused past `max` bytes (the shared bounded reader: a device
/// such as /dev/zero is refused at the bound too).
fn read_bounded(path: &std::path::Path, option: &str, max: u64) -> Result<String, Error> {
    sins_model::text::read_text_bounded(path, max, "diagnose result")
        .map_err(|e| format!("{option} {}: cannot read: {e}", path.display()).into())
}

/// The section list at `path`, checked against the records of `data` before any work
/// ([`SectionsFile::check_records`]).
pub(crate) fn read_sections(
    path: &std::path::Path,
    data: &calib::io::ImuData,
) -> Result<SectionsFile, Error> {
    crate::provenance::check_stamp(
        path,
        &[calib::io::schema::SECTIONS],
        "the sections.json `sins-calib import` writes",
    )?;
    let sections = SectionsFile::read(path)?;
    let times: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    sections
        .check_records(&times)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(sections)
}

/// The free-motion block of the JSON result (docs/formats.md).
#[derive(Serialize)]
pub struct FreeMotionJson {
    /// Where the noise came from: `"configured"` or `"measured in the rests"`.
    noise_source: &'static str,
    /// The levels the filter used (sigma of a 1-s mean).
    noise_gyro_deg_h: f64,
    noise_accel_m_s2: f64,
    motion_attitude_noise_deg: f64,
    /// Measured noise: the rests' scatter and the factor on its specific-force level.
    #[serde(skip_serializing_if = "Option::is_none")]
    measured: Option<MeasuredJson>,
    gravity_m_s2: f64,
    static_intervals: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    held_out_every: Option<usize>,
    /// The grade chosen from the data (without a configuration).
    #[serde(skip_serializing_if = "Option::is_none")]
    grade: Option<GradeJson>,
    terms: Vec<&'static str>,
    turns: Vec<TurnJson>,
    #[serde(skip_serializing_if = "Option::is_none")]
    validation: Option<ValidationJson>,
}

#[derive(Serialize)]
struct MeasuredJson {
    gyro_deg_h: f64,
    accel_m_s2: f64,
    dof: usize,
    accel_factor: f64,
    /// The innovations' variance over the rests' own noise, and its p-value.
    scatter_ratio: f64,
    scatter_p_value: f64,
    motion_attitude_noise_deg: f64,
    motion_windows: usize,
    fits: usize,
}

#[derive(Serialize)]
struct GradeJson {
    grade: &'static str,
    by_noise: &'static str,
    by_rest_rate: &'static str,
    rest_rate_excess_deg_h: f64,
}

#[derive(Serialize)]
struct TurnJson {
    name: String,
    expected_deg: f64,
    before_deg: f64,
    after_deg: f64,
}

#[derive(Serialize)]
struct BeforeAfter {
    before: f64,
    after: f64,
}

#[derive(Serialize)]
struct ValidationJson {
    static_rms_m_s2: BeforeAfter,
    rotation_rms_deg: BeforeAfter,
    intervals: usize,
    rotation_pairs: usize,
    /// Whether the rotation figure takes the Earth's rotation out, and the floor it leaves
    /// where it cannot (deg).
    earth_rate_compensated: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    earth_rate_floor_deg: Option<f64>,
    fitted_static_rms_m_s2: f64,
    fitted_intervals: usize,
    held_out_motion_rms_deg: f64,
    held_out_motions: usize,
    fitted_motion_rms_deg: f64,
    fitted_motions: usize,
}

/// The JSON block of a result.
pub fn json(r: &HandTurnedResult, setup: &SetupSummary, holdout: Option<usize>) -> FreeMotionJson {
    let measured = match r.noise {
        NoiseSource::Configured => None,
        NoiseSource::Measured {
            at_rest,
            accel_factor,
            excess,
            motion_noise_deg,
            motion_windows,
            fits,
            ..
        } => Some(MeasuredJson {
            gyro_deg_h: at_rest.gyro_rad_s / DEG_PER_HOUR,
            accel_m_s2: at_rest.accel_m_s2,
            dof: at_rest.dof,
            accel_factor,
            scatter_ratio: excess.ratio,
            scatter_p_value: excess.p_value,
            motion_attitude_noise_deg: motion_noise_deg,
            motion_windows,
            fits,
        }),
    };
    FreeMotionJson {
        noise_source: match r.noise {
            NoiseSource::Configured => "configured",
            NoiseSource::Measured { .. } => "measured in the rests",
        },
        noise_gyro_deg_h: r.config.noise.gyro_deg_h,
        noise_accel_m_s2: r.config.noise.accel_m_s2,
        motion_attitude_noise_deg: r.config.filter.motion_attitude_noise_deg,
        measured,
        gravity_m_s2: r.config.site().specific_force_at_rest_enu().norm(),
        static_intervals: r.estimate.rests.len(),
        held_out_every: holdout,
        grade: setup.grade.map(|g| GradeJson {
            grade: g.grade.name(),
            by_noise: g.by_noise.name(),
            by_rest_rate: g.by_rest_rate.name(),
            rest_rate_excess_deg_h: g.rest_rate_excess_deg_h,
        }),
        terms: setup.terms.iter().map(|c| c.id()).collect(),
        turns: r
            .evaluation
            .turns
            .iter()
            .map(|t| TurnJson {
                name: t.name.clone(),
                expected_deg: t.expected_rad.to_degrees(),
                before_deg: t.before_rad.to_degrees(),
                after_deg: t.after_rad.to_degrees(),
            })
            .collect(),
        validation: r.evaluation.validation.map(|v| ValidationJson {
            static_rms_m_s2: BeforeAfter {
                before: v.static_rms_before_m_s2,
                after: v.static_rms_after_m_s2,
            },
            rotation_rms_deg: BeforeAfter {
                before: v.rotation_rms_before_rad.to_degrees(),
                after: v.rotation_rms_after_rad.to_degrees(),
            },
            intervals: v.intervals,
            rotation_pairs: v.rotation_pairs,
            earth_rate_compensated: v.earth_rate == EarthRateTreatment::Compensated,
            earth_rate_floor_deg: match v.earth_rate {
                EarthRateTreatment::Compensated => None,
                EarthRateTreatment::NotResolved { floor_rad } => Some(floor_rad.to_degrees()),
            },
            fitted_static_rms_m_s2: v.fitted_static_rms_m_s2,
            fitted_intervals: v.fitted_intervals,
            held_out_motion_rms_deg: v.held_out_motion_rms_rad.to_degrees(),
            held_out_motions: v.held_out_motions,
            fitted_motion_rms_deg: v.fitted_motion_rms_rad.to_degrees(),
            fitted_motions: v.fitted_motions,
        }),
    }
}

/// What the report and the JSON say of a run's setup beyond its result: where the
/// configuration came from, the grade chosen, the terms asked for.
pub struct SetupSummary {
    /// Where the configuration came from.
    pub origin: String,
    /// The grade chosen from the data.
    pub grade: Option<GradeChoice>,
    /// The terms beyond the paper's model.
    pub terms: Vec<Candidate>,
    /// What the configuration assumed ([`Setup::assumptions`]).
    pub assumptions: Vec<String>,
}

impl Setup {
    /// What the report keeps of it.
    pub fn summary(&self) -> SetupSummary {
        SetupSummary {
            origin: self.origin.clone(),
            grade: self.grade,
            terms: self.terms.clone(),
            assumptions: self.assumptions.clone(),
        }
    }
}

/// The head lines of the report that only a hand-turned recording has: the noise and the
/// model.
pub fn header(setup: &SetupSummary, r: &HandTurnedResult, holdout: Option<usize>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "  settings        {}", setup.origin);
    if let Some(g) = &setup.grade {
        let _ = writeln!(s, "  grade           {}", g.describe());
    }
    let c = &r.config;
    match r.noise {
        NoiseSource::Configured => {
            let _ = writeln!(
                s,
                "  noise           configured: gyro {} deg/h, specific force {} m/s^2 (1-s means)",
                table::significant(c.noise.gyro_deg_h, 3),
                table::significant(c.noise.accel_m_s2, 3)
            );
        }
        NoiseSource::Measured {
            at_rest,
            accel_factor,
            excess,
            motion_windows,
            fits,
            ..
        } => {
            let _ = writeln!(
                s,
                "  noise           measured in the rests (1-s means, {} degrees of freedom): gyro \
                 {} deg/h, specific force {} m/s^2",
                at_rest.dof,
                table::significant(at_rest.gyro_rad_s / DEG_PER_HOUR, 3),
                table::significant(at_rest.accel_m_s2, 3)
            );
            let _ = writeln!(
                s,
                "                  specific force scaled by {} to {} m/s^2, the scatter of the \
                 fit's innovations ({} the rests' own noise: variance ratio {}, p = {:.2e})",
                table::significant(accel_factor, 3),
                table::significant(c.noise.accel_m_s2, 3),
                if excess.significant() {
                    "significantly more than"
                } else {
                    "consistent with"
                },
                table::significant(excess.ratio, 3),
                excess.p_value
            );
            let _ = writeln!(
                s,
                "                  motion noise measured from the first window after each of {} \
                 motions; {fits} fit{} to bring both to the innovations",
                motion_windows,
                if fits == 1 { "" } else { "s" }
            );
        }
    }
    let _ = writeln!(
        s,
        "  motions         {} deg of attitude noise per motion (what the gyros' model misses \
         in a hand turn; filter.motion_attitude_noise_deg)",
        table::significant(c.filter.motion_attitude_noise_deg, 3)
    );
    let _ = writeln!(
        s,
        "  gravity         {} m/s^2",
        table::significant(c.site().specific_force_at_rest_enu().norm(), 7)
    );
    let _ = writeln!(
        s,
        "  terms           {} (at {}-grade priors)",
        if setup.terms.is_empty() {
            "the paper's model only (--terms or --terms-from adds others)".to_string()
        } else {
            format!(
                "the paper's model and {}",
                setup
                    .terms
                    .iter()
                    .map(|c| c.id())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        c.unit_grade().name()
    );
    if let Some(k) = holdout {
        let _ = writeln!(
            s,
            "  held out        every {k}-th rest: its measurements are predicted, not used"
        );
    }
    s
}

/// The turns and the held-out validation, for the report.
pub fn evaluation_report(e: &Evaluation) -> String {
    let mut s = String::new();
    for t in &e.turns {
        let _ = writeln!(
            s,
            "  turn {}: expected {:.1} deg, raw gyro {:.2} deg, calibrated {:.2} deg",
            t.name,
            t.expected_rad.to_degrees(),
            t.before_rad.to_degrees(),
            t.after_rad.to_degrees()
        );
    }
    let fitted: Vec<_> = e.poses.iter().filter(|p| !p.held_out).collect();
    let rms = |f: fn(&calib::motion::free_motion::PoseResidual) -> f64| {
        (fitted.iter().map(|p| f(p).powi(2)).sum::<f64>() / fitted.len().max(1) as f64).sqrt()
    };
    let _ = writeln!(
        s,
        "  static |f| - g RMS over the {} fitted rests: before {:.5} m/s^2, after {:.5} m/s^2",
        fitted.len(),
        rms(|p| p.before_m_s2),
        rms(|p| p.after_m_s2)
    );
    if let Some(v) = &e.validation {
        let _ = writeln!(
            s,
            "\nHeld-out validation ({} rests, {} pairs of consecutive ones)\n  static |f| - g \
             RMS        before {:.5} m/s^2, after {:.5} m/s^2\n  rotation (gravity direction) \
             RMS  before {:.3} deg, after {:.3} deg{}\n  over single motions     into or out of \
             held-out rests {:.3} deg ({}), between fitted rests {:.3} deg ({})",
            v.intervals,
            v.rotation_pairs,
            v.static_rms_before_m_s2,
            v.static_rms_after_m_s2,
            v.rotation_rms_before_rad.to_degrees(),
            v.rotation_rms_after_rad.to_degrees(),
            match v.earth_rate {
                EarthRateTreatment::Compensated => " (the Earth's rotation taken out)".to_string(),
                EarthRateTreatment::NotResolved { floor_rad } => format!(
                    " (the Earth's rotation not taken out: the gyros do not resolve the \
                     heading; it adds up to {:.3} deg RMS over these pairs)",
                    floor_rad.to_degrees()
                ),
            },
            v.held_out_motion_rms_rad.to_degrees(),
            v.held_out_motions,
            v.fitted_motion_rms_rad.to_degrees(),
            v.fitted_motions
        );
    }
    s
}
