//! `sins-calib calibrate`: estimation from recorded data, with a report in the paper's units.

use crate::Error;
use crate::console::Written;
use crate::diagnostic_plots::write_diagnostics_dir;
use crate::run_report::RunReport;
use crate::session::{Calibrate, Records, Session};
use calib::estimate::ImuSource as _;
use calib::estimate::calibration::{Calibration, calibrate_program};
use calib::io::angle_records::AngleFile;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal as _;

/// IMU records above which a progress bar is shown (about a second of work).
const PROGRESS_ABOVE_RECORDS: usize = 100_000;

fn progress_bar(records: usize) -> ProgressBar {
    if records <= PROGRESS_ABOVE_RECORDS || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    // The length is set from the library's (done, total) reports.
    let bar = ProgressBar::with_draw_target(Some(records as u64), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(
        "calibrating [{bar:30}] {human_pos}/{human_len} IMU records read over all passes \
         ({percent:>3} %), {elapsed} elapsed, about {eta} left",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// Run `calibrate` with a program, turntable angles, or on a recording of rests (with
/// `--free-motion`, a hand-turned one): resolve the command line, fit, build the report once,
/// write and print it; returns the exit status (3: the data contradict the model).
pub fn run(args: &crate::args::CalibrateArgs) -> Result<u8, Error> {
    let flight = crate::navigation::Flight::load(&args.flight)?;
    let mut session = crate::session::calibrate(args)?;
    let fit = fit(&mut session)?;
    let report = RunReport::build(&session, &fit, &flight)?;
    let estimated = report.result.parameters.iter();
    check_physical(
        estimated.map(|p| (p.name.as_str(), p.value)),
        &session.imu_file,
    )?;
    let written = write_outputs(&session, &fit, &report)?;
    crate::report(
        &crate::console::render(&report, &written),
        session.json.as_deref(),
    )?;
    if !report.verdict.fits() {
        eprintln!("{}", crate::console::misfit_message(&report.verdict));
    }
    Ok(report.verdict.exit_status())
}

/// Refuse an estimate beyond the physical bounds `apply` holds a result to
/// (`calib::config::plausible`), before anything is written: a scale factor of 100 % is a
/// diverged fit (two axes swapped, a left-handed axis map, records in other units), which
/// `apply` would refuse only later; the exit status must say so now.
pub fn check_physical<'a>(
    parameters: impl IntoIterator<Item = (&'a str, f64)>,
    imu_file: &str,
) -> Result<(), Error> {
    for (name, value) in parameters {
        if let Err(message) = calib::config::plausible::check(name, value) {
            return Err(format!(
                "the fit of {imu_file} diverged: {message}; nothing is written. Check the \
                 records' axes (two swapped, or a left-handed axis map in the import profile), \
                 their units and the configuration's priors"
            )
            .into());
        }
    }
    Ok(())
}

/// [`check_physical`] of an estimate's states (the attitude errors have no bound): `diagnose`'s
/// final model, refused before its result is written.
pub fn check_estimate(estimate: &calib::estimate::Estimate, imu_file: &str) -> Result<(), Error> {
    let states = estimate.names.iter().map(String::as_str);
    check_physical(states.zip(estimate.values.iter().copied()), imu_file)
}

/// The filter on the session's data: along the program (and the angles), or through the
/// rests of a recording without one; the calibration comes with the tests of its innovations
/// and its verdict (run whatever the outputs: the verdict rests on them).
fn fit(s: &mut Session<Calibrate>) -> Result<Calibration, Error> {
    let records = match &s.records {
        Records::Streamed(imu) => imu.len_hint().unwrap_or(0),
        Records::Held(data) => data.records.len(),
    };
    let bar = progress_bar(records);
    let mut progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let calibration = match (&mut s.records, &s.rests) {
        (Records::Streamed(imu), Some(found)) => {
            let free_motion = found.free_motion.as_ref();
            calib::estimate::hand_turned::calibrate(
                &s.config,
                &s.task.layout,
                &mut **imu,
                &found.rests,
                free_motion.map_or(&[], |f| &f.turns),
                s.holdout,
                free_motion.and_then(|f| f.measured),
                &mut progress,
            )?
        }
        (Records::Streamed(imu), None) => {
            let turntable = s.turntable.as_ref().map(AngleFile::records);
            calibrate_program(
                &s.config,
                &s.task.layout,
                &mut **imu,
                turntable,
                &mut progress,
            )?
        }
        (Records::Held(_), _) => unreachable!("calibrate streams its records"),
    };
    bar.finish_and_clear();
    Ok(calibration)
}

/// Write the outputs asked for (diagnostic plots, JSON, plot, report), each a rendering of
/// the one report `r`; returns what was written, for the printout.
fn write_outputs(
    s: &Session<Calibrate>,
    fit: &Calibration,
    r: &RunReport,
) -> Result<Written, Error> {
    let mut written = Written::default();
    if let Some(dir) = &s.task.diagnostics {
        let plots = write_diagnostics_dir(dir, &fit.diagnostics, &fit.estimate.innovations)?;
        written.diagnostics = Some((dir.clone(), plots));
    }
    if let Some(path) = &s.json {
        crate::result_json::write(path, r)?;
        if !crate::output::is_stdout(path) {
            written.json = Some(path.clone());
        }
    }
    if let (Some(path), Some(e)) = (&s.task.plot, &fit.evaluation) {
        crate::output::write_with(path, |tmp| {
            crate::plot::static_residuals_png(tmp, &s.imu_file, &e.poses)
        })?;
        written.plot = Some(path.clone());
    }
    if let (Some(dir), Some(lab)) = (&s.report, &r.lab) {
        let report = crate::lab_report::Report {
            title: "Calibration report",
            id: &lab.id,
            verdict: &r.verdict,
            mean_nis: &r.fit.mean_nis,
            hand_turned: r.free_motion.as_ref(),
            parameters: &r.parameters,
            unobserved: &r.fit.unobserved,
            truth: r.truth.as_ref().map(crate::console::truth),
            correlation: &lab.correlation,
            strongest: &lab.strongest,
            segments: &lab.segments,
            fit: crate::lab_report::FitView {
                est: &fit.estimate,
                diagnostics: &fit.diagnostics,
            },
            base: None,
            extension: None,
            navigation: Some(&r.navigation),
            correction: r.result.correction.as_ref(),
        };
        let plots = crate::lab_report::write(dir, &report)?;
        written.report = Some((dir.clone(), plots));
    }
    Ok(written)
}
