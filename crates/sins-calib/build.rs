//! The git commit the program is built from, for the reports it writes
//! (`SINS_CALIB_GIT_COMMIT`): `git rev-parse HEAD` when the source is a git checkout and git is
//! there, "unknown" otherwise. The build never fails for want of git.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Run git with `args` in the crate's directory; its trimmed output when it succeeds.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()?;
    let text = String::from_utf8(out.stdout).ok()?;
    (out.status.success() && !text.trim().is_empty()).then(|| text.trim().to_string())
}

/// Rebuild when HEAD moves: the HEAD file, the branch's ref and the packed refs.
fn watch_head() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let absolute = |p: String| -> PathBuf {
        let p = PathBuf::from(p);
        if p.is_absolute() { p } else { dir.join(p) }
    };
    let (Some(git_dir), Some(common)) = (
        git(&["rev-parse", "--git-dir"]).map(absolute),
        git(&["rev-parse", "--git-common-dir"]).map(absolute),
    ) else {
        return;
    };
    let mut watched = vec![git_dir.join("HEAD"), common.join("packed-refs")];
    if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
        watched.push(common.join(branch));
    }
    // Only files that exist: a missing one would rerun this script on every build.
    for p in watched.iter().filter(|p| p.is_file()) {
        println!("cargo:rerun-if-changed={}", p.display());
    }
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let commit = git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".to_string());
    watch_head();
    println!("cargo:rustc-env=SINS_CALIB_GIT_COMMIT={commit}");
}
