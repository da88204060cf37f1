//! What the CLI tests share: the binary, running it, and scratch directories.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `sins-calib` binary under test.
pub const BIN: &str = env!("CARGO_BIN_EXE_sins-calib");

/// Run the binary with `args` (whatever its exit status).
pub fn run(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Output bytes as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A fresh directory `name` under `group` (one group per test file).
pub fn scratch(group: &str, name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(group)
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch directory");
    dir
}

/// A path as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}
