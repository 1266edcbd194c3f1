//! Configuration files as TOML text with their origin, merged as patches over
//! the embedded defaults, and errors that point at a file, line and column.
//!
//! A user file overrides the shipped defaults field by field (gitui's style
//! patches): tables merge key by key, every other value (arrays included)
//! replaces the default. The merged table is deserialized once; when a field is
//! wrong, the failing key path is looked up in the user's own file so the error
//! names the line the user wrote.

use std::fmt;
use std::path::PathBuf;

use serde::de::DeserializeOwned;
use toml::de::{DeTable, DeValue};

/// Where a configuration text came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// Compiled into jogterm from `config/` or `themes/`.
    Embedded(&'static str),
    File(PathBuf),
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::Embedded(name) => write!(f, "<built-in {name}>"),
            Origin::File(path) => write!(f, "{}", path.display()),
        }
    }
}

/// A configuration text and where it came from.
#[derive(Debug, Clone)]
pub struct Source {
    pub origin: Origin,
    pub text: String,
}

/// A configuration problem, located in the file that caused it, and the
/// further problems found in the same files (`more`): a file with several
/// mistakes gets them all reported at once, each on a line of its own.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct ConfigError {
    pub origin: Origin,
    /// 1-based line and column, when the problem has a place in the text.
    pub line: Option<usize>,
    pub column: Option<usize>,
    /// Dotted key path of the offending field, e.g. `axes.X.steps_per_unit`.
    pub key: Option<String>,
    pub message: String,
    /// The other problems, in the order of the files and lines (boxed: an
    /// error travels in every `Result` of the loader).
    pub more: Box<[ConfigError]>,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}{}: error: {}{}",
            self.origin,
            location(self.line, self.column),
            self.message,
            key_note(&self.key)
        )?;
        for other in self.more.iter() {
            write!(f, "\n{other}")?;
        }
        Ok(())
    }
}

fn location(line: Option<usize>, column: Option<usize>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!(":{l}:{c}"),
        (Some(l), None) => format!(":{l}"),
        _ => String::new(),
    }
}

fn key_note(key: &Option<String>) -> String {
    key.as_ref()
        .map(|k| format!(" (at `{k}`)"))
        .unwrap_or_default()
}

impl ConfigError {
    pub fn new(origin: Origin, message: impl Into<String>) -> Self {
        Self {
            origin,
            line: None,
            column: None,
            key: None,
            message: message.into(),
            more: Box::default(),
        }
    }

    /// One error carrying all of `errors`, sorted by file, line and column;
    /// `None` when there are none.
    pub fn all(mut errors: Vec<ConfigError>) -> Option<ConfigError> {
        errors.sort_by(|a, b| {
            (a.origin.to_string(), a.line, a.column).cmp(&(b.origin.to_string(), b.line, b.column))
        });
        errors.dedup();
        let mut iter = errors.into_iter();
        let mut first = iter.next()?;
        first.more = iter.collect();
        Some(first)
    }

    /// This problem and the further ones, each on its own.
    pub fn each(&self) -> Vec<ConfigError> {
        let mut head = self.clone();
        let more = std::mem::take(&mut head.more);
        std::iter::once(head).chain(more.into_vec()).collect()
    }

    /// An error about the field at `key`, placed on its line in `source` when
    /// the source sets it (otherwise on the file as a whole).
    pub fn at_key(source: &Source, key: &[String], message: impl Into<String>) -> Self {
        let mut err = ConfigError::new(source.origin.clone(), message);
        err.key = Some(key.join("."));
        if let Some(offset) = locate_key(&source.text, key) {
            let (line, column) = line_column(&source.text, offset);
            err.line = Some(line);
            err.column = Some(column);
        }
        err
    }

    fn from_toml(source: &Source, err: &toml::de::Error) -> Self {
        let mut out = ConfigError::new(source.origin.clone(), err.message().trim().to_string());
        if let Some(span) = err.span() {
            let (line, column) = line_column(&source.text, span.start);
            out.line = Some(line);
            out.column = Some(column);
        }
        out
    }
}

