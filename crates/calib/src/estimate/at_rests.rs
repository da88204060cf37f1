//! A fit of a recording of rests (no program, no turntable angles): its checks, the start
//! levelled in the first rest, the passes, and the score tests' pass.

use super::pass::Feedback;
use super::passes::{gyro_noise_walks_the_tilt, iterate_passes};
use super::programmed::first_pass_feedback;
use super::scan::{Spacing, scan_imu};
use super::{
    Estimate, EstimateError, ImuSource, Motion, Nominal, PassInputs, Scan, SitePriors, score_pass,
};

use crate::config::RunConfig;
use crate::estimate::data_checks::{check_gyros_alive, check_specific_force_within};
use crate::io::IoError;
use crate::model::layout::StateLayout;
use crate::motion::rests::{Rest, RestError};

/// Calibrate a recording without a program or turntable angles: the unit rests in several
/// orientations (`rests`, on the IMU clock, in time order) and is turned between them in any
/// way. The same filter as for a program ([`crate::estimate::run`]), with the specific force
/// measured only where every step of a window lies in a rest (less
/// [`crate::motion::rests::REST_MARGIN_S`] at both ends), the start attitude levelled in the first
/// rest (and gyrocompassed where the gyros resolve the Earth rate), and the attitude carried by the
/// gyros through every motion ([`crate::motion::rests`]). The layout must be an IMU-only one.
///
/// `start.coarse` is where the first pass starts: the totals of the instrument parameters (in
/// the layout's order), or `None` for the prior means ([`RestsStart`]). Units whose errors are large (per-cent scale
/// factors, degrees per second of bias) need one ([`super::coarse_start::coarse_start_at_rests`]
/// makes it).
pub(super) fn fit_at_rests(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    rests: &[Rest],
    turns: &[crate::motion::rests::Turn],
    start: RestsStart,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let recording = Recording { rests, turns };
    let plan = SitePriors::of(config);
    rests_estimate(config, &plan, layout, imu, recording, start, progress)
}

/// Where a fit of a recording of rests starts.
#[derive(Clone, Copy, Default)]
pub(super) struct RestsStart<'a> {
    /// The totals of the instrument parameters (in the layout's order) the first pass starts
    /// from, or `None` for the prior means ([`fit_at_rests`]).
    pub(super) coarse: Option<&'a [f64]>,
    /// A fit of the same states on the same records with other noise levels (the noise fixed
    /// point's fit before): its converged estimates are the first linearisation point, its
    /// first pass one like the later ones, which may be the last.
    pub(super) warm: Option<&'a Estimate>,
    /// The largest shift (posterior sigmas) of a pass that ends the fit, if not the default
    /// (`passes::CONVERGED_SIGMA_RESTS`): a looser one for a fit that only measures the noise.
    pub(super) tolerance_sigma: Option<f64>,
}

/// The rests and known turns of a recording without a program.
#[derive(Clone, Copy)]
pub(super) struct Recording<'a> {
    /// The rests, on the IMU clock, in time order.
    pub(super) rests: &'a [Rest],
    /// Known turns between them.
    pub(super) turns: &'a [crate::motion::rests::Turn],
}

/// [`fit_at_rests`] with its site and priors resolved.
pub(super) fn rests_estimate(
    config: &RunConfig,
    plan: &SitePriors,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    recording: Recording,
    start: RestsStart,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    let rests = recording.rests;
    if layout.install.is_some() {
        return Err(EstimateError::Rests {
            file: imu.file().to_string(),
            source: RestError::WithTurntable,
        });
    }
    // A warm start is a fit of the same records: their first reading is its.
    let rate = config.filter.imu_rate_hz;
    let held = start
        .warm
        .and_then(|w| w.replay.as_ref())
        .and_then(|r| r.scan_at(rate));
    let scan = match held {
        Some(scan) => scan,
        None => std::sync::Arc::new(scan_of_rests(imu, rate, progress)?),
    };
    check_recording_of_rests(config, plan, &scan, rests, imu.file())?;
    let (motion, first_point) =
        motion_at_rests(config, plan, layout, &scan, recording, start.coarse).map_err(
            |source| EstimateError::Rests {
                file: imu.file().to_string(),
                source,
            },
        )?;
    let feedback = first_feedback_at_rests(config, &motion, first_point.is_some());
    let warm = start.warm.and_then(|w| w.warm_start(layout));
    let inp = PassInputs {
        config,
        plan,
        layout,
        turntable: None,
        scan: &scan,
        motion: &motion,
    };
    let is_warm = warm.is_some();
    let first = warm.or(first_point);
    let mut est = iterate_passes(
        &inp,
        imu,
        first,
        feedback,
        is_warm,
        start.tolerance_sigma,
        progress,
    )?;
    if let Some(replay) = est.replay.as_mut() {
        replay.scan = Some((scan.clone(), rate));
    }
    Ok(est)
}

