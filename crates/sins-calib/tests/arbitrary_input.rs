//! Property tests: `sins-calib calibrate` on a short simulated run whose IMU or turntable file
//! has been mutated at random (bytes changed, ranges cut, junk inserted, the file cut off, a
//! line doubled) never panics: it calibrates (exit 0, or 3 when the fit fails its band) or
//! refuses with exit status 1 and a message that names the mutated file; so do the other
//! commands that read an IMU file (`segment`, `noise`, `calibrate --free-motion`, `diagnose`,
//! `apply`). The seeds are fixed.

use crate::common::BIN;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// A 30-s run of the example configuration, simulated once: (dir, config).
fn base_run() -> &'static (PathBuf, PathBuf) {
    static RUN: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sins-calib-arbitrary");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
        let text = std::fs::read_to_string(example).unwrap();
        let cfg = dir.join("run.toml");
        std::fs::write(
            &cfg,
            text.replace("# duration_s = 600.0", "duration_s = 30.0"),
        )
        .unwrap();
        let out = Command::new(BIN)
            .args([
                "simulate",
                "--config",
                cfg.to_str().unwrap(),
                "--out",
                dir.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        (dir, cfg)
    })
}

#[derive(Debug, Clone)]
enum Mutation {
    Set(usize, u8),
    Cut(usize, usize),
    Insert(usize, &'static str),
    Truncate(usize),
    DoubleLine(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        (any::<usize>(), 1usize..200).prop_map(|(i, n)| Mutation::Cut(i, n)),
        (
            any::<usize>(),
            prop_oneof![
                Just("1e308"),
                Just("NaN"),
                Just(","),
                Just("\n"),
                Just("-0.5"),
                Just("\u{fffd}"),
                Just("99999"),
                Just("t,wx")
            ]
        )
            .prop_map(|(i, s)| Mutation::Insert(i, s)),
        any::<usize>().prop_map(Mutation::Truncate),
        any::<usize>().prop_map(Mutation::DoubleLine),
    ]
}

fn apply(mut b: Vec<u8>, m: &Mutation) -> Vec<u8> {
    let at = |i: usize, len: usize| i % (len + 1);
    match m {
        Mutation::Set(i, v) => {
            let k = i % b.len();
            b[k] = *v;
        }
        Mutation::Cut(i, n) => {
            let k = at(*i, b.len());
            let end = (k + n).min(b.len());
            b.drain(k..end);
        }
        Mutation::Insert(i, s) => {
            let k = at(*i, b.len());
            b.splice(k..k, s.bytes());
        }
        Mutation::Truncate(i) => b.truncate(at(*i, b.len())),
        Mutation::DoubleLine(i) => {
            let starts: Vec<usize> = std::iter::once(0)
                .chain(
                    b.iter()
                        .enumerate()
                        .filter(|(_, c)| **c == b'\n')
                        .map(|(k, _)| k + 1),
                )
                .filter(|k| *k < b.len())
                .collect();
            let s = starts[i % starts.len()];
            let e = b[s..]
                .iter()
                .position(|c| *c == b'\n')
                .map_or(b.len(), |k| s + k + 1);
            let line = b[s..e].to_vec();
            b.splice(e..e, line);
        }
    }
    b
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 40,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_123),
        ..ProptestConfig::default()
    })]

    #[test]
    fn calibrate_on_mutated_files_never_panics_and_names_the_file(
        turntable_side in any::<bool>(),
        ms in proptest::collection::vec(mutation(), 1..3),
    ) {
        let (dir, cfg) = base_run();
        let name = if turntable_side { "turntable.csv" } else { "imu.csv" };
        let mut bytes = std::fs::read(dir.join(name)).unwrap();
        for m in &ms {
            bytes = apply(bytes, m);
        }
        let case = dir.join(format!("case-{:?}", std::thread::current().id()));
        std::fs::create_dir_all(&case).unwrap();
        for other in ["imu.csv", "turntable.csv"] {
            let path = case.join(other);
            if other == name {
                std::fs::write(&path, &bytes).unwrap();
            } else {
                std::fs::copy(dir.join(other), &path).unwrap();
            }
        }
        let out = Command::new(BIN)
            .args([
                "calibrate",
                "--imu", case.join("imu.csv").to_str().unwrap(),
                "--turntable", case.join("turntable.csv").to_str().unwrap(),
                "--config", cfg.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        prop_assert!(!err.contains("panicked"), "{ms:?}: {err}");
        let code = out.status.code();
        prop_assert!(matches!(code, Some(0 | 1 | 3)), "{ms:?}: exit {code:?}: {err}");
        if code == Some(1) {
            let shown = case.join(name).display().to_string();
            prop_assert!(err.contains(&shown), "{ms:?}: the refusal does not name {shown}: {err}");
        }
    }
}

/// The calibration file `apply` corrects with: the base run calibrated once.
fn base_calibration() -> &'static PathBuf {
    static CAL: OnceLock<PathBuf> = OnceLock::new();
    CAL.get_or_init(|| {
        let (dir, cfg) = base_run();
        let path = dir.join("calibration.json");
        let out = Command::new(BIN)
            .args(["calibrate", "--imu"])
            .arg(dir.join("imu.csv"))
            .args(["--turntable"])
            .arg(dir.join("turntable.csv"))
            .args(["--config"])
            .arg(cfg)
            .args(["--json"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(matches!(out.status.code(), Some(0 | 3)), "{out:?}");
        path
    })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 30,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_125),
        ..ProptestConfig::default()
    })]

    /// Every other command that reads an IMU file, on a mutated one: exit 0, 3 (the model does
    /// not fit) or 1 with a message that names the file; never a panic.
    #[test]
    fn every_imu_reader_on_mutated_files_never_panics_and_names_the_file(
        which in 0usize..5,
        ms in proptest::collection::vec(mutation(), 1..3),
    ) {
        let (dir, cfg) = base_run();
        let mut bytes = std::fs::read(dir.join("imu.csv")).unwrap();
        for m in &ms {
            bytes = apply(bytes, m);
        }
        let case = dir.join(format!("reader-{:?}", std::thread::current().id()));
        std::fs::create_dir_all(&case).unwrap();
        let imu = case.join("imu.csv");
        std::fs::write(&imu, &bytes).unwrap();
        let imu_arg = imu.to_str().unwrap();
        let out_file = case.join("out.csv");
        let calibration = base_calibration();
        let args: Vec<&str> = match which {
            0 => vec!["segment", "--imu", imu_arg],
            1 => vec!["noise", "--imu", imu_arg, "--all-at-rest"],
            2 => vec!["calibrate", "--imu", imu_arg, "--free-motion"],
            3 => vec!["diagnose", "--imu", imu_arg, "--config", cfg.to_str().unwrap()],
            _ => vec![
                "apply", "--calibration", calibration.to_str().unwrap(), "--imu", imu_arg,
                "--out", out_file.to_str().unwrap(),
            ],
        };
        let out = Command::new(BIN).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        prop_assert!(!err.contains("panicked"), "{args:?} {ms:?}: {err}");
        let code = out.status.code();
        prop_assert!(matches!(code, Some(0 | 1 | 3)), "{args:?} {ms:?}: exit {code:?}: {err}");
        if code == Some(1) {
            prop_assert!(
                err.starts_with("error: ") && err.contains(imu_arg),
                "{args:?} {ms:?}: the refusal does not name {imu_arg}: {err}"
            );
        }
    }
}

