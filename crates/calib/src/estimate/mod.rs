//! Calibration from recorded data (the method in full: `docs/estimation.md`).
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
use crate::config::{AttitudePrior, ClockConfig, ConfigError, RunConfig};
use crate::estimate::data_checks::{
    Stuck, check_gyros_alive, check_record, check_specific_force, check_specific_force_within,
};
use crate::io::angle_records::AngleRecords;
use crate::io::{ImuData, ImuKind, ImuRecord, IoError, ResultFile, ResultParameter, check_overlap};
use crate::model::LinearModel;
use crate::model::engine::prior_filter;
use crate::model::engine::{Engine, MeasurementNoise, RateChanges, Schedule};
use crate::model::extension::ModelExtension;
use crate::model::layout::{StateLayout, initial_covariance, layout_for, layout_with};
use crate::motion::align::{DirectionErrors, RateBin, RateBinner, aligned_prior, fit_mounting};
use crate::motion::program_start::{
    ProgramStart, ProgramStartError, TurntableClockError, check_program_start,
    check_turntable_clock, find_program_start,
};
use crate::motion::rests::{Rest, RestError};
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::attitude::{exp_so3, log_so3};
use sins_model::terms::Unit;
use turntable::gimbal::c_platform_to_base;

mod angles;
pub mod calibration;
mod consider;
pub mod covariance;
pub mod data_checks;
pub mod hand_turned;
pub mod noise;
mod pass;
pub mod score_pass;
pub mod verdict;

pub use crate::io::source::{FileImu, ImuSource, MemoryImu};
use angles::AngleInterpolator;
use pass::{AngleReader, Feedback, Linearisation, Pass, PassResult, PassSettings, Strapdown};

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
    /// A recording without a program: its rests ([`estimate_at_rests`]); empty with a program.
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
    /// What the fit's last pass was made with (its motion and the point its extended pass is
    /// linearised about): for the extended pass of a recording of rests, made once after the
    /// noise fixed point settles rather than in each of its fits ([`score_rests`]).
    replay: Option<Box<Replay>>,
}

/// The motion of a fit and its last estimates ([`Estimate`]'s `replay`).
#[derive(Clone)]
struct Replay {
    motion: Motion,
    nominal: Nominal,
}

impl Replay {
    fn boxed(motion: &Motion, nominal: Nominal) -> Box<Self> {
        Box::new(Self {
            motion: motion.clone(),
            nominal,
        })
    }
}

impl std::fmt::Debug for Replay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Replay { .. }")
    }
}

impl Estimate {
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
pub(crate) struct Plan {
    /// The site.
    site: sins_model::earth::Site,
    /// The specific force at rest there (m/s^2).
    gravity_m_s2: f64,
    /// The paper's priors in SI.
    priors: sins_model::terms::PaperPriors,
}

impl Plan {
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

/// The temperatures of the records, as the scan found them.
#[derive(Clone, Debug, Default)]
struct TemperatureScan {
    sum: f64,
    n: usize,
    min: f64,
    max: f64,
    /// 1-s means `[t_s, temp_c]` (the time the middle of the second).
    series: Vec<[f64; 2]>,
    /// The open second: its index, sum and count.
    open: Option<(i64, f64, usize)>,
}

impl TemperatureScan {
    fn push(&mut self, t: f64, temp: f64) {
        if self.n == 0 {
            (self.min, self.max) = (temp, temp);
        }
        self.sum += temp;
        self.n += 1;
        self.min = self.min.min(temp);
        self.max = self.max.max(temp);
        let second = t.floor() as i64;
        match &mut self.open {
            Some((k, s, c)) if *k == second => {
                *s += temp;
                *c += 1;
            }
            _ => {
                self.close();
                self.open = Some((second, temp, 1));
            }
        }
    }

    fn close(&mut self) {
        if let Some((k, s, c)) = self.open.take() {
            self.series.push([k as f64 + 0.5, s / c as f64]);
        }
    }

    fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }
}

/// Why the thermal terms' reference temperature is the one it is.
const REFERENCE_MEAN: &str = "the mean of the records' temperatures: the biases and scale \
    factors of the result are those at it, where they are least correlated with the temperature \
    coefficients";
const REFERENCE_CONFIGURED: &str = "temperature.reference_c of the configuration";

impl Scan {
    /// The reference temperature and the summary for the result, when the records have a
    /// temperature.
    fn temperature(&self, config: &RunConfig) -> Option<crate::io::ResultTemperature> {
        let t = self.temperature.as_ref()?;
        let configured = config.temperature.as_ref().and_then(|c| c.reference_c);
        Some(crate::io::ResultTemperature {
            reference_c: configured.unwrap_or_else(|| t.mean()),
            reference_reason: if configured.is_some() {
                REFERENCE_CONFIGURED
            } else {
                REFERENCE_MEAN
            }
            .to_string(),
            min_c: Some(t.min),
            max_c: Some(t.max),
        })
    }
}

/// Length of the rate bins of the scan (s).
const BIN_S: f64 = 0.1;

/// How far one record's interval may be from the configured one: a programmed run's records
/// come at a fixed rate (within 5 %); a recording of rests may have jittered time stamps (each
/// record is then integrated over its own interval: within 50 %) and, in rate form, a few
/// dropped records (a rate record integrated over up to five intervals; an increment record
/// lost is a rotation lost).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Spacing {
    Fixed,
    Jittered,
}

impl Spacing {
    /// The accepted range of `interval / configured interval`.
    fn range(self, kind: ImuKind) -> (f64, f64) {
        match (self, kind) {
            (Spacing::Fixed, _) => (0.95, 1.05),
            (Spacing::Jittered, ImuKind::Increments) => (0.5, 1.5),
            (Spacing::Jittered, ImuKind::Rates) => (0.5, 5.0),
        }
    }
}

