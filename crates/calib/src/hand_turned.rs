//! A hand-turned recording without a program, a turntable or a configuration: what the filter
//! of a recording of rests ([`crate::estimate::calibrate_rests`]) needs that a laboratory
//! configuration would give, taken from the recording itself, and the held-out figures of
//! [`crate::free_motion`] for its result.
//!
//! - **White noise** ([`white_noise_at_rest`]): the scatter of the 1-s means inside the rests
//!   (each rest's own mean removed), the quantity the configuration's `[noise]` levels are
//!   ("the standard deviation of a 1-s average"). It is what the filter's specific-force
//!   windows see, sensor filters and slow disturbances included; a white-noise density from
//!   the samples (or the Allan curve's slope) understates it where the samples are correlated
//!   (the Xsens recording: 8.4e-4 m/s^2 from the Allan fit, its rests' 1-s means scatter by
//!   about twice that).
//! - **A configuration** ([`default_config`]): consumer-grade priors
//!   ([`crate::free_motion::consumer_priors`]), the site's latitude, the record rate measured
//!   from the time stamps, the measured noise.
//! - **The model**: the paper's with the two terms a hand-turned consumer unit commonly needs
//!   ([`DEFAULT_TERMS`]: the batch fit carried them by default before the filter took its
//!   place), at the unit grade's priors.

use crate::config::RunConfig;
use crate::free_motion::{Evaluation, Interval};
use crate::io::{ImuData, ImuKind};
use crate::rests::{REST_MARGIN_S, Rest};
use sins_model::candidates::Candidate;
use sins_model::units::DEG_PER_HOUR;

/// Length of the blocks whose means give the white-noise level (s): the configuration's levels
/// are the standard deviation of a 1-s average.
const BLOCK_S: f64 = 1.0;

/// The terms a hand-turned recording is calibrated with by default, beyond the paper's four.
pub const DEFAULT_TERMS: [Candidate; 2] =
    [Candidate::GyroGSensitivity, Candidate::GyroScaleAsymmetry];

/// The attitude noise of a motion in a hand-turned recording without a configuration
/// (`filter.motion_attitude_noise_deg`): the floor the batch fit gave a gravity direction
/// carried from one pose to the next (0.1 deg), for what the gyros' model misses in a hand
/// turn. Not measured from the data: the first window after a motion is dominated by the
/// attitude uncertainty the priors leave (its predicted scatter on the Ferraris session was
/// larger than the observed), so its excess cannot show a tenth of a degree. With it the
/// Ferraris session's turns come to 360 deg within 1 deg without a hold-out (-362.4 deg on x
/// without it).
pub const MOTION_ATTITUDE_NOISE_DEG: f64 = 0.1;

/// The white-noise levels measured in the rests of a recording: each the standard deviation of
/// a 1-s mean of one axis, pooled over the rests and the three axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WhiteNoiseAtRest {
    /// Gyro (rad/s).
    pub gyro_rad_s: f64,
    /// Accelerometer (m/s^2).
    pub accel_m_s2: f64,
    /// Degrees of freedom of the pooled variance (per axis).
    pub dof: usize,
}

