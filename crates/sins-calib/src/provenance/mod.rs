//! Where a result comes from: the unit it is of (`[unit]` of a configuration or import profile,
//! `--unit-model` / `--unit-serial`), the SHA-256 of every input file, the `import.json` an
//! `imu.csv` was imported with (its profile and raw files), and the schema stamp of the JSON
//! files the commands read (`calib::io::schema`).

pub mod identification;
pub mod sha256;

use crate::Error;
use calib::config::UnitIdentity;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The unit options of the commands that write or apply a result.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct UnitArgs {
    /// The model (type designation) of the unit the data are of: written into the result and
    /// its report; for a run without a configuration's or import profile's `[unit]` (a
    /// hand-turned recording) the only source. A value contradicting one of those is refused.
    #[arg(long, value_name = "TEXT")]
    pub unit_model: Option<String>,
    /// The serial number of the unit the data are of (as --unit-model).
    #[arg(long, value_name = "TEXT")]
    pub unit_serial: Option<String>,
}

impl UnitArgs {
    /// The identity the options give.
    pub fn identity(&self) -> UnitIdentity {
        UnitIdentity {
            model: self.unit_model.clone(),
            serial: self.unit_serial.clone(),
        }
    }
}

/// The unit identity from its sources (`(source, identity)`, e.g. the configuration, the
/// import profile, the options), merged field by field; two sources that give a field
/// different values are refused, naming both.
pub fn merge_units(sources: &[(String, UnitIdentity)]) -> Result<UnitIdentity, Error> {
    let mut merged = UnitIdentity::default();
    for (i, (a, ua)) in sources.iter().enumerate() {
        for (b, ub) in &sources[..i] {
            if let Some((field, x, y)) = ub.conflicts(ua).into_iter().next() {
                return Err(format!(
                    "the unit's {field} is \"{x}\" in {b} but \"{y}\" in {a}: expected one unit \
                     (correct the one that is wrong)"
                )
                .into());
            }
        }
        merged = merged.overridden_by(ua);
    }
    Ok(merged)
}

/// A file the run read, identified by its content.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputHash {
    /// What the file is to the run (`IMU records`, `section list`, `import profile`, ...).
    pub role: String,
    /// The path as given (or as `import.json` recorded it).
    pub path: String,
    /// SHA-256, lower-case hex.
    pub sha256: String,
    /// Size in bytes.
    pub bytes: u64,
}

impl InputHash {
    /// Hash the file at `path` (a regular file: a device such as /dev/zero or a pipe is
    /// refused, it has no content to name).
    pub fn of(role: &str, path: &Path) -> Result<Self, Error> {
        if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
            return Err(format!(
                "{}: is not a regular file: expected a file whose SHA-256 names the {role}",
                path.display()
            )
            .into());
        }
        let (sha256, bytes) = crate::provenance::sha256::of_file(path)?;
        Ok(Self {
            role: role.to_string(),
            path: path.display().to_string(),
            sha256,
            bytes,
        })
    }
}

/// What `import` adds to `import.json` beyond the `import` crate's report: the unit and the
/// SHA-256 of its inputs (profile and raw files) and of the files it wrote.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct ImportProvenance {
    /// The profile's `[unit]`.
    #[serde(default, skip_serializing_if = "UnitIdentity::is_empty")]
    pub unit: UnitIdentity,
    /// The profile and the raw files read.
    #[serde(default)]
    pub input_files: Vec<InputHash>,
    /// SHA-256 of each file written beside `import.json`, by name.
    #[serde(default)]
    pub output_sha256: std::collections::BTreeMap<String, String>,
}

/// The `import.json` an `imu.csv` was imported with: the one beside it, when that file says
/// (its `output_sha256`) it wrote this very `imu.csv`.
pub struct ImportBeside {
    /// The `import.json` file.
    pub path: PathBuf,
    /// Its hash, as an input of the run.
    pub hash: InputHash,
    /// What it records.
    pub provenance: ImportProvenance,
}

/// The `import.json` beside an `imu.csv`: of these records, or a note why it is not used.
pub type ImportFound = Result<ImportBeside, String>;

/// Look for the `import.json` beside `imu`: `Ok(None)` when there is none; else the hash of
/// `imu` (taken only then) and the import, or a note (`Err` of the inner result) when the file
/// is of another `imu.csv` or of an older version without hashes, and is then not used.
pub fn import_beside(imu: &Path) -> Result<Option<(InputHash, ImportFound)>, Error> {
    let dir = match imu.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let path = dir.join("import.json");
    if !path.is_file() {
        return Ok(None);
    }
    let shown = path.display().to_string();
    let text = read_small(&path, "import report JSON")?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| format!("{shown}: not an import report (JSON): {e}"))?;
    calib::io::schema::check(
        &shown,
        v.get("schema"),
        &[calib::io::schema::IMPORT],
        "the import.json of `sins-calib import`",
    )?;
    let provenance: ImportProvenance = serde_json::from_value(v)
        .map_err(|e| format!("{shown}: not an import report of `sins-calib import`: {e}"))?;
    let imu_hash = InputHash::of("IMU records", imu)?;
    let imu_sha256 = imu_hash.sha256.as_str();
    let name = imu
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    match provenance.output_sha256.get(&name) {
        None => Ok(Some((
            imu_hash,
            Err(format!(
                "{shown} records no SHA-256 of {name} (an import of an earlier version, or of \
             another file): its profile and raw files are not named in the result"
            )),
        ))),
        Some(h) if h != imu_sha256 => Ok(Some((
            imu_hash,
            Err(format!(
                "{shown} is of another {name} (its SHA-256 differs): its profile and raw files \
             are not named in the result"
            )),
        ))),
        Some(_) => Ok(Some((
            imu_hash,
            Ok(ImportBeside {
                hash: InputHash::of("import report", &path)?,
                path,
                provenance,
            }),
        ))),
    }
}

