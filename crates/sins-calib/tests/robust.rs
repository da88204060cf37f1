//! Every command holds against broken, absurd and hostile input (issue 20): bounded program
//! durations and step counts, refused options, plausibility checks on import and segment, and
//! outputs checked before the work and written whole. Each refusal exits 1 with a message
//! naming the file, line or option.

use crate::common::{self, run, s, text};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Output;

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-robust", name)
}

/// Exit status 1, a short message holding every needle, nothing on stdout.
fn refused(o: &Output, needles: &[&str]) {
    let e = text(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(1),
        "stdout: {}\nstderr: {e}",
        text(&o.stdout)
    );
    for n in needles {
        assert!(e.contains(n), "expected `{n}` in: {e}");
    }
    assert!(e.len() < 1000, "message too long ({} bytes): {e}", e.len());
    assert!(
        o.stdout.is_empty(),
        "refused after the work: {}",
        text(&o.stdout)
    );
}

/// `examples/run.toml` with `edit` applied, written into `dir` as `name`.
fn config(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let text = std::fs::read_to_string(example).expect("examples/run.toml");
    let path = dir.join(name);
    std::fs::write(&path, edit(text)).expect("config");
    path
}

/// A configuration in `dir` whose program is one dwell of `duration` (TOML text).
fn dwell_config(dir: &Path, duration: &str) -> (PathBuf, PathBuf) {
    let program = dir.join("program.toml");
    std::fs::write(
        &program,
        format!(
            "name = \"long\"\nstart_deg = [0.0, 0.0, 0.0]\n[[segment]]\nkind = \"rotate\"\n\
             gimbal = 2\nrate_deg_s = 10.0\nduration_s = 36.0\n[[segment]]\nkind = \"dwell\"\n\
             duration_s = {duration}\n"
        ),
    )
    .unwrap();
    let cfg = config(dir, "run.toml", |t| {
        t.replace("program = \"paper\"", "program = \"program.toml\"")
    });
    (cfg, program)
}

