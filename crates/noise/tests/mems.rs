//! A MEMS gyro at rest as a user's recording showed it: white noise, an oscillation at a fifth
//! of the sample rate (lag-2 autocorrelation of the samples about -0.35), and a flicker floor
//! (docs/noise.md, "An oscillation and a flicker floor"). Seeds and bounds were fixed before
//! the first run.

use noise::analyse_axis_from;
use noise::consistency::check_family;
use noise::fit::Term;
use noise::floor::{FLICKER_ADEV, flicker_floor, slow_terms};
use noise::likelihood::{BLOCKS_PER_CORRELATION, Model, fit_ml, fit_ml_blocks};
use rand::{SeedableRng, rngs::Xoshiro256PlusPlus};
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::TAU;
use std::ops::Range;

const DEG_H: f64 = std::f64::consts::PI / 180.0 / 3600.0;
const DT: f64 = 0.01;
/// White level (deg/h, the deviation of a 1-s average) and bias instability (deg/h) of the
/// user's gyro.
const WHITE_DEG_H: f64 = 139.0;
const INSTABILITY_DEG_H: f64 = 27.5;
/// The flicker floor: first-order Gauss-Markov processes of equal variance, three time
/// constants a decade from 0.1 s to 10^4 s (a sum of log-spaced Gauss-Markov processes has a
/// 1/f spectrum between its shortest and longest time constant).
const GM_DECADES: (i32, i32) = (-3, 12);

fn time_constants() -> Vec<f64> {
    (GM_DECADES.0..=GM_DECADES.1)
        .map(|i| 10f64.powf(i as f64 / 3.0))
        .collect()
}

/// The Allan deviation of the Gauss-Markov sum with unit deviation per process.
fn flicker_adev_unit(tau_s: f64) -> f64 {
    time_constants()
        .iter()
        .map(|&tc| {
            Model {
                white: 0.0,
                walk: 0.0,
                gauss_markov: Some((1.0, tc)),
            }
            .avar(tau_s)
        })
        .sum::<f64>()
        .sqrt()
}

/// Each process's deviation (rad/s) for a floor of `0.664 B` at 1000 s, the middle of the
/// floor.
fn gm_sigma() -> f64 {
    FLICKER_ADEV * INSTABILITY_DEG_H * DEG_H / flicker_adev_unit(1000.0)
}

/// `records` rate samples (rad/s) at 100 Hz: white noise, the oscillation (a sinusoid of
/// period 5 records whose phase jitters by 0.02 rad a record, sized for a lag-2
/// autocorrelation of -0.35), the flicker floor.
fn simulate(records: usize, seed: u64) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
    let white_sd = WHITE_DEG_H * DEG_H / DT.sqrt();
    // A sinusoid of variance A^2 / 2 = s / (1 - s) of the white variance has a share s of the
    // samples' variance and lag-2 autocorrelation s cos(4 pi / 5) = -0.809 s: s = 0.43.
    let share: f64 = 0.43;
    let amplitude = (2.0 * share / (1.0 - share)).sqrt() * white_sd;
    let sigma = gm_sigma();
    let tcs = time_constants();
    let phis: Vec<f64> = tcs.iter().map(|tc| (-DT / tc).exp()).collect();
    let mut gm: Vec<f64> = tcs.iter().map(|_| sigma * normal()).collect();
    let mut phase = TAU * normal();
    (0..records)
        .map(|_| {
            let mut y = white_sd * normal() + amplitude * phase.sin();
            phase += TAU / 5.0 + 0.02 * normal();
            for (g, phi) in gm.iter_mut().zip(&phis) {
                *g = phi * *g + sigma * (1.0 - phi * phi).sqrt() * normal();
                y += *g;
            }
            y
        })
        .collect()
}

