//! Where the rotation program starts on the IMU clock, found from the data.
//!
//! A recording never starts exactly when the program does. The magnitude of the measured rate
//! does not depend on how the unit is mounted, so it can be matched against the magnitude of
//! the program's platform rate: first on one-second blocks over every admissible start (the
//! whole program must lie within the data), then on the scan's short bins around the best one,
//! and last to well below one bin by minimising the misfit of the exact bin means (the rate of a
//! program piece is constant in the platform frame, so a bin that straddles a change of rate
//! averages the two rates by the time spent in each; an error of 1 ms in the start moves such a
//! bin's mean by 3.5e-3 rad/s at the paper's reversals, against 2e-4 rad/s from a 1e-3 scale
//! error).

use crate::motion::align::RateBin;
use sins_model::earth::Site;
use turntable::kinematics::{Kinematics, Mounting};
use turntable::program::Program;

/// Why the program's start could not be found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProgramStartError {
    /// The data are shorter than the program.
    #[error(
        "the IMU data span {data_s:.3} s but the program lasts {program_s:.3} s: expected a \
         recording of the whole program"
    )]
    TooShort {
        /// Length of the data (s).
        data_s: f64,
        /// Length of the program (s).
        program_s: f64,
    },
    /// The program never turns, so its start cannot be seen in the rates.
    #[error(
        "the program does not turn the platform, so its start cannot be found from the rates: \
         give it with --program-start SECONDS (the IMU time at which the program starts)"
    )]
    NoRotation,
    /// The program's rate changes fall elsewhere in the data than a given start puts them.
    #[error(
        "the program's changes of rate are at a start of t = {found_s:.4} s on the IMU clock in \
         these data, not at the given start t = {given_s:.4} s: check --program-start (or leave \
         it out to use the start found from the data)"
    )]
    Elsewhere {
        /// The start given (s).
        given_s: f64,
        /// The start the rate changes put it at (s).
        found_s: f64,
    },
    /// The measured rates do not follow the program from a start given by the user.
    #[error(
        "the measured rotation rates do not follow the program from the given start \
         t = {given_s} s on the IMU clock (--program-start or filter.program_start_s): an RMS \
         misfit of {rms_deg_s:.3} deg/s in the rate magnitude (at most {limit_deg_s:.3} deg/s \
         expected); check the start given (leave it out to find it from the data)"
    )]
    NotAtGiven {
        /// The start given (s).
        given_s: f64,
        /// Its RMS misfit (deg/s).
        rms_deg_s: f64,
        /// The misfit accepted (deg/s).
        limit_deg_s: f64,
    },
    /// A start given by the user puts the program outside the records.
    #[error(
        "the program from the given start t = {given_s} s on the IMU clock (--program-start or \
         filter.program_start_s) lies outside the records (t = {first_s} .. {last_s} s): \
         expected a start within them (leave it out to find it from the data)"
    )]
    OutsideData {
        /// The start given (s).
        given_s: f64,
        /// The first and last record's time (s).
        first_s: f64,
        /// The last record's time (s).
        last_s: f64,
    },
    /// The measured rates do not follow the program at any start.
    #[error(
        "the measured rotation rates do not follow the program at any start time: the best \
         start, t = {best_s:.3} s on the IMU clock, leaves an RMS misfit of {rms_deg_s:.3} deg/s \
         in the rate magnitude (at most {limit_deg_s:.3} deg/s expected); check the program, \
         the gyro units (deg/s given as rad/s is a factor of 57) and the column order"
    )]
    NoMatch {
        /// The best start found (s).
        best_s: f64,
        /// Its RMS misfit (deg/s).
        rms_deg_s: f64,
        /// The misfit accepted (deg/s).
        limit_deg_s: f64,
    },
}

/// The program's start on the IMU clock and how well the data follow the program from there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProgramStart {
    /// IMU time at which the program's time 0 falls (s).
    pub t_imu_s: f64,
    /// RMS misfit of the rate magnitude over the program (rad/s).
    pub rms_misfit: f64,
}

/// The program's platform rate (rad/s, platform axes, with the Earth rate) as exact means over
/// intervals of program time.
struct Profile {
    kin: Kinematics,
    /// Piece boundaries (program time), with the rest before and after.
    edges: Vec<f64>,
}

