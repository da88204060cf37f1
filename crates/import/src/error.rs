//! Errors of the import: every one names the file, the line where there is one, and what was
//! expected.

use calib::io::IoError;

/// Why an import or a segmentation was refused.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The profile is not valid TOML, has an unknown or mistyped field, or fails a check.
    #[error("{file}: {message}")]
    Profile {
        /// The profile's file name.
        file: String,
        /// What is wrong (TOML errors carry their line and column) and what was expected.
        message: String,
    },
    /// A file not read or not written, a line of it without the expected form, or a file
    /// unusable as a whole (e.g. its specific force is nowhere near g): `calib::io`'s errors,
    /// which name the file, the line where there is one, and what was expected.
    #[error(transparent)]
    Io(#[from] IoError),
}

impl ImportError {
    pub(crate) fn line(file: &str, line: usize, message: impl Into<String>) -> Self {
        Self::Io(IoError::Line {
            file: file.to_string(),
            line,
            message: message.into(),
        })
    }

    pub(crate) fn file(file: &str, message: impl Into<String>) -> Self {
        Self::Io(IoError::File {
            file: file.to_string(),
            message: message.into(),
        })
    }

    pub(crate) fn read(file: &str, source: std::io::Error) -> Self {
        Self::Io(IoError::Read {
            file: file.to_string(),
            source,
        })
    }

    pub(crate) fn write(file: &str, source: std::io::Error) -> Self {
        Self::Io(IoError::Write {
            file: file.to_string(),
            source,
        })
    }

    pub(crate) fn profile(file: &str, message: impl Into<String>) -> Self {
        Self::Profile {
            file: file.to_string(),
            message: message.into(),
        }
    }
}