/// Read the IMU data once: count the records and check that they come at the configured rate
/// (within the `spacing`'s tolerance), naming the first line that does not.
fn scan_imu(
    imu: &mut dyn ImuSource,
    rate_hz: f64,
    spacing: Spacing,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Scan, EstimateError> {
    let dt = 1.0 / rate_hz;
    imu.rewind()?;
    let hint = imu.len_hint().unwrap_or(0);
    let (mut n, mut first, mut prev) = (0usize, f64::NAN, f64::NAN);
    let mut binner = RateBinner::new(BIN_S);
    let kind = imu.kind();
    let mut temperature: Option<TemperatureScan> = None;
    // A stuck sensor, checked on the raw values (the lines of the first and last record).
    let (mut stuck, mut lines) = (Stuck::default(), (0, 0));
    while let Some((rec, line)) = imu.next_record()? {
        check_record(&rec, kind, dt, imu.file(), line)?;
        stuck.push(&rec);
        lines = (if n == 0 { line } else { lines.0 }, line);
        if let Some(temp) = rec.temp {
            temperature.get_or_insert_default().push(rec.t, temp);
        }
        let (g, a) = (Vector3::from(rec.gyro), Vector3::from(rec.accel));
        match kind {
            ImuKind::Increments => binner.push(rec.t, dt, &g, &a),
            ImuKind::Rates => binner.push(rec.t, dt, &(g * dt), &(a * dt)),
        }
        if n == 0 {
            first = rec.t;
        } else {
            let d = rec.t - prev;
            let (lo, hi) = spacing.range(kind);
            if !(lo..=hi).contains(&(d / dt)) {
                let expected = match spacing {
                    Spacing::Fixed => format!("{dt} s (filter.imu_rate_hz = {rate_hz}) within 5 %"),
                    Spacing::Jittered => format!(
                        "{} to {} s (filter.imu_rate_hz = {rate_hz}: {lo} to {hi} intervals)",
                        lo * dt,
                        hi * dt
                    ),
                };
                // About a thousand intervals: the stamps are in milliseconds.
                let ms = if (500.0..2000.0).contains(&(d / dt)) {
                    " (time stamps in milliseconds? imu.csv holds seconds: `import` with [time] \
                     unit = \"ms\" converts them)"
                } else {
                    ""
                };
                return Err(IoError::Line {
                    file: imu.file().to_string(),
                    line,
                    message: format!(
                        "the interval to the previous record is {d} s: expected {expected}; \
                         gaps and other rates are not interpolated{ms}"
                    ),
                }
                .into());
            }
        }
        prev = rec.t;
        n += 1;
        if n.is_multiple_of(PROGRESS_EVERY) {
            progress(n, 3 * hint.max(n));
        }
    }
    // Less than a second holds no specific-force measurement at the usual rates: nothing
    // would be estimated, and the priors would be reported as a calibration.
    if n < 2 || (prev - first).is_nan() || prev - first < MIN_RECORDING_S {
        return Err(IoError::File {
            file: imu.file().to_string(),
            message: format!(
                "{n} IMU record(s){}: expected at least {MIN_RECORDING_S} s of records (nothing \
                 is calibrated from less)",
                if n >= 2 {
                    format!(" covering {} s", prev - first)
                } else {
                    String::new()
                }
            ),
        }
        .into());
    }
    stuck
        .check(lines.0, lines.1)
        .map_err(|message| IoError::File {
            file: imu.file().to_string(),
            message,
        })?;
    if let Some(t) = &mut temperature {
        t.close();
    }
    Ok(Scan {
        n,
        span: (first, prev),
        bins: binner.finish(),
        program_start: f64::NAN,
        program_start_found: false,
        temperature,
    })
}

pub use crate::io::MIN_RECORDING_S;

/// Records between two progress reports.
const PROGRESS_EVERY: usize = 4096;

/// Calibrate from recorded data in memory with the configuration's model and settings.
/// `progress` is called with (work done, total work) now and then; the work counts the reading
/// of the records and both filter passes, so the total is three times the records.
pub fn estimate(
    config: &RunConfig,
    data: &RunData,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let layout = layout_for(config, data.turntable.is_some());
    estimate_with(config, &layout, data, progress)
}

/// Calibrate from recorded data in memory with the paper's model extended by `ext`
/// ([`crate::model::layout::layout_with`]: the extra terms' parameters are states after the paper's,
/// a gyro drift is process noise on the gyro biases). With an empty extension this is
/// [`estimate`], bit for bit.
pub fn estimate_ext(
    config: &RunConfig,
    data: RunData,
    ext: &ModelExtension,
) -> Result<Estimate, EstimateError> {
    estimate_ext_kept(config, data, ext, &mut None)
}

/// [`estimate_ext`] with the program kept for the next fit ([`estimate_from_kept`]).
pub(crate) fn estimate_ext_kept(
    config: &RunConfig,
    data: RunData,
    ext: &ModelExtension,
    program: &mut Option<turntable::program::Program>,
) -> Result<Estimate, EstimateError> {
    let layout = layout_with(config, data.turntable.is_some(), ext);
    let mut imu = MemoryImu::new(data.imu, data.imu_file);
    estimate_from_kept(
        config,
        &layout,
        &mut imu,
        data.turntable,
        program,
        &mut |_, _| {},
    )
}

/// [`estimate`] with any state layout (e.g. an extended instrument model).
pub fn estimate_with(
    config: &RunConfig,
    layout: &StateLayout,
    data: &RunData,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let mut imu = MemoryImu::new(data.imu, data.imu_file);
    estimate_from(config, layout, &mut imu, data.turntable, progress)
}

/// Calibrate from any IMU source (e.g. a file read record by record, twice) and the turntable
/// records, with the state layout `layout`.
///
/// Two passes over the data. The first feeds every estimate back as it goes (closed loop) and
/// starts from the prior means; its linearisation errors are products of the current errors,
/// which are large at first: an unobservable 1-degree heading error times a 1e-3 scale-factor
/// error puts 5 sigma of bias into the IMU-only accelerometer matrix. The second pass
/// linearises about the first pass's estimates (the increments are compensated with them, the
/// turntable angles read with their delay and installation) and keeps the same prior, so only
/// the attitude is fed back and the parameter errors stay in the filter state.
pub fn estimate_from(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    turntable: Option<AngleRecords>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    estimate_from_kept(config, layout, imu, turntable, &mut None, progress)
}

/// [`estimate_from`] with the program kept in `program` for fits of the same configuration
/// (the model-extension loop's): used when there, else compiled (after the records are read,
/// so that the errors come in the same order) and left there. Only the noise, the model and
/// the held-out segments may differ between the configurations of the fits that share it: a
/// program that `config` reads from the angle records must have been resolved into it.
pub(crate) fn estimate_from_kept(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    turntable: Option<AngleRecords>,
    program: &mut Option<turntable::program::Program>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let mut scan = scan_imu(imu, config.filter.imu_rate_hz, Spacing::Fixed, progress)?;
    let imu_start = scan.span.0 - 1.0 / config.filter.imu_rate_hz;
    let resolved =
        crate::motion::angles_program::resolve_program(config, turntable, Some(imu_start))?;
    let config = resolved.as_ref().unwrap_or(config);
    let program = match program {
        Some(p) => p.clone(),
        None => program.insert(config.program()?).clone(),
    };
    let plan = Plan::of(config);
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
    let first = first_linearisation_point(config, &plan, layout, &scan, &motion);
    let inp = PassInputs {
        config,
        plan: &plan,
        layout,
        turntable: tt_setup.as_ref(),
        scan: &scan,
        motion: &motion,
    };
    let mut estimate = iterate_passes(&inp, imu, first, first_pass_feedback(config), progress)?;
    estimate.carried_terms = carried;
    Ok(estimate)
}

/// What the first pass from the prior feeds back: everything (closed loop), except in a fit
/// with held-out measurements, where only the attitude is. A held-out stretch leaves the
/// attitude unaided for a whole segment; closed loop, the first update after it moved the
/// parameters by what the stretch's drift had built up and fed that back (a run hiding a
/// g-sensitivity the model lacked diverged: specific-force innovations of 10 m/s^2).
fn first_pass_feedback(config: &RunConfig) -> Feedback {
    match config.filter.hold_out_every {
        Some(_) => Feedback::Attitude,
        None => Feedback::All,
    }
}

/// Calibrate a recording without a program or turntable angles: the unit rests in several
/// orientations (`rests`, on the IMU clock, in time order) and is turned between them in any
/// way. The same filter as for a program ([`estimate_from`]), with the specific force measured
/// only where every step of a window lies in a rest (less [`crate::motion::rests::REST_MARGIN_S`] at
/// both ends), the start attitude levelled in the first rest (and gyrocompassed where the gyros
/// resolve the Earth rate), and the attitude carried by the gyros through every motion
/// ([`crate::motion::rests`]). The layout must be an IMU-only one.
///
/// `coarse` is where the first pass starts: the totals of the instrument parameters (in the
/// layout's order), or `None` for the prior means. Units whose errors are large (per-cent scale
/// factors, degrees per second of bias) need one ([`calibrate_rests`] makes it).
pub fn estimate_at_rests(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
    coarse: Option<&[f64]>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let recording = Recording { rests, turns };
    let plan = Plan::of(config);
    rests_estimate(config, &plan, layout, imu, recording, coarse, progress)
}

/// The rests and known turns of a recording without a program.
#[derive(Clone, Copy)]
struct Recording<'a> {
    /// The rests, on the IMU clock, in time order.
    rests: &'a [Rest],
    /// Known turns between them.
    turns: &'a [crate::motion::rests::Turn],
}

