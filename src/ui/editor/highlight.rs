//! Syntax highlighting from the parser's spans: the command code, its
//! parameters and separators, comments, the places the parser noted (a
//! spelling the formatter would change), and what is wrong (the line's
//! syntax error, the linter's diagnostics).

use std::ops::Range;

use crate::program::{Diagnostic, Line, LineKind, Severity};

/// What a piece of a line is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Class {
    Plain,
    Code,
    Param,
    Punct,
    Comment,
}

/// What lies over a piece of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Mark {
    #[default]
    None,
    /// Accepted, but written differently by the formatter.
    Note,
    Warning,
    Error,
}

/// A run of bytes of one class and mark.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Run {
    pub bytes: Range<usize>,
    pub class: Class,
    pub mark: Mark,
}

fn paint<T: Copy>(cells: &mut [T], range: &Range<usize>, value: T) {
    let end = range.end.min(cells.len());
    let start = range.start.min(end);
    if let Some(slice) = cells.get_mut(start..end) {
        slice.fill(value);
    }
}

fn raise(cells: &mut [Mark], range: &Range<usize>, mark: Mark) {
    let end = range.end.min(cells.len());
    let start = range.start.min(end);
    if let Some(slice) = cells.get_mut(start..end) {
        for cell in slice {
            *cell = (*cell).max(mark);
        }
    }
}

impl PartialOrd for Mark {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Mark {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        let rank = |m: &Mark| match m {
            Mark::None => 0,
            Mark::Note => 1,
            Mark::Warning => 2,
            Mark::Error => 3,
        };
        rank(self).cmp(&rank(other))
    }
}

/// The runs of `line`, with `diagnostics` (of this line) and, when the
/// linter has not seen the line yet, its syntax error laid over them. An
/// empty span (something missing at the end) marks the last character.
pub fn runs(line: &Line, diagnostics: &[Diagnostic], unchecked: bool) -> Vec<Run> {
    let text = line.text();
    let n = text.len();
    let mut class = vec![Class::Plain; n];
    let mut mark = vec![Mark::None; n];
    match line.kind() {
        LineKind::Blank => {}
        LineKind::Comment(cols) => paint(&mut class, cols, Class::Comment),
        LineKind::Statement(s) => {
            paint(&mut class, &s.code, Class::Punct);
            let code_end = s.params.first().map_or(s.code.end, |p| p.start);
            paint(&mut class, &(s.code.start..code_end), Class::Code);
            for p in &s.params {
                paint(&mut class, p, Class::Param);
            }
            if let Some(c) = &s.comment {
                paint(&mut class, c, Class::Comment);
            }
            for note in &s.notes {
                raise(&mut mark, &note.cols, Mark::Note);
            }
            if unchecked && let Err(e) = &s.command {
                raise(&mut mark, &visible(&e.cols, text), Mark::Error);
            }
        }
    }
    for d in diagnostics {
        let m = match d.severity {
            Severity::Error => Mark::Error,
            Severity::Warning => Mark::Warning,
        };
        raise(&mut mark, &visible(&d.span.cols(), text), m);
    }
    // Runs on character boundaries only.
    let mut out: Vec<Run> = Vec::new();
    for (i, ch) in text.char_indices() {
        let end = i + ch.len_utf8();
        let (c, m) = (
            class.get(i).copied().unwrap_or(Class::Plain),
            mark.get(i).copied().unwrap_or_default(),
        );
        match out.last_mut() {
            Some(run) if run.class == c && run.mark == m => run.bytes.end = end,
            _ => out.push(Run {
                bytes: i..end,
                class: c,
                mark: m,
            }),
        }
    }
    out
}

/// A span that can be seen: an empty one (something missing) covers the
/// character before it, or the first one.
fn visible(cols: &Range<usize>, text: &str) -> Range<usize> {
    if cols.start < cols.end {
        return cols.clone();
    }
    let at = cols.start.min(text.len());
    match text
        .get(..at)
        .and_then(|head| head.char_indices().next_back())
    {
        Some((i, c)) => i..i + c.len_utf8(),
        None => 0..text.chars().next().map_or(0, char::len_utf8),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::{Language, Program};

    fn classes(text: &str) -> Vec<(String, Class, Mark)> {
        let p = Program::parse(Language::Isel, text);
        let line = p.line(0).expect("a line");
        runs(line, &[], true)
            .into_iter()
            .map(|r| (text[r.bytes.clone()].to_string(), r.class, r.mark))
            .collect()
    }

    #[test]
    fn codes_parameters_comments_and_errors() {
        use Class::*;
        assert_eq!(
            classes("m100,900 ; go"),
            [
                ("m".to_string(), Code, Mark::None),
                ("100".to_string(), Param, Mark::None),
                (",".to_string(), Punct, Mark::None),
                ("900".to_string(), Param, Mark::None),
                (" ".to_string(), Plain, Mark::None),
                ("; go".to_string(), Comment, Mark::None),
            ]
        );
        let bad = classes("x12");
        assert!(bad.iter().any(|(_, _, m)| *m == Mark::Error), "{bad:?}");
        let noted = classes("M100,900");
        assert_eq!(
            noted.first().map(|r| r.2),
            Some(Mark::Note),
            "table spelling"
        );
        assert_eq!(
            classes("; Größe").len(),
            1,
            "one run over multi-byte characters"
        );
    }
}
