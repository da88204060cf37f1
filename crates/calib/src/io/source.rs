//! Where the IMU records come from: a source that can be read from its start again, once per
//! pass, so that a calibration never needs the whole file in memory.

use crate::io::{ImuData, ImuKind, ImuReader, ImuRecord, IoError};

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
    /// Replace the contents of `out` with up to `max` next records and their lines; empty at
    /// the end. The passes read in chunks, so that a source behind `dyn ImuSource` costs one
    /// dynamic call per chunk, not one per IMU step.
    fn next_chunk(&mut self, out: &mut Vec<(ImuRecord, usize)>, max: usize) -> Result<(), IoError> {
        fill_chunk(self, out, max)
    }
    /// Every record with its line, when the source holds them all in memory already (a file
    /// read once and kept): a reading then visits them in place rather than copying them out
    /// chunk by chunk. `None` (the default) where they must be read.
    fn held(&self) -> Option<&[(ImuRecord, usize)]> {
        None
    }
}

/// [`ImuSource::next_chunk`] record by record.
fn fill_chunk<S: ImuSource + ?Sized>(
    source: &mut S,
    out: &mut Vec<(ImuRecord, usize)>,
    max: usize,
) -> Result<(), IoError> {
    out.clear();
    while out.len() < max {
        match source.next_record()? {
            Some(r) => out.push(r),
            None => break,
        }
    }
    Ok(())
}