/// [`estimate_at_rests`] with its plan resolved.
fn rests_estimate(
    config: &RunConfig,
    plan: &Plan,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    recording: Recording,
    coarse: Option<&[f64]>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let rests = recording.rests;
    if layout.install.is_some() {
        return Err(EstimateError::Rests {
            file: imu.file().to_string(),
            source: RestError::WithTurntable,
        });
    }
    let mut scan = scan_imu(imu, config.filter.imu_rate_hz, Spacing::Jittered, progress)?;
    check_recording_of_rests(config, plan, &scan, rests, imu.file())?;
    scan.program_start = scan.span.0 - 1.0 / config.filter.imu_rate_hz;
    scan.program_start_found = false;
    let (motion, first_point) = motion_at_rests(config, plan, layout, &scan, recording, coarse)
        .map_err(|source| EstimateError::Rests {
            file: imu.file().to_string(),
            source,
        })?;
    let feedback = first_feedback_at_rests(config, &motion, first_point.is_some());
    let inp = PassInputs {
        config,
        plan,
        layout,
        turntable: None,
        scan: &scan,
        motion: &motion,
    };
    iterate_passes(&inp, imu, first_point, feedback, progress)
}

/// The extended pass of the score tests ([`score_pass`]) for a fit `est` of a recording of
/// rests in `data` made with `config` and `layout`: linearised about the fit's last estimates,
/// with its motion, priors and held-out rests. `calibrate` makes it once, after the noise fixed
/// point settles (each fit of the fixed point would otherwise make its own). Nothing to do for
/// a fit that kept no replay.
pub fn score_rests(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    est: &mut Estimate,
) -> Result<(), EstimateError> {
    let Some(replay) = est.replay.take() else {
        return Ok(());
    };
    let plan = Plan::of(config);
    let rate = config.filter.imu_rate_hz;
    let mut scan = scan_imu(imu, rate, Spacing::Jittered, &mut |_, _| {})?;
    scan.program_start = scan.span.0 - 1.0 / rate;
    scan.program_start_found = false;
    let mut scored = config.clone();
    scored.filter.score_terms = true;
    let inp = PassInputs {
        config: &scored,
        plan: &plan,
        layout,
        turntable: None,
        scan: &scan,
        motion: &replay.motion,
    };
    let tilt_walks = gyro_noise_walks_the_tilt(config, &plan, scan.n as f64 / rate);
    score_pass::attach(&inp, imu, Some(&replay.nominal), tilt_walks, est);
    est.replay = Some(replay);
    Ok(())
}

/// The checks of a recording of rests before any filter: the records' mean rate is the
/// configured one, the gyros are alive, the specific force's magnitude is within what the
/// priors allow, and the rests lie within the records.
fn check_recording_of_rests(
    config: &RunConfig,
    plan: &Plan,
    scan: &Scan,
    rests: &[Rest],
    file: &str,
) -> Result<(), EstimateError> {
    let dt = 1.0 / config.filter.imu_rate_hz;
    // Jittered stamps are integrated as they are, but their mean rate must be the configured
    // one: the filter's transitions and the Earth rate step at it.
    let mean_dt = (scan.span.1 - scan.span.0) / (scan.n - 1) as f64;
    if (mean_dt / dt - 1.0).abs() > MEAN_INTERVAL_TOLERANCE {
        return Err(IoError::File {
            file: file.to_string(),
            message: format!(
                "the records come every {mean_dt} s on average: expected {dt} s \
                 (filter.imu_rate_hz = {}) within {} %",
                config.filter.imu_rate_hz,
                100.0 * MEAN_INTERVAL_TOLERANCE
            ),
        }
        .into());
    }
    check_gyros_alive(&scan.bins, true, file)?;
    let g = plan.gravity_m_s2;
    // Three sigma of what the priors allow the magnitude to be off by.
    let p = plan.priors;
    let tol = 3.0 * (p.accel_scale + p.accel_bias / g);
    check_specific_force_within(&scan.bins, g, tol, file)?;
    crate::motion::rests::check_rests(rests, scan.span.0 - dt, dt).map_err(|source| {
        EstimateError::Rests {
            file: file.to_string(),
            source,
        }
    })
}

/// What the unit did on a recording of rests: its rests, those less their margins, the start
/// attitude levelled in the first (and gyrocompassed where the gyros resolve the Earth rate)
/// about the coarse start or the prior means, the known turns in time order. With a coarse
/// start also the point the first pass linearises about: the coarse start, from the start
/// attitude levelled with it.
fn motion_at_rests(
    config: &RunConfig,
    plan: &Plan,
    layout: &StateLayout,
    scan: &Scan,
    recording: Recording,
    coarse: Option<&[f64]>,
) -> Result<(Motion, Option<Nominal>), RestError> {
    let Recording { rests, turns } = recording;
    let usable = crate::motion::rests::usable(rests);
    let first = usable.first().copied().ok_or(RestError::None)?;
    let pri = layout.prior_sigma();
    let instrument = StateLayout::INSTRUMENT..StateLayout::INSTRUMENT + layout.n_instrument();
    let p0 = match coarse {
        Some(c) if c.len() == instrument.len() => c.to_vec(),
        Some(c) => {
            return Err(RestError::CoarseStart {
                got: c.len(),
                expected: instrument.len(),
            });
        }
        None => vec![0.0; instrument.len()],
    };
    let align = crate::motion::rests::align_in_rest(
        &scan.bins,
        &first,
        &plan.site,
        &layout.model,
        &p0,
        &pri[instrument.clone()],
        config.gyro_psd(),
        config.accel_psd(),
    )
    .ok_or(RestError::NoData {
        t0: first.t0,
        t1: first.t1,
    })?;
    let first_point = coarse.map(|_| {
        let mut totals = vec![0.0; layout.dim()];
        totals[instrument.clone()].copy_from_slice(&p0);
        Nominal {
            totals,
            c_start: align.c_start,
        }
    });
    let mut turns = turns.to_vec();
    turns.sort_by(|a, b| a.t0.total_cmp(&b.t0));
    let motion = Motion::Rests {
        rests: rests.to_vec(),
        usable,
        align,
        coarse: coarse.map(<[f64]>::to_vec),
        turns,
    };
    Ok((motion, first_point))
}

/// What the first pass over a recording of rests feeds back: the tilt alone from a coarse
/// start or where the heading is free (not gyrocompassed), else [`first_pass_feedback`].
fn first_feedback_at_rests(config: &RunConfig, motion: &Motion, coarse_start: bool) -> Feedback {
    let heading_free = match motion {
        Motion::Rests { align, .. } => !align.gyrocompassed,
        Motion::Program(_) => false,
    };
    // A coarse start is good enough to linearise the parameters about, not to feed the
    // poorly observed ones back as the first updates move them (closed loop from the Xsens
    // recording's coarse start, the vertical accelerometer's bias and scale factor went to
    // -8.6 m/s^2 and 0.87 within 7 s of its first rest). Nor the heading, which a unit that
    // needs a coarse start does not gyrocompass: its linear estimate, with a prior sigma of
    // pi, turned the trajectory by radians, and the first updates after each hand turn of the
    // Xsens recording came 1 to 7 degrees off (first-pass mean NIS 370 with the g-sensitivity
    // in the model, against 3.2 feeding back the tilt alone); with one rest's measurements
    // held out the error reached 12 degrees at the next rest and the passes diverged.
    // The same holds without a coarse start wherever the heading is free: a tactical-grade
    // unit (gyro-bias prior 10 deg/h, paper's other priors) on a recording turned both ways
    // about every axis (tests/tests/rests_loop.rs) had a first closed-loop pass at a mean NIS
    // of 167 on a clean run (seed 793), and the passes after it wandered for five passes
    // before they found the solution; with a walk in the data they never did.
    if coarse_start || heading_free {
        Feedback::Tilt
    } else {
        first_pass_feedback(config)
    }
}

/// [`estimate_at_rests`] with a coarse start where the priors call for
/// one ([`needs_coarse_start`]): the batch fit of [`crate::motion::free_motion`] (the paper's 21
/// parameters from the rests' mean specific forces and the rotations between them), whose
/// values the filter's first pass linearises about. Without it the first closed-loop pass
/// runs away on a consumer-grade unit: on the shipped Xsens recording the accelerometer bias
/// and scale factor of the vertical axis, which one rest cannot tell apart, went to
/// -19.8 m/s^2 and +2.0 within the first rest, and the filter diverged after the first turn.
pub fn calibrate_rests(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let coarse = coarse_start_at_rests(config, layout, imu, rests, turns)?;
    estimate_at_rests(
        config,
        layout,
        imu,
        rests,
        turns,
        coarse.as_deref(),
        progress,
    )
}

