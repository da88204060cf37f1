//! Calibration from recorded data (the method in full: `docs/estimation.md`).
//!
//! The one entry is [`run`]: a [`Plan`] (the configuration, the model and the kind of run with
//! its options: [`RunKind`]) and the [`Records`] in, a [`calibration::Calibration`] out. Its
//! parts: the first reading of the records (`scan`), a programmed run located on the IMU clock
//! (`programmed`), a recording of rests (`at_rests`, its coarse start `coarse_start`, the
//! hand-turned run with its measured noise [`hand_turned`]), the turntable side
//! (`turntable_setup`), where the passes start (`start_point`), the passes themselves
//! (`passes`, one pass `pass`).
//!
//! - Checks before any filter: values no sensor gives, the specific force at rest, dead gyros,
//!   the program's start on the IMU clock (found from the rates or checked), the turntable
//!   angles against the program through the clock relation.
//! - Strapdown: the attitude `C` (body to ENU) is integrated at the IMU rate from the increments,
//!   corrected with the current parameter estimate, with the coning correction
//!   `phi = dth + dth_prev x dth / 12`; the velocity increment in ENU gets the rotation and
//!   sculling corrections; both previous-sample terms are dropped across a jump of the rate.
//!   The start attitude is aligned to the program's rotations (IMU only) or comes from the
//!   mounting fitted to the program's directions (with the turntable angles).
//! - Specific force: the mean over each window of `C dv` against the site's `(0, 0, g)`.
//! - Turntable angles: interpolated (linearly, wrap-aware) at the turntable-clock time of
//!   `t + tau_hat`, turned into the attitude `C_tt` with the current installation estimate, and
//!   compared with `C`; one sample per record when the records are sparse.
//! - Filter: the error-state model of [`crate::model`] with [`crate::model::engine`], shared with the
//!   covariance analysis; a closed-loop first pass, then passes linearised about the one before
//!   until the parameters settle; the mounting covariances mapped to rotation-vector
//!   coordinates; the second-order specific-force error carried as a consider parameter where
//!   it matters (`consider`).

use crate::check::diagnostics::{self, Innovation};
use crate::config::{ConfigError, RunConfig};
use crate::io::angle_records::AngleRecords;
use crate::io::{ImuData, ImuKind, ResultFile, ResultParameter};
use crate::model::layout::{StateLayout, layout_for};
use crate::motion::align::RateBin;
use crate::motion::program_start::{ProgramStartError, TurntableClockError};
use crate::motion::rests::{Rest, RestError, Turn};
use calibration::Calibration;
use nalgebra::{DMatrix, Matrix3};
use sins_model::terms::Unit;

mod angles;
mod at_rests;
pub mod calibration;
mod coarse_start;
mod consider;
pub mod covariance;
pub mod data_checks;
pub mod hand_turned;
mod motion_terms;
pub mod noise;
mod pass;
mod passes;
mod programmed;
mod rest_excess;
mod scan;
pub mod score_pass;
mod start_point;
mod turntable_setup;
pub mod verdict;
pub use coarse_start::needs_coarse_start;
pub use passes::force_baseline_instructions;
use passes::run_pass;
pub(crate) use programmed::fit_extended;
use scan::TemperatureScan;
use turntable_setup::TurntableSetup;

pub use crate::io::source::{FileImu, ImuSource, MemoryImu};
use pass::Feedback;

/// What a calibration is to be: the configuration, the model, and the kind of run with its
/// options. With the records ([`Records`]) it is all [`run`] needs.
#[derive(Clone, Copy)]
pub struct Plan<'a> {
    /// The configuration.
    pub config: &'a RunConfig,
    /// The state layout (e.g. the paper's model extended by candidate terms:
    /// [`crate::model::layout::layout_with`]); `None`: the configuration's model
    /// ([`layout_for`]), with the turntable's states where its angles are given.
    pub layout: Option<&'a StateLayout>,
    /// The kind of run.
    pub kind: RunKind<'a>,
}

