//! `cargo xtask docs-check`: the documentation's commands run as written and their printed
//! output compared with what the documentation shows.
//!
//! What is run: every fenced block whose info string is `sh` (or untagged and a command, below) in
//! `README.md` and every `.md` under `docs/`, in
//! the order of the file, one `bash` per block (`set -e -o pipefail`, standard error merged into
//! standard output). Each file's blocks share one working directory: a fresh temporary copy of
//! the repository (every file but `target/`, `.git/` and `out/`), so the commands' relative paths
//! (`examples/run.toml`, `out/xsens`, `docs/noise/...png`) resolve as from the repository's root
//! and nothing in the repository is written. In the blocks:
//!
//! - `sins-calib` is the release binary of the workspace (built first with
//!   `cargo build --release -p sins-calib`, its directory put first on `PATH`), and the prefix
//!   `cargo run --release -p sins-calib --` is replaced by `sins-calib`;
//! - any other `cargo` command runs in the repository itself (it writes only under `target/`);
//! - every `/tmp/` is replaced by a `tmp/` directory of the temporary working directory, and in
//!   the output that directory is written back as `/tmp/`.
//!
//! A block without a language tag (a bare fence) is checked too: it is a command block when its
//! first line that is neither blank nor a `#` comment starts with a command the documentation
//! runs (`sins-calib`, `cargo`, `wc`, `/usr/bin/time`; [`untagged_is_command`]), and otherwise
//! the output of the command block before it, as a `text` block. An untagged block that follows
//! no command block in its section fails the check, naming its line: tag it (`text` for an
//! illustration that is not a command's output, `sh` for a command, or another language).
//!
//! A block is skipped when the line before its fence (blank lines aside) is an HTML comment
//! `<!-- docs-check: skip (why) -->`; skipped blocks are counted and listed with their reason.
//!
//! What is compared: the `text` blocks that follow a `sh` block, up to the next `sh` block or
//! heading, are excerpts of that block's output, in the order the output prints them. The rule
//! for an excerpt: lines are compared after whitespace normalisation (leading and trailing
//! whitespace removed, every run of whitespace made one space) and blank lines are ignored, in
//! the text block and in the output alike. A line that is only `...` stands for any number of
//! skipped output lines; the lines between two such lines (or the block's ends) must appear
//! consecutively in the output, every run after the previous one. A text block may begin and end
//! anywhere in the output (a report's header lines above the excerpt are not part of it), and
//! each text block begins after the end of the one before. So every number a text block shows
//! is checked, and a line the output gained or lost inside an excerpt fails it.
//!
//! JSON examples: a `json` block preceded by `<!-- docs-check: json PATH -->` is compared,
//! after the file's commands have run, with the file PATH (relative to the working directory)
//! they wrote: every number the example shows must be in the file, in the same order, as written
//! or, for a number with a fraction or exponent, to 1e-9 relative (the last bits of a
//! floating-point result may differ between processors); string literals are not compared, and
//! `...` and left-out keys are allowed.
//!
//! The files are independent (each has its own working copy) and are checked `--jobs` (2) at a
//! time; the report lists them in order.
//!
//! The last line printed is `docs-check: N passed, M failed, K skipped` (each command block, each
//! text block and each JSON example counts once; a failed command block fails its text blocks
//! too); the exit status is non-zero when anything failed. With `--keep` the working copies stay,
//! and in each the output of every command block, `docs-check-<file>-<line>.out`, to update a
//! document from.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

/// A fenced block of a Markdown file.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    /// 1-based line of the opening fence.
    pub line: usize,
    /// The info string's first word (`sh`, `text`, ...; empty for a bare fence).
    pub lang: String,
    /// The lines between the fences.
    pub body: Vec<String>,
    /// `Some(reason)` when a `<!-- docs-check: skip (reason) -->` comment precedes the fence.
    pub skip: Option<String>,
    /// `Some(path)` when a `<!-- docs-check: json PATH -->` comment precedes the fence.
    pub json_file: Option<String>,
}

/// One item of a Markdown file for the check: a fenced block or a heading (which ends the text
/// blocks that belong to the command block before it).
#[derive(Debug, Clone, PartialEq)]
pub enum Item {
    Block(Block),
    Heading,
}

