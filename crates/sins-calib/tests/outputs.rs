//! Every command holds, round two (issue 34): small text inputs bounded by their kind (a
//! device without end refused at the bound, naming the file and the bound), data read with a
//! bound on a line, and outputs checked before the work (distinct, not an input, not a device,
//! in a writable directory), written whole, with nothing left behind on a failure or an
//! interruption, and `--json -` failing when standard output is closed.

use crate::common::{self, BIN, run, s, text};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    common::scratch("sins-calib-outputs", name)
}

/// Exit status 1 with every needle in the message, nothing on stdout (refused before the
/// work), within `seconds`.
fn refused_fast(args: &[&str], needles: &[&str], seconds: u64) -> Output {
    let start = Instant::now();
    let o = run(args);
    let took = start.elapsed();
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{args:?}\nstderr: {e}");
    for n in needles {
        assert!(e.contains(n), "{args:?}: expected `{n}` in: {e}");
    }
    assert!(o.stdout.is_empty(), "{args:?}: refused after the work");
    assert!(
        took < Duration::from_secs(seconds),
        "{args:?}: refused after {took:?}"
    );
    o
}

/// A simulated run of 5 s in `dir` (imu.csv, turntable.csv, truth.json) and its configuration.
fn short_run(dir: &Path) -> PathBuf {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/run.toml");
    let t = std::fs::read_to_string(example).expect("example");
    let cfg = dir.join("run.toml");
    std::fs::write(&cfg, t.replace("# duration_s = 600.0", "duration_s = 5.0")).expect("config");
    let o = run(&["simulate", "--config", s(&cfg), "--out", s(dir)]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    cfg
}

/// Files of `dir` whose names say they are temporary.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp") || n.contains("probe"))
        .collect()
}

