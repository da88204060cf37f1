//! Property tests of the readers (in process, so fast) and of the numeric options of every
//! command (the binary): `imu.csv`, `turntable.csv`, the run configuration, the program, the
//! import profile, the section list, the result file and the noise file, each from a valid
//! file mutated at random (bytes set, absurd numbers inserted, ranges cut, the file cut off)
//! or from arbitrary bytes, never panic: they read, or refuse with a message that names the
//! file and where in it (a line, or a field or section of the file). The options: absurd
//! numbers (non-finite, negative, beyond 1e12) never panic and are refused naming the
//! option. The seeds are fixed.

use crate::common::BIN;
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sins-calib-readers");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(format!("{:?}-{name}", std::thread::current().id()))
}

/// Which reader, with a valid file to start from.
#[derive(Debug, Clone, Copy)]
enum Reader {
    Imu,
    Turntable,
    Config,
    Program,
    Profile,
    Sections,
    Result,
}

const READERS: [Reader; 7] = [
    Reader::Imu,
    Reader::Turntable,
    Reader::Config,
    Reader::Program,
    Reader::Profile,
    Reader::Sections,
    Reader::Result,
];

const SECTIONS: &str = r#"{
  "source": "list.json",
  "format": "imucal",
  "sections": [
    { "name": "x_p", "kind": "static", "source_start": 0, "source_end": 3,
      "first_record": 0, "last_record": 2, "start_s": 0.01, "end_s": 0.03,
      "up": [1.0, 0.0, 0.0], "mean_f_m_s2": [9.8, 0.0, 0.0] },
    { "name": "x_rot", "kind": "rotation", "source_start": 3, "source_end": 5,
      "first_record": 3, "last_record": 4, "start_s": 0.04, "end_s": 0.05,
      "axis": [1.0, 0.0, 0.0], "expected_turn_deg": -360.0, "measured_turn_deg": -358.0,
      "mean_f_m_s2": [9.8, 0.1, 0.0] }
  ]
}
"#;

const RESULT: &str = r#"{
  "parameters": [
    { "name": "gyro.bias.x", "value": 1e-6, "sigma": 1e-7, "unit": "rad/s" },
    { "name": "gyro.theta.xx", "value": 1e-3, "sigma": 1e-4, "unit": "1" },
    { "name": "accel.bias.z", "value": 0.01, "sigma": 0.001, "unit": "m/s^2" }
  ]
}
"#;

const IMU: &str = "t,dthx,dthy,dthz,dvx,dvy,dvz\n\
    0.01,1e-6,2e-6,3e-6,0.001,0.002,0.0981\n\
    0.02,1e-6,2e-6,3e-6,0.001,0.002,0.0981\n\
    0.03,1e-6,2e-6,3e-6,0.001,0.002,0.0981\n\
    0.04,1e-6,2e-6,3e-6,0.001,0.002,0.0981\n";

const TURNTABLE: &str = "t,k1,k2,k3\n0,0,0,0\n0.02,0.1,0,0\n0.04,0.2,0,0\n";

impl Reader {
    fn seed(self) -> String {
        let read = |p: &str| std::fs::read_to_string(root().join(p)).unwrap();
        match self {
            Reader::Imu => IMU.into(),
            Reader::Turntable => TURNTABLE.into(),
            Reader::Config => read("examples/run.toml"),
            Reader::Program => read("examples/static-4h.program.toml"),
            Reader::Profile => read("examples/ferraris_session.toml"),
            Reader::Sections => SECTIONS.into(),
            Reader::Result => RESULT.into(),
        }
    }

