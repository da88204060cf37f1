//! Temporary outputs removed on an interruption (SIGINT, SIGTERM, SIGHUP).
//!
//! Outputs are written to temporary files (and directories) beside their final paths and
//! renamed into place; each is registered here while it exists ([`Pending`]). The signals are
//! received by one thread through `signal-hook` (whose handler only writes to a pipe): the
//! removal then runs as ordinary code in that thread, not in a signal handler (where taking a
//! lock or freeing memory is not allowed), and the program exits with status 128 + the
//! signal's number, as a shell reports a process killed by it.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The temporary files and directories that exist now.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic while the lock was held leaves a list that is still a list of paths.
    PENDING
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Remove every registered temporary file or directory.
fn remove_pending() {
    for p in pending().drain(..) {
        if p.is_dir() {
            let _ = std::fs::remove_dir_all(&p);
        } else {
            let _ = std::fs::remove_file(&p);
        }
    }
}

/// A temporary file or directory registered for removal: removed when the guard is dropped
/// (a failure, an early return, a panic) unless [`Pending::keep`] was called after it was
/// renamed into place, and by the signal thread on an interruption.
pub struct Pending {
    path: PathBuf,
    kept: bool,
}

impl Pending {
    /// Register `path` (before it is created, so that no moment exists when it is on disk
    /// and unknown here).
    pub fn new(path: &Path) -> Self {
        pending().push(path.to_path_buf());
        Self {
            path: path.to_path_buf(),
            kept: false,
        }
    }

    /// The path is no longer temporary (renamed into place, or removed by its owner).
    pub fn keep(mut self) {
        self.kept = true;
        pending().retain(|p| *p != self.path);
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if self.kept {
            return;
        }
        // Unregistered first, so that the signal thread does not remove it twice.
        pending().retain(|p| *p != self.path);
        if self.path.is_dir() {
            let _ = std::fs::remove_dir_all(&self.path);
        } else {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Start the thread that receives the interrupting signals (`signal-hook`'s iterator: its
/// handler only writes to a pipe, and this thread reads it), removes the temporary outputs and
/// exits with 128 + the signal's number. Called first in `main`.
#[cfg(unix)]
pub fn install() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    // Without the handlers the signals keep their default action (the program ends; the
    // temporary outputs of an interrupted write stay): nothing else to do.
    let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
        return;
    };
    let _ = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            if let Some(signal) = signals.forever().next() {
                remove_pending();
                eprintln!("interrupted (signal {signal}): temporary outputs removed");
                std::process::exit(128 + signal);
            }
        });
}

/// Elsewhere the signals keep their default action (temporary outputs are still removed on
/// failures by [`Pending`]).
#[cfg(not(unix))]
pub fn install() {}
