//! A CSV file written line by line (the streamed writers of `imu.csv` and `turntable.csv`).

use super::IoError;
use std::path::Path;

/// A file written a line at a time through one reused buffer, counting the records.
pub(super) struct CsvLines {
    out: std::io::BufWriter<std::fs::File>,
    /// The file's name, for messages.
    pub(super) file: String,
    /// Records written (the header not counted).
    pub(super) records: usize,
    /// The line being built; written and cleared by [`CsvLines::write_record`].
    pub(super) line: String,
}

impl CsvLines {
    /// Create the file at `path` and write `header` (with its line end).
    pub(super) fn create(path: &Path, header: String) -> Result<Self, IoError> {
        let file = path.display().to_string();
        let f = std::fs::File::create(path).map_err(|source| IoError::Write {
            file: file.clone(),
            source,
        })?;
        let mut w = Self {
            out: std::io::BufWriter::with_capacity(1 << 16, f),
            file,
            records: 0,
            line: header,
        };
        w.flush_line()?;
        Ok(w)
    }

    fn flush_line(&mut self) -> Result<(), IoError> {
        use std::io::Write as _;
        self.out
            .write_all(self.line.as_bytes())
            .map_err(|source| IoError::Write {
                file: self.file.clone(),
                source,
            })?;
        self.line.clear();
        Ok(())
    }

    /// Write the record built in [`CsvLines::line`].
    pub(super) fn write_record(&mut self) -> Result<(), IoError> {
        self.records += 1;
        self.flush_line()
    }

    /// Flush the file; the number of records written.
    pub(super) fn finish(mut self) -> Result<usize, IoError> {
        use std::io::Write as _;
        self.out.flush().map_err(|source| IoError::Write {
            file: self.file.clone(),
            source,
        })?;
        Ok(self.records)
    }
}
