//! The free-motion model's terms switched off one at a time on the two real recordings
//! (`docs/real-data.md`, "Cause of the gyro misfit"). Ignored by default: it needs the imported
//! recordings and their segments in `out/` (the commands of `docs/real-data.md`):
//!
//! ```sh
//! sins-calib import --profile examples/xsens_mti.toml --out out/xsens
//! sins-calib segment --imu out/xsens/imu.csv --json out/xsens/segments.json
//! sins-calib import --profile examples/ferraris_session.toml --out out/ferraris
//! sins-calib segment --imu out/ferraris/imu.csv --json out/ferraris/segments.json
//! cargo test --release -p calib --test integration free_motion_real:: -- --ignored --nocapture
//! ```

use calib::io::read_imu_csv;
use calib::motion::free_motion::{FreeMotionSettings, Interval, KnownTurn, calibrate_free_motion};
use std::path::{Path, PathBuf};

fn out(dir: &str, file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../out")
        .join(dir)
        .join(file)
}

fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e} (run the commands of the header)", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn index(v: &serde_json::Value, key: &str) -> usize {
    v[key].as_u64().unwrap_or_else(|| panic!("{key} in {v}")) as usize
}

fn intervals(dir: &str) -> Vec<Interval> {
    json(&out(dir, "segments.json"))["static"]
        .as_array()
        .expect("static")
        .iter()
        .map(|s| Interval {
            first_record: index(s, "first_record"),
            last_record: index(s, "last_record"),
        })
        .collect()
}

/// The rotations of `sections.json`, widened to the motion between the rests around them (as
/// `calibrate --free-motion` does).
fn turns(dir: &str, ivs: &[Interval]) -> Vec<KnownTurn> {
    let path = out(dir, "sections.json");
    if !path.exists() {
        return Vec::new();
    }
    json(&path)["sections"]
        .as_array()
        .expect("sections")
        .iter()
        .filter(|s| s["kind"] == "rotation")
        .map(|s| {
            let (a, b) = (index(s, "first_record"), index(s, "last_record"));
            let axis = s["axis"].as_array().expect("axis");
            KnownTurn {
                name: s["name"].as_str().expect("name").into(),
                first_record: ivs
                    .iter()
                    .filter(|iv| iv.last_record < a)
                    .map(|iv| iv.last_record + 1)
                    .next_back()
                    .unwrap_or(a),
                last_record: ivs
                    .iter()
                    .find(|iv| iv.first_record > b)
                    .map_or(b, |iv| iv.first_record),
                axis: [0, 1, 2].map(|k| axis[k].as_f64().expect("axis")),
                angle_rad: s["expected_turn_deg"].as_f64().expect("angle").to_radians(),
            }
        })
        .collect()
}

fn ablation(dir: &str, holdout: usize) {
    let data = read_imu_csv(&out(dir, "imu.csv")).expect("imu.csv");
    let ivs = intervals(dir);
    let turns = turns(dir, &ivs);
    let g = 9.806198;
    let variants: [(&str, bool, bool, bool); 5] = [
        ("all terms (default)", true, true, true),
        ("without scale-factor asymmetry", true, false, true),
        ("without g-sensitivity", false, true, true),
        ("without both (paper model)", false, false, true),
        ("paper model, bias from the first rest", false, false, false),
    ];
    println!("{dir}, every {holdout}-th interval held out");
    for (name, gsens, asym, all_rests) in variants {
        let mut s = FreeMotionSettings::new(g);
        s.holdout = Some(holdout);
        if !gsens {
            s.g_sensitivity_prior = None;
        }
        if !asym {
            s.scale_asymmetry_prior = None;
        }
        s.bias_from_all_intervals = all_rests;
        let r = calibrate_free_motion(&data, &ivs, &turns, &s).expect("calibration");
        let v = r.validation.expect("validation");
        let t: Vec<String> = r
            .turns
            .iter()
            .map(|t| format!("{:.2}", t.after_rad.to_degrees()))
            .collect();
        println!(
            "  {name:<40} chi2 {:7.3}  held-out rotation {:.3} -> {:.3} deg  turns [{}]",
            r.gyro_fit.reduced_chi2,
            v.rotation_rms_before_rad.to_degrees(),
            v.rotation_rms_after_rad.to_degrees(),
            t.join(", ")
        );
    }
}

#[test]
#[ignore = "needs the imported recordings in out/ (see the header)"]
fn terms_switched_off_on_the_real_recordings() {
    ablation("xsens", 4);
    ablation("ferraris", 2);
    ablation("ferraris", 3);
}