/// The coarse start of [`calibrate_rests`] where the priors call for one
/// ([`needs_coarse_start`]), from the rests the fit does not hold out; `None` otherwise.
pub(crate) fn coarse_start_at_rests(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
) -> Result<Option<Vec<f64>>, EstimateError> {
    if !needs_coarse_start(config) {
        return Ok(None);
    }
    // A held-out rest is not seen by the coarse start either: its values are the prior
    // mean of the passes.
    let fitted: Vec<Rest> = rests
        .iter()
        .enumerate()
        .filter(|(i, _)| !crate::motion::rests::held_out(*i, config.filter.hold_out_every))
        .map(|(_, r)| *r)
        .collect();
    let plan = Plan::of(config);
    Ok(Some(coarse_start(&plan, layout, imu, &fitted, turns)?))
}

/// Whether the priors are wide enough that the first pass needs a coarse start: a gyro or
/// accelerometer scale factor above 1 %, a misalignment above 10 arcmin, a gyro bias above
/// 0.1 deg/s or an accelerometer bias above 0.1 m/s^2. The paper's priors (1e-3, 3 arcmin,
/// 0.5 deg/h, 0.02 m/s^2) need none (tests/tests/rests.rs).
pub fn needs_coarse_start(config: &RunConfig) -> bool {
    let p = &config.priors;
    p.gyro_scale > 0.01
        || p.accel_scale > 0.01
        || p.gyro_misalignment_arcmin > 10.0
        || p.accel_misalignment_arcmin > 10.0
        || p.gyro_bias_deg_h > 360.0
        || p.accel_bias_m_s2 > 0.1
}

/// The coarse start of [`calibrate_rests`]: the batch fit's values of the paper's parameters
/// (by name; the extension terms at zero).
fn coarse_start(
    plan: &Plan,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
) -> Result<Vec<f64>, EstimateError> {
    use crate::motion::free_motion::{CoarseSettings, coarse_fit};
    let file = imu.file().to_string();
    // The rests and turns on the grouped records: a rest's groups are those that lie wholly in
    // it, a turn's those that hold any of it (a group reaches up to COARSE_GROUP_S into the
    // rest before): `Rest::records`, `Turn::records`. Held: the batch fit integrates them
    // about 25 times an iteration (a tenth of the records at 100 Hz: 7 bytes a record).
    let grouped = coarse_records(imu)?;
    let data = &grouped;
    // The paper's 21 parameters only: the terms beyond them start at zero. A consumer unit's
    // g-sensitivity turns its attitude by degrees in a hand turn, but the first pass feeds
    // back only the tilt, which each rest's first window corrects (with the batch fit's
    // g-sensitivity and asymmetry in the coarse start the Xsens and Ferraris results moved by
    // hundredths of their sigmas, and the start took twice as long: 0.47 against 0.24 s of
    // CPU on a 324-s, 200-Hz recording).
    let settings = CoarseSettings {
        gravity_m_s2: plan.gravity_m_s2,
        priors: plan.priors,
    };
    let fit = coarse_fit(data, rests, turns, &settings).map_err(|e| EstimateError::Rests {
        file,
        source: RestError::CoarseFit(e.to_string()),
    })?;
    let names = layout.entries();
    Ok(
        (StateLayout::INSTRUMENT..StateLayout::INSTRUMENT + layout.n_instrument())
            .map(|i| {
                fit.parameters
                    .iter()
                    .find(|p| p.name == names[i].name)
                    .map_or(0.0, |p| p.value)
            })
            .collect(),
    )
}

/// How far the mean record interval of a recording of rests may be from the configured one.
const MEAN_INTERVAL_TOLERANCE: f64 = 0.01;

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

/// The passes over the data: a first pass from `first` (or the prior) that feeds back
/// `first_feedback` (everything: closed loop), then passes
/// linearised about the one before until no parameter moves by more than
/// [`CONVERGED_SIGMA`]; the second-order specific-force error is then carried into the
/// covariance through the final pass's sensitivity to a residual offset.
fn iterate_passes(
    inp: &PassInputs,
    imu: &mut dyn ImuSource,
    first: Option<Nominal>,
    first_feedback: Feedback,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let PassInputs {
        config,
        layout,
        motion,
        ..
    } = *inp;
    let n = inp.scan.n;
    // Later passes keep their trajectory on a program. On a recording of rests they feed the
    // tilt back: their trajectory is the pass before's, integrated with its estimates, and the
    // gyro noise of a MEMS unit (120 deg/h in a 1-s average) walks its tilt by about a degree
    // over nine minutes, whose second-order specific-force error `-g |beta_h|^2 / 2` read as a
    // vertical accelerometer scale factor 3e-5 low on every consumer-grade run (3 sigma; NEES
    // 75 per run for 24 states, tests/tests/rests.rs; 29 with the tilt fed back). The heading
    // is not fed back: feeding the whole attitude back diverged on those runs, and the
    // heading, which such a unit cannot gyrocompass, does not enter the specific force at rest.
    // Every pass carries a constant copy of the start attitude error, so that the next pass can
    // start from the estimate of the start attitude (a fixed-point smoother).
    let (own, smoother) = (*inp, layout.with_start_attitude());
    let s = smoother.start_attitude.expect("set by with_start_attitude");
    let inp = PassInputs {
        layout: &smoother,
        ..*inp
    };
    // Recordings of rests may carry per-cent errors, about which the linearised model converges
    // more slowly (a consumer-grade simulated run: NEES 79 after four passes, 40 after eight).
    let (max_passes, converged) = match motion {
        Motion::Program(_) => (MAX_PASSES, CONVERGED_SIGMA),
        Motion::Rests { .. } => (MAX_PASSES_RESTS, CONVERGED_SIGMA_RESTS),
    };
    let total = (1 + max_passes) * n;
    let tilt_walks =
        gyro_noise_walks_the_tilt(config, inp.plan, n as f64 / config.filter.imu_rate_hz);
    let mut nominal = first;
    let mut shift = f64::INFINITY;
    let mut pass = 0;
    let mut sensitivity;
    let mut estimate = loop {
        let done = (1 + pass) * n;
        let feedback = if pass == 0 {
            first_feedback
        } else if matches!(motion, Motion::Rests { .. }) && tilt_walks {
            Feedback::Tilt
        } else {
            Feedback::None
        };
        let (est, c_start, sens) = run_pass(
            &inp,
            imu,
            nominal.as_ref(),
            feedback,
            nominal.is_some(),
            &mut |j| progress(done + j, total),
        )?;
        sensitivity = sens;
        pass += 1;
        let mut beta = Vector3::new(est.values[s], est.values[s + 1], est.values[s + 2]);
        // A start heading the data do not resolve is not moved: its linear estimate, with a
        // sigma near a radian, reached +-3 rad on a consumer-grade recording of rests and
        // turned the next pass's heading half a turn, the one after back (a period-2 cycle of
        // the passes at 0.5 sigma in the gyro biases, all eight passes run). Tilt is always
        // resolved by the first rest.
        if est.cov[(s + 2, s + 2)].sqrt() > HEADING_UNRESOLVED_RAD {
            beta.z = 0.0;
        }
        if let (Some(prev), true) = (&nominal, pass > 1) {
            shift = (StateLayout::INSTRUMENT..layout.dim())
                .map(|i| (est.values[i] - prev.totals[i]).abs() / est.cov[(i, i)].sqrt())
                .fold(0.0, f64::max);
        }
        nominal = Some(Nominal {
            totals: est.values[..layout.dim()].to_vec(),
            c_start: exp_so3(&beta) * c_start,
        });
        if pass == max_passes || shift < converged {
            break est;
        }
    };
    // The final pass carried its sensitivity to a constant specific-force residual offset
    // when it was linearised about a pass before (or the coarse start).
    if let Some(sens) = &sensitivity {
        consider::second_order_accel(config, &smoother, &mut estimate, sens);
    }
    progress(total, total);
    estimate.truncate(layout.dim());
    score_pass::attach(&own, imu, nominal.as_ref(), tilt_walks, &mut estimate);
    estimate.replay = nominal.map(|n| Replay::boxed(motion, n));
    estimate.stats.passes = pass;
    estimate.stats.first_pass_shift_sigma = shift;
    Ok(estimate)
}