impl Profile {
    fn new(program: &Program, site: &Site) -> Self {
        let mut edges: Vec<f64> = program.pieces().iter().map(|p| p.t0).collect();
        edges.push(program.duration());
        Self {
            kin: Kinematics::new(program.clone(), Mounting::default(), *site),
            edges,
        }
    }

    /// Mean rate over the program-time interval `(a, b)`: each piece's (constant) rate weighted
    /// by its share of the interval.
    fn mean(&self, a: f64, b: f64) -> nalgebra::Vector3<f64> {
        // The cuts a, the edges inside (a, b), b, walked without collecting them (this runs
        // for every bin at every trial start).
        let k = self.edges.partition_point(|&e| e <= a);
        let inner = self.edges[k..].iter().copied().take_while(|&e| e < b);
        let mut sum = nalgebra::Vector3::zeros();
        let mut lo = a;
        for hi in inner.chain(std::iter::once(b)) {
            sum += self.kin.sample(0.5 * (lo + hi)).omega_body * (hi - lo);
            lo = hi;
        }
        sum / (b - a)
    }
}

/// Sum of squared misfits of the rate magnitude with the program started at `s`, over the bins
/// within the program, and their number.
fn misfit(bins: &[RateBin], profile: &Profile, duration: f64, s: f64) -> (f64, usize) {
    let (mut sse, mut n) = (0.0, 0);
    for b in bins {
        let (a, e) = (b.t0 - s, b.t1 - s);
        if a < 0.0 || e > duration {
            continue;
        }
        let d = b.rate.norm() - profile.mean(a, e).norm();
        sse += d * d;
        n += 1;
    }
    (sse, n)
}

/// [`misfit`] over the bins within `half_width` of a change of the program's rate only: they
/// carry the timing; elsewhere the misfit hardly depends on the start.
fn misfit_near_changes(
    bins: &[RateBin],
    profile: &Profile,
    changes: &[f64],
    s: f64,
    half_width: f64,
) -> f64 {
    let (mut sse, mut n) = (0.0, 0usize);
    for &c in changes {
        let (a, b) = (c + s - half_width, c + s + half_width);
        let k = bins.partition_point(|bin| bin.t1 <= a);
        // Outside the program the platform rests: data that turn there count against `s`.
        for bin in bins[k..].iter().take_while(|bin| bin.t0 < b) {
            let (x, y) = (bin.t0 - s, bin.t1 - s);
            let d = bin.rate.norm() - profile.mean(x, y).norm();
            sse += d * d;
            n += 1;
        }
    }
    sse / n.max(1) as f64
}

/// Find the program's start on the IMU clock from the scan's rate bins.
pub fn find_program_start(
    bins: &[RateBin],
    program: &Program,
    site: &Site,
) -> Result<ProgramStart, ProgramStartError> {
    let duration = program.duration();
    let (Some(first), Some(last)) = (bins.first(), bins.last()) else {
        return Err(ProgramStartError::TooShort {
            data_s: 0.0,
            program_s: duration,
        });
    };
    let (t_first, t_last) = (first.t0, last.t1);
    // Half a bin of slack at either end: the bins need not line up with the program.
    let slack = 0.5 * (first.t1 - first.t0);
    if t_last - t_first + 2.0 * slack < duration {
        return Err(ProgramStartError::TooShort {
            data_s: t_last - t_first,
            program_s: duration,
        });
    }
    if program.pieces().iter().all(|p| p.rate == [0.0; 3]) {
        return Err(ProgramStartError::NoRotation);
    }
    let profile = Profile::new(program, site);
    let (lo, hi) = (t_first - slack, t_last + slack - duration);
    let coarse = coarse_start(bins, &profile, duration, lo, hi);
    // Bins around the coarse start, then golden-section search between neighbouring bins.
    let step = first.t1 - first.t0;
    let changes = crate::model::engine::RateChanges::new(program);
    let near = |s: f64| misfit_near_changes(bins, &profile, changes.times(), s, 3.0);
    let mut best = (f64::INFINITY, coarse);
    let mut s = (coarse - 2.0).max(lo);
    while s <= (coarse + 2.0).min(hi) {
        let v = near(s);
        if v < best.0 {
            best = (v, s);
        }
        s += step;
    }
    let t = golden_section(near, (best.1 - step).max(lo), (best.1 + step).min(hi), 1e-5);
    let (sse, n) = misfit(bins, &profile, duration, t);
    let rms = (sse / n.max(1) as f64).sqrt();
    let rate_rms = program_rate_rms(&profile, duration);
    // Gyro scale errors of up to 1 % and biases of a few deg/h leave a misfit far below this;
    // a wrong program, wrong units or a wrong column leave far more.
    let limit = 0.05 * rate_rms + 1e-3;
    if rms > limit {
        return Err(ProgramStartError::NoMatch {
            best_s: t,
            rms_deg_s: rms.to_degrees(),
            limit_deg_s: limit.to_degrees(),
        });
    }
    Ok(ProgramStart {
        t_imu_s: t,
        rms_misfit: rms,
    })
}

