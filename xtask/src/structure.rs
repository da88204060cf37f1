//! `cargo xtask structure`: the shape of the code, measured from the sources.
//!
//! - every function in `crates/*/src` and `xtask/src` longer than [`MAX_FN_LINES`] lines (from
//!   the `fn` line to its closing brace; `#[cfg(test)]` modules left out);
//! - where things live (`crate::bounds`): files over 1,000 non-test lines, the estimate's entry,
//!   the command line's top-level files, exact repeats, candidate terms named in many files;
//! - the entries at the top of `crates/calib/src` (at most [`MAX_CALIB_ENTRIES`]);
//! - cycles between the modules of `calib`: between its rooms (the top-level modules), and
//!   between sibling files inside a room (a parent's `mod.rs` and its children's `super::` are the
//!   language's own tie and are not counted).
//!
//! A module `a` depends on `b` when `a`'s code (comments and test modules left out) names a path
//! `crate::b...`, or `super::b` for siblings. The scan reads text, not the compiler's name
//! resolution: a name brought in by a glob or a re-export counts where it is written.
//! Exits non-zero when any bound is broken.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The longest function allowed (lines).
pub const MAX_FN_LINES: usize = 100;
/// The most entries (files and folders) at the top of `crates/calib/src`.
pub const MAX_CALIB_ENTRIES: usize = 12;

/// A function over the bound.
#[derive(Debug, PartialEq)]
pub struct LongFn {
    /// File, from the repository's root.
    pub file: String,
    /// The function's name.
    pub name: String,
    /// Line of its `fn` (1-based).
    pub line: usize,
    /// Its length in lines.
    pub lines: usize,
}

/// Run the check from the repository's root; `Ok(true)` when every bound holds.
pub fn run(root: &Path) -> Result<bool, String> {
    let mut long = Vec::new();
    let mut sources = Vec::new();
    let mut files = rust_files(&root.join("crates"))?;
    files.extend(rust_files(&root.join("xtask/src"))?);
    for file in files {
        let rel = file
            .strip_prefix(root)
            .unwrap_or(&file)
            .display()
            .to_string();
        if !rel.contains("/src/") && !rel.starts_with("xtask/src") {
            continue;
        }
        let text = read(&file)?;
        if rel.starts_with("crates/") {
            sources.push((rel.clone(), text.clone()));
        }
        long.extend(
            long_functions(&text, MAX_FN_LINES)
                .into_iter()
                .map(|(name, line, lines)| LongFn {
                    file: rel.clone(),
                    name,
                    line,
                    lines,
                }),
        );
    }
    long.sort_by(|a, b| b.lines.cmp(&a.lines).then(a.file.cmp(&b.file)));
    println!(
        "functions over {MAX_FN_LINES} lines in crates/*/src and xtask/src: {}",
        long.len()
    );
    for f in &long {
        println!("  {:>4} lines  {}:{}  {}", f.lines, f.file, f.line, f.name);
    }

    let calib = root.join("crates/calib/src");
    let entries = top_entries(&calib)?;
    println!(
        "entries at the top of crates/calib/src: {} (at most {MAX_CALIB_ENTRIES}): {}",
        entries.len(),
        entries.join(" ")
    );

    let graph = module_graph(&calib)?;
    let rooms = room_graph(&graph);
    let room_cycles = cycles(&rooms);
    let sibling_cycles: Vec<Vec<String>> = cycles(&sibling_graph(&graph));
    println!(
        "rooms of calib (top-level modules) and what each uses:\n{}",
        rooms
            .iter()
            .map(|(a, bs)| format!(
                "  {a} -> {}",
                bs.iter().cloned().collect::<Vec<_>>().join(" ")
            ))
            .collect::<Vec<_>>()
            .join("\n")
    );
    println!("module cycles between calib's rooms: {}", room_cycles.len());
    for c in &room_cycles {
        println!("  {}", c.join(" -> "));
    }
    println!(
        "module cycles between sibling files of a room: {}",
        sibling_cycles.len()
    );
    for c in &sibling_cycles {
        println!("  {}", c.join(" -> "));
    }
    let bounds = crate::bounds::check(root, &sources)?;
    Ok(bounds
        && long.is_empty()
        && entries.len() <= MAX_CALIB_ENTRIES
        && room_cycles.is_empty()
        && sibling_cycles.is_empty())
}

fn read(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))
}

