//! Calibration from recorded data.
//!
//! - Strapdown: the attitude `C` (body to ENU) is integrated at the IMU rate from the increments,
//!   corrected with the current parameter estimate, with the coning correction
//!   `phi = dth + dth_prev x dth / 12`; the velocity increment in ENU gets the rotation and
//!   sculling corrections. The start attitude is the program's at the first interval's start
//!   (the program starts at IMU time zero), the mounting taken as nominal.
//! - Specific force: the mean over each window of `C dv` against the site's `(0, 0, g)`.
//! - Turntable angles: at the end of every IMU step in a window, the angle records are
//!   interpolated (linearly, wrap-aware) at the turntable-clock time of `t + tau_hat`, turned
//!   into the attitude `C_tt` with the current installation estimate, and compared with `C`.
//! - Filter: the error-state model of [`crate::model`] with [`crate::engine`], shared with the
//!   covariance analysis. Whenever no measurement window is open the whole estimate is fed back:
//!   the attitude error into `C`, the parameter errors into the parameter estimates, which
//!   correct the following increments, and the filter state is zeroed.

use crate::config::{ConfigError, RunConfig};
use crate::covariance::{initial_covariance, layout_for};
use crate::engine::{
    MeasurementNoise, Schedule, angle_sample_guard, angle_sample_usable, measurement_instant,
};
use crate::filter::NormalisedFilter;
use crate::io::{ImuData, ImuKind, ResultFile, ResultParameter, TurntableData, check_overlap};
use crate::layout::StateLayout;
use crate::model::{AngleSample, LinearModel};
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::attitude::{attitude_error, exp_so3, orthonormalize};
use sins_model::terms::{ErrorModel, Sensor, SensorInput, Unit};
use turntable::gimbal::{c_platform_to_base, gimbal_jacobian};

/// Errors of an estimation run.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// Configuration problem.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Unusable input data.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// The filter refused a step.
    #[error("Kalman filter at t = {t:.3} s (IMU clock): {source}")]
    Filter {
        /// IMU time of the failing step [s].
        t: f64,
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
    /// Turntable records and their file name; `None` for an IMU-only (24-state) calibration.
    pub turntable: Option<(&'a TurntableData, &'a str)>,
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
    /// Mean normalised innovation squared of the turntable updates (3 when the model fits).
    pub turntable_mean_nis: f64,
    /// Turntable samples used (interpolated angle sets).
    pub turntable_samples: usize,
    /// IMU steps in a turntable window without turntable data (outside the file's span or in
    /// a gap of the records).
    pub turntable_samples_missing: usize,
    /// Turntable samples left out because the platform rate changes within the delay
    /// uncertainty ([`crate::engine::angle_sample_usable`]).
    pub turntable_samples_near_rate_changes: usize,
    /// Largest change of a parameter from the first pass to the second, in posterior sigmas
    /// (large values mean the first pass was far from linear).
    pub first_pass_shift_sigma: f64,
    /// Record rate of the turntable file on the IMU clock [Hz].
    pub turntable_record_rate_hz: f64,
}

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
    /// IMU time of the final estimate [s].
    pub final_time: f64,
    /// Computed attitude at `final_time` (the attitude states are its error).
    pub final_c_body_to_enu: Matrix3<f64>,
    /// Fit statistics.
    pub stats: FitStatistics,
}

impl Estimate {
    fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
    /// Estimate of a state by name (SI).
    pub fn value(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.values[i])
    }
    /// Posterior sigma of a state by name (SI).
    pub fn sigma(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.cov[(i, i)].max(0.0).sqrt())
    }
    /// The parameters (every state but the attitude errors) as a result file.
    pub fn to_result_file(&self) -> ResultFile {
        ResultFile {
            parameters: (StateLayout::INSTRUMENT..self.names.len())
                .map(|i| ResultParameter {
                    name: self.names[i].clone(),
                    value: self.values[i],
                    sigma: Some(self.cov[(i, i)].max(0.0).sqrt()),
                    unit: self.units[i].si_name().to_string(),
                })
                .collect(),
        }
    }
}

