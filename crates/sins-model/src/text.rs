//! Reading a text input (configuration, program, JSON) whole, with a UTF-8 error that says
//! where: `std::fs::read_to_string` says only "stream did not contain valid UTF-8", which
//! leaves a user to search a 40-MB file for the byte.

use std::io;
use std::path::Path;

/// The file at `path` as a string. Bytes that are not UTF-8 give an error of kind
/// [`io::ErrorKind::InvalidData`] naming the line and column (both from 1, the column in bytes)
/// and the first offending byte; other failures are the file system's.
pub fn read_text(path: &Path) -> io::Result<String> {
    let bytes = std::fs::read(path)?;
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
        let e = read_text(&path).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert_eq!(
            e.to_string(),
            "not UTF-8 at line 3, column 9 (byte 0xff): expected UTF-8 text"
        );
        std::fs::write(&path, "a = \"\u{e9}\"\n").unwrap();
        assert_eq!(read_text(&path).unwrap(), "a = \"\u{e9}\"\n");
        assert_eq!(
            read_text(&dir.join("missing")).unwrap_err().kind(),
            io::ErrorKind::NotFound
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
