//! What a `calibrate` run reports, computed once ([`RunReport::build`]) from its session and
//! its fit: every figure the outputs print (the run's setup, the parameters with their sigmas
//! and units, the fit checks, the held-out figures, the truth, the diagnostics, the verdict and
//! its reasons, the assumptions and the provenance). The printout (`crate::render::console`), the JSON
//! result (`crate::render::result_json`) and the laboratory report (`crate::render::lab_report`) each render
//! this one value, so that they cannot disagree.

use crate::Error;
use crate::free_motion::FreeMotionFigures;
use crate::provenance::RunProvenance;
use crate::provenance::identification::Identification;
use crate::session::{Calibrate, ConfigSource, Session};
use calib::check::diagnostics::Diagnostics;
use calib::estimate::Estimate;
use calib::estimate::calibration::Calibration;
use calib::estimate::verdict::{MeanNis, RunVerdict};
use calib::io::{ImuKind, ResultFile, ResultTemperature};
use calib::report::lab::{self, ParameterRow, SegmentRow, TruthComparison};
use std::path::PathBuf;

/// Everything a `calibrate` run reports.
pub struct RunReport {
    /// The configuration, data, model and start of the run.
    pub header: Header,
    /// A hand-turned recording (`--free-motion`): its noise, model, turns and held-out rests.
    pub free_motion: Option<FreeMotionFigures>,
    /// The unit, the inputs' SHA-256 and notes on them.
    pub provenance: RunProvenance,
    /// What the run assumed for want of an input.
    pub assumptions: Vec<String>,
    /// The candidate terms added to the paper's model (ids).
    pub terms: Vec<&'static str>,
    /// The parameters in their report units, with a truth's values.
    pub parameters: Vec<ParameterRow>,
    /// The parameters in SI with their correlation, the correction and the temperature (the
    /// result file's).
    pub result: ResultFile,
    /// The fit's checks and counts.
    pub fit: FitFigures,
    /// Against a truth (`--truth`).
    pub truth: Option<TruthFigures>,
    /// The tests of the innovations.
    pub diagnostics: Diagnostics,
    /// The verdict.
    pub verdict: Verdict,
    /// What only the laboratory report shows (`--report`).
    pub lab: Option<LabFigures>,
    /// What the calibration buys in navigation (docs/navsim.md).
    pub navigation: crate::navigation::Navigation,
}

/// The head of the printout: configuration, data, model, program start or rests.
pub struct Header {
    /// The configuration line.
    pub configuration: Configuration,
    /// The IMU file as named in messages.
    pub imu_file: String,
    /// Records integrated.
    pub imu_records: usize,
    /// Increments or rates.
    pub imu_kind: ImuKind,
    /// First and last time stamp (s).
    pub imu_span: (f64, f64),
    /// The records' temperatures and the thermal terms' reference.
    pub temperature: Option<ResultTemperature>,
    /// The turntable's angle records.
    pub turntable: Option<TurntableSpan>,
    /// States of the model.
    pub states: usize,
    /// Where the program starts, or the rests and the start attitude.
    pub start: Start,
    /// The detector's report of rests it may have missed.
    pub missed_rests: Vec<String>,
}

/// Where the configuration came from and the program it has.
pub enum Configuration {
    /// A configuration with a program (declared or from the angles): origin, name, duration.
    Program(String, String, f64),
    /// `--free-motion` without a configuration.
    MadeFromRecording,
    /// A configuration without a program (a recording of rests): its origin.
    Rests(String),
}

/// The turntable's angle records.
pub struct TurntableSpan {
    /// The file.
    pub file: String,
    /// Records.
    pub count: usize,
    /// First and last stamp on the turntable clock and on the IMU clock (s).
    pub span: (f64, f64),
    /// See `span`.
    pub imu_span: (f64, f64),
}

/// Where the program starts, or how a recording of rests begins.
pub enum Start {
    /// The program's start on the IMU clock (s), and whether it was found from the data.
    Program(f64, bool),
    /// A recording of rests.
    Rests(RestsStart),
}