/// The likelihood fit and the Allan analysis of `increments` over `intervals` (the Allan fit
/// from ten times the likelihood's correlation time, as `noise` makes it).
fn analyse(
    increments: &[f64],
    intervals: &[Range<usize>],
) -> (noise::likelihood::MlFit, noise::AxisNoise) {
    let ml = fit_ml(increments, DT, intervals).expect("ml fit");
    let tau_min = BLOCKS_PER_CORRELATION as f64 * ml.correlation_s;
    let axis = analyse_axis_from(increments, DT, intervals, tau_min).expect("allan");
    (ml, axis)
}

fn autocorrelation(y: &[f64], lag: usize) -> f64 {
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let c0: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    let ck: f64 = y
        .iter()
        .zip(&y[lag..])
        .map(|(a, b)| (a - mean) * (b - mean))
        .sum();
    ck / c0
}

/// 2.8 h at 100 Hz, the user's recording: the likelihood's white level and the floor's bias
/// instability against the truth (white within 10 %, instability within 30 %), the
/// oscillation named with its period. About 5 s in release.
#[test]
#[allow(clippy::single_range_in_vec_init)] // one interval: the whole recording
fn an_oscillation_and_a_flicker_floor() {
    let records = 1_008_000;
    let rate = simulate(records, 31);
    println!(
        "samples' autocorrelation: lag 2 {:+.3}, lag 5 {:+.3}",
        autocorrelation(&rate, 2),
        autocorrelation(&rate, 5)
    );
    let increments: Vec<f64> = rate.iter().map(|w| w * DT).collect();
    let intervals = [0..records];
    let (ml, axis) = analyse(&increments, &intervals);
    let at_1s = axis
        .curve
        .points
        .iter()
        .find(|p| p.tau_s > 1.0)
        .expect("a point above 1 s");
    let osc = ml.oscillation.expect("the oscillation named");
    println!(
        "oscillation: period {} s, rms {:.1} deg/h, differences' autocorrelation {:+.3}, \
         correlated to {} s; blocks {} s",
        osc.period_s,
        osc.rms / DEG_H,
        osc.autocorrelation,
        osc.correlated_to_s,
        ml.block_s
    );
    let white = ml.white.value / DEG_H;
    println!(
        "white: likelihood {:.1} [{:.1}, {:.1}] deg/h, Allan fit {:.1}, Allan deviation at {} s \
         times sqrt(tau) {:.1}, truth {WHITE_DEG_H}",
        white,
        ml.white.lower / DEG_H,
        ml.white.upper / DEG_H,
        axis.fit.term(Term::White).value / DEG_H,
        at_1s.tau_s,
        at_1s.adev * at_1s.tau_s.sqrt() / DEG_H
    );
    // For comparison (a measurement, not tested): the blocks the correlation search alone
    // would give, ten times its last correlated lag.
    let last_lag = (osc.correlated_to_s / DT).round() as usize;
    let old = fit_ml_blocks(
        &increments,
        DT,
        &intervals,
        BLOCKS_PER_CORRELATION * last_lag,
    )
    .expect("ml fit");
    println!(
        "without the oscillation rule: blocks {} s, white {:.1} deg/h",
        old.block_s,
        old.white.value / DEG_H
    );
    let band = check_family(&[(&axis.curve, &ml)]);
    println!(
        "likelihood model against the Allan curve: {} of {} points outside the band",
        band.axes[0].outside().count(),
        band.points
    );
    let floor = flicker_floor(&axis.curve, axis.fit.tau_min_s, ml.white.value).expect("a floor");
    let truth_b = flicker_adev_unit(1000.0) * gm_sigma() / FLICKER_ADEV / DEG_H;
    let ripple: Vec<f64> = [30.0, 100.0, 300.0, 1000.0, 3000.0]
        .iter()
        .map(|&t| flicker_adev_unit(t) * gm_sigma() / FLICKER_ADEV / DEG_H)
        .collect();
    println!(
        "floor: {:.1} [{:.1}, {:.1}] deg/h, dominating from {:.1} to {} s, ln likelihood ratio \
         {:.1} over a walk, truth {:.1} (the floor's own B at 30, 100, 300, 1000, 3000 s: \
         {:.1?})",
        floor.value / DEG_H,
        floor.lower / DEG_H,
        floor.upper / DEG_H,
        floor.from_tau_s,
        floor.to_tau_s,
        floor.ln_lr_over_walk,
        truth_b,
        ripple
    );
    let slow = slow_terms(&axis.curve, &ml);
    println!("{slow:?}");
    assert!(
        (osc.period_s - 0.05).abs() < 1e-9,
        "period {}",
        osc.period_s
    );
    assert!(
        (white / WHITE_DEG_H - 1.0).abs() < 0.10,
        "likelihood white {white} deg/h"
    );
    assert!(
        (floor.value / DEG_H / truth_b - 1.0).abs() < 0.30,
        "floor {} deg/h",
        floor.value / DEG_H
    );
    assert!(slow.bias_instability);
}

