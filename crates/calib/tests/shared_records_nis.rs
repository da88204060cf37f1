//! The turntable mean NIS against what it averages when the model fits.
//!
//! An angle record interpolated into two windows correlates their measurements; each window's
//! `R` carries that covariance with the window before (so that the `R`s of a run add up to the
//! variance of the sum of its measurements: what the parameters need). The innovation's own
//! scatter does not hold it, so the NIS averages `3 - tr(S^-1 R_shared)`, not 3
//! (`FitStatistics::turntable_expected_nis`), and the verdict's band is about that value.
//!
//! With 50-Hz angles and 1-s windows the shortfall is about 1 % (0.026): inside the band of the
//! paper's 45-min program (0.14), but two thirds of the band of a 10-h run (0.039), where a
//! clean run then failed its verdict (the ignored test below). The CI test makes the shortfall
//! large by taking the angles in 0.1-s windows (five records, one shared with the window
//! before): on a clean 900-s run (seed 34) the mean NIS is 2.721 over 8999 updates, expected
//! 2.739, band 0.078: 3.6 bands below 3 (the verdict failed before it was about the expected
//! value), 0.23 bands from the expected value.

use calib::config::{AttitudePrior, RunConfig};
use calib::estimate::verdict::{mean_nis_figures, mean_nis_half_band, misfit_reasons};
use calib::estimate::{self, Estimate, Plan, Records, RunData};
use calib::io::{ImuData, TurntableData};
use calib::simulate::simulate_run;

/// The paper's program as `simulated_run_config` of the workspace tests has it: 100-Hz IMU,
/// 50-Hz angles on a turntable clock 12.5 s ahead running 2e-4 fast, the attitude prior tied to
/// the installation.
fn config(seed: u64) -> RunConfig {
    let mut c = RunConfig::paper();
    c.filter.attitude_prior = AttitudePrior::Installation;
    c.priors.initial_tilt_deg = 0.01;
    c.priors.initial_heading_deg = 0.01;
    c.clock.turntable_offset_s = 12.5;
    c.clock.turntable_rate_error = 2e-4;
    c.truth.imu_rate_hz = 100.0;
    c.truth.turntable_rate_hz = 50.0;
    c.truth.draw_from_priors = true;
    c.truth.seed = seed;
    c
}

fn run(config: &RunConfig) -> Estimate {
    let sim = simulate_run(config, "shared records").unwrap();
    let imu = ImuData::from_samples(&sim.imu);
    let tt = TurntableData::from_samples(&sim.turntable);
    let data = RunData {
        imu: &imu,
        imu_file: "imu.csv",
        turntable: Some((&tt, "turntable.csv").into()),
    };
    estimate::run(Plan::fit_only(config), Records::Held(data), &mut |_, _| {})
        .map(|c| c.estimate)
        .unwrap()
}

#[test]
fn turntable_nis_is_judged_against_its_expected_value() {
    // Seed fixed before the run was looked at; the first 900 s of the program (two cycles).
    let mut c = config(34);
    c.truth.duration_s = Some(900.0);
    c.filter.turntable_rate_hz = 10.0;
    let est = run(&c);
    let s = &est.stats;
    let band = mean_nis_half_band(s.turntable_updates);
    println!(
        "turntable: {} updates, mean NIS {:.4}, expected {:.4}, band {band:.4}; specific force \
         {:.4} over {}",
        s.turntable_updates,
        s.turntable_mean_nis,
        s.turntable_expected_nis,
        s.accel_mean_nis,
        s.accel_updates
    );
    assert!(s.turntable_updates > 8900, "{s:?}");
    // The shortfall is real and large here: well outside a band about 3.
    assert!(
        3.0 - s.turntable_expected_nis > 3.0 * band,
        "expected {:.4}, band {band:.4}",
        s.turntable_expected_nis
    );
    assert!(
        3.0 - s.turntable_mean_nis > 3.0 * band,
        "mean {:.4}, band {band:.4}",
        s.turntable_mean_nis
    );
    // The data agree with the expected value, and the verdict with the data.
    assert!(
        (s.turntable_mean_nis - s.turntable_expected_nis).abs() <= band,
        "mean {:.4} against {:.4} +- {band:.4}",
        s.turntable_mean_nis,
        s.turntable_expected_nis
    );
    let figures = mean_nis_figures(s, true);
    assert!(figures.iter().all(|m| m.consistent()), "{figures:?}");
    let reasons = misfit_reasons(s, None, true);
    assert!(reasons.is_empty(), "{reasons:?}");
}

/// The program of `paper.toml` run `n` times, back to its start position between runs.
fn repeated_paper_program(n: usize) -> String {
    let text = include_str!("../../turntable/programs/paper.toml");
    let first = text
        .find("[[segment]]")
        .expect("the paper's program has segments");
    let (head, segments) = text.split_at(first);
    let back = "[[segment]]\nkind = \"move\"\ntarget_deg = [0.0, 0.0, 0.0]\nrate_deg_s = 10.0\n\n";
    let mut out = head.replace("name = \"paper:", &format!("name = \"paper x{n}:"));
    for i in 0..n {
        if i > 0 {
            out.push_str(back);
        }
        out.push_str(segments);
        out.push('\n');
    }
    out
}

/// A 10-h run: the paper's program 13 times (35 559 s) at the paper's rates, seed 1 (as
/// `examples/run.toml`). Measured (release, about 10 s): turntable mean NIS 2.944 over 35 559
/// updates, expected 2.974, band 0.039 (before the band was about the expected value: exit
/// status 3 at 1.4 bands below 3); specific force 2.996. Seeds 2-5: 2.991, 2.987, 2.975, 2.964.
/// With the shared covariance left out of `R` (a trial build): 2.970 on seed 1.
#[test]
#[ignore = "a 10-h run at 100 Hz: about 10 s in release"]
fn ten_hour_run_of_the_paper_program_fits() {
    let dir = std::env::temp_dir().join(format!("sins-calib-longrun-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("paper13.toml"), repeated_paper_program(13)).unwrap();
    let mut c = config(1);
    c.program = "paper13.toml".into();
    c.base_dir = Some(dir.clone());
    c.truth.values.insert("turntable.tau".into(), 0.02);
    let est = run(&c);
    std::fs::remove_dir_all(&dir).ok();
    let s = &est.stats;
    println!(
        "turntable: {} updates, mean NIS {:.4}, expected {:.4}, band {:.4}; specific force {:.4}",
        s.turntable_updates,
        s.turntable_mean_nis,
        s.turntable_expected_nis,
        mean_nis_half_band(s.turntable_updates),
        s.accel_mean_nis
    );
    assert!(s.turntable_updates > 35_000, "{s:?}");
    let reasons = misfit_reasons(s, None, true);
    assert!(reasons.is_empty(), "{reasons:?}");
}
