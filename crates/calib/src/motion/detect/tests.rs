//! The detector on small simulated recordings: rests around turns, noisy units, lost samples,
//! gaps, a constant-rate rotation, settings refused.

use super::*;

/// The detector on records given from memory at every reading, checked against the
/// segmentation the code gave before the detector had one implementation, to the last bit
/// (`crates/calib/tests/fixtures/segmentations/NAME.json`; how they were made: the README there).
fn detect_static(
    name: &str,
    t: &[f64],
    w: &[[f64; 3]],
    f: &[[f64; 3]],
    settings: &DetectorSettings,
) -> Result<Segmentation, String> {
    let seg = detect_static_streamed(
        &mut |visit| {
            for i in 0..t.len() {
                visit(t[i], w[i], f[i]);
            }
            Ok(())
        },
        None,
        settings,
    );
    if let Ok(s) = &seg {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/segmentations")
            .join(format!("{name}.json"));
        let before = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        let now = serde_json::to_string_pretty(s).unwrap() + "\n";
        assert!(now == before, "{name}: not the segmentation of {path:?}");
    }
    seg
}

/// 10 s at rest, 3 s turning, 10 s at rest, at 100 Hz.
fn synthetic() -> (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut t = Vec::new();
    let mut w = Vec::new();
    let mut f = Vec::new();
    for i in 0..2300 {
        let ti = i as f64 * 0.01;
        let moving = (10.0..13.0).contains(&ti);
        let a = if moving { (ti - 10.0) * 1.0 } else { 0.0 };
        let angle = if ti >= 13.0 { 3.0 } else { a };
        t.push(ti);
        w.push(if moving { [1.0, 0.0, 0.0] } else { [0.0; 3] });
        f.push([0.0, 9.81 * angle.sin(), 9.81 * angle.cos()]);
    }
    (t, w, f)
}

