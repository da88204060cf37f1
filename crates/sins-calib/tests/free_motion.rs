//! `calibrate --free-motion` on the two real recordings shipped in `data/real` (import, then
//! calibrate with a hold-out): the acceptance targets of the free-motion calibration.

use crate::common::{self, BIN, s};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    let o = Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-free-motion", name)
}

fn import(profile: &str, dir: &Path) {
    let profile = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(profile);
    run(&["import", "--profile", s(&profile), "--out", s(dir)]);
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("result")).expect("JSON")
}

fn num(v: &serde_json::Value, path: &[&str]) -> f64 {
    let mut x = v;
    for k in path {
        x = &x[*k];
    }
    x.as_f64().unwrap_or_else(|| panic!("{path:?} in {v}"))
}

#[test]
fn xsens_held_out_targets() {
    let dir = scratch("xsens");
    import("xsens_mti.toml", &dir);
    let (imu, out, png) = (dir.join("imu.csv"), dir.join("r.json"), dir.join("r.png"));
    run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--free-motion",
        "--terms",
        "gyro_g_sensitivity",
        "--holdout",
        "4",
        "--json",
        s(&out),
        "--plot",
        s(&png),
    ]);
    let r = json(&out);
    assert_eq!(r["parameters"].as_array().map(Vec::len), Some(30));
    assert_eq!(r["verdict"]["fits"], true);
    let v = &r["free_motion"]["validation"];
    assert_eq!(num(v, &["intervals"]), 9.0);
    let after = num(v, &["static_rms_m_s2", "after"]);
    assert!(after <= 0.003, "held-out static RMS {after} m/s^2");
    let (rb, ra) = (
        num(v, &["rotation_rms_deg", "before"]),
        num(v, &["rotation_rms_deg", "after"]),
    );
    assert!(ra < 0.5 * rb, "held-out rotation RMS {rb} -> {ra} deg");
    // Issue 42: never worse than the least-squares |f| = g fit to the same rests by more than
    // 5 % on the held-out rests. By default since the rests' excess is weighed where the rests
    // show it (1.08 before, 1.04 now: docs/real-data.md).
    let baseline = num(v, &["baseline", "held_out_static_rms_m_s2"]);
    assert!(
        after <= 1.05 * baseline,
        "{after} against the baseline's {baseline}"
    );
    let p = num(&r["free_motion"], &["rest_error_unasked_p_value"]);
    assert!(p < 0.01, "the excess weighed unasked at p = {p}");
    let bytes = std::fs::read(&png).expect("png");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
}

/// Without the g-sensitivity `diagnose` finds in it (held-out +320 nats), the Xsens unit's
/// held-out rests contradict the paper's model: its windows, predicted by a calibration that
/// has not seen them, scatter a hundred times the rests' own noise. Exit status 3, and the
/// JSON says what decided it.
#[test]
fn xsens_without_its_g_sensitivity_does_not_fit() {
    let dir = scratch("xsens-paper");
    import("xsens_mti.toml", &dir);
    let out = dir.join("r.json");
    let o = Command::new(BIN)
        .args([
            "calibrate",
            "--imu",
            s(&dir.join("imu.csv")),
            "--free-motion",
        ])
        .args(["--holdout", "4", "--json", s(&out)])
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    let r = json(&out);
    assert_eq!(r["verdict"]["fits"], false);
    let reasons = r["verdict"]["reasons"].as_array().expect("reasons");
    assert!(
        reasons
            .iter()
            .any(|x| x.as_str().unwrap_or("").starts_with("held-out rests")),
        "{reasons:?}"
    );
    assert!(
        r["verdict"]["basis"]
            .as_str()
            .unwrap_or("")
            .contains("held-out rests"),
        "{}",
        r["verdict"]
    );
}

#[test]
fn ferraris_turns_and_held_out_faces() {
    let dir = scratch("ferraris");
    import("ferraris_session.toml", &dir);
    let (imu, out) = (dir.join("imu.csv"), dir.join("r.json"));
    let (sections, report) = (dir.join("sections.json"), dir.join("report"));
    run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--sections",
        s(&sections),
        "--free-motion",
        "--holdout",
        "2",
        "--json",
        s(&out),
        "--report",
        s(&report),
    ]);
    // One result type: the laboratory report of any calibration.
    let md = std::fs::read_to_string(report.join("report.md")).expect("report.md");
    assert!(md.contains("gyro.theta.zz"), "{md}");
    let r = json(&out);
    let v = &r["free_motion"]["validation"];
    let (b, a) = (
        num(v, &["static_rms_m_s2", "before"]),
        num(v, &["static_rms_m_s2", "after"]),
    );
    assert!(a * 10.0 <= b, "held-out static RMS {b} -> {a} m/s^2");
    let turns = r["free_motion"]["turns"].as_array().expect("turns");
    assert_eq!(turns.len(), 3);
    for t in turns {
        let after = num(t, &["after_deg"]);
        let before = num(t, &["before_deg"]);
        // The target: every turn within 1 deg of -360 after calibration.
        assert!(
            (after + 360.0).abs() < 1.0,
            "{}: {before} -> {after} deg",
            t["name"]
        );
    }
}

