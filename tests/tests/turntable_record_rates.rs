//! Turntable angle records at low rates: the angles are interpolated onto the IMU time line
//! (linear between records, which is exact while the platform rate is constant), and only the
//! samples whose interpolation span straddles a change of the platform rate are left out. At
//! 1 Hz that is about one second around each of the paper program's rate changes, so almost
//! every sample is used and the calibration stays consistent.
//!
//! CI: one run per record rate (1, 2, 10 and 50 Hz; seed 1 of [`simulated_run_config`]);
//! `--ignored`: 10 runs per rate (seeds 200-209, fixed in advance) with the NEES and bias
//! checks of [`MonteCarlo::check`].

use calib::estimate::{Plan, Records, RunData, run};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;
use workspace_tests::{MonteCarlo, simulated_run_config};

const RATES_HZ: [f64; 4] = [1.0, 2.0, 10.0, 50.0];

fn runs(rate_hz: f64, seeds: std::ops::RangeInclusive<u64>) -> MonteCarlo {
    let mut mc = MonteCarlo::default();
    for seed in seeds {
        let mut config = simulated_run_config();
        config.truth.seed = seed;
        config.truth.turntable_rate_hz = rate_hz;
        let sim = simulate_run(&config, "rates").unwrap();
        let imu = ImuData::from_samples(&sim.imu);
        let tt = TurntableData::from_samples(&sim.turntable);
        let data = RunData {
            imu: &imu,
            imu_file: "imu.csv",
            turntable: Some((&tt, "turntable.csv").into()),
        };
        let est = run(Plan::fit_only(&config), Records::Held(data), &mut |_, _| {})
            .map(|c| c.estimate)
            .unwrap();
        let s = &est.stats;
        let total = s.turntable_samples + s.turntable_samples_near_rate_changes;
        let left_out = s.turntable_samples_near_rate_changes as f64 / total as f64;
        println!(
            "{rate_hz} Hz, seed {seed}: {} of {total} samples used ({:.2} % left out near rate \
             changes), {} updates, turntable mean NIS {:.3}, accel mean NIS {:.3}",
            s.turntable_samples,
            100.0 * left_out,
            s.turntable_updates,
            s.turntable_mean_nis,
            s.accel_mean_nis
        );
        // The paper's program has 20 changes of rate; at 1 Hz each costs about 1-2 s of samples.
        assert!(
            left_out < 0.02,
            "{rate_hz} Hz: {:.2} % left out",
            100.0 * left_out
        );
        assert!(s.turntable_updates >= 2700, "{rate_hz} Hz: {s:?}");
        // 2727 updates of 3 degrees of freedom: the mean NIS has a standard error of 0.05.
        assert!(
            (s.turntable_mean_nis - 3.0).abs() < 0.2,
            "{rate_hz} Hz: {s:?}"
        );
        mc.add(&config, &sim, &est);
    }
    mc
}

#[test]
fn every_record_rate_keeps_its_samples_and_fits() {
    for rate in RATES_HZ {
        let mc = runs(rate, 1..=1);
        // One run: its NEES against the 99.9 % quantile of chi-square with 28 dof (56.9).
        assert!(mc.nees[0] < 56.9, "{rate} Hz: NEES {:.1}", mc.nees[0]);
    }
}

#[test]
#[ignore = "10 runs per rate, about two minutes in release"]
fn every_record_rate_is_consistent_over_ten_seeds() {
    let failures: Vec<String> = RATES_HZ
        .iter()
        .flat_map(|&rate| runs(rate, 200..=209).check(&format!("{rate} Hz records")))
        .collect();
    assert!(failures.is_empty(), "{failures:?}");
}