/// Wrap an angle difference into (-180, 180] degrees.
fn wrap_deg(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// Interpolated gimbal angles [rad] and the two records with their weights.
type Interpolated = ([f64; 3], [(usize, f64); 2]);

/// Interpolates the turntable records on the IMU time line.
struct AngleInterpolator<'a> {
    data: &'a TurntableData,
    /// Index of the record at or before the last query.
    cursor: usize,
    /// Largest record spacing (turntable clock) still interpolated across.
    max_gap: f64,
}

impl<'a> AngleInterpolator<'a> {
    fn new(data: &'a TurntableData, median_interval: f64) -> Self {
        Self {
            data,
            cursor: 0,
            max_gap: 2.5 * median_interval,
        }
    }

    /// Angles [rad] at turntable-clock time `t_tt` and the two records with their weights;
    /// `None` outside the records or across a gap. Queries must not go back in time by more
    /// than a record or two (they advance with the IMU).
    fn at(&mut self, t_tt: f64) -> Option<Interpolated> {
        let r = &self.data.records;
        if r.len() < 2 || t_tt < r[0].t || t_tt > r[r.len() - 1].t {
            return None;
        }
        while self.cursor > 0 && r[self.cursor].t > t_tt {
            self.cursor -= 1;
        }
        while self.cursor + 2 < r.len() && r[self.cursor + 1].t < t_tt {
            self.cursor += 1;
        }
        let (a, b) = (&r[self.cursor], &r[self.cursor + 1]);
        let span = b.t - a.t;
        if span > self.max_gap {
            return None;
        }
        let w = ((t_tt - a.t) / span).clamp(0.0, 1.0);
        let k = std::array::from_fn(|g| {
            (a.k_deg[g] + w * wrap_deg(b.k_deg[g] - a.k_deg[g])).to_radians()
        });
        Some((k, [(self.cursor, 1.0 - w), (self.cursor + 1, w)]))
    }
}