/// The start heading's posterior sigma above which a pass does not move the next pass's start
/// heading (rad): the gyrocompassing threshold of [`crate::motion::rests`].
const HEADING_UNRESOLVED_RAD: f64 = crate::motion::rests::GYROCOMPASS_MAX_SIGMA_RAD;

/// Length of the record groups of the coarse start (s).
const COARSE_GROUP_S: f64 = 0.1;

/// The records of `data` combined in groups of about [`COARSE_GROUP_S`], for the coarse start:
/// the batch fit integrates every record about 25 times per Gauss-Newton iteration (a central
/// difference per gyro parameter), which was most of a consumer-grade calibration's time (0.47 s
/// of CPU for a 324-s, 200-Hz recording: 150 times `wc -l`). A group's rotation is the exact
/// product of its records' raw rotations, its velocity increment their sum, stamped with its
/// last record's time. The calibration is then applied to the group rather than to each record:
/// the difference is the commutator of the calibration error with the rotation within a group,
/// at 100 deg/s and 5 % about 8e-4 rad per 0.1-s group, well inside the linear reach of the
/// filter passes that follow (they see every record). From 50 ms to 0.1 s the coarse start's
/// share of a `calibrate --free-motion` of that recording went from 18 % to about 9 % of its
/// CPU, and the Xsens and Ferraris results moved by hundredths of their sigmas.
fn coarse_records(imu: &mut dyn ImuSource) -> Result<ImuData, IoError> {
    let mut chunk = Vec::new();
    let dt = sins_model::timing::median_interval_streamed(|visit| {
        crate::io::source::read_records(imu, &mut chunk, &mut |r, _| {
            visit(r.t);
            true
        })
    })?;
    let size = if dt.is_finite() && dt > 0.0 {
        ((COARSE_GROUP_S / dt).round() as usize).max(1)
    } else {
        1
    };
    let increments = matches!(imu.kind(), ImuKind::Increments);
    let mut records = Vec::with_capacity(imu.len_hint().unwrap_or(0) / size + 1);
    if size == 1 {
        // The records as they are.
        crate::io::source::read_records(imu, &mut chunk, &mut |r, _| {
            records.push(*r);
            true
        })?;
        return Ok(ImuData {
            kind: imu.kind(),
            records,
        });
    }
    // The open group: its rotation, velocity increment, last stamp and records; the stamp
    // before it.
    let mut group = (Matrix3::identity(), Vector3::zeros(), f64::NAN, 0usize);
    let mut t_prev = f64::NAN;
    let mut last: Option<ImuRecord> = None;
    let close = |records: &mut Vec<ImuRecord>,
                 c: &Matrix3<f64>,
                 dv: &Vector3<f64>,
                 last: &ImuRecord,
                 t_prev: f64| {
        let span = if increments { 1.0 } else { last.t - t_prev };
        records.push(ImuRecord {
            t: last.t,
            gyro: (log_so3(c) / span).into(),
            accel: (dv / span).into(),
            temp: last.temp,
        });
    };
    crate::io::source::read_records(imu, &mut chunk, &mut |r, _| {
        if last.is_none() {
            t_prev = r.t - dt;
        }
        let (c, dv, t0, n) = &mut group;
        if *n == 0 {
            (*c, *dv, *t0) = (Matrix3::identity(), Vector3::zeros(), t_prev);
        }
        let h = if increments { 1.0 } else { r.t - *t0 };
        *c *= exp_so3(&(Vector3::from(r.gyro) * h));
        *dv += Vector3::from(r.accel) * h;
        *t0 = r.t;
        *n += 1;
        last = Some(*r);
        if *n == size {
            close(&mut records, c, dv, r, t_prev);
            t_prev = r.t;
            *n = 0;
        }
        true
    })?;
    if let (Some(r), true) = (last, group.3 > 0) {
        close(&mut records, &group.0, &group.1, &r, t_prev);
    }
    Ok(ImuData {
        kind: imu.kind(),
        records,
    })
}

/// Whether the gyro noise walks the tilt of a trajectory integrated over `run_s` far enough
/// that its second-order specific-force error (`g sigma^2 / 2`, `sigma^2 = q run_s`) exceeds
/// a tenth of the noise of one specific-force measurement: then later passes on a recording of
/// rests feed the tilt back ([`Feedback::Tilt`]). A MEMS gyro (120 deg/h in a 1-s average)
/// over nine minutes: 9e-4 m/s^2 against 1.2e-3; the paper's (0.1 deg/h): 6e-10 against 1e-3.
/// Not on every recording: on one whose configured accelerometer noise is ten times too low
/// (crates/sins-calib/tests/rests.rs) the fed-back tilt ran away (mean NIS 6.4e6 against 281
/// without).
fn gyro_noise_walks_the_tilt(config: &RunConfig, plan: &Plan, run_s: f64) -> bool {
    let g = plan.gravity_m_s2;
    let second_order = 0.5 * g * config.gyro_psd() * run_s;
    let one_measurement = (config.accel_psd() * config.filter.accel_rate_hz).sqrt();
    second_order > 0.1 * one_measurement
}

/// Find (or check) where the program starts on the IMU clock. A program that never turns has
/// no start to find: it is taken to start with the data.
fn locate_program(
    config: &RunConfig,
    plan: &Plan,
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

/// Set by [`force_baseline_instructions`].
static BASELINE_ONLY: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Run the IMU steps of every later estimation in this process with the baseline instruction
/// set only (`true`), or with the best the processor has (`false`, the default). For checking
/// that the paths give the same bits: the steps are compiled for each (AVX2 and the baseline on
/// x86-64) and chosen at run time.
pub fn force_baseline_instructions(on: bool) {
    BASELINE_ONLY.store(on, std::sync::atomic::Ordering::Relaxed);
}

/// IMU records through [`Pass::step`], compiled for every instruction set pulp dispatches to
/// (on x86-64 AVX2 with FMA, and the baseline; NEON on aarch64) and run with the one the
/// processor has: `step` and what it calls are inlined into [`pulp::WithSimd::with_simd`], which
/// pulp monomorphises inside a function with those target features (no unsafe code here). Rust
/// does not contract `a * b + c` into a fused multiply-add, so every path gives the same bits.
/// (A closure handed to `dispatch` would not do: pulp inlines the call, not the closure's body.)
struct Steps<'p, 'a, 'c> {
    pass: &'p mut Pass<'a>,
    chunk: &'c [(crate::io::ImuRecord, usize)],
}

impl pulp::WithSimd for Steps<'_, '_, '_> {
    type Output = Result<(), EstimateError>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Self::Output {
        for (rec, line) in self.chunk {
            self.pass.step(rec, *line)?;
        }
        Ok(())
    }
}

/// Passes over the data at most: the first closed loop, each further one linearised about the
/// one before (parameters and start attitude).
const MAX_PASSES: usize = 4;

/// Most passes over a recording of rests ([`estimate_at_rests`]).
const MAX_PASSES_RESTS: usize = 8;

/// A pass whose estimates moved less than this (posterior sigmas, largest over the parameters)
/// from the pass before ends the iteration.
const CONVERGED_SIGMA: f64 = 0.02;

/// [`CONVERGED_SIGMA`] on a recording of rests. Its passes contract by a factor of about ten
/// each (largest shifts 0.17, 0.020, 0.0019 sigma on the 324-s consumer-grade recording of
/// docs/performance.md; 0.50, 0.027, 0.004 on the shipped Xsens recording), so a pass that
/// moved less than this leaves the next one to move less than a hundredth of a sigma; at 0.02
/// both recordings ran a fourth pass for that, a seventh of the whole job's CPU time.
const CONVERGED_SIGMA_RESTS: f64 = 0.05;

