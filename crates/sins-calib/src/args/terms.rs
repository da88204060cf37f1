//! Candidate terms named on the command line: the ids of `--terms` (each once, each known) and
//! the `accepted_terms` of a `diagnose --json` result (`--terms-from`). Shared by `calibrate`,
//! `diagnose`, `analyse` and `design`.

use crate::Error;
use sins_model::candidates::Candidate;

/// Refuse a term given twice in --terms (it would be tested twice and halve every Bonferroni
/// threshold).
pub fn check_distinct(ids: &[String]) -> Result<(), Error> {
    for (i, id) in ids.iter().enumerate() {
        if ids[..i].contains(id) {
            return Err(format!(
                "--terms {}: `{id}` is given twice: expected each candidate term once",
                ids.join(" ")
            )
            .into());
        }
    }
    Ok(())
}

/// Parse candidate ids, naming the valid ones on a bad id and refusing one given twice
/// ([`check_distinct`]).
pub fn parse_terms(ids: &[String]) -> Result<Vec<Candidate>, Error> {
    check_distinct(ids)?;
    ids.iter()
        .map(|id| {
            Candidate::from_id(id).ok_or_else(|| {
                let valid: Vec<&str> = Candidate::ALL.iter().map(|c| c.id()).collect();
                format!(
                    "unknown term {}: expected one of {}",
                    excerpt(id),
                    valid.join(", ")
                )
                .into()
            })
        })
        .collect()
}

/// The ids of the candidates `keep` keeps, from their declarations: the others', then "and the
/// thermal" ones' with `thermal_note` (what they need) after them.
fn ids_listed(keep: impl Fn(Candidate) -> bool, thermal_note: &str) -> String {
    let ids = |thermal: bool| {
        Candidate::ALL
            .into_iter()
            .filter(|c| keep(*c) && c.is_thermal() == thermal)
            .map(Candidate::id)
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        "{} and the thermal {} ({thermal_note})",
        ids(false),
        ids(true)
    )
}

/// The long help of a `--terms` option: its short help `short`, then each term `keep` keeps
/// with its help text ([`sins_model::candidates::Declaration::help`]).
fn long_help(short: String, keep: impl Fn(Candidate) -> bool) -> String {
    let mut text = short;
    text.push('\n');
    for c in Candidate::ALL.into_iter().filter(|c| keep(*c)) {
        text.push_str(&format!("\n  {}: {}", c.id(), c.declaration().help));
    }
    text
}

/// Whether `calibrate --terms` takes the candidate: every one (the drift as the model's bias
/// walk).
fn calibrate_takes(_: Candidate) -> bool {
    true
}

/// `calibrate --terms`: the help of the option.
pub fn calibrate_help() -> String {
    format!(
        "Candidate terms to add to the paper's model (ids): {}. None is added without being \
         named",
        ids_listed(calibrate_takes, "these need a `temp` column")
    )
}

/// `calibrate --terms --help`.
pub fn calibrate_long_help() -> String {
    long_help(calibrate_help(), calibrate_takes)
}

/// `diagnose --terms`: the help of the option.
pub fn diagnose_help() -> String {
    format!(
        "Candidate terms to consider (ids; default all): {}",
        ids_listed(calibrate_takes, "tested where the temperature moves")
    )
}

/// `diagnose --terms --help`.
pub fn diagnose_long_help() -> String {
    long_help(diagnose_help(), calibrate_takes)
}

/// Whether `design --terms` takes the candidate: one with parameters to separate (not the
/// drift, process noise).
fn design_takes(c: Candidate) -> bool {
    c.declaration().effect.is_some()
}

/// `design --terms`: the help of the option.
pub fn design_help() -> String {
    format!(
        "Candidate term ids to separate: {}; without them, programs are ranked by the \
         navigation figure they buy (the recorded program, it without each part between its \
         moves, and the menu's additions) and the best is proposed",
        ids_listed(design_takes, "these need a [temperature] profile")
    )
}

/// `design --terms --help`.
pub fn design_long_help() -> String {
    long_help(design_help(), design_takes)
}

/// Refuse a thermal term (`--terms <a thermal id>`) where there is no temperature for it
/// to act on: its effect is the temperature's departure from its reference, so without one its
/// coefficients would stay at their prior, with no reference temperature in the result (and
/// `apply` refusing it later), or a design would propose a program that separates nothing.
/// `lacks` says what is missing (`imu.csv: no \`temp\` column`), `expected` what would do.
pub fn check_thermal(
    terms: &[Candidate],
    has_temperature: bool,
    command: &str,
    lacks: &str,
    expected: &str,
) -> Result<(), Error> {
    if has_temperature {
        return Ok(());
    }
    let Some(c) = terms.iter().find(|c| c.is_thermal()) else {
        return Ok(());
    };
    Err(format!(
        "{command}: {lacks}: the thermal term {} acts on the temperature's departure from its \
         reference, so without temperatures its coefficients stay at their prior: expected \
         {expected}, or the term left out (docs/temperature.md)",
        c.id()
    )
    .into())
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
            // Named with its file: the id came from there, not from the command line.
            if Candidate::from_id(&id).is_none() {
                return Err(format!(
                    "--terms-from {}: `accepted_terms` holds {}: {}",
                    path.display(),
                    excerpt(&id),
                    parse_terms(std::slice::from_ref(&id))
                        .err()
                        .map_or_else(String::new, |e| e.to_string())
                )
                .into());
            }
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

/// A string as shown in a message: at most 60 characters of it.
fn excerpt(s: &str) -> String {
    let mut out: String = s.chars().take(60).collect();
    if out.len() < s.len() {
        out += "...";
    }
    format!("{out:?}")
}

/// The largest `--terms-from` file read (a diagnose result is a few tens of kilobytes).
const TERMS_FROM_MAX_BYTES: u64 = 16 << 20;

/// The text of a small file, refused past `max` bytes (the shared bounded reader: a device
/// such as /dev/zero is refused at the bound too).
fn read_bounded(path: &std::path::Path, option: &str, max: u64) -> Result<String, Error> {
    sins_model::text::read_text_bounded(path, max, "diagnose result")
        .map_err(|e| format!("{option} {}: cannot read: {e}", path.display()).into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The help of every `--terms` names every id the command takes, from the declarations,
    /// and the long help each one's help text.
    #[test]
    fn helps_name_every_id() {
        for c in Candidate::ALL {
            let id = c.id();
            for help in [calibrate_help(), diagnose_help(), calibrate_long_help()] {
                assert!(help.contains(id), "{id} not in {help}");
            }
            assert!(diagnose_long_help().contains(c.declaration().help));
            assert_eq!(design_help().contains(id), c.term(1.0).is_some(), "{id}");
            assert_eq!(
                design_long_help().contains(c.declaration().help),
                c.term(1.0).is_some()
            );
        }
    }
}
