//! A turntable run calibrated without a program in the configuration: the program read from
//! the angle records (`calib::motion::angles_program`) matches the one the turntable ran, and the
//! calibration with it matches the calibration with the true program.

use calib::config::PROGRAM_FROM_ANGLES;
use calib::estimate::{Plan, Records, RunData, run};
use calib::io::{ImuData, TurntableData};
use calib::motion::angles_program::program_from_angles;
use turntable::program::Program;
use workspace_tests::simulated_run_config;

#[test]
fn the_program_read_from_the_angles_is_the_one_run() {
    let mut config = simulated_run_config();
    config.filter.imu_rate_hz = 25.0;
    config.truth.imu_rate_hz = 25.0;
    let sim = calib::simulate::simulate_run(&config, "test").unwrap();
    let tt = TurntableData::from_samples(&sim.turntable);
    let spec = program_from_angles((&tt, "turntable.csv").into(), &config.clock, None).unwrap();
    let read = Program::compile(&spec, "read").unwrap();
    let paper = Program::paper();
    let (a, b) = (read.pieces(), paper.pieces());
    assert_eq!(a.len(), b.len(), "{spec:#?}");
    // The records start at the program's start (plus the delay, 20 ms in this run, and the
    // first record's place on its grid).
    let shift = a[0].t1 - b[0].t1;
    assert!(shift.abs() < 0.1, "shift {shift}");
    // Every piece's rates, and every boundary (the last piece ends with the records, not with
    // the program).
    for (i, (p, q)) in a.iter().zip(b).enumerate() {
        for g in 0..3 {
            assert!(
                (p.rate[g] - q.rate[g]).abs() < 0.002f64.to_radians(),
                "rate {:?} against {:?}",
                p.rate,
                q.rate
            );
        }
        if i + 1 < b.len() {
            assert!(
                (p.t1 - shift - q.t1).abs() < 0.01,
                "end {} against {}",
                p.t1 - shift,
                q.t1
            );
        }
    }
    // Calibrated with the program read from the angles, the estimates are those with the
    // program given (to a small fraction of their sigma).
    let imu = ImuData::from_samples(&sim.imu);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "turntable.csv").into()),
    };
    let given = run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .unwrap();
    let mut from_angles = config.clone();
    from_angles.program = PROGRAM_FROM_ANGLES.into();
    let read = run(
        Plan::fit_only(&from_angles),
        Records::Held(data),
        &mut |_, _| {},
    )
    .map(|c| c.estimate)
    .unwrap();
    let worst = (3..given.names.len())
        .map(|i| (read.values[i] - given.values[i]).abs() / given.cov[(i, i)].sqrt())
        .fold(0.0, f64::max);
    println!("largest difference {worst:.4} sigma");
    println!(
        "program start {:.5} s (given) / {:.5} s (read); turntable mean NIS {:.4} / {:.4}",
        given.program_start_s,
        read.program_start_s,
        given.stats.turntable_mean_nis,
        read.stats.turntable_mean_nis
    );
    assert!(worst < 0.1, "largest difference {worst} sigma");
    // Without a turntable file there is nothing to read the program from: a clear refusal.
    let imu_only = RunData {
        turntable: None,
        ..data
    };
    let e = run(
        Plan::fit_only(&from_angles),
        Records::Held(imu_only),
        &mut |_, _| {},
    )
    .map(|c| c.estimate)
    .unwrap_err()
    .to_string();
    assert!(e.contains("turntable"), "{e}");
}
