//! Outputs checked before the work and written atomically.
//!
//! - [`check_file`] / [`check_dir`], before any work: an output file is not a directory, its
//!   directory exists, and it is none of the command's inputs; an output directory is not a
//!   file and holds none of the inputs under the names the command writes.
//! - [`write_file`]: the text goes to a temporary file in the same directory, then is renamed
//!   onto the path, so the path holds either the old file or the whole new one.
//! - [`DirOutput`]: a directory of outputs (`simulate`, `import`) is written into a temporary
//!   sibling directory and swapped in whole on [`DirOutput::commit`]: a directory that did not
//!   exist, or that holds nothing but the command's own outputs of an earlier run, is replaced
//!   by renaming (the old one renamed aside first, then removed), so no stale output survives
//!   and the outputs change together. A directory holding other files too (a result written
//!   there later, the user's notes) is not taken over: each output is renamed over its old
//!   version and the command's output names this run did not write are removed, the other
//!   files kept. On failure (or drop without commit) the temporary directory is removed and the
//!   old outputs stay as they were.

use crate::Error;
use std::path::{Path, PathBuf};

/// A path's canonical form, when it exists.
fn canonical(p: &Path) -> Option<PathBuf> {
    std::fs::canonicalize(p).ok()
}

/// The file a path names, resolved: its canonical form when it exists, else that of its
/// directory joined with its name (a file to be written), else the path as given.
fn resolved(p: &Path) -> PathBuf {
    canonical(p)
        .or_else(|| {
            let name = p.file_name()?;
            Some(canonical(&parent_of(p))?.join(name))
        })
        .unwrap_or_else(|| p.to_path_buf())
}

/// Whether two paths name the same file (existing, or to be written).
fn same_file(a: &Path, b: &Path) -> bool {
    resolved(a) == resolved(b)
}

/// Refuse an existing path that is neither a regular file nor a directory (a device such as
/// /dev/null or /dev/full, a pipe, a socket): the output is written beside it and renamed
/// onto it, which would replace the device with a regular file.
fn check_not_special(path: &Path, option: &str) -> Result<(), Error> {
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() && !m.is_dir() => Err(format!(
            "{option} {}: is not a regular file (a device, pipe or socket): expected the path \
             of a regular file to write (`-` for standard output where the option takes it)",
            path.display()
        )
        .into()),
        _ => Ok(()),
    }
}

/// Check that a file can be created in `dir`, by creating and removing one: a read-only
/// directory (or one on a read-only file system) is refused before the work, not after it.
fn check_writable_dir(dir: &Path, option: &str, path: &Path) -> Result<(), Error> {
    let probe = (0..100)
        .map(|n| dir.join(format!(".sins-calib-probe-{}-{n}", std::process::id())))
        .find(|p| std::fs::symlink_metadata(p).is_err())
        .unwrap_or_else(|| dir.join(".sins-calib-probe"));
    // Removed by the guard's drop, or by the signal thread on an interruption.
    let _guard = crate::signals::Pending::new(&probe);
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => Ok(()),
        Err(e) => Err(format!(
            "{option} {}: cannot write in the directory {}: {e}: expected a writable directory",
            path.display(),
            dir.display()
        )
        .into()),
    }
}

/// The nearest existing ancestor of `dir` (itself when it exists): where a directory output
/// that does not exist yet is created.
fn existing_ancestor(dir: &Path) -> PathBuf {
    let mut d = dir.to_path_buf();
    loop {
        if d.exists() {
            return d;
        }
        match d.parent() {
            Some(p) if !p.as_os_str().is_empty() => d = p.to_path_buf(),
            _ => return PathBuf::from("."),
        }
    }
}

