//! A fit along a turntable program: the program located on the IMU clock, then the passes.

use super::pass::Feedback;
use super::passes::iterate_passes;
use super::scan::{Spacing, scan_imu};
use super::start_point::first_linearisation_point;
use super::{
    Estimate, EstimateError, ImuSource, MemoryImu, Motion, PassInputs, ProgramOptions, RunData,
    Scan, SitePriors, TurntableSetup, score_pass,
};

use crate::check::diagnostics::DiagnosticSettings;
use crate::config::RunConfig;
use crate::estimate::calibration::Calibration;
use crate::estimate::data_checks::{check_gyros_alive, check_specific_force};
use crate::estimate::noise::NoiseSource;
use crate::io::angle_records::AngleRecords;
use crate::model::extension::ModelExtension;
use crate::model::layout::{StateLayout, layout_with};
use crate::motion::program_start::{
    ProgramStart, ProgramStartError, check_program_start, find_program_start,
};

/// A programmed run ([`super::RunKind::Programmed`]): the fit of [`fit_program`] with the
/// options' extra work (the score tests' pass, the thermal terms carried), its innovations
/// tested with the default settings, and its verdict.
pub(super) fn calibrate(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    turntable: Option<AngleRecords>,
    options: ProgramOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Calibration, EstimateError> {
    let mut config = config.clone();
    let given = (config.filter.score_terms, config.filter.carry_thermal);
    config.filter.score_terms |= options.score_terms;
    config.filter.carry_thermal |= options.carry_thermal;
    let records = ProgramRecords {
        imu,
        turntable,
        program: &mut None,
        warm: None,
    };
    let estimate = fit_program(&config, layout, records, progress)?;
    // The options are the run's, not the configuration's: it is kept as given.
    (config.filter.score_terms, config.filter.carry_thermal) = given;
    Ok(Calibration::new(
        estimate,
        config,
        NoiseSource::Configured,
        None,
        &DiagnosticSettings::default(),
    ))
}

/// A fit of held records with the paper's model extended by `ext`
/// ([`crate::model::layout::layout_with`]: the extra terms' parameters are states after the
/// paper's, a gyro drift is process noise on the gyro biases), the program kept in `program`
/// for the next fit ([`fit_program`]): the model-extension loop's fits. With an empty
/// extension this is the fit of the paper's model, bit for bit.
pub(crate) fn fit_extended(
    config: &RunConfig,
    data: RunData,
    ext: &ModelExtension,
    program: &mut Option<turntable::program::Program>,
    warm: Option<&Estimate>,
) -> Result<Estimate, EstimateError> {
    let layout = layout_with(config, data.turntable.is_some(), ext);
    let mut imu = MemoryImu::new(data.imu, data.imu_file);
    let records = ProgramRecords {
        imu: &mut imu,
        turntable: data.turntable,
        program,
        warm,
    };
    fit_program(config, &layout, records, &mut |_, _| {})
}

/// What [`fit_program`] fits: the IMU records and turntable angles, the program if compiled
/// already, and where to start.
pub(super) struct ProgramRecords<'p, 'a> {
    pub(super) imu: &'p mut dyn ImuSource,
    pub(super) turntable: Option<AngleRecords<'a>>,
    pub(super) program: &'p mut Option<turntable::program::Program>,
    /// A fit of a model with the same states on the same records (another noise model): its
    /// converged estimates are the first linearisation point, and a pass that moves nothing
    /// from them is the last (`None`: from the prior, the first pass closed loop).
    pub(super) warm: Option<&'p Estimate>,
}

/// Calibrate along a program from any IMU source (e.g. a file read record by record, again for
/// every pass) and the turntable records, with the state layout `layout`.
///
/// The first pass feeds every estimate back as it goes (closed loop) and starts from the prior
/// means; its linearisation errors are products of the current errors, which are large at
/// first: an unobservable 1-degree heading error times a 1e-3 scale-factor error puts 5 sigma
/// of bias into the IMU-only accelerometer matrix. The passes after it linearise about the one
/// before (the increments are compensated with its estimates, the turntable angles read with
/// its delay and installation) and keep the same prior, so only the attitude is fed back and
/// the parameter errors stay in the filter state.
///
/// The program is kept in `program` for fits of the same configuration
/// (the model-extension loop's): used when there, else compiled (after the records are read,
/// so that the errors come in the same order) and left there. Only the noise, the model and
/// the held-out segments may differ between the configurations of the fits that share it: a
/// program that `config` reads from the angle records must have been resolved into it.
pub(super) fn fit_program(
    config: &RunConfig,
    layout: &StateLayout,
    records: ProgramRecords,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let ProgramRecords {
        imu,
        turntable,
        program,
        warm,
    } = records;
    let mut scan = scan_imu(imu, config.filter.imu_rate_hz, Spacing::Fixed, progress)?;
    let imu_start = scan.span.0 - 1.0 / config.filter.imu_rate_hz;
    let resolved =
        crate::motion::angles_program::resolve_program(config, turntable, Some(imu_start))?;
    let config = resolved.as_ref().unwrap_or(config);
    let program = match program {
        Some(p) => p.clone(),
        None => program.insert(config.program()?).clone(),
    };
    let plan = SitePriors::of(config);
    let turns = program.pieces().iter().any(|p| p.rate != [0.0; 3]);
    check_gyros_alive(&scan.bins, turns, imu.file())?;
    check_specific_force(&scan.bins, plan.gravity_m_s2, imu.file())?;
    locate_program(config, &plan, &mut scan, &program, imu.file())?;
    let span = scan.temperature.as_ref().map(|t| t.max - t.min);
    let thermal = config
        .filter
        .carry_thermal
        .then(|| score_pass::with_thermal_biases(config, layout, span))
        .flatten();
    let (layout, carried) = thermal
        .as_ref()
        .map_or((layout, Vec::new()), |(l, c)| (l, c.clone()));
    let tt_setup = match (layout.install.is_some(), turntable) {
        (true, Some(tt)) => Some(TurntableSetup::new(config, tt, &scan, &program)?),
        _ => None,
    };
    let motion = Motion::Program(program);
    let warm = warm
        .filter(|_| carried.is_empty())
        .and_then(|w| w.warm_start(layout));
    let is_warm = warm.is_some();
    let first = warm.or_else(|| first_linearisation_point(config, &plan, layout, &scan, &motion));
    let inp = PassInputs {
        config,
        plan: &plan,
        layout,
        turntable: tt_setup.as_ref(),
        scan: &scan,
        motion: &motion,
    };
    let feedback = first_pass_feedback(config);
    let mut estimate = iterate_passes(&inp, imu, first, feedback, is_warm, None, progress)?;
    estimate.carried_terms = carried;
    Ok(estimate)
}

/// What the first pass from the prior feeds back: everything (closed loop), except in a fit
/// with held-out measurements, where only the attitude is. A held-out stretch leaves the
/// attitude unaided for a whole segment; closed loop, the first update after it moved the
/// parameters by what the stretch's drift had built up and fed that back (a run hiding a
/// g-sensitivity the model lacked diverged: specific-force innovations of 10 m/s^2).
pub(super) fn first_pass_feedback(config: &RunConfig) -> Feedback {
    match config.filter.hold_out_every {
        Some(_) => Feedback::Attitude,
        None => Feedback::All,
    }
}

/// Find (or check) where the program starts on the IMU clock. A program that never turns has
/// no start to find: it is taken to start with the data.
pub(super) fn locate_program(
    config: &RunConfig,
    plan: &SitePriors,
    scan: &mut Scan,
    program: &turntable::program::Program,
    file: &str,
) -> Result<(), EstimateError> {
    let site = plan.site;
    let dt = 1.0 / config.filter.imu_rate_hz;
    let refuse = |source| EstimateError::ProgramStart {
        file: file.to_string(),
        source,
    };
    let found = match config.filter.program_start_s {
        // A start a millisecond off already shows in the fit (mean NIS 4.5 for 4 ms on the
        // paper's program): the data must put the rate changes within a tenth of a step.
        Some(t) => check_program_start(&scan.bins, program, &site, t, 0.1 * dt).map_err(refuse)?,
        None => match find_program_start(&scan.bins, program, &site) {
            Err(ProgramStartError::NoRotation) => ProgramStart {
                t_imu_s: scan.span.0 - dt,
                rms_misfit: 0.0,
            },
            // A recording of part of a program is taken to start with it, and checked.
            Err(ProgramStartError::TooShort { .. }) => {
                check_program_start(&scan.bins, program, &site, scan.span.0 - dt, 0.1 * dt)
                    .map_err(refuse)?
            }
            other => other.map_err(refuse)?,
        },
    };
    scan.program_start = found.t_imu_s;
    scan.program_start_found = config.filter.program_start_s.is_none();
    Ok(())
}
