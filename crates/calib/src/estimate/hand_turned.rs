//! A hand-turned recording without a program, a turntable or a configuration: what the filter
//! of a recording of rests ([`crate::estimate::run`]) needs that a laboratory
//! configuration would give, taken from the recording itself, and the held-out figures of
//! [`crate::motion::free_motion`] for its result.
//!
//! - **White noise** ([`white_noise_at_rest`]): the scatter of the 1-s means inside the rests
//!   (each rest's own mean removed), the quantity the configuration's `[noise]` levels are
//!   ("the standard deviation of a 1-s average"). It is what the filter's specific-force
//!   windows see, sensor filters and slow disturbances included; a white-noise density from
//!   the samples (or the Allan curve's slope) understates it where the samples are correlated
//!   (the Xsens recording: 8.4e-4 m/s^2 from the Allan fit, its rests' 1-s means scatter by
//!   about twice that).
//! - **The unit's grade** ([`choose_grade`]): from the measured gyro white noise, made coarser
//!   where the rests' mean rates show gyro biases the grade's priors could not hold. It sets
//!   the priors ([`crate::config::grade_priors`]).
//! - **A configuration** ([`default_config`]): the grade's priors, the site's latitude, the
//!   record rate measured from the time stamps, the measured noise.
//! - **The noise scale and the motion noise** ([`crate::estimate::RunKind::HandTurned`]): the
//!   specific-force level brought to the fit's innovations (up or down), and the attitude noise
//!   of a motion measured from the first window after each motion ([`noise_ml`]).
//! - **The model**: the paper's, plus the terms the caller names (a `diagnose` result's, or the
//!   user's): none is added without evidence.
//! - **The verdict** ([`crate::estimate::verdict::hand_turned_tests`]): with noise the tool set
//!   itself, the innovations' scatter is no test of the model; the held-out rests are. Exit status
//!   3 only where they contradict it.

use crate::check::diagnostics::Innovation;
use crate::config::RunConfig;
use crate::estimate::noise::{MeasuredLevels, variance_ratio};
use crate::io::source::{ImuSource, read_records};
use crate::io::{ImuKind, ImuRecord};
use crate::model::MeasurementKind;
use crate::motion::free_motion::EarthRotation;
use crate::motion::rests::Rest;
use crate::motion::stamps::{RangeWalk, StampCounts};
use nalgebra::{Matrix3, Vector3};
use sins_model::candidates::UnitGrade;
use sins_model::earth::EARTH_RATE;
use sins_model::units::DEG_PER_HOUR;

/// Length of the blocks whose means give the white-noise level (s): the configuration's levels
/// are the standard deviation of a 1-s average.
const BLOCK_S: f64 = 1.0;

/// The attitude noise of a motion (`filter.motion_attitude_noise_deg`) a fit of a hand-turned
/// recording without a configuration starts from, before it is measured
/// ([`noise_ml`]): a navigation-grade unit's gyros carry the attitude through a turn as
/// well as through a rest (0); a tactical unit 0.01 deg; a consumer unit 0.1 deg (the floor the
/// batch fit gave a gravity direction carried from one pose to the next; with it the Ferraris
/// session's turns came to 360 deg within 1 deg).
pub fn start_motion_noise_deg(grade: UnitGrade) -> f64 {
    match grade {
        UnitGrade::Navigation => 0.0,
        UnitGrade::Tactical => 0.01,
        UnitGrade::Consumer => 0.1,
    }
}

/// The largest 1-s gyro white noise (deg/h) of a navigation-grade unit: an angle random walk of
/// 0.017 deg/sqrt(h) (ring lasers and navigation FOGs are at 0.001 to 0.005).
pub const NAVIGATION_MAX_GYRO_NOISE_DEG_H: f64 = 1.0;

/// The largest 1-s gyro white noise (deg/h) of a tactical-grade unit: an angle random walk of
/// 1 deg/sqrt(h) (tactical FOGs and MEMS are at 0.05 to 0.5).
pub const TACTICAL_MAX_GYRO_NOISE_DEG_H: f64 = 60.0;

/// Floors of measured white noise (sigma of a 1-s mean), of the measured level and of the level
/// a fit scales it to: a noise-free recording (a simulation) would otherwise give the filter no
/// measurement noise at all (1e-15 m/s^2 in the rests of this project's simulator). Measured,
/// not derived: on the noise-free navigation-grade 19-position recording of
/// `tests/tests/hand_turned.rs` the filter runs away (mean NIS 1e10 and more) with the
/// specific force's noise at 1e-5 m/s^2 and the gyros' at 0.01 to 0.05 deg/h, and is exact
/// (mean NIS 0.12, its model having no error) at 3e-5 m/s^2 with 0.01 or 0.03 deg/h. Both
/// floors are below a navigation-grade unit's 1-s noise (0.03 to 0.3 deg/h for ring lasers,
/// 1e-4 m/s^2 and more for their accelerometers).
pub const NOISE_FLOOR_GYRO_DEG_H: f64 = 0.01;
/// See [`NOISE_FLOOR_GYRO_DEG_H`] (m/s^2).
pub const NOISE_FLOOR_ACCEL_M_S2: f64 = 3e-5;

/// The grade a recording without a configuration is calibrated at, and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradeChoice {
    /// The grade used: the coarser of the two below.
    pub grade: UnitGrade,
    /// The grade the measured 1-s gyro white noise says
    /// ([`NAVIGATION_MAX_GYRO_NOISE_DEG_H`], [`TACTICAL_MAX_GYRO_NOISE_DEG_H`]).
    pub by_noise: UnitGrade,
    /// The finest grade whose gyro-bias prior holds (at three sigma) the bias the rests show:
    /// the median over the rests of `|mean rate| - Earth rate - 3 sigma of the mean`, a lower
    /// bound of the bias's size (deg/h).
    pub by_rest_rate: UnitGrade,
    /// That lower bound of the gyro bias (deg/h).
    pub rest_rate_excess_deg_h: f64,
}

impl GradeChoice {
    /// One line for reports.
    pub fn describe(&self) -> String {
        format!(
            "{} grade (white noise says {}; the rests' mean rates show gyro biases of at least \
             {:.3} deg/h: {})",
            self.grade.name(),
            self.by_noise.name(),
            self.rest_rate_excess_deg_h,
            self.by_rest_rate.name()
        )
    }
}