fn rust_files(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let listing = std::fs::read_dir(&d).map_err(|e| format!("{}: {e}", d.display()))?;
        for entry in listing {
            let path = entry.map_err(|e| format!("{}: {e}", d.display()))?.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    out.sort();
    Ok(out)
}

fn top_entries(dir: &Path) -> Result<Vec<String>, String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    Ok(names)
}

/// The source with comments, string and character literals blanked (same line structure), so
/// braces and paths are read from code only.
pub fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let blank = |out: &mut String, s: &[u8]| {
        for &c in s {
            out.push(if c == b'\n' { '\n' } else { ' ' });
        }
    };
    while i < b.len() {
        let rest = &b[i..];
        if rest.starts_with(b"//") {
            let end = rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len());
            blank(&mut out, &rest[..end]);
            i += end;
        } else if rest.starts_with(b"/*") {
            let end = find(rest, b"*/").map_or(rest.len(), |e| e + 2);
            blank(&mut out, &rest[..end]);
            i += end;
        } else if let Some(n) = raw_string_len(rest) {
            blank(&mut out, &rest[..n]);
            i += n;
        } else if rest[0] == b'"' {
            let mut j = 1;
            while j < rest.len() && rest[j] != b'"' {
                j += if rest[j] == b'\\' { 2 } else { 1 };
            }
            let n = (j + 1).min(rest.len());
            blank(&mut out, &rest[..n]);
            i += n;
        } else if let Some(n) = char_literal_len(rest) {
            blank(&mut out, &rest[..n]);
            i += n;
        } else {
            // Copy one whole UTF-8 character.
            let n = utf8_len(rest[0]);
            out.push_str(&text[i..i + n]);
            i += n;
        }
    }
    out
}

