//! `--free-motion` (`calibrate` and `diagnose`): a hand-turned multi-position recording without
//! a rotation program or turntable, through the filter of a recording of rests. What this
//! module adds to that path: the configuration from the recording when none is given
//! (`calib::estimate::hand_turned`), the section list's known turns, and the blocks of the report and
//! the JSON that only such a recording has (noise measured in the rests, held-out rests, turns).

use crate::Error;
use crate::render::table;
use ::import::sections::SectionsFile;
use calib::config::RunConfig;
use calib::estimate::calibration::Calibration;
use calib::estimate::hand_turned::{GradeChoice, NoiseSource, WhiteNoiseAtRest};
use calib::model::extension::ModelExtension;
use calib::model::layout::StateLayout;
use calib::motion::detect::RateSource;
use calib::motion::free_motion::{EarthRateTreatment, Evaluation};
use calib::motion::rests::Rest;
use calib::motion::rests::Turn;
use calib::motion::stamps::StampCounts;
use sins_model::candidates::{Candidate, UnitGrade};
use sins_model::units::DEG_PER_HOUR;

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
    /// The grade of the configuration's priors (resolved once: it sets the terms' priors and
    /// is reported).
    pub unit_grade: UnitGrade,
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
/// The records are read again from `source` for each figure, not held.
pub fn setup(
    given: Option<(&RunConfig, &str)>,
    site: (Option<f64>, Option<f64>),
    sections: Option<&std::path::Path>,
    terms: &[Candidate],
    source: &mut RateSource,
    rests: &[Rest],
) -> Result<Setup, Error> {
    let made = match given {
        Some((config, origin)) => given_config(config, origin)?,
        None => config_from_recording(site, source, rests)?,
    };
    let config = made.config;
    let unit_grade = config.unit_grade();
    let ext = ModelExtension::with_grade(terms, unit_grade);
    let layout = calib::model::layout::layout_with(&config, false, &ext);
    let turns = match sections {
        Some(p) => known_turns(&read_sections(p, source)?, source, rests)?,
        None => Vec::new(),
    };
    Ok(Setup {
        config,
        origin: made.origin,
        measured: made.measured,
        layout,
        terms: terms.to_vec(),
        grade: made.grade,
        unit_grade,
        turns,
        assumptions: made.assumptions,
    })
}

/// The configuration of a `--free-motion` run before the model and the turns: where it came
/// from, and what was measured, chosen and assumed to make it.
struct Made {
    config: RunConfig,
    origin: String,
    measured: Option<WhiteNoiseAtRest>,
    grade: Option<GradeChoice>,
    assumptions: Vec<String>,
}

/// A given configuration: refused with a program; its own noise.
fn given_config(config: &RunConfig, origin: &str) -> Result<Made, Error> {
    let config = config.clone();
    if !config.program_from_angles() {
        return Err(format!(
            "{origin}: --free-motion calibrates a recording without a program; this \
             configuration has one (leave --free-motion out, or remove `program`)"
        )
        .into());
    }
    Ok(Made {
        config,
        origin: format!("{origin}: [site], [priors] and [noise]"),
        measured: None,
        grade: None,
        assumptions: Vec::new(),
    })
}

/// The recording's defaults at the site's `latitude` and `height` (each assumed when not
/// given, and said so), with the noise measured in the rests and the grade from the data.
fn config_from_recording(
    (latitude, height): (Option<f64>, Option<f64>),
    source: &mut RateSource,
    rests: &[Rest],
) -> Result<Made, Error> {
    let file = &source.file().to_string();
    let lat = latitude.unwrap_or(DEFAULT_LATITUDE_DEG);
    if !(-90.0..=90.0).contains(&lat) {
        return Err(format!("--latitude {lat}: expected -90 .. 90 deg").into());
    }
    let at_rest = calib::estimate::hand_turned::RecordsAtRest::read(source.source(), rests)?;
    let noise = calib::estimate::hand_turned::white_noise_at_rest(&at_rest).ok_or_else(|| {
        format!(
            "{file}: no rest holds two whole seconds: the white noise cannot be \
                     measured in the rests (give a configuration with [noise], --config)"
        )
    })?;
    let choice = calib::estimate::hand_turned::choose_grade(&at_rest, &noise);
    let h = height.unwrap_or(0.0);
    // From the Dead Sea shore to above any laboratory on a mountain, as [site].
    if !(-500.0..=10_000.0).contains(&h) {
        return Err(format!("--height {h}: expected -500 .. 10000 m").into());
    }
    let config =
        calib::estimate::hand_turned::default_config(&at_rest, lat, h, &noise, choice.grade)
            .ok_or_else(|| format!("{file}: fewer than two records"))?;
    let assumptions = site_assumptions(&config, lat, latitude.is_none(), height.is_none());
    let interval = 1.0 / config.filter.imu_rate_hz;
    if interval > MAX_RECORD_INTERVAL_S {
        check_jump(source)?;
        return Err(calib::estimate::EstimateError::Rests {
            file: file.to_string(),
            source: calib::motion::rests::RestError::SlowRecords {
                interval_s: interval,
            },
        }
        .into());
    }
    let assumed = |missing: bool, option: &str| {
        if missing {
            format!(" (assumed: give --{option})")
        } else {
            String::new()
        }
    };
    Ok(Made {
        origin: format!(
            "no configuration: latitude {lat} deg{}, height {h} m{}, {}-grade priors, white \
             noise and motion noise measured in the rests",
            assumed(latitude.is_none(), "latitude"),
            assumed(height.is_none(), "height"),
            choice.grade.name()
        ),
        config,
        measured: Some(noise),
        grade: Some(choice),
        assumptions,
    })
}