/// The turntable side of the estimation, set up once for every pass: the records checked
/// against the IMU span and the clock relation, their median spacing and rate.
struct TurntableSetup<'a> {
    records: AngleRecords<'a>,
    clock: ClockConfig,
    median_interval: f64,
    /// Record rate on the IMU clock (Hz).
    record_rate_hz: f64,
    /// One sample per record rather than one per IMU step ([`AngleReader::per_record`]).
    per_record: bool,
    /// Variance of one angle record (rad^2).
    angle_var: f64,
    rate_changes: RateChanges,
}

impl<'a> TurntableSetup<'a> {
    /// Check the records of `file` against the IMU span and the clock relation.
    fn new(
        config: &RunConfig,
        tt: AngleRecords<'a>,
        scan: &Scan,
        program: &turntable::program::Program,
    ) -> Result<Self, EstimateError> {
        let clock = config.clock;
        let dt = 1.0 / config.filter.imu_rate_hz;
        let file = tt.file();
        let summary = tt.summary();
        if summary.count == 0 {
            return Err(IoError::File {
                file: file.to_string(),
                message: "expected turntable records, found none".into(),
            }
            .into());
        }
        let span = summary.span;
        check_overlap(
            (scan.span.0 - dt, scan.span.1),
            (clock.imu_time(span.0), clock.imu_time(span.1)),
            file,
        )?;
        let med = summary.median_interval;
        if !(med.is_finite() && med > 0.0) {
            return Err(IoError::File {
                file: file.to_string(),
                message: "expected at least two turntable records".into(),
            }
            .into());
        }
        let record_rate_hz = (1.0 + clock.turntable_rate_error) / med;
        // The delay is searched within its prior (three sigma).
        // About two thousand records spread over the file are plenty.
        check_turntable_clock(
            &tt.clock_sample(),
            &clock,
            program,
            scan.program_start,
            3.0 * config.priors.tau_s,
        )
        .map_err(|source| EstimateError::TurntableClock {
            file: file.to_string(),
            source,
        })?;
        Ok(Self {
            records: tt,
            clock,
            median_interval: med,
            record_rate_hz,
            per_record: 1.0 / record_rate_hz > 2.0 * dt,
            angle_var: config.angle_psd() * record_rate_hz,
            rate_changes: RateChanges::new(program),
        })
    }

    /// The reader of one pass, for a program starting at `program_start` (IMU clock).
    fn reader(&self, program_start: f64) -> Result<AngleReader<'_>, IoError> {
        Ok(AngleReader {
            interp: AngleInterpolator::new(
                self.records.window()?,
                self.clock,
                self.median_interval,
            ),
            rate_changes: &self.rate_changes,
            program_start,
            per_record: self.per_record,
            rate_change_hint: 0,
        })
    }
}

/// The start attitude the prior is about, and the prior covariance of all states. With the
/// turntable angles (or the `independent` attitude prior of the paper's analysis) the start
/// attitude is the program's with the nominal mounting (`c_nominal`) and its error is tied to the
/// installation misalignment ([`initial_covariance`]). Without them it comes from the
/// alignment to the program's rotations where the program turns about two axes
/// ([`crate::motion::align`]), with the error tied to the gyro parameters.
fn start_prior(
    config: &RunConfig,
    plan: &Plan,
    layout: &StateLayout,
    scan: &Scan,
    motion: &Motion,
    install_hat: &Vector3<f64>,
) -> (Matrix3<f64>, DMatrix<f64>) {
    let program = match motion {
        Motion::Program(program) => program,
        Motion::Rests { align, .. } => {
            let p = initial_covariance(config, layout, &align.c_start);
            let mut p = crate::motion::rests::rest_covariance(&p, align);
            crate::model::layout::copy_start_attitude(&mut p, layout);
            return (align.c_start, p);
        }
    };
    let dt = 1.0 / config.filter.imu_rate_hz;
    let (k0, _) = program.state(scan.span.0 - dt - scan.program_start);
    let c_nominal = c_platform_to_base(&k0);
    // The start attitude error is tied to the installation error as a perturbation of the
    // mounting about its linearisation point: C_true = C_p exp(dz_hat) exp(d) gives
    // beta_0 = C_p exp(dz_hat) d + eps, so the correlation is with the attitude of that mounting,
    // not the nominal one (the two differ by dz_hat x d, 1e-3 rad for degree-level mountings,
    // six times the sigma of eps; with the nominal one a static run's installation heading came
    // out 6 sigma off).
    let c_linearised = c_nominal * exp_so3(install_hat);
    let nominal = || (c_nominal, initial_covariance(config, layout, &c_linearised));
    if layout.install.is_some() || config.filter.attitude_prior == AttitudePrior::Independent {
        return nominal();
    }
    let start = scan.program_start;
    aligned_prior(
        config,
        &plan.site,
        layout,
        &scan.bins,
        program,
        start,
        scan.span.0 - dt,
    )
    .unwrap_or_else(nominal)
}

/// The point a pass linearises about: the estimates of the pass before.
#[derive(Clone)]
struct Nominal {
    /// A full state vector of totals (attitude entries unused).
    totals: Vec<f64>,
    /// The estimate of the start attitude (body to ENU).
    c_start: Matrix3<f64>,
}

/// The point the first pass starts from. With the turntable angles, the mounting fitted to the
/// program's directions ([`fit_mounting`]: levelling where the platform rests, the rotation axes
/// where it turns), so that the first pass does not linearise about a start attitude and an
/// installation misalignment that are degrees off (their products with the other errors misled
/// the filter: on a static run it became sure of an installation misalignment that was 1.5 deg
/// off). Without them the start prior itself comes from the program ([`start_prior`]).
fn first_linearisation_point(
    config: &RunConfig,
    plan: &Plan,
    layout: &StateLayout,
    scan: &Scan,
    motion: &Motion,
) -> Option<Nominal> {
    let (Some(k), Motion::Program(program)) = (layout.install, motion) else {
        return None;
    };
    let pri = plan.priors;
    let errors = DirectionErrors {
        gyro_bias: pri.gyro_bias,
        gyro_matrix: pri.gyro_scale.hypot(pri.gyro_misalignment),
        accel_bias: pri.accel_bias,
        accel_matrix: pri.accel_scale.hypot(pri.accel_misalignment),
        mounting: config.install_sigma(),
    };
    let start = scan.program_start;
    let m = fit_mounting(&scan.bins, program, &plan.site, start, &errors)?;
    let dt = 1.0 / config.filter.imu_rate_hz;
    let (k0, _) = program.state(scan.span.0 - dt - start);
    let mut totals = vec![0.0; layout.dim()];
    totals[k..k + 3].copy_from_slice(log_so3(&m).as_slice());
    Some(Nominal {
        totals,
        c_start: c_platform_to_base(&k0) * m,
    })
}

