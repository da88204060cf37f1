//! The command-line program end to end: help, a short simulate + calibrate round trip, refusals
//! of bad input, the covariance analysis.

use crate::common::{self, run, s, text};
use std::path::{Path, PathBuf};

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-cli", name)
}

/// `examples/run.toml` with a 120-s run, written into `dir`.
fn short_config(dir: &Path) -> PathBuf {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let text = std::fs::read_to_string(&example).expect("examples/run.toml");
    let commented = "# duration_s = 600.0";
    assert!(
        text.contains(commented),
        "examples/run.toml no longer has `{commented}`"
    );
    let path = dir.join("short.toml");
    std::fs::write(&path, text.replace(commented, "duration_s = 120.0")).expect("config");
    path
}

#[test]
fn help_explains_every_subcommand_and_option() {
    let top = run(&["--help"]);
    assert!(top.status.success());
    let top = text(&top.stdout);
    for sub in ["simulate", "calibrate", "analyse"] {
        assert!(top.contains(sub), "{top}");
    }
    for (sub, options) in [
        ("simulate", &["--config", "--out", "--seed"][..]),
        (
            "calibrate",
            &["--imu", "--turntable", "--config", "--json", "--truth"][..],
        ),
        ("analyse", &["--config", "--imu-only", "--json"][..]),
    ] {
        let out = run(&[sub, "--help"]);
        assert!(out.status.success(), "{sub} --help");
        let help = text(&out.stdout);
        for option in options {
            // Every option is listed with an explanation on the following line.
            let lines: Vec<&str> = help.lines().collect();
            let at = lines
                .iter()
                .position(|l| l.trim_start().starts_with(option))
                .unwrap_or_else(|| panic!("{sub} --help does not list {option}:\n{help}"));
            let explained = lines
                .get(at + 1)
                .is_some_and(|l| l.split_whitespace().count() > 3);
            assert!(explained, "{sub} --help does not explain {option}:\n{help}");
        }
    }
}

