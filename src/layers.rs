//! The layer order of the crate's top-level modules, checked: a module uses
//! only modules of lower layers, never one of its own layer or above
//! (`docs/architecture.md`, "Layer order"). The check reads the sources, so
//! an upward `use crate::…` (or a path `crate::…`, or `super::` climbing out
//! of the module) anywhere under `src/`, tests included, fails it with the
//! file and line.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The application's modules from the wire up. A module may use the
/// modules of the rows above its own; the modules of one row are
/// independent of each other. Below them all are the core crates
/// (`jogterm-proto`, re-exported as `proto`, `axis`, `motion`, `wire`,
/// `wiring`;
/// `jogterm-gcode`, under `gcode`): their dependency lists in Cargo.toml
/// are their layer rule, which the compiler checks and this test need not.
const LAYERS: &[&[&str]] = &[
    // shared arithmetic and types
    &["traffic"],
    &["config"],
    &["transport"],
    &["sim"],
    &["device"],
    &["program"],
    &["jog", "offsets", "probing"],
    &["gcode"],
    // the job log: runs of G-code jobs (reads `program::store`'s state
    // directory, says times as `gcode::ways` does)
    &["joblog"],
    &["ui"],
    &["cli"],
];

/// Top-level files that are not layers: the crate root, the binary and
/// this check.
const NOT_LAYERS: &[&str] = &["lib", "main", "layers"];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|row| row.contains(&module))
}

/// One reference from a file to a top-level module of the crate.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Reference {
    line: usize,
    module: String,
}

/// `text` with comments removed and the contents of string and character
/// literals blanked (newlines kept, so lines still count): what is left is
/// code whose paths can be read without a parser.
fn code_only(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            // Block comments nest in Rust.
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(chars[i]));
                    i += 1;
                }
            }
        } else if c == 'r' && matches!(next, Some('"') | Some('#')) && !ident_before(&chars, i) {
            // Raw string: r"…", r#"…"#, …
            let mut j = i + 1;
            let mut hashes = 0;
            while chars.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if chars.get(j) != Some(&'"') {
                out.push(c);
                i += 1;
                continue;
            }
            out.push('"');
            j += 1;
            while j < chars.len() {
                if chars[j] == '"' && (1..=hashes).all(|h| chars.get(j + h) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                out.push(blank(chars[j]));
                j += 1;
            }
            out.push('"');
            i = j;
        } else if c == '"' {
            out.push('"');
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if let Some(&ch) = chars.get(i) {
                    out.push(blank(ch));
                }
                i += 1;
            }
            out.push('"');
            i += 1;
        } else if c == '\'' {
            // A character literal ('x', '\n', '\u{1F}') or a lifetime ('a).
            let literal_end = if next == Some('\\') {
                (i + 3..chars.len()).find(|&j| chars[j] == '\'')
            } else if chars.get(i + 2) == Some(&'\'') {
                Some(i + 2)
            } else {
                None
            };
            match literal_end {
                Some(end) => {
                    out.push_str("' '");
                    i = end + 1;
                }
                None => {
                    out.push(c);
                    i += 1;
                }
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

fn ident_before(chars: &[char], i: usize) -> bool {
    i > 0 && is_ident(chars[i - 1])
}

/// A small tokenizer over code: identifiers, `::` and single punctuation.
fn tokens(code: &str) -> Vec<(usize, String)> {
    let chars: Vec<char> = code.chars().collect();
    let mut line = 1;
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == '\n' {
            line += 1;
            i += 1;
        } else if c.is_whitespace() {
            i += 1;
        } else if is_ident(c) {
            let start = i;
            while i < chars.len() && is_ident(chars[i]) {
                i += 1;
            }
            out.push((line, chars[start..i].iter().collect()));
        } else if c == ':' && chars.get(i + 1) == Some(&':') {
            out.push((line, "::".to_string()));
            i += 2;
        } else {
            out.push((line, c.to_string()));
            i += 1;
        }
    }
    out
}

/// The top-level modules a file refers to. `depth` is the file's own module
/// depth (`src/x.rs` and `src/x/mod.rs`: 1, `src/x/y.rs`: 2), so that a
/// `super::` chain that climbs out of its top-level module is caught too.
fn references(text: &str, depth: usize) -> Vec<Reference> {
    let toks = tokens(&code_only(text));
    let word = |k: usize| toks.get(k).map(|(_, t)| t.as_str());
    let mut found = Vec::new();
    // Brace depths at which inline `mod name {` blocks were opened.
    let mut inline_mods: Vec<usize> = Vec::new();
    let mut braces = 0usize;
    let mut k = 0;
    while k < toks.len() {
        let (line, tok) = (toks[k].0, toks[k].1.as_str());
        match tok {
            "{" => {
                if k >= 2 && word(k - 2) == Some("mod") {
                    inline_mods.push(braces);
                }
                braces += 1;
            }
            "}" => {
                braces = braces.saturating_sub(1);
                if inline_mods.last() == Some(&braces) {
                    inline_mods.pop();
                }
            }
            _ => {}
        }
        let after_path = k > 0 && word(k - 1) == Some("::");
        let macro_crate = k > 0 && word(k - 1) == Some("$");
        let root = if tok == "crate" && !after_path && !macro_crate {
            Some(k + 1)
        } else if tok == "super" && !after_path {
            let mut climbed = 0;
            let mut j = k;
            while word(j) == Some("super") && word(j + 1) == Some("::") {
                climbed += 1;
                j += 2;
            }
            (climbed > 0 && climbed >= depth + inline_mods.len()).then_some(j - 1)
        } else {
            None
        };
        if let Some(sep) = root.filter(|&s| word(s) == Some("::")) {
            for module in first_segments(&toks, sep + 1) {
                found.push(Reference { line, module });
            }
        }
        k += 1;
    }
    found
}

/// The first segment of the path at `at`: one name, or for a group
/// (`{a::b, c}`) the first name of each of its items.
fn first_segments(toks: &[(usize, String)], at: usize) -> Vec<String> {
    let Some((_, first)) = toks.get(at) else {
        return Vec::new();
    };
    if first != "{" {
        return vec![first.clone()];
    }
    let mut names = Vec::new();
    let mut nesting = 0;
    let mut item_start = true;
    for (_, tok) in &toks[at + 1..] {
        match tok.as_str() {
            "{" => nesting += 1,
            "}" if nesting == 0 => break,
            "}" => nesting -= 1,
            "," if nesting == 0 => item_start = true,
            name if item_start => {
                names.push(name.to_string());
                item_start = false;
            }
            _ => {}
        }
    }
    names
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, into: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        panic!("cannot read {}", dir.display())
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, into);
        } else if path.extension().is_some_and(|e| e == "rs") {
            into.push(path);
        }
    }
}