/// The directory a file path lives in (`.` for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Refuse `-` (standard output) for `option` when the standard output was closed (`>&-`).
///
/// The Rust runtime opens /dev/null (read-write) in place of a closed standard descriptor
/// before `main`, so writes to a closed standard output succeed and the JSON would be lost with
/// exit status 0. That /dev/null is told from a redirection (`> /dev/null`, which a shell opens
/// write-only) by its read-write mode, read from /proc (Linux; elsewhere nothing is refused).
fn check_stdout_open(option: &str) -> Result<(), Error> {
    let is_devnull =
        std::fs::read_link("/proc/self/fd/1").is_ok_and(|target| target == Path::new("/dev/null"));
    let read_write = || {
        std::fs::read_to_string("/proc/self/fdinfo/1").is_ok_and(|info| {
            info.lines()
                .find_map(|l| l.strip_prefix("flags:"))
                .and_then(|f| u32::from_str_radix(f.trim(), 8).ok())
                .is_some_and(|flags| flags & 0o3 == 0o2)
        })
    };
    if is_devnull && read_write() {
        return Err(format!(
            "{option} -: standard output is closed: expected an open standard output to write \
             to (or a file path for {option})"
        )
        .into());
    }
    Ok(())
}

/// Check, before any work, that `path` (given by `option`) names a PNG file that can be
/// written ([`check_file`]): the plots are PNG only.
pub fn check_png(path: &Path, option: &str, inputs: &[&Path]) -> Result<(), Error> {
    let png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !png {
        return Err(format!(
            "{option} {}: expected a .png file (plots are written as PNG)",
            path.display()
        )
        .into());
    }
    check_file(path, option, inputs)
}

/// Check, before any work, that `path` (given by `option`) can take an output file: not a
/// directory, in an existing directory, and none of `inputs`.
pub fn check_file(path: &Path, option: &str, inputs: &[&Path]) -> Result<(), Error> {
    if is_stdout(path) {
        return check_stdout_open(option);
    }
    let shown = path.display();
    if path.is_dir() {
        return Err(format!(
            "{option} {shown}: is a directory: expected the path of a file to write"
        )
        .into());
    }
    if path.file_name().is_none() || path.as_os_str().to_string_lossy().ends_with('/') {
        return Err(format!("{option} {shown}: expected the path of a file to write").into());
    }
    check_not_special(path, option)?;
    let dir = parent_of(path);
    if !dir.is_dir() {
        let what = if dir.exists() {
            "is not a directory"
        } else {
            "does not exist"
        };
        return Err(format!(
            "{option} {shown}: the directory {} {what}: expected a file in an existing \
             directory",
            dir.display()
        )
        .into());
    }
    check_writable_dir(&dir, option, path)?;
    if let Some(input) = inputs.iter().find(|i| same_file(path, i)) {
        return Err(format!(
            "{option} {shown}: is an input of this command ({}): expected another file, so \
             that the input is not overwritten",
            input.display()
        )
        .into());
    }
    Ok(())
}

/// Check, before any work, that `dir` (given by `option`) can take the outputs `names`: not an
/// existing file, and none of `inputs` is one of the files that would be replaced there.
pub fn check_dir(dir: &Path, option: &str, names: &[&str], inputs: &[&Path]) -> Result<(), Error> {
    let shown = dir.display();
    let what = if names.is_empty() {
        "its outputs".to_string()
    } else {
        names.join(", ")
    };
    if dir.exists() && !dir.is_dir() {
        return Err(format!(
            "{option} {shown}: is a file: expected a directory (existing or to be created) to \
             write {} into",
            what
        )
        .into());
    }
    if dir.exists() {
        check_writable_dir(dir, option, dir)?;
    }
    // The directory is written beside itself and renamed into place (or created there).
    let beside = existing_ancestor(&parent_of(dir));
    if !beside.is_dir() {
        return Err(format!(
            "{option} {shown}: {} is not a directory: expected a directory (existing or to be \
             created) to write {} into",
            beside.display(),
            what
        )
        .into());
    }
    check_writable_dir(&beside, option, dir)?;
    for name in names {
        let out = dir.join(name);
        check_not_special(&out, option)?;
        if out.is_dir() {
            return Err(format!(
                "{option} {shown}: {} is a directory: expected a file of that name or none",
                out.display()
            )
            .into());
        }
        if let Some(input) = inputs.iter().find(|i| same_file(&out, i)) {
            return Err(format!(
                "{option} {shown}: {} is an input of this command ({}) and would be replaced: \
                 expected another output directory",
                out.display(),
                input.display()
            )
            .into());
        }
    }
    Ok(())
}

