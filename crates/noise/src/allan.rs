//! The overlapping Allan variance of one sensor axis over one or more static intervals.
//!
//! The input is the sensor's increments (angle increments for a gyro, velocity increments for
//! an accelerometer, or a rate times its interval), one per record, at a nominal record
//! interval `tau0`. Within a static interval of `L` records the phase is the running sum
//! `x_0 = 0, x_k = sum_{i<k} theta_i` (`L + 1` points, the interval's mean rate removed first
//! for precision: the Allan variance does not see a constant rate), and at averaging factor `m`
//! (`tau = m tau0`)
//!
//! ```text
//! AVAR(tau) = sum_k (x_{k+2m} - 2 x_{k+m} + x_k)^2 / (2 tau^2 n),   k = 0 .. n-1,  n = L + 1 - 2m
//! ```
//!
//! Several intervals are combined by adding their sums of squares and their numbers of terms:
//! the combined estimate is the average of the intervals' estimates weighted by their number of
//! terms `n`, and its degrees of freedom are the sum of theirs (the intervals are independent).
//! An interval shorter than `2m` records contributes nothing at that `m`, so the longest
//! interval bounds the longest `tau`.
//!
//! The averaging factors are octaves, `m = 1, 2, 4, ...` up to half the longest interval: each
//! costs one pass over the data, `O(N log N)` in all (1.44 million records, 20 octaves, in
//! about 0.1 s). Octave spacing also keeps neighbouring estimates less correlated than a
//! denser spacing would; the fit ([`crate::fit`]) accounts for the correlation that remains.

use crate::NoiseError;
use crate::edf::{self, NoiseType};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// One averaging time of an Allan variance curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AllanPoint {
    /// Averaging factor (records per average).
    pub m: usize,
    /// Averaging time `m tau0` (s).
    pub tau_s: f64,
    /// Overlapping Allan variance (unit^2, the unit of the rate: rad/s or m/s^2).
    pub avar: f64,
    /// Allan deviation, `sqrt(avar)`.
    pub adev: f64,
    /// Number of terms summed, over all intervals.
    pub terms: usize,
    /// Equivalent degrees of freedom, over all intervals ([`edf::edf_overlapping`]).
    pub edf: f64,
    /// The noise type the degrees of freedom were computed for.
    pub noise_type: NoiseType,
    /// Lower end of the 68.3 % (one-sigma) confidence interval of the deviation.
    pub lower: f64,
    /// Upper end of that interval.
    pub upper: f64,
}

/// An overlapping Allan variance curve of one axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AllanCurve {
    /// Nominal record interval (s).
    pub tau0_s: f64,
    /// Records in each interval used.
    pub interval_records: Vec<usize>,
    /// The curve, in increasing `tau`.
    pub points: Vec<AllanPoint>,
}

impl AllanCurve {
    /// Records used, over all intervals.
    pub fn records(&self) -> usize {
        self.interval_records.iter().sum()
    }

    /// Set the noise type of every point (one per point, in order), recomputing its degrees of
    /// freedom and confidence interval.
    pub fn set_noise_types(&mut self, types: &[NoiseType]) {
        for (p, &t) in self.points.iter_mut().zip(types) {
            p.noise_type = t;
            p.edf = self
                .interval_records
                .iter()
                .map(|&l| edf::edf_overlapping(l + 1, p.m, t))
                .sum();
            let (lo, hi) = edf::confidence_interval(p.adev, p.edf, edf::ONE_SIGMA);
            p.lower = lo;
            p.upper = hi;
        }
    }
}

/// Check the intervals against the data: non-empty, inside `0..len`, in order and not
/// overlapping.
pub(crate) fn check_intervals(len: usize, intervals: &[Range<usize>]) -> Result<(), NoiseError> {
    if intervals.is_empty() {
        return Err(NoiseError::NoIntervals);
    }
    let mut end = 0;
    for (i, r) in intervals.iter().enumerate() {
        if r.start >= r.end || r.end > len || (i > 0 && r.start < end) {
            return Err(NoiseError::BadInterval {
                index: i,
                start: r.start,
                end: r.end,
                records: len,
            });
        }
        end = r.end;
    }
    Ok(())
}

/// The overlapping Allan variance at octave averaging factors of the increments `increments`
/// (one per record; SI: rad or m/s) at the nominal record interval `tau0_s`, over the static
/// `intervals` (record index ranges, end exclusive, in order, not overlapping). The degrees of
/// freedom are first computed for white rate noise; [`AllanCurve::set_noise_types`] changes
/// that (the fit does, from the fitted model).
pub fn overlapping_allan(
    increments: &[f64],
    tau0_s: f64,
    intervals: &[Range<usize>],
) -> Result<AllanCurve, NoiseError> {
    if !(tau0_s.is_finite() && tau0_s > 0.0) {
        return Err(NoiseError::BadInterval0(tau0_s));
    }
    check_intervals(increments.len(), intervals)?;
    if let Some(i) = increments.iter().position(|x| !x.is_finite()) {
        return Err(NoiseError::NotFinite { record: i });
    }
    let longest = intervals.iter().map(|r| r.len()).max().unwrap_or(0);
    if longest < 2 {
        return Err(NoiseError::TooShort { longest });
    }
    let mut ms = Vec::new();
    let mut m = 1;
    while 2 * m <= longest {
        ms.push(m);
        m *= 2;
    }
    let mut sums = vec![0.0; ms.len()];
    let mut terms = vec![0usize; ms.len()];
    let mut x = Vec::with_capacity(longest + 1);
    for r in intervals {
        let data = &increments[r.clone()];
        let mean = data.iter().sum::<f64>() / data.len() as f64;
        x.clear();
        x.push(0.0);
        let mut s = 0.0;
        for v in data {
            s += v - mean;
            x.push(s);
        }
        let l = data.len();
        for (j, &m) in ms.iter().enumerate() {
            if 2 * m > l {
                break;
            }
            let n = l + 1 - 2 * m;
            let mut acc = 0.0;
            for k in 0..n {
                let d = x[k + 2 * m] - 2.0 * x[k + m] + x[k];
                acc += d * d;
            }
            sums[j] += acc;
            terms[j] += n;
        }
    }
    Ok(curve_of(tau0_s, intervals, &ms, &sums, &terms))
}

