//! The Allan fit follows the curve it fits, and the likelihood fit checks out on a sensor whose
//! own filter correlates neighbouring samples. Seeds and thresholds written before the first
//! run.

#![allow(clippy::single_range_in_vec_init)] // one interval: the whole recording

use noise::allan::overlapping_allan;
use noise::fit::{Term, fit_terms};
use noise::likelihood::{correlation_records, fit_ml};
use rand::{SeedableRng, rngs::Xoshiro256PlusPlus};
use rand_distr::{Distribution, StandardNormal};

/// White rate noise `white` (1-s average), a bias walk `walk`, and a flicker-like floor made
/// of Gauss-Markov processes at 1, 10 and 100 s (each `floor` deviation), `records` at 100 Hz.
fn sensor(seed: u64, records: usize, white: f64, walk: f64, floor: f64) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let dt: f64 = 0.01;
    let tcs: [f64; 3] = [1.0, 10.0, 100.0];
    let mut g = [0.0f64; 3];
    let mut b = 0.0;
    (0..records)
        .map(|_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            let zb: f64 = StandardNormal.sample(&mut rng);
            b += walk * dt.sqrt() * zb;
            let mut gm = 0.0;
            for (gi, tc) in g.iter_mut().zip(tcs) {
                let phi = (-dt / tc).exp();
                let zg: f64 = StandardNormal.sample(&mut rng);
                *gi = phi * *gi + floor * (1.0 - phi * phi).sqrt() * zg;
                gm += *gi;
            }
            white * dt.sqrt() * z + (b + gm) * dt
        })
        .collect()
}

/// White noise, a walk and a bias floor, 1 h at 100 Hz, seeds 31..=33: the fitted sum inside
/// every point's 95 % band or, where a point leaves it by chance, not on a stretch the terms
/// cannot follow, and the chi-square passes.
#[test]
fn fitted_sum_stays_in_the_band() {
    for seed in 31..=33u64 {
        let data = sensor(seed, 360_000, 1e-5, 2e-7, 2e-6);
        let mut c = overlapping_allan(&data, 0.01, &[0..data.len()]).unwrap();
        let f = fit_terms(&mut c).unwrap();
        println!(
            "seed {seed}: chi2 {:.2}/{} p {:.3}, misfits {:?}",
            f.chi2, f.dof, f.p_value, f.misfits
        );
        assert!(f.passes(), "seed {seed}: {f:?}");
        // At most one point outside its 95 % band (20 points: 1 expected by chance).
        let outside: usize = f.misfits.iter().map(|m| m.points).sum();
        assert!(outside <= 2, "seed {seed}: {outside} points outside");
        assert!((f.term(Term::White).value / 1e-5 - 1.0).abs() < 0.05);
    }
}

/// The failure mode of the issue: a curve that is white at short tau and falls below the
/// white line at long tau (as on the Xsens rests). A model with a bias floor above the data
/// there must not be preferred: no term lifts the sum above the white line the short taus fix
/// (the first bound written, the sum within 1.5 times the data everywhere, could not hold: the
/// long points were lowered by 2, below what any sum through the short ones reaches), and the
/// fit reports the stretch the terms cannot follow and fails its check.
#[test]
fn an_over_predicting_model_is_not_preferred() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(41);
    // 38 intervals of 10-50 s at 100 Hz, white noise 130 deg/h-like (SI 6.3e-4 rad/s).
    let mut data = Vec::new();
    let mut intervals = Vec::new();
    for k in 0..38usize {
        let len = 1000 + (k * 997) % 4000;
        let start = data.len();
        for _ in 0..len {
            let z: f64 = StandardNormal.sample(&mut rng);
            data.push(6.3e-4 * 0.1 * z);
        }
        intervals.push(start..data.len());
    }
    let mut c = overlapping_allan(&data, 0.01, &intervals).unwrap();
    // The long-tau points pushed below the white line by a factor 2 in deviation, like the
    // rests of a real unit whose intervals were chosen where it was quiet.
    let n = c.points.len();
    for p in &mut c.points[n - 3..] {
        p.avar /= 4.0;
        p.adev /= 2.0;
    }
    let f = fit_terms(&mut c).unwrap();
    println!("{f:?}");
    let white = f.term(Term::White).value;
    for p in &c.points {
        let r = f.avar(p.tau_s).sqrt() / (white / p.tau_s.sqrt());
        println!("tau {:.2}: sum over the white line {r:.3}", p.tau_s);
        assert!(
            r < 1.01,
            "tau {}: the sum {r} times the white line",
            p.tau_s
        );
    }
    let b = f.term(Term::BiasInstability);
    assert!(!b.included || 0.664 * b.value < c.points[n - 1].upper);
    assert!(
        f.misfits
            .iter()
            .any(|m| m.fitted && m.to_tau_s >= c.points[n - 1].tau_s),
        "the lowered points not reported"
    );
    assert!(!f.passes());
}

/// A gyro whose samples pass a 5-record moving average (neighbouring samples correlated, as
/// the Xsens's internal filter does), white and walk otherwise, 20 min at 100 Hz, seed 51: the
/// correlation length is found (4 to 6 records), and the likelihood fit on block means above
/// it passes its check with the white level within 5 % and no Gauss-Markov time at a bound.
#[test]
fn likelihood_passes_on_filtered_samples() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(51);
    let (records, dt, white, walk): (usize, f64, f64, f64) = (120_000, 0.01, 1e-4, 1e-6);
    let raw: Vec<f64> = (0..records + 4)
        .map(|_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            white / dt.sqrt() * z
        })
        .collect();
    let mut b = 0.0;
    let data: Vec<f64> = (0..records)
        .map(|i| {
            let zb: f64 = StandardNormal.sample(&mut rng);
            b += walk * dt.sqrt() * zb;
            (raw[i..i + 5].iter().sum::<f64>() / 5.0 + b) * dt
        })
        .collect();
    let k = correlation_records(&data, &[0..records]);
    let f = fit_ml(&data, dt, &[0..records]).unwrap();
    println!("correlation {k} records, {f:?}");
    assert!((4..=6).contains(&k), "correlation length {k}");
    assert!(f.passes(), "check {:?}", f.whiteness);
    assert!(
        (f.white.value / white - 1.0).abs() < 0.05,
        "white {}",
        f.white.value
    );
    assert!(!f.tc_at_bound);
}
