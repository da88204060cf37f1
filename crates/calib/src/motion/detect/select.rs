//! Order statistics of values read again from their start, in memory independent of their
//! number: the `k`-th smallest in `f64::total_cmp` order, exactly as a selection over the values
//! held in a slice gives it (`select_nth_unstable_by(k, f64::total_cmp)`).
//!
//! Each reading narrows every channel's value to the values sharing the bits found so far: the
//! first counts the values by the top sixteen bits of their order key, the next by the next
//! sixteen, and so on, until the values that share the bits found are few enough
//! ([`COLLECT_AT_MOST`] over all channels) to be held and selected among. Values that are few
//! enough from the start (a recording of up to a million records) are held in the first
//! reading and take only that one; a channel of a few million windowed deviations takes two
//! readings; of a million equal values, five at most.
//! (`sins_model::timing::StreamedIntervalMedian` is the same idea for a median interval.)

/// Values held at most, over all channels, for the last reading's selection (8 bytes each).
pub const COLLECT_AT_MOST: usize = 1 << 20;

const BITS: u32 = 16;

/// The order key of `x`: unsigned integers order as `f64::total_cmp` orders the values.
#[inline]
fn key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 { !b } else { b | (1 << 63) }
}

#[derive(Clone, Debug)]
struct Channel {
    /// Bits of the key found so far (the top `known` bits).
    prefix: u64,
    known: u32,
    /// Rank among the values sharing the prefix.
    rank: usize,
    /// Values sharing the prefix (after the last histogram).
    count: usize,
    done: Option<f64>,
}

impl Channel {
    #[inline]
    fn matches(&self, k: u64) -> bool {
        self.known == 0 || k >> (64 - self.known) == self.prefix >> (64 - self.known)
    }

    /// Take the next sixteen bits from the histogram `hist` of the values sharing the prefix
    /// (`first_rank`: the rank sought, at the first reading, where the count becomes known).
    fn narrow(&mut self, hist: &[usize], first_rank: Option<usize>) {
        if let Some(r) = first_rank {
            self.rank = r;
            if r >= hist.iter().sum() {
                self.done = Some(f64::NAN);
                return;
            }
        }
        let shift = 64 - self.known - BITS;
        let mut below = 0usize;
        for (bucket, &count) in hist.iter().enumerate() {
            if below + count > self.rank {
                self.prefix |= (bucket as u64) << shift;
                self.rank -= below;
                self.count = count;
                break;
            }
            below += count;
        }
        self.known += BITS;
        if self.known == 64 {
            let b = self.prefix;
            let bits = if b >> 63 == 1 { b & !(1 << 63) } else { !b };
            self.done = Some(f64::from_bits(bits));
        }
    }
}

/// The `r`-th smallest of `v` (`f64::total_cmp` order), NaN beyond its length.
fn selected(v: &mut [f64], r: usize) -> f64 {
    if r < v.len() {
        *v.select_nth_unstable_by(r, f64::total_cmp).1
    } else {
        f64::NAN
    }
}

/// The `rank(count)`-th smallest value of each of `channels` channels (`f64::total_cmp` order;
/// NaN for a channel without values, or a rank beyond its count), with the values read again at
/// every call of `read` (which must visit the same values in the same order each time, as
/// `(channel, value)`). `rank` gets the channel and its number of values.
pub fn select_streamed<E>(
    channels: usize,
    rank: impl Fn(usize, usize) -> usize,
    read: impl FnMut(&mut dyn FnMut(usize, f64)) -> Result<(), E>,
) -> Result<Vec<f64>, E> {
    select_holding_at_most(channels, rank, read, COLLECT_AT_MOST)
}