/// What a configuration made from the recording assumed of its site: the latitude and the
/// height, each when not given.
fn site_assumptions(
    config: &RunConfig,
    lat: f64,
    latitude_assumed: bool,
    height_assumed: bool,
) -> Vec<String> {
    let mut assumptions = Vec::new();
    if latitude_assumed {
        assumptions.push(format!(
            "latitude {lat} deg assumed: no [site] given (--latitude or a configuration's \
             [site] sets it); normal gravity {} m/s^2 and the Earth rate's components follow \
             from it",
            table::significant(config.site().specific_force_at_rest_enu().norm(), 7)
        ));
    }
    if height_assumed {
        assumptions.push(
            "height 0 m assumed: no [site] given (--height or a configuration's [site] sets \
             it); gravity falls 3.1e-6 m/s^2 a metre above it, which the accelerometers' scale \
             factors take up (0.3 ppm a metre)"
                .to_string(),
        );
    }
    assumptions
}

/// Refuse a jump in the time stamps (an interval of more than [`JUMP_MEDIAN_INTERVALS`]
/// median intervals, e.g. 1e6 s), naming its line: it makes the records' mean interval that
/// of no recording, and the message would otherwise blame the record rate. One reading of the
/// records for their longest interval (the last of the longest, as `Iterator::max_by` gives).
fn check_jump(source: &mut RateSource) -> Result<(), Error> {
    let file = source.file().to_string();
    let median = source.median;
    // Index, length and stamps of the longest interval so far.
    let mut longest: Option<(usize, f64, f64, f64)> = None;
    let (mut k, mut previous) = (0usize, f64::NAN);
    source.records_of(&mut |r, _| {
        if k > 0 {
            let d = r.t - previous;
            if longest.is_none_or(|(_, best, _, _)| d.total_cmp(&best).is_ge()) {
                longest = Some((k - 1, d, previous, r.t));
            }
        }
        previous = r.t;
        k += 1;
    })?;
    let Some((k, d, t0, t1)) = longest else {
        return Ok(());
    };
    if median > 0.0 && d > JUMP_MEDIAN_INTERVALS * median {
        return Err(format!(
            "{file}: line {}: the time stamps jump by {} s (t = {} s at line {}, {} s here) \
             against a median interval of {} s: expected records at a steady rate; split the \
             recording at the jump",
            k + 3,
            table::compact(d),
            table::compact(t0),
            k + 2,
            table::compact(t1),
            table::compact(median)
        )
        .into());
    }
    Ok(())
}

/// An interval longer than this many median intervals is a jump in the time stamps.
const JUMP_MEDIAN_INTERVALS: f64 = 1000.0;

/// The section list at `path`, checked against the records of `source` before any work
/// ([`SectionsFile::check_records`], [`check_faces`]): one reading for the stamps of its
/// sections' first and last records, one for its static faces' specific force.
pub(crate) fn read_sections(
    path: &std::path::Path,
    source: &mut RateSource,
) -> Result<SectionsFile, Error> {
    crate::provenance::check_stamp(
        path,
        &[calib::io::schema::SECTIONS],
        "the sections.json `sins-calib import` writes",
    )?;
    let sections = SectionsFile::read(path)?;
    let ends = sections
        .sections
        .iter()
        .flat_map(|s| [s.first_record, s.last_record]);
    let median = source.median;
    let stamps = StampCounts::read(source.source(), [], ends, median)?;
    sections
        .check_records(&stamps)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    check_faces(&sections, source).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(sections)
}

