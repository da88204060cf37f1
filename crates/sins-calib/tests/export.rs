//! `sins-calib export`: the imu_tk and OpenVINS files, read back and applied by those tools'
//! own equations (written out here from their sources) to raw records, give what `apply`
//! gives; the Kalibr file parses as YAML with the noise file's levels converted; the refusals.

use crate::common::{self, BIN, s, text};
use calib::io::read_imu_csv;
use nalgebra::{Matrix3, Vector3};
use serde_json::{Value, json};
use sins_model::units::DEG_PER_HOUR;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-export", name)
}

fn ok(args: &[&str]) -> Output {
    let o = Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs");
    assert!(o.status.success(), "{args:?}: {}", text(&o.stderr));
    o
}

/// Exit status 1 with every needle in the message, and no output file `out`.
fn refused(args: &[&str], needles: &[&str], out: &Path) {
    let o = Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs");
    assert_eq!(o.status.code(), Some(1), "{args:?}: {}", text(&o.stdout));
    let e = text(&o.stderr);
    for n in needles {
        assert!(e.contains(n), "{args:?}: `{n}` not in {e}");
    }
    assert!(!out.exists(), "{args:?} wrote {}", out.display());
}

fn json_of(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("file")).expect("JSON")
}

/// A 20-s simulated run of the example configuration: its truth (the calibration) and its
/// records as rates (`rates.csv`: the raw records `apply` and the other tools' models correct).
fn simulated_run(dir: &Path) -> (PathBuf, PathBuf) {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let cfg = dir.join("run.toml");
    let t = std::fs::read_to_string(example).expect("example");
    std::fs::write(&cfg, t.replace("# duration_s = 600.0", "duration_s = 20.0")).expect("config");
    ok(&["simulate", "--config", s(&cfg), "--out", s(dir)]);
    let raw = read_imu_csv(&dir.join("imu.csv")).expect("imu");
    let mut rates = String::from("t,wx,wy,wz,fx,fy,fz\n");
    let mut t_before = 0.0;
    for r in &raw.records {
        let dt = r.t - t_before;
        t_before = r.t;
        let v: Vec<String> = r
            .gyro
            .iter()
            .chain(&r.accel)
            .map(|x| (x / dt).to_string())
            .collect();
        rates += &format!("{},{}\n", r.t, v.join(","));
    }
    let path = dir.join("rates.csv");
    std::fs::write(&path, rates).expect("rates");
    (dir.join("truth.json"), path)
}

/// `apply`'s correction of `rates` with `calibration`: (raw, corrected) per record, as
/// (gyro, accel) vectors.
fn applied(dir: &Path, calibration: &Path, rates: &Path) -> Vec<[Vector3<f64>; 4]> {
    let out = dir.join("corrected.csv");
    let _ = std::fs::remove_file(&out);
    ok(&[
        "apply",
        "--calibration",
        s(calibration),
        "--imu",
        s(rates),
        "--out",
        s(&out),
    ]);
    let raw = read_imu_csv(rates).expect("rates");
    let cor = read_imu_csv(&out).expect("corrected");
    assert_eq!(raw.records.len(), cor.records.len());
    raw.records
        .iter()
        .zip(&cor.records)
        .map(|(r, c)| {
            [
                Vector3::from(r.gyro),
                Vector3::from(r.accel),
                Vector3::from(c.gyro),
                Vector3::from(c.accel),
            ]
        })
        .collect()
}

/// `|got - want| <= 1e-12 |want|` for every record.
fn assert_close(got: &Vector3<f64>, want: &Vector3<f64>, what: &str) {
    let e = (got - want).norm();
    assert!(
        e <= 1e-12 * want.norm(),
        "{what}: {got:?} against apply's {want:?}: relative error {:e}",
        e / want.norm()
    );
}

/// A 3x3 matrix of YAML rows.
fn yaml_matrix(v: &serde_norway::Value) -> Matrix3<f64> {
    let rows = v.as_sequence().expect("rows");
    assert_eq!(rows.len(), 3);
    Matrix3::from_fn(|i, j| {
        let row = rows[i].as_sequence().expect("row");
        assert_eq!(row.len(), 3);
        row[j].as_f64().expect("number")
    })
}

fn yaml_vector(v: &serde_norway::Value) -> Vector3<f64> {
    let a = v.as_sequence().expect("vector");
    Vector3::from_fn(|i, _| a[i].as_f64().expect("number"))
}

