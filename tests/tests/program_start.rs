//! The program on the IMU time line (issue: "the start of the program on the IMU time line"):
//! recordings whose IMU clock does not read zero at the program's start calibrate as well as the
//! one that does, and say where the program starts; a wrong given start and data that follow no
//! program are refused with the cause named.

use calib::estimate::{self, Estimate, EstimateError, Plan, Records, RunData};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;
use workspace_tests::simulated_run_config;

/// The simulated run with its IMU clock reading `offset` at the program's start (the turntable
/// clock relation follows, so that the same angles fall at the same instants).
fn shifted(
    imu: &ImuData,
    config: &calib::config::RunConfig,
    offset: f64,
) -> (ImuData, calib::config::RunConfig) {
    let mut data = imu.clone();
    for r in &mut data.records {
        r.t += offset;
    }
    let mut c = config.clone();
    c.clock.turntable_offset_s -= (1.0 + c.clock.turntable_rate_error) * offset;
    (data, c)
}

fn run(imu: &ImuData, tt: &TurntableData, config: &calib::config::RunConfig) -> Estimate {
    let data = RunData {
        imu,
        imu_file: "imu.csv",
        turntable: Some((tt, "turntable.csv").into()),
    };
    estimate::run(Plan::fit_only(config), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .expect("calibrates")
}

#[test]
fn runs_whose_clock_starts_anywhere_calibrate_alike_and_report_the_start() {
    let config = simulated_run_config();
    let sim = simulate_run(&config, "test").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let base = run(&imu, &tt, &config);
    assert!(base.program_start_found);
    assert!(
        base.program_start_s.abs() < 1e-4,
        "{}",
        base.program_start_s
    );
    for offset in [0.3, 1000.0, -50.0] {
        let (data, c) = shifted(&imu, &config, offset);
        let est = run(&data, &tt, &c);
        // Found to well within a millisecond (the issue asks for 1 ms).
        assert!(
            (est.program_start_s - offset).abs() < 1e-4,
            "offset {offset}: start found at {}",
            est.program_start_s
        );
        // The same estimates: the two runs differ only by the clock's reading.
        for (i, name) in est.names.iter().enumerate().skip(3) {
            let d = (est.values[i] - base.values[i]).abs() / base.cov[(i, i)].sqrt();
            assert!(d < 0.01, "offset {offset}: {name} moved by {d} sigma");
        }
    }
}

#[test]
fn a_wrong_given_start_and_data_of_another_program_are_refused() {
    let mut config = simulated_run_config();
    config.truth.duration_s = None;
    let sim = simulate_run(&config, "test").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: None,
    };
    // A start 1 s late: the rate changes in the data say otherwise.
    let mut late = config.clone();
    late.filter.program_start_s = Some(1.0);
    match estimate::run(Plan::fit_only(&late), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
    {
        Err(e @ EstimateError::ProgramStart { .. }) => {
            let msg = e.to_string();
            assert!(msg.starts_with("imu.csv: "), "{msg}");
            assert!(msg.contains("--program-start"), "{msg}");
        }
        other => panic!("expected a refusal, got {:?}", other.map(|e| e.values)),
    }
    // Rates in deg/s under a rad/s header: no start fits, and the message names the units.
    let mut degrees = imu.clone();
    for r in &mut degrees.records {
        for g in &mut r.gyro {
            *g = g.to_degrees();
        }
    }
    let data = RunData {
        imu: &degrees,
        imu_file: "imu.csv",
        turntable: None,
    };
    match estimate::run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
    {
        Err(e @ EstimateError::ProgramStart { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("deg/s given as rad/s"), "{msg}");
        }
        other => panic!("expected a refusal, got {:?}", other.map(|e| e.values)),
    }
}