/// 20 poses of 5 s (10 s of motion between them, not used) of the same gyro: too short to
/// tell a bias instability or a walk.
#[test]
fn short_poses_do_not_determine_the_slow_terms() {
    let pose = 500;
    let rate = simulate(20 * 1500, 32);
    let increments: Vec<f64> = rate.iter().map(|w| w * DT).collect();
    let intervals: Vec<Range<usize>> = (0..20).map(|i| i * 1500..i * 1500 + pose).collect();
    let (ml, axis) = analyse(&increments, &intervals);
    let slow = slow_terms(&axis.curve, &ml);
    println!(
        "white {:.1} [{:.1}, {:.1}] deg/h, walk {:.0} [{:.0}, {:.0}] deg/h/sqrt(h); {slow:?}",
        ml.white.value / DEG_H,
        ml.white.lower / DEG_H,
        ml.white.upper / DEG_H,
        ml.walk.value / DEG_H * 60.0,
        ml.walk.lower / DEG_H * 60.0,
        ml.walk.upper / DEG_H * 60.0,
    );
    assert_eq!(slow.longest_rest_s, 5.0);
    assert!(!slow.walk, "walk determined from 5-s poses");
    assert!(
        !slow.bias_instability,
        "bias instability determined from 5-s poses"
    );
}

/// A value with the ends of its 68 % interval.
type Interval = (f64, f64, f64);

/// What the analysis of one 2.8-h recording gives: the oscillation's period (s), the
/// likelihood's white level (deg/h), the floor's bias instability and its 68 % interval (deg/h;
/// `None`: no floor) and whether the slow terms call the bias instability determined.
#[allow(clippy::single_range_in_vec_init)] // one interval: the whole recording
fn measure(seed: u64) -> (Option<f64>, f64, Option<Interval>, bool) {
    let records = 1_008_000;
    let increments: Vec<f64> = simulate(records, seed).iter().map(|w| w * DT).collect();
    let intervals = [0..records];
    let (ml, axis) = analyse(&increments, &intervals);
    let floor = flicker_floor(&axis.curve, axis.fit.tau_min_s, ml.white.value)
        .map(|f| (f.value / DEG_H, f.lower / DEG_H, f.upper / DEG_H));
    let slow = slow_terms(&axis.curve, &ml);
    (
        ml.oscillation.map(|o| o.period_s),
        ml.white.value / DEG_H,
        floor,
        slow.bias_instability,
    )
}

