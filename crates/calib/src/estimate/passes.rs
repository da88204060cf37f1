//! The passes over the records: iterated to convergence, each one set up, run over the records
//! with the instruction set the processor has, and read out as an estimate.

use super::pass::{
    AngleReader, Feedback, Linearisation, Pass, PassResult, PassSettings, Strapdown,
};

use super::start_point::start_filter;
use super::{
    Estimate, EstimateError, ImuSource, Motion, Nominal, PROGRESS_EVERY, PassInputs, Replay,
    SitePriors, consider, score_pass,
};

use crate::check::diagnostics;
use crate::config::RunConfig;
use crate::io::{ImuKind, ImuRecord};
use crate::model::LinearModel;
use crate::model::engine::{Engine, MeasurementNoise, Schedule};
use crate::model::layout::StateLayout;
use nalgebra::{DMatrix, Matrix3, Vector3};
use sins_model::attitude::exp_so3;

/// The passes over the data: a first pass from `first` (or the prior) that feeds back
/// `first_feedback` (everything: closed loop), or with `warm` one linearised about `first` as
/// the later passes are (the converged estimates of a fit of a model that differs only in
/// its noise: the model-extension loop's walk), then passes
/// linearised about the one before until no parameter moves by more than
/// [`CONVERGED_SIGMA`]; the second-order specific-force error is then carried into the
/// covariance through the final pass's sensitivity to a residual offset.
pub(super) fn iterate_passes(
    inp: &PassInputs,
    imu: &mut dyn ImuSource,
    first: Option<Nominal>,
    first_feedback: Feedback,
    warm: bool,
    tolerance_sigma: Option<f64>,
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
    let (max_passes, converged) = pass_limits(motion, tolerance_sigma);
    let total = (1 + max_passes) * n;
    let tilt_walks =
        gyro_noise_walks_the_tilt(config, inp.plan, n as f64 / config.filter.imu_rate_hz);
    let mut nominal = first;
    let mut shift = f64::INFINITY;
    let mut pass = 0;
    let mut sensitivity;
    let mut estimate = loop {
        let done = (1 + pass) * n;
        let feedback = if pass == 0 && !warm {
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
        // A warm start (`first` the converged estimates of a fit of a neighbouring model) is
        // a pass like the later ones: it may be the last.
        if let (Some(prev), true) = (&nominal, pass > 1 || warm) {
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

/// The most passes of a fit of `motion`, and the largest shift (posterior sigmas) of a pass
/// that ends it: `tolerance_sigma` where given. Recordings of rests may carry per-cent errors,
/// about which the linearised model converges more slowly (a consumer-grade simulated run: NEES
/// 79 after four passes, 40 after eight).
fn pass_limits(motion: &Motion, tolerance_sigma: Option<f64>) -> (usize, f64) {
    let (max_passes, converged) = match motion {
        Motion::Program(_) => (MAX_PASSES, CONVERGED_SIGMA),
        Motion::Rests { .. } => (MAX_PASSES_RESTS, CONVERGED_SIGMA_RESTS),
    };
    (max_passes, tolerance_sigma.unwrap_or(converged))
}

/// The start heading's posterior sigma above which a pass does not move the next pass's start
/// heading (rad): the gyrocompassing threshold of [`crate::motion::rests`].
pub(super) const HEADING_UNRESOLVED_RAD: f64 = crate::motion::rests::GYROCOMPASS_MAX_SIGMA_RAD;

/// Whether the gyro noise walks the tilt of a trajectory integrated over `run_s` far enough
/// that its second-order specific-force error (`g sigma^2 / 2`, `sigma^2 = q run_s`) exceeds
/// a tenth of the noise of one specific-force measurement: then later passes on a recording of
/// rests feed the tilt back ([`Feedback::Tilt`]). A MEMS gyro (120 deg/h in a 1-s average)
/// over nine minutes: 9e-4 m/s^2 against 1.2e-3; the paper's (0.1 deg/h): 6e-10 against 1e-3.
/// Not on every recording: on one whose configured accelerometer noise is ten times too low
/// (crates/sins-calib/tests/rests.rs) the fed-back tilt ran away (mean NIS 6.4e6 against 281
/// without).
pub(super) fn gyro_noise_walks_the_tilt(config: &RunConfig, plan: &SitePriors, run_s: f64) -> bool {
    let g = plan.gravity_m_s2;
    let second_order = 0.5 * g * config.gyro_psd() * run_s;
    let one_measurement = (config.accel_psd() * config.filter.accel_rate_hz).sqrt();
    second_order > 0.1 * one_measurement
}

/// Set by [`force_baseline_instructions`].
pub(super) static BASELINE_ONLY: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);
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
pub(super) struct Steps<'p, 'a, 'c> {
    pub(super) pass: &'p mut Pass<'a>,
    pub(super) chunk: &'c [(crate::io::ImuRecord, usize)],
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
pub(super) const MAX_PASSES: usize = 4;

/// Most passes over a recording of rests (`at_rests::fit_at_rests`).
pub(crate) const MAX_PASSES_RESTS: usize = 8;

/// A pass whose estimates moved less than this (posterior sigmas, largest over the parameters)
/// from the pass before ends the iteration.
pub(super) const CONVERGED_SIGMA: f64 = 0.02;

/// [`CONVERGED_SIGMA`] on a recording of rests. Its passes contract by a factor of about ten
/// each (largest shifts 0.17, 0.020, 0.0019 sigma on the 324-s consumer-grade recording of
/// docs/performance.md; 0.50, 0.027, 0.004 on the shipped Xsens recording), so a pass that
/// moved less than this leaves the next one to move less than a hundredth of a sigma; at 0.02
/// both recordings ran a fourth pass for that, a seventh of the whole job's CPU time.
pub(crate) const CONVERGED_SIGMA_RESTS: f64 = 0.05;

/// The tolerance of a fit whose estimates only measure the noise for the next fit (the noise
/// fixed point's fits before its last, `hand_turned::fit_measuring_noise`): a pass that moved
/// less than this leaves the next to move less than [`CONVERGED_SIGMA_RESTS`] (the tenfold
/// contraction above), and the fit's innovations, from which the noise is measured, are those
/// of the fixed point to a few hundredths of a sigma of the parameters. The fit whose levels
/// settle is then taken on to [`CONVERGED_SIGMA_RESTS`].
pub(crate) const PROVISIONAL_SIGMA_RESTS: f64 = 0.5;

/// The IMU-time intervals whose measurements a fit with `filter.hold_out_every = every` holds
/// out: every `every`-th segment with measurements, counted from 1 (the program's segments;
/// the rests of a recording of rests, whose motions have none).
pub(super) fn held_out_windows(
    motion: &Motion,
    program_start: f64,
    every: usize,
) -> Vec<(f64, f64)> {
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
pub(super) type PassOutcome = (Estimate, Matrix3<f64>, Option<DMatrix<f64>>);

/// One pass over the data, linearised about `nominal` (the prior means and the program's
/// start attitude if `None`): compensation, turntable reading and start attitude with the
/// nominal values, the prior mean of each error state the prior mean less the nominal value.
/// `feedback` says what the pass feeds back as it goes ([`Feedback`]).
pub(super) fn run_pass(
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
pub(super) fn pass_engine(
    inp: &PassInputs,
    filter: kalman::KalmanFilter,
    track_offset: bool,
) -> Engine {
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
pub(super) fn pass_settings(inp: &PassInputs, kind: ImuKind, feedback: Feedback) -> PassSettings {
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
pub(super) fn set_up_pass<'r>(
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
pub(super) fn motion_before(inp: &PassInputs, c0: &Matrix3<f64>) -> (Vector3<f64>, Vector3<f64>) {
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
pub(super) fn run_records(
    pass: &mut Pass,
    imu: &mut dyn ImuSource,
    first_time: f64,
    progress: &mut dyn FnMut(usize),
) -> Result<f64, EstimateError> {
    imu.rewind()?;
    let mut j = 0;
    let mut final_time = first_time;
    let arch = if BASELINE_ONLY.load(std::sync::atomic::Ordering::Relaxed) {
        pulp::Arch::Scalar
    } else {
        pulp::Arch::new()
    };
    let mut step_chunk = |pass: &mut Pass, chunk: &[(ImuRecord, usize)]| {
        arch.dispatch(Steps { pass, chunk })?;
        if let Some((rec, _)) = chunk.last() {
            final_time = rec.t;
        }
        j += chunk.len();
        progress(j);
        Ok::<(), EstimateError>(())
    };
    if let Some(all) = imu.held() {
        // Held in memory: stepped in place, not copied out chunk by chunk.
        for chunk in all.chunks(PROGRESS_EVERY) {
            step_chunk(pass, chunk)?;
        }
    } else {
        let mut chunk = Vec::with_capacity(PROGRESS_EVERY);
        loop {
            imu.next_chunk(&mut chunk, PROGRESS_EVERY)?;
            if chunk.is_empty() {
                break;
            }
            step_chunk(pass, &chunk)?;
        }
    }
    // A streamed angle file that could not be read to the end (changed since it was opened).
    if let Some(e) = pass.angles.as_mut().and_then(|a| a.interp.take_error()) {
        return Err(e.into());
    }
    Ok(final_time)
}

/// The estimate of a finished pass over records of `imu_kind` that ended at `final_time`,
/// its innovations assigned to the motion's segments; and the pass's offset sensitivity.
pub(super) fn pass_estimate(
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
        likelihood_ratios: Vec::new(),
        replay: None,
    };
    (estimate, offset_sensitivity)
}