fn median_interval(times: impl Iterator<Item = f64>) -> f64 {
    let t: Vec<f64> = times.collect();
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return f64::NAN;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// Check that the IMU records come at the configured rate (within 5 %), naming the first line
/// that does not.
fn check_imu_rate(data: &ImuData, file: &str, rate_hz: f64) -> Result<(), EstimateError> {
    let dt = 1.0 / rate_hz;
    if data.records.len() < 2 {
        return Err(crate::io::IoError::File {
            file: file.to_string(),
            message: "expected at least two IMU records".into(),
        }
        .into());
    }
    for (i, w) in data.records.windows(2).enumerate() {
        let d = w[1].t - w[0].t;
        if (d / dt - 1.0).abs() > 0.05 {
            return Err(crate::io::IoError::Line {
                file: file.to_string(),
                // Record i + 1 is on line i + 3 (header on line 1).
                line: i + 3,
                message: format!(
                    "the interval to the previous record is {d} s: expected {dt} s \
                     (filter.imu_rate_hz = {rate_hz}) within 5 %; gaps and other rates are not \
                     interpolated"
                ),
            }
            .into());
        }
    }
    Ok(())
}

/// The measured body rate of record `i` (uncorrected; for detecting rate changes).
fn raw_rate(imu: &ImuData, i: usize, dt: f64) -> Vector3<f64> {
    let g = Vector3::from(imu.records[i].gyro);
    match imu.kind {
        ImuKind::Increments => g / dt,
        ImuKind::Rates => g,
    }
}

/// Invert the sensor models with the current estimates: the true increments solve
/// `dth' = dth - nu(p; w, f) dt` and `dv' = dv + df(p; w, f) dt`, with the errors evaluated at the
/// true rate and specific force. Three fixed-point passes: the first alone (errors evaluated at
/// the measured values) would leave `Theta^2 w`, a 3e-6 relative scale error for a 1e-3 `Theta`,
/// which is twenty times the scale-factor sigma the paper's program reaches.
fn correct_increments(
    model: &ErrorModel,
    p: &[f64],
    raw_dth: &Vector3<f64>,
    raw_dv: &Vector3<f64>,
    dt: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let (mut dth, mut dv) = (*raw_dth, *raw_dv);
    for _ in 0..3 {
        let input = SensorInput {
            omega_body: dth / dt,
            f_body: dv / dt,
        };
        dth = raw_dth + model.error(Sensor::Gyro, p, &input) * dt;
        dv = raw_dv - model.error(Sensor::Accel, p, &input) * dt;
    }
    (dth, dv)
}

/// Calibrate from recorded data with the configuration's model and settings. `progress` is
/// called with (steps done, total steps) about a hundred times per pass; the total counts both
/// passes of [`estimate_with`], twice the IMU records. The program is taken to start at IMU
/// time zero (shift the time stamps of a recording that does not).
pub fn estimate(
    config: &RunConfig,
    data: &RunData,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let layout = layout_for(config, data.turntable.is_some());
    estimate_with(config, &layout, data, progress)
}

/// [`estimate`] with any state layout (e.g. an extended instrument model).
///
/// Two passes over the data. The first feeds every estimate back as it goes (closed loop) and
/// starts from the prior means; its linearisation errors are products of the current errors,
/// which are large at first: an unobservable 1-degree heading error times a 1e-3 scale-factor
/// error puts 5 sigma of bias into the IMU-only accelerometer matrix. The second pass
/// linearises about the first pass's estimates (the increments are compensated with them, the
/// turntable angles read with their delay and installation) and keeps the same prior, so only
/// the attitude is fed back and the parameter errors stay in the filter state.
pub fn estimate_with(
    config: &RunConfig,
    layout: &StateLayout,
    data: &RunData,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let n = data.imu.records.len();
    let first = run_pass(config, layout, data, None, &mut |j, _| progress(j, 2 * n))?;
    let mut second = run_pass(config, layout, data, Some(&first.values), &mut |j, _| {
        progress(n + j, 2 * n)
    })?;
    second.stats.first_pass_shift_sigma = (StateLayout::INSTRUMENT..layout.dim())
        .map(|i| (second.values[i] - first.values[i]).abs() / second.cov[(i, i)].sqrt())
        .fold(0.0, f64::max);
    Ok(second)
}

/// One pass over the data. Without `nominal`: closed loop from the prior means. With it (a full
/// state vector of totals, attitude entries unused): compensation and turntable reading with
/// the nominal values, the prior mean of each error state `-nominal`, attitude-only feedback.
fn run_pass(
    config: &RunConfig,
    layout: &StateLayout,
    data: &RunData,
    nominal: Option<&[f64]>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let f = &config.filter;
    let imu = data.imu;
    check_imu_rate(imu, data.imu_file, f.imu_rate_hz)?;
    let dt = 1.0 / f.imu_rate_hz;
    let program = config.program()?;
    let site = config.site();
    let u_enu = site.earth_rate_enu();
    let f_enu = site.specific_force_at_rest_enu();
    let clock = config.clock;
    let use_tt = layout.install.is_some();
    let mut stats = FitStatistics::default();

    let mut interp = None;
    let mut angle_var = None;
    if let (true, Some((tt, file))) = (use_tt, data.turntable) {
        let span = tt.span().ok_or_else(|| crate::io::IoError::File {
            file: file.to_string(),
            message: "expected turntable records, found none".into(),
        })?;
        let (t0, t1) = imu.span().expect("checked above");
        check_overlap(
            (t0 - dt, t1),
            (clock.imu_time(span.0), clock.imu_time(span.1)),
            file,
        )?;
        let med = median_interval(tt.records.iter().map(|r| r.t));
        if !(med.is_finite() && med > 0.0) {
            return Err(crate::io::IoError::File {
                file: file.to_string(),
                message: "expected at least two turntable records".into(),
            }
            .into());
        }
        stats.turntable_record_rate_hz = (1.0 + clock.turntable_rate_error) / med;
        angle_var = Some(config.angle_psd() * stats.turntable_record_rate_hz);
        interp = Some(AngleInterpolator::new(tt, med));
    }

    let schedule = Schedule::new(config);
    let noise = MeasurementNoise {
        accel_psd: config.accel_psd(),
        angle_var_per_record: angle_var,
    };
    let mut model = LinearModel::new(layout, dt, &u_enu, config.gyro_psd());

    let n_instr = layout.n_instrument();
    // Current totals (the linearisation point): instrument parameters, delta_z, tau, gamma_p.
    let totals = nominal.map_or_else(|| vec![0.0; layout.dim()], <[f64]>::to_vec);
    let v3 = |k: Option<usize>| {
        k.map_or(Vector3::zeros(), |k| {
            Vector3::new(totals[k], totals[k + 1], totals[k + 2])
        })
    };
    let off = StateLayout::INSTRUMENT;
    let mut p_hat = totals[off..off + n_instr].to_vec();
    let mut delta_hat = v3(layout.install);
    let mut tau_hat = layout.tau.map_or(0.0, |k| totals[k]);
    let mut gamma_hat = v3(layout.base);
    let full_feedback = nominal.is_none();

    let t_start = imu.records[0].t - dt;
    let (k0, _) = program.state(t_start);
    let mut c = c_platform_to_base(&k0);
    let mut filter = NormalisedFilter::with_covariance(&initial_covariance(config, layout, &c))
        .map_err(|source| EstimateError::Filter { t: 0.0, source })?;
    // The prior means are zero: as errors of the nominal values they are -nominal.
    for (k, v) in totals.iter().enumerate().skip(off) {
        filter.set_state(k, -v);
    }
    let a_step = exp_so3(&(-u_enu * dt));
    let (mut dth_prev, mut dv_prev) = (Vector3::zeros(), Vector3::zeros());
    let n_steps = imu.records.len();
    let every = (n_steps / 100).max(1);
    let (mut nis_acc, mut nis_tt) = (0.0, 0.0);
    let mut c_install = exp_so3(&delta_hat);
    let mut c_base = exp_so3(&gamma_hat);

    for (i, rec) in imu.records.iter().enumerate() {
        let j = i + 1;
        let t = rec.t;
        let (raw_dth, raw_dv) = match imu.kind {
            ImuKind::Increments => (Vector3::from(rec.gyro), Vector3::from(rec.accel)),
            ImuKind::Rates => (Vector3::from(rec.gyro) * dt, Vector3::from(rec.accel) * dt),
        };
        let (dth, dv) = correct_increments(&layout.model, &p_hat, &raw_dth, &raw_dv, dt);
        let phi = dth + dth_prev.cross(&dth) / 12.0;
        let dv_body =
            dv + 0.5 * dth.cross(&dv) + (dth_prev.cross(&dv) + dv_prev.cross(&dth)) / 12.0;
        let c_prev = c;
        c = a_step * c_prev * exp_so3(&phi);
        let c_mid = (c_prev + c) * 0.5;
        let input = SensorInput {
            omega_body: dth / dt,
            f_body: dv / dt,
        };
        let dv_enu = c_prev * dv_body;
        let in_acc = schedule.in_accel_window(j).then_some(&dv_enu);
        model.substep(layout, &c_mid, &input, &p_hat, in_acc);
        (dth_prev, dv_prev) = (dth, dv);

        if let Some(interp) = interp.as_mut()
            && schedule.in_turntable_window(j)
        {
            let (guard, threshold) = angle_sample_guard(
                filter.sigma(layout.tau.expect("turntable layout")),
                1.0 / stats.turntable_record_rate_hz,
                dt,
                config.angle_psd(),
                schedule.turntable_window as f64 * dt,
            );
            let m = (guard / dt).ceil() as usize;
            // Near the ends of the data the rate on the far side is unknown: not usable.
            let usable = i >= m
                && i + m < n_steps
                && angle_sample_usable(
                    &raw_rate(imu, i.saturating_sub(m), dt),
                    &raw_rate(imu, i, dt),
                    &raw_rate(imu, (i + m).min(n_steps - 1), dt),
                    guard,
                    threshold,
                );
            match interp.at(clock.turntable_time(t + tau_hat)) {
                Some(_) if !usable => stats.turntable_samples_near_rate_changes += 1,
                Some((k, records)) => {
                    let c_tt = c_base * c_platform_to_base(&k) * c_install;
                    model.add_angle_sample(&AngleSample {
                        y: attitude_error(&c, &c_tt),
                        c_body_to_enu: c,
                        platform_rate_enu: c * input.omega_body - u_enu,
                        gimbal_jacobian: gimbal_jacobian(&k),
                        records: &records,
                    });
                    stats.turntable_samples += 1;
                }
                None => stats.turntable_samples_missing += 1,
            }
        }

        let last = j == n_steps;
        let report = measurement_instant(
            &mut filter,
            &mut model,
            layout,
            &schedule,
            j,
            &f_enu,
            &noise,
            false,
            last,
        )
        .map_err(|source| EstimateError::Filter { t, source })?;
        if let Some(nis) = report.accel_nis {
            stats.accel_updates += 1;
            nis_acc += nis;
        }
        if let Some(nis) = report.turntable_nis {
            stats.turntable_updates += 1;
            nis_tt += nis;
        }
        if (report.accel_nis.is_some() || report.turntable_nis.is_some() || last)
            && !model.accel_open()
            && !model.turntable_open()
        {
            // Feedback: the attitude error into the attitude; in a closed-loop pass every other
            // error estimate into its total too, and the filter state back to zero.
            let x = filter.state();
            c = orthonormalize(&(exp_so3(&Vector3::new(x[0], x[1], x[2])) * c));
            if !full_feedback {
                for k in 0..3 {
                    filter.set_state(k, 0.0);
                }
            } else {
                for (k, p) in p_hat.iter_mut().enumerate() {
                    *p += x[StateLayout::INSTRUMENT + k];
                }
                if let Some(k) = layout.install {
                    delta_hat += Vector3::new(x[k], x[k + 1], x[k + 2]);
                    c_install = exp_so3(&delta_hat);
                }
                if let Some(k) = layout.tau {
                    tau_hat += x[k];
                }
                if let Some(k) = layout.base {
                    gamma_hat += Vector3::new(x[k], x[k + 1], x[k + 2]);
                    c_base = exp_so3(&gamma_hat);
                }
                filter.reset_state();
            }
        }
        if j % every == 0 || last {
            progress(j, n_steps);
        }
    }
    stats.imu_steps = n_steps;
    stats.accel_mean_nis = nis_acc / stats.accel_updates.max(1) as f64;
    stats.turntable_mean_nis = nis_tt / stats.turntable_updates.max(1) as f64;

    // Whatever the last windows left in the state (they were still open at the end).
    let x = filter.state();
    let mut values = x.clone();
    c = exp_so3(&Vector3::new(x[0], x[1], x[2])) * c;
    values[..3].fill(0.0);
    for (k, p) in p_hat.iter().enumerate() {
        values[StateLayout::INSTRUMENT + k] += p;
    }
    if let Some(k) = layout.install {
        for a in 0..3 {
            values[k + a] += delta_hat[a];
        }
    }
    if let Some(k) = layout.tau {
        values[k] += tau_hat;
    }
    if let Some(k) = layout.base {
        for a in 0..3 {
            values[k + a] += gamma_hat[a];
        }
    }
    Ok(Estimate {
        names: layout.entries().iter().map(|e| e.name.clone()).collect(),
        units: layout.entries().iter().map(|e| e.unit).collect(),
        values,
        prior_sigma: layout.prior_sigma(),
        cov: filter.covariance(),
        final_time: imu.records[n_steps - 1].t,
        final_c_body_to_enu: c,
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angle_differences_wrap_the_short_way() {
        assert_eq!(wrap_deg(350.0), -10.0);
        assert_eq!(wrap_deg(-350.0), 10.0);
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(10.0), 10.0);
    }
}
