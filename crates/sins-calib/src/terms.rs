//! Candidate terms named on the command line: the ids of `--terms` (each once, each known) and
//! the `accepted_terms` of a `diagnose --json` result (`--terms-from`). Shared by `calibrate`,
//! `diagnose`, `analyse` and `design`.

use crate::Error;
use sins_model::candidates::Candidate;

/// Parse candidate ids, naming the valid ones on a bad id and refusing one given twice (it
/// would be tested twice and halve every Bonferroni threshold).
pub fn parse_terms(ids: &[String]) -> Result<Vec<Candidate>, Error> {
    for (i, id) in ids.iter().enumerate() {
        if ids[..i].contains(id) {
            return Err(format!(
                "--terms {}: `{id}` is given twice: expected each candidate term once",
                ids.join(" ")
            )
            .into());
        }
    }
    ids.iter()
        .map(|id| {
            Candidate::from_id(id).ok_or_else(|| {
                let valid: Vec<&str> = Candidate::ALL.iter().map(|c| c.id()).collect();
                format!("unknown term {id:?}: expected one of {}", valid.join(", ")).into()
            })
        })
        .collect()
}

/// The terms of `--terms` and `--terms-from` (a `diagnose --json` result's `accepted_terms`),
/// each once, in the order given.
pub fn terms_asked(
    ids: &[String],
    from: Option<&std::path::Path>,
) -> Result<Vec<Candidate>, Error> {
    let mut all: Vec<String> = ids.to_vec();
    if let Some(path) = from {
        for id in accepted_terms(path)? {
            if !all.contains(&id) {
                all.push(id);
            }
        }
    }
    parse_terms(&all)
}

/// The `accepted_terms` of the `diagnose --json` result at `path`.
fn accepted_terms(path: &std::path::Path) -> Result<Vec<String>, Error> {
    let text = read_bounded(path, "--terms-from", TERMS_FROM_MAX_BYTES)?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        format!(
            "{}: not a diagnose result (JSON): {e}; expected the file `sins-calib diagnose \
             --json` writes",
            path.display()
        )
    })?;
    calib::io::schema::check(
        &path.display().to_string(),
        v.get("schema"),
        &[calib::io::schema::DIAGNOSIS],
        "the file `sins-calib diagnose --json` writes",
    )?;
    let accepted = v
        .get("accepted_terms")
        .and_then(|a| a.as_array())
        .ok_or_else(|| {
            format!(
                "{}: no `accepted_terms` list: expected the file `sins-calib diagnose --json` \
                 writes",
                path.display()
            )
        })?;
    accepted
        .iter()
        .map(|t| {
            t.as_str().map(str::to_string).ok_or_else(|| {
                format!(
                    "{}: `accepted_terms` holds {t}: expected term ids (strings)",
                    path.display()
                )
                .into()
            })
        })
        .collect()
}

/// The largest `--terms-from` file read (a diagnose result is a few tens of kilobytes).
const TERMS_FROM_MAX_BYTES: u64 = 16 << 20;

/// The text of a small file, refused past `max` bytes (the shared bounded reader: a device
/// such as /dev/zero is refused at the bound too).
fn read_bounded(path: &std::path::Path, option: &str, max: u64) -> Result<String, Error> {
    sins_model::text::read_text_bounded(path, max, "diagnose result")
        .map_err(|e| format!("{option} {}: cannot read: {e}", path.display()).into())
}