impl<'a> Plan<'a> {
    /// A programmed run of the configuration's model, the fit alone
    /// ([`ProgramOptions::FIT_ONLY`]).
    pub fn fit_only(config: &'a RunConfig) -> Self {
        Self {
            config,
            layout: None,
            kind: RunKind::Programmed(ProgramOptions::FIT_ONLY),
        }
    }
}

/// The kinds of run.
#[derive(Clone, Copy)]
pub enum RunKind<'a> {
    /// Along a turntable program (given, or read from the angle records), with the turntable's
    /// angles where the layout has their states: located on the IMU clock, then passes over
    /// the records until the parameters settle.
    Programmed(ProgramOptions),
    /// A hand-turned recording of rests (no program, no turntable): the filter of a recording
    /// of rests, with its noise measured and rests held out where asked, and the figures of
    /// the result on the rests ([`hand_turned`]).
    HandTurned(HandTurnedRun<'a>),
    /// The filter alone on a recording of rests: the configured noise, no hold-out, no score
    /// tests and no figures ([`Calibration::evaluation`] is `None`).
    RestsFilter {
        /// The rests, on the IMU clock, in time order.
        rests: &'a [Rest],
        /// Known turns between them, as measurements.
        turns: &'a [Turn],
    },
}

/// What a programmed run does beyond the fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProgramOptions {
    /// The score tests of the candidate terms ([`score_pass`]).
    pub score_terms: bool,
    /// The thermal terms carried where the records' temperature spans enough
    /// (`score_pass::with_thermal_biases`).
    pub carry_thermal: bool,
}

impl ProgramOptions {
    /// `calibrate`'s: the score tests, and the thermal terms carried where they can be.
    pub const CALIBRATE: Self = Self {
        score_terms: true,
        carry_thermal: true,
    };
    /// The fit alone (as the configuration asks).
    pub const FIT_ONLY: Self = Self {
        score_terms: false,
        carry_thermal: false,
    };
}

/// A hand-turned recording of rests ([`RunKind::HandTurned`]).
#[derive(Clone, Copy, Debug)]
pub struct HandTurnedRun<'a> {
    /// The rests, on the IMU clock, in time order.
    pub rests: &'a [Rest],
    /// Known turns between them, as measurements.
    pub turns: &'a [Turn],
    /// Every how many rests one is held out (`filter.hold_out_every`); `None`: none.
    pub holdout: Option<usize>,
    /// The rests' white noise, where the noise is measured from the recording
    /// ([`hand_turned::white_noise_at_rest`]); `None`: the configured noise.
    pub measured: Option<hand_turned::WhiteNoiseAtRest>,
}

/// The records a calibration is made from.
pub enum Records<'a> {
    /// Held in memory (IMU records and, for a programmed run, the turntable's).
    Held(RunData<'a>),
    /// An IMU source read again for every pass (e.g. a file read record by record), and the
    /// turntable records.
    Streamed {
        /// The IMU records.
        imu: &'a mut dyn ImuSource,
        /// The turntable records, for a programmed run with the angles.
        turntable: Option<AngleRecords<'a>>,
    },
}

