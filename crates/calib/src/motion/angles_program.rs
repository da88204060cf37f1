//! The rotation program read from the turntable's angle records, for a run whose configuration
//! gives none (`program = "from-angles"`): the angles say how the platform moved.
//!
//! The records are put on the IMU clock by the configuration's clock relation and unwrapped.
//! Each record gets the rate of every gimbal over a window of [`RATE_WINDOW_S`] centred on it,
//! when the rates over the window's two halves agree to [`STEADY_TOLERANCE_DEG_S`] (a change of
//! rate inside the window makes them differ: the records within half a window of a change
//! belong to no piece); maximal runs of such records whose rates stay within that tolerance of
//! the run's first are the program's pieces. Each piece's angles are fitted with a straight line per gimbal; the boundary between
//! two pieces is where the lines of the gimbal whose rate changes most meet (a reversal is
//! placed to a few milliseconds from 50-Hz records with 0.03-deg noise). A piece with every rate
//! below [`STILL_DEG_S`] is a dwell, one with one gimbal turning a rotation; two gimbals turning
//! at once cannot be written as a program and are refused, naming the time.
//!
//! The program's times are the records' times on the IMU clock, which hold the angles `tau`
//! earlier; the estimation finds the program's start from the IMU rates and estimates `tau`, as
//! with a program given in the configuration.

use crate::config::RunConfig;
use crate::io::IoError;
use crate::io::angle_records::AngleRecords;
use turntable::program::{ProgramSpec, Segment};
use turntable::sensor::Clock;

/// Width of the window the rates are taken over (s).
pub const RATE_WINDOW_S: f64 = 1.0;
/// Rates of one piece stay within this of each other (deg/s).
pub const RATE_TOLERANCE_DEG_S: f64 = 0.5;
/// The two halves of a window agree to this when no rate changes inside it (deg/s): ten times
/// the noise of their difference for 50-Hz records with 0.03-deg noise (0.15 deg/s).
pub const STEADY_TOLERANCE_DEG_S: f64 = 1.5;
/// A gimbal slower than this is still (deg/s).
pub const STILL_DEG_S: f64 = 0.2;
/// The program starts this much before the first record or IMU interval (s): within the
/// start finder's slack of half a 0.1-s rate bin.
const START_MARGIN_S: f64 = 0.045;
/// Pieces shorter than this are taken as transitions, not pieces (s).
const MIN_PIECE_S: f64 = 1.5 * RATE_WINDOW_S;

/// One piece: its records and fitted lines (`k = a + b (t - t_ref)` per gimbal).
#[derive(Clone, Copy, Debug)]
struct Piece {
    t_first: f64,
    t_last: f64,
    t_ref: f64,
    a: [f64; 3],
    b: [f64; 3],
}

impl Piece {
    fn at(&self, t: f64) -> [f64; 3] {
        [0, 1, 2].map(|g| self.a[g] + self.b[g] * (t - self.t_ref))
    }
}

