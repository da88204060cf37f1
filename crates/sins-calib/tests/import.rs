//! `import` and `segment` end to end: the shipped profiles of the two real recordings, the
//! segmentation of what they write, and refusals (exit status 1, one line naming file and line).

use crate::common::{self, run, s, text};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-import", name)
}

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
}

#[test]
fn help_lists_import_and_segment_with_their_options() {
    let top = text(&run(&["--help"]).stdout);
    assert!(top.contains("import") && top.contains("segment"), "{top}");
    for (sub, options) in [
        ("import", &["--profile", "--out", "--allow-gaps"][..]),
        (
            "segment",
            &[
                "--imu",
                "--json",
                "--rest-window",
                "--rest-max-std-f",
                "--rest-max-std-w",
                "--rest-max-rate",
                "--rest-min-duration",
                "--rest-noise-factor",
                "--gap-factor",
            ][..],
        ),
    ] {
        let out = run(&[sub, "--help"]);
        assert!(out.status.success(), "{sub} --help");
        let help = text(&out.stdout);
        for option in options {
            assert!(
                help.contains(option),
                "{sub} --help lacks {option}:\n{help}"
            );
        }
    }
}

#[test]
fn xsens_import_then_segment() {
    let dir = scratch("xsens");
    let out = run(&[
        "import",
        "--profile",
        s(&example("xsens_mti.toml")),
        "--out",
        s(&dir),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    for needle in [
        "51175 data rows",
        "t = 0.02984 .. 511.718 s, 51175 records",
        "intervals 0.009 .. 0.0104 s (each record keeps its own time stamp)",
        "gaps: none",
        "saturation: gyro none",
        "imu.csv: 51175 records, rates",
    ] {
        assert!(report.contains(needle), "no `{needle}` in\n{report}");
    }
    assert!(dir.join("import.json").is_file());
    assert!(!dir.join("turntable.csv").exists());

    let json = dir.join("segments.json");
    let out = run(&[
        "segment",
        "--imu",
        s(&dir.join("imu.csv")),
        "--json",
        s(&json),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(report.contains("38 static intervals"), "{report}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let intervals = v["static"].as_array().unwrap();
    assert_eq!(intervals.len(), 38);
    assert_eq!(v["records"], 51175);
    assert!(intervals[0]["duration_s"].as_f64().unwrap() > 50.0);
    assert!(v["imu"].as_str().unwrap().ends_with("imu.csv"));
}

#[test]
fn ferraris_import_writes_sections_and_segment_prints_intervals() {
    let dir = scratch("ferraris");
    let out = run(&[
        "import",
        "--profile",
        s(&example("ferraris_session.toml")),
        "--out",
        s(&dir),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(report.contains("sections.json: 9 sections"), "{report}");
    assert!(report.contains("gyro integrates to -371.9 deg"), "{report}");
    let sections: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("sections.json")).unwrap()).unwrap();
    assert_eq!(sections["sections"].as_array().unwrap().len(), 9);
    assert_eq!(sections["sections"][0]["name"], "x_p");

    let out = run(&["segment", "--imu", s(&dir.join("imu.csv"))]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(report.contains("13 static intervals"), "{report}");
    assert!(report.contains("|f| [m/s^2]"), "{report}");
}

#[test]
fn refusals_name_the_file_and_line() {
    let dir = scratch("refusals");
    // A profile with an unknown key.
    let profile = dir.join("bad.toml");
    let good = std::fs::read_to_string(example("ferraris_session.toml")).unwrap();
    std::fs::write(
        &profile,
        good.replace("rate_hz = 102.4", "rate_hz = 102.4\nrate = 1"),
    )
    .unwrap();
    let out = run(&["import", "--profile", s(&profile), "--out", s(&dir)]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains("bad.toml: TOML parse error at line"), "{err}");
    assert!(err.contains("unknown field `rate`"), "{err}");

    // A recording with a gap: refused, then kept with --allow-gaps.
    let mut csv = String::from("t,wx,wy,wz,fx,fy,fz\n");
    for i in 0..600 {
        let t = i as f64 * 0.01 + if i >= 300 { 0.5 } else { 0.0 };
        csv += &format!("{t},0,0,0,0,0,9.81\n");
    }
    std::fs::write(dir.join("gap.csv"), csv).unwrap();
    let toml = r#"form = "rates"
[input]
file = "gap.csv"
skip_lines = 1
[time]
column = 1
[gyro]
columns = [2, 3, 4]
unit = "rad/s"
[accel]
columns = [5, 6, 7]
unit = "m/s^2"
"#;
    let profile = dir.join("gap.toml");
    std::fs::write(&profile, toml).unwrap();
    let out_dir = dir.join("gap");
    let out = run(&["import", "--profile", s(&profile), "--out", s(&out_dir)]);
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains("gap.csv: line 302: a gap of 0.51 s"), "{err}");
    assert!(!out_dir.join("imu.csv").exists(), "nothing written");
    let out = run(&[
        "import",
        "--profile",
        s(&profile),
        "--out",
        s(&out_dir),
        "--allow-gaps",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(report.contains("gaps: 1"), "{report}");
    assert!(
        report.contains("0.51 s (51.0 median intervals)"),
        "{report}"
    );
    let out = run(&["segment", "--imu", s(&out_dir.join("imu.csv"))]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(report.contains("2 static intervals"), "{report}");
    assert!(report.contains("1 gap"), "{report}");

    // segment: a file that is not an imu.csv, and bad settings.
    let out = run(&["segment", "--imu", s(&dir.join("gap.csv")), "--window", "0"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("window_s = 0"),
        "{}",
        text(&out.stderr)
    );
    let out = run(&["segment", "--imu", s(&profile)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("gap.toml: line 1"),
        "{}",
        text(&out.stderr)
    );
}

/// The static detector's options are one set with one spelling (`--rest-*`) on every command
/// that finds rests; `segment`'s and `noise`'s former spellings are hidden aliases that give the
/// same result.
#[test]
fn rest_options_are_one_spelling_and_the_old_ones_hidden_aliases() {
    let rest_options = [
        "--rest-window",
        "--rest-max-std-f",
        "--rest-max-std-w",
        "--rest-max-rate",
        "--rest-min-duration",
        "--rest-noise-factor",
    ];
    let old_spellings = [
        "--window",
        "--max-std-f",
        "--max-std-w",
        "--max-rate",
        "--min-duration",
        "--noise-factor",
    ];
    for sub in ["segment", "noise", "calibrate", "diagnose"] {
        let out = run(&[sub, "--help"]);
        assert!(out.status.success(), "{sub} --help");
        let help = text(&out.stdout);
        for option in rest_options {
            assert!(
                help.contains(option),
                "{sub} --help lacks {option}:\n{help}"
            );
        }
        for old in old_spellings {
            assert!(!help.contains(old), "{sub} --help shows {old}:\n{help}");
        }
    }

    let dir = scratch("rest-aliases");
    let out = run(&[
        "import",
        "--profile",
        s(&example("xsens_mti.toml")),
        "--out",
        s(&dir),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let imu = dir.join("imu.csv");
    let values = ["0.5", "0.2", "0.06", "0.12", "3", "4"];
    let spelled = |names: &[&str]| -> Vec<String> {
        names
            .iter()
            .zip(values)
            .flat_map(|(n, v)| [n.to_string(), v.to_string()])
            .collect()
    };
    for sub in ["segment", "noise"] {
        let printed = |names: &[&str]| {
            let mut args = vec![sub.to_string(), "--imu".into(), s(&imu).into()];
            args.extend(spelled(names));
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let out = run(&args);
            assert!(out.status.success(), "{args:?}: {}", text(&out.stderr));
            text(&out.stdout)
        };
        let new = printed(&rest_options);
        assert!(new.contains("0.5 s"), "{sub}:\n{new}");
        assert_eq!(new, printed(&old_spellings), "{sub}: the aliases differ");
    }
}