/// The outputs of one command, checked before the work in one place: each as
/// [`check_file`], [`check_png`] or [`check_dir`] against the command's inputs, and every one
/// distinct from the others (`--json X --plot X` would otherwise leave one file written over
/// the other). A directory output claims itself and the files it writes there.
pub struct Outputs<'a> {
    inputs: Vec<&'a Path>,
    /// Each claimed file, resolved, with the option that claims it.
    claimed: Vec<(PathBuf, String)>,
}

impl<'a> Outputs<'a> {
    /// Outputs of a command that reads `inputs`.
    pub fn new(inputs: &[&'a Path]) -> Self {
        Self {
            inputs: inputs.to_vec(),
            claimed: Vec::new(),
        }
    }

    /// Claim `files` for the output `path` given by `option`: none may be another output's.
    fn claim(&mut self, option: &str, path: &Path, files: Vec<PathBuf>) -> Result<(), Error> {
        for f in files {
            if let Some((_, other)) = self.claimed.iter().find(|(c, _)| *c == f) {
                return Err(format!(
                    "{option} {}: is also the output of {other}: expected a distinct path for \
                     every output, so that neither is written over the other",
                    path.display()
                )
                .into());
            }
            self.claimed.push((f, option.to_string()));
        }
        Ok(())
    }

    /// An output file ([`check_file`]); `-` (standard output) is not a file and claims nothing.
    pub fn file(&mut self, path: &Path, option: &str) -> Result<(), Error> {
        check_file(path, option, &self.inputs)?;
        if is_stdout(path) {
            return Ok(());
        }
        self.claim(option, path, vec![resolved(path)])
    }

    /// A PNG output file ([`check_png`]).
    pub fn png(&mut self, path: &Path, option: &str) -> Result<(), Error> {
        check_png(path, option, &self.inputs)?;
        self.claim(option, path, vec![resolved(path)])
    }

    /// A directory of outputs `names` ([`check_dir`]).
    pub fn dir(&mut self, dir: &Path, option: &str, names: &[&str]) -> Result<(), Error> {
        check_dir(dir, option, names, &self.inputs)?;
        let mut files = vec![resolved(dir)];
        files.extend(names.iter().map(|n| resolved(&dir.join(n))));
        self.claim(option, dir, files)
    }
}

/// A temporary name beside `path`: `.NAME.tmp-PID-N`.
fn temporary_beside(path: &Path, n: usize) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |s| s.to_string_lossy().into_owned());
    parent_of(path).join(format!(".{name}.tmp-{}-{n}", std::process::id()))
}

/// Whether a temporary of this program, of process `pid`, may be stale: the process is gone.
/// Only where `/proc` tells (Linux); elsewhere nothing is taken as stale.
fn process_gone(pid: u32) -> bool {
    Path::new("/proc/self").exists() && !Path::new(&format!("/proc/{pid}")).exists()
}

/// The process id in a temporary's name after `prefix` (`PID-N`, then an extension or
/// nothing), if the name is one of ours.
fn temporary_pid(name: &str, prefix: &str) -> Option<u32> {
    let rest = name.strip_prefix(prefix)?;
    let (pid, rest) = rest.split_once('-')?;
    let n = rest.split('.').next()?;
    (!n.is_empty() && n.bytes().all(|b| b.is_ascii_digit())).then_some(())?;
    pid.parse().ok()
}

/// Remove the temporaries an earlier run into the same place left (killed with SIGKILL, or by
/// a power cut, before its own clean-up could run: a 7.6-h run left hundreds of megabytes):
/// beside `path`, `.NAME.tmp-PID-N[.ext]` files and directories and `.sins-calib-probe-PID-N`
/// probes of processes that no longer exist. Those of a run still going are left alone.
pub fn remove_stale(path: &Path) {
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return;
    };
    let dir = parent_of(path);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return;
    };
    let ours = format!(".{name}.tmp-");
    for e in entries.flatten() {
        let entry = e.file_name().to_string_lossy().into_owned();
        let pid =
            temporary_pid(&entry, &ours).or_else(|| temporary_pid(&entry, ".sins-calib-probe-"));
        if pid.is_some_and(|p| p != std::process::id() && process_gone(p)) {
            let p = e.path();
            let _ = if e.file_type().is_ok_and(|t| t.is_dir()) {
                std::fs::remove_dir_all(&p)
            } else {
                std::fs::remove_file(&p)
            };
        }
    }
}