/// The fenced blocks and headings of a Markdown file, in order.
pub fn parse_markdown(text: &str) -> Vec<Item> {
    let mut items = Vec::new();
    // The block being read, with its fence.
    let mut open: Option<(String, Block)> = None;
    let mut last_nonblank: Option<String> = None;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if let Some((fence, mut block)) = open.take() {
            if trimmed.trim_end() == fence {
                items.push(Item::Block(block));
                last_nonblank = None;
            } else {
                block.body.push(line.to_string());
                open = Some((fence, block));
            }
            continue;
        }
        if trimmed.starts_with("```") {
            let fence: String = trimmed.chars().take_while(|&c| c == '`').collect();
            let lang = trimmed[fence.len()..]
                .split_whitespace()
                .next()
                .unwrap_or("")
                .to_string();
            let skip = last_nonblank.as_deref().and_then(skip_reason);
            let json_file = last_nonblank.as_deref().and_then(json_file);
            let block = Block {
                line: i + 1,
                lang,
                body: Vec::new(),
                skip,
                json_file,
            };
            open = Some((fence, block));
            continue;
        }
        if line.starts_with('#') {
            items.push(Item::Heading);
        }
        if !line.trim().is_empty() {
            last_nonblank = Some(line.trim().to_string());
        }
    }
    items
}

/// What a `<!-- docs-check: ... -->` line says.
fn directive(line: &str) -> Option<&str> {
    let inner = line.strip_prefix("<!--")?.strip_suffix("-->")?.trim();
    Some(inner.strip_prefix("docs-check:")?.trim())
}

/// The file of a `<!-- docs-check: json PATH -->` line.
fn json_file(line: &str) -> Option<String> {
    let path = directive(line)?.strip_prefix("json ")?.trim();
    (!path.is_empty()).then(|| path.to_string())
}

/// The reason of a `<!-- docs-check: skip (reason) -->` line.
fn skip_reason(line: &str) -> Option<String> {
    let rest = directive(line)?.strip_prefix("skip")?.trim();
    let reason = rest
        .strip_prefix('(')
        .and_then(|r| r.strip_suffix(')'))
        .unwrap_or(rest);
    Some(reason.trim().to_string())
}

/// A command block with the text blocks that show its output.
#[derive(Debug)]
pub struct Case {
    pub command: Block,
    pub outputs: Vec<Block>,
}

/// The commands whose first word makes an untagged block a command block.
const COMMAND_WORDS: [&str; 4] = ["sins-calib", "cargo", "wc", "/usr/bin/time"];

/// Whether an untagged block is a command block: its first line that is neither blank nor a
/// `#` comment starts with one of [`COMMAND_WORDS`] (or a `$ ` prompt).
pub fn untagged_is_command(body: &[String]) -> bool {
    body.iter()
        .map(|l| l.trim())
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|l| {
            l.starts_with("$ ")
                || COMMAND_WORDS
                    .iter()
                    .any(|w| l.split_whitespace().next() == Some(*w))
        })
}

/// The `sh` blocks of a file, each with the `text` blocks after it (up to the next `sh` block or
/// heading); untagged blocks count as `sh` or `text` ([`untagged_is_command`]). Returns also
/// the lines of the untagged blocks that are not a command and follow none.
pub fn cases(items: &[Item]) -> (Vec<Case>, Vec<usize>) {
    let mut cases: Vec<Case> = Vec::new();
    let mut orphans = Vec::new();
    let mut in_scope = false;
    for item in items {
        match item {
            Item::Heading => in_scope = false,
            Item::Block(b)
                if b.lang == "sh" || (b.lang.is_empty() && untagged_is_command(&b.body)) =>
            {
                cases.push(Case {
                    command: b.clone(),
                    outputs: Vec::new(),
                });
                in_scope = true;
            }
            Item::Block(b) if (b.lang == "text" || b.lang.is_empty()) && in_scope => {
                if let Some(c) = cases.last_mut() {
                    c.outputs.push(b.clone());
                }
            }
            Item::Block(b) if b.lang.is_empty() && b.skip.is_none() => orphans.push(b.line),
            Item::Block(_) => {}
        }
    }
    (cases, orphans)
}

