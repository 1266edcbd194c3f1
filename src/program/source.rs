//! Source text of a program: lines, comments and spans.
//!
//! A program file is a sequence of lines (LF or CR LF). Each line is blank, a
//! comment, or one command with an optional trailing comment. Comments and
//! blank lines never reach the controller (`docs/programs.md`):
//! - a line whose first non-blank character is `;` is a comment;
//! - a line whose first non-blank character is `#` followed by a blank or the
//!   end of the line is a comment. EMCU commands start with `#` too (`#S150`,
//!   `#E1,800`, `#R400`), but never with `#` and a blank, so the rule cannot
//!   swallow one;
//! - a `;` after a command starts a trailing comment (no command of either
//!   family contains `;`).
//!
//! Blanks (spaces, tabs) before and after a command are not part of it.

use std::ops::Range;

/// A place in the source: a line (0-based) and a byte range in it. Columns are
/// byte offsets, so an editor can slice the line's text with them; use
/// [`Span::column`] for the 1-based character column a person reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Span {
    pub line: usize,
    pub start: usize,
    pub end: usize,
}

impl Span {
    pub fn new(line: usize, cols: Range<usize>) -> Span {
        Span {
            line,
            start: cols.start,
            end: cols.end.max(cols.start),
        }
    }

    /// The byte range in the line.
    pub fn cols(&self) -> Range<usize> {
        self.start..self.end
    }

    /// The 1-based character column of the span's start in `line_text`, as
    /// compilers print it (`file:line:col`).
    pub fn column(&self, line_text: &str) -> usize {
        // A start inside a multi-byte character (never produced here) is the
        // column of that character.
        let boundary = (0..=self.start.min(line_text.len()))
            .rev()
            .find(|i| line_text.is_char_boundary(*i))
            .unwrap_or(0);
        line_text.get(..boundary).map_or(0, |p| p.chars().count()) + 1
    }
}

/// The lines of a text: split at LF, one CR before the LF dropped. A final
/// line end does not start another line; an empty text has no lines.
pub fn lines(text: &str) -> impl Iterator<Item = &str> {
    let body = text.strip_suffix('\n').unwrap_or(text);
    let mut pieces = if text.is_empty() {
        None
    } else {
        Some(body.split('\n'))
    };
    std::iter::from_fn(move || {
        let piece = pieces.as_mut()?.next()?;
        Some(piece.strip_suffix('\r').unwrap_or(piece))
    })
}

/// What one line holds, as byte ranges in it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Shape {
    Blank,
    /// A whole-line comment: from its marker to the last non-blank character.
    Comment(Range<usize>),
    /// A command, without blanks around it, and its trailing comment.
    Code {
        code: Range<usize>,
        comment: Option<Range<usize>>,
    },
}

fn is_blank(c: char) -> bool {
    c.is_ascii_whitespace()
}

/// Classify one line (without its line end).
pub(crate) fn shape(line: &str) -> Shape {
    let start = line.len() - line.trim_start_matches(is_blank).len();
    let end = line.trim_end_matches(is_blank).len();
    let Some(rest) = line.get(start..end).filter(|r| !r.is_empty()) else {
        return Shape::Blank;
    };
    let mut chars = rest.chars();
    let first = chars.next();
    let second = chars.next();
    if first == Some(';') || (first == Some('#') && second.is_none_or(is_blank)) {
        return Shape::Comment(start..end);
    }
    match rest.find(';') {
        None => Shape::Code {
            code: start..end,
            comment: None,
        },
        Some(at) => {
            let semicolon = start + at;
            let code_end = line
                .get(..semicolon)
                .map_or(semicolon, |s| s.trim_end_matches(is_blank).len());
            Shape::Code {
                code: start..code_end,
                comment: Some(semicolon..end),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_split_at_lf_and_drop_one_cr() {
        assert_eq!(lines("").count(), 0);
        assert_eq!(lines("a").collect::<Vec<_>>(), ["a"]);
        assert_eq!(lines("a\n").collect::<Vec<_>>(), ["a"]);
        assert_eq!(lines("a\r\nb\r\n").collect::<Vec<_>>(), ["a", "b"]);
        assert_eq!(lines("\n\n").collect::<Vec<_>>(), ["", ""]);
        assert_eq!(lines("a\r\r\nb").collect::<Vec<_>>(), ["a\r", "b"]);
    }

    #[test]
    fn comments_blanks_and_code_are_told_apart() {
        assert_eq!(shape(""), Shape::Blank);
        assert_eq!(shape(" \t "), Shape::Blank);
        assert_eq!(shape("; note"), Shape::Comment(0..6));
        assert_eq!(shape("  # note  "), Shape::Comment(2..8));
        assert_eq!(shape("#"), Shape::Comment(0..1));
        assert_eq!(shape("#\tx"), Shape::Comment(0..3));
        assert_eq!(
            shape("#S150"),
            Shape::Code {
                code: 0..5,
                comment: None
            }
        );
        assert_eq!(
            shape("  m100,900 ; home "),
            Shape::Code {
                code: 2..10,
                comment: Some(11..17)
            }
        );
        assert_eq!(
            shape("#E1,800;fast"),
            Shape::Code {
                code: 0..7,
                comment: Some(7..12)
            }
        );
    }

    #[test]
    fn columns_count_characters_from_one() {
        let span = Span::new(0, 4..5);
        assert_eq!(span.column("abcdef"), 5);
        assert_eq!(Span::new(0, 3..4).column("äbc"), 3);
        assert_eq!(Span::new(0, 1..2).column("äbc"), 1);
        assert_eq!(Span::new(0, 99..99).column("ab"), 3);
    }
}