/// The program the records of `tt` (file `file`) describe, with the clock relation `clock`.
/// With `imu_start` (the start of the first IMU interval, IMU clock) before the first record,
/// the first piece is taken back to it: the records cannot say what came before them, and the
/// IMU data from then on need a program state (a platform already turning when the angle
/// records begin would otherwise start the calibration degrees off). IMU records before the
/// program's start are taken as taken at rest in its start position, as with a given program.
pub fn program_from_angles(
    tt: AngleRecords,
    clock: &Clock,
    imu_start: Option<f64>,
) -> Result<ProgramSpec, IoError> {
    let file = tt.file();
    let refuse = |message: String| IoError::File {
        file: file.to_string(),
        message,
    };
    // One reading in order: memory independent of the number of records (a window of the
    // records within half a rate window of the one whose rate is taken, and each piece's sums).
    let mut reading = PieceReader::default();
    tt.for_each(|r| reading.push(clock.imu_time(r.t), r.k_deg))?;
    let (n, t_first, t_last, pieces) = reading.finish();
    if n < 3 || t_last - t_first < 2.0 * RATE_WINDOW_S {
        return Err(refuse(format!(
            "{n} angle records over {:.3} s: too few to read a program from (expected at least {} s)",
            if n == 0 { 0.0 } else { t_last - t_first },
            2.0 * RATE_WINDOW_S
        )));
    }
    if pieces.is_empty() {
        return Err(refuse(
            "no stretch of steady gimbal rates in the angle records".into(),
        ));
    }
    let bounds = boundaries(&pieces, t_first, t_last, imu_start);
    let start = pieces[0].at(bounds[0]);
    let mut segments = Vec::with_capacity(pieces.len());
    for (idx, p) in pieces.iter().enumerate() {
        let duration_s = bounds[idx + 1] - bounds[idx];
        if duration_s <= 0.0 {
            continue;
        }
        let moving: Vec<usize> = (0..3).filter(|&g| p.b[g] != 0.0).collect();
        segments.push(match moving.as_slice() {
            [] => Segment::Dwell { duration_s },
            [g] => Segment::Rotate {
                gimbal: (*g + 1) as u8,
                rate_deg_s: p.b[*g],
                duration_s,
            },
            _ => {
                return Err(refuse(format!(
                    "gimbals {} turn together from t = {:.3} s (IMU clock): a program of one-gimbal \
                     turns and dwells cannot describe it; give the program in the configuration",
                    moving.iter().map(|g| (g + 1).to_string()).collect::<Vec<_>>().join(" and "),
                    p.t_first
                )));
            }
        });
    }
    Ok(ProgramSpec {
        name: format!("read from the angle records of {file}"),
        start_deg: start,
        segments,
    })
}

/// A least-squares line through points given one by one (Welford's updates: the centred sums
/// without holding the points, as stable as the two-pass sums).
#[derive(Clone, Copy, Debug, Default)]
struct LineSums {
    n: f64,
    t_mean: f64,
    y_mean: [f64; 3],
    stt: f64,
    sty: [f64; 3],
}

impl LineSums {
    fn push(&mut self, t: f64, y: &[f64; 3]) {
        self.n += 1.0;
        let dt = t - self.t_mean;
        self.t_mean += dt / self.n;
        let dt_after = t - self.t_mean;
        self.stt += dt * dt_after;
        for ((y, mean), sty) in y.iter().zip(&mut self.y_mean).zip(&mut self.sty) {
            *mean += (y - *mean) / self.n;
            // sum (t - tm)(y - ym), updated: dt (y - ym_new) (Welford's co-moment).
            *sty += dt * (y - *mean);
        }
    }

    /// The piece's line through the points: at the mean time, the mean angles and the slopes.
    fn piece(&self, t_first: f64, t_last: f64) -> Piece {
        let slope = |g: usize| {
            let b = if self.stt > 0.0 {
                self.sty[g] / self.stt
            } else {
                0.0
            };
            if b.abs() < STILL_DEG_S { 0.0 } else { b }
        };
        Piece {
            t_first,
            t_last,
            t_ref: self.t_mean,
            a: self.y_mean,
            b: [0, 1, 2].map(slope),
        }
    }
}

/// A run of steady records with rates within the tolerance of its first.
#[derive(Clone, Copy, Debug)]
struct Run {
    r0: [f64; 3],
    t_first: f64,
    t_last: f64,
    sums: LineSums,
}

/// The pieces of the records read in order (IMU-clock times, angles in degrees): each record's
/// gimbal rates over a window centred on it, when steady (`None` within half a window of a
/// change of rate or of the ends); maximal runs of steady records with rates within the
/// tolerance of the run's first, each fitted with a line per gimbal.
#[derive(Debug, Default)]
struct PieceReader {
    /// Records read (unwrapped angles), from the first within half a window before the record
    /// whose rate is next, to the last read.
    window: std::collections::VecDeque<(f64, [f64; 3])>,
    /// Index in `window` of the record whose rate is next.
    centre: usize,
    /// The last record's raw angles, to unwrap the next.
    last_raw: Option<([f64; 3], [f64; 3])>,
    n: usize,
    t_first: f64,
    t_last: f64,
    run: Option<Run>,
    pieces: Vec<Piece>,
}

impl PieceReader {
    fn push(&mut self, t: f64, k_raw: [f64; 3]) {
        let k = match self.last_raw {
            None => k_raw,
            Some((_, prev)) => {
                [0, 1, 2].map(|g| prev[g] + turntable::gimbal::wrap_deg(k_raw[g] - prev[g]))
            }
        };
        self.last_raw = Some((k_raw, k));
        if self.n == 0 {
            self.t_first = t;
        }
        self.n += 1;
        self.t_last = t;
        // Every record whose window's far end this one passes has its rate now.
        while self.centre < self.window.len()
            && t - self.window[self.centre].0 > 0.5 * RATE_WINDOW_S
        {
            self.take_centre();
        }
        self.window.push_back((t, k));
    }

