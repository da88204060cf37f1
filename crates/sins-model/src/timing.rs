//! Medians of time stamps: one definition for every crate that needs a recording's record
//! interval (the readers, the estimation, the diagnostics, the batch fit).

/// Median of a slice (`NaN` when empty; the mean of the two middle values for an even count);
/// the slice is reordered. Linear time (a selection, not a sort).
pub fn median_of(values: &mut [f64]) -> f64 {
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    let mid = n / 2;
    let (below, m, _) = values.select_nth_unstable_by(mid, f64::total_cmp);
    let m = *m;
    if n % 2 == 1 {
        m
    } else {
        0.5 * (below.iter().copied().fold(f64::NEG_INFINITY, f64::max) + m)
    }
}

/// Median interval of time stamps: the median of the positive finite differences of
/// consecutive stamps (`NaN` when there is none: fewer than two stamps, or none increasing).
pub fn median_interval(t: &[f64]) -> f64 {
    median_interval_of(t.iter().copied())
}

/// [`median_interval`] of stamps given one by one (a long recording's records need not be
/// copied into a slice of their times first: the spacings alone are held, 8 bytes a record).
pub fn median_interval_of(t: impl IntoIterator<Item = f64>) -> f64 {
    let mut t = t.into_iter();
    let Some(mut previous) = t.next() else {
        return f64::NAN;
    };
    let mut d = Vec::with_capacity(t.size_hint().0);
    for x in t {
        let step = x - previous;
        if step.is_finite() && step > 0.0 {
            d.push(step);
        }
        previous = x;
    }
    median_of(&mut d)
}

/// [`median_interval_of`] of stamps read again from the start at every call of `read` (which
/// must visit the same stamps in the same order each time), in memory independent of their
/// number: the same value, found sixteen bits at a time, one reading each (positive finite
/// doubles order as their bit patterns), four readings in all. A long record file is read
/// four times rather than held.
pub fn median_interval_streamed<E>(
    read: impl FnMut(&mut dyn FnMut(f64)) -> Result<(), E>,
) -> Result<f64, E> {
    streamed_holding_at_most(read, StreamedIntervalMedian::HOLD_AT_MOST)
}

/// [`median_interval_streamed`] holding at most `hold` intervals (the tests' small bound
/// exercises the readings by histogram).
fn streamed_holding_at_most<E>(
    mut read: impl FnMut(&mut dyn FnMut(f64)) -> Result<(), E>,
    hold: usize,
) -> Result<f64, E> {
    let mut median = StreamedIntervalMedian::holding_at_most(hold);
    read(&mut |t| median.push(t))?;
    median.finish(read)
}

/// [`median_interval_streamed`] with its first reading done by the caller (stamp by stamp,
/// [`StreamedIntervalMedian::push`]), e.g. while it reads the file for other reasons; three
/// readings remain ([`StreamedIntervalMedian::finish`]), none where the first reading's
/// intervals were few enough to hold ([`StreamedIntervalMedian::HOLD_AT_MOST`]).
#[derive(Clone, Debug)]
pub struct StreamedIntervalMedian {
    /// Counts of the intervals by their top sixteen bits.
    first: Vec<usize>,
    n: usize,
    previous: f64,
    /// The intervals themselves while there are at most `hold` of them (`None` after).
    held: Option<Vec<f64>>,
    hold: usize,
}

impl Default for StreamedIntervalMedian {
    fn default() -> Self {
        Self::new()
    }
}

impl StreamedIntervalMedian {
    const BUCKETS: usize = 1 << 16;

    /// Intervals held at most (8 bytes each): a recording of up to a million records takes one
    /// reading, a longer one four.
    pub const HOLD_AT_MOST: usize = 1 << 20;

    /// Nothing read yet.
    pub fn new() -> Self {
        Self::holding_at_most(Self::HOLD_AT_MOST)
    }

    fn holding_at_most(hold: usize) -> Self {
        Self {
            first: vec![0; Self::BUCKETS],
            n: 0,
            previous: f64::NAN,
            held: Some(Vec::new()),
            hold,
        }
    }

    /// The next stamp of the first reading.
    #[inline]
    pub fn push(&mut self, t: f64) {
        let step = t - self.previous;
        if step.is_finite() && step > 0.0 {
            self.n += 1;
            self.first[(step.to_bits() >> 48) as usize] += 1;
            if let Some(h) = self.held.as_mut() {
                if h.len() < self.hold {
                    h.push(step);
                } else {
                    self.held = None;
                }
            }
        }
        self.previous = t;
    }