/// A line with its whitespace normalised.
fn normalise(line: &str) -> String {
    line.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The non-blank lines of a text, normalised.
pub fn normalised_lines<'a>(lines: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    lines
        .into_iter()
        .map(normalise)
        .filter(|l| !l.is_empty())
        .collect()
}

/// Matches an excerpt (normalised lines, `...` for skipped lines) against the output's
/// normalised lines from `from` on. Returns the index after the excerpt's last line, or a
/// message naming the first line that does not match and what the output has there.
pub fn match_excerpt(excerpt: &[String], output: &[String], from: usize) -> Result<usize, String> {
    let mut pos = from;
    for run in excerpt.split(|l| l == "...") {
        if run.is_empty() {
            continue;
        }
        let found = (pos..output.len().saturating_sub(run.len() - 1))
            .find(|&i| output[i..i + run.len()] == *run);
        match found {
            Some(i) => pos = i + run.len(),
            None => {
                // The longest prefix of the run found in order, to name the line that differs.
                let mut best = (0usize, pos);
                for i in pos..output.len() {
                    let n = run
                        .iter()
                        .zip(&output[i..])
                        .take_while(|(a, b)| a == b)
                        .count();
                    if n > best.0 {
                        best = (n, i);
                    }
                }
                let (n, i) = best;
                return Err(if n == 0 {
                    format!(
                        "the documented line\n        {}\n      is not in the output (after line {} of {})",
                        run[0],
                        pos,
                        output.len()
                    )
                } else {
                    let got = output
                        .get(i + n)
                        .map_or("(end of output)".to_string(), |s| s.clone());
                    format!(
                        "after {n} matching line(s) from output line {}, the documentation has\n        {}\n      where the output has\n        {}",
                        i + 1,
                        run[n],
                        got
                    )
                });
            }
        }
    }
    Ok(pos)
}

/// The numbers of a JSON text, as written, in order (string literals left out).
pub fn json_numbers(text: &str) -> Vec<String> {
    let mut numbers = Vec::new();
    let mut chars = text.chars().peekable();
    let mut current = String::new();
    let mut flush = |current: &mut String| {
        if current.chars().any(|c| c.is_ascii_digit()) {
            numbers.push(std::mem::take(current));
        } else {
            current.clear();
        }
    };
    while let Some(c) = chars.next() {
        if c == '"' {
            flush(&mut current);
            while let Some(d) = chars.next() {
                match d {
                    '\\' => {
                        chars.next();
                    }
                    '"' => break,
                    _ => {}
                }
            }
        } else if c.is_ascii_digit()
            || (matches!(c, '-' | '+' | '.' | 'e' | 'E') && !current.is_empty())
            || (c == '-' && current.is_empty())
        {
            current.push(c);
        } else {
            flush(&mut current);
        }
    }
    flush(&mut current);
    numbers
}

/// Two numbers as written in JSON are the same: equal as written, or equal to 1e-9 relative
/// when either has a fraction or exponent (the last bits of floating-point results may differ
/// between processors, e.g. with and without fused multiply-add).
fn same_number(a: &str, b: &str) -> bool {
    if a == b {
        return true;
    }
    let float = |s: &str| s.contains(['.', 'e', 'E']);
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) if float(a) || float(b) => (x - y).abs() <= 1e-9 * x.abs().max(y.abs()),
        _ => false,
    }
}

/// Checks that the numbers of a JSON example appear in the file's JSON in the same order (the
/// example may leave anything out with `...`). Returns the count checked or a message naming the
/// first number not found.
pub fn match_json_numbers(example: &str, file: &str) -> Result<usize, String> {
    let (want, have) = (json_numbers(example), json_numbers(file));
    let mut pos = 0;
    for (k, n) in want.iter().enumerate() {
        match have[pos..].iter().position(|h| same_number(n, h)) {
            Some(i) => pos += i + 1,
            None => {
                let near = have.get(pos).map_or("(end of file)", String::as_str);
                return Err(format!(
                    "number {} of the example, {n}, is not in the file after the number before it (the file has {near} next)",
                    k + 1
                ));
            }
        }
    }
    Ok(want.len())
}

