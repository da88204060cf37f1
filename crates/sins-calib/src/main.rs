//! `sins-calib`: the command-line program of the toolkit.
//!
//! - `simulate`: a simulated run (IMU and turntable records, true values) from a run configuration;
//! - `calibrate`: estimate the instrument errors from recorded data, with a report in the paper's
//!   units, fit statistics and, against a truth file, the errors in sigmas;
//! - `analyse`: covariance analysis of a run configuration, without data;
//! - `import`: a recording in another layout turned into `imu.csv` by an import profile;
//! - `segment`: an `imu.csv` split into static intervals and motion;
//! - `noise`: the sensors' noise from data at rest (maximum-likelihood levels, Allan deviation,
//!   fitted noise terms);
//! - `diagnose`: what the model gets wrong, and the terms that fix it (model-extension loop);
//! - `design`: a program that separates candidate terms;
//! - `apply`: raw IMU records corrected with a calibration result;
//! - `export`: noise levels and a calibration written for Kalibr, OpenVINS or imu_tk.
//!
//! The work is done by the `calib` library; this crate only reads arguments, reports and exits.
//! File formats: `docs/formats.md`.

// No unsafe code: the interrupting signals come through `signal-hook` (`signals`).
#![forbid(unsafe_code)]

// Messages to the standard error and output, written without panicking. The standard macros
// panic when the write fails ("failed printing to stderr": `2>/dev/full`, a reader that has
// gone), which turned every refusal into exit status 101 and stopped a finished run before its
// files were written. These shadows, defined before the `mod` lines, are the ones every module
// below uses. A message that cannot be written is dropped: the exit status still says what
// happened, and the files of a finished run are still written. The report itself goes through
// [`print`], where a failed write is an error (the exit status must say the report is lost).
macro_rules! eprintln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}
macro_rules! eprint {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($arg)*);
    }};
}

mod args;
mod commands;
mod free_motion;
mod navigation;
mod output;
mod plots;
mod provenance;
mod recording_checks;
mod render;
mod session;
mod signals;

use commands::{
    analyse, apply, calibrate, design, diagnose, export, import, noise, segment, simulate,
};

use calib::config::RunConfig;
use clap::{Parser, Subcommand};
use std::io::Write as _;
use std::process::ExitCode;

/// Errors end the program with their message (which names file and line where there is one).
pub type Error = Box<dyn std::error::Error>;

