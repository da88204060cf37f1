//! The rotation program's structure on the IMU clock: one segment per piece of constant gimbal
//! rates (a dwell, a rotation, each leg of a move), grouped into cycles.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;
use turntable::gimbal::{c_platform_to_base, gimbal_jacobian};
use turntable::program::{Piece, Program};

/// One piece of the program (constant gimbal rates) on the IMU clock.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    /// Index in the program (0-based, time order).
    pub index: usize,
    /// The cycle it belongs to (1-based), `None` for dwells and re-orientations. A cycle is a
    /// run of consecutive rotations about one gimbal that turns it by at least a full turn and
    /// brings it back to where it started (mod 360 deg): the paper's +-10 deg/s cycles.
    pub cycle: Option<usize>,
    /// Human-readable, e.g. `"cycle 2, rotation about y, +"`.
    pub label: String,
    /// Start on the IMU clock (s).
    pub t0: f64,
    /// End on the IMU clock (s).
    pub t1: f64,
    /// Rotation frequency of the platform, `|rate| / 2 pi` (Hz; 0 for a dwell).
    pub rotation_hz: f64,
    /// The rest of a recording without a program in which the start attitude is levelled:
    /// its specific force gave the start tilt's prior (ten times wider than the levelling's
    /// sigma, [`crate::motion::rests::PRIOR_WIDENING`]), so its innovations are small by
    /// construction and its NIS test is one-sided (too large only). A one-window first rest
    /// of the Ferraris session had NIS 1e-4 on 3 degrees of freedom (p = 2e-7).
    #[serde(default)]
    pub levels_start: bool,
}

impl Segment {
    /// Duration (s).
    pub fn duration(&self) -> f64 {
        self.t1 - self.t0
    }
}

/// The gimbal a piece turns (the one with the largest rate), if any.
fn turning_gimbal(p: &Piece) -> Option<usize> {
    (0..3)
        .filter(|&g| p.rate[g] != 0.0)
        .max_by(|&a, &b| p.rate[a].abs().total_cmp(&p.rate[b].abs()))
}

/// The rotation axis of a piece in the platform (nominally instrument) frame, with its sign:
/// `"x, +"` when within 5 deg of a platform axis, else the gimbal's name.
fn axis_label(p: &Piece) -> String {
    let w_base = gimbal_jacobian(&p.k0) * Vector3::from(p.rate);
    let w = c_platform_to_base(&p.k0).transpose() * w_base;
    let n = w.norm();
    if !(n.is_finite() && n > 0.0) {
        return "no rotation".into();
    }
    let (i, c) = w.iter().enumerate().fold((0, 0.0f64), |acc, (i, v)| {
        if v.abs() > acc.1.abs() { (i, *v) } else { acc }
    });
    if c.abs() / n > 5f64.to_radians().cos() {
        let sign = if c > 0.0 { "+" } else { "-" };
        format!("about {}, {sign}", ["x", "y", "z"][i])
    } else {
        let g = turning_gimbal(p).unwrap_or(0);
        let sign = if p.rate[g] > 0.0 { "+" } else { "-" };
        format!("about gimbal {}, {sign}", g + 1)
    }
}

/// Group consecutive rotation pieces about one gimbal; mark a group as a cycle when it turns by
/// at least a full turn and ends where it started (mod 2 pi). Returns the cycle of each piece.
fn cycles(pieces: &[Piece]) -> Vec<Option<usize>> {
    let mut out = vec![None; pieces.len()];
    let mut next = 1;
    let mut i = 0;
    while i < pieces.len() {
        let Some(g) = turning_gimbal(&pieces[i]) else {
            i += 1;
            continue;
        };
        let mut j = i;
        let (mut net, mut total) = (0.0, 0.0);
        while j < pieces.len() && turning_gimbal(&pieces[j]) == Some(g) {
            let turn = pieces[j].rate[g] * (pieces[j].t1 - pieces[j].t0);
            net += turn;
            total += turn.abs();
            j += 1;
        }
        let back = (net / TAU - (net / TAU).round()).abs() < 1e-6;
        if back && total >= TAU * (1.0 - 1e-9) {
            out[i..j].fill(Some(next));
            next += 1;
        }
        i = j;
    }
    out
}

/// The segments of `program` when it starts at IMU time `program_start_s`: one per piece, with
/// its cycle and a label.
pub fn segments(program: &Program, program_start_s: f64) -> Vec<Segment> {
    let pieces = program.pieces();
    let cyc = cycles(pieces);
    pieces
        .iter()
        .enumerate()
        .map(|(index, p)| {
            let rate = turning_gimbal(p).map_or(0.0, |g| p.rate[g].abs());
            let label = match (cyc[index], rate > 0.0) {
                (_, false) => "dwell".to_string(),
                (Some(c), true) => format!("cycle {c}, rotation {}", axis_label(p)),
                (None, true) => format!("re-orientation {}", axis_label(p)),
            };
            Segment {
                levels_start: false,
                index,
                cycle: cyc[index],
                label,
                t0: program_start_s + p.t0,
                t1: program_start_s + p.t1,
                rotation_hz: rate / TAU,
            }
        })
        .collect()
}

/// The segment holding IMU time `t`: times before the program go to the first segment, after
/// it to the last (0 without segments).
pub fn segment_of(segments: &[Segment], t: f64) -> usize {
    let k = segments.partition_point(|s| s.t1 < t);
    k.min(segments.len().saturating_sub(1))
}

/// Set the segment of every innovation from its time.
pub fn assign_segments(innov: &mut [super::Innovation], segments: &[Segment]) {
    for i in innov {
        i.segment = segment_of(segments, i.t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_program_has_three_cycles_with_the_instrument_axes() {
        let s = segments(&Program::paper(), 10.0);
        let labels: Vec<&str> = s.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "cycle 1, rotation about x, +",
                "cycle 1, rotation about x, -",
                "re-orientation about z, -",
                "cycle 2, rotation about y, +",
                "cycle 2, rotation about y, -",
                "re-orientation about z, +",
                "re-orientation about y, +",
                "cycle 3, rotation about z, +",
                "cycle 3, rotation about z, -",
            ]
        );
        assert_eq!(s[0].t0, 10.0);
        assert!((s[1].t1 - 910.0).abs() < 1e-9);
        assert!((s[0].rotation_hz - 1.0 / 36.0).abs() < 1e-12);
        assert_eq!(segment_of(&s, 0.0), 0);
        assert_eq!(segment_of(&s, 500.0), 1);
        assert_eq!(segment_of(&s, 1e9), 8);
        assert_eq!(segment_of(&[], 3.0), 0);
    }
}