/// The script that runs a `sh` block: the prelude and the block with its substitutions.
fn script(body: &[String], tmp: &Path, root: &Path, bin_dir: &Path) -> String {
    let tmp_prefix = format!("{}/", tmp.display());
    let mut s = String::new();
    s.push_str("set -e -o pipefail\nexec 2>&1\n");
    s.push_str(&format!(
        "export PATH={}:\"$PATH\"\n",
        shell_quote(&bin_dir.display().to_string())
    ));
    s.push_str(&format!(
        "cargo() {{ (cd {} && command cargo \"$@\"); }}\n",
        shell_quote(&root.display().to_string())
    ));
    for line in body {
        let line = line
            .replace("cargo run --release -p sins-calib --", "sins-calib")
            .replace("/tmp/", &tmp_prefix);
        s.push_str(&line);
        s.push('\n');
    }
    s
}

fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// Copies the repository into `dest`, leaving out `target/`, `.git/` and `out/` at its root.
fn copy_repository(root: &Path, dest: &Path) -> std::io::Result<()> {
    fn copy_dir(from: &Path, to: &Path, top: bool) -> std::io::Result<()> {
        std::fs::create_dir_all(to)?;
        for entry in std::fs::read_dir(from)? {
            let entry = entry?;
            let name = entry.file_name();
            if top && matches!(name.to_str(), Some("target" | ".git" | "out" | "target-wt")) {
                continue;
            }
            let ty = entry.file_type()?;
            let (src, dst) = (entry.path(), to.join(&name));
            if ty.is_dir() {
                copy_dir(&src, &dst, false)?;
            } else if ty.is_file() {
                std::fs::copy(&src, &dst)?;
            }
        }
        Ok(())
    }
    copy_dir(root, dest, true)
}

/// The Markdown files checked: `README.md` and every `.md` under `docs/` (the report example's
/// too), in name order.
fn markdown_files(root: &Path) -> std::io::Result<Vec<PathBuf>> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
        for e in std::fs::read_dir(dir)? {
            let p = e?.path();
            if p.is_dir() {
                walk(&p, out)?;
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
        Ok(())
    }
    let mut docs = Vec::new();
    walk(&root.join("docs"), &mut docs)?;
    docs.sort();
    let mut files = vec![root.join("README.md")];
    files.extend(docs);
    Ok(files)
}

#[derive(Default)]
struct Tally {
    passed: usize,
    failed: usize,
    skipped: usize,
}

/// A file's report as it is written, and its counts.
#[derive(Default)]
struct Log {
    report: String,
    tally: Tally,
}

impl Log {
    fn say(&mut self, line: String) {
        self.report.push_str(&line);
        self.report.push('\n');
    }
}

/// Runs the blocks of one file in the working copy `work`; returns the report and the counts.
fn check_file(rel: &str, file: &Path, work: &Path, root: &Path, bin_dir: &Path) -> (String, Tally) {
    let mut log = Log::default();
    let text = match std::fs::read_to_string(file) {
        Ok(t) => t,
        Err(e) => {
            log.say(format!("FAIL {rel}: cannot read: {e}"));
            log.tally.failed += 1;
            return (log.report, log.tally);
        }
    };
    let items = parse_markdown(&text);
    let (cases, orphans) = cases(&items);
    for line in orphans {
        log.say(format!(
            "FAIL {rel}:{line}: a block without a language tag that is neither a command nor \
             follows one: tag it (`text` for an illustration, `sh` for a command)"
        ));
        log.tally.failed += 1;
    }
    if cases.is_empty() {
        return (log.report, log.tally);
    }
    if let Err(e) = copy_repository(root, work).and_then(|_| {
        let _ = std::fs::remove_dir_all(work.join("tmp"));
        std::fs::create_dir_all(work.join("tmp"))
    }) {
        log.say(format!(
            "FAIL {rel}: cannot copy the repository to {}: {e}",
            work.display()
        ));
        log.tally.failed += 1;
        return (log.report, log.tally);
    }
    let place = Place {
        rel,
        work,
        root,
        bin_dir,
    };
    for case in &cases {
        run_block(&place, case, &mut log);
    }
    check_json_examples(rel, work, &items, &mut log);
    (log.report, log.tally)
}