/// Six poses of 4 s joined by 1.5-s turns of 90 degrees about x at 200 Hz, with white noise
/// of `sigma_f` (m/s^2) and `sigma_w` (rad/s) per sample (a fixed pseudo-random stream).
fn noisy_poses(sigma_f: f64, sigma_w: f64) -> (Vec<f64>, Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut gauss = move || {
        // Box-Muller on a xorshift stream.
        let mut u = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (a, b) = (u(), u());
        (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
    };
    let (mut t, mut w, mut f) = (vec![], vec![], vec![]);
    let (rest, turn, dt) = (4.0, 1.5, 0.005);
    let rate = std::f64::consts::FRAC_PI_2 / turn;
    let n = ((6.0 * rest + 5.0 * turn) / dt) as usize;
    for i in 0..n {
        let ti = i as f64 * dt;
        let k = (ti / (rest + turn)).floor();
        let phase = ti - k * (rest + turn);
        let moving = phase >= rest && k < 5.0;
        let angle = rate * (k * turn + if moving { phase - rest } else { 0.0 });
        t.push(ti);
        let wx = if moving { rate } else { 0.0 };
        w.push([wx + sigma_w * gauss(), sigma_w * gauss(), sigma_w * gauss()]);
        f.push([
            sigma_f * gauss(),
            9.81 * angle.sin() + sigma_f * gauss(),
            9.81 * angle.cos() + sigma_f * gauss(),
        ]);
    }
    (t, w, f)
}

#[test]
fn a_noisy_units_rests_are_found_with_thresholds_from_its_noise() {
    // Accelerometer noise per sample at the fixed threshold (a consumer unit, 0.12 m/s^2).
    let (t, w, f) = noisy_poses(0.12, 0.01);
    let fixed = DetectorSettings {
        noise_factor: 0.0,
        ..DetectorSettings::default()
    };
    let s = detect_static("noisy_poses_fixed", &t, &w, &f, &fixed).unwrap();
    assert!(s.static_intervals.len() < 6, "{}", s.static_intervals.len());
    let s = detect_static(
        "noisy_poses_defaults",
        &t,
        &w,
        &f,
        &DetectorSettings::default(),
    )
    .unwrap();
    assert_eq!(s.static_intervals.len(), 6, "{s:?}");
    assert!((s.noise_floor_f_m_s2 / (0.12 * 3f64.sqrt()) - 1.0).abs() < 0.1);
    assert!(s.threshold_std_f_m_s2 > 0.3, "{}", s.threshold_std_f_m_s2);
    // No rest reaches into a turn.
    for r in &s.static_intervals {
        let k = (r.start_s / 5.5).floor();
        assert!(
            r.start_s >= k * 5.5 - 1e-9 && r.end_s <= k * 5.5 + 4.0 + 1e-9,
            "{r:?}"
        );
    }
}

#[test]
fn a_pose_that_lost_a_sample_is_one_interval() {
    let (mut t, mut w, mut f) = noisy_poses(0.01, 0.001);
    // Drop one sample in the middle of the third pose (t = 13 s).
    let k = t.iter().position(|&x| x >= 13.0).unwrap();
    t.remove(k);
    w.remove(k);
    f.remove(k);
    let s = detect_static(
        "lost_sample_defaults",
        &t,
        &w,
        &f,
        &DetectorSettings::default(),
    )
    .unwrap();
    assert_eq!(s.gaps.len(), 1);
    assert_eq!(s.static_intervals.len(), 6, "{:?}", s.static_intervals);
    let third = &s.static_intervals[2];
    assert!(third.start_s < 13.0 && third.end_s > 13.0, "{third:?}");
    // Without merging the pose is two runs of 1.5 s, each too short: the pose is lost.
    let split = DetectorSettings {
        merge_across_short_gaps: false,
        ..DetectorSettings::default()
    };
    let s = detect_static("lost_sample_unmerged", &t, &w, &f, &split).unwrap();
    assert_eq!(s.static_intervals.len(), 5, "{:?}", s.static_intervals);
}

#[test]
fn two_rests_around_a_turn() {
    let (t, w, f) = synthetic();
    let s = detect_static(
        "two_rests_defaults",
        &t,
        &w,
        &f,
        &DetectorSettings::default(),
    )
    .unwrap();
    assert_eq!(s.static_intervals.len(), 2, "{s:?}");
    let a = &s.static_intervals[0];
    assert!(a.start_s == 0.0 && (a.end_s - 9.5).abs() < 0.02, "{a:?}");
    assert!((a.norm_f_m_s2 - 9.81).abs() < 1e-9);
    let b = &s.static_intervals[1];
    assert!(
        (b.start_s - 13.5).abs() < 0.02 && b.last_record == 2299,
        "{b:?}"
    );
    assert_eq!(s.motion.len(), 1);
    assert_eq!(s.motion[0].first_record, a.last_record + 1);
    assert_eq!(s.motion[0].last_record, b.first_record - 1);
}

#[test]
fn constant_rate_rotation_about_the_vertical_is_not_rest() {
    let (t, _, f) = synthetic();
    let w = vec![[0.0, 0.0, 0.5]; t.len()];
    let f: Vec<[f64; 3]> = f.iter().map(|_| [0.0, 0.0, 9.81]).collect();
    let s = detect_static(
        "vertical_rotation_defaults",
        &t,
        &w,
        &f,
        &DetectorSettings::default(),
    )
    .unwrap();
    assert!(s.static_intervals.is_empty());
}

#[test]
fn static_intervals_end_at_gaps() {
    let (mut t, w, f) = synthetic();
    for x in t.iter_mut().skip(500) {
        *x += 0.5;
    }
    let s = detect_static("gap_defaults", &t, &w, &f, &DetectorSettings::default()).unwrap();
    assert_eq!(s.gaps.len(), 1);
    assert_eq!(s.static_intervals.len(), 3);
    assert_eq!(s.static_intervals[0].last_record, 499);
    assert_eq!(s.static_intervals[1].first_record, 500);
}

#[test]
fn bad_settings_are_named() {
    let (t, w, f) = synthetic();
    let settings = DetectorSettings {
        window_s: 0.0,
        ..Default::default()
    };
    let e = detect_static("bad_settings", &t, &w, &f, &settings).unwrap_err();
    assert!(e.contains("window_s"), "{e}");
}
