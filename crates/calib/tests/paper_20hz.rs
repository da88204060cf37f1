//! The simulated run several tests of this crate estimate from: the paper's program with
//! 20-Hz IMU records and 10-Hz angles (a fifth of the 100-Hz run's steps), the attitude prior
//! tied to the installation.

use calib::config::{AttitudePrior, RunConfig};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;

/// The configuration and the simulated records for `seed`.
pub fn paper_20hz_run(seed: u64) -> (RunConfig, ImuData, TurntableData) {
    let mut c = RunConfig::paper();
    c.filter.attitude_prior = AttitudePrior::Installation;
    c.priors.initial_tilt_deg = 0.01;
    c.priors.initial_heading_deg = 0.01;
    c.truth.imu_rate_hz = 20.0;
    c.filter.imu_rate_hz = 20.0;
    c.truth.turntable_rate_hz = 10.0;
    c.truth.seed = seed;
    let sim = simulate_run(&c, "test").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    (c, imu, tt)
}
