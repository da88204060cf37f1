//! Rotation programs: what the turntable's three gimbals do, read from TOML.
//!
//! A program is a start position and a list of segments; each segment gives the gimbals constant
//! rates for a while, so the gimbal angles are piecewise linear in time and every derived
//! quantity (attitude, body rate) is known in closed form.
//!
//! ```toml
//! name = "one turn about the bank axis"
//! start_deg = (0.0, 0.0, 0.0)
//! [[segment]]
//! kind = "rotate"        # one gimbal at a constant rate
//! gimbal = 2             # 1 = heading, 2 = bank, 3 = pitch
//! rate_deg_s = 10.0
//! duration_s = 36.0
//! [[segment]]
//! kind = "dwell"         # all gimbals still
//! duration_s = 10.0
//! [[segment]]
//! kind = "move"          # to target angles, one gimbal after another, at rate_deg_s
//! target_deg = (-90.0, 0.0, 0.0)
//! rate_deg_s = 10.0
//! ```

use serde::{Deserialize, Serialize};
use std::path::Path;

/// The paper's three-cycle program, embedded.
pub const PAPER_PROGRAM_TOML: &str = include_str!("../programs/paper.toml");

/// The longest program accepted (s): 10 days.
///
/// Turntable programs last minutes to hours (the paper's three cycles take 2727 s; a bias
/// stability or thermal run a day or two). Ten days is far above any of them and keeps every
/// command that works along the program (the covariance analysis and the simulator step at the
/// IMU rate, `8.64e7` steps at 100 Hz) within hours of work and gigabytes of memory; a longer
/// total is a typing error (`1e12` for `1e2`) or a unit mistake, refused when the program is
/// compiled with the file and the segment where the total passes the bound.
pub const MAX_PROGRAM_DURATION_S: f64 = 864_000.0;

/// The largest gimbal angle accepted in a program's `start_deg` and `target_deg` (deg, either
/// sign): a hundred turns. A gimbal's angle may count whole turns (a program recorded after
/// turns), but `1e300` is a typing error whose radians keep no digit of the motion.
pub const MAX_ANGLE_DEG: f64 = 36_000.0;

/// The fastest gimbal rate accepted (deg/s).
///
/// Calibration turntables turn at up to some hundreds of degrees per second (rate tables for
/// scale-factor tests reach 1000-1500 deg/s) and a hand turn reaches about 900 deg/s; beyond
/// 2000 deg/s no gimbal turns, and a value like `1e6` is a typing error or a unit mistake. It
/// also keeps one IMU step's rotation small enough for the integrators (20 deg per step at
/// 100 Hz).
pub const MAX_RATE_DEG_S: f64 = 2000.0;

/// Errors reading a program.
#[derive(Debug, thiserror::Error)]
pub enum ProgramError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// File path.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
    /// The TOML does not describe a program.
    #[error("{origin}: {message}")]
    Parse {
        /// File path or `"<embedded>"`.
        origin: String,
        /// What toml/serde said, with line and column.
        message: String,
    },
    /// A segment is not physically meaningful.
    #[error("{origin}: segment {index} ({kind}): {message}")]
    Segment {
        /// File path or `"<embedded>"`.
        origin: String,
        /// 1-based segment index.
        index: usize,
        /// Segment kind.
        kind: &'static str,
        /// What is wrong and what was expected.
        message: String,
    },
}

/// One segment of a program, as written in TOML.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Segment {
    /// One gimbal turns at a constant rate.
    Rotate {
        /// Gimbal number: 1 = heading (outer), 2 = bank (middle), 3 = pitch (inner).
        #[serde(deserialize_with = "gimbal_number")]
        gimbal: u8,
        /// Rate (deg/s) (signed).
        rate_deg_s: f64,
        /// Duration (s).
        duration_s: f64,
    },
    /// All gimbals still.
    Dwell {
        /// Duration (s).
        duration_s: f64,
    },
    /// Move to target angles, one gimbal after another (heading, bank, pitch), each at the given
    /// rate magnitude; gimbals already at their target do not move.
    Move {
        /// Target angles (deg).
        #[serde(deserialize_with = "exactly")]
        target_deg: [f64; 3],
        /// Rate magnitude (deg/s).
        rate_deg_s: f64,
    },
}

