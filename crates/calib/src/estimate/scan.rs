//! The first reading of the records: their count, span, spacing, rate bins and temperatures.

use super::{EstimateError, ImuSource, MIN_RECORDING_S, PROGRESS_EVERY, Scan};
use crate::config::RunConfig;
use crate::estimate::data_checks::{Stuck, check_record};
use crate::io::{ImuKind, IoError};
use crate::motion::align::RateBinner;
use nalgebra::Vector3;

/// The temperatures of the records, as the scan found them.
#[derive(Clone, Debug, Default)]
pub(super) struct TemperatureScan {
    pub(super) sum: f64,
    pub(super) n: usize,
    pub(super) min: f64,
    pub(super) max: f64,
    /// 1-s means `[t_s, temp_c]` (the time the middle of the second).
    pub(super) series: Vec<[f64; 2]>,
    /// The open second: its index, sum and count.
    pub(super) open: Option<(i64, f64, usize)>,
}

impl TemperatureScan {
    pub(super) fn push(&mut self, t: f64, temp: f64) {
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

    pub(super) fn close(&mut self) {
        if let Some((k, s, c)) = self.open.take() {
            self.series.push([k as f64 + 0.5, s / c as f64]);
        }
    }

    pub(super) fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }
}

/// Why the thermal terms' reference temperature is the one it is.
pub(super) const REFERENCE_MEAN: &str = "the mean of the records' temperatures: the biases and scale \
    factors of the result are those at it, where they are least correlated with the temperature \
    coefficients";
pub(super) const REFERENCE_CONFIGURED: &str = "temperature.reference_c of the configuration";

impl Scan {
    /// The reference temperature and the summary for the result, when the records have a
    /// temperature.
    pub(super) fn temperature(&self, config: &RunConfig) -> Option<crate::io::ResultTemperature> {
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
pub(super) const BIN_S: f64 = 0.1;

/// How far one record's interval may be from the configured one: a programmed run's records
/// come at a fixed rate (within 5 %); a recording of rests may have jittered time stamps (each
/// record is then integrated over its own interval: within 50 %) and, in rate form, a few
/// dropped records (a rate record integrated over up to five intervals; an increment record
/// lost is a rotation lost).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Spacing {
    Fixed,
    Jittered,
}

impl Spacing {
    /// The accepted range of `interval / configured interval`.
    pub(super) fn range(self, kind: ImuKind) -> (f64, f64) {
        match (self, kind) {
            (Spacing::Fixed, _) => (0.95, 1.05),
            (Spacing::Jittered, ImuKind::Increments) => (0.5, 1.5),
            (Spacing::Jittered, ImuKind::Rates) => (0.5, 5.0),
        }
    }
}

/// Read the IMU data once: count the records and check that they come at the configured rate
/// (within the `spacing`'s tolerance), naming the first line that does not.
pub(super) fn scan_imu(
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