/// [`select_streamed`] holding at most `collect_at_most` values (the tests' small bound
/// exercises the readings by histogram).
fn select_holding_at_most<E>(
    channels: usize,
    rank: impl Fn(usize, usize) -> usize,
    mut read: impl FnMut(&mut dyn FnMut(usize, f64)) -> Result<(), E>,
    collect_at_most: usize,
) -> Result<Vec<f64>, E> {
    let mut ch: Vec<Channel> = (0..channels)
        .map(|_| Channel {
            prefix: 0,
            known: 0,
            rank: 0,
            count: 0,
            done: None,
        })
        .collect();
    let mut first = true;
    loop {
        let open: Vec<usize> = (0..channels).filter(|&c| ch[c].done.is_none()).collect();
        if open.is_empty() {
            break;
        }
        let held: usize = open.iter().map(|&c| ch[c].count).sum();
        if !first && held <= collect_at_most {
            // Hold the values that share the bits found, and select among them.
            let mut values: Vec<Vec<f64>> = open
                .iter()
                .map(|&c| Vec::with_capacity(ch[c].count))
                .collect();
            let slot: Vec<Option<usize>> = (0..channels)
                .map(|c| open.iter().position(|&o| o == c))
                .collect();
            read(&mut |c, x| {
                if let Some(s) = slot[c]
                    && ch[c].matches(key(x))
                {
                    values[s].push(x);
                }
            })?;
            for (s, &c) in open.iter().enumerate() {
                ch[c].done = Some(selected(&mut values[s], ch[c].rank));
            }
            break;
        }
        // Count the values sharing the prefix by their next sixteen bits. The first reading
        // also holds the values while they are few enough: when all of them are, it selects
        // among them at once, without a second reading (the detector's levels read the
        // windowed deviations once instead of twice).
        let mut hist: Vec<Vec<usize>> = open.iter().map(|_| vec![0usize; 1 << BITS]).collect();
        let slot: Vec<Option<usize>> = (0..channels)
            .map(|c| open.iter().position(|&o| o == c))
            .collect();
        let mut early: Option<Vec<Vec<f64>>> = first.then(|| vec![Vec::new(); open.len()]);
        let mut early_held = 0usize;
        read(&mut |c, x| {
            if let Some(s) = slot[c] {
                let k = key(x);
                let chan = &ch[c];
                if chan.matches(k) {
                    let shift = 64 - chan.known - BITS;
                    hist[s][((k >> shift) & 0xffff) as usize] += 1;
                }
                if let Some(values) = early.as_mut() {
                    if early_held < collect_at_most {
                        values[s].push(x);
                        early_held += 1;
                    } else {
                        early = None;
                    }
                }
            }
        })?;
        if let Some(mut values) = early {
            for (s, &c) in open.iter().enumerate() {
                let r = rank(c, values[s].len());
                ch[c].done = Some(selected(&mut values[s], r));
            }
            break;
        }
        for (s, &c) in open.iter().enumerate() {
            let first_rank = first.then(|| rank(c, hist[s].iter().sum()));
            ch[c].narrow(&hist[s], first_rank);
        }
        first = false;
    }
    Ok(ch.into_iter().map(|c| c.done.unwrap_or(f64::NAN)).collect())
}

/// The index of the `q` quantile among `len` values as the detector takes it: `round((len - 1)
/// q)`.
pub fn quantile_rank(len: usize, q: f64) -> usize {
    if len == 0 {
        return 0;
    }
    ((len - 1) as f64 * q).round() as usize
}

/// The `q` quantile of `v` held in a slice (by selection; NaN for an empty slice): the value of
/// rank [`quantile_rank`], as [`select_streamed`] gives it from values read again.
pub(crate) fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut c = v.to_vec();
    let k = quantile_rank(c.len(), q);
    let (_, x, _) = c.select_nth_unstable_by(k, f64::total_cmp);
    *x
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held(v: &[f64], k: usize) -> f64 {
        let mut c = v.to_vec();
        *c.select_nth_unstable_by(k, f64::total_cmp).1
    }

    #[test]
    fn the_streamed_selection_equals_the_one_in_memory() {
        let mut state = 99u64;
        let mut u = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let spread: Vec<f64> = (0..5000).map(|_| (u() * 40.0 - 20.0).exp()).collect();
        let signed: Vec<f64> = (0..3001).map(|_| u() - 0.5).collect();
        let equal = vec![0.25; 2000];
        let mut near: Vec<f64> = (0..3000).map(|i| 0.01 + (i % 7) as f64 * 1e-17).collect();
        near.push(0.0);
        near.push(-0.0);
        let sets = [spread, signed, equal, near];
        // Held at once (one reading), and by histogram when fewer may be held (two).
        for (limit, want_readings) in [(COLLECT_AT_MOST, 1), (10_000, 2)] {
            for q in [0.0, 0.1, 0.25, 0.5, 0.9, 1.0] {
                let mut readings = 0;
                let got = select_holding_at_most::<()>(
                    sets.len(),
                    |_, n| quantile_rank(n, q),
                    |visit| {
                        readings += 1;
                        // Interleaved, as a reading of records gives them.
                        for i in 0..5000 {
                            for (c, s) in sets.iter().enumerate() {
                                if let Some(&x) = s.get(i) {
                                    visit(c, x);
                                }
                            }
                        }
                        Ok(())
                    },
                    limit,
                )
                .unwrap();
                for (c, s) in sets.iter().enumerate() {
                    let want = held(s, quantile_rank(s.len(), q));
                    assert_eq!(got[c].to_bits(), want.to_bits(), "q {q} set {c}");
                }
                assert_eq!(readings, want_readings);
            }
        }
        // An empty channel.
        let got = select_streamed::<()>(
            2,
            |_, n| n / 2,
            |visit| {
                visit(1, 3.0);
                Ok(())
            },
        )
        .unwrap();
        assert!(got[0].is_nan());
        assert_eq!(got[1], 3.0);
    }
}