impl Segment {
    fn kind(&self) -> &'static str {
        match self {
            Segment::Rotate { .. } => "rotate",
            Segment::Dwell { .. } => "dwell",
            Segment::Move { .. } => "move",
        }
    }
}

/// A list of exactly `N` numbers. The array's own deserializer takes the first `N` of a
/// longer list and ignores the rest (a `start_deg` of four, or a million, entries was read as
/// its first three); a list of another length is refused, naming both lengths.
pub fn exactly<'de, D, const N: usize>(d: D) -> Result<[f64; N], D::Error>
where
    D: serde::Deserializer<'de>,
{
    let v = Vec::<f64>::deserialize(d)?;
    let n = v.len();
    v.try_into().map_err(|_| {
        serde::de::Error::custom(format!(
            "a list of {n} numbers: expected exactly {N} (one per gimbal or axis)"
        ))
    })
}

/// A rotation program as written in TOML.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProgramSpec {
    /// Human-readable name.
    pub name: String,
    /// Gimbal angles at t = 0 (deg).
    #[serde(deserialize_with = "exactly")]
    pub start_deg: [f64; 3],
    /// Segments in order.
    #[serde(rename = "segment")]
    pub segments: Vec<Segment>,
}

/// A gimbal number, read as any integer so that one beyond a `u8` is refused naming the field
/// (a `u8` read directly reports `-1` as an invalid integer, without the field's name: the
/// segment's kind tag makes the reader buffer the table).
fn gimbal_number<'de, D: serde::Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
    let v = i64::deserialize(d)?;
    // Numbers that fit are checked with the segment's index (`segment_problem`).
    u8::try_from(v).map_err(|_| {
        serde::de::Error::custom(format!(
            "gimbal = {v}: expected 1, 2 or 3 (heading, bank, pitch)"
        ))
    })
}

/// Three angles within +-[`MAX_ANGLE_DEG`], or what is wrong with them.
fn angles_problem(name: &str, a: &[f64; 3]) -> Option<String> {
    a.iter()
        .any(|a| !(a.is_finite() && a.abs() <= MAX_ANGLE_DEG))
        .then(|| {
            format!(
                "{name} = {a:?}: expected three angles in degrees within +-{MAX_ANGLE_DEG} (a \
                 hundred turns)"
            )
        })
}

/// What is wrong with a segment's numbers, if anything.
fn segment_problem(seg: &Segment) -> Option<String> {
    let positive = |name: &str, v: f64| {
        (!(v.is_finite() && v > 0.0)).then(|| format!("{name} must be > 0, got {v}"))
    };
    let rate = |v: f64| {
        (v.abs() > MAX_RATE_DEG_S).then(|| {
            format!(
                "rate_deg_s = {v} is beyond the fastest gimbal rate accepted, \
                 {MAX_RATE_DEG_S} deg/s in magnitude (a typing error or a unit mistake)"
            )
        })
    };
    match *seg {
        Segment::Rotate {
            gimbal,
            rate_deg_s,
            duration_s,
        } => {
            if !(1..=3).contains(&gimbal) {
                Some(format!("gimbal must be 1, 2 or 3, got {gimbal}"))
            } else if !rate_deg_s.is_finite() {
                Some("rate_deg_s must be finite".into())
            } else {
                rate(rate_deg_s).or_else(|| positive("duration_s", duration_s))
            }
        }
        Segment::Dwell { duration_s } => positive("duration_s", duration_s),
        Segment::Move {
            target_deg,
            rate_deg_s,
        } => positive("rate_deg_s", rate_deg_s)
            .or_else(|| rate(rate_deg_s))
            .or_else(|| angles_problem("target_deg", &target_deg)),
    }
}