/// Check a start given by the user: the data must follow the program from there, and the
/// program's changes of rate must fall where the data have them (within `tolerance_s`).
pub fn check_program_start(
    bins: &[RateBin],
    program: &Program,
    site: &Site,
    start: f64,
    tolerance_s: f64,
) -> Result<ProgramStart, ProgramStartError> {
    let profile = Profile::new(program, site);
    let duration = program.duration();
    let (sse, n) = misfit(bins, &profile, duration, start);
    let rms = (sse / n.max(1) as f64).sqrt();
    let limit = 0.05 * program_rate_rms(&profile, duration) + 1e-3;
    if n == 0 {
        return Err(ProgramStartError::OutsideData {
            given_s: start,
            first_s: bins.first().map_or(f64::NAN, |b| b.t0),
            last_s: bins.last().map_or(f64::NAN, |b| b.t1),
        });
    }
    if rms > limit {
        return Err(ProgramStartError::NotAtGiven {
            given_s: start,
            rms_deg_s: rms.to_degrees(),
            limit_deg_s: limit.to_degrees(),
        });
    }
    // Where do the rate changes near the given start put it?
    let changes = crate::model::engine::RateChanges::new(program);
    if !changes.times().is_empty() {
        let step = bins.first().map_or(0.1, |b| b.t1 - b.t0);
        let near = |s: f64| misfit_near_changes(bins, &profile, changes.times(), s, 3.0);
        let (mut best, mut s) = ((f64::INFINITY, start), start - 2.0);
        while s <= start + 2.0 {
            let v = near(s);
            if v < best.0 {
                best = (v, s);
            }
            s += step;
        }
        let found = golden_section(near, best.1 - step, best.1 + step, 1e-5);
        // Refuse only when the data clearly prefer the other start: where they say nothing
        // (a recording that begins with the program shows no rest before it), the misfit is
        // flat. The floor is the misfit a 1e-3 scale error leaves at the paper's rates.
        let floor = 2.5e-7;
        if (found - start).abs() > tolerance_s && near(start) > 2.0 * near(found) + floor {
            return Err(ProgramStartError::Elsewhere {
                given_s: start,
                found_s: found,
            });
        }
    }
    Ok(ProgramStart {
        t_imu_s: start,
        rms_misfit: rms,
    })
}

/// RMS of the program's rate magnitude (rad/s), on one-second means.
fn program_rate_rms(profile: &Profile, duration: f64) -> f64 {
    let n = duration.floor().max(1.0) as usize;
    let sum: f64 = (0..n)
        .map(|i| {
            profile
                .mean(i as f64, (i as f64 + 1.0).min(duration))
                .norm_squared()
        })
        .sum();
    (sum / n as f64).sqrt()
}

/// The best start on a one-second grid, from one-second means of the rate magnitude.
fn coarse_start(bins: &[RateBin], profile: &Profile, duration: f64, lo: f64, hi: f64) -> f64 {
    // Data: mean magnitude per second of IMU time, from the bins.
    let t0 = lo.floor();
    let n_data = (bins.last().map_or(0.0, |b| b.t1) - t0).ceil().max(1.0) as usize + 1;
    let (mut sum, mut count) = (vec![0.0; n_data], vec![0usize; n_data]);
    for b in bins {
        let k = (0.5 * (b.t0 + b.t1) - t0).floor();
        if k >= 0.0 && (k as usize) < n_data {
            sum[k as usize] += b.rate.norm();
            count[k as usize] += 1;
        }
    }
    let data: Vec<Option<f64>> = sum
        .iter()
        .zip(&count)
        .map(|(s, &c)| (c > 0).then(|| s / c as f64))
        .collect();
    let n_prog = duration.floor() as usize;
    let prog: Vec<f64> = (0..n_prog)
        .map(|i| profile.mean(i as f64, i as f64 + 1.0).norm())
        .collect();
    let mut best = (f64::INFINITY, lo);
    let mut s = lo;
    while s <= hi + 1e-9 {
        let off = s - t0;
        let (mut sse, mut n) = (0.0, 0usize);
        for (i, p) in prog.iter().enumerate() {
            let k = (off + i as f64).round();
            if let Some(Some(d)) = (k >= 0.0).then(|| data.get(k as usize).copied()).flatten() {
                sse += (d - p) * (d - p);
                n += 1;
            }
        }
        let v = sse / n.max(1) as f64;
        if n > 0 && v < best.0 {
            best = (v, s);
        }
        s += 1.0;
    }
    best.1
}

