//! `cargo xtask audit`: every command of `sins-calib` run on a fixed list of hostile inputs
//! (`xtask/audit/cases.toml`), each run classified:
//!
//! - `panic/abort`: a panic, a signal, an exit status other than 0 .. 3, or no end within the
//!   case's time limit (an unbounded read, a write blocked on a pipe);
//! - `silent success`: exit 0 (or 3, results written) on input the case says must be refused;
//! - `late refusal`: refused, but after the work: the report was already printed;
//! - `damaged output`: a refusal that changed or left a file in the case's directory (an input
//!   overwritten, a partial output, a temporary file), or a success whose outputs are missing or
//!   do not parse (JSON, TOML, CSV with finite numbers and a constant number of columns, PNG);
//! - `unclear error`: refused, but the message lacks the words the case expects (the option or
//!   field and its range: the cause, not a downstream symptom);
//! - `refused good input`: a case that must succeed was refused;
//! - `ok`.
//!
//! The inputs are generated once per audit (a short simulated run, a static recording, a
//! calibration, a noise file, an import of the Ferraris session of `data/real`) and each case
//! derives its own files from them in its own directory. Prints the runs that are not `ok` and
//! the count per class; exits non-zero when any class but `ok` (and `skipped`) is non-zero.

use serde::Deserialize;
use std::collections::BTreeMap;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

/// The case list, `xtask/audit/cases.toml`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseList {
    case: Vec<CaseSpec>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum Expect {
    Refuse,
    Succeed,
    /// Exit 1 after the work (the report could not be printed) with the outputs kept.
    Keep,
}

/// One case: a command line (split on spaces; `{fx}` the fixtures' directory, `{case}` the
/// case's own, `{v}` each of `values` in turn), the files it creates, and what must happen.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseSpec {
    name: String,
    cmd: String,
    #[serde(default)]
    values: Vec<String>,
    expect: Expect,
    /// Words the refusal must contain (case-insensitive; `a|b`: either), `{v}` substituted.
    #[serde(default)]
    words: Vec<String>,
    /// Files created in the case's directory before the run, by name.
    #[serde(default)]
    files: BTreeMap<String, FileSpec>,
    /// `"closed"`: the command runs with its standard output closed (`>&-`); `"full"`: on
    /// /dev/full (every write fails with ENOSPC).
    #[serde(default)]
    stdout: Option<String>,
    /// `"full"`: the command runs with its standard error on /dev/full; `"gone"`: on a pipe
    /// whose reader has closed it (every write fails with EPIPE). Its words cannot be read
    /// then: the exit status alone decides.
    #[serde(default)]
    stderr: Option<String>,
    /// Outputs a success must leave (files or directories), checked to parse.
    #[serde(default)]
    outputs: Vec<String>,
    /// Files a success must leave absent (the stale temporaries of an earlier, killed run).
    #[serde(default)]
    absent: Vec<String>,
    /// Exit status 0 required for a success (else 3, "the model does not fit", passes too).
    #[serde(default)]
    exit0: bool,
    /// The longest standard error accepted from a refusal (bytes): a message past it is an
    /// unclear error (a hostile input echoed whole).
    #[serde(default)]
    max_stderr: Option<usize>,
    /// Time limit (s), default 30.
    #[serde(default)]
    timeout_s: Option<f64>,
}

