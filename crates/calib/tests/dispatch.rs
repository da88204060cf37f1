//! The IMU steps of an estimation are compiled for several instruction sets and the processor
//! picks one at run time (`calib::estimate`, `Steps`): every path must give the same bits. On a
//! processor with AVX2 this compares the AVX2 path with the baseline one; on one without, the
//! baseline with itself. (Other tests of this binary may run their estimations on the baseline
//! path meanwhile: the same bits, only slower.)

use calib::config::{AttitudePrior, RunConfig};
use calib::estimate::{RunData, estimate, force_baseline_instructions};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;

#[test]
fn every_instruction_set_gives_the_same_estimates() {
    let mut c = RunConfig::paper();
    c.filter.attitude_prior = AttitudePrior::Installation;
    c.priors.initial_tilt_deg = 0.01;
    c.priors.initial_heading_deg = 0.01;
    c.truth.imu_rate_hz = 20.0;
    c.filter.imu_rate_hz = 20.0;
    c.truth.turntable_rate_hz = 10.0;
    c.truth.seed = 3;
    let sim = simulate_run(&c, "test").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "turntable.csv")),
    };
    let run = |baseline: bool| {
        force_baseline_instructions(baseline);
        let est = estimate(&c, &data, &mut |_, _| {}).unwrap();
        force_baseline_instructions(false);
        est
    };
    let (best, baseline) = (run(false), run(true));
    assert_eq!(best.values.len(), 28);
    assert_eq!(best.values, baseline.values);
    assert_eq!(best.cov, baseline.cov);
    assert_eq!(best.stats.passes, baseline.stats.passes);
}
