//! The bounds on where things live (issue 45, "one place for each thing"), measured from the
//! sources by `cargo xtask structure`:
//!
//! - no file in `crates/*/src` over [`MAX_FILE_LINES`] non-test lines (the lines before its first
//!   `#[cfg(test)]`);
//! - the estimate's entry, `crates/calib/src/estimate/mod.rs`, at most [`MAX_ESTIMATE_ENTRY_LINES`];
//! - at most [`MAX_CLI_ENTRIES`] files and folders at the top of `crates/sins-calib/src`;
//! - at most [`MAX_EXACT_REPEATS`] exact repeats in `crates/*/src` (see [`exact_repeats`]);
//! - every candidate term's id named in at most [`MAX_FILES_PER_TERM`] files of `crates/*/src`
//!   (its declaration and one more), so that a term is declared in one place.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

/// The longest file allowed (non-test lines).
pub const MAX_FILE_LINES: usize = 1000;
/// The longest estimate entry allowed (non-test lines of `crates/calib/src/estimate/mod.rs`).
pub const MAX_ESTIMATE_ENTRY_LINES: usize = 700;
/// The most entries at the top of `crates/sins-calib/src`.
pub const MAX_CLI_ENTRIES: usize = 15;
/// The most exact repeats allowed in `crates/*/src`.
pub const MAX_EXACT_REPEATS: usize = 5;
/// The most files a candidate term's id may be named in.
pub const MAX_FILES_PER_TERM: usize = 2;
/// Identical significant lines that make a repeat.
pub const REPEAT_LINES: usize = 6;
/// A run standing in more places than this is an idiom, not a repeat (as in the usual tools).
const MAX_PLACES: usize = 8;

/// The part of a source file before its unit tests.
pub fn non_test(text: &str) -> &str {
    let mut at = 0;
    for line in text.split_inclusive('\n') {
        if line.trim_start().starts_with("#[cfg(test)]") {
            return &text[..at];
        }
        at += line.len();
    }
    text
}

/// A file's significant lines for the repeat scan: (1-based line, the line with its white space
/// folded), without blank lines, comments, lines of punctuation alone and `use` lines.
pub fn significant_lines(text: &str) -> Vec<(usize, String)> {
    non_test(text)
        .lines()
        .enumerate()
        .filter_map(|(n, line)| {
            let folded = line.split_whitespace().collect::<Vec<_>>().join(" ");
            let skip = folded.is_empty()
                || folded.starts_with("//")
                || folded.starts_with("use ")
                || folded.starts_with("pub use ")
                || !folded.chars().any(|c| c.is_alphanumeric());
            (!skip).then_some((n + 1, folded))
        })
        .collect()
}

/// One exact repeat: two places (file, first line, last line) with the same run of at least
/// [`REPEAT_LINES`] significant lines; `more` other runs shared by the same two files.
#[derive(Debug, PartialEq)]
pub struct Repeat {
    pub a: (String, usize, usize),
    pub b: (String, usize, usize),
    pub more: usize,
}

/// A run shared by two files: (its first window in file a, in file b, its length in windows).
type Run = (usize, usize, usize);