/// The grade of a unit from its recording's rests ([`GradeChoice`]).
pub fn choose_grade(at_rest: &RecordsAtRest, noise: &WhiteNoiseAtRest) -> GradeChoice {
    let noise_deg_h = noise.gyro_rad_s / DEG_PER_HOUR;
    let by_noise = if noise_deg_h <= NAVIGATION_MAX_GYRO_NOISE_DEG_H {
        UnitGrade::Navigation
    } else if noise_deg_h <= TACTICAL_MAX_GYRO_NOISE_DEG_H {
        UnitGrade::Tactical
    } else {
        UnitGrade::Consumer
    };
    let mut excess: Vec<f64> = at_rest
        .rests
        .iter()
        .filter_map(|r| {
            let (w, span) = r.mean_rate()?;
            let sigma_mean = noise.gyro_rad_s * (3.0 / span.max(BLOCK_S)).sqrt();
            Some((w.norm() - EARTH_RATE - 3.0 * sigma_mean).max(0.0))
        })
        .collect();
    excess.sort_by(f64::total_cmp);
    let excess = excess.get(excess.len() / 2).copied().unwrap_or(0.0);
    let holds = |g: UnitGrade| 3.0 * crate::config::grade_priors(g).gyro_bias >= excess;
    let by_rest_rate = [UnitGrade::Navigation, UnitGrade::Tactical]
        .into_iter()
        .find(|&g| holds(g))
        .unwrap_or(UnitGrade::Consumer);
    let rank = |g: UnitGrade| match g {
        UnitGrade::Navigation => 0,
        UnitGrade::Tactical => 1,
        UnitGrade::Consumer => 2,
    };
    GradeChoice {
        grade: if rank(by_noise) >= rank(by_rest_rate) {
            by_noise
        } else {
            by_rest_rate
        },
        by_noise,
        by_rest_rate,
        rest_rate_excess_deg_h: excess / DEG_PER_HOUR,
    }
}

/// What a hand-turned recording's configuration takes from its records ([`white_noise_at_rest`],
/// [`choose_grade`], [`default_config`]), read rather than held: the records' count and first
/// and last stamps, and each rest's records less
/// [`REST_MARGIN_S`](crate::motion::rests::REST_MARGIN_S) at both ends ([`Rest::records`]) as the
/// means of their whole seconds and their mean rate. A few numbers per second of rest: the
/// same sums as over the records held, in the same order.
#[derive(Clone, Debug)]
pub struct RecordsAtRest {
    /// Number of records.
    records: usize,
    /// First and last stamps.
    span: Option<(f64, f64)>,
    /// Each rest, in the order given.
    rests: Vec<RestSums>,
}

/// One rest's records: their whole seconds' mean rates and specific forces, and the sums of
/// its mean rate; each record over its own interval (`dt`; one that does not advance is left
/// out).
#[derive(Clone, Debug, Default)]
struct RestSums {
    blocks: Vec<([f64; 3], [f64; 3])>,
    /// The open block: rate and specific force times their intervals, and its span.
    open: ([f64; 3], [f64; 3], f64),
    /// The rate times each interval (an increment as it is) and the span, for the mean rate.
    rate: (Vector3<f64>, f64),
}

impl RestSums {
    fn add(&mut self, kind: ImuKind, r: &ImuRecord, dt: f64) {
        if dt <= 0.0 {
            return;
        }
        let (w, f) = match kind {
            ImuKind::Rates => (r.gyro, r.accel),
            ImuKind::Increments => (r.gyro.map(|x| x / dt), r.accel.map(|x| x / dt)),
        };
        let (sw, sf, span) = &mut self.open;
        for i in 0..3 {
            sw[i] += w[i] * dt;
            sf[i] += f[i] * dt;
        }
        *span += dt;
        if *span >= BLOCK_S - 1e-9 {
            let span = *span;
            self.blocks
                .push((sw.map(|x| x / span), sf.map(|x| x / span)));
            self.open = ([0.0; 3], [0.0; 3], 0.0);
        }
        let g = Vector3::from(r.gyro);
        self.rate.0 += match kind {
            ImuKind::Rates => g * dt,
            ImuKind::Increments => g,
        };
        self.rate.1 += dt;
    }

    /// The mean rate (rad/s) and the span of the records, `None` without any.
    fn mean_rate(&self) -> Option<(Vector3<f64>, f64)> {
        let (sum, span) = self.rate;
        (span > 0.0).then(|| (sum / span, span))
    }
}

impl RecordsAtRest {
    /// The records of `imu` at its `rests`: two readings, one to put the rests on the records
    /// ([`StampCounts`]), one for their sums.
    pub fn read(imu: &mut dyn ImuSource, rests: &[Rest]) -> Result<Self, crate::io::IoError> {
        let inner: Vec<Rest> = rests.iter().map(Rest::less_margins).collect();
        let times = inner.iter().flat_map(|r| [r.t0, r.t1]);
        let counts = StampCounts::read(imu, times, [], f64::NAN)?;
        let ranges: Vec<std::ops::Range<usize>> =
            inner.iter().map(|r| r.records(&counts)).collect();
        let mut sums = vec![RestSums::default(); rests.len()];
        let mut walk = RangeWalk::new(&ranges);
        let kind = imu.kind();
        let (mut k, mut span, mut previous) = (0usize, None, f64::NAN);
        read_records(imu, &mut Vec::new(), &mut |r, _| {
            // A rest's records start at the second record: the interval is to the one before.
            for &i in walk.at(k) {
                sums[i].add(kind, r, r.t - previous);
            }
            span = Some((span.map_or(r.t, |(a, _)| a), r.t));
            previous = r.t;
            k += 1;
            true
        })?;
        Ok(Self {
            records: k,
            span,
            rests: sums,
        })
    }
}