/// A file of a case, derived from a fixture or written out.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    /// Copy of this file (placeholders substituted), then edited as below.
    from: Option<String>,
    /// The file's whole text.
    text: Option<String>,
    /// TOML: fields set by dotted path (a quoted part for a name with dots), the value in TOML
    /// syntax.
    #[serde(default)]
    set: BTreeMap<String, String>,
    /// TOML: fields removed by dotted path.
    #[serde(default)]
    remove: Vec<String>,
    /// Result JSON: parameter values set by name (JSON number syntax).
    #[serde(default)]
    param: BTreeMap<String, String>,
    /// Result JSON: parameters removed by name (a hand-edited result).
    #[serde(default)]
    drop_param: Vec<String>,
    /// JSON: values set by JSON pointer (JSON syntax).
    #[serde(default)]
    json: BTreeMap<String, String>,
    /// Text replacements, in order.
    #[serde(default)]
    replace: Vec<(String, String)>,
    /// CSV edits: `ms` (time column times 1000), `g` (the accelerometer columns divided by g),
    /// `swap` (gyro and accelerometer columns swapped), `head:N` (the header and N records),
    /// `temp:V` (a temp column of V), `shift:LINE:S` (S seconds added to the times from file
    /// line LINE on), `swapcols:A:B` (columns A and B, 0-based, swapped), `constant` (every
    /// record's values those of the first: a stuck sensor).
    #[serde(default)]
    transform: Vec<String>,
    /// Text appended after the rest: each string repeated its number of times (a
    /// configuration nested 100 000 deep, an array of 300 000 entries).
    #[serde(default)]
    pieces: Vec<(String, usize)>,
    /// A sparse file of this many bytes (zeros).
    sparse_bytes: Option<u64>,
    /// A named pipe.
    #[serde(default)]
    fifo: bool,
    /// A directory.
    #[serde(default)]
    dir: bool,
    /// Made read-only (a directory: no new files in it).
    #[serde(default)]
    readonly: bool,
}

/// The classes of a run, in the order printed.
const CLASSES: [&str; 8] = [
    "ok",
    "panic/abort",
    "silent success",
    "late refusal",
    "damaged output",
    "unclear error",
    "refused good input",
    "skipped",
];

struct Outcome {
    class: &'static str,
    detail: String,
}