/// Minimum of a unimodal function on `[a, b]` to within `tol`.
fn golden_section(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, tol: f64) -> f64 {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    while (b - a).abs() > tol {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - r * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

/// Why the turntable angles do not follow the program on the clock relation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TurntableClockError {
    /// The angles hardly move although the program turns.
    #[error(
        "the gimbal angles stay within {range_deg:.3} deg while the program turns the platform \
         by up to {program_deg:.1} deg: expected angles that follow the program (constant \
         angles: a stuck sensor or the wrong columns)"
    )]
    Constant {
        /// Largest spread of a recorded gimbal angle (deg).
        range_deg: f64,
        /// Largest spread of the program's gimbal angles (deg).
        program_deg: f64,
    },
    /// The angles look like radians.
    #[error(
        "the gimbal angles follow the program once multiplied by 180/pi (largest magnitude \
         {max_abs:.3} while the program's reach {program_deg:.1} deg): the angles look like \
         radians; the file must give them in degrees"
    )]
    Radians {
        /// Largest recorded magnitude.
        max_abs: f64,
        /// Largest magnitude of the program's angles (deg).
        program_deg: f64,
    },
    /// The angles follow the program at another time offset.
    #[error(
        "the gimbal angles follow the program {shift_s:+.3} s later on the IMU clock than the \
         [clock] relation puts them (RMS {rms_deg:.3} deg there, {rms_at_zero_deg:.3} deg with \
         the relation as given): check the [clock] relation (clock.turntable_offset_s = \
         {offset_s:.3} s would put them there)"
    )]
    Shifted {
        /// Shift of the best fit (IMU clock, s).
        shift_s: f64,
        /// RMS angle misfit at that shift (deg).
        rms_deg: f64,
        /// RMS angle misfit with the relation as given (deg).
        rms_at_zero_deg: f64,
        /// The turntable clock offset that would fit (s).
        offset_s: f64,
    },
    /// The angles do not follow the program at any offset.
    #[error(
        "the gimbal angles do not follow the program at any clock offset: RMS misfit \
         {rms_deg:.3} deg at best (at most {limit_deg:.3} deg expected); check the program and \
         the column order (heading, bank, pitch)"
    )]
    NoMatch {
        /// Best RMS misfit (deg).
        rms_deg: f64,
        /// Accepted misfit (deg).
        limit_deg: f64,
    },
}