/// The 2.8-h case over `seeds`, counted and checked against the surveys' thresholds: the
/// period named in every run; the white level within 10 % and the floor's bias instability
/// within 30 % of the truth in at least 18 of 20 each; its 68 % interval covering it in at
/// least 9 of 20.
fn survey_floor(seeds: std::ops::RangeInclusive<u64>) {
    let truth_b = flicker_adev_unit(1000.0) * gm_sigma() / FLICKER_ADEV / DEG_H;
    let (mut period_ok, mut white_ok, mut floor_ok, mut covered) = (0, 0, 0, 0);
    for seed in seeds.clone() {
        let (period, white, floor, determined) = measure(seed);
        println!(
            "seed {seed}: period {period:?} s, white {white:.1} deg/h (truth {WHITE_DEG_H}), \
             floor {floor:.1?} deg/h (truth {truth_b:.1}), determined {determined}"
        );
        period_ok += usize::from(period.is_some_and(|p| (p - 0.05).abs() < 1e-9));
        white_ok += usize::from((white / WHITE_DEG_H - 1.0).abs() < 0.10);
        floor_ok += usize::from(
            determined && floor.is_some_and(|(b, _, _)| (b / truth_b - 1.0).abs() < 0.30),
        );
        covered += usize::from(floor.is_some_and(|(_, lo, hi)| lo <= truth_b && truth_b <= hi));
    }
    let n = seeds.count();
    println!(
        "period named {period_ok}/{n}, white within 10 % {white_ok}/{n}, floor within 30 % \
         {floor_ok}/{n}, its 68 % interval covering the truth {covered}/{n}"
    );
    assert_eq!(period_ok, n);
    assert!(white_ok >= 18 && floor_ok >= 18 && covered >= 9);
}

/// The rates of the 2.8-h case over seeds 3101-3120 (a survey, about a minute:
/// `cargo test --release -p noise --test mems -- --ignored --nocapture`). Thresholds fixed
/// before the first run: the oscillation's period named in every run, the white level within
/// 10 % and the floor's bias instability within 30 % of the truth in at least 18 of 20 each.
/// (The floor's rule of session 25 was worked out on these seeds' curves: the fresh survey
/// below is its check.) Its 68 % interval covering the truth in at least 9 of 20 (13.6
/// expected; 8 or fewer has a probability under 1 %), fixed before the interval's first run.
#[test]
#[ignore]
fn survey_oscillation_and_floor_over_seeds() {
    survey_floor(3101..=3120);
}

/// The same on seeds the floor's rule was not worked out on (3121-3140; thresholds those of
/// the survey above, fixed before this survey's first run).
#[test]
#[ignore]
fn survey_oscillation_and_floor_over_fresh_seeds() {
    survey_floor(3121..=3140);
}

/// 20 poses of 5 s over seeds 3201-3250: the bias instability and the walk are never called
/// determined (the rule the single seed above checks, counted).
#[test]
fn short_poses_never_determine_the_slow_terms() {
    let pose = 500;
    let mut determined = Vec::new();
    for seed in 3201..=3250u64 {
        let rate = simulate(20 * 1500, seed);
        let increments: Vec<f64> = rate.iter().map(|w| w * DT).collect();
        let intervals: Vec<Range<usize>> = (0..20).map(|i| i * 1500..i * 1500 + pose).collect();
        let (ml, axis) = analyse(&increments, &intervals);
        let slow = slow_terms(&axis.curve, &ml);
        if slow.walk || slow.bias_instability {
            determined.push((seed, slow.walk, slow.bias_instability));
        }
    }
    assert!(
        determined.is_empty(),
        "(seed, walk, bias instability) determined from 5-s poses: {determined:?}"
    );
}

/// `records` rate samples (rad/s) at 100 Hz of white noise (the same level as above) and a bias
/// random walk that dominates it from 300 s on: a bowl, no floor.
fn simulate_white_and_walk(records: usize, seed: u64) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
    let white = WHITE_DEG_H * DEG_H;
    // sqrt(3) N / K = 300 s.
    let walk = 3f64.sqrt() * white / 300.0;
    let mut bias = 0.0;
    (0..records)
        .map(|_| {
            bias += walk * DT.sqrt() * normal();
            white / DT.sqrt() * normal() + bias
        })
        .collect()
}

