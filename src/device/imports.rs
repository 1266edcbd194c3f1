//! The modules of each driver (and of `common` and `inputs`) use each other
//! in one direction: shared types live in leaf modules (`emcu::context`
//! names its lines itself, `emp::drive` holds a drive's state), so no ring
//! of modules has to be understood, or changed, at once. Checked on the
//! sources: a `super::sibling` path (or `crate::device::<dir>::sibling`)
//! outside a file's tests is an edge, and a cycle fails with its modules.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::Path;

/// The directories under `src/device` whose files are checked.
const DIRS: &[&str] = &["isel", "emcu", "emp", "common", "inputs"];

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// A file's code before its tests, without comments (line comments and
/// doc comments: enough for these files, which put paths in no strings).
fn code(text: &str) -> String {
    text.lines()
        .take_while(|l| !l.trim_start().starts_with("#[cfg(test)]"))
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The first segments after each `prefix` in `code`: `prefix::a::b` gives
/// `a`, `prefix::{a::X, b}` gives `a` and `b`.
fn first_segments(code: &str, prefix: &str) -> BTreeSet<String> {
    let mut found = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find(prefix) {
        let before_ok = rest[..i].chars().next_back().is_none_or(|c| !is_ident(c));
        rest = &rest[i + prefix.len()..];
        if !before_ok {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 0usize;
            let mut item = String::new();
            let mut items = Vec::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => items.push(std::mem::take(&mut item)),
                    _ => item.push(c),
                }
            }
            items.push(item);
            for item in items {
                let name: String = item.trim().chars().take_while(|c| is_ident(*c)).collect();
                if !name.is_empty() {
                    found.insert(name);
                }
            }
        } else {
            let name: String = rest.chars().take_while(|c| is_ident(*c)).collect();
            if !name.is_empty() {
                found.insert(name);
            }
        }
    }
    found
}

/// Module → the sibling modules it uses, for the files of `dir`.
fn graph(dir: &Path, name: &str) -> BTreeMap<String, BTreeSet<String>> {
    let Ok(entries) = fs::read_dir(dir) else {
        return BTreeMap::new();
    };
    let files: BTreeMap<String, String> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .filter_map(|p| {
            let module = p.file_stem()?.to_str()?.to_owned();
            Some((module, fs::read_to_string(&p).ok()?))
        })
        .filter(|(module, _)| module != "mod")
        .collect();
    files
        .iter()
        .map(|(module, text)| {
            let code = code(text);
            let mut uses = first_segments(&code, "super::");
            uses.extend(first_segments(&code, &format!("crate::device::{name}::")));
            let siblings = uses
                .into_iter()
                .filter(|u| u != module && files.contains_key(u))
                .collect();
            (module.clone(), siblings)
        })
        .collect()
}

/// A cycle in `graph`, as the modules on it, if there is one.
fn cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = path.iter().position(|p| p == node) {
            let mut ring = path[at..].to_vec();
            ring.push(node.to_owned());
            return Some(ring);
        }
        if done.contains(node) {
            return None;
        }
        path.push(node.to_owned());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(ring) = visit(next, graph, path, done) {
                return Some(ring);
            }
        }
        path.pop();
        done.insert(node.to_owned());
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|start| visit(start, graph, &mut Vec::new(), &mut done))
}

#[test]
fn the_modules_of_each_driver_use_each_other_in_one_direction() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/device");
    for name in DIRS {
        let g = graph(&root.join(name), name);
        assert!(g.len() > 3, "src/device/{name}: its modules were not read");
        if let Some(ring) = cycle(&g) {
            panic!(
                "src/device/{name}: the modules use each other in a ring: {}",
                ring.join(" → ")
            );
        }
    }
}

#[test]
fn uses_are_found_in_every_spelling_and_a_ring_is_named() {
    let code = code(
        "use super::context::{Cmd, Context};\nuse super::{io, op::Next};\n\
         // super::raw in a comment\nlet t = crate::device::emcu::run::x();\nfn f() { not_super::y }",
    );
    let mut uses = first_segments(&code, "super::");
    uses.extend(first_segments(&code, "crate::device::emcu::"));
    assert_eq!(
        uses.into_iter().collect::<Vec<_>>(),
        ["context", "io", "op", "run"]
    );
    let g: BTreeMap<String, BTreeSet<String>> = [
        ("a", vec!["b"]),
        ("b", vec!["c"]),
        ("c", vec!["a"]),
        ("d", vec![]),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v.into_iter().map(str::to_owned).collect()))
    .collect();
    assert_eq!(
        cycle(&g),
        Some(vec!["a".into(), "b".into(), "c".into(), "a".into()])
    );
    let mut g = g;
    g.insert("c".into(), BTreeSet::new());
    assert_eq!(cycle(&g), None);
}