/// The top-level module of a file under `src/` and its module depth.
fn module_of(relative: &Path) -> (String, usize) {
    let parts: Vec<String> = relative
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let top = parts[0].trim_end_matches(".rs").to_string();
    let depth = parts.len() - usize::from(parts.last().is_some_and(|p| p == "mod.rs"));
    (top, depth)
}

/// Every reference in `src/` that goes to the same layer or up, as
/// `file:line: a -> b`.
fn violations(src: &Path) -> Vec<String> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files.sort();
    let mut found = Vec::new();
    for file in files {
        let relative = file.strip_prefix(src).unwrap_or(&file);
        let (top, depth) = module_of(relative);
        if NOT_LAYERS.contains(&top.as_str()) {
            continue;
        }
        let text = fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let Some(from) = layer(&top) else {
            found.push(format!("{}: module `{top}` is in no layer", file.display()));
            continue;
        };
        for r in references(&text, depth) {
            if r.module == top {
                continue;
            }
            match layer(&r.module) {
                Some(to) if to < from => {}
                Some(_) => found.push(format!(
                    "src/{}:{}: `{top}` uses `{}`, which is not below it",
                    relative.display(),
                    r.line,
                    r.module
                )),
                // `crate::SomeReexport` or a name that is not a module.
                None => {}
            }
        }
    }
    found
}

#[test]
fn no_module_uses_its_own_layer_or_one_above() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let found = violations(&src);
    assert!(
        found.is_empty(),
        "imports against the layer order (src/layers.rs, docs/architecture.md):\n{}",
        found.join("\n")
    );
}

#[test]
fn every_top_level_module_has_a_layer() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut modules = BTreeSet::new();
    for entry in fs::read_dir(&src).expect("src").flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let path = entry.path();
        if path.is_dir() || name.ends_with(".rs") {
            modules.insert(name.trim_end_matches(".rs").to_string());
        }
    }
    for module in &modules {
        assert!(
            NOT_LAYERS.contains(&module.as_str()) || layer(module).is_some(),
            "src/{module}: add it to a row of LAYERS in src/layers.rs"
        );
    }
    for row in LAYERS {
        for module in *row {
            assert!(
                modules.contains(*module),
                "LAYERS names `{module}`, not in src/"
            );
        }
    }
}

