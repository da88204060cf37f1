//! The whole calibration of the paper's 45-minute program from 100 Hz raw data: reading the
//! two CSV files, and the estimation itself (strapdown, measurement windows, filter).
//!
//! `cargo bench -p calib --bench calibration`

use calib::config::{AttitudePrior, RunConfig};
use calib::estimate::{Plan, Records, RunData, run};
use calib::io::{
    ImuData, TurntableData, format_imu_csv, format_turntable_csv, parse_imu_csv,
    parse_turntable_csv,
};
use calib::simulate::simulate_run;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn config() -> RunConfig {
    let mut c = RunConfig::paper();
    c.filter.attitude_prior = AttitudePrior::Installation;
    c.priors.initial_tilt_deg = 0.01;
    c.priors.initial_heading_deg = 0.01;
    c.clock.turntable_offset_s = 12.5;
    c.clock.turntable_rate_error = 2e-4;
    c.truth.turntable_rate_hz = 100.0;
    c
}

fn bench(c: &mut Criterion) {
    let config = config();
    let sim = simulate_run(&config, "bench").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let imu_text = format_imu_csv(&imu, "imu.csv").unwrap();
    let tt_text = format_turntable_csv(&tt);
    let mut g = c.benchmark_group("calibration_45min_100Hz");
    g.sample_size(10);
    g.bench_function("parse_csv", |b| {
        b.iter(|| {
            let i = parse_imu_csv(black_box(&imu_text), "imu.csv").unwrap();
            let t = parse_turntable_csv(black_box(&tt_text), "turntable.csv").unwrap();
            (i.records.len(), t.records.len())
        })
    });
    for (label, with_tt) in [("estimate_28_states", true), ("estimate_24_states", false)] {
        g.bench_function(label, |b| {
            b.iter(|| {
                let data = RunData {
                    imu: &imu,
                    imu_file: "imu.csv",
                    turntable: with_tt.then_some((&tt, "turntable.csv").into()),
                };
                run(
                    Plan::fit_only(&config),
                    Records::Held(*black_box(&data)),
                    &mut |_, _| {},
                )
                .unwrap()
                .estimate
                .values[3]
            })
        });
    }
    g.bench_function("covariance_analysis_28_states", |b| {
        b.iter(|| {
            calib::estimate::covariance::covariance_analysis(black_box(&config), true)
                .unwrap()
                .cov[(3, 3)]
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
