//! `sins-calib apply`: the Ferraris session calibrated and corrected (the acceptance
//! test), the file form kept, and the refusals.

use crate::common::{self, BIN, s, text};
use calib::io::{ImuKind, read_imu_csv, read_result_json};
use calib::model::correction::{Correction, ExtensionInputs, correct_records};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-apply", name)
}

fn ok(args: &[&str]) -> Output {
    let o = Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
    o
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("file")).expect("JSON")
}

fn index(v: &serde_json::Value, key: &str) -> usize {
    v[key].as_u64().unwrap_or_else(|| panic!("{key} in {v}")) as usize
}

/// The Ferraris session, calibrated with `calibrate --free-motion` and corrected with `apply`:
/// its three hand-made turns integrate to 360 deg within 1.5 deg, and the `|f| - g` RMS of its
/// six static faces is at most 0.005 m/s^2.
#[test]
fn ferraris_corrected_turns_and_static_faces() {
    let dir = scratch("ferraris");
    let profile =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/ferraris_session.toml");
    ok(&["import", "--profile", s(&profile), "--out", s(&dir)]);
    let (imu, sections) = (dir.join("imu.csv"), dir.join("sections.json"));
    let (result, segments, corrected) = (
        dir.join("r.json"),
        dir.join("seg.json"),
        dir.join("corrected.csv"),
    );
    ok(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--sections",
        s(&sections),
        "--free-motion",
        "--json",
        s(&result),
    ]);
    ok(&["segment", "--imu", s(&imu), "--json", s(&segments)]);
    let out = ok(&[
        "apply",
        "--calibration",
        s(&result),
        "--imu",
        s(&imu),
        "--out",
        s(&corrected),
    ]);
    assert!(
        text(&out.stdout).contains("10376 records (rates)"),
        "{}",
        text(&out.stdout)
    );

    let r = json(&result);
    let n = r["parameters"].as_array().expect("parameters").len();
    let corr = r["correlation"].as_array().expect("correlation");
    assert_eq!(corr.len(), n);
    assert!(
        corr.iter()
            .enumerate()
            .all(|(i, row)| row[i] == 1.0 && row.as_array().unwrap().len() == n)
    );
    // The filter models the terms on the true specific force and rate.
    assert_eq!(r["correction"]["extension_inputs"], "corrected");
    let g = r["free_motion"]["gravity_m_s2"].as_f64().expect("gravity");

    let raw = read_imu_csv(&imu).expect("imu");
    let cor = read_imu_csv(&corrected).expect("corrected");
    assert_eq!(cor.kind, ImuKind::Rates);
    assert_eq!(cor.records.len(), raw.records.len());
    assert!(
        cor.records
            .iter()
            .zip(&raw.records)
            .all(|(a, b)| a.t == b.t)
    );

    // The turns of the section list, widened to the motion between the static intervals
    // around them (as the calibration does), integrated about their axis.
    let rests: Vec<(usize, usize)> = json(&segments)["static"]
        .as_array()
        .expect("static")
        .iter()
        .map(|v| (index(v, "first_record"), index(v, "last_record")))
        .collect();
    let list = json(&sections)["sections"]
        .as_array()
        .expect("sections")
        .clone();
    let fitted: Vec<f64> = r["free_motion"]["turns"]
        .as_array()
        .expect("turns")
        .iter()
        .map(|t| t["after_deg"].as_f64().expect("after_deg"))
        .collect();
    let mut turns = Vec::new();
    for sec in list.iter().filter(|v| v["kind"] == "rotation") {
        let (a, b) = (index(sec, "first_record"), index(sec, "last_record"));
        let lo = rests
            .iter()
            .filter(|iv| iv.1 < a)
            .map(|iv| iv.1 + 1)
            .next_back()
            .unwrap_or(a);
        let hi = rests.iter().find(|iv| iv.0 > b).map_or(b, |iv| iv.0);
        let axis = Vector3::from_fn(|i, _| sec["axis"][i].as_f64().expect("axis"));
        let angle = |d: &calib::io::ImuData| -> f64 {
            (lo..=hi)
                .map(|k| {
                    axis.dot(&Vector3::from(d.records[k].gyro))
                        * (d.records[k].t - d.records[k - 1].t)
                })
                .sum::<f64>()
                .to_degrees()
        };
        let expected = sec["expected_turn_deg"].as_f64().expect("expected");
        println!(
            "{}: raw {:.3} deg, corrected {:.3} deg, expected {expected}",
            sec["name"],
            angle(&raw),
            angle(&cor)
        );
        turns.push((angle(&cor), expected));
    }
    assert_eq!(turns.len(), 3);
    for ((got, expected), fit) in turns.iter().zip(&fitted) {
        assert!(
            (got - expected).abs() <= 1.5,
            "turn {got} deg, expected {expected}"
        );
        // The fit's turn figures integrate the records `apply` writes (the same correction,
        // calib::motion::free_motion::evaluate) over the same records (the rests after the
        // turns begin on a stamp: equal to the last bit on this session).
        assert!((got - fit).abs() < 1e-9, "turn {got} deg, the fit's {fit}");
    }

    // The static faces of the section list: |mean f| - g.
    let faces: Vec<(usize, usize)> = list
        .iter()
        .filter(|v| v["kind"] == "static")
        .map(|v| (index(v, "first_record"), index(v, "last_record")))
        .collect();
    assert_eq!(faces.len(), 6);
    let rms = |d: &calib::io::ImuData| -> f64 {
        let sq: f64 = faces
            .iter()
            .map(|&(a, b)| {
                let m = (a..=b)
                    .map(|k| Vector3::from(d.records[k].accel))
                    .sum::<Vector3<f64>>()
                    / (b - a + 1) as f64;
                (m.norm() - g).powi(2)
            })
            .sum();
        (sq / faces.len() as f64).sqrt()
    };
    let (before, after) = (rms(&raw), rms(&cor));
    println!("static faces |f| - g RMS: raw {before:.5} m/s^2, corrected {after:.5} m/s^2");
    assert!(after <= 0.005, "{after}");
    assert!(after < 0.1 * before, "{before} -> {after}");
}