    /// The rate of the record at `centre` over the window as read (up to the last record
    /// within half a window after it), fed to the runs.
    fn take_centre(&mut self) {
        let half = 0.5 * RATE_WINDOW_S;
        let (ti, ki) = self.window[self.centre];
        // The first record within half a window before it (earlier ones are no longer needed:
        // the next centres are later).
        while ti - self.window[0].0 > half {
            self.window.pop_front();
            self.centre -= 1;
        }
        let (tl, kl) = self.window[0];
        let (th, kh) = *self
            .window
            .iter()
            .rev()
            .find(|(t, _)| t - ti <= half)
            .expect("the centre itself");
        // Steady: the rates over the two halves of the window agree (a change of rate inside
        // the window makes them differ), and both halves are nearly full.
        let (left, right) = (ti - tl, th - ti);
        let full = left > 0.45 * RATE_WINDOW_S && right > 0.45 * RATE_WINDOW_S;
        let steady = full
            && (0..3).all(|g| {
                ((ki[g] - kl[g]) / left - (kh[g] - ki[g]) / right).abs() < STEADY_TOLERANCE_DEG_S
            });
        let rate = steady.then(|| [0, 1, 2].map(|g| (kh[g] - kl[g]) / (left + right)));
        self.centre += 1;
        self.feed(ti, &ki, rate);
    }

    fn feed(&mut self, t: f64, k: &[f64; 3], rate: Option<[f64; 3]>) {
        if let Some(run) = &mut self.run {
            if rate.is_some_and(|r| (0..3).all(|g| (r[g] - run.r0[g]).abs() < RATE_TOLERANCE_DEG_S))
            {
                run.t_last = t;
                run.sums.push(t, k);
                return;
            }
            self.close_run();
        }
        if let Some(r0) = rate {
            let mut sums = LineSums::default();
            sums.push(t, k);
            self.run = Some(Run {
                r0,
                t_first: t,
                t_last: t,
                sums,
            });
        }
    }

    fn close_run(&mut self) {
        if let Some(run) = self.run.take()
            && run.t_last - run.t_first >= MIN_PIECE_S - RATE_WINDOW_S
        {
            self.pieces.push(run.sums.piece(run.t_first, run.t_last));
        }
    }

    /// Records read, first and last times, and the pieces.
    fn finish(mut self) -> (usize, f64, f64, Vec<Piece>) {
        while self.centre < self.window.len() {
            self.take_centre();
        }
        self.close_run();
        (self.n, self.t_first, self.t_last, self.pieces)
    }
}

/// The program's boundaries: its start (before the first record, see
/// [`program_from_angles`]), where the lines of the gimbal whose rate changes most meet between
/// consecutive pieces, and the last record.
fn boundaries(pieces: &[Piece], t_first: f64, t_last: f64, imu_start: Option<f64>) -> Vec<f64> {
    let half = 0.5 * RATE_WINDOW_S;
    // The first piece starts a little before the first record (and the IMU data): the records
    // hold the angles tau earlier or later than their stamps, and a program that starts after
    // the IMU data would take the first records as taken at rest while the platform turns (a
    // 0.3-deg start error at 10 deg/s and tau = -31 ms). The start finder accepts a program
    // starting up to half a rate bin (0.05 s) before the data.
    let mut bounds = vec![imu_start.map_or(t_first, |s| s.min(t_first)) - START_MARGIN_S];
    for w in pieces.windows(2) {
        let (p, q) = (&w[0], &w[1]);
        let g = (0..3)
            .max_by(|&a, &b| (p.b[a] - q.b[a]).abs().total_cmp(&(p.b[b] - q.b[b]).abs()))
            .expect("three gimbals");
        let db = p.b[g] - q.b[g];
        let tb = if db.abs() > 0.0 {
            // p.a + p.b (t - p.ref) = q.a + q.b (t - q.ref)
            (q.a[g] - p.a[g] + p.b[g] * p.t_ref - q.b[g] * q.t_ref) / db
        } else {
            0.5 * (p.t_last + q.t_first)
        };
        bounds.push(tb.clamp(p.t_last - half, q.t_first + half));
    }
    bounds.push(t_last);
    bounds
}