/// A temporary name beside `path` that no file has yet (the stale ones of killed runs removed
/// first, [`remove_stale`]).
pub fn fresh_temporary(path: &Path) -> Result<PathBuf, Error> {
    remove_stale(path);
    (0..100)
        .map(|n| temporary_beside(path, n))
        .find(|p| std::fs::symlink_metadata(p).is_err())
        .ok_or_else(|| format!("{}: cannot find a temporary name beside it", path.display()).into())
}

/// Whether an output path is `-`: standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Write `text` to `path` atomically: a temporary file in the same directory, renamed onto it;
/// `-` writes it to standard output, where, unlike a report, a closed pipe is an error: the
/// output asked for is lost, and the exit status must say so.
pub fn write_file(path: &Path, text: &[u8]) -> Result<(), Error> {
    if is_stdout(path) {
        use std::io::Write as _;
        let mut out = std::io::stdout().lock();
        return out
            .write_all(text)
            .and_then(|()| out.flush())
            .map_err(|e| format!("cannot write to standard output (`-`): {e}").into());
    }
    let tmp = fresh_temporary(path)?;
    // Removed on a failure (the guard's drop) and on an interruption (the signal thread).
    let guard = crate::signals::Pending::new(&tmp);
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::File::open(&tmp)?.sync_all())
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    guard.keep();
    Ok(())
}

/// Write the output `path` atomically with `write`, which is given a temporary path beside it
/// (ending in the same extension: the plotting library chooses the image format by it) and
/// must create the file there; the file is then renamed onto `path`. A failure or an
/// interruption leaves no temporary file.
pub fn write_with(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), Error>,
) -> Result<(), Error> {
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    remove_stale(path);
    let tmp = (0..100)
        .map(|n| {
            let mut t = temporary_beside(path, n).into_os_string();
            t.push(&ext);
            PathBuf::from(t)
        })
        .find(|p| !p.exists())
        .ok_or_else(|| format!("{}: cannot find a temporary name beside it", path.display()))?;
    let guard = crate::signals::Pending::new(&tmp);
    write(&tmp)?;
    std::fs::rename(&tmp, path).map_err(|e| format!("{}: cannot write: {e}", path.display()))?;
    guard.keep();
    Ok(())
}

/// A directory of outputs being written (see the module's documentation).
pub struct DirOutput {
    dir: PathBuf,
    tmp: PathBuf,
    /// Removes `tmp` on an interruption (and on drop before the commit).
    guard: Option<crate::signals::Pending>,
    names: Vec<&'static str>,
    committed: bool,
}