/// `cargo xtask audit`.
pub fn audit(only: Option<&str>, keep: bool, verbose: bool, bin: Option<&Path>) -> ExitCode {
    let t0 = Instant::now();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lies in the workspace")
        .to_path_buf();
    let bin = match bin {
        Some(b) => std::path::absolute(b).unwrap_or_else(|_| b.to_path_buf()),
        None => match build(&root) {
            Some(b) => b,
            None => return ExitCode::FAILURE,
        },
    };
    let list_path = root.join("xtask/audit/cases.toml");
    let cases = match std::fs::read_to_string(&list_path)
        .map_err(|e| e.to_string())
        .and_then(|t| toml::from_str::<CaseList>(&t).map_err(|e| e.to_string()))
    {
        Ok(l) => expand(l.case),
        Err(e) => {
            eprintln!("error: {}: {e}", list_path.display());
            return ExitCode::FAILURE;
        }
    };
    let scratch = std::env::temp_dir().join(format!("sins-calib-audit-{}", std::process::id()));
    let fx = scratch.join("fx");
    if let Err(e) = fixtures(&bin, &root, &fx) {
        eprintln!("error: audit fixtures: {e}");
        let _ = std::fs::remove_dir_all(&scratch);
        return ExitCode::FAILURE;
    }
    let mut counts: BTreeMap<&str, usize> = CLASSES.iter().map(|c| (*c, 0)).collect();
    let mut ran = 0;
    for (k, case) in cases.iter().enumerate() {
        if only.is_some_and(|o| !case.name.contains(o)) {
            continue;
        }
        ran += 1;
        let dir = scratch.join(format!("case-{k:03}"));
        let outcome = match run_case(&bin, &fx, &dir, case) {
            Ok(o) => o,
            Err(e) => Outcome {
                class: "panic/abort",
                detail: format!("the audit could not set the case up: {e}"),
            },
        };
        *counts.entry(outcome.class).or_default() += 1;
        if outcome.class != "ok" || verbose {
            println!("{:<18} {}: {}", outcome.class, case.name, outcome.detail);
        }
        if !keep {
            make_writable(&dir);
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
    println!(
        "audit: {ran} cases in {:.1} s ({})",
        t0.elapsed().as_secs_f64(),
        list_path
            .strip_prefix(&root)
            .unwrap_or(&list_path)
            .display()
    );
    for c in CLASSES {
        println!("  {c:<20} {}", counts[c]);
    }
    if keep {
        println!("audit: kept {}", scratch.display());
    } else {
        let _ = std::fs::remove_dir_all(&scratch);
    }
    let bad: usize = counts
        .iter()
        .filter(|(c, _)| !matches!(**c, "ok" | "skipped"))
        .map(|(_, n)| n)
        .sum();
    if bad == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// `cargo build --release -p sins-calib`; the binary's path.
fn build(root: &Path) -> Option<PathBuf> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    match Command::new(&cargo)
        .current_dir(root)
        .args(["build", "--release", "--quiet", "-p", "sins-calib"])
        .status()
    {
        Ok(s) if s.success() => {}
        Ok(s) => {
            eprintln!("error: cargo build --release -p sins-calib failed ({s})");
            return None;
        }
        Err(e) => {
            eprintln!("error: cannot run {cargo}: {e}");
            return None;
        }
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|p| if p.is_absolute() { p } else { root.join(p) })
        .unwrap_or_else(|| root.join("target"));
    Some(target.join("release").join("sins-calib"))
}

/// One case per value of `values` (the name gets ` = value`).
fn expand(cases: Vec<CaseSpec>) -> Vec<CaseSpec> {
    let mut out = Vec::new();
    for c in cases {
        if c.values.is_empty() {
            out.push(c);
            continue;
        }
        for v in &c.values {
            let sub = |s: &str| s.replace("{v}", v);
            let mut d = c.clone();
            d.values.clear();
            d.name = format!("{} [{v}]", sub(&c.name));
            d.cmd = sub(&c.cmd);
            d.words = c.words.iter().map(|w| sub(w)).collect();
            d.files = c
                .files
                .iter()
                .map(|(name, f)| {
                    let mut f = f.clone();
                    f.from = f.from.map(|s| sub(&s));
                    f.text = f.text.map(|s| sub(&s));
                    f.set = f.set.iter().map(|(k, x)| (sub(k), sub(x))).collect();
                    f.param = f.param.iter().map(|(k, x)| (sub(k), sub(x))).collect();
                    f.json = f.json.iter().map(|(k, x)| (sub(k), sub(x))).collect();
                    f.replace = f.replace.iter().map(|(a, b)| (sub(a), sub(b))).collect();
                    f.transform = f.transform.iter().map(|t| sub(t)).collect();
                    (sub(name), f)
                })
                .collect();
            d.outputs = c.outputs.iter().map(|o| sub(o)).collect();
            d.absent = c.absent.iter().map(|o| sub(o)).collect();
            out.push(d);
        }
    }
    out
}

/// Run `sins-calib` with `args` in `cwd`; fails unless it exits 0 (or 3 when `fit_optional`).
fn run_fixture(bin: &Path, cwd: &Path, args: &[&str]) -> Result<(), String> {
    let out = Command::new(bin)
        .current_dir(cwd)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{}: {e}", bin.display()))?;
    if matches!(out.status.code(), Some(0 | 3)) {
        Ok(())
    } else {
        Err(format!(
            "sins-calib {}: {}: {}",
            args.join(" "),
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// A short program (56 s: a rest, then one turn about each gimbal between rests), for the
/// commands that need the whole program recorded (`diagnose`) and to keep the runs short.
const SHORT_PROGRAM: &str = r#"name = "audit: one turn about each gimbal"
start_deg = [0.0, 0.0, 0.0]

[[segment]]
kind = "dwell"
duration_s = 5.0

[[segment]]
kind = "rotate"
gimbal = 2
rate_deg_s = 10.0
duration_s = 9.0

[[segment]]
kind = "dwell"
duration_s = 5.0

[[segment]]
kind = "rotate"
gimbal = 3
rate_deg_s = 10.0
duration_s = 9.0

[[segment]]
kind = "dwell"
duration_s = 5.0

[[segment]]
kind = "rotate"
gimbal = 1
rate_deg_s = 10.0
duration_s = 18.0

[[segment]]
kind = "dwell"
duration_s = 5.0
"#;

/// A steady turn about the vertical (heading gimbal) at 20 deg/s for 60 s: a recording whose
/// gyro spread and specific force are those of a rest.
const TURNING_PROGRAM: &str = r#"name = "audit: a steady turn about the vertical"
start_deg = [0.0, 0.0, 0.0]

[[segment]]
kind = "rotate"
gimbal = 1
rate_deg_s = 20.0
duration_s = 60.0
"#;

/// The inputs the cases derive theirs from, in `fx`:
/// - `run.toml`, `short.program.toml`: `examples/run.toml` on the short program;
/// - `sim/`: its simulated run (imu.csv, turntable.csv, truth.json);
/// - `cal.json`: its calibration; `diag.json`: its `diagnose --json`;
/// - `static.toml`, `static.program.toml`, `static/`: a 60-s rest, simulated; `noise.json`:
///   its `noise --json`;
/// - `turning.toml`, `turning.program.toml`, `turning/`: a 60-s steady turn about the vertical
///   at 20 deg/s, simulated;
/// - `ferraris.toml`, `ferraris/`: the Ferraris session imported (imu.csv, sections.json);
///   `ferraris.csv`: its source records;
///   `segments.json`: `segment --json` of it.
fn fixtures(bin: &Path, root: &Path, fx: &Path) -> Result<(), String> {
    let io = |e: std::io::Error| e.to_string();
    std::fs::create_dir_all(fx).map_err(io)?;
    let example = std::fs::read_to_string(root.join("examples/run.toml")).map_err(io)?;
    std::fs::write(fx.join("short.program.toml"), SHORT_PROGRAM).map_err(io)?;
    // The program by its absolute path, so that a copy of the configuration elsewhere reads it.
    let run = example.replace(
        "program = \"paper\"",
        &format!("program = \"{}\"", fx.join("short.program.toml").display()),
    );
    std::fs::write(fx.join("run.toml"), &run).map_err(io)?;
    std::fs::write(
        fx.join("static.program.toml"),
        "name = \"static\"\nstart_deg = [0.0, 0.0, 0.0]\n\n[[segment]]\nkind = \"dwell\"\n\
         duration_s = 60.0\n",
    )
    .map_err(io)?;
    std::fs::write(
        fx.join("static.toml"),
        run.replace("short.program.toml", "static.program.toml"),
    )
    .map_err(io)?;
    let profile = std::fs::read_to_string(root.join("examples/ferraris_session.toml"))
        .map_err(io)?
        .replace("../data/", &format!("{}/data/", root.display()));
    std::fs::write(fx.join("ferraris.toml"), profile).map_err(io)?;
    std::fs::copy(
        root.join("data/real/ferraris_session/example_ferraris_session.csv"),
        fx.join("ferraris.csv"),
    )
    .map_err(io)?;
    std::fs::write(fx.join("turning.program.toml"), TURNING_PROGRAM).map_err(io)?;
    std::fs::write(
        fx.join("turning.toml"),
        run.replace("short.program.toml", "turning.program.toml"),
    )
    .map_err(io)?;
    for args in [
        "simulate --config turning.toml --out turning",
        "simulate --config run.toml --out sim",
        "simulate --config static.toml --out static",
        "calibrate --imu sim/imu.csv --turntable sim/turntable.csv --config run.toml --json cal.json",
        "diagnose --imu sim/imu.csv --turntable sim/turntable.csv --config run.toml --json diag.json",
        "noise --imu static/imu.csv --all-at-rest --json noise.json",
        "import --profile ferraris.toml --out ferraris",
        "segment --imu ferraris/imu.csv --json segments.json",
    ] {
        let args: Vec<&str> = args.split(' ').collect();
        run_fixture(bin, fx, &args)?;
    }
    Ok(())
}

fn substitute(s: &str, fx: &Path, dir: &Path) -> String {
    s.replace("{fx}", &fx.display().to_string())
        .replace("{case}", &dir.display().to_string())
}

/// Split a dotted TOML path, a quoted part kept whole (`truth.values."gyro.bias.x"`).
fn toml_path(p: &str) -> Vec<String> {
    let mut parts = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    for ch in p.chars() {
        match ch {
            '"' => quoted = !quoted,
            '.' if !quoted => parts.push(std::mem::take(&mut cur)),
            c => cur.push(c),
        }
    }
    parts.push(cur);
    parts
}

fn edit_toml(text: &str, f: &FileSpec, fx: &Path, dir: &Path) -> Result<String, String> {
    let mut doc: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
    for (path, value) in &f.set {
        let value = substitute(value, fx, dir);
        let v: toml::Table =
            toml::from_str(&format!("v = {value}")).map_err(|e| format!("{value}: {e}"))?;
        let v = v["v"].clone();
        let parts = toml_path(path);
        let (last, head) = parts.split_last().expect("a path has a part");
        let mut t = &mut doc;
        for p in head {
            t = t
                .entry(p.clone())
                .or_insert_with(|| toml::Value::Table(Default::default()))
                .as_table_mut()
                .ok_or_else(|| format!("{path}: {p} is not a table"))?;
        }
        t.insert(last.clone(), v);
    }
    for path in &f.remove {
        let parts = toml_path(path);
        let (last, head) = parts.split_last().expect("a path has a part");
        let mut t = &mut doc;
        for p in head {
            t = t
                .get_mut(p)
                .and_then(|v| v.as_table_mut())
                .ok_or_else(|| format!("{path}: no table {p}"))?;
        }
        t.remove(last);
    }
    toml::to_string(&doc).map_err(|e| e.to_string())
}

fn edit_json(text: &str, f: &FileSpec) -> Result<String, String> {
    let mut doc: serde_json::Value = serde_json::from_str(text).map_err(|e| e.to_string())?;
    for (name, value) in &f.param {
        let v: serde_json::Value = serde_json::from_str(value).map_err(|e| e.to_string())?;
        let p = doc["parameters"]
            .as_array_mut()
            .and_then(|ps| ps.iter_mut().find(|p| p["name"] == name.as_str()))
            .ok_or_else(|| format!("no parameter {name}"))?;
        p["value"] = v;
    }
    // `get_mut`: indexing would insert a null `parameters` into another kind of file.
    if let Some(ps) = doc.get_mut("parameters").and_then(|p| p.as_array_mut()) {
        ps.retain(|p| !f.drop_param.iter().any(|n| p["name"] == n.as_str()));
    }
    for (pointer, value) in &f.json {
        let v: serde_json::Value = serde_json::from_str(value).map_err(|e| e.to_string())?;
        *doc.pointer_mut(pointer)
            .ok_or_else(|| format!("no {pointer} in the JSON"))? = v;
    }
    serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())
}

fn edit_csv(text: &str, transform: &str) -> Result<String, String> {
    let mut lines: Vec<Vec<String>> = text
        .lines()
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let (op, arg) = transform.split_once(':').unwrap_or((transform, ""));
    let num = |s: &str| s.trim().parse::<f64>().map_err(|e| format!("{s}: {e}"));
    match op {
        "head" => {
            let n: usize = arg.parse().map_err(|e| format!("{transform}: {e}"))?;
            lines.truncate(n + 1);
        }
        "temp" => {
            lines[0].push("temp".into());
            for l in &mut lines[1..] {
                l.push(arg.to_string());
            }
        }
        "ms" | "g" | "swap" => {
            for l in &mut lines[1..] {
                if l.len() < 7 {
                    continue;
                }
                match op {
                    "ms" => l[0] = format!("{}", num(&l[0])? * 1000.0),
                    "g" => {
                        for v in &mut l[4..7] {
                            *v = format!("{}", num(v)? / 9.80665);
                        }
                    }
                    _ => {
                        let (a, b) = l[1..7].split_at_mut(3);
                        a.swap_with_slice(b);
                    }
                }
            }
        }
        "shift" => {
            // `shift:LINE:SECONDS`: SECONDS added to the time of the records from file line
            // LINE (1-based, the header line 1) on: a gap or a jump in the time stamps.
            let (line, by) = arg
                .split_once(':')
                .ok_or_else(|| format!("{transform}: expected shift:LINE:SECONDS"))?;
            let line: usize = line.parse().map_err(|e| format!("{transform}: {e}"))?;
            let by = num(by)?;
            for l in lines.iter_mut().skip(line.max(2) - 1) {
                l[0] = format!("{}", num(&l[0])? + by);
            }
        }
        "swapcols" => {
            // `swapcols:A:B`: the values of columns A and B (0-based) swapped, the header kept.
            let (a, b) = arg
                .split_once(':')
                .ok_or_else(|| format!("{transform}: expected swapcols:A:B"))?;
            let a: usize = a.parse().map_err(|e| format!("{transform}: {e}"))?;
            let b: usize = b.parse().map_err(|e| format!("{transform}: {e}"))?;
            for l in &mut lines[1..] {
                if l.len() > a.max(b) {
                    l.swap(a, b);
                }
            }
        }
        "constant" => {
            // Every record a copy of the first: a stuck sensor.
            let first = lines.get(1).cloned().unwrap_or_default();
            for l in lines.iter_mut().skip(2) {
                let t = std::mem::take(&mut l[0]);
                *l = first.clone();
                l[0] = t;
            }
        }
        _ => return Err(format!("unknown transform {transform}")),
    }
    let mut out = String::new();
    for l in lines {
        out.push_str(&l.join(","));
        out.push('\n');
    }
    Ok(out)
}

fn make_file(path: &Path, f: &FileSpec, fx: &Path, dir: &Path) -> Result<(), String> {
    let io = |e: std::io::Error| format!("{}: {e}", path.display());
    if f.dir {
        std::fs::create_dir_all(path).map_err(io)?;
    } else if f.fifo {
        let s = Command::new("mkfifo").arg(path).status().map_err(io)?;
        if !s.success() {
            return Err(format!("mkfifo {}: {s}", path.display()));
        }
    } else if let Some(n) = f.sparse_bytes {
        std::fs::File::create(path)
            .and_then(|file| file.set_len(n))
            .map_err(io)?;
    } else {
        let mut text = match (&f.from, &f.text) {
            (Some(from), _) => {
                let from = substitute(from, fx, dir);
                std::fs::read_to_string(&from).map_err(|e| format!("{from}: {e}"))?
            }
            (None, Some(t)) => substitute(t, fx, dir),
            (None, None) => String::new(),
        };
        if !f.set.is_empty() || !f.remove.is_empty() {
            text = edit_toml(&text, f, fx, dir)?;
        }
        if !f.param.is_empty() || !f.json.is_empty() || !f.drop_param.is_empty() {
            text = edit_json(&text, f)?;
        }
        for t in &f.transform {
            text = edit_csv(&text, t)?;
        }
        for (piece, times) in &f.pieces {
            text += &piece.repeat(*times);
        }
        for (a, b) in &f.replace {
            let (a, b) = (substitute(a, fx, dir), substitute(b, fx, dir));
            if !text.contains(a.as_str()) {
                return Err(format!("{}: no {a:?} to replace", path.display()));
            }
            text = text.replace(a.as_str(), &b);
        }
        std::fs::write(path, text).map_err(io)?;
    }
    if f.readonly {
        set_mode(path, if f.dir { 0o555 } else { 0o444 });
    }
    Ok(())
}

fn set_mode(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt as _;
    let _ = std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode));
}

/// Everything under `dir` writable again, so that it can be removed.
fn make_writable(dir: &Path) {
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                set_mode(&e.path(), 0o755);
                make_writable(&e.path());
            }
        }
    }
}

