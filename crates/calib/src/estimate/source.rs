//! Where the IMU records come from: a source that can be read from its start again, once per
//! pass, so that a calibration never needs the whole file in memory.

use crate::io::{ImuData, ImuKind, ImuRecord, IoError};

/// IMU records in time order, readable from the start again (one reading per pass).
pub trait ImuSource {
    /// The file name, for messages.
    fn file(&self) -> &str;
    /// Increments or rates.
    fn kind(&self) -> ImuKind;
    /// Start again at the first record.
    fn rewind(&mut self) -> Result<(), IoError>;
    /// The next record and its line in the file; `None` at the end.
    fn next_record(&mut self) -> Result<Option<(ImuRecord, usize)>, IoError>;
    /// An estimate of the number of records (for progress reports), if known before reading.
    fn len_hint(&self) -> Option<usize> {
        None
    }
}

/// Records already in memory (a parsed file or a simulation).
#[derive(Clone, Debug)]
pub struct MemoryImu<'a> {
    data: &'a ImuData,
    file: &'a str,
    next: usize,
}

impl<'a> MemoryImu<'a> {
    /// Records of `data`, named `file` in messages; record `i` is on line `i + 2` (a header
    /// line first).
    pub fn new(data: &'a ImuData, file: &'a str) -> Self {
        Self {
            data,
            file,
            next: 0,
        }
    }
}

impl ImuSource for MemoryImu<'_> {
    fn file(&self) -> &str {
        self.file
    }
    fn kind(&self) -> ImuKind {
        self.data.kind
    }
    fn rewind(&mut self) -> Result<(), IoError> {
        self.next = 0;
        Ok(())
    }
    fn next_record(&mut self) -> Result<Option<(ImuRecord, usize)>, IoError> {
        let r = self.data.records.get(self.next).copied();
        self.next += 1;
        Ok(r.map(|r| (r, self.next + 1)))
    }
    fn len_hint(&self) -> Option<usize> {
        Some(self.data.records.len())
    }
}