/// The rests of a recording without a program and its start attitude.
pub struct RestsStart {
    /// Rests found, and their time in all (s).
    pub count: usize,
    /// See `count`.
    pub at_rest_s: f64,
    /// Specific-force windows with motion left out.
    pub windows_in_motion: usize,
    /// Whether the heading was gyrocompassed, and the sigma the gyro priors allow (deg).
    pub gyrocompassed: bool,
    /// See `gyrocompassed`.
    pub gyrocompass_sigma_deg: f64,
}

/// The fit's checks and counts.
pub struct FitFigures {
    /// States of the model.
    pub states: usize,
    /// IMU records integrated.
    pub imu_records: usize,
    /// IMU time of the final estimate (s).
    pub final_time_s: f64,
    /// The mean NIS of each measurement against its band.
    pub mean_nis: Vec<MeanNis>,
    /// The turntable samples used (with the angles).
    pub turntable: Option<TurntableSamples>,
    /// Known turns measured: updates, mean NIS, half-width of its band about 1.
    pub known_turns: Option<(usize, f64, f64)>,
    /// Parameters the data leave at their prior, with their posterior over prior sigma.
    pub unobserved: Vec<(String, f64)>,
    /// The second-order specific-force error carried (m/s^2) and its directions.
    pub second_order: (f64, usize),
}

/// The turntable samples of a fit with the angles.
pub struct TurntableSamples {
    /// Used, left out near rate changes, without turntable data.
    pub used: usize,
    /// See `used`.
    pub near_rate_changes: usize,
    /// See `used`.
    pub missing: usize,
    /// The angle records' rate on the IMU clock (Hz).
    pub record_rate_hz: f64,
}

/// An estimate against a truth.
pub struct TruthFigures {
    /// The truth file.
    pub path: PathBuf,
    /// The comparison (`None`: the truth names no estimated parameter).
    pub comparison: Option<TruthComparison>,
    /// Clock values of the truth that differ from the configuration's: (name, the truth's
    /// value, the configuration's, the configuration field).
    pub clock_notes: Vec<(&'static str, f64, f64, &'static str)>,
}

/// The verdict of a run: the one its exit status, printout, JSON and report say.
#[derive(Clone, Debug)]
pub struct Verdict {
    /// Reasons for exit status 3, one line each (empty: nothing contradicts the model).
    pub reasons: Vec<String>,
    /// Findings that do not decide, each with its figures.
    pub findings: Vec<String>,
    /// What the verdict rests on.
    pub basis: String,
    /// Whether anything tested the model.
    pub tested: bool,
    /// How the command decides (one sentence, for the report).
    pub rule: String,
    /// What to check when the data contradict the model (the printout's advice).
    pub advice: String,
    /// The held-out tests of a hand-turned calibration with measured noise, with their figures
    /// (empty with a configured noise).
    pub tests: Vec<calib::estimate::verdict::VerdictTest>,
}

impl Verdict {
    /// Whether nothing contradicts the model.
    pub fn fits(&self) -> bool {
        self.reasons.is_empty()
    }

    /// The command's exit status.
    pub fn exit_status(&self) -> u8 {
        if self.fits() {
            0
        } else {
            crate::MODEL_DOES_NOT_FIT
        }
    }
}

/// What only the laboratory report shows.
pub struct LabFigures {
    /// Inputs, configuration, tool, date, command line.
    pub id: Identification,
    /// The parameters' posterior correlation (names, matrix) and its strongest pairs.
    pub correlation: (Vec<String>, Vec<Vec<f64>>),
    /// See `correlation`.
    pub strongest: Vec<(String, String, f64)>,
    /// The NIS of every segment of every measurement.
    pub segments: Vec<SegmentRow>,
}

