//! The schema stamp of every JSON file the toolkit writes: a top-level
//! `"schema": {"name": "sins-calib.calibration", "version": 1}` (`docs/formats.md`, "Schema
//! versions").
//!
//! `version` is the major version of the file's layout: fields are added without changing it
//! (readers ignore fields they do not know); a change that an older reader would misread
//! (a field renamed, removed, or given another meaning or unit) raises it. A reader accepts a
//! file without the stamp (written before it existed) and one of its own version or older, and
//! refuses a newer one ([`check`]), naming the file.

use serde::{Deserialize, Serialize};

/// The stamp of a JSON file: which file it is and the major version of its layout.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Schema {
    /// `sins-calib.` and the kind of file (the constants of this module).
    pub name: String,
    /// Major version of the layout.
    pub version: u32,
}

/// `calibrate --json`: a calibration result.
pub const CALIBRATION: &str = "sins-calib.calibration";
/// `simulate`'s `truth.json`: the true values of a simulated run.
pub const TRUTH: &str = "sins-calib.truth";
/// `diagnose --json`: the model-extension loop.
pub const DIAGNOSIS: &str = "sins-calib.diagnosis";
/// `segment --json`: static intervals and motion.
pub const SEGMENTATION: &str = "sins-calib.segmentation";
/// `noise --json`: the sensors' noise at rest.
pub const NOISE: &str = "sins-calib.noise";
/// `analyse --json`: a covariance analysis.
pub const ANALYSIS: &str = "sins-calib.analysis";
/// `import`'s `import.json`: what an import read and found.
pub const IMPORT: &str = "sins-calib.import";
/// `import`'s `sections.json`: a section list on the imported records.
pub const SECTIONS: &str = "sins-calib.sections";
/// `cargo xtask paper-check --json`: the paper's tables recomputed.
pub const PAPER_CHECK: &str = "sins-calib.paper-check";

/// The major version every file is written with, and the newest a reader accepts.
pub const VERSION: u32 = 1;

impl Schema {
    /// The stamp of a file of kind `name` at the current [`VERSION`].
    pub fn current(name: &str) -> Self {
        Self {
            name: name.to_string(),
            version: VERSION,
        }
    }
}

/// A value of any serialisable type with the stamp as its first field: `T` must serialise as
/// a map (a struct or a JSON object).
#[derive(Serialize)]
pub struct Stamped<'a, T: Serialize + ?Sized> {
    /// The stamp.
    pub schema: Schema,
    /// The file's contents.
    #[serde(flatten)]
    pub body: &'a T,
}

/// `body` as pretty JSON with the stamp of kind `name` first, ending in a newline.
pub fn to_json<T: Serialize + ?Sized>(name: &str, body: &T) -> Result<String, serde_json::Error> {
    let stamped = Stamped {
        schema: Schema::current(name),
        body,
    };
    Ok(serde_json::to_string_pretty(&stamped)? + "\n")
}

/// Check the stamp `found` of `file` (the value of its `"schema"` key, `None` when it has none)
/// against the kinds a reader takes (`accepted`, e.g. a calibration result or a truth):
/// no stamp (an older file) passes; a stamp of another kind, a malformed one, or a newer
/// major version is refused with a message naming the file.
pub fn check(
    file: &str,
    found: Option<&serde_json::Value>,
    accepted: &[&str],
    expected: &str,
) -> Result<(), String> {
    let Some(v) = found else {
        return Ok(());
    };
    let stamp: Schema = serde_json::from_value(v.clone()).map_err(|e| {
        format!(
            "{file}: `schema` is {v}: expected {{\"name\": \"sins-calib....\", \"version\": N}} \
             ({e})"
        )
    })?;
    if !accepted.contains(&stamp.name.as_str()) {
        return Err(format!(
            "{file}: is a `{}` file (its `schema`): expected {expected} ({})",
            stamp.name,
            accepted
                .iter()
                .map(|a| format!("`{a}`"))
                .collect::<Vec<_>>()
                .join(" or ")
        ));
    }
    if stamp.version > VERSION {
        return Err(format!(
            "{file}: `{}` version {} is newer than this program reads (version {VERSION} and \
             older): a later sins-calib wrote it; use that version, or one that reads it",
            stamp.name, stamp.version
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamp_comes_first_and_is_checked() {
        #[derive(Serialize)]
        struct Body {
            z: u8,
            a: u8,
        }
        let text = to_json(CALIBRATION, &Body { z: 1, a: 2 }).unwrap();
        let at = |k: &str| text.find(k).unwrap();
        assert!(
            at("\"schema\"") < at("\"z\"") && at("\"z\"") < at("\"a\""),
            "{text}"
        );
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["schema"]["name"], CALIBRATION);
        assert_eq!(v["schema"]["version"], VERSION);
        let ok = |s: Option<&serde_json::Value>| check("r.json", s, &[CALIBRATION], "a result");
        ok(v.get("schema")).unwrap();
        ok(None).unwrap();
        let newer = serde_json::json!({"name": CALIBRATION, "version": VERSION + 1});
        let e = ok(Some(&newer)).unwrap_err();
        assert!(e.starts_with("r.json: ") && e.contains("newer"), "{e}");
        let other = serde_json::json!({"name": NOISE, "version": 1});
        let e = ok(Some(&other)).unwrap_err();
        assert!(
            e.contains("sins-calib.noise") && e.contains("a result"),
            "{e}"
        );
        let e = ok(Some(&serde_json::json!("1"))).unwrap_err();
        assert!(e.contains("expected"), "{e}");
    }
}