/// The scatter of the 1-s means in the rests ([`WhiteNoiseAtRest`]); each rest less
/// [`REST_MARGIN_S`](crate::motion::rests::REST_MARGIN_S) at both ends, cut into whole
/// seconds, its own mean removed. `None` when no rest holds two whole seconds.
pub fn white_noise_at_rest(at_rest: &RecordsAtRest) -> Option<WhiteNoiseAtRest> {
    let (mut ss_w, mut ss_f, mut dof) = (0.0, 0.0, 0usize);
    for rest in &at_rest.rests {
        let blocks = &rest.blocks;
        let n = blocks.len();
        if n < 2 {
            continue;
        }
        for i in 0..3 {
            let mw = blocks.iter().map(|b| b.0[i]).sum::<f64>() / n as f64;
            let mf = blocks.iter().map(|b| b.1[i]).sum::<f64>() / n as f64;
            ss_w += blocks.iter().map(|b| (b.0[i] - mw).powi(2)).sum::<f64>();
            ss_f += blocks.iter().map(|b| (b.1[i] - mf).powi(2)).sum::<f64>();
        }
        dof += n - 1;
    }
    (dof > 0).then(|| WhiteNoiseAtRest {
        gyro_rad_s: (ss_w / (3 * dof) as f64).sqrt(),
        accel_m_s2: (ss_f / (3 * dof) as f64).sqrt(),
        dof,
    })
}

/// The configuration of a hand-turned recording without one: no program, the priors of
/// `grade` ([`crate::config::grade_priors`]), the site at `latitude_deg` and `height_m`, the record
/// rate of the data (the mean interval), specific-force windows of the whole records nearest
/// one second, `noise` (above [`NOISE_FLOOR_GYRO_DEG_H`] and [`NOISE_FLOOR_ACCEL_M_S2`]) and the
/// grade's starting motion noise ([`start_motion_noise_deg`]). `None` for fewer than two
/// records or a non-positive span.
pub fn default_config(
    at_rest: &RecordsAtRest,
    latitude_deg: f64,
    height_m: f64,
    noise: &WhiteNoiseAtRest,
    grade: UnitGrade,
) -> Option<RunConfig> {
    let (first, last) = at_rest.span?;
    let n = at_rest.records;
    if n < 2 || last <= first {
        return None;
    }
    let rate = (n - 1) as f64 / (last - first);
    let mut c = RunConfig::paper();
    c.program = crate::config::PROGRAM_FROM_ANGLES.to_string();
    c.site.latitude_deg = latitude_deg;
    c.site.longitude_deg = 0.0;
    c.site.height_m = height_m;
    c.set_grade_priors(grade);
    c.noise.gyro_deg_h = (noise.gyro_rad_s / DEG_PER_HOUR).max(NOISE_FLOOR_GYRO_DEG_H);
    c.noise.accel_m_s2 = noise.accel_m_s2.max(NOISE_FLOOR_ACCEL_M_S2);
    c.filter.imu_rate_hz = rate;
    c.filter.accel_rate_hz = rate / (rate * BLOCK_S).round().max(1.0);
    c.filter.turntable_rate_hz = c.filter.accel_rate_hz;
    c.filter.motion_attitude_noise_deg = start_motion_noise_deg(grade);
    Some(c)
}

pub use super::rest_excess::{
    REST_ERROR_MIN_DOF, REST_ERROR_UNASKED_LEVEL, REST_ERROR_UNASKED_MIN_DOF, RestExcess,
    rest_error_m_s2, rest_excess, weigh_rest_excess_unasked,
};

/// The largest motion noise the fit measures (rad, 5.7 deg): a hand turn that leaves the
/// attitude more uncertain than this carries nothing from one rest to the next, and a model
/// that calls for more misses something a noise cannot stand for.
pub const MAX_MOTION_NOISE_RAD: f64 = 0.1;

/// A motion noise below this (rad, 0.2 arcsec) is no different from none.
pub const MOTION_NOISE_NEGLIGIBLE_RAD: f64 = 1e-6;

/// How many fits a hand-turned calibration makes at most to bring measured noise to the data's
/// scatter and measure the motion noise.
pub const MAX_NOISE_FITS: usize = 10;

pub use crate::estimate::noise::{
    EXCESS_LEVEL, GROSS_VARIANCE_RATIO, NoiseSource, ScatterExcess, WhiteNoiseAtRest,
};

/// The noise of a fit measured from its own innovations ([`noise_ml`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseMl {
    /// The factor on the base specific-force level.
    pub accel_factor: f64,
    /// The attitude noise of a motion, one sigma per axis (rad).
    pub motion_sigma_rad: f64,
    /// Specific-force windows behind the factor.
    pub windows: usize,
    /// First windows after a motion behind the motion noise.
    pub motion_windows: usize,
}

/// The specific-force noise scale and the attitude noise of a motion by maximum likelihood on
/// a fit's innovations (the windows it used, the recording's first left out: its tilt prior
/// is levelled from it). A window's innovation covariance is `S = S0 + k^2 R_base + q g^2
/// diag(1, 1, 0) [first window after a motion]`: `R_base = sigma^2 / t I` the white noise of a
/// window of `t` seconds at the measured level `sigma`, scaled by `k^2`; the motion noise, of
/// variance `q` per axis, added to the attitude just before the first window after a motion
/// (the specific force at rest `(0, 0, g)` in ENU turns a tilt `beta` into the horizontal
/// innovation `f x beta`; the heading does not show). `S0`, the part of `S` from the states'
/// own uncertainty, is `S` less both at the values the fit was made with. The likelihood is
/// maximised over `k` (from `min_factor`, which keeps the level at [`NOISE_FLOOR_ACCEL_M_S2`],
/// and at least 1e-3, to 1e4, a misfit far above the noise) and `q >= 0` (a grid in `log sqrt(q)`
/// from 1e-8 to [`MAX_MOTION_NOISE_RAD`], refined by golden section), coordinate by
/// coordinate. Later windows depend on both only through the
/// states after the earlier ones: the estimate is one step of an iteration that
/// `fit_measuring_noise` repeats to a fixed point. `None` without windows.
pub fn noise_ml(
    innovations: &[Innovation],
    rests: usize,
    fitted: (f64, f64),
    base_window_var: f64,
    min_factor: f64,
    g: f64,
) -> Option<NoiseMl> {
    let windows = MlWindows::of(innovations, rests, fitted, base_window_var, g);
    if windows.windows.is_empty() {
        return None;
    }
    let motion_windows = windows.windows.iter().filter(|w| w.2).count();
    let (k, sigma) = windows.maximise(fitted, min_factor, motion_windows > 0);
    Some(NoiseMl {
        accel_factor: k,
        motion_sigma_rad: sigma,
        windows: windows.windows.len(),
        motion_windows,
    })
}