/// The known turns of `sections` on the records of `source` between its `rests`
/// ([`SectionsFile::known_turns`]): one reading to put the rests on the records, one for the
/// stamps of the turns' records.
fn known_turns(
    sections: &SectionsFile,
    source: &mut RateSource,
    rests: &[Rest],
) -> Result<Vec<Turn>, Error> {
    let times = || rests.iter().flat_map(|r| [r.t0, r.t1]);
    let median = source.median;
    let counts = StampCounts::read(source.source(), times(), [], median)?;
    let records = sections.turn_records(rests, &counts);
    let stamps = StampCounts::read(source.source(), times(), records, median)?;
    Ok(sections.known_turns(rests, &stamps))
}

/// The largest angle (deg) between a static face's `up` and the specific force its records
/// measure: a hand-placed face is within a few degrees; a reversed or wrong one is 90 or 180.
const MAX_FACE_TILT_DEG: f64 = 30.0;

/// Check every static face of the list against the records: its `up` given (the specific force
/// at rest is g times it, which the calibration measures it by) and within
/// [`MAX_FACE_TILT_DEG`] of the direction of the specific force over its records. A face with
/// its `up` missing or reversed was used as it was written. (The records are those
/// [`SectionsFile::check_records`] found inside the file.) One reading of the faces' records.
fn check_faces(sections: &SectionsFile, source: &mut RateSource) -> Result<(), String> {
    use calib::motion::sections::SectionKind;
    let faces: Vec<_> = sections
        .sections
        .iter()
        .filter(|s| s.kind == SectionKind::Static)
        .collect();
    // The sum of the records' specific force (or velocity increments): its direction is
    // that of the mean specific force either way.
    let ranges: Vec<_> = faces
        .iter()
        .map(|s| s.first_record..s.last_record + 1)
        .collect();
    let mut sums = vec![nalgebra::Vector3::zeros(); faces.len()];
    calib::motion::stamps::read_ranges(source.source(), &ranges, f64::NAN, &mut |i, _, r, _| {
        sums[i] += nalgebra::Vector3::from(r.accel);
    })
    .map_err(|e| e.to_string())?;
    for (s, sum) in faces.iter().zip(&sums) {
        let Some(up) = s.up else {
            return Err(format!(
                "section `{}` is a static face without `up`: expected the body axis that \
                 points up there (a unit vector in the axes of the IMU file)",
                s.name
            ));
        };
        let up = nalgebra::Vector3::from(up);
        let angle = up.angle(sum).to_degrees();
        if angle.is_nan() || angle > MAX_FACE_TILT_DEG {
            let dir = sum.normalize();
            return Err(format!(
                "section `{}`: up = [{:.3}, {:.3}, {:.3}], but the specific force its records \
                 measure points along [{:.3}, {:.3}, {:.3}], {angle:.0} deg from it: expected \
                 the body axis that points up within {MAX_FACE_TILT_DEG} deg (a reversed or \
                 wrong `up`, or a section list of another recording)",
                s.name, up[0], up[1], up[2], dir[0], dir[1], dir[2]
            ));
        }
    }
    Ok(())
}

/// What the report and the JSON say of a run's setup beyond its result: where the
/// configuration came from, the grade chosen, the terms asked for.
pub struct SetupSummary {
    /// Where the configuration came from.
    pub origin: String,
    /// The grade chosen from the data.
    pub grade: Option<GradeChoice>,
    /// The grade of the configuration's priors.
    pub unit_grade: UnitGrade,
    /// The terms beyond the paper's model.
    pub terms: Vec<Candidate>,
    /// What the configuration assumed ([`Setup::assumptions`]).
    pub assumptions: Vec<String>,
    /// The rests' excess, where it is weighed without `--rest-error`
    /// ([`calib::estimate::hand_turned::RestExcess::weighed_unasked`]; set by the session).
    pub rest_error_unasked: Option<calib::estimate::hand_turned::RestExcess>,
}

impl Setup {
    /// What the report keeps of it.
    pub fn summary(&self) -> SetupSummary {
        SetupSummary {
            origin: self.origin.clone(),
            grade: self.grade,
            unit_grade: self.unit_grade,
            terms: self.terms.clone(),
            assumptions: self.assumptions.clone(),
            rest_error_unasked: None,
        }
    }
}