/// The filter at the start of a pass: the prior covariance about the program's start attitude
/// (aligned or from the installation), the prior means of the errors of the linearisation
/// point `totals`, and the start attitude (the program's with the nominal mounting, or the
/// estimate of the pass before), which it returns with the filter.
fn start_filter(
    config: &RunConfig,
    plan: &Plan,
    layout: &StateLayout,
    scan: &Scan,
    motion: &Motion,
    nominal: Option<&Nominal>,
    totals: &[f64],
) -> Result<(kalman::KalmanFilter, Matrix3<f64>), EstimateError> {
    let install_hat = layout.install.map_or(Vector3::zeros(), |k| {
        Vector3::new(totals[k], totals[k + 1], totals[k + 2])
    });
    let (c_program, p0) = start_prior(config, plan, layout, scan, motion, &install_hat);
    let mut filter = prior_filter(&p0).map_err(|source| EstimateError::Filter {
        t: scan.span.0,
        line: 0,
        source,
    })?;
    // The prior means are zero (or a recording's coarse start): as errors of the nominal values
    // they are the prior mean less the nominal value.
    let prior_mean = |k: usize| match motion {
        Motion::Rests {
            coarse: Some(c), ..
        } => c.get(k - StateLayout::INSTRUMENT).copied().unwrap_or(0.0),
        _ => 0.0,
    };
    for (k, v) in totals.iter().enumerate().skip(StateLayout::INSTRUMENT) {
        filter.set_state(k, prior_mean(k) - v);
    }
    // The start attitude: the program's with the nominal mounting, or the estimate of the pass
    // before. The prior is about the program's start attitude, so relative to the estimate the
    // start attitude error (and its copy) has the prior mean `log(C_program C_start^T)`.
    let c0 = nominal.map_or(c_program, |n| n.c_start);
    let beta_prior = log_so3(&(c_program * c0.transpose()));
    for k in 0..3 {
        filter.set_state(k, beta_prior[k]);
        if let Some(s) = layout.start_attitude {
            filter.set_state(s + k, beta_prior[k]);
        }
    }
    Ok((filter, c0))
}

/// The IMU-time intervals whose measurements a fit with `filter.hold_out_every = every` holds
/// out: every `every`-th segment with measurements, counted from 1 (the program's segments;
/// the rests of a recording of rests, whose motions have none).
fn held_out_windows(motion: &Motion, program_start: f64, every: usize) -> Vec<(f64, f64)> {
    let segments = match motion {
        Motion::Program(program) => diagnostics::segments(program, program_start),
        Motion::Rests { rests, .. } => crate::motion::rests::segments(rests)
            .into_iter()
            .filter(|s| s.label.starts_with("rest"))
            .collect(),
    };
    segments
        .iter()
        .enumerate()
        .filter(|(k, _)| crate::motion::rests::held_out(*k, Some(every)))
        .map(|(_, s)| (s.t0, s.t1))
        .collect()
}

/// What [`run_pass`] gives: the estimate, the start attitude the pass used and, when asked
/// for, its sensitivity to a constant specific-force residual offset (`n x 3`).
type PassOutcome = (Estimate, Matrix3<f64>, Option<DMatrix<f64>>);

/// What every pass of a calibration reads: the configuration, the state layout, the turntable
/// side (set up only for a layout with the mounting states: [`estimate_from`]), the scan of
/// the IMU data and what the unit did.
#[derive(Clone, Copy)]
struct PassInputs<'r, 't> {
    config: &'r RunConfig,
    plan: &'r Plan,
    layout: &'r StateLayout,
    turntable: Option<&'r TurntableSetup<'t>>,
    scan: &'r Scan,
    motion: &'r Motion,
}

/// One pass over the data, linearised about `nominal` (the prior means and the program's
/// start attitude if `None`): compensation, turntable reading and start attitude with the
/// nominal values, the prior mean of each error state the prior mean less the nominal value.
/// `feedback` says what the pass feeds back as it goes ([`Feedback`]).
fn run_pass(
    inp: &PassInputs,
    imu: &mut dyn ImuSource,
    nominal: Option<&Nominal>,
    feedback: Feedback,
    track_offset: bool,
    progress: &mut dyn FnMut(usize),
) -> Result<PassOutcome, EstimateError> {
    let angles = match inp.turntable {
        Some(tt) => Some(tt.reader(inp.scan.program_start)?),
        None => None,
    };
    let totals = nominal.map_or_else(|| vec![0.0; inp.layout.dim()], |n| n.totals.clone());
    let (filter, c0) = start_filter(
        inp.config, inp.plan, inp.layout, inp.scan, inp.motion, nominal, &totals,
    )?;
    let engine = pass_engine(inp, filter, track_offset);
    let settings = pass_settings(inp, imu.kind(), feedback);
    let mut pass = set_up_pass(inp, settings, engine, c0, &totals, angles);
    let final_time = run_records(&mut pass, imu, inp.scan.span.0, progress)?;
    let (estimate, offset_sensitivity) = pass_estimate(inp, imu.kind(), final_time, pass.finish());
    Ok((estimate, c0, offset_sensitivity))
}

/// The filter engine of a pass: the linear model of the layout at the IMU step, the schedule
/// of the measurements and their configured noise, the vertical row to second order in the
/// tilt on a recording of rests, and the sensitivity to a specific-force residual offset when
/// `track_offset`.
fn pass_engine(inp: &PassInputs, filter: kalman::KalmanFilter, track_offset: bool) -> Engine {
    let config = inp.config;
    let dt = 1.0 / config.filter.imu_rate_hz;
    let u_enu = inp.plan.site.earth_rate_enu();
    let noise = MeasurementNoise {
        accel_psd: config.accel_psd(),
        angle_var_per_record: inp.turntable.map(|tt| tt.angle_var),
    };
    let model = LinearModel::new(inp.layout, dt, &u_enu, config.gyro_psd());
    let mut engine = Engine::new(filter, model, Schedule::new(config), noise, false);
    engine.vertical_second_order = matches!(inp.motion, Motion::Rests { .. });
    if track_offset {
        engine.offset_sensitivity = Some(crate::model::engine::OffsetSensitivity::new(
            inp.layout.dim(),
            engine.filter.max_measurement_dim(),
        ));
    }
    engine
}

/// The fixed settings of a pass over records of `kind`.
fn pass_settings(inp: &PassInputs, kind: ImuKind, feedback: Feedback) -> PassSettings {
    let config = inp.config;
    let dt = 1.0 / config.filter.imu_rate_hz;
    let site = inp.plan.site;
    PassSettings {
        kind,
        dt,
        inv_dt: 1.0 / dt,
        u_enu: site.earth_rate_enu(),
        f_enu: site.specific_force_at_rest_enu(),
        feedback,
        n_steps: inp.scan.n,
        own_intervals: matches!(inp.motion, Motion::Rests { .. }),
        motion_attitude_noise_rad: config.filter.motion_attitude_noise_deg.to_radians(),
        rest_error_var: config.filter.rest_error_m_s2.powi(2),
        accel_rate_hz: config.filter.accel_rate_hz,
        temp_reference_c: inp.scan.temperature(config).map(|t| t.reference_c),
    }
}

/// The pass at its start: the strapdown from the start attitude `c0`, the linearisation point
/// `totals`, the turntable reader; on a recording of rests the gate of its rests and its known
/// turns; the held-out windows; the motion before the first record where the model takes rate
/// derivatives.
fn set_up_pass<'r>(
    inp: &PassInputs<'r, '_>,
    settings: PassSettings,
    engine: Engine,
    c0: Matrix3<f64>,
    totals: &[f64],
    angles: Option<AngleReader<'r>>,
) -> Pass<'r> {
    // What the pass needs of the run, then the pass.
    let held_out = inp
        .config
        .filter
        .hold_out_every
        .map(|every| held_out_windows(inp.motion, inp.scan.program_start, every));
    let before = inp
        .layout
        .model
        .uses_rate_derivatives()
        .then(|| motion_before(inp, &c0));
    let nav = Strapdown::new(c0, &settings.u_enu, settings.dt);
    let lin = Linearisation::from_totals(inp.layout, totals);
    let mut pass = Pass::new(inp.layout, settings, engine, nav, lin, angles);
    if let Some(tt) = inp.turntable {
        pass.stats.turntable_record_rate_hz = tt.record_rate_hz;
    }
    if let Motion::Rests { usable, turns, .. } = inp.motion {
        pass.rest_gate = Some(crate::motion::rests::RestGate::new(usable.clone()));
        pass.turns = turns.clone();
    }
    if let Some(held_out) = held_out {
        pass.held_out = held_out;
    }
    if let Some((omega_body, f_body)) = before {
        pass.set_motion_before(omega_body, f_body);
    }
    pass
}