/// imu_tk's `CalibratedTriad_::load`: T, K (3x3, row-major) and B (3), whitespace-separated.
fn imu_tk_load(path: &Path) -> (Matrix3<f64>, Matrix3<f64>, Vector3<f64>) {
    let text = std::fs::read_to_string(path).expect("calib file");
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|x| x.parse().expect("a number"))
        .collect();
    assert_eq!(v.len(), 21, "{text}");
    (
        Matrix3::from_row_slice(&v[0..9]),
        Matrix3::from_row_slice(&v[9..18]),
        Vector3::from_row_slice(&v[18..21]),
    )
}

/// imu_tk's `unbiasNormalize` (`X' = T K (X - B)`) on the raw records is `apply`'s output.
#[test]
fn imu_tk_files_give_applys_correction() {
    let dir = scratch("imu_tk");
    let (truth, rates) = simulated_run(&dir);
    let prefix = dir.join("unit");
    let o = ok(&[
        "export",
        "--to",
        "imu-tk",
        "--calibration",
        s(&truth),
        "--out",
        s(&prefix),
    ]);
    assert!(
        text(&o.stdout).contains("unit_gyro.calib"),
        "{}",
        text(&o.stdout)
    );
    let (ta, ka, ba) = imu_tk_load(&dir.join("unit_acc.calib"));
    let (tg, kg, bg) = imu_tk_load(&dir.join("unit_gyro.calib"));
    for (t, k) in [(&ta, &ka), (&tg, &kg)] {
        assert_eq!(t.diagonal(), Vector3::repeat(1.0));
        assert_eq!(*k, Matrix3::from_diagonal(&k.diagonal()));
    }
    let records = applied(&dir, &truth, &rates);
    assert!(records.len() > 1000);
    for [w_raw, f_raw, w, f] in &records {
        assert_close(&(tg * kg * (w_raw - bg)), w, "imu_tk gyro");
        assert_close(&(ta * ka * (f_raw - ba)), f, "imu_tk accelerometer");
    }
}

/// OpenVINS's propagation (`ov_msckf` Propagator, `model: "kalibr"`): `Dw = Tw^-1`,
/// `Da = Ta^-1` of which only the lower triangle is kept (`State::Dm`),
/// `a = R_ACCtoIMU Da (a_m - b_a)`, `w = R_GYROtoIMU Dw (w_m - b_g - Tg a)`, with the
/// rotations the transposes of the file's `R_IMUto*`; on the raw records it is `apply`'s
/// output, g-sensitivity included.
#[test]
fn openvins_file_gives_applys_correction() {
    let dir = scratch("openvins");
    let (truth, rates) = simulated_run(&dir);
    let noise = static_noise(&dir);
    // The truth with a g-sensitivity, which OpenVINS holds as Tg.
    let mut v = json_of(&truth);
    let gsens = [
        3e-6, -1e-6, 2e-6, 0.5e-6, -4e-6, 1e-6, -2e-6, 1.5e-6, 2.5e-6,
    ];
    for (k, name) in ["xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"]
        .iter()
        .enumerate()
    {
        v["parameters"].as_array_mut().unwrap().push(json!({
            "name": format!("gyro.gsens.{name}"), "value": gsens[k], "sigma": 1e-7,
            "unit": "rad/s/(m/s^2)"
        }));
    }
    let calibration = dir.join("with_gsens.json");
    std::fs::write(&calibration, v.to_string()).unwrap();
    let out = dir.join("kalibr_imu_chain.yaml");
    ok(&[
        "export",
        "--to",
        "openvins",
        "--noise",
        s(&noise),
        "--allow-unchecked",
        "--calibration",
        s(&calibration),
        "--out",
        s(&out),
    ]);
    let text_out = std::fs::read_to_string(&out).unwrap();
    let body = text_out
        .strip_prefix("%YAML:1.0\n")
        .expect("OpenVINS's first line");
    let y: serde_norway::Value = serde_norway::from_str(body).expect("YAML");
    let imu = &y["imu0"];
    assert_eq!(imu["model"].as_str(), Some("kalibr"));
    let lower = |m: Matrix3<f64>| m.lower_triangle();
    let dw = lower(yaml_matrix(&imu["Tw"]).try_inverse().unwrap());
    let da = lower(yaml_matrix(&imu["Ta"]).try_inverse().unwrap());
    let r_gyro_to_imu = yaml_matrix(&imu["R_IMUtoGYRO"]).transpose();
    let r_acc_to_imu = yaml_matrix(&imu["R_IMUtoACC"]).transpose();
    let tg = yaml_matrix(&imu["Tg"]);
    assert!(
        (r_gyro_to_imu.transpose() * r_gyro_to_imu - Matrix3::identity())
            .abs()
            .max()
            < 1e-15
    );
    assert!(tg.abs().max() > 0.0);
    let b_g = yaml_vector(&imu["sins_calib_bias_g"]);
    let b_a = yaml_vector(&imu["sins_calib_bias_a"]);
    for [w_m, a_m, w, f] in &applied(&dir, &calibration, &rates) {
        let a = r_acc_to_imu * da * (a_m - b_a);
        let w_hat = r_gyro_to_imu * dw * (w_m - b_g - tg * a);
        assert_close(&a, f, "OpenVINS accelerometer");
        assert_close(&w_hat, w, "OpenVINS gyro");
    }
}