    fn file_name(self) -> &'static str {
        match self {
            Reader::Imu => "imu.csv",
            Reader::Turntable => "turntable.csv",
            Reader::Config => "run.toml",
            Reader::Program => "prog.toml",
            Reader::Profile => "profile.toml",
            Reader::Sections => "sections.json",
            Reader::Result => "result.json",
        }
    }

    /// Read `path`: `Err` holds the message.
    fn read(self, path: &Path) -> Result<(), String> {
        let e = |e: &dyn std::fmt::Display| e.to_string();
        match self {
            Reader::Imu => calib::io::read_imu_csv(path).map(drop).map_err(|x| e(&x)),
            Reader::Turntable => calib::io::read_turntable_csv(path)
                .map(drop)
                .map_err(|x| e(&x)),
            Reader::Config => calib::config::RunConfig::from_file(path)
                .map(drop)
                .map_err(|x| e(&x)),
            Reader::Program => turntable::program::Program::from_file(path)
                .map(drop)
                .map_err(|x| e(&x)),
            Reader::Profile => import::profile::Profile::load(path)
                .map(drop)
                .map_err(|x| e(&x)),
            Reader::Sections => import::sections::SectionsFile::read(path)
                .map(drop)
                .map_err(|x| e(&x)),
            Reader::Result => calib::io::read_result_json(path)
                .map(drop)
                .map_err(|x| e(&x)),
        }
    }
}

#[derive(Debug, Clone)]
enum Mutation {
    Set(usize, u8),
    Cut(usize, usize),
    Insert(usize, &'static str),
    Truncate(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        (any::<usize>(), 1usize..40).prop_map(|(i, n)| Mutation::Cut(i, n)),
        (
            any::<usize>(),
            prop_oneof![
                Just("1e300"),
                Just("-1e308"),
                Just("nan"),
                Just("NaN"),
                Just("inf"),
                Just("-1"),
                Just("0"),
                Just(","),
                Just("\n"),
                Just("\""),
                Just("["),
                Just("}"),
                Just("\u{0}"),
                Just("\u{fffd}"),
                Just("99999999999999999999"),
            ]
        )
            .prop_map(|(i, s)| Mutation::Insert(i, s)),
        any::<usize>().prop_map(Mutation::Truncate),
    ]
}

fn mutate(mut b: Vec<u8>, m: &Mutation) -> Vec<u8> {
    let at = |i: usize, len: usize| i % (len + 1);
    match m {
        Mutation::Set(i, v) => {
            if !b.is_empty() {
                let k = i % b.len();
                b[k] = *v;
            }
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
    }
    b
}

/// Whether a refusal says where: a line, or a field, key or section name of the file.
fn says_where(message: &str, seed: &str) -> bool {
    if message.contains("line") {
        return true;
    }
    seed.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.'))
        .filter(|w| w.len() >= 3 && w.chars().any(|c| c.is_ascii_alphabetic()))
        .any(|w| message.contains(w))
}

fn check_reader(reader: Reader, bytes: &[u8], what: &str) -> Result<(), TestCaseError> {
    let path = scratch(reader.file_name());
    std::fs::write(&path, bytes).unwrap();
    let shown = path.display().to_string();
    if let Err(message) = reader.read(&path) {
        prop_assert!(
            message.contains(&shown),
            "{reader:?} {what}: the refusal does not name {shown}: {message}"
        );
        prop_assert!(
            says_where(&message, &reader.seed()),
            "{reader:?} {what}: the refusal says no line or field: {message}"
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 400,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_128),
        ..ProptestConfig::default()
    })]

    /// Every reader on its valid file mutated at random: reads, or refuses naming the file and
    /// where.
    #[test]
    fn readers_on_mutated_files_never_panic_and_say_where(
        which in 0..READERS.len(),
        ms in proptest::collection::vec(mutation(), 1..4),
    ) {
        let reader = READERS[which];
        let mut bytes = reader.seed().into_bytes();
        for m in &ms {
            bytes = mutate(bytes, m);
        }
        check_reader(reader, &bytes, &format!("{ms:?}"))?;
    }