/// The files under `dir` with their type, length and a digest of the regular ones.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, (String, u64, u64)> {
    use std::hash::{Hash as _, Hasher as _};
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            let Ok(m) = std::fs::symlink_metadata(&p) else {
                continue;
            };
            let ft = m.file_type();
            let (kind, digest) = if ft.is_dir() {
                stack.push(p.clone());
                ("dir", 0)
            } else if ft.is_file() && m.len() <= 64 << 20 {
                let mut h = std::collections::hash_map::DefaultHasher::new();
                std::fs::read(&p).unwrap_or_default().hash(&mut h);
                ("file", h.finish())
            } else if ft.is_file() {
                ("file", 0)
            } else {
                ("special", 0)
            };
            out.insert(p, (kind.to_string(), m.len(), digest));
        }
    }
    out
}

/// Why an output does not parse, if it does not.
fn check_output(path: &Path) -> Option<String> {
    let shown = path.display();
    let m = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) => return Some(format!("{shown}: missing: {e}")),
    };
    if m.is_dir() {
        let entries = std::fs::read_dir(path).ok()?;
        return entries.flatten().find_map(|e| check_output(&e.path()));
    }
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let bytes = std::fs::read(path).ok()?;
    if bytes.is_empty() {
        return Some(format!("{shown}: empty"));
    }
    let text = || String::from_utf8_lossy(&bytes).into_owned();
    match ext {
        "json" => serde_json::from_slice::<serde_json::Value>(&bytes)
            .err()
            .map(|e| format!("{shown}: not JSON: {e}")),
        "toml" => toml::from_str::<toml::Table>(&text())
            .err()
            .map(|e| format!("{shown}: not TOML: {e}")),
        "png" => (!bytes.starts_with(b"\x89PNG")).then(|| format!("{shown}: not a PNG")),
        "csv" => {
            let t = text();
            let mut lines = t.lines();
            let width = lines.next()?.split(',').count();
            for (k, l) in lines.enumerate() {
                let fields: Vec<&str> = l.split(',').collect();
                if fields.len() != width {
                    return Some(format!("{shown}: line {}: {} fields", k + 2, fields.len()));
                }
                if let Some(f) = fields
                    .iter()
                    .find(|f| !f.trim().parse::<f64>().is_ok_and(f64::is_finite))
                {
                    return Some(format!(
                        "{shown}: line {}: {f:?} not a finite number",
                        k + 2
                    ));
                }
            }
            None
        }
        _ => None,
    }
}