fn utf8_len(first: u8) -> usize {
    match first {
        0x00..=0x7f => 1,
        0xc0..=0xdf => 2,
        0xe0..=0xef => 3,
        _ => 4,
    }
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// `r"..."`, `r#"..."#`, `br"..."`: the literal's length.
fn raw_string_len(s: &[u8]) -> Option<usize> {
    let start = if s.starts_with(b"br") {
        2
    } else if s.starts_with(b"r") {
        1
    } else {
        return None;
    };
    let hashes = s[start..].iter().take_while(|&&c| c == b'#').count();
    if s.get(start + hashes) != Some(&b'"') {
        return None;
    }
    let mut close = vec![b'"'];
    close.extend(std::iter::repeat_n(b'#', hashes));
    let body = start + hashes + 1;
    find(&s[body..], &close).map(|e| body + e + close.len())
}

/// `'x'`, `'\n'`, `'\u{..}'` (not a lifetime `'a`).
fn char_literal_len(s: &[u8]) -> Option<usize> {
    if s[0] != b'\'' || s.len() < 3 {
        return None;
    }
    if s[1] == b'\\' {
        return s[2..].iter().position(|&c| c == b'\'').map(|e| e + 3);
    }
    let n = utf8_len(s[1]);
    (s.get(1 + n) == Some(&b'\'')).then_some(n + 2)
}

/// Functions longer than `max` lines: (name, line of the `fn`, lines), test modules left out.
pub fn long_functions(text: &str, max: usize) -> Vec<(String, usize, usize)> {
    let code = code_only(text);
    let lines: Vec<&str> = code.lines().collect();
    let raw: Vec<&str> = text.lines().collect();
    // (function name, depth at open, line of the `fn`)
    let mut open: Vec<(Option<String>, i64, usize)> = Vec::new();
    let mut depth = 0i64;
    let mut test_attr = false;
    let mut test_depth: Option<i64> = None;
    let mut found = Vec::new();
    // A `fn` seen whose body has not opened yet (a signature may span lines).
    let mut pending: Option<(String, usize)> = None;
    // Parentheses and brackets open (a `;` inside `[f64; 3]` ends no declaration).
    let mut nest = 0i64;
    let mut pending_nest = 0i64;
    for (n, line) in lines.iter().enumerate() {
        let trimmed = line.trim_start();
        if raw[n].trim_start().starts_with("#[cfg(test)]") {
            test_attr = true;
        }
        let is_mod = trimmed.starts_with("mod ") || trimmed.starts_with("pub mod ");
        if let Some(name) = fn_name(trimmed) {
            pending = Some((name, n));
            pending_nest = nest;
        } else if is_mod && test_attr && trimmed.contains('{') && test_depth.is_none() {
            test_depth = Some(depth);
        }
        if !trimmed.is_empty() && !trimmed.starts_with("#[") {
            test_attr = false;
        }
        for c in line.chars() {
            match c {
                '{' => {
                    let (name, at) = match pending.take() {
                        Some((name, at)) => (Some(name), at),
                        None => (None, n),
                    };
                    open.push((name, depth, at));
                    depth += 1;
                }
                '}' => {
                    depth -= 1;
                    if let Some((Some(name), _, at)) = open.pop()
                        && test_depth.is_none()
                        && n + 1 - at > max
                    {
                        found.push((name, at + 1, n + 1 - at));
                    }
                    if test_depth == Some(depth) {
                        test_depth = None;
                    }
                }
                '(' | '[' => nest += 1,
                ')' | ']' => nest -= 1,
                // A declaration without a body (a trait's method).
                ';' if nest == pending_nest => pending = None,
                _ => {}
            }
        }
    }
    found
}

fn fn_name(trimmed: &str) -> Option<String> {
    let mut words = trimmed.split_whitespace().peekable();
    while let Some(w) = words.next() {
        let qualifier = w == "pub"
            || w.starts_with("pub(")
            || ["const", "async", "unsafe", "extern", "default"].contains(&w)
            || w.starts_with('"');
        if qualifier {
            continue;
        }
        if w == "fn" {
            let name: String = words
                .next()?
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            return (!name.is_empty()).then_some(name);
        }
        return None;
    }
    None
}

/// Module path (e.g. `estimate::pass`) -> the module paths its code names.
type Graph = BTreeMap<String, BTreeSet<String>>;

fn module_graph(src: &Path) -> Result<Graph, String> {
    let files = rust_files(src)?;
    let modules: BTreeSet<String> = files.iter().filter_map(|f| module_of(src, f)).collect();
    let mut graph = Graph::new();
    for file in &files {
        let Some(module) = module_of(src, file) else {
            continue;
        };
        let code = code_only(&read(file)?);
        let code = without_test_modules(&code);
        let mut uses = BTreeSet::new();
        for path in crate_paths(&code) {
            if let Some(m) = deepest_module(&modules, &path) {
                uses.insert(m);
            }
        }
        let parent = module.rsplit_once("::").map(|(p, _)| p.to_string());
        for name in super_paths(&code) {
            let sibling = match &parent {
                Some(p) => format!("{p}::{name}"),
                None => name,
            };
            if modules.contains(&sibling) {
                uses.insert(sibling);
            }
        }
        uses.remove(&module);
        graph.insert(module, uses);
    }
    Ok(graph)
}

/// `crates/calib/src/estimate/pass.rs` -> `estimate::pass`; `lib.rs` -> none.
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).ok()?;
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|l| l == "mod") {
        parts.pop();
    }
    (!parts.is_empty() && parts != ["lib"]).then(|| parts.join("::"))
}

fn without_test_modules(code: &str) -> String {
    match code.find("#[cfg(test)]") {
        // Test modules stand at the end of a file in this project (clippy's
        // items_after_test_module holds them there).
        Some(at) if code[at..].contains("mod ") => code[..at].to_string(),
        _ => code.to_string(),
    }
}

/// Every `crate::a::b::...` path, `use crate::{a::x, b}` groups expanded to their heads.
fn crate_paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("crate::") {
        let after = &rest[at + 7..];
        if after.starts_with('{') {
            let body = group_body(after);
            for item in split_top(body) {
                out.push(path_words(item.trim()));
            }
        } else {
            out.push(path_words(after));
        }
        rest = after;
    }
    out
}

fn group_body(s: &str) -> &str {
    let mut depth = 0;
    for (i, c) in s.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return &s[1..i];
                }
            }
            _ => {}
        }
    }
    &s[1..]
}

fn split_top(body: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, c) in body.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&body[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(&body[start..]);
    out
}

fn path_words(s: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut rest = s;
    loop {
        let word: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if word.is_empty() {
            break;
        }
        rest = &rest[word.len()..];
        words.push(word);
        match rest.strip_prefix("::") {
            Some(r) if !r.starts_with('{') => rest = r,
            Some(r) => {
                // A nested group: its heads extend this path.
                if let Some(first) = split_top(group_body(r)).first() {
                    words.extend(path_words(first.trim()));
                }
                break;
            }
            None => break,
        }
    }
    words
}