/// The specific-force windows [`noise_ml`] weighs, with what their likelihood needs.
struct MlWindows {
    /// Innovation, `S0` and whether the window is the first after a motion.
    windows: Vec<(Vector3<f64>, Matrix3<f64>, bool)>,
    /// The white-noise variance of a window at the base level.
    base_window_var: f64,
    /// `g^2 diag(1, 1, 0)`: a tilt variance's share of a window's covariance.
    d: Matrix3<f64>,
}

impl MlWindows {
    /// The windows of a fit made at `fitted` (factor, motion sigma in rad), each with `S0`, its
    /// `S` less the noise of both at the fitted values; a window whose `S0` is not positive
    /// definite (rounding) is left out.
    fn of(
        innovations: &[Innovation],
        rests: usize,
        fitted: (f64, f64),
        base_window_var: f64,
        g: f64,
    ) -> Self {
        let (k_fit, sigma_fit) = fitted;
        let d = Matrix3::from_diagonal(&Vector3::new(g * g, g * g, 0.0));
        let mut windows: Vec<(Vector3<f64>, Matrix3<f64>, bool)> = Vec::new();
        let mut last_segment = None;
        let accel = innovations
            .iter()
            .filter(|i| i.kind == MeasurementKind::Accel);
        for inn in accel.skip(1) {
            let first = last_segment != Some(inn.segment);
            last_segment = Some(inn.segment);
            if inn.held_out {
                continue;
            }
            // Rest k is segment 2k ([`crate::motion::rests::segments`]); rest 0 follows no
            // motion.
            let after_motion =
                first && inn.segment > 0 && inn.segment % 2 == 0 && inn.segment < 2 * rests;
            let mut s0 = inn.s - Matrix3::identity() * (k_fit * k_fit * base_window_var);
            if after_motion {
                s0 -= d * (sigma_fit * sigma_fit);
            }
            // Symmetric, and no less than a small part of S (rounding).
            let s0 = (s0 + s0.transpose()) * 0.5;
            if s0.cholesky().is_some() {
                windows.push((inn.nu, s0, after_motion));
            }
        }
        Self {
            windows,
            base_window_var,
            d,
        }
    }

    /// The log-likelihood of the windows at the factor `k` and the motion variance `q`.
    fn log_likelihood(&self, k: f64, q: f64) -> f64 {
        self.part(k, q, None)
    }

    /// [`Self::log_likelihood`] of the windows after a motion (`Some(true)`), of the others
    /// (`Some(false)`), or of all (`None`): at a fixed factor the others' part does not depend
    /// on the motion variance, and the search over it sums it once.
    fn part(&self, k: f64, q: f64, after_motion: Option<bool>) -> f64 {
        let r = Matrix3::identity() * (k * k * self.base_window_var);
        self.windows
            .iter()
            .filter(|w| after_motion.is_none_or(|a| a == w.2))
            .map(|(nu, s0, first)| {
                let s = if *first { s0 + r + self.d * q } else { s0 + r };
                match s.cholesky() {
                    Some(c) => {
                        let l = c.l();
                        let log_det = 2.0 * (0..3).map(|i| l[(i, i)].ln()).sum::<f64>();
                        -0.5 * (nu.dot(&c.solve(nu)) + log_det)
                    }
                    None => f64::NEG_INFINITY,
                }
            })
            .sum()
    }

    /// The factor and the motion sigma (rad) of the largest likelihood, coordinate by
    /// coordinate from `fitted`: the factor in its logarithm from `min_factor` (at least 1e-3)
    /// to 1e4, then (with windows after a motion) the motion sigma on a grid of `10^x` rad,
    /// or none, refined by golden section; four rounds.
    fn maximise(&self, fitted: (f64, f64), min_factor: f64, motions: bool) -> (f64, f64) {
        let (mut k, mut sigma) = (fitted.0.max(1e-3), fitted.1);
        for _ in 0..4 {
            let lk = golden_max(
                &|x: f64| self.log_likelihood(x.exp(), sigma * sigma),
                min_factor.max(1e-3).ln(),
                1e4f64.ln(),
            );
            let k_before = k;
            k = lk.exp();
            if !motions {
                break;
            }
            let sigma_before = sigma;
            sigma = self.best_motion_sigma(k);
            // A round that changed neither would be repeated exactly by the next.
            if (k, sigma) == (k_before, sigma_before) {
                break;
            }
        }
        (k, sigma)
    }

    /// The motion sigma (rad) of the largest likelihood at the factor `k`: `10^x` on a grid
    /// of 0.1 from 1e-8 to [`MAX_MOTION_NOISE_RAD`], or none, then golden section about the
    /// best grid point.
    fn best_motion_sigma(&self, k: f64) -> f64 {
        let rest = self.part(k, 0.0, Some(false));
        let at = |q: f64| rest + self.part(k, q, Some(true));
        let (mut best_x, mut best) = (f64::NEG_INFINITY, at(0.0));
        let mut x = -8.0;
        while x <= MAX_MOTION_NOISE_RAD.log10() + 1e-9 {
            let l = at(10f64.powf(2.0 * x));
            if l > best {
                (best_x, best) = (x, l);
            }
            x += 0.1;
        }
        if !best_x.is_finite() {
            return 0.0;
        }
        10f64.powf(golden_max(
            &|x: f64| at(10f64.powf(2.0 * x)),
            best_x - 0.1,
            best_x + 0.1,
        ))
    }
}

/// The maximum of `f` on `[a, b]` by 40 steps of golden section, each evaluating `f` once
/// (the inner point kept is the next step's other one).
fn golden_max(f: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    const STEPS: usize = 40;
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut e) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fe) = (f(c), f(e));
    for step in 1..=STEPS {
        let last = step == STEPS;
        if fc > fe {
            (b, e, fe) = (e, c, fc);
            c = b - r * (b - a);
            if !last {
                fc = f(c);
            }
        } else {
            (a, c, fc) = (c, e, fe);
            e = a + r * (b - a);
            if !last {
                fe = f(e);
            }
        }
    }
    0.5 * (a + b)
}

