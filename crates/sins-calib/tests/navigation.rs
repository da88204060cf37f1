//! The navigation figure of the commands (docs/navsim.md, "What a calibration buys, on every
//! command"): `analyse` reproduces paper-check's two figures; `calibrate`'s figure agrees with
//! the analysis of its configuration; `design` ranks a program without the paper's third cycle
//! below the paper's; a consumer recording's horizon is its grade's; an accepted g-sensitivity
//! has its share in the budget.

use crate::common::{self, run, s, text};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-navigation", name)
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("JSON file")).expect("JSON")
}

fn rho(v: &serde_json::Value) -> f64 {
    v["navigation"]["rho_m"]
        .as_f64()
        .unwrap_or_else(|| panic!("navigation.rho_m in {}", v["navigation"]))
}

/// paper-check's figure: the instrument block (gyro.*, accel.*) of the reconciled
/// configuration's covariance analysis, the default flight and options (xtask's `navigation`).
fn paper_check_rho(with_turntable: bool) -> f64 {
    let config = calib::paper::reconciled();
    let p = calib::estimate::covariance::covariance_analysis(&config, with_turntable).unwrap();
    let idx: Vec<usize> = (0..p.names.len())
        .filter(|&i| p.names[i].starts_with("gyro.") || p.names[i].starts_with("accel."))
        .collect();
    let names = idx.iter().map(|&i| p.names[i].clone()).collect();
    let cov = nalgebra::DMatrix::from_fn(idx.len(), idx.len(), |a, b| p.cov[(idx[a], idx[b])]);
    let cov = navsim::InstrumentCovariance::new(names, cov).unwrap();
    let flight = navsim::SnakeTrajectory::new(&navsim::SnakeConfig::default_config()).unwrap();
    navsim::rho_series(&flight, &cov, &navsim::NavOptions::default())
        .unwrap()
        .final_rho_m()
}

#[test]
fn analyse_reproduces_paper_checks_two_figures() {
    let dir = scratch("analyse");
    for (imu_only, paper_check) in [(true, 2470.0), (false, 713.0)] {
        let out_json = dir.join(format!("analysis-{imu_only}.json"));
        let mut args = vec![
            "analyse",
            "--config",
            "paper-reconciled",
            "--json",
            s(&out_json),
        ];
        if imu_only {
            args.push("--imu-only");
        }
        let out = run(&args);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let stdout = text(&out.stdout);
        let line = format!("navigation: {paper_check:.0} m after 1 h of the paper's snake");
        assert!(stdout.contains(&line), "{stdout}");
        let figure = rho(&json(&out_json));
        assert_eq!(figure.round(), paper_check);
        assert_eq!(figure.round(), paper_check_rho(!imu_only).round());
    }
}

/// `examples/run.toml` with the IMU and the angles at 25 Hz (a run of a second).
fn config_25_hz(dir: &Path) -> PathBuf {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let text = std::fs::read_to_string(&example).expect("examples/run.toml");
    let path = dir.join("run25.toml");
    let text = text
        .replace("imu_rate_hz = 100.0", "imu_rate_hz = 25.0")
        .replace("turntable_rate_hz = 50.0", "turntable_rate_hz = 25.0");
    std::fs::write(&path, text).expect("config");
    path
}

