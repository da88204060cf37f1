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

/// Whether two paths name the same existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    match (canonical(a), canonical(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// The directory a file path lives in (`.` for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
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
        return Ok(());
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
    let dir = parent_of(path);
    if !dir.is_dir() {
        return Err(format!(
            "{option} {shown}: the directory {} does not exist: expected a file in an existing \
             directory",
            dir.display()
        )
        .into());
    }
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
    if dir.exists() && !dir.is_dir() {
        return Err(format!(
            "{option} {shown}: is a file: expected a directory (existing or to be created) to \
             write {} into",
            names.join(", ")
        )
        .into());
    }
    for name in names {
        let out = dir.join(name);
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

/// A temporary name beside `path`: `.NAME.tmp-PID-N`.
fn temporary_beside(path: &Path, n: usize) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "output".into(), |s| s.to_string_lossy().into_owned());
    parent_of(path).join(format!(".{name}.tmp-{}-{n}", std::process::id()))
}

/// Whether an output path is `-`: standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Write `text` to `path` atomically: a temporary file in the same directory, renamed onto it;
/// `-` writes it to standard output.
pub fn write_file(path: &Path, text: &[u8]) -> Result<(), Error> {
    if is_stdout(path) {
        return crate::print(&String::from_utf8_lossy(text));
    }
    let tmp = (0..100)
        .map(|n| temporary_beside(path, n))
        .find(|p| !p.exists())
        .ok_or_else(|| format!("{}: cannot find a temporary name beside it", path.display()))?;
    let result = std::fs::write(&tmp, text)
        .and_then(|()| std::fs::File::open(&tmp)?.sync_all())
        .and_then(|()| std::fs::rename(&tmp, path));
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("{}: cannot write: {e}", path.display()).into()
    })
}

/// A directory of outputs being written (see the module's documentation).
pub struct DirOutput {
    dir: PathBuf,
    tmp: PathBuf,
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
        let tmp = (0..100)
            .map(|n| temporary_beside(dir, n))
            .find(|p| !p.exists())
            .ok_or_else(|| format!("{}: cannot find a temporary name beside it", dir.display()))?;
        std::fs::create_dir(&tmp)
            .map_err(|e| format!("{}: cannot create the directory: {e}", tmp.display()))?;
        Ok(Self {
            dir: dir.to_path_buf(),
            tmp,
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