#[test]
fn text_inputs_past_their_bound_are_refused_naming_the_file_and_the_bound() {
    let zero = Path::new("/dev/zero");
    if !zero.exists() {
        eprintln!("no /dev/zero here: skipped");
        return;
    }
    let dir = scratch("bounded");
    let cfg = short_run(&dir);
    let imu = dir.join("imu.csv");
    // A configuration, directly and as the rotation program it names.
    refused_fast(
        &["analyse", "--config", "/dev/zero"],
        &["/dev/zero", "configuration", "1 MiB"],
        10,
    );
    let program_cfg = dir.join("program-zero.toml");
    let t = std::fs::read_to_string(&cfg).unwrap();
    assert!(
        t.contains("program = \"paper\""),
        "the example names its program"
    );
    std::fs::write(
        &program_cfg,
        t.replace("program = \"paper\"", "program = \"/dev/zero\""),
    )
    .unwrap();
    let sim = dir.join("sim");
    for command in ["analyse", "simulate"] {
        let mut args = vec![command, "--config", s(&program_cfg)];
        if command == "simulate" {
            args.extend(["--out", s(&sim)]);
        }
        refused_fast(&args, &["/dev/zero", "rotation program", "16 MiB"], 10);
    }
    // Result and truth files.
    let out = dir.join("out.csv");
    refused_fast(
        &[
            "apply",
            "--calibration",
            "/dev/zero",
            "--imu",
            s(&imu),
            "--out",
            s(&out),
        ],
        &["/dev/zero", "result or truth JSON", "64 MiB"],
        20,
    );
    refused_fast(
        &[
            "calibrate",
            "--imu",
            s(&imu),
            "--config",
            s(&cfg),
            "--truth",
            "/dev/zero",
        ],
        &["/dev/zero", "64 MiB"],
        20,
    );
    refused_fast(
        &[
            "calibrate",
            "--imu",
            s(&imu),
            "--free-motion",
            "--terms-from",
            "/dev/zero",
        ],
        &["--terms-from", "/dev/zero", "16 MiB"],
        20,
    );
    refused_fast(
        &[
            "diagnose",
            "--imu",
            s(&imu),
            "--config",
            s(&cfg),
            "--noise",
            "/dev/zero",
        ],
        &["/dev/zero", "noise result JSON", "64 MiB"],
        20,
    );
    // An import profile, and a profile whose input file is the device.
    refused_fast(
        &[
            "import",
            "--profile",
            "/dev/zero",
            "--out",
            s(&dir.join("imp")),
        ],
        &["/dev/zero", "import profile", "1 MiB"],
        10,
    );
    let profile = dir.join("zero-input.toml");
    std::fs::write(
        &profile,
        "form = \"rates\"\n[input]\nfile = \"/dev/zero\"\nskip_lines = 1\n[time]\ncolumn = 1\n\
         [gyro]\ncolumns = [2, 3, 4]\nunit = \"rad/s\"\n[accel]\ncolumns = [5, 6, 7]\n\
         unit = \"m/s^2\"\n",
    )
    .unwrap();
    refused_fast(
        &[
            "import",
            "--profile",
            s(&profile),
            "--out",
            s(&dir.join("imp")),
        ],
        &["/dev/zero", "line 1", "bound"],
        10,
    );
    // A section list the profile names (read with the recording, before anything is written).
    let example =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/ferraris_session.toml");
    let ferraris = std::fs::read_to_string(&example).unwrap();
    let data = example
        .parent()
        .unwrap()
        .join("../data/real/ferraris_session");
    let sections_zero = dir.join("sections-zero.toml");
    let edited = ferraris
        .replace(
            "\"../data/real/ferraris_session/example_ferraris_session.csv\"",
            &format!("\"{}\"", s(&data.join("example_ferraris_session.csv"))),
        )
        .replace(
            "\"../data/real/ferraris_session/example_ferraris_session_list.json\"",
            "\"/dev/zero\"",
        );
    assert!(
        edited.contains("\"/dev/zero\""),
        "the example names its section list"
    );
    std::fs::write(&sections_zero, edited).unwrap();
    refused_fast(
        &[
            "import",
            "--profile",
            s(&sections_zero),
            "--out",
            s(&dir.join("imp")),
        ],
        &["/dev/zero", "section list", "16 MiB"],
        20,
    );
    // A data file without line ends.
    refused_fast(
        &["segment", "--imu", "/dev/zero"],
        &["/dev/zero", "line 1", "bound"],
        10,
    );
    assert!(!dir.join("imp").exists() && !dir.join("sim").exists());
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

#[test]
fn outputs_are_distinct_not_inputs_not_devices_before_the_work() {
    let dir = scratch("distinct");
    let cfg = short_run(&dir);
    let imu = dir.join("imu.csv");
    let png = dir.join("both.png");
    // --json X --plot X: one would be written over the other.
    refused_fast(
        &[
            "noise",
            "--imu",
            s(&imu),
            "--all-at-rest",
            "--json",
            s(&png),
            "--plot",
            s(&png),
        ],
        &["--plot", "also the output of --json"],
        10,
    );
    refused_fast(
        &[
            "calibrate",
            "--imu",
            s(&imu),
            "--free-motion",
            "--json",
            s(&png),
            "--plot",
            s(&png),
        ],
        &["--plot", "also the output of --json"],
        10,
    );
    // A JSON inside a report directory under one of the report's names.
    let report = dir.join("report");
    let inside = report.join(calib_report_name());
    std::fs::create_dir_all(&report).unwrap();
    refused_fast(
        &[
            "calibrate",
            "--imu",
            s(&imu),
            "--config",
            s(&cfg),
            "--json",
            s(&inside),
            "--report",
            s(&report),
        ],
        &["--report", "also the output of --json"],
        10,
    );
    assert!(!png.exists() && !inside.exists());
    // Onto an input: diagnose's --noise file, spelled another way.
    let noise = dir.join("noise.json");
    std::fs::write(&noise, "{}").unwrap();
    let again = dir.join(".").join("noise.json");
    refused_fast(
        &[
            "diagnose",
            "--imu",
            s(&imu),
            "--config",
            s(&cfg),
            "--noise",
            s(&noise),
            "--json",
            s(&again),
        ],
        &["--json", "is an input"],
        10,
    );
    assert_eq!(std::fs::read_to_string(&noise).unwrap(), "{}");
    // Devices: the atomic rename would replace them with a regular file.
    let truth = dir.join("truth.json");
    for device in ["/dev/null", "/dev/full"] {
        if !Path::new(device).exists() {
            eprintln!("no {device} here: skipped");
            continue;
        }
        refused_fast(
            &["analyse", "--config", s(&cfg), "--json", device],
            &["--json", device, "not a regular file"],
            10,
        );
        refused_fast(
            &["segment", "--imu", s(&imu), "--json", device],
            &["--json", device, "not a regular file"],
            10,
        );
        let out = ["apply", "--calibration", s(&truth)];
        let mut args = out.to_vec();
        args.extend(["--imu", s(&imu), "--out", device]);
        refused_fast(&args, &["--out", device, "not a regular file"], 10);
        let m = std::fs::metadata(device).unwrap();
        assert!(!m.is_file(), "{device} is still a device");
    }
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// One of the files a report directory holds.
fn calib_report_name() -> &'static str {
    "report.md"
}

#[cfg(unix)]
#[test]
fn an_output_where_nothing_can_be_written_is_refused_before_the_work() {
    use std::os::unix::fs::PermissionsExt as _;
    let dir = scratch("unwritable");
    let cfg = short_run(&dir);
    let imu = dir.join("imu.csv");
    let locked = dir.join("locked");
    std::fs::create_dir_all(&locked).unwrap();
    let mode = |m: u32| std::fs::Permissions::from_mode(m);
    std::fs::set_permissions(&locked, mode(0o555)).unwrap();
    // Root writes into a read-only directory: then the directory of the output is a regular
    // file instead, which nobody can write into.
    let root = std::fs::write(locked.join("probe"), "x").is_ok();
    let (target, needle) = if root {
        let _ = std::fs::remove_file(locked.join("probe"));
        let file = dir.join("a-file");
        std::fs::write(&file, "x").unwrap();
        (file.join("out.json"), "is not a directory")
    } else {
        (locked.join("out.json"), "cannot write in the directory")
    };
    for command in [
        vec!["analyse", "--config", s(&cfg)],
        vec!["segment", "--imu", s(&imu)],
        vec!["noise", "--imu", s(&imu), "--all-at-rest"],
        vec!["calibrate", "--imu", s(&imu), "--config", s(&cfg)],
        vec!["diagnose", "--imu", s(&imu), "--config", s(&cfg)],
    ] {
        let mut args = command.clone();
        args.extend(["--json", s(&target)]);
        refused_fast(&args, &["--json", needle], 10);
    }
    let mut args = vec!["apply", "--calibration"];
    let truth = dir.join("truth.json");
    args.extend([s(&truth), "--imu", s(&imu), "--out", s(&target)]);
    refused_fast(&args, &["--out", needle], 10);
    std::fs::set_permissions(&locked, mode(0o755)).unwrap();
}

#[test]
fn json_to_a_closed_standard_output_fails() {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    // The read end is gone before the child starts: every write to its stdout fails.
    drop(reader);
    let o = Command::new(BIN)
        .args(["analyse", "--config", "paper", "--imu-only", "--json", "-"])
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .expect("the binary runs");
    let e = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("standard output"), "{e}");
}