/// Whether a new file can be created in `dir` (not under root's permissions).
fn permissions_enforced(dir: &Path) -> bool {
    let probe = dir.join(".audit-probe");
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            false
        }
        Err(_) => true,
    }
}

/// The case's words missing from its standard error (none when it could not be read).
fn missing_words<'a>(case: &'a CaseSpec, stderr: &str, unread: bool) -> Vec<&'a String> {
    if unread {
        return Vec::new();
    }
    let lower = stderr.to_lowercase();
    case.words
        .iter()
        .filter(|w| !w.split('|').any(|alt| lower.contains(&alt.to_lowercase())))
        .collect()
}

/// /dev/full opened for writing: every write to it fails with ENOSPC.
fn dev_full() -> Result<Stdio, String> {
    std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .map(Stdio::from)
        .map_err(|e| format!("/dev/full: {e}"))
}

/// The command of a case, its standard output and error as the case says.
fn command(bin: &Path, args: &[String], case: &CaseSpec) -> Result<Command, String> {
    let mut cmd = match case.stdout.as_deref() {
        Some("closed") => {
            let mut c = Command::new("/bin/sh");
            c.args(["-c", "exec \"$@\" >&-", "sh"]).arg(bin).args(args);
            c
        }
        Some("full") => {
            let mut c = Command::new(bin);
            c.args(args).stdout(dev_full()?);
            c
        }
        None => {
            let mut c = Command::new(bin);
            c.args(args).stdout(Stdio::piped());
            c
        }
        Some(other) => return Err(format!("stdout = {other:?}: expected closed or full")),
    };
    match case.stderr.as_deref() {
        None | Some("gone") => cmd.stderr(Stdio::piped()),
        Some("full") => cmd.stderr(dev_full()?),
        Some(other) => return Err(format!("stderr = {other:?}: expected full or gone")),
    };
    Ok(cmd)
}