/// A 60-s simulated run in `dir`: (config, imu.csv).
fn short_run(dir: &Path) -> (PathBuf, PathBuf) {
    let cfg = config(dir, "short.toml", |t| {
        t.replace("# duration_s = 600.0", "duration_s = 60.0")
    });
    let out = run(&["simulate", "--config", s(&cfg), "--out", s(dir)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    (cfg, dir.join("imu.csv"))
}

#[test]
fn program_durations_are_bounded_in_every_command() {
    let dir = scratch("durations");
    let (_, imu) = short_run(&dir);
    for duration in ["1e300", "1e12", "900000.0"] {
        let (cfg, program) = dwell_config(&dir, duration);
        let out = dir.join("out");
        let cases: [&[&str]; 5] = [
            &["analyse", "--config", s(&cfg)],
            &[
                "design",
                "--config",
                s(&cfg),
                "--terms",
                "gyro_g_sensitivity",
            ],
            &["simulate", "--config", s(&cfg), "--out", s(&out)],
            &["calibrate", "--imu", s(&imu), "--config", s(&cfg)],
            &["diagnose", "--imu", s(&imu), "--config", s(&cfg)],
        ];
        for args in cases {
            let o = run(args);
            refused(&o, &[s(&program), "segment 2 (dwell)", "864000"]);
        }
        assert!(!out.exists(), "simulate wrote {}", out.display());
    }
}

#[test]
fn imu_steps_are_bounded_before_any_allocation() {
    let dir = scratch("steps");
    // 9 days at 1 kHz: 7.8e8 steps.
    let (cfg, _) = dwell_config(&dir, "777600.0");
    let fast = config(&dir, "fast.toml", |t| {
        t.replace("program = \"paper\"", "program = \"program.toml\"")
            .replace(
                "imu_rate_hz = 100.0               # rate of the IMU records",
                "imu_rate_hz = 1000.0 # rate",
            )
    });
    let o = run(&["analyse", "--config", s(&fast)]);
    refused(
        &o,
        &["program.toml", "filter.imu_rate_hz = 1000", "IMU steps"],
    );
    // Simulate writes at most 5e7 records.
    let o = run(&[
        "simulate",
        "--config",
        s(&cfg),
        "--out",
        s(&dir.join("out")),
    ]);
    refused(&o, &["records", "at most"]);
    // So does a run longer than its program.
    let long_run = config(&dir, "long_run.toml", |t| {
        t.replace("# duration_s = 600.0", "duration_s = 800000.0")
    });
    let o = run(&[
        "simulate",
        "--config",
        s(&long_run),
        "--out",
        s(&dir.join("out")),
    ]);
    refused(
        &o,
        &["long_run.toml", "800000 s at truth.imu_rate_hz", "at most"],
    );
    // A duration beyond ten days is refused at load, naming the field and its range.
    let absurd = config(&dir, "absurd_run.toml", |t| {
        t.replace("# duration_s = 600.0", "duration_s = 1e300")
    });
    let o = run(&[
        "simulate",
        "--config",
        s(&absurd),
        "--out",
        s(&dir.join("out")),
    ]);
    refused(
        &o,
        &["absurd_run.toml", "duration_s = 1e300", "at most 864000 s"],
    );
    // Design runs seven analyses: 2 days of program at 100 Hz is too much for it, not for one.
    let two_days = dwell_config(&dir, "172800.0").0;
    let o = run(&[
        "design",
        "--config",
        s(&two_days),
        "--terms",
        "accel_quadratic",
    ]);
    refused(&o, &["program.toml", "covariance analyses", "IMU steps"]);
}

#[test]
fn design_refuses_a_term_given_twice() {
    let dir = scratch("terms");
    let cfg = config(&dir, "run.toml", |t| t);
    let o = run(&[
        "design",
        "--config",
        s(&cfg),
        "--terms",
        "accel_quadratic",
        "gyro_g_sensitivity",
        "accel_quadratic",
    ]);
    refused(&o, &["--terms", "`accel_quadratic` is given twice"]);
}

#[test]
fn file_outputs_are_checked_before_the_work() {
    let dir = scratch("file-outputs");
    let (cfg, imu) = short_run(&dir);
    let before = std::fs::read(&imu).unwrap();
    // Onto a directory.
    let o = run(&[
        "design",
        "--config",
        s(&cfg),
        "--terms",
        "accel_quadratic",
        "--out",
        s(&dir),
    ]);
    refused(&o, &["--out", "is a directory"]);
    let o = run(&["analyse", "--config", s(&cfg), "--json", s(&dir)]);
    refused(&o, &["--json", "is a directory"]);
    let o = run(&["segment", "--imu", s(&imu), "--json", s(&dir)]);
    refused(&o, &["--json", "is a directory"]);
    // Onto an input.
    let o = run(&["segment", "--imu", s(&imu), "--json", s(&imu)]);
    refused(&o, &["--json", "is an input"]);
    assert_eq!(std::fs::read(&imu).unwrap(), before);
    let o = run(&["analyse", "--config", s(&cfg), "--json", s(&cfg)]);
    refused(&o, &["--json", "is an input"]);
    let o = run(&[
        "design",
        "--config",
        s(&cfg),
        "--terms",
        "accel_quadratic",
        "--out",
        s(&cfg),
    ]);
    refused(&o, &["--out", "is an input"]);
    // Into a directory that does not exist.
    let o = run(&[
        "analyse",
        "--config",
        s(&cfg),
        "--json",
        s(&dir.join("no/such.json")),
    ]);
    refused(&o, &["--json", "does not exist"]);
    // A good one is written whole, with no temporary file left.
    let json = dir.join("analysis.json");
    let o = run(&["analyse", "--config", s(&cfg), "--json", s(&json)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        std::fs::read_to_string(&json)
            .unwrap()
            .contains("\"parameters\"")
    );
    let stray: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(stray.is_empty(), "{stray:?}");
}

#[test]
fn simulate_writes_its_directory_whole() {
    let dir = scratch("simulate-outputs");
    let (cfg, imu) = short_run(&dir);
    let old_imu = std::fs::read(&imu).unwrap();
    let old_truth = std::fs::read(dir.join("truth.json")).unwrap();
    // Onto a file.
    let o = run(&["simulate", "--config", s(&cfg), "--out", s(&imu)]);
    refused(&o, &["--out", "is a file"]);
    assert_eq!(std::fs::read(&imu).unwrap(), old_imu);
    // An output name taken by a directory: refused before anything is written, the old
    // imu.csv and truth.json stay together.
    std::fs::remove_file(dir.join("turntable.csv")).unwrap();
    std::fs::create_dir(dir.join("turntable.csv")).unwrap();
    let o = run(&[
        "simulate",
        "--config",
        s(&cfg),
        "--out",
        s(&dir),
        "--seed",
        "7",
    ]);
    refused(&o, &["turntable.csv", "is a directory"]);
    assert_eq!(std::fs::read(&imu).unwrap(), old_imu);
    assert_eq!(std::fs::read(dir.join("truth.json")).unwrap(), old_truth);
    // A re-run replaces all three and keeps other files.
    std::fs::remove_dir(dir.join("turntable.csv")).unwrap();
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    let o = run(&[
        "simulate",
        "--config",
        s(&cfg),
        "--out",
        s(&dir),
        "--seed",
        "7",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_ne!(std::fs::read(&imu).unwrap(), old_imu);
    assert_ne!(std::fs::read(dir.join("truth.json")).unwrap(), old_truth);
    assert!(dir.join("turntable.csv").is_file() && dir.join("notes.txt").is_file());
}

/// A synthetic recording at rest, `rows` records at 100 Hz: `t,wx,wy,wz,fx,fy,fz` in s, rad/s,
/// m/s^2, with a header line. `t_scale` multiplies the time stamps (1000: milliseconds).
fn recording(path: &Path, rows: usize, t_scale: f64) {
    let mut out = String::from("t,wx,wy,wz,fx,fy,fz\n");
    for k in 0..rows {
        let t = (k as f64 + 1.0) * 0.01 * t_scale;
        let e = ((k * 7919) % 13) as f64 * 1e-4;
        out += &format!(
            "{t},{},{},{},{},{},{}\n",
            1e-4 + e,
            -2e-4,
            7e-5 - e,
            0.01 + e,
            -0.02,
            9.81 - e
        );
    }
    std::fs::write(path, out).unwrap();
}

/// A profile reading `recording.csv` beside it, with `edit` applied to its text.
fn profile(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let text = "form = \"rates\"\n\
                [input]\nfile = \"recording.csv\"\nskip_lines = 1\n\
                [time]\ncolumn = 1\n\
                [gyro]\ncolumns = [2, 3, 4]\nunit = \"rad/s\"\n\
                [accel]\ncolumns = [5, 6, 7]\nunit = \"m/s^2\"\n"
        .to_string();
    let path = dir.join(name);
    std::fs::write(&path, edit(text)).unwrap();
    path
}

#[test]
fn import_refuses_implausible_profiles_and_data() {
    let dir = scratch("import");
    recording(&dir.join("recording.csv"), 3000, 1.0);
    recording(&dir.join("recording_ms.csv"), 3000, 1000.0);
    recording(&dir.join("recording_huge.csv"), 3000, 1e290);
    let out = dir.join("out");
    let good = profile(&dir, "good.toml", |t| t);
    let o = run(&["import", "--profile", s(&good), "--out", s(&out)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    type Case = (&'static str, fn(String) -> String, &'static [&'static str]);
    let cases: &[Case] = &[
        (
            "twice.toml",
            |t| t.replace("columns = [2, 3, 4]", "columns = [2, 3, 2]"),
            &[
                "column 2 is used twice",
                "[gyro] columns (x)",
                "[gyro] columns (z)",
            ],
        ),
        (
            "by_name.toml",
            |t| {
                t.replace("skip_lines = 1", "skip_lines = 1\nheader_line = 1")
                    .replace("columns = [2, 3, 4]", "columns = [\"wx\", \"wy\", 2]")
            },
            &[
                "recording.csv: line 1",
                "gyro x (column `wx`) and gyro z (column 2) are the same field 2",
            ],
        ),
        (
            "time_as_gyro.toml",
            |t| t.replace("columns = [2, 3, 4]", "columns = [1, 3, 4]"),
            &[
                "column 1 is used twice",
                "[time] column",
                "[gyro] columns (x)",
            ],
        ),
        (
            "four.toml",
            |t| t.replace("columns = [2, 3, 4]", "columns = [2, 3, 4, 5]"),
            &["4 values", "expected exactly 3"],
        ),
        (
            "rate_huge.toml",
            |t| t.replace("column = 1\n", "rate_hz = 1e300\n"),
            &["rate_hz = 1e300"],
        ),
        (
            "rate_tiny.toml",
            |t| t.replace("column = 1\n", "rate_hz = 1e-300\n"),
            &["rate_hz = 1e-300"],
        ),
        (
            "slow.toml",
            |t| t.replace("column = 1\n", "rate_hz = 0.01\n"),
            &["median 100 s", "rate_hz"],
        ),
        (
            "half_hz.toml",
            |t| t.replace("column = 1\n", "rate_hz = 0.5\n"),
            &[
                "median 2 s",
                "expected 0.00001 .. 1 s",
                "check [time] rate_hz = 0.5",
            ],
        ),
        (
            "ms.toml",
            |t| t.replace("recording.csv", "recording_ms.csv"),
            &[
                "recording_ms.csv",
                "ms.toml",
                "ms declared as seconds",
                "unit = \"ms\"",
            ],
        ),
        (
            "huge_t.toml",
            |t| t.replace("recording.csv", "recording_huge.csv"),
            &[
                "recording_huge.csv",
                "median 1.000e288 s",
                "check [time] column and unit",
            ],
        ),
        (
            "sensitivity.toml",
            |t| {
                t.replace(
                    "unit = \"rad/s\"",
                    "unit = \"counts\"\noffset = [0.0, 0.0, 0.0]\n\
                     sensitivity = [1e-300, 1.0, 1.0]\nsensitivity_unit = \"rad/s\"",
                )
            },
            &[
                "line 2",
                "gyro x (column 2)",
                "below 100 rad/s",
                "sensitivity",
            ],
        ),
        (
            "unknown.toml",
            |t| t.replace("unit = \"rad/s\"", "unit = \"rad/s\"\nscale = 2.0"),
            &["unknown field `scale`"],
        ),
        (
            "join.toml",
            |t| {
                t.replace(
                    "file = \"recording.csv\"",
                    "gyro_file = \"recording.csv\"\naccel_file = \"recording.csv\"\n\
                     join_tolerance_s = 1e300",
                )
            },
            &["join_tolerance_s = 1e300"],
        ),
        (
            "join_wide.toml",
            |t| {
                t.replace(
                    "file = \"recording.csv\"",
                    "gyro_file = \"recording.csv\"\naccel_file = \"recording.csv\"\n\
                     join_tolerance_s = 0.5",
                )
            },
            &["join_tolerance_s = 0.5", "half the median interval"],
        ),
    ];
    let old = std::fs::read(out.join("imu.csv")).unwrap();
    for (name, edit, needles) in cases {
        let p = profile(&dir, name, edit);
        let o = run(&["import", "--profile", s(&p), "--out", s(&out)]);
        let mut all = vec![*name];
        all.extend_from_slice(needles);
        if ["ms.toml", "sensitivity.toml", "huge_t.toml"].contains(name) {
            // Named by data file and line, with the profile in the message.
            all.push("recording");
        }
        refused(&o, &all);
        assert_eq!(std::fs::read(out.join("imu.csv")).unwrap(), old, "{name}");
    }
}

#[test]
fn import_writes_its_directory_whole_and_never_onto_its_input() {
    let dir = scratch("import-outputs");
    recording(&dir.join("recording.csv"), 3000, 1.0);
    let list = dir.join("list.json");
    std::fs::write(&list, "{\"x_p\": {\"start\": 10, \"end\": 2000}}\n").unwrap();
    let with_sections = profile(&dir, "sections.toml", |t| {
        t + "[sections]\nfile = \"list.json\"\n"
    });
    let plain = profile(&dir, "plain.toml", |t| t);
    let out = dir.join("out");
    let o = run(&["import", "--profile", s(&with_sections), "--out", s(&out)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(out.join("sections.json").is_file());
    // A re-import without a section list leaves no stale sections.json.
    let o = run(&["import", "--profile", s(&plain), "--out", s(&out)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(!out.join("sections.json").exists());
    assert!(out.join("imu.csv").is_file() && out.join("import.json").is_file());
    // A section listed twice is refused, and nothing is written.
    std::fs::write(
        &list,
        "{\"x_p\": {\"start\": 10, \"end\": 200},\n \"x_p\": {\"start\": 300, \"end\": 400}}\n",
    )
    .unwrap();
    let fresh = dir.join("fresh");
    let o = run(&["import", "--profile", s(&with_sections), "--out", s(&fresh)]);
    refused(&o, &["list.json", "line 2", "`x_p` is listed twice"]);
    assert!(!fresh.exists());
    // An output name taken by a directory: refused before the work, nothing replaced.
    let old = std::fs::read(out.join("imu.csv")).unwrap();
    std::fs::remove_file(out.join("import.json")).unwrap();
    std::fs::create_dir(out.join("import.json")).unwrap();
    let o = run(&["import", "--profile", s(&plain), "--out", s(&out)]);
    refused(&o, &["import.json", "is a directory"]);
    assert_eq!(std::fs::read(out.join("imu.csv")).unwrap(), old);
    std::fs::remove_dir(out.join("import.json")).unwrap();
    // The source is OUT/imu.csv: refused, the source kept.
    let own = out.join("own.toml");
    std::fs::write(
        &own,
        std::fs::read_to_string(&plain)
            .unwrap()
            .replace("recording.csv", "imu.csv"),
    )
    .unwrap();
    let o = run(&["import", "--profile", s(&own), "--out", s(&out)]);
    refused(&o, &["imu.csv", "would be replaced"]);
    assert_eq!(std::fs::read(out.join("imu.csv")).unwrap(), old);
    // Onto a file.
    let o = run(&["import", "--profile", s(&plain), "--out", s(&list)]);
    refused(&o, &["--out", "is a file"]);
}

#[test]
fn segment_refuses_data_no_imu_gives() {
    let dir = scratch("segment");
    let good = dir.join("good.csv");
    recording(&good, 3000, 1.0);
    let o = run(&["segment", "--imu", s(&good)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    refused(
        &run(&["segment", "--imu", s(&good), "--rest-window", "1e300"]),
        &["--rest-window 1e300", "at most 600 s"],
    );
    refused(
        &run(&["segment", "--imu", s(&good), "--rest-window", "599"]),
        &["--rest-window", "longer than the recording", "good.csv"],
    );
    let edit = |name: &str, f: &dyn Fn(usize, &mut Vec<String>)| {
        let text = std::fs::read_to_string(&good).unwrap();
        let mut lines = text.lines();
        let mut out = String::from(lines.next().unwrap()) + "\n";
        for (i, l) in lines.enumerate() {
            let mut v: Vec<String> = l.split(',').map(str::to_string).collect();
            f(i, &mut v);
            out += &(v.join(",") + "\n");
        }
        let p = dir.join(name);
        std::fs::write(&p, out).unwrap();
        p
    };
    let huge = edit("huge_f.csv", &|_, v| v[6] = "1e300".into());
    refused(
        &run(&["segment", "--imu", s(&huge)]),
        &["huge_f.csv", "line 2", "specific force"],
    );
    let zero = edit("zero_f.csv", &|_, v| {
        for x in &mut v[4..7] {
            *x = "0".into();
        }
    });
    refused(
        &run(&["segment", "--imu", s(&zero)]),
        &["zero_f.csv", "static interval 1", "expected g"],
    );
    let tiny = edit("tiny_dt.csv", &|i, v| {
        v[0] = format!("{:e}", (i + 1) as f64 * 1e-300)
    });
    refused(
        &run(&["segment", "--imu", s(&tiny)]),
        &["tiny_dt.csv", "median"],
    );
}

/// A number as TOML writes it (`inf`, `-inf`, `nan`, or Rust's exact form otherwise).
fn toml_number(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{x:?}")
    }
}

/// Durations no program may have: beyond ten days, zero, negative, infinite, not a number.
fn absurd_duration() -> impl Strategy<Value = f64> {
    prop_oneof![
        (6.0f64..300.0).prop_map(|e| 10f64.powf(e)),
        (-300.0f64..300.0).prop_map(|e| -(10f64.powf(e))),
        Just(0.0),
        Just(f64::INFINITY),
        Just(f64::NAN),
    ]
}

/// Exit status 1 with a one-line message: refused, neither accepted nor crashed (101).
fn refused_somehow(o: &Output) -> Result<(), TestCaseError> {
    let e = text(&o.stderr);
    prop_assert_eq!(o.status.code(), Some(1), "{}", e);
    prop_assert!(e.starts_with("error: ") && e.len() < 1000, "{}", e);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 12,
        rng_seed: proptest::test_runner::RngSeed::Fixed(20_261_124),
        ..ProptestConfig::default()
    })]

    /// `analyse`, `design` and `simulate` never accept a program of absurd duration.
    #[test]
    fn absurd_programs_never_exit_0(d in absurd_duration(), which in 0usize..3) {
        let dir = scratch(&format!("prop-program-{which}"));
        let (cfg, _) = dwell_config(&dir, &toml_number(d));
        let out = dir.join("out");
        let args: Vec<&str> = match which {
            0 => vec!["analyse", "--config", s(&cfg)],
            1 => vec!["design", "--config", s(&cfg), "--terms", "accel_quadratic"],
            _ => vec!["simulate", "--config", s(&cfg), "--out", s(&out)],
        };
        refused_somehow(&run(&args))?;
        prop_assert!(!out.exists());
    }

    /// `import` never accepts a record rate or a gyro sensitivity no IMU has.
    #[test]
    fn absurd_imports_never_exit_0(
        rate in prop_oneof![
            (-300.0f64..-1.6).prop_map(|e| 10f64.powf(e)),
            (5.1f64..300.0).prop_map(|e| 10f64.powf(e)),
        ],
        sensitivity in (-300.0f64..-6.1).prop_map(|e| 10f64.powf(e)),
        by_rate in any::<bool>(),
    ) {
        let dir = scratch("prop-import");
        recording(&dir.join("recording.csv"), 3000, 1.0);
        let p = profile(&dir, "p.toml", |t| {
            if by_rate {
                t.replace("column = 1\n", &format!("rate_hz = {rate:?}\n"))
            } else {
                t.replace(
                    "unit = \"rad/s\"",
                    &format!(
                        "unit = \"counts\"\noffset = [0.0, 0.0, 0.0]\nsensitivity = [1.0, \
                         {sensitivity:?}, 1.0]\nsensitivity_unit = \"rad/s\""
                    ),
                )
            }
        });
        let out = dir.join("out");
        refused_somehow(&run(&["import", "--profile", s(&p), "--out", s(&out)]))?;
        prop_assert!(!out.exists());
    }

    /// `segment` never accepts a specific force scaled far from g, or time stamps far too close.
    #[test]
    fn absurd_recordings_never_segment(
        scale in prop_oneof![
            Just(0.0),
            (-300.0f64..-1.0).prop_map(|e| 10f64.powf(e)),
            (2.5f64..300.0).prop_map(|e| 10f64.powf(e)),
        ],
        dt in prop_oneof![
            Just(0.01),
            (-300.0f64..-5.5).prop_map(|e| 10f64.powf(e)),
        ],
    ) {
        let dir = scratch("prop-segment");
        let imu = dir.join("imu.csv");
        let mut text = String::from("t,wx,wy,wz,fx,fy,fz\n");
        for k in 0..3000 {
            let e = ((k * 7919) % 13) as f64 * 1e-4;
            text += &format!(
                "{:e},1e-4,-2e-4,7e-5,{:e},{:e},{:e}\n",
                (k + 1) as f64 * dt,
                (0.01 + e) * scale,
                -0.02 * scale,
                (9.81 - e) * scale
            );
        }
        std::fs::write(&imu, text).unwrap();
        // A scale near 1 with a sane interval is not absurd: skip it.
        prop_assume!(!(dt == 0.01 && (0.5..1.5).contains(&scale)));
        refused_somehow(&run(&["segment", "--imu", s(&imu)]))?;
    }
}

/// Bytes that are not UTF-8 in a configuration, an import profile or a JSON input name the
/// line and column (issue 20, "Messages"; was "stream did not contain valid UTF-8").
#[test]
fn text_inputs_that_are_not_utf8_name_the_line() {
    let dir = scratch("not-utf8");
    let toml = dir.join("bad.toml");
    let mut bytes =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml"))
            .expect("examples/run.toml");
    bytes.extend_from_slice(b"# \xff\n");
    let line = 1 + bytes.iter().filter(|&&b| b == b'\n').count() - 1;
    std::fs::write(&toml, &bytes).expect("config");
    refused(
        &run(&["analyse", "--config", s(&toml)]),
        &[
            "bad.toml",
            &format!("not UTF-8 at line {line}, column 3 (byte 0xff)"),
        ],
    );
    let profile = dir.join("profile.toml");
    std::fs::write(&profile, b"description = \"x\"\n\xfe\n").expect("profile");
    refused(
        &run(&[
            "import",
            "--profile",
            s(&profile),
            "--out",
            s(&dir.join("out")),
        ]),
        &["profile.toml", "not UTF-8 at line 2, column 1 (byte 0xfe)"],
    );
    let json = dir.join("bad.json");
    std::fs::write(&json, b"{\"parameters\": [\n{\"name\": \"\xff\"}]}\n").expect("json");
    let imu = dir.join("imu.csv");
    std::fs::write(&imu, "t,dthx,dthy,dthz,dvx,dvy,dvz\n0.01,0,0,0,0,0,0.098\n").expect("imu");
    refused(
        &run(&[
            "apply",
            "--calibration",
            s(&json),
            "--imu",
            s(&imu),
            "--out",
            s(&dir.join("corrected.csv")),
        ]),
        &["bad.json", "not UTF-8 at line 2, column 11 (byte 0xff)"],
    );
}