/// 1-based line and column of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// Byte offset of the value at `key` in `text`, when the text sets it.
fn locate_key(text: &str, key: &[String]) -> Option<usize> {
    locate_value(text, key).map(|span| span.start)
}

/// Byte range of the value at `key` (tables by key, arrays by index), when
/// the text sets it.
fn locate_value(text: &str, key: &[String]) -> Option<std::ops::Range<usize>> {
    let doc = DeTable::parse(text).ok()?;
    let (first, rest) = key.split_first()?;
    let (_, mut value) = doc
        .get_ref()
        .iter()
        .find(|(k, _)| k.get_ref().as_ref() == first.as_str())?;
    for part in rest {
        let inner = match value.get_ref() {
            DeValue::Table(table) => table
                .iter()
                .find(|(k, _)| k.get_ref().as_ref() == part.as_str())
                .map(|(_, v)| v),
            DeValue::Array(items) => part.parse::<usize>().ok().and_then(|i| items.get(i)),
            _ => None,
        };
        value = inner?;
    }
    Some(value.span())
}

/// Byte offset in `raw` (a TOML string literal with its quotes) of the
/// character at byte `offset` of its decoded value. Escapes count as the
/// characters they are written with.
fn offset_in_literal(raw: &str, offset: usize) -> usize {
    let quote_len = if raw.starts_with("\"\"\"") || raw.starts_with("'''") {
        3
    } else {
        1
    };
    let literal = raw.starts_with('\'');
    let body = raw.get(quote_len..).unwrap_or("");
    let mut decoded = 0;
    let mut chars = body.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        if decoded >= offset {
            return quote_len + i;
        }
        if c == '\\' && !literal {
            let skip = match chars.peek().map(|(_, e)| *e) {
                Some('u') => 5,
                Some('U') => 9,
                Some('x') => 3,
                _ => 1,
            };
            for _ in 0..skip {
                chars.next();
            }
            // An escape stands for one character; its UTF-8 length is not
            // known here and does not matter for the column of later ones
            // within the usual ASCII command text.
            decoded += 1;
        } else {
            decoded += c.len_utf8();
        }
    }
    quote_len + body.len()
}

/// Parse a source as a TOML table, with syntax errors located.
pub fn parse_table(source: &Source) -> Result<toml::Table, ConfigError> {
    toml::from_str::<toml::Table>(&source.text).map_err(|e| ConfigError::from_toml(source, &e))
}

/// Parse and deserialize one source as it is (no layering), with errors
/// located in it: for tables whose spans matter (`toml::Spanned`), which a
/// merged [`toml::Table`] would lose.
pub fn deserialize_text<T: DeserializeOwned>(source: &Source) -> Result<T, ConfigError> {
    toml::from_str::<T>(&source.text).map_err(|e| ConfigError::from_toml(source, &e))
}