impl RunReport {
    /// The report of `fit` on the session `s`, its navigation figure on `flight`.
    pub fn build(
        s: &Session<Calibrate>,
        fit: &Calibration,
        flight: &crate::navigation::Flight,
    ) -> Result<Self, Error> {
        let est = &fit.estimate;
        let lab::Figures {
            parameters,
            truth: comparison,
            result,
            mean_nis,
            known_turns,
            unobserved,
            correlation,
            strongest,
            segments,
        } = lab::Figures::of(fit, s.task.truth.as_ref().map(|(_, t)| t));
        let truth = s.task.truth.as_ref().map(|(path, t)| TruthFigures {
            path: path.clone(),
            comparison,
            clock_notes: clock_notes(t, &fit.config.clock),
        });
        let header = header(s, est);
        let fit_figures = fit_figures(est, mean_nis, known_turns, unobserved);
        let verdict = verdict(s, fit);
        let lab = match &s.report {
            Some(_) => Some(lab_figures(s, fit, correlation, strongest, segments)?),
            None => None,
        };
        let free_motion = match (s.free_motion(), &fit.evaluation) {
            (Some(f), Some(_)) => {
                crate::free_motion::figures(fit, &f.summary, s.holdout, known_turns)
            }
            _ => None,
        };
        let terms: Vec<&'static str> = s.task.terms.iter().map(|c| c.id()).collect();
        let navigation = crate::navigation::Navigation::of_estimate(
            est,
            &fit.config,
            flight,
            &terms,
            verdict.fits(),
        );
        Ok(Self {
            header,
            free_motion,
            provenance: s.provenance.clone(),
            assumptions: s
                .free_motion()
                .map_or(Vec::new(), |f| f.summary.assumptions.clone()),
            terms,
            parameters,
            result,
            fit: fit_figures,
            truth,
            diagnostics: fit.diagnostics.clone(),
            verdict,
            lab,
            navigation,
        })
    }
}

/// The head of the printout.
fn header(s: &Session<Calibrate>, est: &Estimate) -> Header {
    let configuration = match (&s.program, &s.source) {
        (Some((name, duration)), _) => {
            Configuration::Program(s.origin.clone(), name.clone(), *duration)
        }
        (None, ConfigSource::FromRecording) => Configuration::MadeFromRecording,
        (None, _) => Configuration::Rests(s.origin.clone()),
    };
    let turntable = s.turntable.as_ref().map(|tt| {
        let summary = tt.records().summary();
        let (a, b) = summary.span;
        TurntableSpan {
            file: tt.records().file().to_string(),
            count: summary.count,
            span: (a, b),
            imu_span: (s.config.clock.imu_time(a), s.config.clock.imu_time(b)),
        }
    });
    let start = match &est.start_alignment {
        None => Start::Program(est.program_start_s, est.program_start_found),
        Some(al) => Start::Rests(RestsStart {
            count: est.rests.len(),
            at_rest_s: est.rests.iter().map(|r| r.t1 - r.t0).sum(),
            windows_in_motion: est.stats.accel_windows_in_motion,
            gyrocompassed: al.gyrocompassed,
            gyrocompass_sigma_deg: al.gyrocompass_sigma_rad.to_degrees(),
        }),
    };
    Header {
        configuration,
        imu_file: s.imu_file.clone(),
        imu_records: est.stats.imu_steps,
        imu_kind: est.imu_kind,
        imu_span: est.imu_span,
        temperature: est.temperature.clone(),
        turntable,
        states: est.names.len(),
        start,
        missed_rests: s
            .rests
            .as_ref()
            .and_then(|r| r.missed.clone())
            .unwrap_or_default(),
    }
}

/// The fit's checks and counts.
fn fit_figures(
    est: &Estimate,
    mean_nis: Vec<MeanNis>,
    known_turns: Option<(usize, f64, f64)>,
    unobserved: Vec<(String, f64)>,
) -> FitFigures {
    let s = &est.stats;
    let with_turntable = est.with_turntable();
    FitFigures {
        states: est.names.len(),
        imu_records: s.imu_steps,
        final_time_s: est.final_time,
        mean_nis,
        turntable: with_turntable.then_some(TurntableSamples {
            used: s.turntable_samples,
            near_rate_changes: s.turntable_samples_near_rate_changes,
            missing: s.turntable_samples_missing,
            record_rate_hz: s.turntable_record_rate_hz,
        }),
        known_turns,
        unobserved,
        second_order: (s.second_order_accel_sigma, s.consider_directions),
    }
}