/// A 120-s static simulated recording's `noise --json` (too short to tell a bias walk: the
/// exports of it are asked for with `--allow-unchecked`).
fn static_noise(dir: &Path) -> PathBuf {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/static-4h.toml");
    let t = std::fs::read_to_string(example).expect("example");
    let cfg = dir.join("static.toml");
    let program =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/static-4h.program.toml");
    std::fs::write(
        &cfg,
        t.replace("# duration_s = 600.0", "duration_s = 120.0")
            .replace("\"static-4h.program.toml\"", &format!("{:?}", s(&program))),
    )
    .expect("config");
    let rec = dir.join("static");
    ok(&["simulate", "--config", s(&cfg), "--out", s(&rec)]);
    let noise = dir.join("noise.json");
    ok(&[
        "noise",
        "--imu",
        s(&rec.join("imu.csv")),
        "--all-at-rest",
        "--json",
        s(&noise),
    ]);
    noise
}

/// Kalibr's `imu.yaml` parses as YAML; its figures are the noise file's largest axis,
/// converted: deg/h at 1 Hz to rad/s/sqrt(Hz), deg/h/sqrt(h) to rad/s^2/sqrt(Hz).
#[test]
fn kalibr_file_holds_the_noise_files_levels() {
    let dir = scratch("kalibr");
    let noise = static_noise(&dir);
    let out = dir.join("imu.yaml");
    ok(&[
        "export",
        "--to",
        "kalibr",
        "--noise",
        s(&noise),
        "--allow-unchecked",
        "--out",
        s(&out),
        "--rostopic",
        "/sensors/imu",
    ]);
    let y: serde_norway::Value =
        serde_norway::from_str(&std::fs::read_to_string(&out).unwrap()).expect("YAML");
    let n = json_of(&noise);
    let max = |sensor: &str, key: &str| -> f64 {
        n[sensor][key]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .fold(f64::MIN, f64::max)
    };
    let expected = [
        (
            "gyroscope_noise_density",
            max("gyro", "white_deg_h") * DEG_PER_HOUR,
        ),
        (
            "gyroscope_random_walk",
            max("gyro", "bias_walk_deg_h_sqrt_h") * DEG_PER_HOUR / 60.0,
        ),
        ("accelerometer_noise_density", max("accel", "white_m_s2")),
        (
            "accelerometer_random_walk",
            max("accel", "bias_walk_m_s2_sqrt_s"),
        ),
    ];
    for (key, want) in expected {
        let got = y[key].as_f64().unwrap_or_else(|| panic!("{key}"));
        assert!(
            want > 0.0 && (got - want).abs() <= 1e-15 * want,
            "{key}: {got} against {want}"
        );
    }
    // The gyro white level of the configuration: 0.1 deg/h at 1 Hz, 4.85e-7 rad/s/sqrt(Hz).
    let g = y["gyroscope_noise_density"].as_f64().unwrap();
    assert!((g / (0.1 * DEG_PER_HOUR) - 1.0).abs() < 0.05, "{g}");
    assert_eq!(y["update_rate"].as_f64(), Some(100.0));
    assert_eq!(y["rostopic"].as_str(), Some("/sensors/imu"));
}