/// Merge `patch` into `base`: tables key by key, anything else replaced.
pub fn merge(base: &mut toml::Table, patch: toml::Table) {
    for (key, value) in patch {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(p)) => merge(b, p),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// Deserialize a merged table. A failing field is reported against the first
/// source (the most specific one, usually the user's file) that sets it.
pub fn deserialize<T: DeserializeOwned>(
    table: toml::Table,
    sources: &[&Source],
) -> Result<T, ConfigError> {
    match deserialize_all(table, None, sources) {
        (Some(value), errors) if errors.is_empty() => Ok(value),
        (_, errors) => Err(ConfigError::all(errors).unwrap_or_else(unlocated)),
    }
}

fn unlocated() -> ConfigError {
    ConfigError::new(Origin::Embedded("configuration"), "cannot be read")
}

/// Most problems one load reports: beyond it a file is more wrong than right.
const MAX_PROBLEMS: usize = 50;

/// Deserialize a merged table, collecting every field that fails rather than
/// only the first: after each failure the field is set back to its value in
/// `fallback` (the embedded defaults the file patches, known to be good) or
/// left out when the defaults have none, and the table is tried again. So
/// one wrong field cannot hide another. Each error is placed in the most
/// specific source that sets its key. The value is the repaired one (for
/// checks that look at more than one field), `None` when the table could
/// not be repaired.
pub fn deserialize_all<T: DeserializeOwned>(
    mut table: toml::Table,
    fallback: Option<&toml::Table>,
    sources: &[&Source],
) -> (Option<T>, Vec<ConfigError>) {
    let mut errors: Vec<ConfigError> = Vec::new();
    let mut seen: Vec<(Vec<String>, String)> = Vec::new();
    // Fields left out by a repair: their "missing field" is no new problem.
    let mut dropped: Vec<Vec<String>> = Vec::new();
    loop {
        let err = match serde_path_to_error::deserialize::<_, T>(toml::Value::Table(table.clone()))
        {
            Ok(value) => return (Some(value), errors),
            Err(err) => err,
        };
        let key: Vec<String> = err
            .path()
            .iter()
            .filter_map(|seg| match seg {
                serde_path_to_error::Segment::Map { key } => Some(key.clone()),
                serde_path_to_error::Segment::Seq { index } => Some(index.to_string()),
                _ => None,
            })
            .collect();
        let message = err.inner().message().trim().to_string();
        let path = field_path(&table, &key, &message);
        let again = seen.iter().any(|(k, m)| *k == key && *m == message);
        if again || dropped.contains(&path) {
            return (None, errors);
        }
        errors.push(error_for_key(sources, &key, message.clone()));
        if errors.len() >= MAX_PROBLEMS {
            return (None, errors);
        }
        match repair(&mut table, fallback, &path) {
            Repair::Replaced => {}
            Repair::Dropped => dropped.push(path),
            Repair::Impossible => return (None, errors),
        }
        seen.push((key, message));
    }
}

/// The field an error is about: the key path, or for a missing field the
/// path of that field; cut at the first array (a bad element is repaired
/// by replacing its whole array).
fn field_path(table: &toml::Table, key: &[String], message: &str) -> Vec<String> {
    let missing = message
        .strip_prefix("missing field `")
        .and_then(|rest| rest.split_once('`'))
        .map(|(field, _)| field.to_string());
    let full: Vec<String> = key.iter().cloned().chain(missing).collect();
    let mut current = Some(table);
    let mut out = Vec::new();
    for part in full {
        let Some(t) = current else { break };
        current = match t.get(&part) {
            Some(toml::Value::Table(inner)) => Some(inner),
            _ => None,
        };
        out.push(part);
    }
    out
}

enum Repair {
    Replaced,
    Dropped,
    Impossible,
}

/// Put the field at `path` back to what `fallback` has there, or drop it.
fn repair(table: &mut toml::Table, fallback: Option<&toml::Table>, path: &[String]) -> Repair {
    let Some((last, parents)) = path.split_last() else {
        return Repair::Impossible;
    };
    let good = fallback.and_then(|f| lookup(f, path)).cloned();
    let Some(parent) = lookup_table_mut(table, parents) else {
        return Repair::Impossible;
    };
    match good {
        Some(value) if parent.get(last) != Some(&value) => {
            parent.insert(last.clone(), value);
            Repair::Replaced
        }
        Some(_) => Repair::Impossible,
        None => match parent.remove(last) {
            Some(_) => Repair::Dropped,
            None => Repair::Impossible,
        },
    }
}

fn lookup<'a>(table: &'a toml::Table, path: &[String]) -> Option<&'a toml::Value> {
    let (first, rest) = path.split_first()?;
    let value = table.get(first)?;
    match (value, rest.is_empty()) {
        (v, true) => Some(v),
        (toml::Value::Table(t), false) => lookup(t, rest),
        _ => None,
    }
}