/// Where a file's blocks run: the file, its working copy, the repository and the binaries.
struct Place<'a> {
    rel: &'a str,
    work: &'a Path,
    root: &'a Path,
    bin_dir: &'a Path,
}

/// Runs one command block and compares its output with the text blocks after it.
fn run_block(place: &Place, case: &Case, log: &mut Log) {
    let Place {
        rel,
        work,
        root,
        bin_dir,
    } = *place;
    let tmp = work.join("tmp");
    let at = format!("{rel}:{}", case.command.line);
    if let Some(reason) = &case.command.skip {
        log.say(format!(
            "skip {at} ({reason}){}",
            if case.outputs.is_empty() {
                String::new()
            } else {
                format!(", and its {} output block(s)", case.outputs.len())
            }
        ));
        log.tally.skipped += 1 + case.outputs.len();
        return;
    }
    let t = Instant::now();
    let out = Command::new("bash")
        .arg("-c")
        .arg(script(&case.command.body, &tmp, root, bin_dir))
        .current_dir(work)
        .stdin(Stdio::null())
        .stderr(Stdio::inherit())
        .output();
    let secs = t.elapsed().as_secs_f64();
    let out = match out {
        Ok(o) => o,
        Err(e) => {
            log.say(format!("FAIL {at}: cannot run bash: {e}"));
            log.tally.failed += 1 + case.outputs.len();
            return;
        }
    };
    let printed =
        String::from_utf8_lossy(&out.stdout).replace(&format!("{}/", tmp.display()), "/tmp/");
    // What the block printed, for updating the documentation from it (`--keep`).
    let _ = std::fs::write(
        work.join(format!("docs-check-{}.out", at.replace(['/', ':'], "-"))),
        printed.as_bytes(),
    );
    if !out.status.success() {
        log.say(format!(
            "FAIL {at}: the commands exited with {} after {secs:.1} s; their last output:",
            out.status
        ));
        let lines: Vec<&str> = printed.lines().collect();
        for l in &lines[lines.len().saturating_sub(15)..] {
            log.say(format!("      | {l}"));
        }
        log.tally.failed += 1 + case.outputs.len();
        return;
    }
    log.say(format!("ok   {at}: ran in {secs:.1} s"));
    log.tally.passed += 1;
    let output = normalised_lines(printed.lines());
    let mut pos = 0;
    for block in &case.outputs {
        let excerpt = normalised_lines(block.body.iter().map(String::as_str));
        match match_excerpt(&excerpt, &output, pos) {
            Ok(next) => {
                log.say(format!(
                    "ok   {rel}:{}: output as shown ({} lines)",
                    block.line,
                    excerpt.iter().filter(|l| *l != "...").count()
                ));
                log.tally.passed += 1;
                pos = next;
            }
            Err(why) => {
                log.say(format!(
                    "FAIL {rel}:{}: output differs from the command's ({at}):\n      {why}",
                    block.line
                ));
                log.tally.failed += 1;
            }
        }
    }
}

/// The JSON examples of a file, against the files its commands wrote.
fn check_json_examples(rel: &str, work: &Path, items: &[Item], log: &mut Log) {
    for item in items {
        let Item::Block(block) = item else { continue };
        let Some(path) = &block.json_file else {
            continue;
        };
        let at = format!("{rel}:{}", block.line);
        match std::fs::read_to_string(work.join(path)) {
            Ok(file) => match match_json_numbers(&block.body.join("\n"), &file) {
                Ok(n) => {
                    log.say(format!(
                        "ok   {at}: JSON example's {n} numbers as in {path}"
                    ));
                    log.tally.passed += 1;
                }
                Err(why) => {
                    log.say(format!(
                        "FAIL {at}: JSON example differs from {path}: {why}"
                    ));
                    log.tally.failed += 1;
                }
            },
            Err(e) => {
                log.say(format!(
                    "FAIL {at}: {path}: cannot read (written by no command before?): {e}"
                ));
                log.tally.failed += 1;
            }
        }
    }
}