/// `diagnose --free-motion` on the Xsens recording, through the filter of a recording of
/// rests: the loop accepts the g-sensitivity (its held-out check over every fourth rest passes:
/// measured +406) and nothing more; the extended model still fails the diagnostics (exit
/// status 3, docs/real-data.md). The test asserts the decision, not that verdict.
#[test]
fn diagnose_finds_the_xsens_g_sensitivity() {
    let dir = scratch("diagnose-xsens");
    import("xsens_mti.toml", &dir);
    let out_json = dir.join("loop.json");
    let out = Command::new(BIN)
        .args([
            "diagnose",
            "--imu",
            s(&dir.join("imu.csv")),
            "--free-motion",
        ])
        .args(["--json", s(&out_json)])
        .output()
        .expect("the binary runs");
    assert!(
        matches!(out.status.code(), Some(0 | 3)),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j = json(&out_json);
    assert_eq!(
        j["accepted_terms"],
        serde_json::json!(["gyro_g_sensitivity"])
    );
    let check = &j["rounds"][0]["held_out"];
    assert_eq!(check["term"], "gyro_g_sensitivity", "{j}");
    let gain = num(check, &["log_density_with"]) - num(check, &["log_density_without"]);
    assert!(gain > 0.0, "held-out gain {gain}");
}

/// A section list that does not belong to the records is refused before any work, naming the
/// section (issue 20: another recording's section list was used, or a section past the end
/// skipped, with exit 0): the Ferraris list against the Xsens records, and the Ferraris list
/// with a section moved past the end of its own records.
#[test]
fn a_section_list_of_other_records_is_refused() {
    let dir = scratch("foreign-sections");
    import("ferraris_session.toml", &dir.join("ferraris"));
    import("xsens_mti.toml", &dir.join("xsens"));
    let sections = dir.join("ferraris/sections.json");
    let refused = |imu: &Path, list: &Path, needle: &str| {
        for cmd in [
            ["calibrate", "--free-motion"],
            ["diagnose", "--free-motion"],
        ] {
            let o = Command::new(BIN)
                .args(cmd)
                .args(["--imu", s(imu), "--sections", s(list)])
                .output()
                .expect("the binary runs");
            let e = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(1), "{cmd:?}: {e}");
            assert!(e.contains(needle) && e.contains(s(list)), "{cmd:?}: {e}");
            assert!(o.stdout.is_empty() || !String::from_utf8_lossy(&o.stdout).contains("Fit"));
        }
    };
    refused(
        &dir.join("xsens/imu.csv"),
        &sections,
        "section `x_p`: start_s .. end_s = 5.2734375 .. 12.40234375 s, but its records are stamped",
    );
    let mut list = json(&sections);
    list["sections"][0]["last_record"] = serde_json::json!(1_000_000);
    let moved = dir.join("moved.json");
    std::fs::write(&moved, serde_json::to_string_pretty(&list).expect("JSON")).expect("write");
    refused(
        &dir.join("ferraris/imu.csv"),
        &moved,
        "spans records 540 .. 1000000, but the IMU file has 10376 records",
    );
    // A rotation about a zero axis gave 39 parameters of 0 +- 0 and nulls in the JSON.
    let mut list = json(&sections);
    let rotation = list["sections"]
        .as_array_mut()
        .expect("sections")
        .iter_mut()
        .find(|x| x.get("axis").is_some())
        .expect("a rotation section");
    rotation["axis"] = serde_json::json!([0.0, 0.0, 0.0]);
    let zero = dir.join("zero-axis.json");
    std::fs::write(&zero, serde_json::to_string_pretty(&list).expect("JSON")).expect("write");
    refused(
        &dir.join("ferraris/imu.csv"),
        &zero,
        "`axis` = [0.0, 0.0, 0.0] has length 0: expected a unit vector",
    );
}

