//! The shipped recordings with the adaptive window and minimum: their rests are long enough for
//! the fixed 1-s window and 2-s minimum, which the defaults therefore keep, so the intervals are
//! those of the fixed settings, and the motion suggests no rest the detector missed.

mod common;

use calib::motion::detect::{DetectorSettings, Segmentation, Source, segment};
use common::import_to;
use import::ImportOptions;
use import::profile::Profile;
use std::path::Path;

fn segmented(profile_name: &str) -> (Segmentation, Segmentation) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(profile_name);
    let profile = Profile::load(&path).expect("shipped profile");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("import-adaptive-real-data")
        .join(profile_name);
    let imported =
        import_to(&profile, &ImportOptions::default(), &dir).expect("shipped recording imports");
    let adaptive = segment(&imported.imu, &DetectorSettings::default()).unwrap();
    let fixed = DetectorSettings {
        adapt_window: false,
        adapt_min_duration: false,
        ..DetectorSettings::default()
    };
    (adaptive, segment(&imported.imu, &fixed).unwrap())
}

fn check(profile: &str, rests: usize, typical: std::ops::Range<f64>) {
    let (adaptive, fixed) = segmented(profile);
    let a = &adaptive.adaptation;
    assert_eq!(
        (a.window, a.min_duration),
        (Source::Default, Source::Default)
    );
    let d = a.typical_rest_s.unwrap();
    assert!(typical.contains(&d), "{profile}: typical rest {d}");
    assert_eq!(adaptive.static_intervals.len(), rests);
    assert_eq!(adaptive.static_intervals, fixed.static_intervals);
    // A turn between every two rests, and any motion before the first or after the last (the
    // Xsens recording ends 3.5 s after its last rest, in motion).
    assert!(
        (rests - 1..=rests + 1).contains(&adaptive.motion_events),
        "{profile}: {} motion events",
        adaptive.motion_events
    );
    assert!(
        adaptive.missed_quiet_stretches.is_empty(),
        "{profile}: {:#?}",
        adaptive.missed_quiet_stretches
    );
}

#[test]
fn xsens_keeps_the_fixed_window_and_its_38_rests() {
    check("xsens_mti.toml", 38, 6.0..9.0);
}

#[test]
fn ferraris_keeps_the_fixed_window_and_its_13_rests() {
    check("ferraris_session.toml", 13, 4.0..5.0);
}