/// Calibrate: the one entry into the estimate. `progress` is called with (work done, total
/// work) now and then; the work counts the reading of the records and the passes.
///
/// A recording of rests has no turntable angles: given with one, it is refused.
pub fn run(
    plan: Plan,
    records: Records,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Calibration, EstimateError> {
    let mut held;
    let (imu, turntable): (&mut dyn ImuSource, _) = match records {
        Records::Held(data) => {
            held = MemoryImu::new(data.imu, data.imu_file);
            (&mut held, data.turntable)
        }
        Records::Streamed { imu, turntable } => (imu, turntable),
    };
    let config = plan.config;
    let configured;
    let layout = match plan.layout {
        Some(layout) => layout,
        None => {
            configured = layout_for(config, turntable.is_some());
            &configured
        }
    };
    if turntable.is_some() && !matches!(plan.kind, RunKind::Programmed(_)) {
        return Err(EstimateError::Rests {
            file: imu.file().to_string(),
            source: RestError::WithTurntable,
        });
    }
    match plan.kind {
        RunKind::Programmed(options) => {
            programmed::calibrate(config, layout, imu, turntable, options, progress)
        }
        RunKind::HandTurned(run) => hand_turned::calibrate(config, layout, imu, &run, progress),
        RunKind::RestsFilter { rests, turns } => {
            let input = hand_turned::RestsInput { imu, rests, turns };
            hand_turned::filter_only(config, layout, input, progress)
        }
    }
}

/// Errors of an estimation run.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// The rests of a recording without a program cannot carry a calibration.
    #[error("{file}: {source}")]
    Rests {
        /// IMU file.
        file: String,
        /// What is wrong with the rests.
        source: RestError,
    },
    /// Configuration problem.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Unusable input data.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// The data do not follow the rotation program.
    #[error("{file}: {source}")]
    ProgramStart {
        /// The IMU file.
        file: String,
        /// What did not match.
        source: ProgramStartError,
    },
    /// The turntable angles do not follow the program on the clock relation.
    #[error("{file}: {source}")]
    TurntableClock {
        /// The turntable file.
        file: String,
        /// What did not match.
        source: TurntableClockError,
    },
    /// The filter refused a step.
    #[error(
        "the Kalman filter failed at t = {t:.3} s (IMU clock), record on line {line}: {source}"
    )]
    Filter {
        /// IMU time of the failing step (s).
        t: f64,
        /// Line of the IMU file holding the record.
        line: usize,
        /// Cause.
        source: kalman::KalmanError,
    },
}

/// The recorded data of a run.
#[derive(Clone, Copy, Debug)]
pub struct RunData<'a> {
    /// IMU records.
    pub imu: &'a ImuData,
    /// Name of the IMU file (for messages).
    pub imu_file: &'a str,
    /// Turntable records and their file name (`(&data, "tt.csv").into()`, or an
    /// [`crate::io::angle_records::AngleFile`]'s records); `None` for an IMU-only (24-state)
    /// calibration.
    pub turntable: Option<AngleRecords<'a>>,
}

/// Fit statistics of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FitStatistics {
    /// IMU steps integrated.
    pub imu_steps: usize,
    /// Specific-force updates.
    pub accel_updates: usize,
    /// Mean normalised innovation squared of the specific-force updates (3 when the model fits).
    pub accel_mean_nis: f64,
    /// Turntable-angle updates.
    pub turntable_updates: usize,
    /// Mean normalised innovation squared of the turntable updates (about 3 when the model
    /// fits: [`Self::turntable_expected_nis`]).
    pub turntable_mean_nis: f64,
    /// What [`Self::turntable_mean_nis`] averages when the model fits: the mean over the
    /// updates of `3 - tr(S^-1 R_shared)` ([`crate::model::engine::UpdateRecord::expected_nis`]),
    /// below 3 by the share of each window's `R` that covers the records it shares with the
    /// window before (about 0.03 with 50-Hz angle records). 3 without updates.
    pub turntable_expected_nis: f64,
    /// Turntable samples used (interpolated angle sets).
    pub turntable_samples: usize,
    /// IMU steps in a turntable window without turntable data (outside the file's span or in
    /// a gap of the records).
    pub turntable_samples_missing: usize,
    /// Turntable samples left out because the platform rate changes within the delay
    /// uncertainty (`RateChanges`).
    pub turntable_samples_near_rate_changes: usize,
    /// Largest change of a parameter from the pass before the last to the last, in posterior
    /// sigmas (large values mean the iteration had not converged).
    pub first_pass_shift_sigma: f64,
    /// Passes over the data made by the filter.
    pub passes: usize,
    /// Record rate of the turntable file on the IMU clock (Hz).
    pub turntable_record_rate_hz: f64,
    /// Standard deviation (m/s^2, largest direction) of the second-order specific-force error
    /// `beta x (C df)` that the linear model leaves out, from the posterior; zero when it is
    /// negligible (see docs/estimation.md, step 8).
    pub second_order_accel_sigma: f64,
    /// Principal directions of that error carried into the posterior covariance (those above
    /// a tenth of the white-noise sigma of the run's mean specific force), through the final
    /// pass's sensitivity to a residual offset.
    pub consider_directions: usize,
    /// Specific-force windows left out because the unit moved in them (a recording of rests;
    /// zero with a program, where the specific force is known throughout).
    pub accel_windows_in_motion: usize,
    /// Known turns measured (a recording of rests with a section list's turns).
    pub turn_updates: usize,
    /// Mean normalised innovation squared of the known turns (1 when the model fits).
    pub turn_mean_nis: f64,
}

