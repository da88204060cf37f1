//! The integration tests of this crate in one test binary (one link, and the tests of all
//! files run in parallel): each file of this directory is a module. Run one file's tests with
//! `cargo test --release -p calib --test integration <file>::`.

mod angle_streaming;
mod arbitrary_input;
mod bias_walk;
mod candidates;
mod candidates_table;
mod correction;
mod diagnostics;
mod dispatch;
mod io;
mod jacobians;
mod paper_20hz;
mod shared_records_nis;