/// The truth's clock values that differ from the configuration's `[clock]` (the estimated
/// delay absorbs the difference).
fn clock_notes(
    truth: &ResultFile,
    clock: &calib::config::ClockConfig,
) -> Vec<(&'static str, f64, f64, &'static str)> {
    [
        (
            sins_model::names::CLOCK_OFFSET,
            clock.turntable_offset_s,
            "clock.turntable_offset_s",
        ),
        (
            sins_model::names::CLOCK_RATE_ERROR,
            clock.turntable_rate_error,
            "clock.turntable_rate_error",
        ),
    ]
    .into_iter()
    .filter_map(|(name, configured, what)| {
        let p = truth.get(name)?;
        ((p.value - configured).abs() > 1e-12 * (1.0 + configured.abs()))
            .then_some((name, p.value, configured, what))
    })
    .collect()
}

/// The verdict of the fit (the calibration's, [`RunVerdict`]: the innovation diagnostics
/// always among its checks), with the rule the report states and the advice the printout
/// gives.
fn verdict(s: &Session<Calibrate>, fit: &Calibration) -> Verdict {
    let case = Case {
        measured: fit.noise_measured(),
        rests: fit.evaluation.is_some(),
        turntable: s.turntable.is_some(),
    };
    Verdict::of(fit.verdict.clone(), case)
}

/// What a run's verdict is about: noise measured from the data (the held-out rests decide) or
/// configured (the innovations decide); a recording of rests or a program; turntable angles.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    /// The noise was measured from these data.
    pub measured: bool,
    /// A recording of rests (no program).
    pub rests: bool,
    /// The turntable's angles were used.
    pub turntable: bool,
}

impl Verdict {
    /// The verdict `v` with the rule the report states and the advice the printout gives,
    /// both naming only what the run has.
    pub fn of(v: RunVerdict, case: Case) -> Self {
        let (rule, advice) = if case.measured {
            (
                "The noise was measured from these data, so the scatter of the innovations is no \
                 test: the model fits unless the held-out rests, the known turns or a candidate \
                 term the data call for (moving a parameter by 3 sigma or more) contradict it; \
                 the tests of the innovations inform."
                    .to_string(),
                "the held-out rests, the known turns or the score tests contradict the \
                 calibration\n  {}\nThe estimates above are not to be trusted: an error the \
                 model lacks outweighs the noise (`sins-calib diagnose --free-motion` names the \
                 candidates; --terms adds one)."
                    .to_string(),
            )
        } else {
            let check = if case.rests {
                "the motion noise (filter.motion_attitude_noise_deg)"
            } else if case.turntable {
                "the program, the clock relation"
            } else {
                "the program"
            };
            (
                "The model fits when no mean NIS is above its band, no test of the innovations \
                 fails (they inform only where every mean NIS is below its band: the noise is \
                 then over-stated and the sigmas conservative), and no candidate term the score \
                 tests call for at 1 % would move a parameter by 3 sigma or more."
                    .to_string(),
                format!(
                    "the innovations or the score tests contradict the model\n  {{}}\nThe \
                     estimates above are not to be trusted: check the noise levels in [noise], \
                     {check}, and errors the model lacks (a term named above: `diagnose` fits \
                     it)."
                ),
            )
        };
        Self {
            reasons: v.decisive,
            findings: v.informative,
            basis: v.basis,
            tested: v.tested,
            rule,
            advice,
            tests: v.tests,
        }
    }
}

/// What only the laboratory report shows: the identification (the inputs hashed, the
/// configuration as used), the correlations and the segments' NIS.
fn lab_figures(
    s: &Session<Calibrate>,
    fit: &Calibration,
    correlation: (Vec<String>, Vec<Vec<f64>>),
    strongest: Vec<(String, String, f64)>,
    segments: Vec<SegmentRow>,
) -> Result<LabFigures, Error> {
    let inputs: Vec<(&'static str, &std::path::Path)> = s
        .report_inputs
        .iter()
        .map(|(role, p)| (*role, p.as_path()))
        .collect();
    let assumptions = s
        .free_motion()
        .map_or(Vec::new(), |f| f.summary.assumptions.clone());
    let id = crate::provenance::identification::identify(&inputs, s.source.shown(), &fit.config)?
        .with_provenance(&s.provenance, &assumptions);
    Ok(LabFigures {
        id,
        correlation,
        strongest,
        segments,
    })
}