/// Calibration of strapdown inertial systems on turntables (after Vavilova, Golovan, Parusnikov,
/// Vasineva).
///
/// Simulate a calibration run, calibrate an IMU from recorded data, or analyse how well a rotation
/// program calibrates before booking the turntable. File formats: docs/formats.md. Values in files
/// are SI; reports are in the paper's units (deg/h, arcmin, m/s^2).
///
/// Exit status: 0 success; 1 refused input or another error (the message names the file, line
/// or option); 2 a malformed command line; 3 (calibrate, diagnose) the model does not fit the
/// data: the results were computed and written, but are not to be trusted; 128 + the signal's
/// number when interrupted (SIGINT 130, SIGTERM 143), with no temporary output left behind.
/// A standard error that cannot be written (full, or its reader gone) changes no status; a
/// report that cannot be written to the standard output ends with status 1 after the run's
/// output files are written (they are kept).
#[derive(Debug, Parser)]
#[command(name = "sins-calib", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a run: write DIR/imu.csv, DIR/turntable.csv and DIR/truth.json.
    ///
    /// The configuration's `[truth]` section sets the seed, the record rates, the duration and the
    /// true values; `[noise]` the sensor noises; `[clock]` the turntable clock against the IMU clock.
    Simulate(simulate::Args),
    /// Calibrate from recorded data and print the estimates in the paper's units.
    ///
    /// Without --turntable the 24-state model runs on the IMU data alone (attitude error, gyro
    /// biases, gyro matrix Theta, accelerometer biases, lower-triangular accelerometer matrix
    /// Gamma); with it the 28-state model adds the installation misalignment of the instrument on
    /// the platform and the delay of the turntable data (and the base misalignment when the
    /// configuration's filter.estimate_base_misalignment is true). With --free-motion a
    /// hand-turned multi-position recording is calibrated without program or turntable.
    Calibrate(args::CalibrateArgs),
    /// Covariance analysis: the prior and posterior sigma of every parameter, without data.
    ///
    /// Runs the configuration's filter along the ideal motion of its rotation program and
    /// reports what a calibration with that program, noise and priors can achieve.
    Analyse(analyse::Args),
    /// Import a recording in another layout: write DIR/imu.csv (and turntable.csv, sections.json
    /// where the source has angles or a section list) and DIR/import.json.
    ///
    /// An import profile (TOML) says which files, columns, time base, units, axes and ranges the
    /// recording has; or --bag and --topic read the sensor_msgs/Imu messages of a ROS 1 bag or
    /// an MCAP file. Time stamps keep their jitter; gaps are refused (or kept with
    /// --allow-gaps), saturated samples counted, a specific force at rest nowhere near g refused.
    Import(import::Args),
    /// Split an imu.csv into static intervals and motion, and print the static intervals.
    ///
    /// A record is static when, over a window centred on it, the standard deviations of the
    /// specific force and of the rate and the magnitude of the mean rate are below thresholds;
    /// runs of static records at least --rest-min-duration long are the static intervals.
    Segment(segment::Args),
    /// The sensors' noise from data at rest: the white level and bias walk of every gyro and
    /// accelerometer axis by maximum likelihood with 68 % profile intervals, the overlapping
    /// Allan deviation with confidence intervals, the noise terms fitted to it (quantisation,
    /// white noise, bias instability, bias random walk, rate ramp) with their uncertainties, and
    /// a `[noise]` block to paste (docs/noise.md).
    ///
    /// Uses the static intervals the detector finds (as `segment`), each less a detector window
    /// at an end next to motion, or the whole recording with --all-at-rest; the longest interval
    /// bounds the longest averaging time.
    Noise(noise::Args),
    /// Find what the paper's model gets wrong: fit it, test every candidate error term against
    /// the innovations, add the best-supported one the program can separate, measure the gain,
    /// and repeat while it is significant (docs/model-extension.md).
    ///
    /// Exit status: 0 when the final model fits the data by the rule of `calibrate` (its mean
    /// NIS and the tests of its innovations; with the noise measured from a hand-turned
    /// recording, its held-out rests), 3 when it does not or when the held-out check refused a
    /// term the data call for (with or without accepted terms: the misfit is then one no
    /// candidate explains), 1 for refused input or another error, 2 for a malformed command
    /// line.
    Diagnose(args::DiagnoseArgs),
    /// Propose a rotation program that separates the given candidate terms from the paper's
    /// parameters, printed as TOML with its predicted sigmas.
    Design(design::Args),
    /// Correct raw IMU records with a calibration result: the estimated model inverted record
    /// by record (every estimated extension term included), written in the same form.
    ///
    /// Rates or increments, time stamps and an optional temp column are kept. The result's
    /// parameters say which terms to invert; unknown or incomplete ones are refused. The
    /// formulas: docs/formats.md, "Correction".
    Apply(apply::Args),
    /// Write noise levels (`noise --json`) and a calibration (`calibrate --json`) in the files
    /// of Kalibr (imu.yaml), OpenVINS (kalibr_imu_chain.yaml) or imu_tk (*_acc.calib,
    /// *_gyro.calib).
    ///
    /// The same linear correction as `apply`, factored into each tool's matrices; terms a format
    /// cannot hold are refused unless --drop-terms. The conventions: docs/formats.md, "Files
    /// written by `export`".
    Export(export::Args),
}

/// Read a run configuration by name (`paper`, `paper-reconciled`) or path; returns it with the
/// name to use for it in messages.
pub fn load_config(name: &str) -> Result<(RunConfig, String), Error> {
    let config = calib::paper::named_or_file(name)?;
    let origin = match name {
        "paper" | "paper-reconciled" => format!("<embedded {name} config>"),
        path => path.to_string(),
    };
    Ok((config, origin))
}