#[test]
fn apply_leaves_nothing_behind_when_it_fails_midway_or_is_interrupted() {
    let dir = scratch("apply");
    short_run(&dir);
    let imu = std::fs::read_to_string(dir.join("imu.csv")).unwrap();
    let truth = dir.join("truth.json");
    let out = dir.join("corrected.csv");
    // A bad row after thousands of good ones: refused when reached, midway through writing.
    let mut lines: Vec<&str> = imu.lines().collect();
    assert!(lines.len() > 100, "{} lines", lines.len());
    let at = lines.len() / 2;
    lines.insert(at, "1e400,x,0,0,0,0,0");
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let o = run(&[
        "apply",
        "--calibration",
        s(&truth),
        "--imu",
        s(&bad),
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains(&format!("line {}", at + 1)));
    assert!(!out.exists());
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));

    // Interrupted: the records come through a pipe that is held open, so the command is
    // surely in the middle of its output when the signal comes.
    if Command::new("mkfifo").arg("--help").output().is_err() {
        eprintln!("no mkfifo here: skipped");
        return;
    }
    let fifo = dir.join("imu.fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let mut child = Command::new(BIN)
        .args(["apply", "--calibration", s(&truth), "--imu", s(&fifo)])
        .args(["--out", s(&out)])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut feed = std::fs::OpenOptions::new().write(true).open(&fifo).unwrap();
    let head: Vec<&str> = imu.lines().take(100).collect();
    std::io::Write::write_all(&mut feed, (head.join("\n") + "\n").as_bytes()).unwrap();
    let start = Instant::now();
    while temporaries(&dir).is_empty() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "no temporary file"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    drop(feed);
    assert_eq!(status.code(), Some(128 + 15), "ended by the signal");
    assert!(!out.exists());
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}