impl DirOutput {
    /// Start writing the outputs `names` (every name the command may write) for `dir`: a fresh
    /// temporary sibling directory (the parent is created when missing).
    pub fn begin(dir: &Path, names: &[&'static str]) -> Result<Self, Error> {
        let parent = parent_of(dir);
        std::fs::create_dir_all(&parent)
            .map_err(|e| format!("{}: cannot create the directory: {e}", parent.display()))?;
        remove_stale(dir);
        let tmp = (0..100)
            .map(|n| temporary_beside(dir, n))
            .find(|p| !p.exists())
            .ok_or_else(|| format!("{}: cannot find a temporary name beside it", dir.display()))?;
        let guard = crate::signals::Pending::new(&tmp);
        std::fs::create_dir(&tmp)
            .map_err(|e| format!("{}: cannot create the directory: {e}", tmp.display()))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            tmp,
            guard: Some(guard),
            names: names.to_vec(),
            committed: false,
        })
    }

    /// Whether the existing directory is a real directory (not a link to one) holding nothing
    /// but files of the command's output names.
    fn only_outputs(&self) -> bool {
        let real = std::fs::symlink_metadata(&self.dir).is_ok_and(|m| m.file_type().is_dir());
        real && std::fs::read_dir(&self.dir).is_ok_and(|entries| {
            entries.into_iter().all(|e| {
                e.is_ok_and(|e| {
                    e.file_type().is_ok_and(|t| t.is_file())
                        && self.names.iter().any(|n| e.file_name() == *n)
                })
            })
        })
    }

    /// Where to write output `name` now (inside the temporary directory).
    pub fn path(&self, name: &str) -> PathBuf {
        self.tmp.join(name)
    }

    /// Where output `name` is once committed.
    pub fn final_path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// The temporary directory (for writers that take a directory).
    pub fn tmp_dir(&self) -> &Path {
        &self.tmp
    }

    /// Put the written outputs in place; the command's output names not written this time are
    /// removed from the directory.
    pub fn commit(mut self) -> Result<(), Error> {
        let fail = |p: &Path, e: std::io::Error| -> Error {
            format!("{}: cannot write: {e}", p.display()).into()
        };
        if !self.dir.exists() {
            std::fs::rename(&self.tmp, &self.dir).map_err(|e| fail(&self.dir, e))?;
            self.committed = true;
            return Ok(());
        }
        if self.only_outputs() {
            let aside = (0..100)
                .map(|n| temporary_beside(&self.dir, 100 + n))
                .find(|p| !p.exists())
                .ok_or_else(|| fail(&self.dir, std::io::ErrorKind::AlreadyExists.into()))?;
            std::fs::rename(&self.dir, &aside).map_err(|e| fail(&self.dir, e))?;
            if let Err(e) = std::fs::rename(&self.tmp, &self.dir) {
                // Put the old outputs back.
                let _ = std::fs::rename(&aside, &self.dir);
                return Err(fail(&self.dir, e));
            }
            let _ = std::fs::remove_dir_all(&aside);
            self.committed = true;
            return Ok(());
        }
        // Nothing is moved unless every old output can be replaced.
        if let Some(d) = self
            .names
            .iter()
            .map(|n| self.dir.join(n))
            .find(|p| p.is_dir())
        {
            return Err(format!(
                "{}: is a directory: expected a file of that name or none",
                d.display()
            )
            .into());
        }
        for name in &self.names {
            let (new, old) = (self.tmp.join(name), self.dir.join(name));
            if new.exists() {
                std::fs::rename(&new, &old).map_err(|e| fail(&old, e))?;
            } else if old.is_file() {
                std::fs::remove_file(&old).map_err(|e| fail(&old, e))?;
            }
        }
        let _ = std::fs::remove_dir_all(&self.tmp);
        self.committed = true;
        Ok(())
    }
}

impl Drop for DirOutput {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
        // The temporary directory is gone either way (renamed into place or removed).
        if let Some(g) = self.guard.take() {
            g.keep();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("sins-calib-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn temporaries_of_killed_runs_are_removed_by_the_next_run() {
        let d = scratch("stale");
        let out = d.join("c.csv");
        // A process id no process has (above Linux's largest, 2^22).
        let dead = 4_999_999;
        let stale = d.join(format!(".c.csv.tmp-{dead}-0"));
        let stale_png = d.join(format!(".p.png.tmp-{dead}-3.png"));
        let stale_dir = d.join(format!(".out.tmp-{dead}-100"));
        let live = d.join(format!(".c.csv.tmp-{}-7", std::process::id()));
        let other = d.join(".c.csv.tmp-notes");
        for f in [&stale, &stale_png, &live, &other] {
            std::fs::write(f, "x").unwrap();
        }
        std::fs::create_dir(&stale_dir).unwrap();
        write_file(&out, b"new").unwrap();
        write_with(&d.join("p.png"), |tmp| Ok(std::fs::write(tmp, "png")?)).unwrap();
        DirOutput::begin(&d.join("out"), &["a.txt"])
            .unwrap()
            .commit()
            .unwrap();
        if Path::new("/proc/self").exists() {
            for f in [&stale, &stale_png, &stale_dir] {
                assert!(!f.exists(), "{} left", f.display());
            }
        }
        // A running process's temporary and a name that is not ours stay.
        assert!(live.exists() && other.exists());
    }

    #[test]
    fn files_are_checked_and_replaced_whole() {
        let d = scratch("file");
        let input = d.join("in.csv");
        std::fs::write(&input, "x").unwrap();
        assert!(
            check_file(&d, "--json", &[])
                .unwrap_err()
                .to_string()
                .contains("directory")
        );
        let e = check_file(&input, "--json", &[&input])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--json") && e.contains("input"), "{e}");
        let e = check_file(&d.join("no/such/out.json"), "--out", &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
        let out = d.join("out.json");
        check_file(&out, "--json", &[&input]).unwrap();
        write_file(&out, b"one").unwrap();
        write_file(&out, b"two").unwrap();
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "two");
        // No temporary file is left beside it.
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 2);
    }