#[test]
fn references_are_found_in_every_spelling() {
    let text = r##"
use crate::proto::isel;
use crate::{axis::Axis, ui::{keymap, model}, device};
pub(crate) fn f() { let _ = crate::sim::SimDevice::new(); }
// use crate::cli::nothing;  (a comment)
/* crate::cli::nothing /* nested */ still comment */
const S: &str = "crate::cli::nothing";
const R: &str = r#"crate::cli::nothing"#;
fn g<'a>(c: char) -> bool { c == '{' || c == '\'' }
macro_rules! m { () => { $crate::cli::x() } }
mod inner {
    use super::super::jog::Gate;
    use super::local;
}
use super::super::config::Profile;
"##;
    // As `src/device/x.rs` (depth 2): `super::super` leaves `device`
    // outside the inline module, not inside it.
    let found: Vec<(usize, String)> = references(text, 2)
        .into_iter()
        .map(|r| (r.line, r.module))
        .collect();
    let expect = [
        (2, "proto"),
        (3, "axis"),
        (3, "ui"),
        (3, "device"),
        (4, "sim"),
        (15, "config"),
    ];
    let expect: Vec<(usize, String)> = expect.iter().map(|(l, m)| (*l, m.to_string())).collect();
    assert_eq!(found, expect);
}

#[test]
fn an_upward_import_is_reported_with_its_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let device = dir.path().join("device");
    fs::create_dir_all(&device).expect("mkdir");
    fs::write(
        device.join("mod.rs"),
        "use crate::config::Profile;\nuse crate::{proto, ui::keymap::Action};\n",
    )
    .expect("write");
    fs::write(
        dir.path().join("traffic.rs"),
        "use crate::config::Profile;\n",
    )
    .expect("write");
    let found = violations(dir.path());
    assert_eq!(
        found,
        [
            "src/device/mod.rs:2: `device` uses `ui`, which is not below it",
            "src/traffic.rs:1: `traffic` uses `config`, which is not below it",
        ]
    );
}

// ----- import circles inside `src/ui` ----------------------------------------

/// A file's module path under `src/` (`ui/jog/limit.rs` → `ui::jog::limit`,
/// `ui/jog/mod.rs` → `ui::jog`).
fn module_path(relative: &Path) -> Vec<String> {
    let mut parts: Vec<String> = relative
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The module paths a file's code names, before its tests: `crate::…`,
/// `super::…` and `self::…` paths, `use` groups item by item, and paths
/// through the child modules the file declares (`mod x;` then `x::Y`).
/// `module` is the file's own module path. Paths are as far as they are
/// written; [`resolve`] finds the file they land in.
fn module_paths(text: &str, module: &[String]) -> Vec<(usize, Vec<String>)> {
    let code = code_only(text);
    // Code under a `#[cfg(test)]` is the file's tests: not an import.
    let code = code.split("#[cfg(test)]").next().unwrap_or_default();
    let toks = tokens(code);
    let word = |k: usize| toks.get(k).map(|(_, t)| t.as_str());
    let children: BTreeSet<&str> = (0..toks.len())
        .filter(|&k| word(k) == Some("mod") && word(k + 2) == Some(";"))
        .filter_map(|k| word(k + 1))
        .collect();
    let mut found = Vec::new();
    let mut k = 0;
    while k < toks.len() {
        let line = toks[k].0;
        let tok = toks[k].1.as_str();
        let after_path = k > 0 && word(k - 1) == Some("::");
        let base: Option<(Vec<String>, usize)> = if after_path || word(k + 1) != Some("::") {
            None
        } else if tok == "crate" {
            Some((Vec::new(), k + 2))
        } else if tok == "self" {
            Some((module.to_vec(), k + 2))
        } else if tok == "super" {
            let mut base = module.to_vec();
            let mut j = k;
            while word(j) == Some("super") && word(j + 1) == Some("::") {
                base.pop();
                j += 2;
            }
            Some((base, j))
        } else if children.contains(tok) {
            let mut base = module.to_vec();
            base.push(tok.to_string());
            Some((base, k + 2))
        } else {
            None
        };
        let Some((mut base, mut j)) = base else {
            k += 1;
            continue;
        };
        // The rest of the path: names joined by `::`, or a group.
        loop {
            match word(j) {
                Some("{") => {
                    for item in first_segments(&toks, j) {
                        let mut path = base.clone();
                        path.push(item);
                        found.push((line, path));
                    }
                    break;
                }
                Some(name) if name.chars().all(is_ident) => {
                    base.push(name.to_string());
                    if word(j + 1) == Some("::") {
                        j += 2;
                    } else {
                        found.push((line, base));
                        break;
                    }
                }
                _ => {
                    found.push((line, base));
                    break;
                }
            }
        }
        k = j.max(k + 1);
    }
    found
}

/// The file (module path) a path lands in: its longest prefix that is one.
fn resolve<'a>(path: &[String], files: &'a BTreeSet<Vec<String>>) -> Option<&'a Vec<String>> {
    (1..=path.len())
        .rev()
        .find_map(|n| files.get(path.get(..n)?))
}