/// The mean NIS of the specific-force windows, the recording's first left out (the start
/// tilt's prior is levelled from the same data, so its NIS is small by construction), and the
/// held-out ones. A rest's first window also holds what the motion before it did to the
/// attitude: with the vertical row taken to second order in the tilt
/// ([`crate::model::engine::Engine::vertical_second_order`]) that is a tilt the window measures,
/// and what remains is the unit settling (on the shipped Xsens recording a few first windows are 3
/// to 6 sigma off in the vertical alone), which is part of the scatter the noise level has to
/// carry. (Before the correction those windows were left out: their mean NIS was 55.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InnovationScatter {
    /// Windows counted.
    pub windows: usize,
    /// Their mean NIS.
    pub mean_nis: f64,
}

impl InnovationScatter {
    /// From a fit's innovation log: the windows it used.
    pub fn of(innovations: &[crate::check::diagnostics::Innovation]) -> Self {
        Self::of_kind(innovations, false)
    }

    /// The held-out windows' (predicted, not used).
    pub fn held_out(innovations: &[crate::check::diagnostics::Innovation]) -> Self {
        Self::of_kind(innovations, true)
    }

    fn of_kind(innovations: &[crate::check::diagnostics::Innovation], held_out: bool) -> Self {
        let (mut windows, mut nis) = (0usize, 0.0);
        let accel = innovations
            .iter()
            .filter(|inn| inn.kind == crate::model::MeasurementKind::Accel);
        for inn in accel.skip(1) {
            if inn.held_out != held_out {
                continue;
            }
            let Some(chol) = inn.s.cholesky() else {
                continue;
            };
            nis += inn.nu.dot(&chol.solve(&inn.nu));
            windows += 1;
        }
        Self {
            windows,
            mean_nis: nis / windows.max(1) as f64,
        }
    }
}

/// What a recording of rests is calibrated from: its records (read again for every fit), its
/// rests and known turns.
pub struct RestsInput<'a> {
    /// The records.
    pub imu: &'a mut dyn ImuSource,
    /// The rests.
    pub rests: &'a [Rest],
    /// Known turns, as filter measurements.
    pub turns: &'a [crate::motion::rests::Turn],
}

/// A fit of a recording of rests with its noise measured: the filter's estimate and where its
/// noise came from (`fit_measuring_noise`).
pub(crate) struct MeasuredFit {
    /// The estimate of the last fit.
    pub estimate: crate::estimate::Estimate,
    /// The configuration it ran with.
    pub config: RunConfig,
    /// The noise.
    pub noise: NoiseSource,
}

