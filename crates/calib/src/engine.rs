//! The part of the filter loop that the covariance analysis and the estimation share: when
//! measurements are taken, which IMU steps their windows average, and the predict-update at a
//! measurement instant. The two differ only in where the attitude and the residuals come from
//! (the true motion, or the strapdown solution and the recorded data).

use crate::config::RunConfig;
use crate::filter::NormalisedFilter;
use crate::layout::StateLayout;
use crate::model::{LinearModel, Measurement};
use kalman::KalmanError;
use nalgebra::Vector3;

/// Measurement instants and windows, in IMU steps (step `j` ends at `j * dt`, `j >= 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    /// Steps between specific-force measurements.
    pub accel_interval: usize,
    /// Steps averaged by one specific-force measurement (the last ones of its interval).
    pub accel_window: usize,
    /// Steps between turntable-angle measurements.
    pub turntable_interval: usize,
    /// Steps averaged by one turntable-angle measurement.
    pub turntable_window: usize,
}

impl Schedule {
    /// The schedule of a configuration.
    pub fn new(config: &RunConfig) -> Self {
        let accel_interval = config.accel_interval_steps();
        let turntable_interval = config.turntable_interval_steps();
        Self {
            accel_interval,
            accel_window: config.window_steps(accel_interval),
            turntable_interval,
            turntable_window: config.window_steps(turntable_interval),
        }
    }

    /// Step `j` belongs to a specific-force window.
    pub fn in_accel_window(&self, j: usize) -> bool {
        (j - 1) % self.accel_interval >= self.accel_interval - self.accel_window
    }

    /// Step `j` belongs to a turntable-angle window.
    pub fn in_turntable_window(&self, j: usize) -> bool {
        (j - 1) % self.turntable_interval >= self.turntable_interval - self.turntable_window
    }

    /// A specific-force measurement is taken at the end of step `j`.
    pub fn accel_due(&self, j: usize) -> bool {
        j.is_multiple_of(self.accel_interval)
    }

    /// A turntable-angle measurement is taken at the end of step `j`.
    pub fn turntable_due(&self, j: usize) -> bool {
        j.is_multiple_of(self.turntable_interval)
    }
}

/// Whether a turntable-angle sample lies far enough from changes of the platform rate for the
/// linear delay model `-Omega_x tau` to hold.
///
/// A sample compares IMU attitude at `t` with turntable angles of `t + tau_hat - tau`,
/// interpolated between records. Within `guard` (three sigma of the delay estimate plus the record
/// spacing and the IMU step) of a change of the rate, such as the reversals of the paper's
/// program, the angles are not `k(t) - k_dot tau`: the error is the change of rate times the time
/// offset. The sample is used when that is below `threshold` [rad] both ways: `omega_*` are the
/// body rates at `t - guard`, `t` and `t + guard`.
pub fn angle_sample_usable(
    omega_before: &Vector3<f64>,
    omega_now: &Vector3<f64>,
    omega_after: &Vector3<f64>,
    guard: f64,
    threshold: f64,
) -> bool {
    let change = (omega_before - omega_now)
        .norm()
        .max((omega_after - omega_now).norm());
    change * guard <= threshold
}

/// The time guard and threshold of [`angle_sample_usable`]: `guard = 3 sigma_tau + record
/// spacing + IMU step`, `threshold` a tenth of the noise of one turntable measurement.
pub fn angle_sample_guard(
    sigma_tau: f64,
    record_spacing: f64,
    dt: f64,
    angle_psd: f64,
    window_s: f64,
) -> (f64, f64) {
    (
        3.0 * sigma_tau + record_spacing + dt,
        0.1 * (angle_psd / window_s).sqrt(),
    )
}

/// Noise levels of the measurements.
#[derive(Clone, Copy, Debug)]
pub struct MeasurementNoise {
    /// Accelerometer PSD [(m/s^2)^2 s].
    pub accel_psd: f64,
    /// Variance of one angle record, each gimbal [rad^2]; `None` without turntable angles.
    pub angle_var_per_record: Option<f64>,
}

/// What happened at a measurement instant.
#[derive(Clone, Copy, Debug, Default)]
pub struct InstantReport {
    /// Normalised innovation squared of the specific-force update (3 degrees of freedom).
    pub accel_nis: Option<f64>,
    /// Normalised innovation squared of the turntable update.
    pub turntable_nis: Option<f64>,
}

/// At the end of step `j`: if a measurement is due, close its window, predict to now and update.
/// `f_enu` is the true specific force in ENU. With `covariance_only` the residuals are ignored.
/// With `close_all` (the last step of the data) every open window is closed and used.
#[allow(clippy::too_many_arguments)]
pub fn measurement_instant(
    filter: &mut NormalisedFilter,
    model: &mut LinearModel,
    layout: &StateLayout,
    schedule: &Schedule,
    j: usize,
    f_enu: &Vector3<f64>,
    noise: &MeasurementNoise,
    covariance_only: bool,
    close_all: bool,
) -> Result<InstantReport, KalmanError> {
    let accel_due = schedule.accel_due(j) || (close_all && model.accel_open());
    let tt_due = noise.angle_var_per_record.is_some()
        && (schedule.turntable_due(j) || (close_all && model.turntable_open()));
    let mut report = InstantReport::default();
    if !accel_due && !tt_due {
        return Ok(report);
    }
    let acc = if accel_due {
        let m = model.accel_measurement(f_enu, noise.accel_psd);
        model.reset_accel();
        m
    } else {
        None
    };
    let tt = match (tt_due, noise.angle_var_per_record) {
        (true, Some(var)) => {
            let m = model.turntable_measurement(layout, var);
            model.reset_turntable();
            m
        }
        _ => None,
    };
    filter.predict(model, covariance_only)?;
    let mut apply = |m: &Measurement| -> Result<Option<f64>, KalmanError> {
        if covariance_only {
            filter.update_covariance(&m.h, &m.r)?;
            Ok(None)
        } else {
            Ok(Some(filter.update(&m.z, &m.h, &m.r)?.nis))
        }
    };
    if let Some(m) = &acc {
        report.accel_nis = apply(m)?;
    }
    if let Some(m) = &tt {
        report.turntable_nis = apply(m)?;
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_end_at_their_measurement_instants() {
        let s = Schedule {
            accel_interval: 16,
            accel_window: 4,
            turntable_interval: 2,
            turntable_window: 2,
        };
        let acc: Vec<usize> = (1..=32).filter(|&j| s.in_accel_window(j)).collect();
        assert_eq!(acc, vec![13, 14, 15, 16, 29, 30, 31, 32]);
        assert!(s.accel_due(16) && !s.accel_due(15));
        assert!((1..=8).all(|j| s.in_turntable_window(j)));
    }
}