/// `config` with its program read from the turntable records when it says `"from-angles"`
/// (`None`: the configuration gives its program, use it as it is).
///
/// `imu_start`: see [`program_from_angles`].
pub fn resolve_program(
    config: &RunConfig,
    turntable: Option<AngleRecords>,
    imu_start: Option<f64>,
) -> Result<Option<RunConfig>, IoError> {
    match (config.program_from_angles(), turntable) {
        (true, Some(tt)) => {
            let mut c = config.clone();
            c.inline_program = Some(program_from_angles(tt, &config.clock, imu_start)?);
            Ok(Some(c))
        }
        _ => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::TurntableRecord;

    // The two-pass reading the streamed one replaced (every record's rate, then the runs), as
    // the reference the streamed reading is checked against.
    mod two_pass {
        use super::super::*;

        pub fn unwrap(records: &[[f64; 3]]) -> Vec<[f64; 3]> {
            let mut out: Vec<[f64; 3]> = Vec::with_capacity(records.len());
            for k in records {
                let next = match out.last() {
                    None => *k,
                    Some(prev) => {
                        [0, 1, 2].map(|g| prev[g] + turntable::gimbal::wrap_deg(k[g] - prev[g]))
                    }
                };
                out.push(next);
            }
            out
        }

        fn line(t: &[f64], y: &[f64]) -> (f64, f64, f64) {
            let n = t.len() as f64;
            let tm = t.iter().sum::<f64>() / n;
            let ym = y.iter().sum::<f64>() / n;
            let (mut stt, mut sty) = (0.0, 0.0);
            for (ti, yi) in t.iter().zip(y) {
                stt += (ti - tm) * (ti - tm);
                sty += (ti - tm) * (yi - ym);
            }
            (tm, ym, if stt > 0.0 { sty / stt } else { 0.0 })
        }

        /// Each record's gimbal rates (deg/s) over a window centred on it, when steady (`None` within
        /// half a window of a change of rate or of the ends).
        pub fn window_rates(t: &[f64], k: &[[f64; 3]]) -> Vec<Option<[f64; 3]>> {
            let n = t.len();
            let half = 0.5 * RATE_WINDOW_S;
            let mut lo = 0;
            let mut hi = 0;
            (0..n)
                .map(|i| {
                    while t[i] - t[lo] > half {
                        lo += 1;
                    }
                    while hi + 1 < n && t[hi + 1] - t[i] <= half {
                        hi += 1;
                    }
                    // Steady: the rates over the two halves of the window agree (a change of rate
                    // inside the window makes them differ), and both halves are nearly full.
                    let (left, right) = (t[i] - t[lo], t[hi] - t[i]);
                    let full = left > 0.45 * RATE_WINDOW_S && right > 0.45 * RATE_WINDOW_S;
                    let steady = full
                        && (0..3).all(|g| {
                            ((k[i][g] - k[lo][g]) / left - (k[hi][g] - k[i][g]) / right).abs()
                                < STEADY_TOLERANCE_DEG_S
                        });
                    steady.then(|| [0, 1, 2].map(|g| (k[hi][g] - k[lo][g]) / (left + right)))
                })
                .collect()
        }

        /// Maximal runs of steady records with rates within the tolerance of the run's first, each
        /// fitted with a line per gimbal.
        pub fn steady_pieces(t: &[f64], k: &[[f64; 3]], rates: &[Option<[f64; 3]>]) -> Vec<Piece> {
            let n = t.len();
            let mut pieces: Vec<Piece> = Vec::new();
            let mut i = 0;
            while i < n {
                let Some(r0) = rates[i] else {
                    i += 1;
                    continue;
                };
                let mut j = i;
                while j + 1 < n
                    && rates[j + 1].is_some_and(|r| {
                        (0..3).all(|g| (r[g] - r0[g]).abs() < RATE_TOLERANCE_DEG_S)
                    })
                {
                    j += 1;
                }
                if t[j] - t[i] >= MIN_PIECE_S - RATE_WINDOW_S {
                    let ts = &t[i..=j];
                    let mut p = Piece {
                        t_first: t[i],
                        t_last: t[j],
                        t_ref: 0.0,
                        a: [0.0; 3],
                        b: [0.0; 3],
                    };
                    for g in 0..3 {
                        let y: Vec<f64> = k[i..=j].iter().map(|x| x[g]).collect();
                        let (tm, ym, slope) = line(ts, &y);
                        p.t_ref = tm;
                        p.a[g] = ym;
                        p.b[g] = if slope.abs() < STILL_DEG_S {
                            0.0
                        } else {
                            slope
                        };
                    }
                    pieces.push(p);
                }
                i = j + 1;
            }
            pieces
        }
    }

    /// The streamed reading finds the pieces of the two-pass reading: the same records in
    /// each (first and last times equal), lines equal to rounding, on noisy 50-Hz records of
    /// turns, reversals, dwells and a wrap past 180 deg.
    #[test]
    fn the_streamed_reading_finds_the_two_pass_pieces() {
        let mut state = 7u64;
        let mut noise = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            0.03 * (((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5) * 3.46
        };
        // (duration s, rates deg/s)
        let legs = [
            (5.0, [0.0, 0.0, 0.0]),
            (20.0, [10.0, 0.0, 0.0]),
            (7.0, [0.0, 0.0, 0.0]),
            (12.0, [0.0, -15.0, 0.0]),
            (9.0, [0.0, 15.0, 0.0]),
            (0.7, [0.0, 0.0, 3.0]),
            (30.0, [0.0, 0.0, 20.0]),
            (4.0, [0.0, 0.0, 0.0]),
        ];
        let (mut t, mut k) = (0.0, [170.0, 0.0, 0.0]);
        let (mut ts, mut raw) = (Vec::new(), Vec::new());
        for (duration, rate) in legs {
            let steps = (duration * 50.0) as usize;
            for _ in 0..steps {
                t += 0.02;
                for g in 0..3 {
                    k[g] += rate[g] * 0.02;
                }
                ts.push(t);
                raw.push([0, 1, 2].map(|g| turntable::gimbal::wrap_deg(k[g] + noise())));
            }
        }
        let unwrapped = two_pass::unwrap(&raw);
        let rates = two_pass::window_rates(&ts, &unwrapped);
        let reference = two_pass::steady_pieces(&ts, &unwrapped, &rates);
        let mut reading = PieceReader::default();
        for (t, k) in ts.iter().zip(&raw) {
            reading.push(*t, *k);
        }
        let (n, _, _, pieces) = reading.finish();
        assert_eq!(n, ts.len());
        assert_eq!(pieces.len(), reference.len());
        assert!(pieces.len() >= 6, "{} pieces", pieces.len());
        for (p, q) in pieces.iter().zip(&reference) {
            assert_eq!((p.t_first, p.t_last), (q.t_first, q.t_last));
            assert!((p.t_ref - q.t_ref).abs() < 1e-9);
            for g in 0..3 {
                assert!((p.a[g] - q.a[g]).abs() < 1e-9, "{} {}", p.a[g], q.a[g]);
                assert!((p.b[g] - q.b[g]).abs() < 1e-9, "{} {}", p.b[g], q.b[g]);
            }
        }
    }

    /// The reading holds about one rate window of records, whatever their number.
    #[test]
    fn the_reading_holds_one_window_of_records() {
        let mut reading = PieceReader::default();
        let mut most = 0;
        for i in 0..200_000 {
            let t = 12.5 + 0.001 * i as f64;
            reading.push(t, [0.0, 10.0 * t, 0.0]);
            most = most.max(reading.window.len());
        }
        assert!(most <= 1002, "{most} records held");
        let (_, _, _, pieces) = reading.finish();
        assert_eq!(pieces.len(), 1);
    }

    #[test]
    fn a_two_gimbal_move_is_refused_with_its_time() {
        let records = (0..500)
            .map(|i| {
                let t = i as f64 * 0.02;
                TurntableRecord {
                    t,
                    k_deg: [10.0 * t, 5.0 * t, 0.0],
                }
            })
            .collect();
        let data = crate::io::TurntableData { records };
        let e = program_from_angles((&data, "tt.csv").into(), &Clock::default(), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("tt.csv") && e.contains("gimbals 1 and 2"), "{e}");
    }
}
