//! The JSON the commands write: `--json -` puts only the JSON on standard output (the report
//! goes to standard error), every file carries its schema stamp, readers refuse a newer or a
//! foreign one and take a file without one; the unit identity of a result and `apply`'s check
//! of it; the SHA-256 of every input of a hand-turned calibration.

use crate::common::{self, run, s, text};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-json-outputs", name)
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// The Ferraris session imported into `dir` with `extra` appended to its profile (paths made
/// absolute so the profile can live in `dir`).
fn import_ferraris(dir: &Path, extra: &str) -> PathBuf {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data");
    let profile = std::fs::read_to_string(examples().join("ferraris_session.toml"))
        .expect("profile")
        .replace("../data", s(&data));
    let path = dir.join("profile.toml");
    std::fs::write(&path, profile + extra).expect("profile");
    let out = dir.join("imported");
    let o = run(&["import", "--profile", s(&path), "--out", s(&out)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    out
}

/// Standard output parsed as JSON with the stamp `name`, after a successful run of `args`.
fn stdout_json(args: &[&str], name: &str) -> serde_json::Value {
    let o = run(args);
    // Exit status 3 is a verdict (the model does not fit these data), written with its JSON.
    assert!(
        matches!(o.status.code(), Some(0 | 3)),
        "{args:?}: {}",
        text(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
        panic!(
            "{args:?}: standard output is not JSON alone ({e}):\n{}",
            text(&o.stdout)
        )
    });
    assert_eq!(v["schema"]["name"], name, "{args:?}");
    assert_eq!(v["schema"]["version"], 1, "{args:?}");
    assert!(
        !text(&o.stderr).is_empty(),
        "{args:?}: the report went nowhere"
    );
    v
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("file")).expect("JSON")
}

#[test]
fn json_to_stdout_is_json_alone_on_every_command() {
    let dir = scratch("stdout");
    let imported = import_ferraris(&dir, "");
    let imu = imported.join("imu.csv");
    stdout_json(
        &["segment", "--imu", s(&imu), "--json", "-"],
        "sins-calib.segmentation",
    );
    stdout_json(
        &["noise", "--imu", s(&imu), "--json", "-"],
        "sins-calib.noise",
    );
    stdout_json(
        &["analyse", "--config", "paper", "--json", "-"],
        "sins-calib.analysis",
    );
    let r = stdout_json(
        &[
            "calibrate",
            "--imu",
            s(&imu),
            "--free-motion",
            "--json",
            "-",
        ],
        "sins-calib.calibration",
    );
    assert!(r["parameters"].as_array().is_some_and(|p| p.len() == 21));
    stdout_json(
        &["diagnose", "--imu", s(&imu), "--free-motion", "--json", "-"],
        "sins-calib.diagnosis",
    );
}

#[test]
fn files_written_carry_their_stamp() {
    let dir = scratch("stamps");
    let imported = import_ferraris(&dir, "");
    assert_eq!(
        read_json(&imported.join("import.json"))["schema"]["name"],
        "sins-calib.import"
    );
    assert_eq!(
        read_json(&imported.join("sections.json"))["schema"]["name"],
        "sins-calib.sections"
    );
    // simulate's truth, on a configuration cut to a few seconds.
    let example = std::fs::read_to_string(examples().join("run.toml")).expect("run.toml");
    let config = dir.join("short.toml");
    std::fs::write(
        &config,
        example.replace("# duration_s = 600.0", "duration_s = 5.0"),
    )
    .expect("config");
    let sim = dir.join("sim");
    let o = run(&["simulate", "--config", s(&config), "--out", s(&sim)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let truth = read_json(&sim.join("truth.json"));
    assert_eq!(truth["schema"]["name"], "sins-calib.truth");
    // The stamp is the first key, so that a reader sees it first.
    let raw = std::fs::read_to_string(sim.join("truth.json")).unwrap();
    assert!(raw.trim_start().starts_with("{\n  \"schema\""), "{raw}");
}

#[test]
fn readers_refuse_newer_or_foreign_files_and_take_older_ones() {
    let dir = scratch("readers");
    let imported = import_ferraris(&dir, "");
    let imu = imported.join("imu.csv");
    let result = dir.join("r.json");
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--free-motion",
        "--json",
        s(&result),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = dir.join("c.csv");
    let apply = |cal: &Path| {
        run(&[
            "apply",
            "--calibration",
            s(cal),
            "--imu",
            s(&imu),
            "--out",
            s(&out),
        ])
    };
    // Newer major version: refused, naming the file.
    let newer = dir.join("newer.json");
    let mut v = read_json(&result);
    v["schema"]["version"] = 2.into();
    std::fs::write(&newer, v.to_string()).unwrap();
    let o = apply(&newer);
    assert_eq!(o.status.code(), Some(1));
    let e = text(&o.stderr);
    assert!(e.contains("newer.json") && e.contains("version 2"), "{e}");
    // Another kind of file.
    let noise = dir.join("noise.json");
    assert!(
        run(&["noise", "--imu", s(&imu), "--json", s(&noise)])
            .status
            .success()
    );
    let o = apply(&noise);
    let e = text(&o.stderr);
    assert!(!o.status.success() && e.contains("noise.json"), "{e}");
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--free-motion",
        "--terms-from",
        s(&result),
    ]);
    let e = text(&o.stderr);
    assert!(
        o.status.code() == Some(1)
            && e.contains("sins-calib.calibration")
            && e.contains("diagnose"),
        "{e}"
    );
    // A file without the stamp (an older version's) is read.
    let older = dir.join("older.json");
    let mut v = read_json(&result);
    v.as_object_mut().unwrap().remove("schema");
    std::fs::write(&older, v.to_string()).unwrap();
    let o = apply(&older);
    assert!(o.status.success(), "{}", text(&o.stderr));
}

#[test]
fn unit_identity_goes_into_the_result_and_apply_checks_it() {
    let dir = scratch("unit");
    let imported = import_ferraris(&dir, "\n[unit]\nmodel = \"imucal\"\nserial = \"F-001\"\n");
    let imu = imported.join("imu.csv");
    let result = dir.join("r.json");
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--free-motion",
        "--sections",
        s(&imported.join("sections.json")),
        "--json",
        s(&result),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let report = text(&o.stdout);
    assert!(
        report.contains("unit            model imucal, serial F-001"),
        "{report}"
    );
    assert!(report.contains("latitude 45 deg assumed"), "{report}");
    let r = read_json(&result);
    assert_eq!(r["unit"]["serial"], "F-001");
    assert_eq!(r["unit"]["model"], "imucal");
    assert!(
        r["assumptions"][0]
            .as_str()
            .is_some_and(|a| a.contains("latitude 45 deg assumed")),
        "{r}"
    );
    // Every input with its SHA-256: the records, the section list, import.json, the profile
    // and the raw files.
    let inputs = r["inputs"].as_array().expect("inputs");
    for role in [
        "IMU records",
        "section list",
        "import report",
        "import profile",
        "raw imu file",
        "raw section list",
    ] {
        let f = inputs
            .iter()
            .find(|f| f["role"] == role)
            .unwrap_or_else(|| panic!("no `{role}` in {inputs:?}"));
        assert_eq!(f["sha256"].as_str().map(str::len), Some(64), "{f}");
    }
    // A contradicting option is refused.
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--free-motion",
        "--unit-serial",
        "X9",
    ]);
    let e = text(&o.stderr);
    assert!(
        o.status.code() == Some(1) && e.contains("F-001") && e.contains("X9"),
        "{e}"
    );

    // apply: the records copied elsewhere (no import.json beside them).
    let other = dir.join("other");
    std::fs::create_dir_all(&other).unwrap();
    let raw = other.join("imu.csv");
    std::fs::copy(&imu, &raw).unwrap();
    let out = dir.join("c.csv");
    let apply = |extra: &[&str]| {
        let mut a = vec![
            "apply",
            "--calibration",
            s(&result),
            "--imu",
            s(&raw),
            "--out",
            s(&out),
        ];
        a.extend_from_slice(extra);
        run(&a)
    };
    let o = apply(&["--unit-serial", "X9"]);
    let e = text(&o.stderr);
    assert!(
        o.status.code() == Some(1)
            && e.contains("another unit")
            && e.contains("--accept-other-unit"),
        "{e}"
    );
    assert!(!out.exists());
    let o = apply(&["--unit-serial", "X9", "--accept-other-unit"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = apply(&["--unit-serial", "F-001"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // Unknown on the data's side: said, and applied.
    let o = apply(&[]);
    assert!(o.status.success());
    assert!(
        text(&o.stderr).contains("is not known"),
        "{}",
        text(&o.stderr)
    );
    // Beside its import.json, the data's unit is the profile's.
    let o = run(&[
        "apply",
        "--calibration",
        s(&result),
        "--imu",
        s(&imu),
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        !text(&o.stderr).contains("not known"),
        "{}",
        text(&o.stderr)
    );
    // A hand-turned run without a profile: the options name the unit.
    let o = run(&[
        "calibrate",
        "--imu",
        s(&raw),
        "--free-motion",
        "--unit-model",
        "M",
        "--unit-serial",
        "S1",
        "--json",
        "-",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    assert_eq!(v["unit"]["serial"], "S1");
    assert_eq!(v["unit"]["model"], "M");
}
