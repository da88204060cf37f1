//! Record intervals: median, extremes and gaps. Jitter is kept (every record keeps its own time
//! stamp); an interval longer than `gap_factor` median intervals is a gap, reported, never
//! bridged.

use serde::{Deserialize, Serialize};

/// Interval statistics of a recording.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Median interval between consecutive records (s).
    pub median_interval_s: f64,
    /// Shortest interval (s).
    pub min_interval_s: f64,
    /// Longest interval (s).
    pub max_interval_s: f64,
    /// An interval longer than this many median intervals is a gap.
    pub gap_factor: f64,
}

/// A gap: an interval longer than `gap_factor` median intervals, before record `index`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapAt {
    /// 0-based index of the record after the gap.
    pub index: usize,
    /// Time of the record before the gap (s).
    pub t_before_s: f64,
    /// Time of the record after the gap (s).
    pub t_after_s: f64,
}

impl GapAt {
    /// Length of the interval (s).
    pub fn length_s(&self) -> f64 {
        self.t_after_s - self.t_before_s
    }
}

pub use sins_model::timing::{median_interval, median_of};

/// Interval statistics and gaps of strictly increasing time stamps (at least two).
pub fn analyse(t: &[f64], gap_factor: f64) -> (Timing, Vec<GapAt>) {
    let median = median_interval(t);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut gaps = Vec::new();
    for (i, w) in t.windows(2).enumerate() {
        let d = w[1] - w[0];
        lo = lo.min(d);
        hi = hi.max(d);
        if d > gap_factor * median {
            gaps.push(GapAt {
                index: i + 1,
                t_before_s: w[0],
                t_after_s: w[1],
            });
        }
    }
    (
        Timing {
            median_interval_s: median,
            min_interval_s: lo,
            max_interval_s: hi,
            gap_factor,
        },
        gaps,
    )
}

/// The gap-free stretches `[start, end)` of a recording with these gaps.
pub fn blocks(n: usize, gaps: &[GapAt]) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(gaps.len() + 1);
    let mut start = 0;
    for g in gaps {
        out.push((start, g.index));
        start = g.index;
    }
    if start < n {
        out.push((start, n));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians() {
        assert_eq!(median_of(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median_of(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median_of(&mut []).is_nan());
    }

    #[test]
    fn gaps_and_blocks() {
        let t = [0.0, 0.01, 0.02, 0.05, 0.06, 0.07];
        let (timing, gaps) = analyse(&t, 1.5);
        assert!((timing.median_interval_s - 0.01).abs() < 1e-12);
        assert_eq!(gaps.len(), 1);
        assert_eq!(gaps[0].index, 3);
        assert!((gaps[0].length_s() - 0.03).abs() < 1e-12);
        assert_eq!(blocks(t.len(), &gaps), vec![(0, 3), (3, 6)]);
    }
}
