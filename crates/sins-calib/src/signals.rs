//! Temporary outputs removed on an interruption (SIGINT, SIGTERM, SIGHUP).
//!
//! Outputs are written to temporary files (and directories) beside their final paths and
//! renamed into place; each is registered here while it exists ([`Pending`]). The signals are
//! blocked in every thread from the start of `main` and received by one thread waiting for
//! them with `sigwait`: the removal then runs as ordinary code in that thread, not in a signal
//! handler (where taking a lock or freeing memory is not allowed), and the program exits with
//! status 128 + the signal's number, as a shell reports a process killed by it.
//!
//! This is the one place with unsafe code: four calls into the C library on a `sigset_t`
//! this module owns, checked by their return values.

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

/// Block the interrupting signals in this thread (and so in every thread it starts) and start
/// the thread that receives them. Called first in `main`, before any other thread exists.
#[cfg(unix)]
#[allow(unsafe_code)]
pub fn install() {
    const SIGNALS: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];
    // SAFETY: `set` is a local `sigset_t` initialised by `sigemptyset` before any other use;
    // `pthread_sigmask` only reads it (the old mask is not asked for: a null pointer).
    let set = unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        if libc::sigemptyset(&mut set) != 0 {
            return;
        }
        for s in SIGNALS {
            if libc::sigaddset(&mut set, s) != 0 {
                return;
            }
        }
        if libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) != 0 {
            return;
        }
        set
    };
    let spawned = std::thread::Builder::new()
        .name("signals".into())
        .spawn(move || {
            loop {
                let mut signal: libc::c_int = 0;
                // SAFETY: `set` is an initialised `sigset_t` owned by this closure and
                // `signal` a valid place for the number received.
                if unsafe { libc::sigwait(&set, &mut signal) } != 0 {
                    continue;
                }
                remove_pending();
                eprintln!("interrupted (signal {signal}): temporary outputs removed");
                std::process::exit(128 + signal);
            }
        });
    if spawned.is_err() {
        // Without the receiving thread, the signals must end the program as they would
        // have: unblock them again.
        // SAFETY: as above.
        unsafe {
            libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        }
    }
}

/// Elsewhere the signals keep their default action (temporary outputs are still removed on
/// failures by [`Pending`]).
#[cfg(not(unix))]
pub fn install() {}