/// Write the human report: to stdout, or to stderr when the JSON goes to stdout (`--json -`).
pub fn report(text: &str, json: Option<&std::path::Path>) -> Result<(), Error> {
    if json.is_some_and(output::is_stdout) {
        eprint!("{text}");
        Ok(())
    } else {
        print(text)
    }
}

/// Write a report to stdout; a closed pipe (e.g. `| head`) is not an error. Every command
/// prints its report after its files are written, so a failure here (a full disk behind
/// `> file`, `>/dev/full`) ends with status 1 and the files kept, which the message says.
pub fn print(text: &str) -> Result<(), Error> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(format!(
            "cannot write the report to standard output: {e}: the report is lost (any output \
             file this run wrote is complete and kept)"
        )
        .into()),
        _ => Ok(()),
    }
}

/// Exit status of a calibration whose model does not fit the data (the verdict's reasons: a
/// mean NIS outside its band, a failing test of the innovations, held-out rests that
/// contradict it): the estimates were computed and reported, but are not to be trusted. 1 is refused
/// input or another error, 2 a malformed command line.
pub const MODEL_DOES_NOT_FIT: u8 = 3;

fn main() -> ExitCode {
    signals::install();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(args) => simulate::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Calibrate(args) => calibrate::run(&args).map(ExitCode::from),
        Command::Analyse(args) => analyse::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Import(args) => import::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Segment(args) => segment::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Noise(args) => noise::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Diagnose(args) => diagnose::run(&args).map(ExitCode::from),
        Command::Design(args) => design::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Apply(args) => apply::run(&args).map(|()| ExitCode::SUCCESS),
        Command::Export(args) => export::run(&args).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", readable(&e.to_string()));
            ExitCode::FAILURE
        }
    }
}

/// The longest line of an error message shown (characters).
const MESSAGE_LINE_MAX: usize = 1000;
/// The most lines of an error message shown.
const MESSAGE_LINES_MAX: usize = 40;

/// An error message capped at a readable length: a parser's excerpt of a hostile input (a
/// configuration nested 100 000 deep, a 300 000-entry array on one line) echoed that input
/// whole, hundreds of kilobytes. Each line keeps its start (the file, line and field come
/// first) and end (the cause the parser names last); the lines keep the first and last ones.
fn readable(message: &str) -> String {
    let cap_line = |l: &str| -> String {
        let n = l.chars().count();
        if n <= MESSAGE_LINE_MAX {
            return l.to_string();
        }
        let head: String = l.chars().take(MESSAGE_LINE_MAX - 200).collect();
        let tail: String = l.chars().skip(n - 150).collect();
        format!(
            "{head} ... ({} characters left out) ... {tail}",
            n - (MESSAGE_LINE_MAX - 200) - 150
        )
    };
    let lines: Vec<&str> = message.lines().collect();
    let shown: Vec<String> = if lines.len() <= MESSAGE_LINES_MAX {
        lines.iter().map(|l| cap_line(l)).collect()
    } else {
        let (head, tail) = (MESSAGE_LINES_MAX - 10, 10);
        let mut v: Vec<String> = lines[..head].iter().map(|l| cap_line(l)).collect();
        v.push(format!(
            "... ({} lines left out) ...",
            lines.len() - head - tail
        ));
        v.extend(lines[lines.len() - tail..].iter().map(|l| cap_line(l)));
        v
    };
    shown.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn messages_are_capped_keeping_their_ends() {
        let long = format!("p.toml: line 2: {} expected 3", "[".repeat(300_000));
        let shown = readable(&long);
        assert!(shown.len() < 2 * MESSAGE_LINE_MAX, "{}", shown.len());
        assert!(shown.starts_with("p.toml: line 2: "), "{shown}");
        assert!(shown.ends_with("expected 3"), "{shown}");
        let many: String = (0..100_000).map(|k| format!("line {k}\n")).collect();
        let shown = readable(&many);
        assert_eq!(shown.lines().count(), MESSAGE_LINES_MAX + 1);
        assert!(shown.contains("line 99999"), "{shown}");
        // A short message is unchanged.
        assert_eq!(readable("a: b\nc"), "a: b\nc");
    }
}
