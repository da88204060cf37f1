//! The two real recordings shipped in `data/real` through the shipped profiles: the Xsens MTi
//! (two raw-count files with jittered time) and the Ferraris session (one CSV, a sample counter
//! and a section list).

mod common;

use calib::motion::detect::{DetectorSettings, segment};
use common::{Imported, import_to};
use import::ImportOptions;
use import::profile::Profile;
use import::sections::SectionKind;
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
}

/// The shipped profile `name` imported into `out` (a directory of the test's own) and read back.
fn import(name: &str, out: &str) -> Imported {
    let profile = Profile::load(&example(name)).expect("shipped profile");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("import-real-data")
        .join(out);
    import_to(&profile, &ImportOptions::default(), &dir).expect("shipped recording imports")
}

#[test]
fn xsens_keeps_its_jittered_time_and_has_38_static_intervals() {
    let imported = import("xsens_mti.toml", "xsens-jitter");
    let r = &imported.report;
    assert_eq!(r.records, 51175);
    assert_eq!(r.inputs.len(), 2);
    assert_eq!((r.t_first_s, r.t_last_s), (0.02984, 511.718));
    // Jitter kept: the intervals of the source, 9.0 to 10.4 ms, no gaps.
    assert!((r.timing.min_interval_s - 0.009).abs() < 1e-9);
    assert!((r.timing.max_interval_s - 0.0104).abs() < 1e-9);
    assert!(r.gaps.is_empty());
    assert!(r.saturation.iter().all(|s| s.count == 0));
    assert!(
        (r.static_force.ratio_to_g - 1.0).abs() < 0.01,
        "{:?}",
        r.static_force
    );
    // The first record, by hand from the files' first rows and the profile's nominal values.
    let first = &imported.imu.records[0];
    assert_eq!(first.t, 0.02984);
    assert!((first.accel[2] - (36429.0 - 32360.0) / 415.0).abs() < 1e-12);
    assert!((first.gyro[0] - (32786.0 - 32768.0) / 4778.0).abs() < 1e-12);

    let seg = segment(&imported.imu, &DetectorSettings::default()).unwrap();
    let s = &seg.static_intervals;
    assert_eq!(s.len(), 38, "{s:#?}");
    assert_eq!(s[0].first_record, 0);
    assert!((50.0..53.0).contains(&s[0].duration_s), "{:?}", s[0]);
    for x in &s[1..] {
        assert!((3.5..12.0).contains(&x.duration_s), "{x:?}");
    }
    for x in s {
        assert!((9.70..9.95).contains(&x.norm_f_m_s2), "{x:?}");
    }
    assert!(seg.gaps.is_empty());
    assert_eq!(seg.motion.len(), 38);
}

#[test]
fn xsens_count_is_stable_around_the_defaults() {
    let imported = import("xsens_mti.toml", "xsens-stable");
    let d = DetectorSettings::default();
    for settings in [
        DetectorSettings { window_s: 0.5, ..d },
        DetectorSettings {
            max_std_f_m_s2: 0.05,
            max_std_w_rad_s: 0.03,
            ..d
        },
        DetectorSettings {
            max_std_f_m_s2: 0.2,
            max_std_w_rad_s: 0.1,
            ..d
        },
        DetectorSettings {
            min_duration_s: 1.0,
            ..d
        },
    ] {
        let seg = segment(&imported.imu, &settings).unwrap();
        assert_eq!(seg.static_intervals.len(), 38, "{settings:?}");
    }
}

#[test]
fn ferraris_import_reproduces_its_sections() {
    let imported = import("ferraris_session.toml", "ferraris-sections");
    assert_eq!(imported.report.records, 10376);
    assert_eq!(imported.imu.records[540].t, 540.0 / 102.4);
    let sections = imported.sections.as_ref().expect("sections");
    let list: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../data/real/ferraris_session/example_ferraris_session_list.json"),
        )
        .unwrap(),
    )
    .unwrap();
    let names: Vec<&str> = sections.sections.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "x_p", "x_a", "y_p", "y_a", "z_p", "z_a", "x_rot", "y_rot", "z_rot"
        ]
    );
    for s in &sections.sections {
        let start = list[&s.name]["start"].as_u64().unwrap() as usize;
        let end = list[&s.name]["end"].as_u64().unwrap() as usize;
        assert_eq!((s.source_start, s.source_end), (start, end));
        assert_eq!((s.first_record, s.last_record), (start, end - 1));
        assert_eq!(s.start_s, start as f64 / 102.4);
        assert_eq!(s.end_s, (end - 1) as f64 / 102.4);
        match s.kind {
            SectionKind::Static => {
                // The face's axis carries the specific force (SOURCE.md: |a| 9.23 to 10.48).
                let up = s.up.unwrap();
                let along: f64 = (0..3).map(|k| up[k] * s.mean_f_m_s2[k]).sum();
                assert!((9.2..10.5).contains(&along), "{s:?}");
            }
            SectionKind::Rotation => {
                assert_eq!(s.expected_turn_deg, Some(-360.0));
            }
        }
    }
    // SOURCE.md: the raw gyro integrates to -371.9, -354.8 and -359.2 degrees.
    for (name, turn) in [("x_rot", -371.9), ("y_rot", -354.8), ("z_rot", -359.2)] {
        let m = sections.get(name).unwrap().measured_turn_deg.unwrap();
        assert!((m - turn).abs() < 0.05, "{name}: {m}");
    }
    assert_eq!(sections.get("y_a").unwrap().up, Some([0.0, -1.0, 0.0]));
    assert_eq!(sections.get("z_rot").unwrap().axis, Some([0.0, 0.0, 1.0]));
}

#[test]
fn ferraris_static_faces_lie_within_detected_intervals() {
    let imported = import("ferraris_session.toml", "ferraris-faces");
    let sections = imported.sections.as_ref().unwrap();
    let seg = segment(&imported.imu, &DetectorSettings::default()).unwrap();
    let s = &seg.static_intervals;
    assert_eq!(s.len(), 13, "{s:#?}");
    for x in &sections.sections {
        let holding = s
            .iter()
            .filter(|i| i.first_record <= x.first_record && x.last_record <= i.last_record)
            .count();
        let touching = s
            .iter()
            .filter(|i| i.first_record <= x.last_record && x.first_record <= i.last_record)
            .count();
        match x.kind {
            SectionKind::Static => assert_eq!(holding, 1, "{} not within one interval", x.name),
            SectionKind::Rotation => assert_eq!(touching, 0, "{} touches rest", x.name),
        }
    }
}
