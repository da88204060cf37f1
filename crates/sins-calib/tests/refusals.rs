//! Input a lab will feed the program by mistake, each refused early, with the file, the line or
//! time, and the likely cause; and a fit that does not hold reported with its own exit status.

use crate::common::{self, run, s};
use std::path::{Path, PathBuf};
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-refusals", name)
}

/// `examples/run.toml` with `edit` applied, written into `dir`.
fn config(dir: &Path, edit: impl Fn(String) -> String) -> PathBuf {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let text = std::fs::read_to_string(example).expect("examples/run.toml");
    let path = dir.join("run.toml");
    std::fs::write(&path, edit(text)).expect("config");
    path
}

/// A 120-s simulated run in `dir`: (config, imu.csv, turntable.csv, truth.json).
fn short_run(dir: &Path) -> (PathBuf, PathBuf, PathBuf, PathBuf) {
    let cfg = config(dir, |t| {
        t.replace("# duration_s = 600.0", "duration_s = 120.0")
    });
    let out = run(&["simulate", "--config", s(&cfg), "--out", s(dir)]);
    assert!(out.status.success(), "{}", stderr(&out));
    (
        cfg,
        dir.join("imu.csv"),
        dir.join("turntable.csv"),
        dir.join("truth.json"),
    )
}

/// Rewrite every data row of a CSV with `f` (fields in, fields out).
fn rewrite(src: &Path, dst: &Path, f: impl Fn(usize, Vec<String>) -> Vec<String>) {
    let text = std::fs::read_to_string(src).expect("csv");
    let mut lines = text.lines();
    let mut out = String::from(lines.next().expect("header"));
    out.push('\n');
    for (i, l) in lines.enumerate() {
        out += &f(i, l.split(',').map(str::to_string).collect()).join(",");
        out.push('\n');
    }
    std::fs::write(dst, out).expect("write");
}

fn refused(o: &Output, file: &Path, needles: &[&str]) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains(s(file)),
        "the message does not name {}: {e}",
        file.display()
    );
    for n in needles {
        assert!(e.contains(n), "expected `{n}` in: {e}");
    }
    assert!(e.len() < 1000, "message too long ({} bytes)", e.len());
}

/// A change to one data row (index, fields).
type RowEdit = fn(usize, Vec<String>) -> Vec<String>;

#[test]
fn absurd_imu_data_are_refused_before_the_filter() {
    let dir = scratch("absurd");
    let (cfg, imu, _, _) = short_run(&dir);
    let cases: [(&str, &[&str], RowEdit); 5] = [
        ("zero_gyros.csv", &["gyros read at most"], |_, mut v| {
            for x in &mut v[1..4] {
                *x = "0".into();
            }
            v
        }),
        (
            "zero_accel.csv",
            &["accelerometers read zero"],
            |_, mut v| {
                for x in &mut v[4..7] {
                    *x = "0".into();
                }
                v
            },
        ),
        ("swapped.csv", &["swapped"], |_, v| {
            vec![
                v[0].clone(),
                v[4].clone(),
                v[5].clone(),
                v[6].clone(),
                v[1].clone(),
                v[2].clone(),
                v[3].clone(),
            ]
        }),
        ("huge.csv", &["line 502", "beyond any gyro"], |i, mut v| {
            if i == 500 {
                v[2] = "1e308".into();
            }
            v
        }),
        ("in_g.csv", &["in g, not m/s^2"], |_, mut v| {
            for x in &mut v[4..7] {
                *x = (x.parse::<f64>().unwrap() / 9.80665).to_string();
            }
            v
        }),
    ];
    for (name, needles, f) in cases {
        let bad = dir.join(name);
        rewrite(&imu, &bad, f);
        let o = run(&["calibrate", "--imu", s(&bad), "--config", s(&cfg)]);
        refused(&o, &bad, needles);
    }
}

#[test]
fn absurd_turntable_angles_are_refused_with_the_cause() {
    let dir = scratch("angles");
    let (cfg, imu, tt, _) = short_run(&dir);
    let radians = dir.join("radians.csv");
    rewrite(&tt, &radians, |_, v| {
        std::iter::once(v[0].clone())
            .chain(
                v[1..]
                    .iter()
                    .map(|x| x.parse::<f64>().unwrap().to_radians().to_string()),
            )
            .collect()
    });
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--turntable",
        s(&radians),
        "--config",
        s(&cfg),
    ]);
    refused(&o, &radians, &["radians"]);
    let constant = dir.join("constant.csv");
    rewrite(&tt, &constant, |_, v| {
        vec![v[0].clone(), "0".into(), "0".into(), "0".into()]
    });
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--turntable",
        s(&constant),
        "--config",
        s(&cfg),
    ]);
    refused(&o, &constant, &["constant angles"]);
    // A clock offset 0.3 s off: named, with the offset that would fit.
    let off = config(&dir, |t| {
        t.replace("# duration_s = 600.0", "duration_s = 120.0")
            .replace("turntable_offset_s = 12.5 ", "turntable_offset_s = 12.8 ")
    });
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--turntable",
        s(&tt),
        "--config",
        s(&off),
    ]);
    refused(&o, &tt, &["clock.turntable_offset_s = 12.5"]);
}