/// Floors found on white noise and a walk over 4 h, seeds 3301-3320 (a survey, about a
/// minute). Threshold fixed before the first run: at most 1 of 20. The same recordings'
/// walks denied by their curves (`floor::walk_contradicted`, a 1 % test): at most 1 of 20,
/// fixed before its first run (session 24).
#[test]
#[ignore]
fn survey_no_floor_from_white_noise_and_a_walk() {
    no_floor_from_white_noise_and_a_walk(3301..=3320);
}

/// The same on seeds 3321-3340, fresh for the floor's rule of session 25 (thresholds those
/// above, fixed before its first run).
#[test]
#[ignore]
fn survey_no_floor_from_white_noise_and_a_walk_fresh_seeds() {
    no_floor_from_white_noise_and_a_walk(3321..=3340);
}

#[allow(clippy::single_range_in_vec_init)] // one interval: the whole recording
fn no_floor_from_white_noise_and_a_walk(seeds: std::ops::RangeInclusive<u64>) {
    let records = 1_440_000;
    let mut floors = Vec::new();
    let mut denied = Vec::new();
    for seed in seeds {
        let increments: Vec<f64> = simulate_white_and_walk(records, seed)
            .iter()
            .map(|w| w * DT)
            .collect();
        let intervals = [0..records];
        let (ml, axis) = analyse(&increments, &intervals);
        if let Some(f) = flicker_floor(&axis.curve, axis.fit.tau_min_s, ml.white.value) {
            println!(
                "seed {seed}: a floor {:.1} deg/h from {:.1} s",
                f.value / DEG_H,
                f.from_tau_s
            );
            floors.push(seed);
        }
        let slow = slow_terms(&axis.curve, &ml);
        if let Some(at) = slow.walk_contradicted_at {
            println!("seed {seed}: the walk denied at {at:?} ({slow:?})");
            denied.push(seed);
        }
    }
    println!("floors on white noise and a walk: {}/20", floors.len());
    println!("walks denied by their curve: {}/20", denied.len());
    assert!(floors.len() <= 1, "{floors:?}");
    assert!(denied.len() <= 1, "{denied:?}");
}

/// White noise (139 deg/h) and a Gauss-Markov bias alone (correlation times 10, 30, 100 and
/// 300 s, 60 to 25 deg/h), 2.8 h, five seeds each (5101-5105): its bump is no floor. The rule
/// against the bump was added after four such recordings of each kind (seeds 5001-5005) gave a
/// "floor" on 16 of 20 with the flat shape against the walk's alone, and 1 of 20 with it; this
/// survey's seeds and its threshold (at most 2 of 20) were fixed before its first run.
#[test]
#[ignore]
#[allow(clippy::single_range_in_vec_init)] // one interval: the whole recording
fn survey_no_floor_from_a_gauss_markov_bias() {
    let mut floors = Vec::new();
    for (tc, sigma_deg_h) in [(10.0, 60.0), (30.0, 40.0), (100.0, 30.0), (300.0, 25.0)] {
        for seed in 5101..=5105u64 {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
            let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
            let white_sd = WHITE_DEG_H * DEG_H / DT.sqrt();
            let sigma = sigma_deg_h * DEG_H;
            let phi: f64 = (-DT / tc).exp();
            let mut bias = sigma * normal();
            let records = 1_008_000;
            let increments: Vec<f64> = (0..records)
                .map(|_| {
                    bias = phi * bias + sigma * (1.0 - phi * phi).sqrt() * normal();
                    (white_sd * normal() + bias) * DT
                })
                .collect();
            let intervals = [0..records];
            let (ml, axis) = analyse(&increments, &intervals);
            if let Some(f) = flicker_floor(&axis.curve, axis.fit.tau_min_s, ml.white.value) {
                println!(
                    "tc {tc} s, seed {seed}: a floor {:.1} deg/h (ln ratio over the bump {:.1})",
                    f.value / DEG_H,
                    f.ln_lr_over_gauss_markov
                );
                floors.push((tc, seed));
            }
        }
    }
    println!("floors on a Gauss-Markov bias alone: {}/20", floors.len());
    assert!(floors.len() <= 2, "{floors:?}");
}

