//! The angle records of a calibration streamed from their file (`calib::io::angle_records`): the
//! same estimates, covariance and statistics, bit for bit, as with the records in memory, with
//! the program given and with the program read from the angles.

use crate::paper_20hz::paper_20hz_run;
use calib::config::PROGRAM_FROM_ANGLES;
use calib::estimate::{Plan, Records, RunData, run};
use calib::io::angle_records::AngleFile;
use calib::io::write_turntable_csv;

#[test]
fn streamed_angle_records_give_the_estimates_of_records_in_memory() {
    let (c, imu, tt) = paper_20hz_run(4);
    let dir = std::env::temp_dir().join(format!("angle-streaming-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("turntable.csv");
    write_turntable_csv(&path, &tt).unwrap();
    // The file as written parses back to the same records (shortest round-trip numbers).
    let cached = AngleFile::open(&path).unwrap();
    // A cache of 1000 records: the file's 27 000 are read again at every pass.
    let streamed = AngleFile::open_with_cache(&path, 1000).unwrap();
    assert!(cached.is_cached() && !streamed.is_cached());
    let mut from_angles = c.clone();
    from_angles.program = PROGRAM_FROM_ANGLES.into();
    for config in [&c, &from_angles] {
        let run = |turntable| {
            let data = RunData {
                imu: &imu,
                imu_file: "imu.csv",
                turntable: Some(turntable),
            };
            run(Plan::fit_only(config), Records::Held(data), &mut |_, _| {})
                .map(|c| c.estimate)
                .unwrap()
        };
        let memory = run((&tt, "turntable.csv").into());
        assert_eq!(memory.values.len(), 28);
        for file in [&cached, &streamed] {
            let est = run(file.records());
            assert_eq!(est.values, memory.values, "{}", config.program);
            assert_eq!(est.cov, memory.cov);
            assert_eq!(est.stats, memory.stats);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