/// File → the files it uses, for every file under `src/<top>`.
fn file_graph(src: &Path, top: &str) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let mut paths = Vec::new();
    rust_files(&src.join(top), &mut paths);
    let texts: BTreeMap<Vec<String>, String> = paths
        .iter()
        .map(|p| {
            let relative = p.strip_prefix(src).unwrap_or(p);
            let text = fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (module_path(relative), text)
        })
        .collect();
    let files: BTreeSet<Vec<String>> = texts.keys().cloned().collect();
    texts
        .iter()
        .map(|(module, text)| {
            let uses = module_paths(text, module)
                .iter()
                .filter_map(|(_, path)| resolve(path, &files))
                .filter(|to| *to != module)
                .cloned()
                .collect();
            (module.clone(), uses)
        })
        .collect()
}

/// The import circles of `graph`: every set of two or more files each of
/// which reaches the others (strongly connected components), sorted.
fn circles(graph: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<String>> {
    let reach = |from: &Vec<String>| -> BTreeSet<Vec<String>> {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<&Vec<String>> = graph.get(from).into_iter().flatten().collect();
        while let Some(n) = todo.pop() {
            if seen.insert(n.clone()) {
                todo.extend(graph.get(n).into_iter().flatten());
            }
        }
        seen
    };
    let reaches: BTreeMap<&Vec<String>, BTreeSet<Vec<String>>> =
        graph.keys().map(|n| (n, reach(n))).collect();
    let mut placed = BTreeSet::new();
    let mut out = Vec::new();
    for (n, r) in &reaches {
        if placed.contains(*n) || !r.contains(*n) {
            continue;
        }
        let ring: Vec<String> = r
            .iter()
            .filter(|m| reaches.get(m).is_some_and(|back| back.contains(*n)))
            .map(|m| {
                placed.insert(m.clone());
                m.join("::")
            })
            .collect();
        out.push(ring);
    }
    out
}

#[test]
fn the_files_of_ui_import_each_other_in_no_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let graph = file_graph(&src, "ui");
    assert!(graph.len() > 40, "src/ui was not read: {}", graph.len());
    let found = circles(&graph);
    assert!(
        found.is_empty(),
        "files of src/ui that import each other in a circle (docs/architecture.md, \
         \"Inside the UI\"):\n{}",
        found
            .iter()
            .map(|c| c.join(" ⇄ "))
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn ui_paths_are_resolved_to_files_and_a_circle_is_named() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ui = dir.path().join("ui");
    fs::create_dir_all(ui.join("jog")).expect("mkdir");
    let write = |p: &str, t: &str| fs::write(ui.join(p), t).expect("write");
    write("mod.rs", "pub mod jog;\npub mod model;\npub mod update;\n");
    write("model.rs", "use super::jog::Keypad;\n");
    write(
        "jog/mod.rs",
        "pub mod limit;\npub struct Keypad(limit::State);\n",
    );
    write(
        "jog/limit.rs",
        "// use crate::ui::update::say;\npub struct State;\n#[cfg(test)]\nmod tests { use crate::ui::update; }\n",
    );
    write(
        "update.rs",
        "use crate::ui::{model::Model, jog::{self, limit::State}};\n",
    );
    let graph = file_graph(dir.path(), "ui");
    let uses = |m: &str| -> Vec<String> {
        let key: Vec<String> = m.split("::").map(str::to_string).collect();
        graph
            .get(&key)
            .into_iter()
            .flatten()
            .map(|v| v.join("::"))
            .collect()
    };
    assert_eq!(uses("ui::model"), ["ui::jog"]);
    assert_eq!(uses("ui::jog"), ["ui::jog::limit"]);
    assert!(uses("ui::jog::limit").is_empty(), "comments and tests");
    assert_eq!(uses("ui::update"), ["ui::jog", "ui::model"]);
    assert!(circles(&graph).is_empty());
    // limit calls back up: model → jog → limit → model.
    write("jog/limit.rs", "pub struct State(crate::ui::model::M);\n");
    let found = circles(&file_graph(dir.path(), "ui"));
    assert_eq!(found, [vec!["ui::jog", "ui::jog::limit", "ui::model"]]);
}