/// A piece of constant gimbal rates: angles `k0 + rate * (t - t0)` for `t0 <= t <= t1` (SI).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Start time (s).
    pub t0: f64,
    /// End time (s).
    pub t1: f64,
    /// Gimbal angles at `t0` (rad).
    pub k0: [f64; 3],
    /// Gimbal rates (rad/s).
    pub rate: [f64; 3],
}

/// The pieces compiled so far, and the gimbal angles (rad) and time (s) they end at.
struct Pieces {
    k: [f64; 3],
    t: f64,
    pieces: Vec<Piece>,
}

impl Pieces {
    /// The pieces of a checked segment, from where the ones before end.
    fn push(&mut self, seg: &Segment) {
        let (k, t) = (&mut self.k, &mut self.t);
        match *seg {
            Segment::Rotate {
                gimbal,
                rate_deg_s,
                duration_s,
            } => {
                let mut rate = [0.0; 3];
                rate[gimbal as usize - 1] = rate_deg_s.to_radians();
                self.pieces.push(Piece {
                    t0: *t,
                    t1: *t + duration_s,
                    k0: *k,
                    rate,
                });
                k[gimbal as usize - 1] += rate[gimbal as usize - 1] * duration_s;
                *t += duration_s;
            }
            Segment::Dwell { duration_s } => {
                self.pieces.push(Piece {
                    t0: *t,
                    t1: *t + duration_s,
                    k0: *k,
                    rate: [0.0; 3],
                });
                *t += duration_s;
            }
            Segment::Move {
                target_deg,
                rate_deg_s,
            } => {
                // One gimbal after the other, each at the rate; one already there takes no
                // piece.
                for g in 0..3 {
                    let delta = target_deg[g].to_radians() - k[g];
                    if delta.abs() < 1e-12 {
                        continue;
                    }
                    let w = rate_deg_s.to_radians() * delta.signum();
                    let d = delta / w;
                    let mut rate = [0.0; 3];
                    rate[g] = w;
                    self.pieces.push(Piece {
                        t0: *t,
                        t1: *t + d,
                        k0: *k,
                        rate,
                    });
                    k[g] = target_deg[g].to_radians();
                    *t += d;
                }
            }
        }
    }
}

/// Why a spec that compiled to no piece is refused: no segment, or only moves to where the
/// gimbals already are.
fn no_time_message(spec: &ProgramSpec) -> String {
    if spec.segments.is_empty() {
        "a program needs at least one [[segment]]".to_string()
    } else {
        format!(
            "the program takes no time: its {} segment(s) only move to where the gimbals \
             already are (start_deg = {:?}); expected a segment that rotates, dwells or \
             moves somewhere",
            spec.segments.len(),
            spec.start_deg
        )
    }
}

/// A compiled program: piecewise-linear gimbal angles.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// Name from the spec.
    pub name: String,
    pieces: Vec<Piece>,
    start: [f64; 3],
}

impl Program {
    /// The paper's program (embedded default).
    pub fn paper() -> Self {
        Self::from_toml_str(PAPER_PROGRAM_TOML, "<embedded paper program>")
            .expect("the embedded program is valid")
    }