/// The scatter of the 1-s means in the rests ([`WhiteNoiseAtRest`]); each rest less
/// [`REST_MARGIN_S`] at both ends, cut into whole seconds, its own mean removed. `None` when no
/// rest holds two whole seconds.
pub fn white_noise_at_rest(data: &ImuData, rests: &[Rest]) -> Option<WhiteNoiseAtRest> {
    let records = &data.records;
    let t: Vec<f64> = records.iter().map(|r| r.t).collect();
    let (mut ss_w, mut ss_f, mut dof) = (0.0, 0.0, 0usize);
    for rest in rests {
        let (a, b) = (rest.t0 + REST_MARGIN_S, rest.t1 - REST_MARGIN_S);
        // Records whose whole interval (from the record before) lies in [a, b].
        let first = t.partition_point(|&x| x < a) + 1;
        let last = t.partition_point(|&x| x <= b);
        let mut blocks: Vec<([f64; 3], [f64; 3])> = Vec::new();
        let (mut sw, mut sf, mut span) = ([0.0; 3], [0.0; 3], 0.0);
        for k in first..last.min(records.len()) {
            let dt = t[k] - t[k - 1];
            if dt <= 0.0 {
                continue;
            }
            let r = &records[k];
            let (w, f) = match data.kind {
                ImuKind::Rates => (r.gyro, r.accel),
                ImuKind::Increments => (r.gyro.map(|x| x / dt), r.accel.map(|x| x / dt)),
            };
            for i in 0..3 {
                sw[i] += w[i] * dt;
                sf[i] += f[i] * dt;
            }
            span += dt;
            if span >= BLOCK_S - 1e-9 {
                blocks.push((sw.map(|x| x / span), sf.map(|x| x / span)));
                (sw, sf, span) = ([0.0; 3], [0.0; 3], 0.0);
            }
        }
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

/// The configuration of a hand-turned recording without one: no program, consumer-grade
/// priors, the site at `latitude_deg` (height 0), the record rate of the data (the mean
/// interval), specific-force windows of the whole records nearest one second, and `noise`.
/// `None` for fewer than two records or a non-positive span.
pub fn default_config(
    data: &ImuData,
    latitude_deg: f64,
    noise: &WhiteNoiseAtRest,
) -> Option<RunConfig> {
    let (first, last) = (data.records.first()?, data.records.last()?);
    let n = data.records.len();
    if n < 2 || last.t <= first.t {
        return None;
    }
    let rate = (n - 1) as f64 / (last.t - first.t);
    let mut c = RunConfig::paper();
    c.program = crate::config::PROGRAM_FROM_ANGLES.to_string();
    c.site.latitude_deg = latitude_deg;
    c.site.longitude_deg = 0.0;
    c.site.height_m = 0.0;
    let p = crate::free_motion::consumer_priors();
    c.priors.gyro_bias_deg_h = p.gyro_bias / DEG_PER_HOUR;
    c.priors.gyro_scale = p.gyro_scale;
    c.priors.gyro_misalignment_arcmin = p.gyro_misalignment / sins_model::units::ARCMIN;
    c.priors.accel_bias_m_s2 = p.accel_bias;
    c.priors.accel_scale = p.accel_scale;
    c.priors.accel_misalignment_arcmin = p.accel_misalignment / sins_model::units::ARCMIN;
    c.noise.gyro_deg_h = noise.gyro_rad_s / DEG_PER_HOUR;
    c.noise.accel_m_s2 = noise.accel_m_s2;
    c.filter.imu_rate_hz = rate;
    c.filter.accel_rate_hz = rate / (rate * BLOCK_S).round().max(1.0);
    c.filter.turntable_rate_hz = c.filter.accel_rate_hz;
    c.filter.motion_attitude_noise_deg = MOTION_ATTITUDE_NOISE_DEG;
    Some(c)
}

/// How many fits [`calibrate`] makes at most to bring measured noise to the data's scatter.
pub const MAX_NOISE_FITS: usize = 4;

/// Where the white-noise levels of a calibration came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum NoiseSource {
    /// The configuration's `[noise]`.
    Configured,
    /// Measured in the rests ([`white_noise_at_rest`]); the specific force's level then
    /// multiplied by `accel_factor` (at least 1) to the scatter of the filter's innovations
    /// (`fits` fits made).
    Measured {
        /// The rests' scatter.
        at_rest: WhiteNoiseAtRest,
        /// The factor on its specific-force level (1: the fit's mean NIS was in its band, or
        /// below it).
        accel_factor: f64,
        /// Fits made.
        fits: usize,
    },
}

/// The mean NIS of the specific-force windows, the recording's first left out (the start
/// tilt's prior is levelled from the same data, so its NIS is small by construction), and the
/// held-out ones. A rest's first window also holds what the motion before it did to the
/// attitude: with the vertical row taken to second order in the tilt
/// ([`crate::engine::Engine::vertical_second_order`]) that is a tilt the window measures, and
/// what remains is the unit settling (on the shipped Xsens recording a few first windows are 3
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
    /// From a fit's innovation log.
    pub fn of(innovations: &[crate::diagnostics::Innovation]) -> Self {
        let (mut windows, mut nis) = (0usize, 0.0);
        let accel = innovations
            .iter()
            .filter(|inn| inn.kind == crate::model::MeasurementKind::Accel);
        for inn in accel.skip(1) {
            if inn.held_out {
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

/// A calibration of a recording of rests with its held-out figures.
#[derive(Clone, Debug)]
pub struct HandTurnedResult {
    /// The filter's result.
    pub estimate: crate::estimate::Estimate,
    /// The configuration it ran with (the noise levels as finally used).
    pub config: RunConfig,
    /// Where its noise levels came from.
    pub noise: NoiseSource,
    /// The rests as static intervals of the data ([`crate::free_motion::Interval`]).
    pub intervals: Vec<Interval>,
    /// What the calibration does to the rests, the known turns and (with a hold-out) the
    /// held-out rests ([`crate::free_motion::evaluate`]).
    pub evaluation: Evaluation,
}

/// The rests as the records whose whole interval lies in them.
pub fn intervals_of(data: &ImuData, rests: &[Rest]) -> Vec<Interval> {
    let t: Vec<f64> = data.records.iter().map(|r| r.t).collect();
    rests
        .iter()
        .filter_map(|r| {
            let first = t.partition_point(|&x| x <= r.t0);
            let last = t.partition_point(|&x| x <= r.t1).checked_sub(1)?;
            (first <= last).then_some(Interval {
                first_record: first,
                last_record: last,
            })
        })
        .collect()
}

/// Calibrate a recording of rests (no program, no turntable) with the filter of
/// [`crate::estimate::calibrate_rests`], the model `layout`, the known `turns` as measurements,
/// every `holdout`-th rest held out (`filter.hold_out_every`), and report what the result does
/// to the rests, the turns and the held-out rests ([`HandTurnedResult`]).
///
/// With `measured` noise (the configuration's levels taken from [`white_noise_at_rest`]), the
/// specific-force level is brought to the fit's innovations ([`InnovationScatter`]), up to
/// [`MAX_NOISE_FITS`] fits: where the windows have a mean NIS outside its band, the level is
/// scaled by `sqrt(NIS / 3)`, never below the measured level (the rests' own scatter is a
/// floor of what the windows see; a real unit's rests also differ by what the model lacks).
/// Sigmas from a noise the innovations contradict are too small. The factor is reported.
#[allow(clippy::too_many_arguments)]
pub fn calibrate(
    config: &RunConfig,
    layout: &crate::layout::StateLayout,
    data: &ImuData,
    file: &str,
    rests: &[Rest],
    turns: &[crate::free_motion::KnownTurn],
    holdout: Option<usize>,
    measured: Option<WhiteNoiseAtRest>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<HandTurnedResult, crate::estimate::EstimateError> {
    let refuse = |source| crate::estimate::EstimateError::Rests {
        file: file.to_string(),
        source,
    };
    if let Some(every) = holdout.filter(|&k| k < 2 || k > rests.len()) {
        return Err(refuse(crate::rests::RestError::HoldOut {
            every,
            rests: rests.len(),
        }));
    }
    let mut config = config.clone();
    config.filter.hold_out_every = holdout;
    let filter_turns: Vec<crate::rests::Turn> = turns
        .iter()
        .filter_map(|k| crate::rests::Turn::of(k, data))
        .collect();
    let base_accel = config.noise.accel_m_s2;
    let mut factor = 1.0;
    let mut fits = 0;
    let estimate = loop {
        config.noise.accel_m_s2 = base_accel * factor;
        let est = crate::estimate::calibrate_rests(
            &config,
            layout,
            data,
            file,
            rests,
            &filter_turns,
            progress,
        )?;
        fits += 1;
        if measured.is_none() || fits == MAX_NOISE_FITS {
            break est;
        }
        let scatter = InnovationScatter::of(&est.innovations);
        let half = crate::report::lab::mean_nis_half_band(scatter.windows);
        if scatter.windows == 0 || (scatter.mean_nis - 3.0).abs() <= half {
            break est;
        }
        // Never below the rests' own scatter.
        let next = (factor * (scatter.mean_nis / 3.0).sqrt()).max(1.0);
        if next == factor {
            break est;
        }
        factor = next;
    };
    let intervals = intervals_of(data, rests);
    let g = config.site().specific_force_at_rest_enu().norm();
    let value = |name: &str| estimate.value(name);
    let evaluation = crate::free_motion::evaluate(data, &intervals, turns, holdout, g, &value);
    let noise = match measured {
        None => NoiseSource::Configured,
        Some(at_rest) => NoiseSource::Measured {
            at_rest,
            accel_factor: factor,
            fits,
        },
    };
    Ok(HandTurnedResult {
        estimate,
        config,
        noise,
        intervals,
        evaluation,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::ImuRecord;

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
        let n = white_noise_at_rest(&data, &rests).unwrap();
        // About 385 degrees of freedom per axis, 1155 over three: 2 % of sampling error.
        assert!(n.dof > 370, "{n:?}");
        assert!((n.gyro_rad_s / sigma_w - 1.0).abs() < 0.08, "{n:?}");
        assert!((n.accel_m_s2 / sigma_f - 1.0).abs() < 0.08, "{n:?}");
        let c = default_config(&data, 45.0, &n).unwrap();
        assert!((c.filter.imu_rate_hz - rate).abs() < 1e-6);
        assert_eq!(c.accel_interval_steps(), 100);
        assert!(c.program_from_angles());
    }
}