/// What the printout, the JSON and the report say of a hand-turned run beyond the parameters,
/// computed once from its result ([`figures`]).
#[derive(Clone, Debug)]
pub struct FreeMotionFigures {
    /// Where the configuration came from.
    pub origin: String,
    /// The grade chosen from the data (without a configuration).
    pub grade: Option<GradeChoice>,
    /// The grade whose priors the model has.
    pub grade_name: &'static str,
    /// Where the noise came from, with what was measured.
    pub noise: NoiseFigures,
    /// The levels the filter used (sigma of a 1-s mean): gyro (deg/h), specific force (m/s^2).
    pub noise_gyro_deg_h: f64,
    /// See `noise_gyro_deg_h`.
    pub noise_accel_m_s2: f64,
    /// The attitude noise of a motion (deg).
    pub motion_attitude_noise_deg: f64,
    /// The error the windows of one rest share, weighed (m/s^2, `filter.rest_error_m_s2`).
    pub rest_error_m_s2: f64,
    /// The rests' excess, where it is weighed without `--rest-error`.
    pub rest_error_unasked: Option<calib::estimate::hand_turned::RestExcess>,
    /// What the fitted rests' `|f| = g` residuals scatter beyond their white noise (m/s^2;
    /// with the noise measured), and its degrees of freedom.
    pub rest_excess_m_s2: Option<(f64, f64)>,
    /// Normal gravity at the site (m/s^2).
    pub gravity_m_s2: f64,
    /// The rests as static intervals.
    pub static_intervals: usize,
    /// Every K-th rest held out.
    pub holdout: Option<usize>,
    /// The terms beyond the paper's model (ids).
    pub terms: Vec<&'static str>,
    /// The known turns before and after calibration.
    pub turns: Vec<TurnFigures>,
    /// Their measurements' mean NIS ([`calib::estimate::verdict::known_turn_figures`]).
    pub known_turns: Option<(usize, f64, f64)>,
    /// `|f| - g` RMS over the fitted rests (m/s^2) before and after, and their number.
    pub fitted_static_rms_m_s2: (f64, f64),
    /// See `fitted_static_rms_m_s2`.
    pub fitted_rests: usize,
    /// The held-out rests' figures (with a hold-out).
    pub validation: Option<ValidationFigures>,
}

/// Where the noise levels came from.
#[derive(Clone, Copy, Debug)]
pub enum NoiseFigures {
    /// The configuration's.
    Configured,
    /// Measured in the rests.
    Measured(MeasuredFigures),
}

/// The noise measured in the rests and brought to the fit's innovations.
#[derive(Clone, Copy, Debug)]
pub struct MeasuredFigures {
    /// The rests' scatter (1-s means): gyro (deg/h), specific force (m/s^2).
    pub gyro_deg_h: f64,
    /// See `gyro_deg_h`.
    pub accel_m_s2: f64,
    /// Degrees of freedom of the rests' scatter.
    pub dof: usize,
    /// The factor on the specific force's level.
    pub accel_factor: f64,
    /// The innovations' variance over the rests' own noise, its p-value, and whether it is
    /// significant.
    pub scatter_ratio: f64,
    /// See `scatter_ratio`.
    pub scatter_p_value: f64,
    /// See `scatter_ratio`.
    pub scatter_significant: bool,
    /// The motion noise measured (deg), from how many windows, in how many fits.
    pub motion_noise_deg: f64,
    /// See `motion_noise_deg`.
    pub motion_windows: usize,
    /// See `motion_noise_deg`.
    pub fits: usize,
}

/// A known turn (deg).
#[derive(Clone, Debug)]
pub struct TurnFigures {
    /// Its name in the section list.
    pub name: String,
    /// Expected, from the raw gyros, and after calibration.
    pub expected_deg: f64,
    /// See `expected_deg`.
    pub before_deg: f64,
    /// See `expected_deg`.
    pub after_deg: f64,
}