fn lookup_table_mut<'a>(
    table: &'a mut toml::Table,
    path: &[String],
) -> Option<&'a mut toml::Table> {
    let Some((first, rest)) = path.split_first() else {
        return Some(table);
    };
    match table.get_mut(first)? {
        toml::Value::Table(t) => lookup_table_mut(t, rest),
        _ => None,
    }
}

/// An error for `key`, placed in the most specific source that mentions it.
pub fn error_for_key(
    sources: &[&Source],
    key: &[String],
    message: impl Into<String>,
) -> ConfigError {
    let message = message.into();
    let chosen = sources
        .iter()
        .find(|s| locate_key(&s.text, key).is_some())
        .or_else(|| sources.first())
        .copied();
    match chosen {
        Some(source) => ConfigError::at_key(source, key, message),
        None => ConfigError::new(Origin::Embedded("configuration"), message),
    }
}

/// An error about a place inside the string at `key` (byte `offset` of its
/// value): the file, line and the column of that character.
pub fn error_in_string(
    sources: &[&Source],
    key: &[String],
    offset: usize,
    message: impl Into<String>,
) -> ConfigError {
    let mut err = error_for_key(sources, key, message);
    let source = sources
        .iter()
        .find(|s| s.origin == err.origin && locate_key(&s.text, key).is_some());
    if let Some(source) = source
        && let Some(span) = locate_value(&source.text, key)
        && let Some(raw) = source.text.get(span.clone())
        && (raw.starts_with('"') || raw.starts_with('\''))
    {
        let (line, column) = line_column(&source.text, span.start + offset_in_literal(raw, offset));
        err.line = Some(line);
        err.column = Some(column);
    }
    err
}

#[cfg(test)]
mod tests {
    use super::*;

    fn source(text: &str) -> Source {
        Source {
            origin: Origin::File("user.toml".into()),
            text: text.into(),
        }
    }

    #[test]
    fn merge_patches_field_by_field() {
        let mut base: toml::Table =
            toml::from_str("[a]\nx = 1\ny = 2\n[b]\nlist = [1, 2]").unwrap();
        let patch: toml::Table = toml::from_str("[a]\ny = 3\n[b]\nlist = [9]").unwrap();
        merge(&mut base, patch);
        assert_eq!(base["a"]["x"].as_integer(), Some(1));
        assert_eq!(base["a"]["y"].as_integer(), Some(3));
        assert_eq!(base["b"]["list"].as_array().map(Vec::len), Some(1));
    }

    #[test]
    fn syntax_errors_carry_line_and_column() {
        let err = parse_table(&source("a = 1\nb = = 2\n")).unwrap_err();
        assert_eq!(err.line, Some(2));
        assert!(err.to_string().starts_with("user.toml:2:"), "{err}");
    }

    #[test]
    fn type_errors_point_at_the_users_line() {
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Inner {
            steps: f64,
        }
        #[derive(serde::Deserialize, Debug)]
        #[allow(dead_code)]
        struct Outer {
            axis: Inner,
        }
        let user = source("# comment\n[axis]\nsteps = \"many\"\n");
        let table = parse_table(&user).unwrap();
        let err = deserialize::<Outer>(table, &[&user]).unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
        assert_eq!(err.key.as_deref(), Some("axis.steps"));
        assert!(err.message.contains("expected f64"), "{err}");
    }

    #[test]
    fn a_place_in_a_string_of_an_array_has_its_own_column() {
        let user = source("[macros.park]\nlines = [\n  \"@0P\",\n  \"@0M 1,x\",\n]\n");
        let key: Vec<String> = ["macros", "park", "lines", "1"].map(String::from).to_vec();
        let err = error_in_string(&[&user], &key, 6, "bad");
        assert_eq!((err.line, err.column), (Some(4), Some(10)), "{err}");
        let literal = source("[m]\nl = ['ab', \"\\u0041xy\"]\n");
        let key: Vec<String> = ["m", "l", "1"].map(String::from).to_vec();
        let err = error_in_string(&[&literal], &key, 1, "bad");
        assert_eq!((err.line, err.column), (Some(2), Some(19)), "{err}");
    }
}
