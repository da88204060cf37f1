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
}
