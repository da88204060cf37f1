//! Property tests: every reader, fed arbitrary bytes or a good file mutated at random, either
//! reads it or refuses it with an error that names the file; none panics.
//!
//! The mutations are those a lab's files suffer: a byte changed, a range cut out, junk
//! inserted, the file cut off, a line doubled. Case counts are fixed (proptest's default
//! seed handling: failures are persisted nowhere, a failing case is printed shrunk).

use calib::config::RunConfig;
use calib::io::{read_imu_csv, read_result_json, read_turntable_csv};
use proptest::prelude::*;
use std::path::PathBuf;
use turntable::program::Program;

const GOOD_IMU: &str = "t,dthx,dthy,dthz,dvx,dvy,dvz\n\
0.01,1.2e-5,-3.4e-6,7.1e-7,1.0e-4,-2.0e-4,0.0981\n\
0.02,1.3e-5,-3.3e-6,7.0e-7,1.1e-4,-2.1e-4,0.0981\n\
0.03,1.1e-5,-3.5e-6,7.2e-7,0.9e-4,-1.9e-4,0.0980\n";
const GOOD_RATES: &str = "t,wx,wy,wz,fx,fy,fz,temp\n\
0.01,1.2e-3,-3.4e-4,7.1e-5,0.01,-0.02,9.81,25.0\n\
0.02,1.3e-3,-3.3e-4,7.0e-5,0.011,-0.021,9.81,25.1\n";
const GOOD_TURNTABLE: &str = "t,k1,k2,k3\n12.5,0,0.1,0\n12.52,0,0.3,0\n12.54,0,0.5,0\n";
const GOOD_RESULT: &str = r#"{"parameters": [{"name": "gyro.bias.x", "value": 1e-6, "sigma": 1e-8, "unit": "rad/s"},
{"name": "turntable.tau", "value": 0.02, "sigma": 1e-5, "unit": "s"}]}"#;

/// A mutation of a file's bytes.
#[derive(Debug, Clone)]
enum Mutation {
    Set(usize, u8),
    Cut(usize, usize),
    Insert(usize, Vec<u8>),
    Truncate(usize),
    DoubleLine(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        (any::<usize>(), 1usize..20).prop_map(|(i, n)| Mutation::Cut(i, n)),
        (
            any::<usize>(),
            prop_oneof![
                proptest::collection::vec(any::<u8>(), 1..12),
                Just(b"1e308".to_vec()),
                Just(b"NaN".to_vec()),
                Just(b",".to_vec()),
                Just(b"\n".to_vec()),
                Just(b"-inf".to_vec()),
                Just(b"\"".to_vec()),
            ]
        )
            .prop_map(|(i, v)| Mutation::Insert(i, v)),
        any::<usize>().prop_map(Mutation::Truncate),
        any::<usize>().prop_map(Mutation::DoubleLine),
    ]
}

fn apply(text: &[u8], ms: &[Mutation]) -> Vec<u8> {
    let mut b = text.to_vec();
    for m in ms {
        let at = |i: usize, len: usize| if len == 0 { 0 } else { i % (len + 1) };
        match m {
            Mutation::Set(i, v) if !b.is_empty() => {
                let k = i % b.len();
                b[k] = *v;
            }
            Mutation::Set(..) => {}
            Mutation::Cut(i, n) => {
                let k = at(*i, b.len());
                let end = (k + n).min(b.len());
                b.drain(k..end);
            }
            Mutation::Insert(i, v) => {
                let k = at(*i, b.len());
                b.splice(k..k, v.iter().copied());
            }
            Mutation::Truncate(i) => {
                let k = at(*i, b.len());
                b.truncate(k);
            }
            Mutation::DoubleLine(i) => {
                let lines: Vec<&[u8]> = b.split(|c| *c == b'\n').collect();
                let k = i % lines.len();
                let mut out = Vec::new();
                for (j, l) in lines.iter().enumerate() {
                    out.extend_from_slice(l);
                    out.push(b'\n');
                    if j == k {
                        out.extend_from_slice(l);
                        out.push(b'\n');
                    }
                }
                out.pop();
                b = out;
            }
        }
    }
    b
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sins-arbitrary-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(format!("{name}-{:?}", std::thread::current().id()))
}

/// Every reader on the same bytes: a refusal names the file.
fn read_all(bytes: &[u8]) -> Result<(), TestCaseError> {
    for (name, read) in [
        (
            "imu.csv",
            &(|p: &std::path::Path| read_imu_csv(p).map(|_| ()).map_err(|e| e.to_string()))
                as &dyn Fn(&std::path::Path) -> Result<(), String>,
        ),
        ("turntable.csv", &|p| {
            read_turntable_csv(p).map(|_| ()).map_err(|e| e.to_string())
        }),
        ("result.json", &|p| {
            read_result_json(p).map(|_| ()).map_err(|e| e.to_string())
        }),
        ("run.toml", &|p| {
            RunConfig::from_file(p)
                .map(|_| ())
                .map_err(|e| e.to_string())
        }),
        ("program.toml", &|p| {
            Program::from_file(p).map(|_| ()).map_err(|e| e.to_string())
        }),
    ] {
        let path = scratch(name);
        std::fs::write(&path, bytes).unwrap();
        if let Err(message) = read(&path) {
            let shown = path.display().to_string();
            prop_assert!(
                message.contains(&shown),
                "{name}: {message:?} does not name {shown}"
            );
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_123),
        ..ProptestConfig::default()
    })]

    #[test]
    fn arbitrary_bytes_are_read_or_refused_by_name(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        read_all(&bytes)?;
    }

    #[test]
    fn mutated_good_files_are_read_or_refused_by_name(
        which in 0usize..5,
        ms in proptest::collection::vec(mutation(), 1..4),
    ) {
        let base: &[u8] = match which {
            0 => GOOD_IMU.as_bytes(),
            1 => GOOD_RATES.as_bytes(),
            2 => GOOD_TURNTABLE.as_bytes(),
            3 => GOOD_RESULT.as_bytes(),
            _ => turntable::program::PAPER_PROGRAM_TOML.as_bytes(),
        };
        read_all(&apply(base, &ms))?;
    }
}

#[test]
fn the_embedded_configuration_survives_mutation_too() {
    // The run configuration is the one format above without a good sample: a fixed set of
    // mutations of the embedded one.
    let base = calib::config::PAPER_CONFIG_TOML.as_bytes();
    let path = scratch("paper.toml");
    for i in 0..base.len().min(4000) {
        let mut b = base.to_vec();
        b[i] = b"x9=\n\"[.-"[i % 8];
        std::fs::write(&path, &b).unwrap();
        if let Err(e) = RunConfig::from_file(&path) {
            assert!(e.to_string().contains(&path.display().to_string()), "{e}");
        }
    }
}
