//! `--free-motion` (`calibrate` and `diagnose`): a hand-turned multi-position recording without
//! a rotation program or turntable, through the filter of a recording of rests. What this
//! module adds to that path: the configuration from the recording when none is given
//! (`calib::hand_turned`), the section list's known turns, and the blocks of the report and
//! the JSON that only such a recording has (noise measured in the rests, held-out rests, turns).

use crate::Error;
use crate::table;
use ::import::sections::SectionsFile;
use calib::config::RunConfig;
use calib::extension::ModelExtension;
use calib::free_motion::{Evaluation, KnownTurn};
use calib::hand_turned::{DEFAULT_TERMS, HandTurnedResult, NoiseSource, WhiteNoiseAtRest};
use calib::io::ImuData;
use calib::layout::StateLayout;
use calib::rests::Rest;
use serde::Serialize;
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
    /// The paper's model with [`DEFAULT_TERMS`] at the unit grade's priors.
    pub layout: StateLayout,
    /// Known turns of the section list.
    pub turns: Vec<KnownTurn>,
}

/// The configuration: `given` (without a program) with its own noise, or the recording's
/// defaults ([`calib::hand_turned::default_config`]) at `latitude` with the noise measured in
/// the rests.
pub fn setup(
    given: Option<(&RunConfig, &str)>,
    latitude: Option<f64>,
    sections: Option<&std::path::Path>,
    data: &ImuData,
    file: &str,
    rests: &[Rest],
) -> Result<Setup, Error> {
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
            let noise = calib::hand_turned::white_noise_at_rest(data, rests).ok_or_else(|| {
                format!(
                    "{file}: no rest holds two whole seconds: the white noise cannot be \
                     measured in the rests (give a configuration with [noise], --config)"
                )
            })?;
            let config = calib::hand_turned::default_config(data, lat, &noise)
                .ok_or_else(|| format!("{file}: fewer than two records"))?;
            let interval = 1.0 / config.filter.imu_rate_hz;
            if interval > MAX_RECORD_INTERVAL_S {
                return Err(calib::estimate::EstimateError::Rests {
                    file: file.to_string(),
                    source: calib::rests::RestError::SlowRecords {
                        interval_s: interval,
                    },
                }
                .into());
            }
            (
                config,
                format!(
                    "no configuration: latitude {lat} deg, consumer-grade priors, white noise \
                     measured in the rests"
                ),
                Some(noise),
            )
        }
    };
    let ext = ModelExtension::with_grade(&DEFAULT_TERMS, config.unit_grade());
    let layout = calib::layout::layout_with(&config, false, &ext);
    let intervals = calib::hand_turned::intervals_of(data, rests);
    let turns = match sections {
        Some(p) => read_sections(p, data)?.known_turns(&intervals),
        None => Vec::new(),
    };
    Ok(Setup {
        config,
        origin,
        measured,
        layout,
        turns,
    })
}

/// The section list at `path`, checked against the records of `data` before any work
/// ([`SectionsFile::check_records`]).
pub(crate) fn read_sections(
    path: &std::path::Path,
    data: &calib::io::ImuData,
) -> Result<SectionsFile, Error> {
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
    fits: usize,
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
}

/// The JSON block of a result.
pub fn json(r: &HandTurnedResult, holdout: Option<usize>) -> FreeMotionJson {
    let measured = match r.noise {
        NoiseSource::Configured => None,
        NoiseSource::Measured {
            at_rest,
            accel_factor,
            fits,
        } => Some(MeasuredJson {
            gyro_deg_h: at_rest.gyro_rad_s / DEG_PER_HOUR,
            accel_m_s2: at_rest.accel_m_s2,
            dof: at_rest.dof,
            accel_factor,
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
        static_intervals: r.intervals.len(),
        held_out_every: holdout,
        terms: DEFAULT_TERMS.iter().map(|c| c.id()).collect(),
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
        }),
    }
}

/// The head lines of the report that only a hand-turned recording has: the noise and the
/// model.
pub fn header(setup_origin: &str, r: &HandTurnedResult, holdout: Option<usize>) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "  settings        {setup_origin}");
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
            fits,
        } => {
            let _ = writeln!(
                s,
                "  noise           measured in the rests (1-s means, {} degrees of freedom): gyro \
                 {} deg/h, specific force {} m/s^2",
                at_rest.dof,
                table::significant(at_rest.gyro_rad_s / DEG_PER_HOUR, 3),
                table::significant(at_rest.accel_m_s2, 3)
            );
            if accel_factor > 1.0 {
                let _ = writeln!(
                    s,
                    "                  the fit's innovations scatter more: specific force \
                     scaled by {} to {} m/s^2 (the rests differ by more than their own noise, \
                     or the model lacks an error)",
                    table::significant(accel_factor, 3),
                    table::significant(c.noise.accel_m_s2, 3)
                );
            }
            let _ = writeln!(
                s,
                "                  {fits} fit{} to bring the noise to the innovations",
                if fits == 1 { "" } else { "s" }
            );
        }
    }
    if c.filter.motion_attitude_noise_deg > 0.0 {
        let _ = writeln!(
            s,
            "  motions         {} deg of attitude noise per motion (what the gyros' model misses \
             in a hand turn; filter.motion_attitude_noise_deg)",
            table::significant(c.filter.motion_attitude_noise_deg, 3)
        );
    }
    let _ = writeln!(
        s,
        "  gravity         {} m/s^2",
        table::significant(c.site().specific_force_at_rest_enu().norm(), 7)
    );
    let _ = writeln!(
        s,
        "  terms           the paper's model and {} (at {}-grade priors)",
        DEFAULT_TERMS
            .iter()
            .map(|c| c.id())
            .collect::<Vec<_>>()
            .join(", "),
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
    let rms = |f: fn(&calib::free_motion::PoseResidual) -> f64| {
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
             RMS  before {:.3} deg, after {:.3} deg",
            v.intervals,
            v.rotation_pairs,
            v.static_rms_before_m_s2,
            v.static_rms_after_m_s2,
            v.rotation_rms_before_rad.to_degrees(),
            v.rotation_rms_after_rad.to_degrees()
        );
    }
    s
}