/// The curve from the sums of squares and numbers of terms at the averaging factors `ms`.
pub(crate) fn curve_of(
    tau0_s: f64,
    intervals: &[Range<usize>],
    ms: &[usize],
    sums: &[f64],
    terms: &[usize],
) -> AllanCurve {
    let points = ms
        .iter()
        .zip(sums.iter().zip(terms))
        .map(|(&m, (&s, &n))| {
            let tau = m as f64 * tau0_s;
            let avar = s / (2.0 * tau * tau * n as f64);
            AllanPoint {
                m,
                tau_s: tau,
                avar,
                adev: avar.sqrt(),
                terms: n,
                edf: 0.0,
                noise_type: NoiseType::WhiteRate,
                lower: 0.0,
                upper: 0.0,
            }
        })
        .collect::<Vec<_>>();
    let mut curve = AllanCurve {
        tau0_s,
        interval_records: intervals.iter().map(|r| r.len()).collect(),
        points,
    };
    let white = vec![NoiseType::WhiteRate; curve.points.len()];
    curve.set_noise_types(&white);
    curve
}

#[cfg(test)]
#[allow(clippy::single_range_in_vec_init)] // one interval: the whole data
mod tests {
    use super::*;

    /// The direct definition, for one interval and one m.
    fn direct(y: &[f64], tau0: f64, m: usize) -> f64 {
        let mut x = vec![0.0];
        for v in y {
            x.push(x.last().unwrap() + v);
        }
        let n = x.len() - 2 * m;
        let tau = m as f64 * tau0;
        (0..n)
            .map(|k| (x[k + 2 * m] - 2.0 * x[k + m] + x[k]).powi(2))
            .sum::<f64>()
            / (2.0 * tau * tau * n as f64)
    }

    #[test]
    fn matches_the_definition_and_ignores_a_constant_rate() {
        let y: Vec<f64> = (0..257)
            .map(|i| ((i * 7919) % 101) as f64 * 1e-3 + 5.0)
            .collect();
        let c = overlapping_allan(&y, 0.01, &[0..y.len()]).unwrap();
        assert_eq!(
            c.points.iter().map(|p| p.m).collect::<Vec<_>>(),
            vec![1, 2, 4, 8, 16, 32, 64, 128]
        );
        for p in &c.points {
            let d = direct(&y, 0.01, p.m);
            assert!(
                (p.avar - d).abs() <= 1e-9 * d,
                "m {}: {} {}",
                p.m,
                p.avar,
                d
            );
            assert_eq!(p.terms, 258 - 2 * p.m);
            assert!(p.lower < p.adev && p.adev < p.upper);
        }
    }

    #[test]
    fn intervals_combine_weighted_by_their_terms() {
        let y: Vec<f64> = (0..300).map(|i| ((i * 31) % 17) as f64).collect();
        let c = overlapping_allan(&y, 1.0, &[0..100, 150..300]).unwrap();
        // m = 64 only fits the second interval (150 records), m = 128 neither's half.
        assert_eq!(c.points.last().unwrap().m, 64);
        let p = &c.points[2]; // m = 4
        let (a, b) = (direct(&y[0..100], 1.0, 4), direct(&y[150..300], 1.0, 4));
        let (na, nb) = (101.0 - 8.0, 151.0 - 8.0);
        let want = (a * na + b * nb) / (na + nb);
        assert!((p.avar - want).abs() < 1e-9 * want);
        assert_eq!(p.terms, 93 + 143);
        let p64 = c.points.last().unwrap();
        assert_eq!(p64.terms, 151 - 128);
    }

    #[test]
    fn refuses_bad_input() {
        let y = vec![0.0; 10];
        assert!(matches!(
            overlapping_allan(&y, 0.0, &[0..10]),
            Err(NoiseError::BadInterval0(_))
        ));
        assert!(matches!(
            overlapping_allan(&y, 1.0, &[0..11]),
            Err(NoiseError::BadInterval { index: 0, .. })
        ));
        assert!(matches!(
            overlapping_allan(&y, 1.0, &[0..5, 4..8]),
            Err(NoiseError::BadInterval { index: 1, .. })
        ));
        assert!(matches!(
            overlapping_allan(&y, 1.0, &[]),
            Err(NoiseError::NoIntervals)
        ));
        let mut z = y.clone();
        z[3] = f64::NAN;
        assert!(matches!(
            overlapping_allan(&z, 1.0, &[0..10]),
            Err(NoiseError::NotFinite { record: 3 })
        ));
        assert!(matches!(
            overlapping_allan(&y, 1.0, &[0..1, 2..3]),
            Err(NoiseError::TooShort { longest: 1 })
        ));
    }
}