/// The walk (rad/s/sqrt(s)) whose Allan deviation `K sqrt(tau / 3)` meets the floor's
/// `0.664 B` at `tau_s`.
fn walk_meeting_the_floor_at(tau_s: f64) -> f64 {
    FLICKER_ADEV * INSTABILITY_DEG_H * DEG_H / (tau_s / 3.0).sqrt()
}

/// The 2.8-h gyro of [`simulate`] with a bias random walk that meets its floor at `meet_s` (a
/// MEMS bowl: white noise to about 60 s, the floor, the walk rising from there), the walk drawn
/// from its own stream of the seed.
fn simulate_floor_and_walk(records: usize, seed: u64, meet_s: f64) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5eed_0000_0000);
    let mut normal = || -> f64 { StandardNormal.sample(&mut rng) };
    let k = walk_meeting_the_floor_at(meet_s);
    let mut bias = 0.0;
    simulate(records, seed)
        .into_iter()
        .map(|w| {
            bias += k * DT.sqrt() * normal();
            w + bias
        })
        .collect()
}

/// What [`floor_and_walk_survey`] counts over its seeds.
#[derive(Debug, Default)]
struct FloorWalkCounts {
    /// The floor's bias instability determined and within 30 % of the truth.
    floor_ok: usize,
    /// The likelihood's walk over the truth, sorted.
    likelihood_walks: Vec<f64>,
    /// The walk reported (the one fitted with the floor where there is a floor, else the
    /// likelihood's) determined as a value (not a bound).
    determined: usize,
    /// Of those, its 68 % interval covering the truth.
    covered: usize,
    /// Seeds where it is determined with the truth outside its interval by more than 1.5.
    wrong: Vec<u64>,
}

/// The 2.8-h gyro with a walk meeting its floor at `meet_s` over `seeds`, counted.
#[allow(clippy::single_range_in_vec_init)] // one interval: the whole recording
fn floor_and_walk_survey(seeds: std::ops::RangeInclusive<u64>, meet_s: f64) -> FloorWalkCounts {
    let truth_b = flicker_adev_unit(1000.0) * gm_sigma() / FLICKER_ADEV / DEG_H;
    let truth_k = walk_meeting_the_floor_at(meet_s) / DEG_H * 60.0;
    let k = |x: f64| x / DEG_H * 60.0;
    let mut c = FloorWalkCounts::default();
    for seed in seeds {
        let records = 1_008_000;
        let increments: Vec<f64> = simulate_floor_and_walk(records, seed, meet_s)
            .iter()
            .map(|w| w * DT)
            .collect();
        let intervals = [0..records];
        let (ml, axis) = analyse(&increments, &intervals);
        let floor = flicker_floor(&axis.curve, axis.fit.tau_min_s, ml.white.value);
        let slow = slow_terms(&axis.curve, &ml);
        println!(
            "seed {seed}: floor {:.1?} deg/h (truth {truth_b:.1}), determined {}; likelihood \
             walk {:.2} [{:.2}, {:.2}] deg/h/sqrt(h) (truth {truth_k:.2})",
            floor
                .as_ref()
                .map(|f| (f.value / DEG_H, f.from_tau_s, f.to_tau_s)),
            slow.bias_instability,
            k(ml.walk.value),
            k(ml.walk.lower),
            k(ml.walk.upper),
        );
        c.floor_ok += usize::from(
            slow.bias_instability
                && floor.is_some_and(|f| (f.value / DEG_H / truth_b - 1.0).abs() < 0.30),
        );
        c.likelihood_walks.push(k(ml.walk.value) / truth_k);
        let (v, lo, hi) = match &slow.walk_beyond_floor {
            Some(w) => (w.value, w.lower, w.upper),
            None => (ml.walk.value, ml.walk.lower, ml.walk.upper),
        };
        println!(
            "  reported walk ({}): {:.2} [{:.2}, {:.2}] deg/h/sqrt(h), crossover {:.0} s, \
             determined {}, bound {}",
            if slow.walk_beyond_floor.is_some() {
                "with the floor"
            } else {
                "the likelihood's"
            },
            k(v),
            k(lo),
            k(hi),
            slow.walk_crossover_s,
            slow.walk,
            slow.walk_bound
        );
        if slow.walk && !slow.walk_bound {
            c.determined += 1;
            c.covered += usize::from(k(lo) <= truth_k && truth_k <= k(hi));
            if k(lo) > 1.5 * truth_k || k(hi) < truth_k / 1.5 {
                c.wrong.push(seed);
            }
        }
    }
    c.likelihood_walks.sort_by(f64::total_cmp);
    println!("{c:?}");
    c
}

