//! The integration tests of this crate in one test binary (one link, and the tests of all
//! files run in parallel): each file of this directory is a module. Run one file's tests with
//! `cargo test --release -p sins-calib --test integration <file>::`.

mod apply;
mod arbitrary_input;
mod cli;
mod cli_options;
mod common;
mod diagnose;
mod export;
mod free_motion;
mod import;
mod import_bag;
mod json_outputs;
mod navigation;
mod noise;
mod outputs;
mod readers;
mod refusals;
mod report;
mod rests;
mod robust;