/// Fit a recording of rests with `config` and `layout`; with `measured` noise (the
/// configuration's levels taken from [`white_noise_at_rest`]), bring the specific-force level
/// to the fit's innovations and measure the motion noise ([`noise_ml`]), refitting up to
/// [`MAX_NOISE_FITS`] times until both settle (the factor within 3 %, the motion noise within
/// 5 % or below 1e-6 rad). The innovations' scatter against the rests' own noise is then
/// [`crate::estimate::noise::variance_ratio`] of [`InnovationScatter`]. Sigmas from a noise
/// the innovations contradict are wrong in either direction: too small when the windows
/// scatter more, too large when they scatter less.
///
/// `start`: the levels the first fit is made with (`None`: the configuration's,
/// [`MeasuredLevels::configured`]); a fit of a model close to one already measured starts from
/// its levels ([`NoiseSource::measured_levels`]).
pub(crate) fn fit_measuring_noise(
    config: &RunConfig,
    layout: &crate::model::layout::StateLayout,
    input: RestsInput,
    measured: Option<WhiteNoiseAtRest>,
    start: Option<MeasuredLevels>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<MeasuredFit, crate::estimate::EstimateError> {
    let base_accel = config.noise.accel_m_s2;
    let mut levels = start
        .filter(|_| measured.is_some())
        .unwrap_or_else(|| MeasuredLevels::configured(config));
    let mut fits = 0;
    let mut previous_motion: Option<(f64, f64)> = None;
    // The coarse start depends on the priors, the rests, the turns and the hold-out, which
    // the fits share (only their noise differs): found once, not at every fit.
    let (imu, rests, turns) = (input.imu, input.rests, input.turns);
    let coarse = super::coarse_start::coarse_start_at_rests(config, layout, imu, rests, turns)?;
    // Each fit after the first starts from the one before's converged estimates (the same
    // states, other noise levels): one or two passes where a fit from the coarse start takes
    // three to eight.
    let mut before: Option<crate::estimate::Estimate> = None;
    loop {
        let mut config = config.clone();
        levels.apply(&mut config, base_accel);
        // While the noise is being measured, a fit only measures it: it stops at the looser
        // tolerance, and the one whose levels settle is taken on to the full one below.
        let start = super::at_rests::RestsStart {
            coarse: coarse.as_deref(),
            warm: before.as_ref(),
            tolerance_sigma: measured.map(|_| crate::estimate::passes::PROVISIONAL_SIGMA_RESTS),
        };
        let est =
            super::at_rests::fit_at_rests(&config, layout, imu, rests, turns, start, progress)?;
        fits += 1;
        let Some(at_rest) = measured else {
            return Ok(MeasuredFit {
                estimate: est,
                config,
                noise: NoiseSource::Configured,
            });
        };
        let ml = noise_ml(
            &est.innovations,
            rests.len(),
            (levels.accel_factor, levels.motion_rad),
            base_accel * base_accel * config.filter.accel_rate_hz,
            NOISE_FLOOR_ACCEL_M_S2 / base_accel,
            est.gravity_m_s2,
        );
        let next = next_levels(&config, levels, ml);
        if settled(levels, next) || fits == MAX_NOISE_FITS {
            let recording = super::at_rests::Recording { rests, turns };
            let est = super::at_rests::converge_provisional(
                &config,
                layout,
                (imu, recording),
                coarse.as_deref(),
                est,
                progress,
            )?;
            let motion_windows = ml.map_or(0, |m| m.motion_windows);
            let noise = measured_source(&est, at_rest, levels, motion_windows, fits);
            return Ok(MeasuredFit {
                estimate: est,
                config,
                noise,
            });
        }
        before = Some(est);
        let motion = if at_boundary_twice(levels, next, previous_motion)
            || (previous_motion.is_none() && next.motion_rad == 0.0)
        {
            // The likelihood puts the motion noise at zero, again, with the specific-force
            // level settled: it is zero, not a value to approach by quarters (a consumer-grade
            // simulated recording took seven fits to get there, 0.1 deg quartered each time).
            // Or the first fit's estimate is zero, where there is no secant to step by yet:
            // the next fit is made at zero rather than halfway to it (the same recording: two
            // fits where it took three). Not later: on the Ferraris session a later estimate
            // of zero taken at its word swung the motion noise between zero and 0.16 deg for
            // the ten fits allowed, where the secant settles it in seven.
            0.0
        } else {
            next_motion(levels.motion_rad, next.motion_rad, previous_motion)
        };
        previous_motion = Some((levels.motion_rad, next.motion_rad));
        levels = MeasuredLevels {
            accel_factor: next.accel_factor,
            motion_rad: motion,
        };
    }
}

/// The levels the likelihood `ml` of a fit made with `config` at `levels` gives (those levels
/// where it gives none). With a rest's shared error weighed, each window's variance is the
/// white level plus `m` times the shared one, more than a window's own scatter: the likelihood
/// would take the white level down for it (to its floor on the Ferraris session). It stays at
/// least the rests' measured level there.
fn next_levels(config: &RunConfig, levels: MeasuredLevels, ml: Option<NoiseMl>) -> MeasuredLevels {
    let least_factor = if config.filter.rest_error_m_s2 > 0.0 {
        1.0
    } else {
        0.0
    };
    ml.map_or(levels, |m| MeasuredLevels {
        accel_factor: m.accel_factor.max(least_factor),
        motion_rad: m.motion_sigma_rad,
    })
}

/// Whether the motion noise the likelihood estimated is zero for the second fit running
/// (`previous`: the fit before's motion noise and estimate) while the specific-force factor
/// has settled (within 3 %, as in [`settled`]).
fn at_boundary_twice(
    now: MeasuredLevels,
    next: MeasuredLevels,
    previous: Option<(f64, f64)>,
) -> bool {
    let factor_settled = (next.accel_factor / now.accel_factor - 1.0).abs() <= 0.03;
    factor_settled && next.motion_rad == 0.0 && previous.is_some_and(|(_, e)| e == 0.0)
}

/// Whether the levels a fit estimated (`next`) are those it was made with (`now`): the factor
/// within 3 %, the motion noise within 5 % or both below [`MOTION_NOISE_NEGLIGIBLE_RAD`].
fn settled(now: MeasuredLevels, next: MeasuredLevels) -> bool {
    let settled_factor = (next.accel_factor / now.accel_factor - 1.0).abs() <= 0.03;
    let (motion, next_motion) = (now.motion_rad, next.motion_rad);
    let settled_motion = (next_motion - motion).abs() <= 0.05 * next_motion.max(motion)
        || next_motion.max(motion) < MOTION_NOISE_NEGLIGIBLE_RAD;
    settled_factor && settled_motion
}

/// The noise of a fit whose levels settled (or that was the last): the levels it was made
/// with, and the scatter of its windows and its held-out windows against the rests' own
/// noise ([`ScatterExcess`]).
fn measured_source(
    est: &crate::estimate::Estimate,
    at_rest: WhiteNoiseAtRest,
    levels: MeasuredLevels,
    motion_windows: usize,
    fits: usize,
) -> NoiseSource {
    let factor = levels.accel_factor;
    let scatter = InnovationScatter::of(&est.innovations);
    let excess = ScatterExcess::of(
        variance_ratio(factor, scatter.mean_nis),
        scatter.windows,
        at_rest.dof,
    );
    let held = InnovationScatter::held_out(&est.innovations);
    let held_out_excess = (held.windows > 0).then(|| {
        ScatterExcess::of(
            variance_ratio(factor, held.mean_nis),
            held.windows,
            at_rest.dof,
        )
    });
    NoiseSource::Measured {
        at_rest,
        accel_factor: factor,
        excess,
        held_out_excess,
        motion_noise_deg: levels.motion_rad.to_degrees(),
        motion_windows,
        fits,
    }
}

/// The motion noise (rad) of the next fit, from the one the fit before was made with
/// (`motion`), the one it estimated (`estimated`) and the same of the fit before it
/// (`previous`).
///
/// The one-step estimate of the motion noise swings about its fixed point (a fit with more
/// motion noise lets the states absorb more of the first windows, whose innovations then call
/// for less): halfway at first, then the secant of the map from the motion noise fitted with
/// to the one estimated, aimed at its fixed point (within a factor of four of the last), which
/// a damped step reaches only slowly where the map's slope is near -1 (the Ferraris session:
/// 0.12 to 0.15 deg for eight fits).
fn next_motion(motion: f64, estimated: f64, previous: Option<(f64, f64)>) -> f64 {
    let step = match previous {
        Some((m0, e0)) if (motion - m0).abs() > 1e-12 => {
            let slope = (estimated - e0) / (motion - m0);
            if slope < 0.9 {
                motion + (estimated - motion) / (1.0 - slope)
            } else {
                0.5 * (motion + estimated)
            }
        }
        _ => 0.5 * (motion + estimated),
    };
    let step = if motion > 0.0 {
        step.clamp(motion / 4.0, motion * 4.0)
    } else {
        step
    };
    let step = step.clamp(0.0, MAX_MOTION_NOISE_RAD);
    if step < MOTION_NOISE_NEGLIGIBLE_RAD {
        0.0
    } else {
        step
    }
}

/// Calibrate a recording of rests (no program, no turntable:
/// [`crate::estimate::RunKind::HandTurned`]) with the filter of a recording of rests, the model
/// `layout`, the known `turns` as measurements, every `holdout`-th rest held out
/// (`filter.hold_out_every`), the noise measured where `measured` (`fit_measuring_noise`), and
/// report what the result does to the rests, the turns and the held-out rests, with its verdict
/// ([`crate::estimate::calibration::Calibration`]).
///
/// The records are read from `imu` again for every step, not held: the rests put on the
/// records once ([`StampCounts`]), then the poses' check, every pass of every fit, the score
/// tests' pass and the figures each read them through.
pub(super) fn calibrate(
    config: &RunConfig,
    layout: &crate::model::layout::StateLayout,
    imu: &mut dyn ImuSource,
    run: &crate::estimate::HandTurnedRun,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<crate::estimate::calibration::Calibration, crate::estimate::EstimateError> {
    let (rests, turns) = (run.rests, run.turns);
    let (holdout, measured) = (run.holdout, run.measured);
    let file = imu.file().to_string();
    let refuse = |source| crate::estimate::EstimateError::Rests {
        file: file.clone(),
        source,
    };
    if let Some(every) = holdout.filter(|&k| k < 2 || k > rests.len()) {
        return Err(refuse(crate::motion::rests::RestError::HoldOut {
            every,
            rests: rests.len(),
        }));
    }
    let stamps = rest_stamps(imu, rests, turns)?;
    let fitted_means = crate::motion::free_motion::check_poses(imu, &stamps, rests, holdout)
        .map_err(|e| refused(e, crate::motion::rests::RestError::Poses, &refuse))?;
    let mut base = config.clone();
    base.filter.hold_out_every = holdout;
    let input = RestsInput { imu, rests, turns };
    let MeasuredFit {
        estimate,
        config,
        noise,
    } = fit_measuring_noise(&base, layout, input, measured, None, progress)?;
    // The score tests' extended pass, once, on the fit the noise settled on.
    let mut estimate = estimate;
    super::at_rests::score_rests(&config, layout, imu, &mut estimate)?;
    // The gyro terms a measured motion noise can take in: each fitted, its noise measured
    // again, and tested by the ratio of the likelihoods (`super::motion_terms`).
    for (c, dof) in super::motion_terms::terms_to_refit(&estimate, &noise) {
        let extra = [(c, c.prior_sigma(base.unit_grade()))];
        let Some(ext) = super::score_pass::extended_layout(&base, layout, &extra) else {
            continue;
        };
        // Its noise measured from the same start as the fit without it.
        let input = RestsInput { imu, rests, turns };
        let with = fit_measuring_noise(&base, &ext, input, measured, None, progress)?;
        let ratio = super::motion_terms::ratio(c, dof, &estimate, &with.estimate);
        estimate.likelihood_ratios.push(ratio);
    }
    let g = estimate.gravity_m_s2;
    let bias_sigma = ["x", "y", "z"]
        .iter()
        .filter_map(|a| estimate.sigma(&format!("gyro.bias.{a}")))
        .fold(0.0, f64::max);
    let earth = EarthRotation::at(config.site.latitude_deg.to_radians(), bias_sigma);
    // The correction `apply` makes of the result file.
    let evaluation_error = crate::motion::rests::RestError::Evaluation;
    let correction = crate::model::correction::Correction::of_result(&estimate.to_result_file())
        .map_err(|e| refuse(evaluation_error(e.to_string())))?;
    let mut evaluation = crate::motion::free_motion::evaluate(
        imu,
        &stamps,
        rests,
        turns,
        holdout,
        g,
        &earth,
        &correction,
    )
    .map_err(|e| refused(e, evaluation_error, &refuse))?;
    if let Some(at_rest) = measured {
        // What the rests' |f| = g residuals scatter beyond their white noise: reported, and
        // weighed only where asked (`filter.rest_error_m_s2`, `--rest-error`).
        if let Some((excess, dof)) = rest_error_m_s2(&config, imu, rests, &at_rest)? {
            evaluation.rest_excess_m_s2 = Some(excess);
            evaluation.rest_excess_dof = dof;
        }
    }
    if holdout.is_some() && fitted_means.len() > crate::motion::free_motion::BASELINE_PARAMETERS {
        // The simplest estimate from the same rests, judged on the same held-out ones
        // (`docs/real-data.md`, "Against the least-squares baseline").
        let baseline = crate::motion::free_motion::accel_baseline_of_means(&fitted_means, g)
            .map_err(|e| refused(e, evaluation_error, &refuse))?;
        let rms = |held| baseline.static_rms_m_s2(&evaluation.poses, held, g);
        if let (Some(held_out), Some(fitted)) = (rms(true), rms(false)) {
            evaluation.baseline = Some(crate::motion::free_motion::BaselineFigures {
                held_out_static_rms_m_s2: held_out,
                fitted_static_rms_m_s2: fitted,
            });
        }
    }
    Ok(crate::estimate::calibration::Calibration::new(
        estimate,
        config,
        noise,
        Some(evaluation),
        &crate::check::diagnostics::DiagnosticSettings::default(),
    ))
}

/// The filter alone on a recording of rests ([`crate::estimate::RunKind::RestsFilter`]): the
/// configured noise, no hold-out, a coarse start where the priors call for one, and neither
/// the score tests' pass nor the figures.
pub(super) fn filter_only(
    config: &RunConfig,
    layout: &crate::model::layout::StateLayout,
    input: RestsInput,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<crate::estimate::calibration::Calibration, crate::estimate::EstimateError> {
    let fit = fit_measuring_noise(config, layout, input, None, None, progress)?;
    Ok(crate::estimate::calibration::Calibration::new(
        fit.estimate,
        fit.config,
        fit.noise,
        None,
        &crate::check::diagnostics::DiagnosticSettings::default(),
    ))
}

/// The rests and turns put on the records of `imu` in one reading ([`StampCounts`]), with the
/// median interval where a turn holds the first record (whose interval it is).
fn rest_stamps(
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
) -> Result<StampCounts, crate::io::IoError> {
    let times = rests
        .iter()
        .flat_map(|r| [r.t0, r.t1])
        .chain(turns.iter().flat_map(|t| [t.t0, t.t1]));
    let stamps = StampCounts::read(imu, times, [], f64::NAN)?;
    if !turns.iter().any(|t| t.records(&stamps).start == 0) {
        return Ok(stamps);
    }
    let mut chunk = Vec::new();
    let median = sins_model::timing::median_interval_streamed(|visit| {
        read_records(imu, &mut chunk, &mut |r, _| {
            visit(r.t);
            true
        })
    })?;
    Ok(stamps.with_median(median))
}

/// A refusal of the poses' check or the figures as the estimate's error: a record that cannot
/// be read again is the file's (`IoError`), anything else the rests' (`as_rests`, by
/// `refuse`).
fn refused(
    e: crate::motion::free_motion::FreeMotionError,
    as_rests: fn(String) -> crate::motion::rests::RestError,
    refuse: &dyn Fn(crate::motion::rests::RestError) -> crate::estimate::EstimateError,
) -> crate::estimate::EstimateError {
    match e {
        crate::motion::free_motion::FreeMotionError::Io(e) => e.into(),
        e => refuse(as_rests(e.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::ImuData;

    /// Golden section with one evaluation a step finds the maximum of a smooth function, at
    /// either end of its interval too, in 42 evaluations.
    #[test]
    fn golden_section_finds_the_maximum_once_a_step() {
        for (peak, a, b) in [(1.3, -5.0, 5.0), (-4.9, -5.0, 5.0), (7.0, -5.0, 5.0)] {
            let calls = std::cell::Cell::new(0);
            let x = golden_max(
                &|x: f64| {
                    calls.set(calls.get() + 1);
                    -(x - peak) * (x - peak)
                },
                a,
                b,
            );
            let want = f64::clamp(peak, a, b);
            assert!((x - want).abs() < 1e-6, "{x} against {want}");
            assert_eq!(calls.get(), 41);
        }
    }

    /// White noise of known 1-s sigma in two rests, a turn between them: the pooled scatter of
    /// the 1-s means comes back within its sampling error.
    #[test]
    fn the_rests_give_the_noise_of_a_1_s_mean() {
        let (rate, sigma_w, sigma_f) = (100.0, 1e-3, 2e-3);
        // Per-sample sigma whose 1-s mean has sigma_*: sigma * sqrt(rate).
        let mut state = 12345u64;
        let mut normal = || {
            let mut u = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()
        };
        let mut records = Vec::new();
        for k in 0..40_000 {
            let t = k as f64 / rate;
            let moving = (180.0..190.0).contains(&t);
            let mut w = [0.0; 3];
            let mut f = [0.0, 0.0, 9.8];
            for a in 0..3 {
                w[a] = 0.01 + sigma_w * rate.sqrt() * normal();
                f[a] += sigma_f * rate.sqrt() * normal();
            }
            if moving {
                w[0] += 0.5;
            }
            records.push(ImuRecord {
                t,
                gyro: w,
                accel: f,
                temp: None,
            });
        }
        let data = ImuData {
            kind: ImuKind::Rates,
            records,
        };
        let rests = [
            Rest { t0: 0.0, t1: 180.0 },
            Rest {
                t0: 190.0,
                t1: 399.99,
            },
        ];
        let at_rest = RecordsAtRest::read(
            &mut crate::estimate::MemoryImu::new(&data, "imu.csv"),
            &rests,
        )
        .unwrap();
        let n = white_noise_at_rest(&at_rest).unwrap();
        // About 385 degrees of freedom per axis, 1155 over three: 2 % of sampling error.
        assert!(n.dof > 370, "{n:?}");
        assert!((n.gyro_rad_s / sigma_w - 1.0).abs() < 0.08, "{n:?}");
        assert!((n.accel_m_s2 / sigma_f - 1.0).abs() < 0.08, "{n:?}");
        let c = default_config(&at_rest, 45.0, 0.0, &n, UnitGrade::Consumer).unwrap();
        assert!((c.filter.imu_rate_hz - rate).abs() < 1e-6);
        assert_eq!(c.accel_interval_steps(), 100);
        assert!(c.program_from_angles());
    }

    /// Innovations drawn from `S0 + k^2 R + q g^2 diag(1, 1, 0)` (the last term on the first
    /// window of every rest but the first), 40 rests of 10 windows, seed 31 fixed before the
    /// run: the maximum likelihood gives `k` and `sqrt(q)` back within their sampling error
    /// (about 2 % on `k` from 1200 windows, 15 % on `sqrt(q)` from 39 first windows), from a
    /// fit made with other values.
    #[test]
    fn the_noise_scale_and_the_motion_noise_come_back() {
        use rand::{SeedableRng, rngs::StdRng};
        use rand_distr::{Distribution, StandardNormal};
        let (g, k, sigma_q, base_var) = (9.8, 1.7, 2e-3, 1e-6);
        let d = Matrix3::from_diagonal(&Vector3::new(g * g, g * g, 0.0));
        let mut rng = StdRng::seed_from_u64(31);
        let mut innovations = Vec::new();
        let fitted = (1.0, 5e-3);
        for rest in 0..40usize {
            for w in 0..10usize {
                let first = w == 0 && rest > 0;
                // The states' own part: shrinking within a rest.
                let s0 = Matrix3::identity() * (base_var * 2.0 / (1.0 + w as f64));
                let mut s = s0 + Matrix3::identity() * (k * k * base_var);
                if first {
                    s += d * (sigma_q * sigma_q);
                }
                let l = s.cholesky().unwrap().l();
                let z = Vector3::from_fn(|_, _| StandardNormal.sample(&mut rng));
                // What the fit recorded: S at the values it was made with.
                let mut s_fit = s0 + Matrix3::identity() * (fitted.0 * fitted.0 * base_var);
                if first {
                    s_fit += d * (fitted.1 * fitted.1);
                }
                innovations.push(Innovation {
                    t: (rest * 10 + w) as f64,
                    kind: MeasurementKind::Accel,
                    nu: l * z,
                    s: s_fit,
                    segment: 2 * rest,
                    held_out: false,
                    c_body_to_enu: None,
                });
            }
        }
        let ml = noise_ml(&innovations, 40, fitted, base_var, 1e-3, g).unwrap();
        assert_eq!(ml.motion_windows, 39);
        assert!((ml.accel_factor / k - 1.0).abs() < 0.06, "{ml:?}");
        assert!((ml.motion_sigma_rad / sigma_q - 1.0).abs() < 0.45, "{ml:?}");
    }
}