/// A parameter whose posterior sigma is above this fraction of its prior sigma is reported as
/// not observed by the run ([`Estimate::unobserved`]).
pub const UNOBSERVED_SIGMA_RATIO: f64 = 0.9;

/// The result of a calibration: every state's estimate and the posterior covariance.
#[derive(Clone, Debug)]
pub struct Estimate {
    /// State names (`attitude.beta.*` first, then the parameters).
    pub names: Vec<String>,
    /// State units.
    pub units: Vec<Unit>,
    /// Estimates (SI). The attitude errors are zero: they have been fed back into the attitude.
    pub values: Vec<f64>,
    /// Prior sigma (SI).
    pub prior_sigma: Vec<f64>,
    /// Posterior covariance (SI).
    pub cov: DMatrix<f64>,
    /// IMU time of the final estimate (s).
    pub final_time: f64,
    /// Computed attitude at `final_time` (the attitude states are its error).
    pub final_c_body_to_enu: Matrix3<f64>,
    /// The specific force at rest at the site (m/s^2), as the fit took it.
    pub gravity_m_s2: f64,
    /// Fit statistics.
    pub stats: FitStatistics,
    /// First and last time stamp of the IMU records (s).
    pub imu_span: (f64, f64),
    /// Increments or rates.
    pub imu_kind: ImuKind,
    /// IMU time at which the rotation program starts (s).
    pub program_start_s: f64,
    /// Whether that start was found from the data (rather than given).
    pub program_start_found: bool,
    /// Every update of the reported pass in order: innovation, its covariance, IMU time and the
    /// program segment ([`crate::check::diagnostics`]).
    pub innovations: Vec<Innovation>,
    /// The segments the innovations are assigned to: the program's pieces, or the rests and
    /// the motions between them.
    pub segments: Vec<diagnostics::Segment>,
    /// A recording without a program: its rests ([`RunKind::HandTurned`]); empty with a program.
    pub rests: Vec<Rest>,
    /// A recording without a program: how its start attitude was found; `None` with a program.
    pub start_alignment: Option<crate::motion::rests::RestAlignment>,
    /// The records' temperatures and the reference of the thermal terms, when the records have
    /// a temperature.
    pub temperature: Option<crate::io::ResultTemperature>,
    /// The records' temperature in 1-s means on the IMU clock (`[t_s, temp_c]`), when they
    /// have one: the profile the covariance analyses of the model-extension loop take.
    pub temperature_series: Vec<[f64; 2]>,
    /// The posterior of one more pass with every candidate term the recording can test
    /// appended ([`score_pass`]), when the configuration asks for it
    /// (`filter.score_terms`): the score tests of the verdict.
    pub extended: Option<crate::check::score::ExtendedPosterior>,
    /// Why that pass failed, when it did (the fit itself stands; the verdict says the score
    /// tests were not made).
    pub extended_error: Option<String>,
    /// Terms the estimate carried on its own, beyond the layout it was given: the thermal bias
    /// terms of a `calibrate` whose records' temperature moved
    /// ([`score_pass::CARRY_THERMAL_SPAN_K`]).
    pub carried_terms: Vec<String>,
    /// Candidate terms tested by the likelihood ratio of a fit with them, in place of their
    /// score test (a recording of rests whose motion noise was measured above zero:
    /// [`crate::check::score::TermRatio`]).
    pub likelihood_ratios: Vec<crate::check::score::TermRatio>,
    /// What the fit's last pass was made with (its motion and the point its extended pass is
    /// linearised about): for the extended pass of a recording of rests, made once after the
    /// noise fixed point settles rather than in each of its fits (`at_rests::score_rests`).
    replay: Option<Box<Replay>>,
}