    #[test]
    fn outputs_are_distinct_and_a_failed_write_leaves_nothing() {
        let d = scratch("distinct");
        let input = d.join("in.csv");
        std::fs::write(&input, "x").unwrap();
        let mut outputs = Outputs::new(&[&input]);
        outputs.file(&d.join("a.json"), "--json").unwrap();
        // The same file spelled another way, and a file the report directory writes.
        let e = outputs
            .png(&d.join(".").join("a.json"), "--plot")
            .unwrap_err()
            .to_string();
        assert!(e.contains("png"), "{e}");
        let mut outputs = Outputs::new(&[&input]);
        outputs.file(&d.join("x.png"), "--json").unwrap();
        let e = outputs
            .png(&d.join(".").join("x.png"), "--plot")
            .unwrap_err()
            .to_string();
        assert!(e.contains("also the output of --json"), "{e}");
        outputs.file(&d.join("r").join("a.md"), "--x").unwrap_err();
        std::fs::create_dir(d.join("r")).unwrap();
        outputs.file(&d.join("r").join("a.md"), "--x").unwrap();
        let e = outputs
            .dir(&d.join("r"), "--report", &["a.md"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--report") && e.contains("--x"), "{e}");
        // Stdout claims nothing.
        outputs.file(Path::new("-"), "--json").unwrap();
        outputs.file(Path::new("-"), "--json").unwrap();
        // A write that fails midway leaves no temporary file.
        let target = d.join("plot.png");
        let e = write_with(&target, |tmp| {
            assert!(tmp.extension().is_some_and(|e| e == "png"));
            std::fs::write(tmp, "half")?;
            Err("failed".into())
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "failed");
        assert!(!target.exists());
        let names: Vec<_> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        write_with(&target, |tmp| Ok(std::fs::write(tmp, "whole")?)).unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "whole");
    }

    #[test]
    fn directories_are_swapped_without_stale_outputs() {
        let d = scratch("dir");
        let out = d.join("run");
        let names = ["a.csv", "b.json"];
        let w = DirOutput::begin(&out, &names).unwrap();
        std::fs::write(w.path("a.csv"), "1").unwrap();
        std::fs::write(w.path("b.json"), "1").unwrap();
        w.commit().unwrap();
        // Only outputs there: swapped whole, the old b.json gone.
        let w = DirOutput::begin(&out, &names).unwrap();
        std::fs::write(w.path("a.csv"), "2").unwrap();
        w.commit().unwrap();
        assert_eq!(std::fs::read_to_string(out.join("a.csv")).unwrap(), "2");
        assert!(!out.join("b.json").exists());
        assert_eq!(
            std::fs::read_dir(&d).unwrap().count(),
            1,
            "nothing left beside it"
        );
        std::fs::write(out.join("b.json"), "1").unwrap();
        std::fs::write(out.join("mine.txt"), "keep").unwrap();
        // A run that writes only a.csv removes the old b.json and keeps other files.
        let w = DirOutput::begin(&out, &names).unwrap();
        std::fs::write(w.path("a.csv"), "2").unwrap();
        w.commit().unwrap();
        assert_eq!(std::fs::read_to_string(out.join("a.csv")).unwrap(), "2");
        assert!(!out.join("b.json").exists());
        assert!(out.join("mine.txt").exists());
        // A run dropped before its commit changes nothing and leaves no temporary directory.
        let w = DirOutput::begin(&out, &names).unwrap();
        std::fs::write(w.path("a.csv"), "3").unwrap();
        drop(w);
        assert_eq!(std::fs::read_to_string(out.join("a.csv")).unwrap(), "2");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        let file = out.join("a.csv");
        assert!(check_dir(&file, "--out", &names, &[]).is_err());
        let e = check_dir(&out, "--out", &names, &[&file])
            .unwrap_err()
            .to_string();
        assert!(e.contains("would be replaced"), "{e}");
    }
}
