//! The correlations between Allan variance estimates an octave or more apart that the fit uses
//! (`noise::fit::octave_correlation`), checked against a Monte-Carlo of its own: 300 runs
//! (seeds 0..300) of 32768 records of white rate noise, of a rate random walk and of white
//! phase noise, the correlation at lags 1 to 3 averaged over m = 4 .. 256. The table came from
//! a longer run (400 runs, m = 1 .. 8192); the averages must agree within 0.08 (the sampling
//! error of a correlation over 300 runs is about 0.05, and averaging over seven m's shrinks
//! it, though the m's are not independent).

use noise::allan::overlapping_allan;
use noise::edf::NoiseType;
use noise::fit::octave_correlation;
use rand::{SeedableRng, rngs::Xoshiro256PlusPlus};
use rand_distr::{Distribution, StandardNormal};

fn curves(noise: NoiseType) -> Vec<Vec<f64>> {
    let n = 1 << 15;
    (0..300u64)
        .map(|seed| {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
            let (mut walk, mut prev) = (0.0, 0.0);
            let y: Vec<f64> = (0..n)
                .map(|_| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    match noise {
                        NoiseType::RandomWalk => {
                            walk += z;
                            walk
                        }
                        NoiseType::WhitePhase => {
                            let d = z - prev;
                            prev = z;
                            d
                        }
                        _ => z,
                    }
                })
                .collect();
            overlapping_allan(&y, 1.0, std::slice::from_ref(&(0..n)))
                .unwrap()
                .points
                .iter()
                .map(|p| p.avar)
                .collect()
        })
        .collect()
}

#[test]
fn table_matches_a_monte_carlo() {
    for noise in [
        NoiseType::WhiteRate,
        NoiseType::RandomWalk,
        NoiseType::WhitePhase,
    ] {
        let runs = curves(noise);
        let r = runs.len() as f64;
        let m = runs[0].len();
        let mean: Vec<f64> = (0..m)
            .map(|j| runs.iter().map(|c| c[j]).sum::<f64>() / r)
            .collect();
        let sd: Vec<f64> = (0..m)
            .map(|j| (runs.iter().map(|c| (c[j] - mean[j]).powi(2)).sum::<f64>() / r).sqrt())
            .collect();
        for lag in 1..=3 {
            // m = 4 .. 256: octaves 2 ..= 8.
            let js: Vec<usize> = (2..=8).collect();
            let avg = js
                .iter()
                .map(|&j| {
                    runs.iter()
                        .map(|c| (c[j] - mean[j]) * (c[j + lag] - mean[j + lag]))
                        .sum::<f64>()
                        / r
                        / (sd[j] * sd[j + lag])
                })
                .sum::<f64>()
                / js.len() as f64;
            let table = octave_correlation(noise, lag);
            println!("{noise:?} lag {lag}: Monte-Carlo {avg:.3}, table {table:.2}");
            assert!(
                (avg - table).abs() < 0.08,
                "{noise:?} lag {lag}: {avg} vs {table}"
            );
        }
    }
}