/// The motion of a fit and its last estimates ([`Estimate`]'s `replay`); for a recording of
/// rests also the first reading of its records, shared: a later fit of the same records (the
/// noise fixed point's next, the score tests' extended pass) takes it rather than reading them
/// again.
#[derive(Clone)]
struct Replay {
    motion: Motion,
    nominal: Nominal,
    /// The scan and the record rate it was made at (Hz).
    scan: Option<(std::sync::Arc<Scan>, f64)>,
}

impl Replay {
    fn boxed(motion: &Motion, nominal: Nominal) -> Box<Self> {
        Box::new(Self {
            motion: motion.clone(),
            nominal,
            scan: None,
        })
    }

    /// The scan of the records, if kept and made at `rate_hz`.
    fn scan_at(&self, rate_hz: f64) -> Option<std::sync::Arc<Scan>> {
        let (scan, rate) = self.scan.as_ref()?;
        (*rate == rate_hz).then(|| scan.clone())
    }
}

impl std::fmt::Debug for Replay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Replay { .. }")
    }
}

impl Estimate {
    /// The converged estimates of this fit as the first linearisation point of a fit of the
    /// same states (`layout`'s, in order) with another noise model: a warm start. `None` for
    /// other states or a fit that kept no replay.
    fn warm_start(&self, layout: &crate::model::layout::StateLayout) -> Option<Nominal> {
        let same = self
            .names
            .iter()
            .eq(layout.entries().iter().map(|e| &e.name));
        let replay = self.replay.as_ref().filter(|_| same)?;
        Some(replay.nominal.clone())
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
    /// The parameters the data leave (nearly) where the prior had them: posterior sigma above
    /// [`UNOBSERVED_SIGMA_RATIO`] of the prior sigma, with that ratio. A static run, for
    /// example, says nothing of the gyro matrix or of the delay; a rotation about one axis
    /// nothing of some scale factors. Their estimates are the prior's, and their sigmas honest.
    pub fn unobserved(&self) -> Vec<(String, f64)> {
        self.names
            .iter()
            .enumerate()
            .skip(StateLayout::INSTRUMENT)
            .filter_map(|(i, n)| {
                let ratio = self.cov[(i, i)].sqrt() / self.prior_sigma[i];
                (ratio > UNOBSERVED_SIGMA_RATIO).then(|| (n.clone(), ratio))
            })
            .collect()
    }

    /// Whether the turntable's angles were fitted (the layout has their delay).
    pub fn with_turntable(&self) -> bool {
        self.names
            .iter()
            .any(|n| n == sins_model::names::TURNTABLE_TAU)
    }

    /// Estimate of a state by name (SI).
    pub fn value(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.values[i])
    }
    /// Posterior sigma of a state by name (SI).
    pub fn sigma(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.cov[(i, i)].max(0.0).sqrt())
    }
    /// The score test of the states `names` (a term fitted in this estimate) from their
    /// posterior means, covariance and prior sigmas ([`crate::check::score::score_test`]);
    /// `None` where a name is not a state.
    pub fn score_test_of(&self, names: &[String]) -> Option<crate::check::score::ScoreTest> {
        let idx: Vec<usize> = names.iter().map(|n| self.index(n)).collect::<Option<_>>()?;
        let theta: Vec<f64> = idx.iter().map(|&i| self.values[i]).collect();
        let cov = DMatrix::from_fn(idx.len(), idx.len(), |a, b| self.cov[(idx[a], idx[b])]);
        let prior: Vec<f64> = idx.iter().map(|&i| self.prior_sigma[i]).collect();
        Some(crate::check::score::score_test(&theta, &cov, &prior))
    }
    /// Keep the first `n` states only.
    fn truncate(&mut self, n: usize) {
        self.names.truncate(n);
        self.units.truncate(n);
        self.values.truncate(n);
        self.prior_sigma.truncate(n);
        self.cov = self.cov.view((0, 0), (n, n)).into_owned();
    }

    /// The parameters (every state but the attitude errors) as a result file.
    pub fn to_result_file(&self) -> ResultFile {
        let parameters = (StateLayout::INSTRUMENT..self.names.len())
            .map(|i| ResultParameter {
                name: self.names[i].clone(),
                value: self.values[i],
                sigma: Some(self.cov[(i, i)].max(0.0).sqrt()),
                unit: self.units[i].si_name().to_string(),
            })
            .collect();
        let range = StateLayout::INSTRUMENT..self.names.len();
        let correlation =
            crate::io::posterior::correlation(self.names.len(), range, |i, j| self.cov[(i, j)]);
        crate::model::correction::result_file(
            parameters,
            correlation,
            crate::model::correction::ExtensionInputs::True,
            self.temperature.clone(),
        )
    }
}