#[test]
fn malformed_files_are_refused_naming_the_line() {
    let dir = scratch("malformed");
    let (cfg, imu, _, truth) = short_run(&dir);
    let text = std::fs::read_to_string(&imu).unwrap();
    // A last line cut inside a number, without its line end.
    let cut = dir.join("cut.csv");
    std::fs::write(&cut, &text[..text.len() - 5]).unwrap();
    let o = run(&["calibrate", "--imu", s(&cut), "--config", s(&cfg)]);
    refused(&o, &cut, &["cut off"]);
    // A 10-MB field is not echoed whole.
    let huge = dir.join("huge_field.csv");
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[3] = format!("0.03,{},0,0,0,0,9.8", "7".repeat(10_000_000));
    std::fs::write(&huge, lines.join("\n") + "\n").unwrap();
    let o = run(&["calibrate", "--imu", s(&huge), "--config", s(&cfg)]);
    refused(&o, &huge, &["line 4", "bytes"]);
    // Non-UTF-8 bytes: the line is named.
    let mut bytes = text.clone().into_bytes();
    let at = text.match_indices('\n').nth(6).unwrap().0 + 3;
    bytes[at] = 0xff;
    let latin = dir.join("latin.csv");
    std::fs::write(&latin, bytes).unwrap();
    let o = run(&["calibrate", "--imu", s(&latin), "--config", s(&cfg)]);
    refused(&o, &latin, &["line 8", "UTF-8"]);
    // A truth file in other units, and one with a name twice.
    let json = std::fs::read_to_string(&truth).unwrap();
    let other = dir.join("truth_deg.json");
    std::fs::write(&other, json.replacen("\"rad/s\"", "\"deg/h\"", 1)).unwrap();
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--config",
        s(&cfg),
        "--truth",
        s(&other),
    ]);
    refused(&o, &other, &["expected `rad/s`"]);
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let first = v["parameters"][0].clone();
    v["parameters"].as_array_mut().unwrap().push(first);
    let twice = dir.join("truth_twice.json");
    std::fs::write(&twice, v.to_string()).unwrap();
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--config",
        s(&cfg),
        "--truth",
        s(&twice),
    ]);
    refused(&o, &twice, &["twice"]);
}

#[test]
fn bad_configurations_and_outputs_are_refused_up_front() {
    let dir = scratch("config");
    let (cfg, imu, _, _) = short_run(&dir);
    // --json into a missing directory: refused before any work.
    let missing = dir.join("no/such/dir/result.json");
    let o = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--config",
        s(&cfg),
        "--json",
        s(&missing),
    ]);
    refused(&o, &missing, &["does not exist"]);
    // Huge and empty simulations: refused, never an abort.
    for (edit, needle) in [
        ("duration_s = 1e12", "at most"),
        ("duration_s = 0.001", "at least"),
    ] {
        let c = config(&dir, |t| t.replace("# duration_s = 600.0", edit));
        let o = run(&["simulate", "--config", s(&c), "--out", s(&dir.join("sim"))]);
        refused(&o, &c, &[needle]);
    }
    let c = config(&dir, |t| {
        t.replace("latitude_deg = 55.7 ", "latitude_deg = 200 ")
    });
    refused(&run(&["analyse", "--config", s(&c)]), &c, &["latitude"]);
    let o = run(&["analyse", "--config", "paper-reconcilled"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("paper-reconciled") && e.contains("built-in"),
        "{e}"
    );
    let program = dir.join("still.toml");
    std::fs::write(
        &program,
        "name = \"still\"\nstart_deg = [0.0, 0.0, 0.0]\n[[segment]]\nkind = \"move\"\n\
         target_deg = [0.0, 0.0, 0.0]\nrate_deg_s = 10.0\n",
    )
    .unwrap();
    let c = config(&dir, |t| {
        t.replace(
            "program = \"paper\"",
            &format!("program = \"{}\"", s(&program)),
        )
    });
    refused(
        &run(&["analyse", "--config", s(&c)]),
        &program,
        &["only move to where"],
    );
}

#[test]
fn a_fit_outside_its_band_exits_with_status_3() {
    let dir = scratch("misfit");
    let (_, imu, _, _) = short_run(&dir);
    // The accelerometer noise configured three times too low.
    let low = config(&dir, |t| {
        t.replace("# duration_s = 600.0", "duration_s = 120.0")
            .replace("accel_m_s2 = 0.001 ", "accel_m_s2 = 0.0003 ")
    });
    let o = run(&["calibrate", "--imu", s(&imu), "--config", s(&low)]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{e}");
    assert!(e.contains("DOES NOT FIT"), "{e}");
    assert!(e.contains("specific force: mean NIS"), "{e}");
    // The report was written all the same.
    assert!(String::from_utf8_lossy(&o.stdout).contains("accel.bias.x"));
}