/// A rates file with a temp column: the same columns, time stamps and temperatures out, the
/// values those of the library's correction; increments from `simulate` likewise.
#[test]
fn keeps_the_form_and_matches_the_library() {
    let dir = scratch("form");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let cfg = dir.join("run.toml");
    let t = std::fs::read_to_string(example).expect("example");
    std::fs::write(&cfg, t.replace("# duration_s = 600.0", "duration_s = 20.0")).expect("config");
    ok(&["simulate", "--config", s(&cfg), "--out", s(&dir)]);
    let truth = dir.join("truth.json");
    let result = read_result_json(&truth).expect("truth");
    let c = Correction::from_parameters(&result.parameters, ExtensionInputs::True)
        .expect("truth parameters");

    // Increments as simulated.
    let (imu, out) = (dir.join("imu.csv"), dir.join("corrected.csv"));
    ok(&[
        "apply",
        "--calibration",
        s(&truth),
        "--imu",
        s(&imu),
        "--out",
        s(&out),
    ]);
    let raw = read_imu_csv(&imu).expect("imu");
    let got = read_imu_csv(&out).expect("out");
    let header = std::fs::read_to_string(&out).expect("out");
    assert!(
        header.starts_with("t,dthx,dthy,dthz,dvx,dvy,dvz\n"),
        "{}",
        &header[..40]
    );
    assert_eq!(
        got.records,
        correct_records(&c, raw.kind, &raw.records).expect("library")
    );

    // Rates with a temperature, columns in another order.
    let mut text_in = String::from("fz,t,wx,wy,wz,fx,fy,temp\n");
    for (k, r) in raw.records.iter().take(50).enumerate() {
        let dt = 0.01;
        text_in += &format!(
            "{},{},{},{},{},{},{},{}\n",
            r.accel[2] / dt,
            r.t,
            r.gyro[0] / dt,
            r.gyro[1] / dt,
            r.gyro[2] / dt,
            r.accel[0] / dt,
            r.accel[1] / dt,
            20.0 + 0.01 * k as f64
        );
    }
    let (rates, rates_out) = (dir.join("rates.csv"), dir.join("rates_corrected.csv"));
    std::fs::write(&rates, text_in).expect("rates");
    ok(&[
        "apply",
        "--calibration",
        s(&truth),
        "--imu",
        s(&rates),
        "--out",
        s(&rates_out),
    ]);
    let raw = read_imu_csv(&rates).expect("rates");
    let got = read_imu_csv(&rates_out).expect("out");
    assert_eq!(got.kind, ImuKind::Rates);
    assert!(
        std::fs::read_to_string(&rates_out)
            .unwrap()
            .starts_with("t,wx,wy,wz,fx,fy,fz,temp\n")
    );
    assert!(
        got.records
            .iter()
            .zip(&raw.records)
            .all(|(a, b)| a.t == b.t && a.temp == b.temp && a.temp.is_some())
    );
    assert_eq!(
        got.records,
        correct_records(&c, raw.kind, &raw.records).expect("library")
    );
    assert_ne!(got.records[3].gyro, raw.records[3].gyro);
}