#[test]
fn simulate_then_calibrate_round_trip() {
    let dir = scratch("round-trip");
    let config = short_config(&dir);
    let data = dir.join("run");
    let out = run(&["simulate", "--config", s(&config), "--out", s(&data)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(report.contains("12000 records"), "{report}");
    for f in ["imu.csv", "turntable.csv", "truth.json"] {
        assert!(data.join(f).is_file(), "{f} missing");
    }

    let result = dir.join("result.json");
    let out = run(&[
        "calibrate",
        "--imu",
        s(&data.join("imu.csv")),
        "--turntable",
        s(&data.join("turntable.csv")),
        "--config",
        s(&config),
        "--json",
        s(&result),
        "--truth",
        s(&data.join("truth.json")),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    for needle in [
        "gyro.bias.x",
        "deg/h",
        "arcmin",
        "mean NIS",
        "NEES",
        "error/sigma",
    ] {
        assert!(report.contains(needle), "no `{needle}` in\n{report}");
    }

    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&result).expect("result")).expect("JSON");
    let params = json["parameters"].as_array().expect("parameters");
    let names: Vec<&str> = params.iter().map(|p| p["name"].as_str().unwrap()).collect();
    let ax = ["x", "y", "z"];
    let mut expected: Vec<String> = ax.iter().map(|a| format!("gyro.bias.{a}")).collect();
    for i in ax {
        for j in ax {
            expected.push(format!("gyro.theta.{i}{j}"));
        }
    }
    expected.extend(ax.iter().map(|a| format!("accel.bias.{a}")));
    for g in ["xx", "yx", "yy", "zx", "zy", "zz"] {
        expected.push(format!("accel.gamma.{g}"));
    }
    expected.extend(ax.iter().map(|a| format!("install.delta.{a}")));
    expected.push("turntable.tau".into());
    assert_eq!(names, expected);
    for p in params {
        let sigma = p["sigma"].as_f64().expect("sigma");
        let value = p["value"].as_f64().expect("value");
        assert!(sigma.is_finite() && sigma > 0.0, "{p}");
        assert!(value.is_finite(), "{p}");
        assert!(p["unit"].is_string());
    }
    assert_eq!(json["fit"]["states"], 28);
    // Mean NIS of 3-dof updates: 3, standard error sqrt(6 / n); within four of them.
    for fit in [&json["fit"]["turntable"], &json["fit"]] {
        let key = if fit.get("mean_nis").is_some() {
            "mean_nis"
        } else {
            "accel_mean_nis"
        };
        let n_key = if key == "mean_nis" {
            "updates"
        } else {
            "accel_updates"
        };
        let (nis, n) = (fit[key].as_f64().unwrap(), fit[n_key].as_f64().unwrap());
        assert!(
            (nis - 3.0).abs() < 4.0 * (6.0 / n).sqrt(),
            "{key} {nis} over {n}"
        );
    }
    // The result reads back with the library's reader (the extra `fit` field is ignored).
    let back = calib::io::read_result_json(&result).expect("calib reads the result");
    assert_eq!(back.parameters.len(), 25);

    // IMU only: the 21 instrument parameters.
    let imu_only = dir.join("imu-only.json");
    let out = run(&[
        "calibrate",
        "--imu",
        s(&data.join("imu.csv")),
        "--config",
        s(&config),
        "--json",
        s(&imu_only),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&imu_only).unwrap()).unwrap();
    assert_eq!(json["parameters"].as_array().unwrap().len(), 21);
    assert!(json["fit"].get("turntable").is_none());
}

/// A small valid IMU file at 100 Hz (the example configuration's rate).
fn small_imu(path: &Path, nan_on_line: Option<usize>) {
    let mut t = String::from("t,dthx,dthy,dthz,dvx,dvy,dvz\n");
    for i in 1..=200 {
        let line = i + 1;
        let dvz = if nan_on_line == Some(line) {
            "NaN".to_string()
        } else {
            "0.0981".to_string()
        };
        // The first 2 s of the paper's program: 10 deg/s about instrument x.
        t += &format!("{},0.0017453292519943,0,0,0,0,{dvz}\n", i as f64 * 0.01);
    }
    std::fs::write(path, t).unwrap();
}

#[test]
fn a_nan_in_the_imu_file_is_refused_with_file_and_line() {
    let dir = scratch("nan");
    let imu = dir.join("imu.csv");
    small_imu(&imu, Some(7));
    let out = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--config",
        s(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml")),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(
        err.contains(s(&imu)) && err.contains("line 7") && err.contains("dvz"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn a_turntable_file_that_does_not_overlap_is_refused() {
    let dir = scratch("overlap");
    let imu = dir.join("imu.csv");
    small_imu(&imu, None);
    let tt = dir.join("turntable.csv");
    std::fs::write(
        &tt,
        "t,k1,k2,k3\n5000,0,0,0\n5000.02,0,0,0\n5000.04,0,0,0\n",
    )
    .unwrap();
    let out = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--turntable",
        s(&tt),
        "--config",
        s(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml")),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains(s(&tt)) && err.contains("overlap"), "{err}");

    // A malformed turntable row names its line.
    std::fs::write(&tt, "t,k1,k2,k3\n0,0,0,0\n0.02,0,zero,0\n").unwrap();
    let out = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--turntable",
        s(&tt),
        "--config",
        "paper",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains(s(&tt)) && err.contains("line 3"), "{err}");
}

#[test]
fn a_missing_or_bad_configuration_is_refused() {
    let dir = scratch("config");
    let missing = dir.join("nothing.toml");
    let out = run(&["analyse", "--config", s(&missing)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains(s(&missing)));

    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "program = \"paper\"\n[site]\nlatitude_deg = \"north\"\n",
    )
    .unwrap();
    let out = run(&["simulate", "--config", s(&bad), "--out", s(&dir)]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains(s(&bad)) && err.contains("line 3"), "{err}");
}

#[test]
fn analyse_the_paper_configuration() {
    let dir = scratch("analyse");
    let json = dir.join("analysis.json");
    let out = run(&["analyse", "--config", "paper", "--json", s(&json)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(
        report.contains("posterior sigma") && report.contains("turntable.tau"),
        "{report}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let params = v["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 25);
    for p in params {
        let (prior, post) = (
            p["prior_sigma"].as_f64().unwrap(),
            p["sigma"].as_f64().unwrap(),
        );
        assert!(post > 0.0 && post < prior, "{p}");
    }

    let out = run(&["analyse", "--config", "paper-reconciled", "--imu-only"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!text(&out.stdout).contains("turntable.tau"));
}

/// `--diagnostics DIR`: a summary in the report, eight PNGs (two kinds), the "diagnostics"
/// block in the JSON; a file in place of the directory is refused before any work.
#[test]
fn calibrate_with_diagnostics_writes_plots_and_json() {
    let dir = scratch("diagnostics");
    let config = short_config(&dir);
    let data = dir.join("run");
    let out = run(&["simulate", "--config", s(&config), "--out", s(&data)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let plots = dir.join("plots");
    let result = dir.join("result.json");
    let out = run(&[
        "calibrate",
        "--imu",
        s(&data.join("imu.csv")),
        "--turntable",
        s(&data.join("turntable.csv")),
        "--config",
        s(&config),
        "--json",
        s(&result),
        "--diagnostics",
        s(&plots),
    ]);
    let report = text(&out.stdout);
    assert!(report.contains("Diagnostics"), "{report}");
    assert!(report.contains("Ljung-Box"), "{report}");
    assert!(report.contains("verdict"), "{report}");
    for kind in ["accel", "turntable"] {
        for what in ["innovations", "spectrum", "autocorrelation", "nis_segments"] {
            let f = plots.join(format!("{what}_{kind}.png"));
            assert!(f.is_file(), "{} missing", f.display());
        }
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&result).expect("result")).expect("JSON");
    let d = &json["diagnostics"];
    assert!(d["fits"].is_boolean(), "{d}");
    assert_eq!(d["kinds"].as_array().unwrap().len(), 2);
    // A failing verdict ends with exit status 3 (so may a mean NIS outside its band).
    let fits = d["fits"].as_bool().unwrap();
    let code = out.status.code();
    assert!(
        if fits {
            matches!(code, Some(0 | 3))
        } else {
            code == Some(3)
        },
        "{code:?}: {}",
        text(&out.stderr)
    );

    let not_a_dir = dir.join("file.txt");
    std::fs::write(&not_a_dir, "x").unwrap();
    let out = run(&[
        "calibrate",
        "--imu",
        s(&data.join("imu.csv")),
        "--config",
        s(&config),
        "--diagnostics",
        s(&not_a_dir),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(
        err.contains("--diagnostics") && err.contains("is a file: expected a directory"),
        "{err}"
    );
}