/// The exact repeats among `files` (name, text): every pair of files (or of distinct,
/// non-overlapping places in one file) that share a run of [`REPEAT_LINES`] or more identical
/// significant lines; one [`Repeat`] per pair of files, its longest run named.
pub fn exact_repeats(files: &[(String, String)]) -> Vec<Repeat> {
    let lines: Vec<Vec<(usize, String)>> =
        files.iter().map(|(_, t)| significant_lines(t)).collect();
    let mut places: HashMap<String, Vec<(usize, usize)>> = HashMap::new();
    for (f, l) in lines.iter().enumerate() {
        for i in 0..l.len().saturating_sub(REPEAT_LINES - 1) {
            let key = l[i..i + REPEAT_LINES]
                .iter()
                .map(|(_, s)| s.as_str())
                .collect::<Vec<_>>()
                .join("\n");
            places.entry(key).or_default().push((f, i));
        }
    }
    // Window pairs: (file a, index a, file b, index b), a before b.
    let mut pairs = BTreeSet::new();
    for at in places
        .values()
        .filter(|p| p.len() >= 2 && p.len() <= MAX_PLACES)
    {
        for (k, &(fa, ia)) in at.iter().enumerate() {
            for &(fb, ib) in &at[k + 1..] {
                if fa != fb || ib >= ia + REPEAT_LINES {
                    pairs.insert((fa, ia, fb, ib));
                }
            }
        }
    }
    // Maximal runs: a pair starts one when the pair one line earlier is not a pair.
    let mut by_files: BTreeMap<(usize, usize), Vec<Run>> = BTreeMap::new();
    for &(fa, ia, fb, ib) in &pairs {
        if ia > 0 && ib > 0 && pairs.contains(&(fa, ia - 1, fb, ib - 1)) {
            continue;
        }
        let mut len = 1;
        while pairs.contains(&(fa, ia + len, fb, ib + len)) {
            len += 1;
        }
        by_files.entry((fa, fb)).or_default().push((ia, ib, len));
    }
    by_files
        .into_iter()
        .map(|((fa, fb), mut runs)| {
            runs.sort_by_key(|r| std::cmp::Reverse(r.2));
            let (ia, ib, len) = runs[0];
            let last = len + REPEAT_LINES - 2;
            Repeat {
                a: (files[fa].0.clone(), lines[fa][ia].0, lines[fa][ia + last].0),
                b: (files[fb].0.clone(), lines[fb][ib].0, lines[fb][ib + last].0),
                more: runs.len() - 1,
            }
        })
        .collect()
}

/// The files of `files` whose non-test text (code, strings and comments) names `id` as a word.
pub fn files_naming(files: &[(String, String)], id: &str) -> Vec<String> {
    files
        .iter()
        .filter(|(_, text)| non_test(text).lines().any(|l| names_word(l, id)))
        .map(|(name, _)| name.clone())
        .collect()
}

fn names_word(line: &str, word: &str) -> bool {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    line.match_indices(word).any(|(at, _)| {
        let before = line[..at].chars().next_back();
        let after = line[at + word.len()..].chars().next();
        !before.is_some_and(ident) && !after.is_some_and(ident)
    })
}