/// What a case's process did: its exit status (`None`: killed at the time limit), what it
/// printed (the first MiB of each stream) and how long it took.
struct Ran {
    status: Option<std::process::ExitStatus>,
    stdout: String,
    stderr: String,
    elapsed: f64,
    limit_s: u64,
}

/// Run the case's command in `dir` until it ends or its time limit passes.
fn run_process(bin: &Path, args: &[String], dir: &Path, case: &CaseSpec) -> Result<Ran, String> {
    let mut cmd = command(bin, args, case)?;
    cmd.current_dir(dir).stdin(Stdio::null());
    let t0 = Instant::now();
    let mut child = cmd.spawn().map_err(|e| format!("{}: {e}", bin.display()))?;
    if case.stderr.as_deref() == Some("gone") {
        // The reader goes before the command writes: its writes fail with EPIPE.
        drop(child.stderr.take());
    }
    let read = |r: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = Vec::new();
            if let Some(mut r) = r {
                let _ = r.by_ref().take(1 << 20).read_to_end(&mut s);
                let _ = std::io::copy(&mut r, &mut std::io::sink());
            }
            String::from_utf8_lossy(&s).into_owned()
        })
    };
    let out_thread = read(
        child
            .stdout
            .take()
            .map(|s| Box::new(s) as Box<dyn std::io::Read + Send>),
    );
    let err_thread = read(
        child
            .stderr
            .take()
            .map(|s| Box::new(s) as Box<dyn std::io::Read + Send>),
    );
    let limit = Duration::from_secs_f64(case.timeout_s.unwrap_or(30.0));
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break Some(s);
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    Ok(Ran {
        status,
        stdout: out_thread.join().unwrap_or_default(),
        stderr: err_thread.join().unwrap_or_default(),
        elapsed: t0.elapsed().as_secs_f64(),
        limit_s: limit.as_secs(),
    })
}