/// What an estimate asks the configuration for at every step, resolved once at its start: the
/// site (its gravity and Earth rate) and the priors in SI. The fits of one calibration may
/// differ in their noise levels and held-out segments, never in these.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SitePriors {
    /// The site.
    site: sins_model::earth::Site,
    /// The specific force at rest there (m/s^2).
    gravity_m_s2: f64,
    /// The paper's priors in SI.
    priors: sins_model::terms::PaperPriors,
}

impl SitePriors {
    /// The plan of an estimate with `config`.
    pub(crate) fn of(config: &RunConfig) -> Self {
        let site = config.site();
        Self {
            site,
            gravity_m_s2: site.specific_force_at_rest_enu().norm(),
            priors: config.priors_si(),
        }
    }
}

/// What the first reading of the IMU data found.
#[derive(Clone, Debug)]
struct Scan {
    /// Number of records.
    n: usize,
    /// First and last time stamp (s).
    span: (f64, f64),
    /// Mean rates and specific forces over short bins.
    bins: Vec<RateBin>,
    /// IMU time at which the program starts (s).
    program_start: f64,
    /// Whether the program start was found from the data (not given).
    program_start_found: bool,
    /// The records' temperatures, when they have one.
    temperature: Option<TemperatureScan>,
}

pub use crate::io::MIN_RECORDING_S;

/// Records between two progress reports.
const PROGRESS_EVERY: usize = 4096;

/// What the unit did during the recording: what the start attitude, the specific-force
/// measurements and the diagnostics' segments come from.
#[derive(Clone)]
enum Motion {
    /// A turntable program (given, or read from the angle records).
    Program(turntable::program::Program),
    /// Rests between motions that are not known ([`crate::motion::rests`]).
    Rests {
        /// The rests as given.
        rests: Vec<Rest>,
        /// Less their margins.
        usable: Vec<Rest>,
        /// The start attitude from the first.
        align: crate::motion::rests::RestAlignment,
        /// The coarse start, the prior mean of the instrument parameters in place of zero.
        coarse: Option<Vec<f64>>,
        /// Known turns, measured ([`crate::motion::rests::Turn`]).
        turns: Vec<crate::motion::rests::Turn>,
    },
}

/// The point a pass linearises about: the estimates of the pass before.
#[derive(Clone)]
struct Nominal {
    /// A full state vector of totals (attitude entries unused).
    totals: Vec<f64>,
    /// The estimate of the start attitude (body to ENU).
    c_start: Matrix3<f64>,
}

/// What every pass of a calibration reads: the configuration, the state layout, the turntable
/// side (set up only for a layout with the mounting states: [`run`]), the scan of
/// the IMU data and what the unit did.
#[derive(Clone, Copy)]
struct PassInputs<'r, 't> {
    config: &'r RunConfig,
    plan: &'r SitePriors,
    layout: &'r StateLayout,
    turntable: Option<&'r TurntableSetup<'t>>,
    scan: &'r Scan,
    motion: &'r Motion,
}