/// `calibrate --free-motion` on the shipped Xsens recording made absurd (issue 20, "absurd data
/// reported as success"): accelerometer data in g, or time stamps in milliseconds read as
/// seconds, are refused before the filter with the likely cause named (exit status 1); the
/// recording as it is fits (exit 0).
#[test]
fn absurd_recordings_are_refused() {
    let dir = scratch("absurd");
    import("xsens_mti.toml", &dir);
    let text = std::fs::read_to_string(dir.join("imu.csv")).expect("imu.csv");
    let mut lines = text.lines();
    let header = lines.next().expect("header");
    assert_eq!(header, "t,wx,wy,wz,fx,fy,fz");
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().expect("number")).collect())
        .collect();
    let write = |name: &str, f: &dyn Fn(&[f64]) -> Vec<f64>| {
        let mut out = String::from(header) + "\n";
        for r in &rows {
            let v: Vec<String> = f(r).iter().map(|x| format!("{x:e}")).collect();
            out += &(v.join(",") + "\n");
        }
        let path = dir.join(name);
        std::fs::write(&path, out).expect("write");
        path
    };
    let in_g = write("in_g.csv", &|r| {
        let mut v = r.to_vec();
        v[4..7].iter_mut().for_each(|x| *x /= 9.80665);
        v
    });
    let in_ms = write("in_ms.csv", &|r| {
        let mut v = r.to_vec();
        v[0] *= 1000.0;
        v
    });
    for (path, needle) in [
        (&in_g, "the accelerometer values are not in m/s^2"),
        (&in_ms, "stamps in milliseconds"),
    ] {
        let o = Command::new(BIN)
            .args(["calibrate", "--imu", s(path), "--free-motion"])
            .output()
            .expect("runs");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{path:?}: {err}");
        assert!(err.contains(needle) && err.contains(s(path)), "{err}");
        assert!(o.stdout.is_empty(), "{path:?}");
    }
    let o = Command::new(BIN)
        .args([
            "calibrate",
            "--imu",
            s(&dir.join("imu.csv")),
            "--free-motion",
        ])
        .output()
        .expect("runs");
    let out = String::from_utf8_lossy(&o.stdout);
    // The Xsens recording: the score tests call for a gyro g-sensitivity (p ~ 1e-165) that
    // would move gyro.bias.y by about 15 of its sigmas, so the verdict is exit 3 naming it
    // (docs/real-data.md fits it with --terms gyro_g_sensitivity).
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{out}");
    assert!(
        err.contains("the data call for gyro_g_sensitivity"),
        "{err}"
    );
    assert!(out.contains("consistent with 3"), "{out}");
    // A hold-out beyond the intervals held out nothing and printed "before 0.00000, after
    // 0.00000" with exit status 0.
    let o = Command::new(BIN)
        .args([
            "calibrate",
            "--imu",
            s(&dir.join("imu.csv")),
            "--free-motion",
        ])
        .args(["--holdout", "1000"])
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("holdout K = 1000 (--holdout): the recording has 38 rests"),
        "{err}"
    );
}

/// Rests that all point gravity the same way (a unit turned about the vertical between them)
/// are refused before the fit: they cannot separate the accelerometer parameters, and passed
/// the count of three intervals (issue 20).
#[test]
fn rests_in_one_orientation_are_refused() {
    let dir = scratch("one-face");
    let mut program = String::from("name = \"one face\"\nstart_deg = [0.0, 0.0, 0.0]\n");
    for _ in 0..5 {
        program += "[[segment]]\nkind = \"dwell\"\nduration_s = 20.0\n\
                    [[segment]]\nkind = \"rotate\"\ngimbal = 1\nrate_deg_s = 30.0\nduration_s = 3.0\n";
    }
    program += "[[segment]]\nkind = \"dwell\"\nduration_s = 20.0\n";
    std::fs::write(dir.join("program.toml"), program).expect("program");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let cfg = std::fs::read_to_string(example)
        .expect("run.toml")
        .replace("program = \"paper\"", "program = \"program.toml\"");
    std::fs::write(dir.join("run.toml"), cfg).expect("config");
    run(&[
        "simulate",
        "--config",
        s(&dir.join("run.toml")),
        "--out",
        s(&dir),
    ]);
    let o = Command::new(BIN)
        .args([
            "calibrate",
            "--imu",
            s(&dir.join("imu.csv")),
            "--free-motion",
        ])
        .output()
        .expect("runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("in only 1 direction(s)") && err.contains("expected at least 3"),
        "{err}"
    );
}