/// Check the bounds over the sources in `crates/*/src` (`files`: path from the root, text);
/// prints what it finds and returns whether every bound holds.
pub fn check(root: &Path, files: &[(String, String)]) -> Result<bool, String> {
    let mut ok = true;
    let mut long: Vec<(usize, &str)> = files
        .iter()
        .map(|(name, text)| (non_test(text).lines().count(), name.as_str()))
        .filter(|(n, _)| *n > MAX_FILE_LINES)
        .collect();
    long.sort_by(|a, b| b.cmp(a));
    println!(
        "files over {MAX_FILE_LINES} non-test lines in crates/*/src: {}",
        long.len()
    );
    for (n, name) in &long {
        println!("  {n:>5} lines  {name}");
    }
    ok &= long.is_empty();

    let entry = "crates/calib/src/estimate/mod.rs";
    if let Some((_, text)) = files.iter().find(|(n, _)| n == entry) {
        let n = non_test(text).lines().count();
        println!(
            "the estimate's entry, {entry}: {n} non-test lines (at most {MAX_ESTIMATE_ENTRY_LINES})"
        );
        ok &= n <= MAX_ESTIMATE_ENTRY_LINES;
    }

    let cli = root.join("crates/sins-calib/src");
    let entries = std::fs::read_dir(&cli)
        .map_err(|e| format!("{}: {e}", cli.display()))?
        .count();
    println!("entries at the top of crates/sins-calib/src: {entries} (at most {MAX_CLI_ENTRIES})");
    ok &= entries <= MAX_CLI_ENTRIES;

    let repeats = exact_repeats(files);
    println!(
        "exact repeats in crates/*/src (runs of {REPEAT_LINES}+ identical lines): {} (at most {MAX_EXACT_REPEATS})",
        repeats.len()
    );
    for r in &repeats {
        let more = if r.more > 0 {
            format!(" (+{} more runs)", r.more)
        } else {
            String::new()
        };
        println!(
            "  {}:{}-{} ~ {}:{}-{}{more}",
            r.a.0, r.a.1, r.a.2, r.b.0, r.b.1, r.b.2
        );
    }
    ok &= repeats.len() <= MAX_EXACT_REPEATS;

    let mut spread = Vec::new();
    for c in sins_model::candidates::Candidate::ALL {
        let named = files_naming(files, c.id());
        if named.len() > MAX_FILES_PER_TERM {
            spread.push((c.id(), named));
        }
    }
    println!(
        "candidate terms named in more than {MAX_FILES_PER_TERM} files of crates/*/src: {}",
        spread.len()
    );
    for (id, named) in &spread {
        println!("  {id}: {}", named.join(" "));
    }
    ok &= spread.is_empty();
    Ok(ok)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(name: &str, text: &str) -> (String, String) {
        (name.to_string(), text.to_string())
    }

    const RUN: &str = "let a = 1;\nlet b = a + 1;\nlet c = b * 2;\nprintln!(\"{c}\");\nlet d = c - a;\nreturn d;\n";

    #[test]
    fn a_repeat_across_files_is_found_and_comments_and_blanks_do_not_hide_it() {
        let spaced = RUN.replace("let c", "// a comment\n\n   let   c");
        let files = [
            file("x.rs", &format!("fn f() {{\n{RUN}}}\n")),
            file("y.rs", &format!("fn g() {{\n{spaced}}}\n")),
        ];
        let r = exact_repeats(&files);
        assert_eq!(r.len(), 1, "{r:?}");
        assert_eq!(r[0].a, ("x.rs".to_string(), 2, 7));
        assert_eq!(r[0].b, ("y.rs".to_string(), 2, 9));
    }

    #[test]
    fn five_lines_or_a_test_module_are_no_repeat() {
        let five: String = RUN.lines().take(5).map(|l| format!("{l}\n")).collect();
        let files = [file("x.rs", &five), file("y.rs", &five)];
        assert!(exact_repeats(&files).is_empty());
        let tested = format!("fn f() {{}}\n#[cfg(test)]\nmod tests {{\n{RUN}}}\n");
        let files = [file("x.rs", RUN), file("y.rs", &tested)];
        assert!(exact_repeats(&files).is_empty());
    }

    #[test]
    fn a_run_repeated_in_one_file_counts_once_and_not_against_itself() {
        let files = [file("x.rs", &format!("{RUN}x();\n{RUN}"))];
        let r = exact_repeats(&files);
        assert_eq!(r.len(), 1, "{r:?}");
        assert_eq!((r[0].a.1, r[0].b.1), (1, 8));
        // One line repeated many times is not a run against its own shift.
        let same = "x += 1;\n".repeat(7);
        assert!(exact_repeats(&[file("z.rs", &same)]).is_empty());
    }

    #[test]
    fn a_term_is_named_by_word_outside_tests() {
        let files = [
            file("a.rs", "let t = \"gyro_temp_bias\";\n"),
            file("b.rs", "let t = gyro_temp_bias_x;\n"),
            file("d.rs", "// gyro_temp_bias, in a comment\n"),
            file(
                "c.rs",
                "fn f() {}\n#[cfg(test)]\nmod tests { const T: &str = \"gyro_temp_bias\"; }\n",
            ),
        ];
        assert_eq!(
            files_naming(&files, "gyro_temp_bias"),
            vec!["a.rs".to_string(), "d.rs".to_string()]
        );
    }
}