    /// Read a program from a TOML file.
    pub fn from_file(path: &Path) -> Result<Self, ProgramError> {
        let text = sins_model::text::read_text_bounded(
            path,
            sins_model::text::PROGRAM_MAX_BYTES,
            "rotation program",
        )
        .map_err(|source| ProgramError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Parse a program; `origin` names the source in error messages.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, ProgramError> {
        let spec: ProgramSpec = toml::from_str(text).map_err(|e| ProgramError::Parse {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        Self::compile(&spec, origin)
    }

    /// Compile a spec into pieces, checking every segment.
    pub fn compile(spec: &ProgramSpec, origin: &str) -> Result<Self, ProgramError> {
        let err = |index: usize, seg: &Segment, message: String| ProgramError::Segment {
            origin: origin.to_string(),
            index: index + 1,
            kind: seg.kind(),
            message,
        };
        if let Some(message) = angles_problem("start_deg", &spec.start_deg) {
            return Err(ProgramError::Parse {
                origin: origin.to_string(),
                message,
            });
        }
        let mut pieces = Pieces {
            k: spec.start_deg.map(f64::to_radians),
            t: 0.0,
            pieces: Vec::new(),
        };
        for (i, seg) in spec.segments.iter().enumerate() {
            if let Some(message) = segment_problem(seg) {
                return Err(err(i, seg, message));
            }
            let t_before = pieces.t;
            pieces.push(seg);
            let t = pieces.t;
            if t > MAX_PROGRAM_DURATION_S {
                return Err(err(
                    i,
                    seg,
                    format!(
                        "the program's total duration reaches {t:.6e} s here (this segment takes \
                         {:.6e} s, the segments before it {t_before} s): expected at most \
                         {MAX_PROGRAM_DURATION_S} s (10 days) in all; check duration_s (and \
                         rate_deg_s of moves) for a typing error or a unit mistake",
                        t - t_before
                    ),
                ));
            }
        }
        if pieces.pieces.is_empty() {
            return Err(ProgramError::Parse {
                origin: origin.to_string(),
                message: no_time_message(spec),
            });
        }
        Ok(Self {
            name: spec.name.clone(),
            pieces: pieces.pieces,
            start: spec.start_deg.map(f64::to_radians),
        })
    }

    /// The pieces in time order.
    pub fn pieces(&self) -> &[Piece] {
        &self.pieces
    }

    /// Total duration (s).
    pub fn duration(&self) -> f64 {
        self.pieces.last().map_or(0.0, |p| p.t1)
    }

    /// Index of the piece holding time `t` (clamped to the program).
    pub fn piece_index(&self, t: f64) -> usize {
        match self.pieces.binary_search_by(|p| {
            if t < p.t0 {
                std::cmp::Ordering::Greater
            } else if t >= p.t1 {
                std::cmp::Ordering::Less
            } else {
                std::cmp::Ordering::Equal
            }
        }) {
            Ok(i) => i,
            Err(i) => i.min(self.pieces.len() - 1),
        }
    }

    /// [`Program::state`] with the rates' left limits: at a piece boundary `t` the rates of the
    /// piece that ends there (the angles are continuous). With it, `rate(b) - rate(a)` counts a
    /// jump at `t` in `(a, b]` exactly once over a sequence of intervals.
    pub fn state_left(&self, t: f64) -> ([f64; 3], [f64; 3]) {
        let (k, rate) = self.state(t);
        if t <= 0.0 || self.pieces.is_empty() {
            return (k, rate);
        }
        let i = self.piece_index(t);
        let p = &self.pieces[i];
        if t == p.t0 && i > 0 {
            return (k, self.pieces[i - 1].rate);
        }
        if t > p.t1 {
            // After the end: the last piece's rate up to and including its end.
            return (k, [0.0; 3]);
        }
        if t == p.t1 && i + 1 == self.pieces.len() {
            return (k, p.rate);
        }
        (k, rate)
    }

    /// Gimbal angles (rad) and rates (rad/s) at time `t`; before the start the program holds its
    /// start position, after the end its end position (rates zero outside).
    pub fn state(&self, t: f64) -> ([f64; 3], [f64; 3]) {
        if t <= 0.0 {
            return (self.start, [0.0; 3]);
        }
        let p = &self.pieces[self.piece_index(t)];
        if t > p.t1 {
            let d = p.t1 - p.t0;
            return (std::array::from_fn(|g| p.k0[g] + p.rate[g] * d), [0.0; 3]);
        }
        let d = t - p.t0;
        (std::array::from_fn(|g| p.k0[g] + p.rate[g] * d), p.rate)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_program_has_three_cycles_of_15_min() {
        let p = Program::paper();
        // 3 x 900 s of rotation plus three 9 s re-orientations (90 deg at 10 deg/s each).
        assert!(
            (p.duration() - (2700.0 + 3.0 * 9.0)).abs() < 1e-9,
            "{}",
            p.duration()
        );
        let (k, w) = p.state(100.0);
        assert!((k[1] - 1000f64.to_radians()).abs() < 1e-9);
        assert!((w[1] - 10f64.to_radians()).abs() < 1e-15);
        // Each cycle returns to its start.
        let (k_end1, _) = p.state(900.0);
        assert!(k_end1[1].abs() < 1e-9);
        let (k_end, _) = p.state(p.duration());
        assert!((k_end[2] - 90f64.to_radians()).abs() < 1e-9);
        assert!(k_end[1].abs() < 1e-9 && k_end[0].abs() < 1e-9);
    }

    #[test]
    fn rates_beyond_2000_deg_s_are_refused_naming_segment_and_field() {
        let prog = |kind: &str, rate: f64| {
            let body = if kind == "rotate" {
                format!("gimbal = 1\nrate_deg_s = {rate:?}\nduration_s = 10.0\n")
            } else {
                format!("target_deg = [90.0, 0.0, 0.0]\nrate_deg_s = {rate:?}\n")
            };
            format!(
                "name = \"x\"\nstart_deg = [0.0, 0.0, 0.0]\n[[segment]]\nkind = \"dwell\"\n\
                 duration_s = 1.0\n[[segment]]\nkind = \"{kind}\"\n{body}"
            )
        };
        for kind in ["rotate", "move"] {
            assert!(Program::from_toml_str(&prog(kind, 2000.0), "t.toml").is_ok());
            let rate = if kind == "rotate" { -1e6 } else { 1e6 };
            let e = Program::from_toml_str(&prog(kind, rate), "t.toml")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("t.toml: segment 2 ({kind})"))
                    && e.contains("rate_deg_s")
                    && e.contains("2000 deg/s"),
                "{e}"
            );
        }
    }

    #[test]
    fn programs_longer_than_ten_days_are_refused_at_their_segment() {
        let prog = |d1: f64, d2: f64| {
            format!(
                "name = \"x\"\nstart_deg = [0.0, 0.0, 0.0]\n[[segment]]\nkind = \"dwell\"\n\
                 duration_s = {d1:?}\n[[segment]]\nkind = \"rotate\"\ngimbal = 2\n\
                 rate_deg_s = 10.0\nduration_s = {d2:?}\n"
            )
        };
        for (d1, d2, index) in [(1e300, 1.0, 1), (1.0, 1e12, 2), (500_000.0, 500_000.0, 2)] {
            let e = Program::from_toml_str(&prog(d1, d2), "long.toml")
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("long.toml")
                    && e.contains(&format!("segment {index}"))
                    && e.contains("864000"),
                "{e}"
            );
        }
        // A move at a crawl is as long as its angle over its rate.
        let e = Program::from_toml_str(
            "name = \"x\"\nstart_deg = [0.0, 0.0, 0.0]\n[[segment]]\nkind = \"move\"\n\
             target_deg = [90.0, 0.0, 0.0]\nrate_deg_s = 1e-9\n",
            "slow.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("slow.toml") && e.contains("segment 1 (move)"),
            "{e}"
        );
        let p = Program::from_toml_str(&prog(432_000.0, 432_000.0), "ten.toml").unwrap();
        assert_eq!(p.duration(), MAX_PROGRAM_DURATION_S);
    }

    #[test]
    fn bad_segments_are_refused_with_their_index() {
        let text = "name = \"x\"\nstart_deg = [0.0, 0.0, 0.0]\n[[segment]]\nkind = \"dwell\"\nduration_s = 1.0\n[[segment]]\nkind = \"rotate\"\ngimbal = 4\nrate_deg_s = 1.0\nduration_s = 1.0\n";
        let e = Program::from_toml_str(text, "prog.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("prog.toml") && e.contains("segment 2") && e.contains("gimbal"),
            "{e}"
        );
        let e = Program::from_toml_str("name = \"x\"\nstart_deg = [0.0, 0.0]\n", "p.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("p.toml") && e.contains("line"), "{e}");
        let e = Program::from_toml_str(
            "name = \"x\"\nstart_deg = [0.0, 0.0, 0.0]\n[[segment]]\nkind = \"spin\"\n",
            "q.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("q.toml") && e.contains("spin"), "{e}");
    }
}