/// `cargo build --release -p sins-calib`: the binary the blocks run.
fn build_cli(root: &Path) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    println!("docs-check: building sins-calib (cargo build --release -p sins-calib)");
    match Command::new(&cargo)
        .current_dir(root)
        .args(["build", "--release", "--quiet", "-p", "sins-calib"])
        .status()
    {
        Ok(s) if s.success() => Ok(()),
        Ok(s) => Err(format!("cargo build --release -p sins-calib failed ({s})")),
        Err(e) => Err(format!("cannot run {cargo}: {e}")),
    }
}

/// `cargo xtask docs-check`: see the module's documentation.
pub fn docs_check(only: &[String], keep: bool, jobs: usize) -> ExitCode {
    let t0 = Instant::now();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lies in the workspace")
        .to_path_buf();
    if let Err(e) = build_cli(&root) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|p| if p.is_absolute() { p } else { root.join(p) })
        .unwrap_or_else(|| root.join("target"));
    let bin_dir = target.join("release");
    let files = match markdown_files(&root) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: {}: cannot list docs/: {e}", root.display());
            return ExitCode::FAILURE;
        }
    };
    let scratch = std::env::temp_dir().join(format!("docs-check-{}", std::process::id()));
    let selected: Vec<(usize, &PathBuf, String)> = files
        .iter()
        .enumerate()
        .map(|(k, f)| {
            let rel = f.strip_prefix(&root).unwrap_or(f).display().to_string();
            (k, f, rel)
        })
        .filter(|(_, _, rel)| {
            only.is_empty() || only.iter().any(|o| rel == o || rel.ends_with(o.as_str()))
        })
        .collect();
    // The files are independent (each its own working copy): `jobs` of them at a time, their
    // reports printed in the files' order.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let (send, receive) = std::sync::mpsc::channel::<(usize, String, Tally)>();
    let mut tally = Tally::default();
    std::thread::scope(|s| {
        for _ in 0..jobs.max(1) {
            let send = send.clone();
            let (next, selected, scratch, root, bin_dir) =
                (&next, &selected, &scratch, &root, &bin_dir);
            s.spawn(move || {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    let Some((k, file, rel)) = selected.get(i) else {
                        break;
                    };
                    let work = scratch.join(format!("{k}"));
                    let (report, t) = check_file(rel, file, &work, root, bin_dir);
                    if !keep {
                        let _ = std::fs::remove_dir_all(&work);
                    }
                    if send.send((i, report, t)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(send);
        let mut done = std::collections::BTreeMap::new();
        let mut printed = 0;
        for (i, report, t) in receive {
            done.insert(i, (report, t));
            while let Some((report, t)) = done.remove(&printed) {
                print!("{report}");
                tally.passed += t.passed;
                tally.failed += t.failed;
                tally.skipped += t.skipped;
                printed += 1;
            }
        }
    });
    if keep {
        println!("working copies kept in {}", scratch.display());
    } else {
        let _ = std::fs::remove_dir_all(&scratch);
    }
    println!(
        "docs-check: {} passed, {} failed, {} skipped ({:.0} s)",
        tally.passed,
        tally.failed,
        tally.skipped,
        t0.elapsed().as_secs_f64()
    );
    if tally.failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(s: &str) -> Vec<String> {
        normalised_lines(s.lines())
    }

    #[test]
    fn blocks_skips_and_scopes() {
        let md = "# T\n\n```sh\na\n```\n\nprose\n\n```text\nout\n```\n\n## H\n\n```text\nnot output\n```\n\n<!-- docs-check: skip (takes 3 min) -->\n```sh\nslow\n```\n";
        let (c, orphans) = cases(&parse_markdown(md));
        assert!(orphans.is_empty());
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].command.body, vec!["a"]);
        assert_eq!(c[0].outputs.len(), 1);
        assert_eq!(c[0].outputs[0].body, vec!["out"]);
        assert_eq!(c[0].command.skip, None);
        assert_eq!(c[1].command.skip.as_deref(), Some("takes 3 min"));
        assert_eq!(c[1].command.line, 20);
    }

    #[test]
    fn untagged_blocks_are_commands_or_outputs() {
        let md = "# T\n\n```\n# a comment\ncargo xtask paper-check\n```\n\n```\nprinted\n```\n\n## H\n\n```\nnot after a command\n```\n\n```\n$ sins-calib --help\n```\n";
        let (c, orphans) = cases(&parse_markdown(md));
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].command.body[1], "cargo xtask paper-check");
        assert_eq!(c[0].outputs.len(), 1);
        assert_eq!(c[0].outputs[0].body, vec!["printed"]);
        assert_eq!(orphans, vec![14]);
        assert!(c[1].outputs.is_empty());
        assert!(!untagged_is_command(&["cargo-like output".to_string()]));
        assert!(untagged_is_command(&["  sins-calib simulate".to_string()]));
    }

    #[test]
    fn excerpts_match_in_order_and_fail_on_a_changed_number() {
        let out = lines("header\n  a   1.0\n b 2.0\n\n c 3.0\n d 4.0\n");
        assert_eq!(match_excerpt(&lines("a 1.0\nb 2.0"), &out, 0), Ok(3));
        assert_eq!(match_excerpt(&lines("a 1.0\n...\nd 4.0"), &out, 0), Ok(5));
        // Without `...` lines must be consecutive.
        assert!(match_excerpt(&lines("a 1.0\nc 3.0"), &out, 0).is_err());
        // A changed number fails.
        let e = match_excerpt(&lines("a 1.0\nb 2.1"), &out, 0).unwrap_err();
        assert!(e.contains("b 2.1") && e.contains("b 2.0"), "{e}");
        // Out of order fails; a second excerpt starts after the first.
        assert!(match_excerpt(&lines("c 3.0\n...\na 1.0"), &out, 0).is_err());
        assert!(match_excerpt(&lines("a 1.0"), &out, 3).is_err());
    }

    #[test]
    fn scripts_run_the_workspace_binary_and_redirect_tmp() {
        let body = vec![
            "cargo run --release -p sins-calib -- simulate --out /tmp/run".to_string(),
            "sins-calib calibrate --imu /tmp/run/imu.csv".to_string(),
        ];
        let s = script(
            &body,
            Path::new("/w/tmp"),
            Path::new("/repo"),
            Path::new("/repo/target/release"),
        );
        assert!(
            s.contains("\nsins-calib simulate --out /w/tmp/run\n"),
            "{s}"
        );
        assert!(
            s.contains("\nsins-calib calibrate --imu /w/tmp/run/imu.csv\n"),
            "{s}"
        );
        assert!(s.contains("export PATH='/repo/target/release':"), "{s}");
        assert!(s.starts_with("set -e -o pipefail\nexec 2>&1\n"), "{s}");
        assert_eq!(
            skip_reason("<!-- docs-check: skip (takes 3 min) -->").as_deref(),
            Some("takes 3 min")
        );
        assert_eq!(skip_reason("<!-- other -->"), None);
    }

    #[test]
    fn json_examples_compare_their_numbers() {
        let file = r#"{"a": [1.5e-6, -2, {"s": "x 16 y"}], "b": 0.000010343, "c": 3.0}"#;
        assert_eq!(
            json_numbers(file),
            vec!["1.5e-6", "-2", "0.000010343", "3.0"]
        );
        assert_eq!(
            match_json_numbers(r#"{"a": [1.5e-6, ...], "c": 3.0}"#, file),
            Ok(2)
        );
        assert!(match_json_numbers(r#"{"c": 3.0, "a": [1.5e-6]}"#, file).is_err());
        let e = match_json_numbers(r#"{"b": 0.000010344}"#, file).unwrap_err();
        assert!(e.contains("0.000010344"), "{e}");
        // The last bits may differ; the digits a reader reads may not.
        assert_eq!(
            match_json_numbers(r#"{"b": 0.0000103430000001}"#, file),
            Ok(1)
        );
        assert!(match_json_numbers(r#"{"b": 0.00001034301}"#, file).is_err());
        assert!(match_json_numbers(r#"{"a": [1.5e-6, -3]}"#, file).is_err());
        let md = "<!-- docs-check: json out/r.json -->\n```json\n{}\n```\n";
        let items = parse_markdown(md);
        let Item::Block(b) = &items[0] else {
            panic!("{items:?}")
        };
        assert_eq!(b.json_file.as_deref(), Some("out/r.json"));
    }
}
