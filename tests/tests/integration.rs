//! The integration tests of this crate in one test binary (one link, and the tests of all
//! files run in parallel): each file of this directory is a module. Run one file's tests with
//! `cargo test --release -p workspace-tests --test integration <file>::`.

mod baseline;
mod bias_walk_monte_carlo;
mod calibration_estimate;
mod calibration_monte_carlo;
mod hand_turned;
mod hidden_effects;
mod noiseless;
mod operating;
mod program_from_angles;
mod program_start;
mod residual_trend;
mod rests;
mod rests_loop;
mod static_runs;
mod turntable_record_rates;
mod verdict_cases;
