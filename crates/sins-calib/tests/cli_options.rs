//! Options that make no sense are refused before any work (issue 20): `diagnose --level` outside
//! (0, 0.5], a candidate term given twice, `--latitude` beside `--config`, and a `--json` output
//! onto an input or a directory.

use crate::common::{self, run, s, text};

#[test]
fn absurd_options_are_refused_naming_the_option() {
    let dir = common::scratch("sins-calib-options", "refused");
    let imu = dir.join("imu.csv");
    std::fs::write(
        &imu,
        "t,wx,wy,wz,fx,fy,fz\n0.01,0,0,0,0,0,9.8\n0.02,0,0,0,0,0,9.8\n",
    )
    .expect("imu");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "diagnose",
                "--imu",
                s(&imu),
                "--config",
                "paper",
                "--level",
                "NaN",
            ],
            "--level",
        ),
        (
            vec![
                "diagnose",
                "--imu",
                s(&imu),
                "--config",
                "paper",
                "--level",
                "0",
            ],
            "--level",
        ),
        (
            vec![
                "diagnose",
                "--imu",
                s(&imu),
                "--config",
                "paper",
                "--level",
                "2",
            ],
            "--level",
        ),
        (
            vec![
                "diagnose",
                "--imu",
                s(&imu),
                "--config",
                "paper",
                "--terms",
                "accel_quadratic",
                "accel_quadratic",
            ],
            "given twice",
        ),
        (
            vec![
                "calibrate",
                "--imu",
                s(&imu),
                "--config",
                "paper",
                "--json",
                s(&imu),
            ],
            "--json",
        ),
        (
            vec![
                "calibrate",
                "--imu",
                s(&imu),
                "--config",
                "paper",
                "--json",
                s(&dir),
            ],
            "is a directory",
        ),
        (
            vec![
                "diagnose",
                "--imu",
                s(&imu),
                "--config",
                "paper",
                "--json",
                s(&imu),
            ],
            "--json",
        ),
    ];
    for (args, expected) in cases {
        let out = run(&args);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(expected), "{args:?}: {err}");
    }
    // The input is untouched.
    let kept = std::fs::read_to_string(&imu).expect("imu");
    assert!(kept.starts_with("t,wx"), "{kept}");
    // clap's own refusal (exit 2) for --latitude beside --config.
    let out = run(&[
        "calibrate",
        "--imu",
        s(&imu),
        "--free-motion",
        "--config",
        "paper",
        "--latitude",
        "45",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("--latitude"));
}