#[test]
fn a_simulated_runs_figure_is_its_analysis_within_a_quarter() {
    let dir = scratch("simulated");
    let config = config_25_hz(&dir);
    let out = run(&["simulate", "--config", s(&config), "--out", s(&dir)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    for with_turntable in [true, false] {
        let (result, analysis) = (dir.join("result.json"), dir.join("analysis.json"));
        let imu = dir.join("imu.csv");
        let tt = dir.join("turntable.csv");
        let mut args = vec![
            "calibrate",
            "--imu",
            s(&imu),
            "--config",
            s(&config),
            "--json",
            s(&result),
        ];
        let mut analyse = vec!["analyse", "--config", s(&config), "--json", s(&analysis)];
        if with_turntable {
            args.extend(["--turntable", s(&tt)]);
        } else {
            analyse.push("--imu-only");
        }
        let out = run(&args);
        assert!(out.status.success(), "{}", text(&out.stdout));
        assert!(
            text(&out.stdout).contains("navigation: "),
            "{}",
            text(&out.stdout)
        );
        let out = run(&analyse);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let (r, a) = (json(&result), json(&analysis));
        let (got, want) = (rho(&r), rho(&a));
        assert!(
            (got / want - 1.0).abs() < 0.25,
            "with turntable {with_turntable}: calibrate {got} m, analyse {want} m"
        );
        let n = &r["navigation"];
        assert_eq!(n["model_fits"], serde_json::json!(true));
        assert!(n["uncalibrated_rho_m"].as_f64().unwrap() > 10.0 * got);
        let groups: Vec<&str> = n["budget"]
            .as_array()
            .unwrap()
            .iter()
            .map(|g| g["group"].as_str().unwrap())
            .collect();
        assert_eq!(
            groups,
            [
                "gyro_bias",
                "gyro_matrix",
                "accel_bias",
                "accel_matrix",
                "alignment",
                "sensor_noise"
            ]
        );
        let t = n["series"]["t_s"].as_array().unwrap();
        assert_eq!(t.last().and_then(|x| x.as_f64()), Some(3600.0));
    }
}

#[test]
fn design_ranks_the_paper_program_without_its_third_cycle_below_it() {
    let out = run(&["design", "--config", "paper"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let rank = |what: &str| {
        stdout
            .lines()
            .position(|l| l.starts_with("#  ") && l.contains(what))
            .unwrap_or_else(|| panic!("no `{what}` in\n{stdout}"))
    };
    let paper = rank("the recorded program  ");
    let without_third = rank("without its part 3 of 3");
    assert!(paper < without_third, "{stdout}");
    assert!(stdout.contains("kind = \"rotate\""), "{stdout}");
}

#[test]
fn a_consumer_recording_gets_the_horizon_of_its_grade() {
    let dir = scratch("consumer");
    let profile = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/xsens_mti.toml");
    let out = run(&["import", "--profile", s(&profile), "--out", s(&dir)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let result = dir.join("free.json");
    let out = run(&[
        "calibrate",
        "--imu",
        s(&dir.join("imu.csv")),
        "--free-motion",
        "--json",
        s(&result),
    ]);
    let stdout = text(&out.stdout);
    assert!(
        stdout.contains("after 1 min of the paper's snake"),
        "{stdout}"
    );
    let n = &json(&result)["navigation"];
    assert_eq!(n["horizon"]["grade"], "consumer");
    assert_eq!(n["horizon"]["seconds"].as_f64(), Some(60.0));
    assert!(
        n["horizon"]["reason"]
            .as_str()
            .unwrap()
            .contains("after an hour says nothing"),
        "{n}"
    );
    assert!(
        n["alignment"]
            .as_str()
            .unwrap()
            .contains("external reference")
    );
    // Its fit's verdict stands beside the figure.
    let fits = json(&result)["verdict"]["fits"].as_bool().unwrap();
    assert_eq!(n["model_fits"].as_bool(), Some(fits));
}

#[test]
fn an_accepted_g_sensitivity_has_its_share_in_the_budget() {
    let dir = scratch("g-sensitivity");
    let config = config_25_hz(&dir);
    let mut text_config = std::fs::read_to_string(&config).unwrap();
    text_config += "\"gyro.gsens.xz\" = 3e-6\n\"gyro.gsens.yx\" = -3e-6\n";
    std::fs::write(&config, text_config).unwrap();
    let out = run(&["simulate", "--config", s(&config), "--out", s(&dir)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let loop_json = dir.join("loop.json");
    let out = run(&[
        "diagnose",
        "--imu",
        s(&dir.join("imu.csv")),
        "--turntable",
        s(&dir.join("turntable.csv")),
        "--config",
        s(&config),
        "--terms",
        "gyro_g_sensitivity",
        "--json",
        s(&loop_json),
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains("accepted gyro_g_sensitivity"), "{stdout}");
    assert!(stdout.contains("  navigation: "), "{stdout}");
    let j = json(&loop_json);
    let share = j["navigation"]["budget"]
        .as_array()
        .unwrap()
        .iter()
        .find(|g| g["group"] == "gyro_g_sensitivity")
        .and_then(|g| g["rho_m"].as_f64())
        .expect("the term's line in the budget");
    assert!(share > 0.1 * rho(&j), "{share} of {}", rho(&j));
    let terms = &j["navigation"]["terms"];
    assert_eq!(terms[0]["term"], "gyro_g_sensitivity");
    assert_eq!(terms[0]["propagated"], true);
    // Every model the loop moved to has its figure, and the gain is stated.
    let models = j["models"].as_array().unwrap();
    assert_eq!(models.len(), 2);
    assert!(models.iter().all(|m| m["navigation"]["rho_m"].is_f64()));
    let gain = &j["navigation_gain"]["gyro_g_sensitivity"];
    assert!(
        gain["before_m"].is_f64() && gain["after_m"].is_f64(),
        "{gain}"
    );
}