/// What a run records of its origin: the unit, the inputs' hashes, and notes on them.
#[derive(Clone, Debug, Default)]
pub struct RunProvenance {
    /// The unit the data are of (empty: unknown).
    pub unit: UnitIdentity,
    /// Where the unit identity came from (empty when unknown).
    pub unit_sources: Vec<String>,
    /// Every input file with its SHA-256 (when asked for): the files given, and through the
    /// `import.json` beside the IMU records, that file, the import profile and the raw files.
    pub inputs: Vec<InputHash>,
    /// Notes for stderr and the report (an `import.json` beside the records not used).
    pub notes: Vec<String>,
}

impl RunProvenance {
    /// Add the SHA-256 of every file of `files` (role, path), once the run has read them
    /// through their own bounded readers.
    pub fn hash_files(&mut self, files: &[(&str, &Path)]) -> Result<(), Error> {
        for (role, path) in files {
            self.inputs.push(InputHash::of(role, path)?);
        }
        Ok(())
    }
}

/// Gather a run's provenance: the unit from the configuration (`config_unit`: its name and
/// `[unit]`), the `import.json` beside `imu` and the options, refused where they contradict
/// each other; with `hash`, the SHA-256 of `imu` and of the import's files (the other inputs:
/// [`RunProvenance::hash_files`]).
pub fn gather(
    imu: &Path,
    config_unit: Option<(&str, &UnitIdentity)>,
    options: &UnitArgs,
    hash: bool,
) -> Result<RunProvenance, Error> {
    let mut sources: Vec<(String, UnitIdentity)> = Vec::new();
    if let Some((name, u)) = config_unit.filter(|(_, u)| !u.is_empty()) {
        sources.push((format!("[unit] of {name}"), u.clone()));
    }
    let mut notes = Vec::new();
    let mut inputs = Vec::new();
    let beside = import_beside(imu)?;
    let imu_hash = match beside {
        Some((h, Ok(import))) => {
            if !import.provenance.unit.is_empty() {
                let profile = import
                    .provenance
                    .input_files
                    .iter()
                    .find(|f| f.role == "import profile")
                    .map_or("the import profile".to_string(), |f| {
                        format!("the import profile {}", f.path)
                    });
                sources.push((
                    format!("[unit] of {profile} (via {})", import.path.display()),
                    import.provenance.unit.clone(),
                ));
            }
            if hash {
                inputs.push(h.clone());
                inputs.push(import.hash.clone());
                inputs.extend(import.provenance.input_files.iter().cloned());
            }
            Some(h)
        }
        Some((h, Err(note))) => {
            notes.push(note);
            if hash {
                inputs.push(h.clone());
            }
            Some(h)
        }
        None => None,
    };
    if hash && imu_hash.is_none() {
        inputs.insert(0, InputHash::of("IMU records", imu)?);
    }
    let option_unit = options.identity();
    if !option_unit.is_empty() {
        let given: Vec<&str> = [
            (options.unit_model.is_some(), "--unit-model"),
            (options.unit_serial.is_some(), "--unit-serial"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
        .collect();
        sources.push((given.join(" and "), option_unit));
    }
    Ok(RunProvenance {
        unit: merge_units(&sources)?,
        unit_sources: sources.into_iter().map(|(s, _)| s).collect(),
        inputs,
        notes,
    })
}

/// The text of a small JSON file read by a command (bounded as result files are).
pub fn read_small(path: &Path, kind: &str) -> Result<String, Error> {
    sins_model::text::read_text_bounded(path, sins_model::text::RESULT_MAX_BYTES, kind)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()).into())
}

/// Check the schema stamp of the JSON file at `path` (read whole) against the kinds `accepted`
/// (`calib::io::schema::check`); a file that is not JSON is left to its reader's message.
pub fn check_stamp(path: &Path, accepted: &[&str], expected: &str) -> Result<(), Error> {
    let text = read_small(path, "JSON file")?;
    if let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) {
        calib::io::schema::check(
            &path.display().to_string(),
            v.get("schema"),
            accepted,
            expected,
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(model: Option<&str>, serial: Option<&str>) -> UnitIdentity {
        UnitIdentity {
            model: model.map(str::to_string),
            serial: serial.map(str::to_string),
        }
    }

    #[test]
    fn units_merge_and_contradictions_are_refused() {
        let m = merge_units(&[
            ("the configuration".into(), unit(Some("MTi-3"), None)),
            ("--unit-serial".into(), unit(None, Some("A1"))),
        ])
        .unwrap();
        assert_eq!(m, unit(Some("MTi-3"), Some("A1")));
        let e = merge_units(&[
            ("the profile".into(), unit(None, Some("A1"))),
            ("--unit-serial".into(), unit(None, Some("B2"))),
        ])
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("\"A1\" in the profile") && e.contains("\"B2\" in --unit-serial"),
            "{e}"
        );
        assert!(merge_units(&[]).unwrap().is_empty());
    }
}
