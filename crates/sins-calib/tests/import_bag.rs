//! `import --bag`: the Ferraris recording as a ROS 1 bag and as an MCAP file (written by the
//! Python `rosbags` package, tests/fixtures/bags/README.md) imports to the very `imu.csv` of
//! its CSV route and calibrates to the same figures; refusals name the file, topic, message.

use crate::common::{self, run, s, text};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-import-bag", name)
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
}

fn ok(args: &[&str]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
    text(&o.stdout)
}

/// The refusal of `import --bag` as one line on stderr, exit status 1, nothing written.
fn refused(bag: &Path, topic: &str, out: &Path) -> String {
    let o = run(&["import", "--bag", s(bag), "--topic", topic, "--out", s(out)]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stdout));
    assert!(!out.exists(), "a refused import leaves nothing");
    let e = text(&o.stderr);
    assert_eq!(e.lines().count(), 1, "{e}");
    e
}

/// The calibration printout without the lines naming its inputs (the raw files differ by
/// route), and the result without `inputs`.
fn calibrated(dir: &Path, sections: &Path) -> (String, serde_json::Value) {
    let json = dir.join("free.json");
    let out = ok(&[
        "calibrate",
        "--imu",
        s(&dir.join("imu.csv")),
        "--sections",
        s(sections),
        "--free-motion",
        "--terms",
        "gyro_scale_asymmetry",
        "--holdout",
        "2",
        "--json",
        s(&json),
    ]);
    let printout: Vec<&str> = out
        .lines()
        .filter(|l| !l.trim_start().starts_with("input "))
        .collect();
    let printout = printout.join("\n").replace(s(dir), "DIR");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("result")).expect("JSON");
    v.as_object_mut().expect("object").remove("inputs");
    (printout, v)
}

#[test]
fn ferraris_bag_and_mcap_import_and_calibrate_as_the_csv_route() {
    let csv = scratch("csv");
    let profile = repo("examples/ferraris_session.toml");
    ok(&["import", "--profile", s(&profile), "--out", s(&csv)]);
    let imu_csv = std::fs::read(csv.join("imu.csv")).expect("imu.csv");
    let sections = csv.join("sections.json");
    let (csv_printout, csv_result) = calibrated(&csv, &sections);
    assert!(csv_printout.contains("10376 records"), "{csv_printout}");
    for (name, ty) in [("bag", "sensor_msgs/Imu"), ("mcap", "sensor_msgs/msg/Imu")] {
        let dir = scratch(name);
        let bag = repo(&format!("tests/fixtures/bags/ferraris_imu.{name}"));
        let out = ok(&[
            "import",
            "--bag",
            s(&bag),
            "--topic",
            "/imu/data",
            "--out",
            s(&dir),
        ]);
        assert!(
            out.contains(&format!("10376 messages of {ty} on /imu/data")),
            "{out}"
        );
        assert!(
            std::fs::read(dir.join("imu.csv")).expect("imu.csv") == imu_csv,
            "{name}: imu.csv differs from the CSV route's"
        );
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join("import.json")).expect("import.json"),
        )
        .expect("JSON");
        let b = &report["bag"];
        assert_eq!(b["topic"], "/imu/data");
        assert_eq!(b["message_type"], ty);
        assert_eq!(b["frame_ids"], serde_json::json!(["imu_link"]));
        assert_eq!(b["covariance"]["orientation"][0], -1.0);
        assert_eq!(b["covariance_varies"]["angular_velocity"], false);
        assert_eq!(report["records"], 10376);
        assert!(report.get("profile").is_none());
        let input = &report["input_files"][0];
        assert_eq!(input["path"], s(&bag));
        assert_eq!(input["sha256"].as_str().map(str::len), Some(64));
        let (printout, result) = calibrated(&dir, &sections);
        assert_eq!(printout, csv_printout, "{name}: calibration printout");
        assert_eq!(result, csv_result, "{name}: calibration result");
    }
}

#[test]
fn refusals_name_the_file_topic_and_message() {
    for (name, ty) in [("bag", "sensor_msgs/Imu"), ("mcap", "sensor_msgs/msg/Imu")] {
        let bag = repo(&format!("tests/fixtures/bags/refusals.{name}"));
        // Its own folder: the CSV-route test above writes into `scratch("bag")` and
        // `scratch("mcap")` at the same time, and a scratch folder is emptied when taken (a
        // CI run lost that test's result file to this one).
        let own = scratch(&format!("refused-{name}"));
        let out = own.join("out");
        let e = refused(&bag, "/imu/data", &out);
        assert!(
            e.contains("topic /imu/data, message 4: header stamp t = 0.02 s is not after message 3's t = 0.02 s"),
            "{e}"
        );
        let e = refused(&bag, "/temperature", &out);
        assert!(
            e.contains("topic /temperature carries `sensor_msgs/"),
            "{e}"
        );
        assert!(e.contains(&format!("expected {ty}")), "{e}");
        let e = refused(&bag, "/imu", &out);
        assert!(
            e.contains(&format!(
                "no topic /imu: expected one of the file's topics: /imu/data ({ty}, 5 messages), \
                 /temperature"
            )),
            "{e}"
        );
        // Truncated: the first 300 kB of the Ferraris file.
        let whole = std::fs::read(repo(&format!("tests/fixtures/bags/ferraris_imu.{name}")))
            .expect("fixture");
        let cut = own.join(format!("cut.{name}"));
        std::fs::write(&cut, &whole[..300_000]).expect("write");
        let e = refused(&cut, "/imu/data", &out);
        assert!(e.contains(s(&cut)) && e.contains("truncated?"), "{e}");
        // Not a bag at all.
        let e = refused(&repo("examples/ferraris_session.toml"), "/imu/data", &out);
        assert!(
            e.contains("expected a ROS 1 bag (.bag) or an MCAP file"),
            "{e}"
        );
    }
    // --bag without --topic, and with --profile, are usage errors.
    let bag = repo("tests/fixtures/bags/refusals.bag");
    let o = run(&["import", "--bag", s(&bag), "--out", "x"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    let o = run(&[
        "import",
        "--bag",
        s(&bag),
        "--topic",
        "/imu/data",
        "--profile",
        "p.toml",
        "--out",
        "x",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
}