/// One reading of `source` from its first record, in chunks of `chunk` (one dynamic call per
/// chunk): `visit` gets every record with its line, in order, and stops the reading by
/// returning `false` (a later reading starts from the first record again,
/// [`ImuSource::rewind`]). `chunk` is the caller's buffer, so that readings repeated many
/// times do not allocate.
pub fn read_records(
    source: &mut dyn ImuSource,
    chunk: &mut Vec<(ImuRecord, usize)>,
    visit: &mut dyn FnMut(&ImuRecord, usize) -> bool,
) -> Result<(), IoError> {
    /// Records per chunk.
    const CHUNK: usize = 4096;
    source.rewind()?;
    if let Some(all) = source.held() {
        for (r, line) in all {
            if !visit(r, *line) {
                return Ok(());
            }
        }
        return Ok(());
    }
    loop {
        source.next_chunk(chunk, CHUNK)?;
        if chunk.is_empty() {
            return Ok(());
        }
        for (r, line) in chunk.iter() {
            if !visit(r, *line) {
                return Ok(());
            }
        }
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
    fn next_chunk(&mut self, out: &mut Vec<(ImuRecord, usize)>, max: usize) -> Result<(), IoError> {
        out.clear();
        let start = self.next.min(self.data.records.len());
        let end = (start + max).min(self.data.records.len());
        out.extend((start..end).map(|i| (self.data.records[i], i + 2)));
        self.next = end;
        Ok(())
    }
}

/// An `imu.csv` read from its file once per pass. The records of the first reading are kept in
/// memory up to [`FileImu::CACHE_RECORDS`] (a 45-minute run at 100 Hz fits) so that later passes
/// do not parse the file again; a longer file is read again at every pass, and memory stays
/// bounded whatever the length of the run.
#[derive(Debug)]
pub struct FileImu {
    path: std::path::PathBuf,
    file: String,
    reader: Option<ImuReader>,
    kind: ImuKind,
    cache: Vec<(ImuRecord, usize)>,
    /// The cache holds the whole file.
    cached: bool,
    /// The cache was given up (the file is longer than the cache).
    overflowed: bool,
    next: usize,
    size_hint: Option<usize>,
    has_temp: bool,
}

impl FileImu {
    /// Whether the file has a `temp` column (a reading for the temperatures is needed only then).
    pub fn has_temp(&self) -> bool {
        self.has_temp
    }

    /// Records kept in memory at most (80 bytes each).
    pub const CACHE_RECORDS: usize = 500_000;

    /// Open an `imu.csv` (its header is read and checked now).
    pub fn open(path: &std::path::Path) -> Result<Self, IoError> {
        let reader = ImuReader::open(path)?;
        // Progress estimate: about 130 bytes a record in our own files.
        let size_hint = std::fs::metadata(path)
            .ok()
            .map(|m| (m.len() / 130) as usize);
        Ok(Self {
            path: path.to_path_buf(),
            file: path.display().to_string(),
            kind: reader.kind(),
            has_temp: reader.has_temp(),
            reader: Some(reader),
            cache: Vec::new(),
            cached: false,
            overflowed: false,
            next: 0,
            size_hint,
        })
    }
}

impl ImuSource for FileImu {
    fn file(&self) -> &str {
        &self.file
    }
    fn kind(&self) -> ImuKind {
        self.kind
    }
    fn rewind(&mut self) -> Result<(), IoError> {
        self.next = 0;
        if self.cached {
            self.reader = None;
        } else {
            // A reading stopped before the end left the first part of the file in the cache:
            // the cache starts again with the file.
            self.cache.clear();
            if self.reader.as_ref().is_none_or(|r| r.line() > 1) {
                self.reader = Some(ImuReader::open(&self.path)?);
            }
        }
        Ok(())
    }
    fn next_record(&mut self) -> Result<Option<(ImuRecord, usize)>, IoError> {
        if self.cached {
            let r = self.cache.get(self.next).copied();
            self.next += 1;
            return Ok(r);
        }
        let Some(reader) = self.reader.as_mut() else {
            return Ok(None);
        };
        let Some(rec) = reader.next_record()? else {
            // The first complete reading fills the cache unless it overflowed; the reading
            // stays at its end (a call after the end is not the cache's first record).
            self.cached = !self.overflowed;
            self.next = self.cache.len();
            return Ok(None);
        };
        let item = (rec, reader.line());
        if self.cache.is_empty() && !self.overflowed && !self.cached {
            // Reserved at once from the file's size rather than grown by doubling, which
            // copied the records (`docs/performance.md`, "readers").
            let hint = reader.records_hint(crate::io::file_size(&self.path));
            self.cache.reserve(hint.min(Self::CACHE_RECORDS));
        }
        if !self.overflowed {
            if self.cache.len() < Self::CACHE_RECORDS {
                self.cache.push(item);
            } else {
                self.overflowed = true;
                self.cache = Vec::new();
            }
        }
        Ok(Some(item))
    }
    fn held(&self) -> Option<&[(ImuRecord, usize)]> {
        self.cached.then_some(self.cache.as_slice())
    }
    fn len_hint(&self) -> Option<usize> {
        if self.cached {
            Some(self.cache.len())
        } else {
            self.size_hint
        }
    }
    fn next_chunk(&mut self, out: &mut Vec<(ImuRecord, usize)>, max: usize) -> Result<(), IoError> {
        if self.cached {
            out.clear();
            let start = self.next.min(self.cache.len());
            let end = (start + max).min(self.cache.len());
            out.extend_from_slice(&self.cache[start..end]);
            self.next = end;
            return Ok(());
        }
        fill_chunk(self, out, max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reading stopped part of the way and started again must not leave the records it read
    /// in the cache twice.
    #[test]
    fn a_reading_started_again_caches_every_record_once() {
        let dir = std::env::temp_dir().join(format!("file-imu-rewind-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("imu.csv");
        let mut text = String::from("t,dthx,dthy,dthz,dvx,dvy,dvz\n");
        for k in 1..=5 {
            text.push_str(&format!("{}.0,0,0,0,0,0,0.098\n", k));
        }
        std::fs::write(&path, text).unwrap();
        let mut imu = FileImu::open(&path).unwrap();
        let times = |imu: &mut FileImu| {
            imu.rewind().unwrap();
            let mut t = Vec::new();
            while let Some((r, _)) = imu.next_record().unwrap() {
                t.push(r.t);
            }
            t
        };
        imu.rewind().unwrap();
        imu.next_record().unwrap();
        imu.next_record().unwrap();
        let all = vec![1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(times(&mut imu), all);
        // Now from the cache.
        assert_eq!(times(&mut imu), all);
        // A reading in chunks that goes on asking after the end gets nothing more, the first
        // time (from the file) as from the cache.
        let mut imu = FileImu::open(&path).unwrap();
        for _ in 0..2 {
            imu.rewind().unwrap();
            let mut chunk = Vec::new();
            let mut n = 0;
            for _ in 0..4 {
                imu.next_chunk(&mut chunk, 3).unwrap();
                n += chunk.len();
            }
            assert_eq!(n, 5);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
