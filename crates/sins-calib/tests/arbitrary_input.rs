//! Property test: `sins-calib calibrate` on a short simulated run whose IMU or turntable file
//! has been mutated at random (bytes changed, ranges cut, junk inserted, the file cut off, a
//! line doubled) never panics: it calibrates (exit 0, or 3 when the fit fails its band) or
//! refuses with exit status 1 and a message that names the mutated file. The seed is fixed.

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
