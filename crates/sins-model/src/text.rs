//! Reading a small text input (configuration, profile, program, JSON) whole, with a bound that
//! fits its kind and a UTF-8 error that says where: `std::fs::read_to_string` says only "stream
//! did not contain valid UTF-8", which leaves a user to search a 40-MB file for the byte, and
//! reads a 2-GB file (or /dev/zero, forever) before anything can refuse it.

use std::io::{self, Read as _};
use std::path::Path;

// The bounds: each is a few hundred times the largest real file of its kind, and small enough
// that reading up to it, and parsing what was read, stays within a few times its size in memory
// (the TOML lexer holds several copies of its input, so the TOML bounds are the tightest).

/// A run configuration (the paper's is 4 kB; a hand-written one with every section stays
/// well under 100 kB).
pub const CONFIGURATION_MAX_BYTES: u64 = 1 << 20;
/// An import profile (a few kilobytes: files, columns, units, axes).
pub const PROFILE_MAX_BYTES: u64 = 1 << 20;
/// A rotation program: a generated program of tens of thousands of steps is a few megabytes.
pub const PROGRAM_MAX_BYTES: u64 = 16 << 20;
/// A section list (`sections.json` or an imucal list): one entry per rest or turn, kilobytes
/// for real sessions, megabytes for a generated one.
pub const SECTIONS_MAX_BYTES: u64 = 16 << 20;
/// A result or truth JSON (parameters, covariance, per-rest diagnostics, innovations
/// summaries): tens of kilobytes to a few megabytes for the longest runs.
pub const RESULT_MAX_BYTES: u64 = 64 << 20;

/// `max` in the unit a person reads (`1 MiB`, `512 kiB`, `100 bytes`).
pub fn bound_text(max: u64) -> String {
    if max >= 1 << 20 && max.is_multiple_of(1 << 20) {
        format!("{} MiB", max >> 20)
    } else if max >= 1 << 10 && max.is_multiple_of(1 << 10) {
        format!("{} kiB", max >> 10)
    } else {
        format!("{max} bytes")
    }
}

/// The file at `path`, a `kind` (e.g. "configuration") of at most `max_bytes` bytes, as a
/// string. At most `max_bytes + 1` bytes are ever read, so a regular file past the bound and a
/// device without end (/dev/zero) are refused alike, with an error of kind
/// [`io::ErrorKind::InvalidData`] naming the kind and the bound (the caller names the file).
/// Bytes that are not UTF-8 give an error of the same kind naming the line and column (both
/// from 1, the column in bytes) and the first offending byte; other failures are the file
/// system's.
pub fn read_text_bounded(path: &Path, max_bytes: u64, kind: &str) -> io::Result<String> {
    let file = std::fs::File::open(path)?;
    if file.metadata()?.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("is a directory: expected a {kind} file"),
        ));
    }
    let mut bytes = Vec::new();
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "larger than the bound of {} for a {kind}: expected a {kind} file of at most {}",
                bound_text(max_bytes),
                bound_text(max_bytes)
            ),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let at = e.utf8_error().valid_up_to();
        io::Error::new(io::ErrorKind::InvalidData, not_utf8_message(bytes, at))
    })
}

/// "not UTF-8 at line L, column C (byte 0xNN)" for the invalid byte at offset `at`.
fn not_utf8_message(bytes: &[u8], at: usize) -> String {
    let before = &bytes[..at];
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let column = 1 + before.iter().rev().take_while(|&&b| b != b'\n').count();
    format!(
        "not UTF-8 at line {line}, column {column} (byte 0x{:02x}): expected UTF-8 text",
        bytes[at]
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_names_the_line_and_column_of_the_first_bad_byte() {
        let dir = std::env::temp_dir().join(format!("sins-text-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.toml");
        std::fs::write(
            &path,
            b"a = 1\nb = \"\xc3\xa9\"  # fine\nc = 2 # \xff\xfe\n",
        )
        .unwrap();
        let e = read_text_bounded(&path, 1000, "configuration").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert_eq!(
            e.to_string(),
            "not UTF-8 at line 3, column 9 (byte 0xff): expected UTF-8 text"
        );
        std::fs::write(&path, "a = \"\u{e9}\"\n").unwrap();
        assert_eq!(
            read_text_bounded(&path, 1000, "configuration").unwrap(),
            "a = \"\u{e9}\"\n"
        );
        assert_eq!(
            read_text_bounded(&dir.join("missing"), 1000, "configuration")
                .unwrap_err()
                .kind(),
            io::ErrorKind::NotFound
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_past_its_bound_is_refused_without_being_read_whole() {
        let dir = std::env::temp_dir().join(format!("sins-text-bound-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("big.toml");
        std::fs::write(&path, "a".repeat(1025)).unwrap();
        let e = read_text_bounded(&path, 1024, "profile").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert!(
            e.to_string().contains("1 kiB") && e.to_string().contains("profile"),
            "{e}"
        );
        std::fs::write(&path, "a".repeat(1024)).unwrap();
        assert_eq!(
            read_text_bounded(&path, 1024, "profile").unwrap().len(),
            1024
        );
        // A device without end is refused at the bound, not read forever.
        let zero = Path::new("/dev/zero");
        if zero.exists() {
            let e = read_text_bounded(zero, 1 << 20, "program").unwrap_err();
            assert!(e.to_string().contains("1 MiB"), "{e}");
        }
        assert!(read_text_bounded(&dir, 1024, "profile").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
