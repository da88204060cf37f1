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
    /// A line of an input file does not have the expected form.
    #[error("{file}: line {line}: {message}")]
    Line {
        /// File name.
        file: String,
        /// 1-based line number.
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// An input file as a whole is unusable (e.g. its specific force is nowhere near g).
    #[error("{file}: {message}")]
    File {
        /// File name.
        file: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A file could not be read.
    #[error("{file}: cannot read: {source}")]
    Read {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// A file or directory could not be written.
    #[error("{file}: cannot write: {source}")]
    Write {
        /// File name.
        file: String,
        /// Cause.
        source: std::io::Error,
    },
    /// An interchange file (`imu.csv`) refused by its reader, or not written.
    #[error(transparent)]
    Interchange(#[from] IoError),
}

impl ImportError {
    pub(crate) fn line(file: &str, line: usize, message: impl Into<String>) -> Self {
        Self::Line {
            file: file.to_string(),
            line,
            message: message.into(),
        }
    }

    pub(crate) fn file(file: &str, message: impl Into<String>) -> Self {
        Self::File {
            file: file.to_string(),
            message: message.into(),
        }
    }

    pub(crate) fn profile(file: &str, message: impl Into<String>) -> Self {
        Self::Profile {
            file: file.to_string(),
            message: message.into(),
        }
    }
}
