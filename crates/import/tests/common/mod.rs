//! The import as the command runs it ([`import::import_into`]) into a fresh directory, and the
//! files it wrote read back: what the tests look at in memory.

#![allow(dead_code)] // each test file uses its part

use calib::io::{ImuData, TurntableData};
use import::profile::Profile;
use import::sections::SectionsFile;
use import::{ImportError, ImportOptions, ImportReport, Written};
use std::path::Path;

/// An import's files, read back.
#[derive(Debug)]
pub struct Imported {
    /// `imu.csv`.
    pub imu: ImuData,
    /// `turntable.csv`, when the source has angles.
    pub turntable: Option<TurntableData>,
    /// `sections.json`, when the profile has a section list.
    pub sections: Option<SectionsFile>,
    /// `import.json`.
    pub report: ImportReport,
    /// Where the files are.
    pub written: Written,
}

/// Import the recording `profile` describes into `dir` (emptied first) and read its files back.
pub fn import_to(
    profile: &Profile,
    options: &ImportOptions,
    dir: &Path,
) -> Result<Imported, ImportError> {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).expect("output directory");
    let files = import::import_into(profile, options, dir)?;
    let imu = calib::io::read_imu_csv(&files.written.imu).expect("imu.csv reads back");
    let turntable = files
        .written
        .turntable
        .as_ref()
        .map(|p| calib::io::read_turntable_csv(p).expect("turntable.csv reads back"));
    let sections = files
        .written
        .sections
        .as_ref()
        .map(|p| SectionsFile::read(p).expect("sections.json reads back"));
    let report: ImportReport =
        serde_json::from_str(&std::fs::read_to_string(&files.written.report).expect("import.json"))
            .expect("import.json reads back");
    assert_eq!(sections.as_ref(), files.sections.as_ref(), "sections.json");
    assert_eq!(report, files.report, "import.json");
    Ok(Imported {
        imu,
        turntable,
        sections,
        report,
        written: files.written,
    })
}