/// A floor with a walk after it, seeds 3401-3420 (a survey, about a minute): the floor's bias
/// instability within 30 % of the truth in at least 18 of 20, the threshold of the floor's
/// other surveys, fixed with these seeds before the first run (19 of 20). That run found the
/// likelihood's walk (a white-and-walk model, which has no floor) 0.74 to 3.83 times the truth,
/// median 1.85, called determined with intervals that mostly excluded it; the walk is now
/// fitted with the floor (`floor::walk_beyond_floor`). Threshold fixed before its first run: a
/// walk called determined as a value whose 68 % interval misses the truth by more than a
/// factor 1.5 in at most 1 of 20 (none: 18 of 19 are bounds covering it).
#[test]
#[ignore]
fn survey_floor_followed_by_a_walk() {
    let c = floor_and_walk_survey(3401..=3420, 2000.0);
    assert!(
        c.floor_ok >= 18,
        "floor within 30 % in {} of 20",
        c.floor_ok
    );
    assert!(c.wrong.len() <= 1, "{:?}", c.wrong);
}

/// The same gyro with a walk meeting the floor at 250 s, which the 2.8-h curve (to 2600 s)
/// shows over more than two octaves: the walk is to be told as a value. Seeds 3421-3440 and
/// thresholds fixed before the first run: the reported walk determined as a value in at least
/// 15 of 20, its 68 % interval covering the truth in at least 14 of those 20 runs (13.6 of 20
/// expected of an exact interval; the floor's convention is conservative), and determined with
/// the truth outside by more than a factor 1.5 in at most 1. The floor is printed, not tested
/// (it dominates two octaves at most here). The first run failed: covering in 13 of 20, the
/// misses the 5 runs where the floor was not found and the likelihood's walk (no floor in its
/// model) came out 1.25 to 1.67 times the truth with intervals excluding it. The walk is now
/// fitted with a flat excess under it wherever the curve shows one (`floor::floor_under_walk`):
/// 17 of 20 on these seeds, checked on fresh ones below.
#[test]
#[ignore]
fn survey_floor_and_an_early_walk() {
    early_walk(3421..=3440);
}

/// The survey above on seeds 3441-3460, fresh for `floor::floor_under_walk` (its thresholds,
/// fixed before this survey's first run).
#[test]
#[ignore]
fn survey_floor_and_an_early_walk_fresh_seeds() {
    early_walk(3441..=3460);
}

fn early_walk(seeds: std::ops::RangeInclusive<u64>) {
    let c = floor_and_walk_survey(seeds, 250.0);
    assert!(c.determined >= 15, "determined in {} of 20", c.determined);
    assert!(c.covered >= 14, "covering the truth in {} of 20", c.covered);
    assert!(c.wrong.len() <= 1, "{:?}", c.wrong);
}