fn super_paths(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("super::") {
        let after = &rest[at + 7..];
        if after.starts_with('{') {
            for item in split_top(group_body(after)) {
                if let Some(w) = path_words(item.trim()).first() {
                    out.push(w.clone());
                }
            }
        } else if let Some(w) = path_words(after).first() {
            out.push(w.clone());
        }
        rest = after;
    }
    out
}

fn deepest_module(modules: &BTreeSet<String>, path: &[String]) -> Option<String> {
    (1..=path.len())
        .rev()
        .map(|n| path[..n].join("::"))
        .find(|m| modules.contains(m))
}

fn room(module: &str) -> &str {
    module.split("::").next().unwrap_or(module)
}

fn room_graph(graph: &Graph) -> Graph {
    let mut rooms = Graph::new();
    for (a, bs) in graph {
        let ra = room(a).to_string();
        let entry = rooms.entry(ra.clone()).or_default();
        for b in bs {
            if room(b) != ra {
                entry.insert(room(b).to_string());
            }
        }
    }
    rooms
}

/// Arrows between modules of one parent (siblings), children's arrows to their ancestors and
/// parents' to their descendants left out.
fn sibling_graph(graph: &Graph) -> Graph {
    let parent = |m: &str| m.rsplit_once("::").map(|(p, _)| p.to_string());
    let mut out = Graph::new();
    for (a, bs) in graph {
        let entry = out.entry(a.clone()).or_default();
        for b in bs {
            let related = b.starts_with(&format!("{a}::")) || a.starts_with(&format!("{b}::"));
            if !related && parent(a).is_some() && parent(a) == parent(b) {
                entry.insert(b.clone());
            }
        }
    }
    out
}

/// The strongly connected components of more than one node (Tarjan).
fn cycles(graph: &Graph) -> Vec<Vec<String>> {
    struct State<'a> {
        graph: &'a Graph,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        next: usize,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        s.index.insert(v, s.next);
        s.low.insert(v, s.next);
        s.next += 1;
        s.stack.push(v);
        s.on.insert(v);
        let graph = s.graph;
        for w in graph.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low[v];
                s.low.insert(v, lv.min(lw));
            } else if s.on.contains(w) {
                let iw = s.index[w];
                let lv = s.low[v];
                s.low.insert(v, lv.min(iw));
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                comp.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                comp.sort();
                s.out.push(comp);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_function_is_found_and_a_test_module_is_not() {
        let body = "    let x = 1;\n".repeat(101);
        let text = format!(
            "/// doc {{\npub fn long(\n    a: u8,\n) -> u8 {{\n{body}    0\n}}\n\nfn short() {{ \"}}\"; }}\n\n#[cfg(test)]\nmod tests {{\n    fn also_long() {{\n{body}    }}\n}}\n"
        );
        let found = long_functions(&text, 100);
        assert_eq!(found, vec![("long".to_string(), 2, 106)]);
    }

    #[test]
    fn braces_in_strings_chars_and_comments_are_not_code() {
        let sig = "fn b(\n    x: [f64; 3],\n) -> u8 {\n    0\n}\n";
        assert_eq!(long_functions(sig, 4), vec![("b".to_string(), 1, 5)]);
        let text = "fn a() {\n    let s = \"{{\"; let c = '{'; // {\n    let r = r#\"}\"#;\n}\n";
        assert!(long_functions(text, 2).len() == 1);
        assert!(long_functions(text, 4).is_empty());
    }

    #[test]
    fn paths_and_groups_are_read() {
        let code = "use crate::{config::RunConfig, model::{layout::X, engine}};\nlet a = crate::io::read();";
        let paths = crate_paths(code);
        assert!(paths.contains(&vec!["config".to_string(), "RunConfig".to_string()]));
        assert!(paths.contains(&vec![
            "model".to_string(),
            "layout".to_string(),
            "X".to_string()
        ]));
        assert!(paths.contains(&vec!["io".to_string(), "read".to_string()]));
    }

    #[test]
    fn a_cycle_is_found() {
        let mut g = Graph::new();
        g.insert("a".into(), ["b".to_string()].into());
        g.insert("b".into(), ["c".to_string()].into());
        g.insert("c".into(), ["a".to_string()].into());
        g.insert("d".into(), ["a".to_string()].into());
        assert_eq!(cycles(&g), vec![vec!["a", "b", "c"]]);
    }
}