/// The base run's IMU file with one group of columns scaled by `k`: the gyro increments
/// (`which = 0`), the accelerometer increments (1) or the time stamps (2).
fn scaled_imu(which: usize, k: f64) -> Vec<u8> {
    let (dir, _) = base_run();
    let text = std::fs::read_to_string(dir.join("imu.csv")).unwrap();
    let mut lines = text.lines();
    let mut out = String::from(lines.next().unwrap()) + "\n";
    for line in lines {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let cols = match which {
            0 => 1..4,
            1 => 4..7,
            _ => 0..1,
        };
        let row: Vec<String> = v
            .iter()
            .enumerate()
            .map(|(i, x)| format!("{:e}", if cols.contains(&i) { x * k } else { *x }))
            .collect();
        out += &(row.join(",") + "\n");
    }
    out.into_bytes()
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 24,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_126),
        ..ProptestConfig::default()
    })]

    /// Absurd data never exit 0 (issue 20): `calibrate` on the base run with its gyro or
    /// accelerometer increments or its time stamps scaled by a factor no unit mix-up excuses
    /// (1/g, and powers of ten from 10^1.5 to 10^300 either way) refuses (1) or says the model
    /// does not fit (3).
    #[test]
    fn calibrate_never_accepts_absurdly_scaled_data(
        which in 0usize..3,
        k in prop_oneof![
            Just(1.0 / 9.80665),
            (1.5f64..300.0).prop_map(|e| 10f64.powf(e)),
            (1.5f64..300.0).prop_map(|e| 10f64.powf(-e)),
        ],
    ) {
        let (dir, cfg) = base_run();
        let case = dir.join(format!("scaled-{:?}", std::thread::current().id()));
        std::fs::create_dir_all(&case).unwrap();
        let imu = case.join("imu.csv");
        std::fs::write(&imu, scaled_imu(which, k)).unwrap();
        let out = Command::new(BIN)
            .args(["calibrate", "--imu", imu.to_str().unwrap()])
            .args(["--turntable", dir.join("turntable.csv").to_str().unwrap()])
            .args(["--config", cfg.to_str().unwrap()])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        let code = out.status.code();
        prop_assert!(matches!(code, Some(1 | 3)), "column group {which} times {k:e}: exit {code:?}: {err}");
    }
}
