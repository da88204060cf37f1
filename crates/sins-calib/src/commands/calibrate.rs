//! `sins-calib calibrate`: estimation from recorded data, with a report in the paper's units.

use crate::Error;
use crate::plots::innovation_diagnostics::write_diagnostics_dir;
use crate::render::calibrate_figures::RunReport;
use crate::render::console::Written;
use crate::session::{Calibrate, Records, Session};
use calib::estimate::ImuSource as _;
use calib::estimate::calibration::Calibration;
use calib::estimate::{HandTurnedRun, Plan, ProgramOptions, RunKind};
use calib::io::angle_records::AngleFile;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal as _;

/// IMU records above which a progress bar is shown (about a second of work).
const PROGRESS_ABOVE_RECORDS: usize = 100_000;

fn progress_bar(records: usize) -> ProgressBar {
    if records <= PROGRESS_ABOVE_RECORDS || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    // The bar shows the fraction of a fit's work in per mille (`FitProgress`): the library's
    // record totals change within a fit, so records read would move the bar back.
    let bar = ProgressBar::with_draw_target(Some(BAR_STEPS), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(
        "calibrating, {msg} [{bar:30}] {percent:>3} % of its most passes (fewer when it \
         converges), {elapsed} elapsed",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message("fit 1");
    bar
}

/// The bar's length: a fit's work in per mille.
const BAR_STEPS: u64 = 1000;

/// The library's `(done, total)` reports turned into a bar that never moves back within a
/// fit. `total` is an upper bound that changes within a fit (the first read of the records
/// reports against a guess from the file's size, the passes against their most passes), and
/// a recording of rests whose noise is measured is fitted more than once, each fit reporting
/// from zero again: a report below the previous one starts the next fit.
#[derive(Debug, Default)]
struct FitProgress {
    /// The fit being run, from 1.
    fit: usize,
    last_done: usize,
    /// The largest fraction of the fit's work reported so far.
    fraction: f64,
}

impl FitProgress {
    /// The fit and the fraction of its work done after the report `(done, total)`.
    fn advance(&mut self, done: usize, total: usize) -> (usize, f64) {
        if self.fit == 0 || done < self.last_done {
            self.fit += 1;
            self.fraction = 0.0;
        }
        self.last_done = done;
        if total > 0 {
            self.fraction = self.fraction.max((done as f64 / total as f64).min(1.0));
        }
        (self.fit, self.fraction)
    }
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
        &crate::render::console::render(&report, &written),
        session.json.as_deref(),
    )?;
    if !report.verdict.fits() {
        eprintln!(
            "{}",
            crate::render::console::misfit_message(&report.verdict)
        );
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
    let mut shown = FitProgress::default();
    let mut progress = |done: usize, total: usize| {
        let fit_before = shown.fit;
        let (fit, fraction) = shown.advance(done, total);
        if fit != fit_before && fit > 1 {
            bar.set_message(format!(
                "fit {fit}, with the noise levels the fit before measured"
            ));
        }
        bar.set_position((fraction * BAR_STEPS as f64).round() as u64);
    };
    let (Records::Streamed(imu), rests) = (&mut s.records, &s.rests) else {
        unreachable!("calibrate streams its records")
    };
    let (kind, turntable) = match rests {
        Some(found) => {
            let free_motion = found.free_motion.as_ref();
            let run = HandTurnedRun {
                rests: &found.rests,
                turns: free_motion.map_or(&[], |f| &f.turns),
                holdout: s.holdout,
                measured: free_motion.and_then(|f| f.measured),
            };
            (RunKind::HandTurned(run), None)
        }
        None => (
            RunKind::Programmed(ProgramOptions::CALIBRATE),
            s.turntable.as_ref().map(AngleFile::records),
        ),
    };
    let plan = Plan {
        config: &s.config,
        layout: Some(&s.task.layout),
        kind,
    };
    let records = calib::estimate::Records::Streamed {
        imu: &mut **imu,
        turntable,
    };
    let calibration = calib::estimate::run(plan, records, &mut progress)?;
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
        crate::render::result_json::write(path, r)?;
        if !crate::output::is_stdout(path) {
            written.json = Some(path.clone());
        }
    }
    if let (Some(path), Some(e)) = (&s.task.plot, &fit.evaluation) {
        crate::output::write_with(path, |tmp| {
            crate::plots::static_residuals_png(tmp, &s.imu_file, &e.poses)
        })?;
        written.plot = Some(path.clone());
    }
    if let (Some(dir), Some(lab)) = (&s.report, &r.lab) {
        let report = crate::render::lab_report::Report {
            title: "Calibration report",
            id: &lab.id,
            verdict: &r.verdict,
            mean_nis: &r.fit.mean_nis,
            hand_turned: r.free_motion.as_ref(),
            parameters: &r.parameters,
            unobserved: &r.fit.unobserved,
            truth: r.truth.as_ref().map(crate::render::console::truth),
            correlation: &lab.correlation,
            strongest: &lab.strongest,
            segments: &lab.segments,
            fit: crate::render::lab_report::FitView {
                est: &fit.estimate,
                diagnostics: &fit.diagnostics,
            },
            base: None,
            extension: None,
            navigation: Some(&r.navigation),
            correction: r.result.correction.as_ref(),
        };
        let plots = crate::render::lab_report::write(dir, &report)?;
        written.report = Some((dir.clone(), plots));
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::FitProgress;

    #[test]
    fn progress_never_moves_back_within_a_fit_and_a_restart_starts_the_next_fit() {
        let mut p = FitProgress::default();
        // The first read against a guessed total, then the passes against a larger one.
        assert_eq!(p.advance(4096, 30_000), (1, 4096.0 / 30_000.0));
        let (fit, f) = p.advance(8192, 30_000);
        assert_eq!(fit, 1);
        let (fit, g) = p.advance(10_000 + 100, 50_000);
        assert_eq!(fit, 1);
        assert_eq!(g, f, "a larger total must not move the bar back");
        let (_, h) = p.advance(30_000, 50_000);
        assert!((h - 0.6).abs() < 1e-12);
        // The fit converged early: its last report is total of total.
        assert_eq!(p.advance(50_000, 50_000), (1, 1.0));
        // A second fit reports from zero again.
        assert_eq!(p.advance(4096, 40_960), (2, 0.1));
        assert_eq!(p.advance(4096, 0), (2, 0.1));
    }
}