    /// Every reader on arbitrary bytes (short ones, and the valid file's start followed by
    /// arbitrary bytes): reads, or refuses naming the file and where.
    #[test]
    fn readers_on_arbitrary_bytes_never_panic_and_say_where(
        which in 0..READERS.len(),
        keep in 0usize..400,
        tail in proptest::collection::vec(any::<u8>(), 0..64),
    ) {
        let reader = READERS[which];
        let mut bytes = reader.seed().into_bytes();
        bytes.truncate(keep);
        bytes.extend(&tail);
        check_reader(reader, &bytes, &format!("{keep} bytes and {tail:?}"))?;
    }
}

/// A 30-s run of the example configuration on a rest and the paper's first turns, simulated
/// once: (dir, config).
fn base_run() -> &'static (PathBuf, PathBuf) {
    static RUN: std::sync::OnceLock<(PathBuf, PathBuf)> = std::sync::OnceLock::new();
    RUN.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("sins-calib-readers-run");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let text = std::fs::read_to_string(root().join("examples/run.toml")).unwrap();
        let cfg = dir.join("run.toml");
        std::fs::write(
            &cfg,
            text.replace("# duration_s = 600.0", "duration_s = 30.0"),
        )
        .unwrap();
        let out = Command::new(BIN)
            .args(["simulate", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&dir)
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        (dir, cfg)
    })
}

/// An absurd number as written on a command line.
fn absurd() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        (1e12f64..1e308).prop_map(|v| format!("{v:e}")),
        (-1e308f64..-1e-300).prop_map(|v| format!("{v:e}")),
    ]
}

/// (command and its inputs, numeric option) of every command that takes one.
fn option_cases(dir: &Path, cfg: &Path) -> Vec<(Vec<String>, &'static str)> {
    let imu = dir.join("imu.csv").display().to_string();
    let tt = dir.join("turntable.csv").display().to_string();
    let cfg = cfg.display().to_string();
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    let cal = s(&[
        "calibrate",
        "--imu",
        &imu,
        "--turntable",
        &tt,
        "--config",
        &cfg,
    ]);
    let free = s(&["calibrate", "--free-motion", "--imu", &imu]);
    let diag = s(&["diagnose", "--free-motion", "--imu", &imu]);
    let seg = s(&["segment", "--imu", &imu]);
    let noise = s(&["noise", "--imu", &imu]);
    let mut cases = vec![
        (cal.clone(), "--program-start"),
        (free.clone(), "--latitude"),
        (free.clone(), "--holdout"),
        (diag.clone(), "--level"),
        (diag.clone(), "--latitude"),
        (
            s(&["simulate", "--config", &cfg, "--out", &format!("{imu}.d")]),
            "--seed",
        ),
    ];
    for o in [
        "--rest-window",
        "--rest-max-std-f",
        "--rest-max-std-w",
        "--rest-max-rate",
        "--rest-min-duration",
        "--rest-noise-factor",
    ] {
        cases.push((free.clone(), o));
        cases.push((diag.clone(), o));
        cases.push((seg.clone(), o));
        cases.push((noise.clone(), o));
    }
    cases.push((seg.clone(), "--gap-factor"));
    cases
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 48,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_129),
        ..ProptestConfig::default()
    })]

    /// Every numeric option of every command given an absurd number: refused (exit 1 or 2)
    /// naming the option, never a panic or a run.
    #[test]
    fn absurd_numbers_in_every_option_are_refused_naming_it(
        which in 0usize..40,
        value in absurd(),
    ) {
        let (dir, cfg) = base_run();
        let cases = option_cases(dir, cfg);
        let (args, option) = &cases[which % cases.len()];
        let out = Command::new(BIN)
            .args(args)
            .arg(format!("{option}={value}"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        prop_assert!(!err.contains("panicked"), "{args:?} {option}={value}: {err}");
        let code = out.status.code();
        prop_assert!(matches!(code, Some(1 | 2)), "{args:?} {option}={value}: exit {code:?}: {err}");
        prop_assert!(err.contains(option), "{args:?} {option}={value}: {err}");
    }
}
