//! The IMU steps of an estimation are compiled for several instruction sets and the processor
//! picks one at run time (`calib::estimate`, `Steps`): every path must give the same bits. On a
//! processor with AVX2 this compares the AVX2 path with the baseline one; on one without, the
//! baseline with itself. (Other tests of this binary may run their estimations on the baseline
//! path meanwhile: the same bits, only slower.)

use crate::paper_20hz::paper_20hz_run;
use calib::estimate::{Plan, Records, RunData, force_baseline_instructions, run};

#[test]
fn every_instruction_set_gives_the_same_estimates() {
    let (c, imu, tt) = paper_20hz_run(3);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "turntable.csv").into()),
    };
    let run = |baseline: bool| {
        force_baseline_instructions(baseline);
        let est = run(Plan::fit_only(&c), Records::Held(data), &mut |_, _| {})
            .map(|c| c.estimate)
            .unwrap();
        force_baseline_instructions(false);
        est
    };
    let (best, baseline) = (run(false), run(true));
    assert_eq!(best.values.len(), 28);
    assert_eq!(best.values, baseline.values);
    assert_eq!(best.cov, baseline.cov);
    assert_eq!(best.stats.passes, baseline.stats.passes);
}