/// The motion in the middle of the interval before the first record (body rate and specific
/// force), in the body through the start attitude `c0`: the middle, because the program's
/// start is found to a few microseconds, and a jump at the first record's start must fall
/// after it. A recording of rests starts at rest.
fn motion_before(inp: &PassInputs, c0: &Matrix3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let dt = 1.0 / inp.config.filter.imu_rate_hz;
    let site = inp.plan.site;
    let platform = match inp.motion {
        Motion::Program(program) => {
            let t_before = inp.scan.span.0 - 1.5 * dt - inp.scan.program_start;
            let (k, k_dot) = program.state(t_before);
            turntable::gimbal::platform_rate_base(&k, &k_dot)
        }
        Motion::Rests { .. } => Vector3::zeros(),
    };
    (
        c0.transpose() * (site.earth_rate_enu() + platform),
        c0.transpose() * site.specific_force_at_rest_enu(),
    )
}

/// Every IMU record through the pass, read in chunks of [`PROGRESS_EVERY`] (one call through
/// the source per chunk) and stepped with the best instruction set the processor has
/// ([`Steps`]); `progress` hears the records done. The last record's time (`first_time`
/// without records).
fn run_records(
    pass: &mut Pass,
    imu: &mut dyn ImuSource,
    first_time: f64,
    progress: &mut dyn FnMut(usize),
) -> Result<f64, EstimateError> {
    imu.rewind()?;
    let mut j = 0;
    let mut final_time = first_time;
    let mut chunk = Vec::with_capacity(PROGRESS_EVERY);
    loop {
        imu.next_chunk(&mut chunk, PROGRESS_EVERY)?;
        if chunk.is_empty() {
            break;
        }
        let arch = if BASELINE_ONLY.load(std::sync::atomic::Ordering::Relaxed) {
            pulp::Arch::Scalar
        } else {
            pulp::Arch::new()
        };
        arch.dispatch(Steps {
            pass,
            chunk: &chunk,
        })?;
        if let Some((rec, _)) = chunk.last() {
            final_time = rec.t;
        }
        j += chunk.len();
        progress(j);
    }
    // A streamed angle file that could not be read to the end (changed since it was opened).
    if let Some(e) = pass.angles.as_mut().and_then(|a| a.interp.take_error()) {
        return Err(e.into());
    }
    Ok(final_time)
}

/// The estimate of a finished pass over records of `imu_kind` that ended at `final_time`,
/// its innovations assigned to the motion's segments; and the pass's offset sensitivity.
fn pass_estimate(
    inp: &PassInputs,
    imu_kind: ImuKind,
    final_time: f64,
    result: PassResult,
) -> (Estimate, Option<DMatrix<f64>>) {
    let PassResult {
        values,
        c,
        stats,
        cov,
        mut innovations,
        offset_sensitivity,
    } = result;
    let (scan, layout) = (inp.scan, inp.layout);
    let segments = match inp.motion {
        Motion::Program(program) => diagnostics::segments(program, scan.program_start),
        Motion::Rests { rests, .. } => crate::motion::rests::segments(rests),
    };
    diagnostics::assign_segments(&mut innovations, &segments);
    let (rests, start_alignment) = match inp.motion {
        Motion::Program(_) => (vec![], None),
        Motion::Rests { rests, align, .. } => (rests.clone(), Some(align.clone())),
    };
    let estimate = Estimate {
        names: layout.entries().iter().map(|e| e.name.clone()).collect(),
        units: layout.entries().iter().map(|e| e.unit).collect(),
        values,
        prior_sigma: layout.prior_sigma(),
        cov,
        final_time,
        final_c_body_to_enu: c,
        gravity_m_s2: inp.plan.gravity_m_s2,
        stats,
        imu_span: scan.span,
        imu_kind,
        program_start_s: scan.program_start,
        program_start_found: scan.program_start_found,
        innovations,
        segments,
        rests,
        start_alignment,
        temperature: scan.temperature(inp.config),
        temperature_series: scan
            .temperature
            .as_ref()
            .map(|t| t.series.clone())
            .unwrap_or_default(),
        extended: None,
        extended_error: None,
        carried_terms: Vec::new(),
        replay: None,
    };
    (estimate, offset_sensitivity)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records of a tumbling body at 200 Hz with jittered stamps, as increments and as rates.
    fn tumbling(kind: ImuKind) -> ImuData {
        let mut t = 0.0;
        let records = (0..997)
            .map(|k| {
                let h = 0.005 * (1.0 + 0.2 * ((k as f64) * 0.7).sin());
                t += h;
                let w = [
                    1.5 * (t * 0.9).sin(),
                    -0.8 + 0.3 * t.cos(),
                    2.0 * (t * 0.4).cos(),
                ];
                let f = [0.3 * t.sin(), 0.1, 9.8 + 0.01 * t];
                let scale = if matches!(kind, ImuKind::Increments) {
                    h
                } else {
                    1.0
                };
                ImuRecord {
                    t,
                    gyro: w.map(|x| x * scale),
                    accel: f.map(|x| x * scale),
                    temp: None,
                }
            })
            .collect();
        ImuData { kind, records }
    }

    /// The groups of `size` records of `data` from the records held (the form before they were
    /// read group by group): the reference of [`coarse_records`].
    fn held_groups(data: &ImuData, size: usize) -> Vec<ImuRecord> {
        let dt = sins_model::timing::median_interval_of(data.records.iter().map(|r| r.t));
        let increments = matches!(data.kind, ImuKind::Increments);
        let mut records = Vec::new();
        let mut t_prev = data.records.first().map_or(0.0, |r| r.t - dt);
        for group in data.records.chunks(size) {
            let mut c = Matrix3::identity();
            let mut dv = Vector3::zeros();
            let mut t0 = t_prev;
            for r in group {
                let h = if increments { 1.0 } else { r.t - t0 };
                c *= exp_so3(&(Vector3::from(r.gyro) * h));
                dv += Vector3::from(r.accel) * h;
                t0 = r.t;
            }
            let last = group.last().unwrap();
            let span = if increments { 1.0 } else { last.t - t_prev };
            t_prev = last.t;
            records.push(ImuRecord {
                t: last.t,
                gyro: (log_so3(&c) / span).into(),
                accel: (dv / span).into(),
                temp: last.temp,
            });
        }
        records
    }

    /// The whole rotation and velocity change of the grouped records equal those of the
    /// records (to rounding), for increments and rates alike; the last group is a remainder.
    #[test]
    fn grouped_records_keep_the_rotation_and_the_velocity_change() {
        for kind in [ImuKind::Increments, ImuKind::Rates] {
            let data = tumbling(kind);
            let grouped = coarse_records(&mut MemoryImu::new(&data, "imu.csv")).unwrap();
            // 0.1-s groups of 5-ms records: 20 each.
            assert_eq!(grouped.records.len(), 997usize.div_ceil(20), "{kind:?}");
            // The records read group by group are those of the records held, to the bit.
            assert_eq!(grouped.records, held_groups(&data, 20), "{kind:?}");
            // Both start where the first record's interval starts (one median interval back).
            let dt = sins_model::timing::median_interval_of(data.records.iter().map(|r| r.t));
            let start = data.records[0].t - dt;
            let total = |d: &ImuData| {
                let (mut c, mut dv) = (Matrix3::<f64>::identity(), Vector3::<f64>::zeros());
                let mut t0 = start;
                for r in &d.records {
                    let h = if matches!(d.kind, ImuKind::Increments) {
                        1.0
                    } else {
                        r.t - t0
                    };
                    c *= exp_so3(&(Vector3::from(r.gyro) * h));
                    dv += Vector3::from(r.accel) * h;
                    t0 = r.t;
                }
                (c, dv)
            };
            let ((c1, v1), (c2, v2)) = (total(&data), total(&grouped));
            assert!((c1 - c2).norm() < 1e-12, "{kind:?}: rotation");
            assert!((v1 - v2).norm() < 1e-9 * v1.norm(), "{kind:?}: velocity");
            assert_eq!(
                grouped.records.last().map(|r| r.t),
                data.records.last().map(|r| r.t)
            );
        }
    }
}