/// The first reading of a recording of rests: its program (the filter's time origin) starts
/// one step before the first record.
fn scan_of_rests(
    imu: &mut dyn ImuSource,
    rate: f64,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Scan, EstimateError> {
    let mut scan = scan_imu(imu, rate, Spacing::Jittered, progress)?;
    scan.program_start = scan.span.0 - 1.0 / rate;
    scan.program_start_found = false;
    Ok(scan)
}

/// A fit of the noise fixed point that stopped at [`super::passes::PROVISIONAL_SIGMA_RESTS`]
/// taken on from its estimates, with the same levels, until a pass moves less than the full
/// tolerance (`passes::CONVERGED_SIGMA_RESTS`): the passes a fit made at the full tolerance
/// from the start would have made after those. A fit that already got there, or that ran all
/// its passes (as a fit at the full tolerance would have), is returned as it is.
pub(super) fn converge_provisional(
    config: &RunConfig,
    layout: &StateLayout,
    (imu, recording): (&mut dyn ImuSource, Recording),
    coarse: Option<&[f64]>,
    est: Estimate,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate, EstimateError> {
    use super::passes::{CONVERGED_SIGMA_RESTS, MAX_PASSES_RESTS};
    let shift = est.stats.first_pass_shift_sigma;
    if shift < CONVERGED_SIGMA_RESTS || est.stats.passes >= MAX_PASSES_RESTS {
        return Ok(est);
    }
    let start = RestsStart {
        coarse,
        warm: Some(&est),
        tolerance_sigma: None,
    };
    let (rests, turns) = (recording.rests, recording.turns);
    let mut refined = fit_at_rests(config, layout, imu, rests, turns, start, progress)?;
    refined.stats.passes += est.stats.passes;
    Ok(refined)
}

/// The extended pass of the score tests ([`score_pass`]) for a fit `est` of a recording of
/// rests in `data` made with `config` and `layout`: linearised about the fit's last estimates,
/// with its motion, priors and held-out rests. `calibrate` makes it once, after the noise fixed
/// point settles (each fit of the fixed point would otherwise make its own). Nothing to do for
/// a fit that kept no replay.
pub(super) fn score_rests(
    config: &RunConfig,
    layout: &StateLayout,
    imu: &mut dyn ImuSource,
    est: &mut Estimate,
) -> Result<(), EstimateError> {
    let Some(replay) = est.replay.take() else {
        return Ok(());
    };
    let plan = SitePriors::of(config);
    let rate = config.filter.imu_rate_hz;
    let scan = match replay.scan_at(rate) {
        Some(scan) => scan,
        None => std::sync::Arc::new(scan_of_rests(imu, rate, &mut |_, _| {})?),
    };
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
pub(super) fn check_recording_of_rests(
    config: &RunConfig,
    plan: &SitePriors,
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
pub(super) fn motion_at_rests(
    config: &RunConfig,
    plan: &SitePriors,
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
pub(super) fn first_feedback_at_rests(
    config: &RunConfig,
    motion: &Motion,
    coarse_start: bool,
) -> Feedback {
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

/// How far the mean record interval of a recording of rests may be from the configured one.
pub(super) const MEAN_INTERVAL_TOLERANCE: f64 = 0.01;
