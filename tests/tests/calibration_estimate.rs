//! Calibration from raw data, one simulated run: recovery of the turntable terms, agreement of
//! the reported sigma with the covariance analysis, the IMU-only case, refused input.

use calib::estimate::covariance::{covariance_analysis_with, layout_for};
use calib::estimate::{Plan, Records, RunData, run};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;
use nalgebra::Vector3;
use turntable::kinematics::Mounting;
use turntable::simulate::Simulation;
use workspace_tests::simulated_run_config;

fn mounting(sim: &Simulation) -> Mounting {
    let d = |a: &str| sim.truth.get(&format!("install.delta.{a}")).unwrap();
    Mounting {
        delta_z: Vector3::new(d("x"), d("y"), d("z")),
        gamma_p: Vector3::zeros(),
    }
}

#[test]
fn delay_and_installation_are_recovered_and_sigma_matches_the_covariance_analysis() {
    let config = simulated_run_config();
    let sim = simulate_run(&config, "test").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    for with_tt in [true, false] {
        let data = RunData {
            imu: &imu,
            imu_file: "imu.csv",
            turntable: with_tt.then_some((&tt, "turntable.csv").into()),
        };
        let est = run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
            .map(|c| c.estimate)
            .unwrap();
        assert_eq!(est.names.len(), if with_tt { 28 } else { 24 });
        if with_tt {
            for name in [
                "turntable.tau",
                "install.delta.x",
                "install.delta.y",
                "install.delta.z",
            ] {
                let (v, s, t) = (
                    est.value(name).unwrap(),
                    est.sigma(name).unwrap(),
                    sim.truth.get(name).unwrap(),
                );
                assert!(
                    (v - t).abs() < 3.0 * s,
                    "{name}: {v} vs truth {t}, sigma {s}"
                );
                assert!(
                    s < 0.01 * est.prior_sigma[est.names.iter().position(|n| n == name).unwrap()]
                );
            }
            assert!(est.stats.turntable_samples > 250_000, "{:?}", est.stats);
        }
        // The same model and code without data, about the true mounting.
        let layout = layout_for(&config, with_tt);
        let analysis = covariance_analysis_with(&config, &layout, &mounting(&sim)).unwrap();
        for (i, name) in est.names.iter().enumerate().skip(3) {
            let ratio = est.cov[(i, i)].sqrt() / analysis.sigma(name).unwrap();
            assert!(
                (0.9..=1.1).contains(&ratio),
                "{name} ({} states): estimation sigma / analysis sigma = {ratio:.3}",
                est.names.len()
            );
        }
        // The model fits: mean NIS near 3 (2727 updates: standard error 0.05).
        assert!(
            (est.stats.accel_mean_nis - 3.0).abs() < 0.3,
            "{:?}",
            est.stats
        );
        if with_tt {
            assert!(
                (est.stats.turntable_mean_nis - 3.0).abs() < 0.3,
                "{:?}",
                est.stats
            );
        }
    }
}

#[test]
fn a_turntable_file_outside_the_imu_run_is_refused_by_name() {
    let mut config = simulated_run_config();
    config.truth.duration_s = Some(20.0);
    let sim = simulate_run(&config, "test").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    // Told the wrong clock, the turntable data lie an hour after the IMU data.
    config.clock.turntable_offset_s -= 3600.0;
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "rec/turntable.csv").into()),
    };
    let e = run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("rec/turntable.csv") && e.contains("overlap"),
        "{e}"
    );
}

#[test]
fn imu_records_at_another_rate_are_refused_with_the_line() {
    let mut config = simulated_run_config();
    config.truth.duration_s = Some(5.0);
    let sim = simulate_run(&config, "test").unwrap();
    let mut imu = ImuData::from_samples(&sim.imu);
    // A gap: record 100 missing.
    imu.records.remove(100);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: None,
    };
    let e = run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .unwrap_err()
        .to_string();
    assert!(e.contains("imu.csv") && e.contains("line 102"), "{e}");
}