/// Check the turntable records against the program through the clock relation: the recorded
/// gimbal angles at turntable time `t_tt` must be the program's at program time
/// `clock.imu_time(t_tt) - program_start - tau` for a delay `tau` of at most `max_delay_s`.
/// Refuses constant angles, radians and a clock offset that is off, naming the likely cause.
pub fn check_turntable_clock(
    sample: &[crate::io::TurntableRecord],
    clock: &crate::config::ClockConfig,
    program: &Program,
    program_start: f64,
    max_delay_s: f64,
) -> Result<(), TurntableClockError> {
    if sample.len() < 2 {
        return Ok(());
    }
    let misfit = AngleMisfit {
        sample,
        clock,
        program,
        program_start,
        duration: program.duration(),
    };
    let (spread, max_abs) = extent(sample.iter().map(|r| r.k_deg));
    let (prog_spread, prog_abs) = misfit.program_extent();
    if prog_spread > 10.0 && spread < 0.01 * prog_spread {
        return Err(TurntableClockError::Constant {
            range_deg: spread,
            program_deg: prog_spread,
        });
    }
    let at_zero = misfit.rms(0.0).unwrap_or(f64::INFINITY);
    // The fastest gimbal rate times the largest delay, plus sensor noise and a margin.
    let max_rate = program
        .pieces()
        .iter()
        .flat_map(|p| p.rate)
        .fold(0.0_f64, |m, r| m.max(r.abs()))
        .to_degrees();
    let limit = max_rate * max_delay_s + 0.05;
    if at_zero <= limit {
        return Ok(());
    }
    let best = misfit.best_shift(at_zero);
    let radians = |m: &AngleMisfit| {
        m.rms_scaled(0.0, 180.0 / std::f64::consts::PI)
            .is_some_and(|v| v <= limit)
    };
    if best.0 > limit && radians(&misfit) {
        return Err(TurntableClockError::Radians {
            max_abs,
            program_deg: prog_abs,
        });
    }
    if best.0 <= limit {
        return Err(TurntableClockError::Shifted {
            shift_s: best.1,
            rms_deg: best.0,
            rms_at_zero_deg: at_zero,
            offset_s: clock.turntable_offset_s + best.1 * (1.0 + clock.turntable_rate_error),
        });
    }
    Err(TurntableClockError::NoMatch {
        rms_deg: best.0,
        limit_deg: limit,
    })
}

/// The largest spread of a gimbal angle over `angles` (deg) and their largest magnitude.
fn extent(angles: impl Iterator<Item = [f64; 3]>) -> (f64, f64) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let mut max_abs: f64 = 0.0;
    for k in angles {
        for g in 0..3 {
            lo[g] = lo[g].min(k[g]);
            hi[g] = hi[g].max(k[g]);
            max_abs = max_abs.max(k[g].abs());
        }
    }
    let spread = (0..3).map(|g| hi[g] - lo[g]).fold(0.0, f64::max);
    (spread, max_abs)
}

/// The turntable records of [`check_turntable_clock`] against the program.
struct AngleMisfit<'a> {
    sample: &'a [crate::io::TurntableRecord],
    clock: &'a crate::config::ClockConfig,
    program: &'a Program,
    program_start: f64,
    duration: f64,
}

impl AngleMisfit<'_> {
    /// The program's gimbal angles at program time `t` (deg).
    fn program_deg(&self, t: f64) -> [f64; 3] {
        self.program.state(t).0.map(f64::to_degrees)
    }

    /// [`extent`] of the program's angles, at 2001 instants over the program.
    fn program_extent(&self) -> (f64, f64) {
        extent((0..=2000).map(|i| self.program_deg(self.duration * i as f64 / 2000.0)))
    }

    /// RMS angle misfit (deg) of the records inside the program with the records taken
    /// `shift` later on the IMU clock, the recorded values multiplied by `scale` (`None`: no
    /// record inside).
    fn rms_scaled(&self, shift: f64, scale: f64) -> Option<f64> {
        let (mut sse, mut n) = (0.0, 0usize);
        for r in self.sample {
            let t = self.clock.imu_time(r.t) - self.program_start - shift;
            if !(0.0..=self.duration).contains(&t) {
                continue;
            }
            for (recorded, expected) in r.k_deg.iter().zip(self.program_deg(t)) {
                let d = turntable::gimbal::wrap_deg(scale * recorded - expected);
                sse += d * d;
            }
            n += 3;
        }
        (n > 0).then(|| (sse / n as f64).sqrt())
    }

    fn rms(&self, shift: f64) -> Option<f64> {
        self.rms_scaled(shift, 1.0)
    }

    /// The shift (s) of the smallest misfit within a tenth of the program (at least 5 s) on a
    /// 1-s grid, then within a second of it on a 10-ms grid, with that misfit: `(rms, shift)`,
    /// from `(at_zero, 0)`.
    fn best_shift(&self, at_zero: f64) -> (f64, f64) {
        let reach = (0.1 * self.duration).max(5.0);
        let mut best = (at_zero, 0.0);
        let mut s = -reach;
        while s <= reach {
            if let Some(v) = self.rms(s)
                && v < best.0
            {
                best = (v, s);
            }
            s += 1.0;
        }
        let centre = best.1;
        let mut s = centre - 1.0;
        while s <= centre + 1.0 {
            if let Some(v) = self.rms(s)
                && v < best.0
            {
                best = (v, s);
            }
            s += 0.01;
        }
        best
    }
}