fn run_case(bin: &Path, fx: &Path, dir: &Path, case: &CaseSpec) -> Result<Outcome, String> {
    std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    for (name, f) in &case.files {
        make_file(&dir.join(name), f, fx, dir)?;
    }
    for (name, f) in &case.files {
        if f.readonly && f.dir && !permissions_enforced(&dir.join(name)) {
            return Ok(Outcome {
                class: "skipped",
                detail: "directory permissions are not enforced for this user (root)".into(),
            });
        }
    }
    let args: Vec<String> = case
        .cmd
        .split_whitespace()
        .map(|a| substitute(a, fx, dir))
        .collect();
    let before = snapshot(dir);
    let ran = run_process(bin, &args, dir, case)?;
    let first = ran
        .stderr
        .lines()
        .find(|l| l.starts_with("error") || l.contains("panicked"))
        .or_else(|| ran.stderr.lines().last())
        .unwrap_or("")
        .to_string();
    let (class, what) = judge(fx, dir, case, &ran, &before);
    Ok(Outcome {
        class,
        detail: format!("{what} ({:.2} s) {first}", ran.elapsed),
    })
}

/// The outcome's class and what it saw, from what the case's process did.
fn judge(
    fx: &Path,
    dir: &Path,
    case: &CaseSpec,
    ran: &Ran,
    before: &BTreeMap<PathBuf, (String, u64, u64)>,
) -> (&'static str, String) {
    let Some(status) = ran.status else {
        return ("panic/abort", format!("no end within {} s", ran.limit_s));
    };
    let code = status.code();
    if ran.stderr.contains("panicked") || !matches!(code, Some(0..=3)) {
        return ("panic/abort", format!("{status}"));
    }
    let code = code.expect("an exit code");
    let stderr_unread = case.stderr.is_some();
    let missing = missing_words(case, &ran.stderr, stderr_unread);
    match case.expect {
        Expect::Refuse => {
            if code == 0 || code == 3 {
                return ("silent success", format!("exit {code}"));
            }
            let after = snapshot(dir);
            if *before != after {
                let changed: Vec<String> = before
                    .keys()
                    .chain(after.keys())
                    .filter(|p| before.get(*p) != after.get(*p))
                    .map(|p| p.strip_prefix(dir).unwrap_or(p).display().to_string())
                    .collect::<std::collections::BTreeSet<_>>()
                    .into_iter()
                    .collect();
                return (
                    "damaged output",
                    format!("exit {code}, changed: {}", changed.join(", ")),
                );
            }
            if case.stdout.is_none() && !ran.stdout.trim().is_empty() {
                return (
                    "late refusal",
                    format!("exit {code} after printing {} bytes", ran.stdout.len()),
                );
            }
            if !missing.is_empty() {
                return ("unclear error", format!("exit {code}, lacks {missing:?}:"));
            }
            if let Some(max) = case.max_stderr.filter(|m| ran.stderr.len() > *m) {
                return (
                    "unclear error",
                    format!(
                        "exit {code}, a message of {} bytes (at most {max}):",
                        ran.stderr.len()
                    ),
                );
            }
            ("ok", format!("exit {code}"))
        }
        Expect::Keep => {
            match code {
                1 => {}
                0 | 3 => return ("silent success", format!("exit {code}")),
                _ => return ("refused good input", format!("exit {code}")),
            }
            if let Some(why) = damaged_output(fx, dir, case) {
                return ("damaged output", why);
            }
            if !missing.is_empty() {
                return ("unclear error", format!("exit {code}, lacks {missing:?}:"));
            }
            ("ok", format!("exit {code}"))
        }
        Expect::Succeed => {
            if code == 1 || code == 2 || (case.exit0 && code != 0) {
                return ("refused good input", format!("exit {code}"));
            }
            if let Some(why) = damaged_output(fx, dir, case) {
                return ("damaged output", why);
            }
            for a in &case.absent {
                let a = substitute(a, fx, dir);
                if std::fs::symlink_metadata(&a).is_ok() {
                    return ("damaged output", format!("{a}: left behind"));
                }
            }
            ("ok", format!("exit {code}"))
        }
    }
}

/// The first of the case's outputs that is damaged, and how.
fn damaged_output(fx: &Path, dir: &Path, case: &CaseSpec) -> Option<String> {
    case.outputs
        .iter()
        .find_map(|o| check_output(Path::new(&substitute(o, fx, dir))))
}
