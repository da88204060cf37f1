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
use crate::angle_records::AngleRecords;
use crate::io::IoError;
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

fn unwrap(records: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut out: Vec<[f64; 3]> = Vec::with_capacity(records.len());
    for k in records {
        let next = match out.last() {
            None => *k,
            Some(prev) => [0, 1, 2].map(|g| prev[g] + turntable::gimbal::wrap_deg(k[g] - prev[g])),
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
    let (mut t, mut k_deg) = (Vec::new(), Vec::new());
    tt.for_each(|r| {
        t.push(clock.imu_time(r.t));
        k_deg.push(r.k_deg);
    })?;
    let k = unwrap(&k_deg);
    drop(k_deg);
    let n = t.len();
    if n < 3 || t[n - 1] - t[0] < 2.0 * RATE_WINDOW_S {
        return Err(refuse(format!(
            "{n} angle records over {:.3} s: too few to read a program from (expected at least {} s)",
            t.last().unwrap_or(&0.0) - t.first().unwrap_or(&0.0),
            2.0 * RATE_WINDOW_S
        )));
    }
    let rates = window_rates(&t, &k);
    let pieces = steady_pieces(&t, &k, &rates);
    if pieces.is_empty() {
        return Err(refuse(
            "no stretch of steady gimbal rates in the angle records".into(),
        ));
    }
    let bounds = boundaries(&pieces, t[0], t[n - 1], imu_start);
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

/// Each record's gimbal rates (deg/s) over a window centred on it, when steady (`None` within
/// half a window of a change of rate or of the ends).
fn window_rates(t: &[f64], k: &[[f64; 3]]) -> Vec<Option<[f64; 3]>> {
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
fn steady_pieces(t: &[f64], k: &[[f64; 3]], rates: &[Option<[f64; 3]>]) -> Vec<Piece> {
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
            && rates[j + 1]
                .is_some_and(|r| (0..3).all(|g| (r[g] - r0[g]).abs() < RATE_TOLERANCE_DEG_S))
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
