//! Monte-Carlo check of the calibration from raw data: simulated runs with the truth drawn from
//! the priors (the run of [`simulated_run_config`]: turntable clock 12.5 s ahead and 2e-4 fast,
//! angles at 50 Hz against the IMU's 100 Hz), each calibrated with both models (28 states with
//! the turntable angles, 24 from the IMU alone), and the errors compared with the reported sigma.
//!
//! The seed sets and the checks were fixed before the runs were looked at: seeds 1-10 in CI
//! (`monte_carlo_10_seeds`), seeds 100-149 behind `--ignored` (`monte_carlo_50_seeds`,
//! `cargo test --release -p workspace-tests --test integration calibration_monte_carlo:: -- --ignored`). For
//! each model: the NEES summed over the runs inside the two-sided 95 % band of its chi-square
//! distribution, and no state's mean normalised error beyond the Bonferroni bound for the number
//! of states at a family-wise 5 % ([`workspace_tests::MonteCarlo::check`]).

use workspace_tests::{monte_carlo_both_models, simulated_run_config};

fn run(seeds: std::ops::RangeInclusive<u64>) {
    let config = |seed| {
        let mut c = simulated_run_config();
        c.truth.seed = seed;
        c
    };
    monte_carlo_both_models("paper's program", seeds, config, |_, _| {});
}

#[test]
fn monte_carlo_10_seeds() {
    run(1..=10);
}

#[test]
#[ignore = "50 seeds x 2 models, about half a minute in release on 2 cores"]
fn monte_carlo_50_seeds() {
    run(100..=149);
}