    /// The median interval: of the intervals held, or reading the stamps three more times
    /// with `read` (the same value either way, bit for bit).
    pub fn finish<E>(
        self,
        mut read: impl FnMut(&mut dyn FnMut(f64)) -> Result<(), E>,
    ) -> Result<f64, E> {
        let n = self.n;
        if n == 0 {
            return Ok(f64::NAN);
        }
        if let Some(mut held) = self.held {
            return Ok(median_of(&mut held));
        }
        // Ranks sought: the middle one, and the one below it for an even count.
        let mut ranks = if n % 2 == 1 {
            vec![n / 2]
        } else {
            vec![n / 2 - 1, n / 2]
        };
        let mut prefixes = vec![0u64; ranks.len()];
        let mut hist = vec![self.first.clone(), self.first];
        for round in 0..4u32 {
            let shift = 48 - 16 * round;
            if round > 0 {
                // Only the intervals that share the bits found so far.
                for h in &mut hist {
                    h.fill(0);
                }
                let high = shift + 16;
                let mut previous = f64::NAN;
                read(&mut |t| {
                    let step = t - previous;
                    previous = t;
                    if !(step.is_finite() && step > 0.0) {
                        return;
                    }
                    let bits = step.to_bits();
                    for (i, p) in prefixes.iter().enumerate() {
                        if bits >> high == p >> high {
                            hist[i][((bits >> shift) & 0xffff) as usize] += 1;
                        }
                    }
                })?;
            }
            for (i, (rank, prefix)) in ranks.iter_mut().zip(prefixes.iter_mut()).enumerate() {
                let mut below = 0usize;
                for (bucket, &count) in hist[i].iter().enumerate() {
                    if below + count > *rank {
                        *prefix |= (bucket as u64) << shift;
                        *rank -= below;
                        break;
                    }
                    below += count;
                }
            }
        }
        let values: Vec<f64> = prefixes.iter().map(|&b| f64::from_bits(b)).collect();
        Ok(match values.as_slice() {
            [m] => *m,
            [below, m] => 0.5 * (below + m),
            _ => unreachable!("one or two ranks"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians() {
        assert!(median_of(&mut []).is_nan());
        assert_eq!(median_of(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median_of(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!((median_interval(&[0.0, 0.01, 0.02, 0.035, 0.045]) - 0.01).abs() < 1e-15);
        assert!((median_interval(&[0.0, 0.01, 0.03, 0.06, 0.1]) - 0.025).abs() < 1e-15);
        assert!((median_interval(&[0.0, 0.1, 0.1, 0.3, 0.4]) - 0.1).abs() < 1e-15);
        assert!(median_interval(&[1.0]).is_nan());
        assert!(median_interval(&[]).is_nan());
        assert!(median_interval(&[2.0, 1.0]).is_nan());
    }

    /// The streamed median equals the one in memory, bit for bit, on stamps with jitter,
    /// repeats, gaps and reversals, odd and even counts.
    #[test]
    fn the_streamed_median_equals_the_median_in_memory() {
        // Held (one reading) where the intervals are few, by histogram (four) where not.
        let streamed_with = |t: &[f64], hold: usize| {
            let mut readings = 0;
            let m = streamed_holding_at_most::<()>(
                |visit| {
                    readings += 1;
                    t.iter().for_each(|&x| visit(x));
                    Ok(())
                },
                hold,
            )
            .unwrap();
            (m, readings)
        };
        let streamed = |t: &[f64]| streamed_with(t, 0);
        let mut state = 12345u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [2usize, 3, 4, 5, 10, 101, 1000, 4097] {
            let mut t = Vec::with_capacity(n);
            let mut x = 100.0;
            for i in 0..n {
                x += match i % 13 {
                    5 => 0.0,
                    7 => -0.003,
                    11 => 2.5,
                    _ => 0.01 * (1.0 + 0.1 * (uniform() - 0.5)),
                };
                t.push(x);
            }
            let (m, readings) = streamed(&t);
            assert_eq!(m.to_bits(), median_interval(&t).to_bits(), "n {n}");
            assert_eq!(readings, 4);
            let (m, readings) = streamed_with(&t, StreamedIntervalMedian::HOLD_AT_MOST);
            assert_eq!(m.to_bits(), median_interval(&t).to_bits(), "n {n}, held");
            assert_eq!(readings, 1);
        }
        assert!(streamed(&[1.0]).0.is_nan());
        assert!(streamed(&[2.0, 1.0]).0.is_nan());
        assert_eq!(
            streamed(&[0.0, 0.1, 0.1, 0.3, 0.4]).0,
            median_interval(&[0.0, 0.1, 0.1, 0.3, 0.4])
        );
    }
}