#[test]
fn refusals_name_the_cause_and_write_nothing() {
    let dir = scratch("refusals");
    let (truth, _) = simulated_run(&dir);
    let noise = static_noise(&dir);
    let out = dir.join("out.yaml");
    // A 120-s recording cannot tell a bias walk: not written unless asked (--allow-unchecked,
    // which the other cases here give).
    refused(
        &[
            "export",
            "--to",
            "kalibr",
            "--noise",
            s(&noise),
            "--out",
            s(&out),
        ],
        &["is not determined", "--allow-unchecked"],
        &out,
    );
    // Missing and superfluous inputs.
    refused(
        &[
            "export",
            "--to",
            "openvins",
            "--noise",
            s(&noise),
            "--allow-unchecked",
            "--out",
            s(&out),
        ],
        &["--calibration FILE"],
        &out,
    );
    refused(
        &[
            "export",
            "--to",
            "kalibr",
            "--noise",
            s(&noise),
            "--allow-unchecked",
            "--calibration",
            s(&truth),
            "--out",
            s(&out),
        ],
        &["no place for a calibration"],
        &out,
    );
    // A calibration whose data contradicted its model.
    let mut v = json_of(&truth);
    v["verdict"] = json!({"fits": false, "exit_status": 3, "reasons": ["mean NIS 4.1"]});
    let misfit = dir.join("misfit.json");
    std::fs::write(&misfit, v.to_string()).unwrap();
    let prefix = dir.join("tk");
    let acc = dir.join("tk_acc.calib");
    refused(
        &[
            "export",
            "--to",
            "imu-tk",
            "--calibration",
            s(&misfit),
            "--out",
            s(&prefix),
        ],
        &["\"fits\": false", "mean NIS 4.1", "--accept-misfit"],
        &acc,
    );
    ok(&[
        "export",
        "--to",
        "imu-tk",
        "--calibration",
        s(&misfit),
        "--out",
        s(&prefix),
        "--accept-misfit",
    ]);
    std::fs::remove_file(&acc).unwrap();
    // A term imu_tk cannot hold.
    let mut v = json_of(&truth);
    for a in ["x", "y", "z"] {
        v["parameters"].as_array_mut().unwrap().push(json!({
            "name": format!("gyro.asym.{a}"), "value": 1e-5, "sigma": 1e-6, "unit": "1"
        }));
    }
    let asym = dir.join("asym.json");
    std::fs::write(&asym, v.to_string()).unwrap();
    refused(
        &[
            "export",
            "--to",
            "imu-tk",
            "--calibration",
            s(&asym),
            "--out",
            s(&prefix),
        ],
        &[
            "cannot hold the scale asymmetry (gyro.asym)",
            "--drop-terms",
        ],
        &acc,
    );
    let o = ok(&[
        "export",
        "--to",
        "imu-tk",
        "--calibration",
        s(&asym),
        "--out",
        s(&prefix),
        "--drop-terms",
    ]);
    assert!(
        text(&o.stdout).contains("dropped (--drop-terms): the scale asymmetry"),
        "{}",
        text(&o.stdout)
    );
    // A noise figure that failed its check, and a Gauss-Markov bias.
    let mut v = json_of(&noise);
    v["accel"]["ml"][1]["passes"] = json!(false);
    let unchecked = dir.join("unchecked.json");
    std::fs::write(&unchecked, v.to_string()).unwrap();
    refused(
        &[
            "export",
            "--to",
            "kalibr",
            "--noise",
            s(&unchecked),
            "--out",
            s(&out),
        ],
        &["accel y failed its check", "--allow-unchecked"],
        &out,
    );
    ok(&[
        "export",
        "--to",
        "kalibr",
        "--noise",
        s(&unchecked),
        "--out",
        s(&out),
        "--allow-unchecked",
    ]);
    // The file itself says what was let through.
    let written = std::fs::read_to_string(&out).unwrap();
    assert!(
        written.contains("# Note: the levels of accel y failed their check"),
        "{written}"
    );
    std::fs::remove_file(&out).unwrap();
    let mut v = json_of(&noise);
    v["gyro"]["ml"][2]["gauss_markov"] = json!(true);
    let gm = dir.join("gm.json");
    std::fs::write(&gm, v.to_string()).unwrap();
    refused(
        &[
            "export",
            "--to",
            "kalibr",
            "--noise",
            s(&gm),
            "--out",
            s(&out),
            "--allow-unchecked",
        ],
        &["gyro z has a Gauss-Markov bias", "--drop-terms"],
        &out,
    );
    // Not a noise file.
    refused(
        &[
            "export",
            "--to",
            "kalibr",
            "--noise",
            s(&truth),
            "--out",
            s(&out),
        ],
        &[s(&truth), "noise --json"],
        &out,
    );
}