/// The held-out rests' figures ([`calib::motion::free_motion::Validation`]) in the units
/// printed.
#[derive(Clone, Copy, Debug)]
pub struct ValidationFigures {
    /// Held-out rests and pairs of consecutive ones.
    pub intervals: usize,
    /// See `intervals`.
    pub rotation_pairs: usize,
    /// Held-out `|f| - g` RMS before and after (m/s^2).
    pub static_rms_m_s2: (f64, f64),
    /// Gravity-direction RMS between held-out pairs before and after (deg).
    pub rotation_rms_deg: (f64, f64),
    /// `None`: the Earth's rotation taken out; else the floor it leaves (deg).
    pub earth_rate_floor_deg: Option<f64>,
    /// The fitted rests' `|f| - g` RMS (m/s^2) and their number.
    pub fitted_static_rms_m_s2: f64,
    /// See `fitted_static_rms_m_s2`.
    pub fitted_intervals: usize,
    /// Gravity direction over single motions into or out of held-out rests (deg), and count.
    pub held_out_motion_rms_deg: f64,
    /// See `held_out_motion_rms_deg`.
    pub held_out_motions: usize,
    /// The same between fitted rests (deg), and count.
    pub fitted_motion_rms_deg: f64,
    /// See `fitted_motion_rms_deg`.
    pub fitted_motions: usize,
    /// The least-squares `|f| = g` baseline on the same split: held-out and fitted `|f| - g`
    /// RMS (m/s^2).
    pub baseline_static_rms_m_s2: Option<(f64, f64)>,
}

/// The figures of a hand-turned run's result `r` with its `setup`, hold-out and known turns'
/// figures (`None`: the result has no evaluation of its rests).
pub fn figures(
    r: &Calibration,
    setup: &SetupSummary,
    holdout: Option<usize>,
    known_turns: Option<(usize, f64, f64)>,
) -> Option<FreeMotionFigures> {
    let evaluation = r.evaluation.as_ref()?;
    let c = &r.config;
    let fitted: Vec<_> = evaluation.poses.iter().filter(|p| !p.held_out).collect();
    let rms = |f: fn(&calib::motion::free_motion::PoseResidual) -> f64| {
        (fitted.iter().map(|p| f(p).powi(2)).sum::<f64>() / fitted.len().max(1) as f64).sqrt()
    };
    Some(FreeMotionFigures {
        origin: setup.origin.clone(),
        grade: setup.grade,
        grade_name: setup.unit_grade.name(),
        noise: noise_figures(&r.noise),
        noise_gyro_deg_h: c.noise.gyro_deg_h,
        noise_accel_m_s2: c.noise.accel_m_s2,
        motion_attitude_noise_deg: c.filter.motion_attitude_noise_deg,
        rest_error_m_s2: c.filter.rest_error_m_s2,
        rest_error_unasked: setup.rest_error_unasked,
        rest_excess_m_s2: evaluation
            .rest_excess_m_s2
            .map(|x| (x, evaluation.rest_excess_dof)),
        gravity_m_s2: r.estimate.gravity_m_s2,
        static_intervals: r.estimate.rests.len(),
        holdout,
        terms: setup.terms.iter().map(|c| c.id()).collect(),
        turns: turn_figures(evaluation),
        known_turns,
        fitted_static_rms_m_s2: (rms(|p| p.before_m_s2), rms(|p| p.after_m_s2)),
        fitted_rests: fitted.len(),
        validation: evaluation.validation.map(|v| ValidationFigures {
            intervals: v.intervals,
            rotation_pairs: v.rotation_pairs,
            static_rms_m_s2: (v.static_rms_before_m_s2, v.static_rms_after_m_s2),
            rotation_rms_deg: (
                v.rotation_rms_before_rad.to_degrees(),
                v.rotation_rms_after_rad.to_degrees(),
            ),
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
            baseline_static_rms_m_s2: evaluation
                .baseline
                .map(|b| (b.held_out_static_rms_m_s2, b.fitted_static_rms_m_s2)),
        }),
    })
}

/// The noise's source in the units printed.
fn noise_figures(noise: &NoiseSource) -> NoiseFigures {
    match *noise {
        NoiseSource::Configured => NoiseFigures::Configured,
        NoiseSource::Measured {
            at_rest,
            accel_factor,
            excess,
            motion_noise_deg,
            motion_windows,
            fits,
            ..
        } => NoiseFigures::Measured(MeasuredFigures {
            gyro_deg_h: at_rest.gyro_rad_s / DEG_PER_HOUR,
            accel_m_s2: at_rest.accel_m_s2,
            dof: at_rest.dof,
            accel_factor,
            scatter_ratio: excess.ratio,
            scatter_p_value: excess.p_value,
            scatter_significant: excess.significant(),
            motion_noise_deg,
            motion_windows,
            fits,
        }),
    }
}

/// The known turns in degrees.
fn turn_figures(e: &Evaluation) -> Vec<TurnFigures> {
    e.turns
        .iter()
        .map(|t| TurnFigures {
            name: t.name.clone(),
            expected_deg: t.expected_rad.to_degrees(),
            before_deg: t.before_rad.to_degrees(),
            after_deg: t.after_rad.to_degrees(),
        })
        .collect()
}