#[test]
fn refusals_name_the_file_and_leave_nothing_behind() {
    let dir = scratch("refusals");
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let cfg = dir.join("run.toml");
    let t = std::fs::read_to_string(example).expect("example");
    std::fs::write(&cfg, t.replace("# duration_s = 600.0", "duration_s = 5.0")).expect("config");
    ok(&["simulate", "--config", s(&cfg), "--out", s(&dir)]);
    let (imu, truth, out) = (
        dir.join("imu.csv"),
        dir.join("truth.json"),
        dir.join("out.csv"),
    );
    let fails = |args: &[&str], needles: &[&str]| {
        let o = Command::new(BIN).args(args).output().expect("runs");
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        let e = text(&o.stderr);
        for n in needles {
            assert!(e.contains(n), "{args:?}: `{n}` not in {e}");
        }
        assert!(!out.exists(), "{args:?} left {}", out.display());
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
    };
    // --out is the --imu file, also spelled differently.
    let same = dir.join(".").join("imu.csv");
    fails(
        &[
            "apply",
            "--calibration",
            s(&truth),
            "--imu",
            s(&imu),
            "--out",
            s(&same),
        ],
        &["--out is the --imu file"],
    );
    fails(
        &[
            "apply",
            "--calibration",
            s(&truth),
            "--imu",
            s(&imu),
            "--out",
            s(&truth),
        ],
        &["--out is the --calibration file"],
    );
    assert!(read_result_json(&truth).is_ok());
    // A calibration marked as not fitting its data: refused, unless asked for.
    let mut v = json(&truth);
    v["verdict"] = serde_json::json!({
        "fits": false, "exit_status": 3, "reasons": ["held-out rests: scatter 135 times"]
    });
    let misfit = dir.join("misfit.json");
    std::fs::write(&misfit, serde_json::to_string(&v).unwrap()).unwrap();
    fails(
        &[
            "apply",
            "--calibration",
            s(&misfit),
            "--imu",
            s(&imu),
            "--out",
            s(&out),
        ],
        &[
            "\"fits\": false",
            "held-out rests: scatter 135 times",
            "--accept-misfit",
        ],
    );
    ok(&[
        "apply",
        "--calibration",
        s(&misfit),
        "--imu",
        s(&imu),
        "--out",
        s(&out),
        "--accept-misfit",
    ]);
    std::fs::remove_file(&out).unwrap();
    // Unknown and incomplete parameters.
    let mut v = json(&truth);
    v["parameters"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"name": "gyro.wobble.x", "value": 0.0, "unit": "1"}));
    let unknown = dir.join("unknown.json");
    std::fs::write(&unknown, v.to_string()).unwrap();
    fails(
        &[
            "apply",
            "--calibration",
            s(&unknown),
            "--imu",
            s(&imu),
            "--out",
            s(&out),
        ],
        &[s(&unknown), "`gyro.wobble.x`", "expected"],
    );
    let mut v = json(&truth);
    v["parameters"]
        .as_array_mut()
        .unwrap()
        .retain(|p| p["name"] != "gyro.theta.xy");
    let incomplete = dir.join("incomplete.json");
    std::fs::write(&incomplete, v.to_string()).unwrap();
    fails(
        &[
            "apply",
            "--calibration",
            s(&incomplete),
            "--imu",
            s(&imu),
            "--out",
            s(&out),
        ],
        &[s(&incomplete), "gyro.theta.xy", "missing"],
    );
    let mut v = json(&truth);
    v["parameters"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"name": "accel.k2.x", "value": 1e-5, "unit": "1/(m/s^2)"}));
    let partial = dir.join("partial.json");
    std::fs::write(&partial, v.to_string()).unwrap();
    fails(
        &[
            "apply",
            "--calibration",
            s(&partial),
            "--imu",
            s(&imu),
            "--out",
            s(&out),
        ],
        &[s(&partial), "accel_quadratic", "accel.k2.y"],
    );
    // Terms too large to invert for these records: the first record's line is named.
    let mut v = json(&truth);
    for a in ["x", "y", "z"] {
        v["parameters"].as_array_mut().unwrap().push(
            serde_json::json!({"name": format!("accel.k2.{a}"), "value": 1.0, "unit": "1/(m/s^2)"}),
        );
    }
    let huge = dir.join("huge.json");
    std::fs::write(&huge, v.to_string()).unwrap();
    fails(
        &[
            "apply",
            "--calibration",
            s(&huge),
            "--imu",
            s(&imu),
            "--out",
            s(&out),
        ],
        &[s(&imu), "line 2", "do not settle"],
    );
    // A bad record in the middle: the line is named, no output is left.
    let good = std::fs::read_to_string(&imu).unwrap();
    let mut lines: Vec<&str> = good.lines().collect();
    lines[100] = "0.999,1,2,3,4,5,NaN";
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    fails(
        &[
            "apply",
            "--calibration",
            s(&truth),
            "--imu",
            s(&bad),
            "--out",
            s(&out),
        ],
        &[s(&bad), "line 101"],
    );
}
