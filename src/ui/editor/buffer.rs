//! The text being edited: the parsed [`Program`] itself is the buffer, so
//! every edit re-parses only the lines it touches
//! ([`Program::replace_lines`]) and spans, diagnostics and command indices
//! are always those of the text on screen. A cursor (line and character
//! column), and undo/redo as a history of line replacements.
//!
//! The program sits behind an `Arc`: the lint worker reads a snapshot while
//! the operator types on, and an edit copies the program only when that
//! snapshot is still being read (`Arc::make_mut`).

use std::sync::Arc;

use crate::program::{Language, Program};

/// Undo steps kept; the oldest are forgotten beyond this.
pub const UNDO_STEPS: usize = 1000;

/// A place in the text: a line and a column in characters (not bytes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Cursor {
    pub line: usize,
    pub col: usize,
}

impl Cursor {
    pub fn new(line: usize, col: usize) -> Cursor {
        Cursor { line, col }
    }
}

/// What an edit did to the lines: `removed` lines from `at` were replaced
/// by `inserted` lines. Diagnostics and marks shift by it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Change {
    pub at: usize,
    pub removed: usize,
    pub inserted: usize,
}

impl Change {
    /// Where line `line` of the text before the change is now; `None` for a
    /// line the change replaced.
    pub fn map_line(&self, line: usize) -> Option<usize> {
        if line < self.at {
            Some(line)
        } else if line < self.at + self.removed {
            None
        } else {
            Some(line - self.removed + self.inserted)
        }
    }
}

/// Which kind of typing an edit was, so that a run of typed characters (or
/// of deletions) on one line is undone as one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Typing,
    Deleting,
    Other,
}

/// One undoable step: lines `at..at + removed.len()` became `inserted`.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Step {
    at: usize,
    removed: Vec<String>,
    inserted: Vec<String>,
    before: Cursor,
    after: Cursor,
    state_before: u64,
    state_after: u64,
    kind: Kind,
}

#[derive(Debug, Clone)]
pub struct Buffer {
    program: Arc<Program>,
    cursor: Cursor,
    /// The column Up/Down try to keep.
    goal: Option<usize>,
    undo: Vec<Step>,
    redo: Vec<Step>,
    /// Identifies the content: every change gets a new number, undo and
    /// redo return to the number the content had then. A result computed
    /// for a state (lint) is valid exactly while the state is the same.
    state: u64,
    next_state: u64,
    /// Typing may join the last undo step (until the cursor moves away).
    joinable: bool,
    last_change: Option<Change>,
}

/// The text `lines` as [`Program::replace_lines`] reads it back exactly: each
/// line ended by CR LF, because the reader drops one CR before each LF, so
/// a line that itself ends in CR keeps it.
fn encode(lines: &[String]) -> String {
    let mut out = String::with_capacity(lines.iter().map(|l| l.len() + 2).sum());
    for line in lines {
        out.push_str(line);
        out.push_str("\r\n");
    }
    out
}

fn char_count(text: &str) -> usize {
    text.chars().count()
}

/// The byte offset of character `col` in `text` (its end when past it).
pub fn byte_of(text: &str, col: usize) -> usize {
    text.char_indices().nth(col).map_or(text.len(), |(i, _)| i)
}

/// The character column of byte offset `byte` in `text`.
pub fn col_of(text: &str, byte: usize) -> usize {
    text.char_indices().take_while(|(i, _)| *i < byte).count()
}

impl Buffer {
    /// A buffer holding `text`; an empty text is one empty line (an editor
    /// always has a line to type on).
    pub fn new(language: Language, text: &str) -> Buffer {
        let text = if text.is_empty() { "\n" } else { text };
        Buffer {
            program: Arc::new(Program::parse(language, text)),
            cursor: Cursor::default(),
            goal: None,
            undo: Vec::new(),
            redo: Vec::new(),
            state: 0,
            next_state: 1,
            joinable: false,
            last_change: None,
        }
    }

    pub fn program(&self) -> &Program {
        &self.program
    }

    /// A snapshot for a reader on another thread.
    pub fn snapshot(&self) -> Arc<Program> {
        Arc::clone(&self.program)
    }

    pub fn language(&self) -> Language {
        self.program.language()
    }

    pub fn state(&self) -> u64 {
        self.state
    }

    pub fn cursor(&self) -> Cursor {
        self.cursor
    }

    pub fn line_count(&self) -> usize {
        self.program.lines().len().max(1)
    }

    pub fn line(&self, line: usize) -> &str {
        self.program.line(line).map_or("", |l| l.text())
    }

    fn line_len(&self, line: usize) -> usize {
        char_count(self.line(line))
    }

    /// The text as it is saved: every line ended by LF, except a line that
    /// itself ends in CR, which is ended by CR LF so that reading the file
    /// gives it back exactly (a reader drops one CR before each LF).
    pub fn text(&self) -> String {
        let lines = self.program.lines();
        let mut out = String::with_capacity(lines.iter().map(|l| l.text().len() + 2).sum());
        for line in lines {
            out.push_str(line.text());
            if line.text().ends_with('\r') {
                out.push('\r');
            }
            out.push('\n');
        }
        if lines.is_empty() {
            out.push('\n');
        }
        out
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    /// The change the last edit, undo or redo made, once.
    pub fn take_change(&mut self) -> Option<Change> {
        self.last_change.take()
    }

    // ---- cursor ----

    fn clamp(&self, c: Cursor) -> Cursor {
        let line = c.line.min(self.line_count() - 1);
        Cursor::new(line, c.col.min(self.line_len(line)))
    }

    /// Put the cursor at `c` (clamped to the text).
    pub fn move_to(&mut self, c: Cursor) {
        self.cursor = self.clamp(c);
        self.goal = None;
        self.joinable = false;
    }

    pub fn left(&mut self) {
        let c = self.cursor;
        if c.col > 0 {
            self.move_to(Cursor::new(c.line, c.col - 1));
        } else if c.line > 0 {
            self.move_to(Cursor::new(c.line - 1, self.line_len(c.line - 1)));
        }
    }

    pub fn right(&mut self) {
        let c = self.cursor;
        if c.col < self.line_len(c.line) {
            self.move_to(Cursor::new(c.line, c.col + 1));
        } else if c.line + 1 < self.line_count() {
            self.move_to(Cursor::new(c.line + 1, 0));
        }
    }

    /// Up (negative) or down by `lines`, keeping the column aimed at.
    pub fn vertical(&mut self, lines: isize) {
        let goal = self.goal.unwrap_or(self.cursor.col);
        let last = self.line_count() - 1;
        let line = self.cursor.line.saturating_add_signed(lines).min(last);
        self.cursor = Cursor::new(line, goal.min(self.line_len(line)));
        self.goal = Some(goal);
        self.joinable = false;
    }

    pub fn home(&mut self) {
        // First to the first non-blank character, then to column 0.
        let text = self.line(self.cursor.line);
        let indent = char_count(text) - char_count(text.trim_start());
        let col = if self.cursor.col == indent { 0 } else { indent };
        self.move_to(Cursor::new(self.cursor.line, col));
    }

    pub fn end(&mut self) {
        self.move_to(Cursor::new(self.cursor.line, usize::MAX));
    }

    pub fn top(&mut self) {
        self.move_to(Cursor::default());
    }

    pub fn bottom(&mut self) {
        self.move_to(Cursor::new(usize::MAX, usize::MAX));
    }

    /// To the start of the previous (`-1`) or next (`1`) word: letters,
    /// digits and signs belong together, `,` and blanks separate.
    pub fn word(&mut self, dir: isize) {
        let text: Vec<char> = self.line(self.cursor.line).chars().collect();
        let word = |i: usize| {
            text.get(i)
                .is_some_and(|c| c.is_alphanumeric() || *c == '-')
        };
        let mut col = self.cursor.col;
        if dir < 0 {
            if col == 0 {
                self.left();
                return;
            }
            col -= 1;
            while col > 0 && !word(col) {
                col -= 1;
            }
            while col > 0 && word(col - 1) {
                col -= 1;
            }
        } else {
            if col >= text.len() {
                self.right();
                return;
            }
            while col < text.len() && word(col) {
                col += 1;
            }
            while col < text.len() && !word(col) {
                col += 1;
            }
        }
        self.move_to(Cursor::new(self.cursor.line, col));
    }

    // ---- edits ----

    /// Replace lines `at..at + removed` by `inserted`, as one undo step.
    fn apply(
        &mut self,
        at: usize,
        removed: usize,
        inserted: Vec<String>,
        after: Cursor,
        kind: Kind,
    ) {
        let old: Vec<String> = (at..at + removed)
            .map(|l| self.line(l).to_string())
            .collect();
        let before = self.cursor;
        let state_before = self.state;
        self.state = self.next_state;
        self.next_state += 1;
        Arc::make_mut(&mut self.program).replace_lines(at..at + removed, &encode(&inserted));
        self.last_change = Some(Change {
            at,
            removed,
            inserted: inserted.len(),
        });
        let step = Step {
            at,
            removed: old,
            inserted,
            before,
            after,
            state_before,
            state_after: self.state,
            kind,
        };
        self.redo.clear();
        let join = self.joinable
            && kind != Kind::Other
            && self.undo.last().is_some_and(|last| {
                last.kind == kind
                    && last.at == at
                    && last.inserted.len() == 1
                    && step.removed.len() == 1
                    && last.after == before
            });
        match self.undo.last_mut() {
            Some(last) if join => {
                last.inserted = step.inserted;
                last.after = step.after;
                last.state_after = step.state_after;
            }
            _ => {
                self.undo.push(step);
                if self.undo.len() > UNDO_STEPS {
                    self.undo.remove(0);
                }
            }
        }
        self.cursor = self.clamp(after);
        self.goal = None;
        self.joinable = kind != Kind::Other;
    }

    /// Type `c` at the cursor (not a line end: see [`Buffer::newline`]).
    pub fn insert_char(&mut self, c: char) {
        if c == '\n' {
            self.newline();
            return;
        }
        let Cursor { line, col } = self.cursor;
        let mut text = self.line(line).to_string();
        text.insert(byte_of(&text, col), c);
        self.apply(
            line,
            1,
            vec![text],
            Cursor::new(line, col + 1),
            Kind::Typing,
        );
    }

    /// Insert `text` at the cursor, `\n` splitting lines, as one undo step;
    /// the cursor ends after it (a paste).
    pub fn insert_text(&mut self, text: &str) {
        if text.is_empty() {
            return;
        }
        let Cursor { line, col } = self.cursor;
        let current = self.line(line);
        let (head, tail) = current
            .split_at_checked(byte_of(current, col))
            .unwrap_or((current, ""));
        let (head, tail) = (head.to_string(), tail.to_string());
        let mut lines: Vec<String> = text.split('\n').map(str::to_string).collect();
        let last = lines.len() - 1;
        let end_col = char_count(&lines[last]) + if last == 0 { col } else { 0 };
        lines[0].insert_str(0, &head);
        lines[last].push_str(&tail);
        self.apply(
            line,
            1,
            lines,
            Cursor::new(line + last, end_col),
            Kind::Other,
        );
    }

    /// Split the line at the cursor.
    pub fn newline(&mut self) {
        let Cursor { line, col } = self.cursor;
        let text = self.line(line);
        let (head, tail) = text
            .split_at_checked(byte_of(text, col))
            .unwrap_or((text, ""));
        let (head, tail) = (head.to_string(), tail.to_string());
        self.apply(
            line,
            1,
            vec![head, tail],
            Cursor::new(line + 1, 0),
            Kind::Other,
        );
    }

    /// Backspace: the character before the cursor, or the line end before
    /// the line (joining it to the one above).
    pub fn delete_back(&mut self) {
        let Cursor { line, col } = self.cursor;
        if col > 0 {
            let mut text = self.line(line).to_string();
            let at = byte_of(&text, col - 1);
            text.remove(at);
            self.apply(
                line,
                1,
                vec![text],
                Cursor::new(line, col - 1),
                Kind::Deleting,
            );
        } else if line > 0 {
            let above = self.line(line - 1).to_string();
            let joined = format!("{above}{}", self.line(line));
            let col = char_count(&above);
            self.apply(
                line - 1,
                2,
                vec![joined],
                Cursor::new(line - 1, col),
                Kind::Other,
            );
        }
    }

    /// Delete: the character at the cursor, or the line end (joining the
    /// next line).
    pub fn delete_forward(&mut self) {
        let Cursor { line, col } = self.cursor;
        if col < self.line_len(line) {
            let mut text = self.line(line).to_string();
            text.remove(byte_of(&text, col));
            self.apply(line, 1, vec![text], self.cursor, Kind::Deleting);
        } else if line + 1 < self.line_count() {
            let joined = format!("{}{}", self.line(line), self.line(line + 1));
            self.apply(line, 2, vec![joined], self.cursor, Kind::Other);
        }
    }

    /// Delete the cursor's line (the last line is emptied instead).
    pub fn delete_line(&mut self) {
        let line = self.cursor.line;
        if self.line_count() == 1 {
            self.apply(0, 1, vec![String::new()], Cursor::default(), Kind::Other);
        } else {
            let after = Cursor::new(line.min(self.line_count() - 2), self.cursor.col);
            self.apply(line, 1, Vec::new(), after, Kind::Other);
        }
    }

    /// Insert whole lines before line `at` (`at` = the line count appends)
    /// and put the cursor at the end of the last of them, so that the next
    /// insertion after the cursor's line follows them.
    pub fn insert_lines(&mut self, at: usize, lines: Vec<String>) {
        let Some(last) = lines.last() else {
            return;
        };
        let end = Cursor::new(lines.len() - 1, char_count(last));
        // An editor's single empty line is where a first program starts.
        if self.line_count() == 1 && self.line(0).is_empty() {
            self.apply(0, 1, lines, end, Kind::Other);
            return;
        }
        let at = at.min(self.line_count());
        self.apply(
            at,
            0,
            lines,
            Cursor::new(at + end.line, end.col),
            Kind::Other,
        );
    }

    /// Replace bytes `cols` of line `line` by `replacement`, which may hold
    /// line ends (a lint fix that adds a line).
    pub fn replace_in_line(
        &mut self,
        line: usize,
        cols: std::ops::Range<usize>,
        replacement: &str,
    ) {
        if line >= self.line_count() {
            return;
        }
        let text = self.line(line);
        let start = cols.start.min(text.len());
        let end = cols.end.clamp(start, text.len());
        let (Some(head), Some(tail)) = (text.get(..start), text.get(end..)) else {
            return;
        };
        let joined = format!("{head}{replacement}{tail}");
        let lines: Vec<String> = joined.split('\n').map(str::to_string).collect();
        // The cursor goes to the end of what was put in.
        let last = lines.len() - 1;
        let end_col = if last == 0 {
            char_count(head) + char_count(replacement)
        } else {
            char_count(replacement.rsplit('\n').next().unwrap_or_default())
        };
        self.apply(
            line,
            1,
            lines,
            Cursor::new(line + last, end_col),
            Kind::Other,
        );
    }

    /// Replace the whole text (the formatter), as one undo step; the cursor
    /// stays on its line.
    pub fn replace_all(&mut self, text: &str) {
        let lines: Vec<String> = crate::program::source::lines(text)
            .map(str::to_string)
            .collect();
        let lines = if lines.is_empty() {
            vec![String::new()]
        } else {
            lines
        };
        let count = self.line_count();
        let after = Cursor::new(self.cursor.line, 0);
        self.apply(0, count, lines, after, Kind::Other);
    }

    fn replay(
        &mut self,
        at: usize,
        removed: usize,
        inserted: &[String],
        cursor: Cursor,
        state: u64,
    ) {
        Arc::make_mut(&mut self.program).replace_lines(at..at + removed, &encode(inserted));
        self.last_change = Some(Change {
            at,
            removed,
            inserted: inserted.len(),
        });
        self.state = state;
        self.cursor = self.clamp(cursor);
        self.goal = None;
        self.joinable = false;
    }

    /// Undo the last step; `false` when there is none.
    pub fn undo(&mut self) -> bool {
        let Some(step) = self.undo.pop() else {
            return false;
        };
        self.replay(
            step.at,
            step.inserted.len(),
            &step.removed,
            step.before,
            step.state_before,
        );
        self.redo.push(step);
        true
    }

    /// Redo the last undone step; `false` when there is none.
    pub fn redo(&mut self) -> bool {
        let Some(step) = self.redo.pop() else {
            return false;
        };
        self.replay(
            step.at,
            step.removed.len(),
            &step.inserted,
            step.after,
            step.state_after,
        );
        self.undo.push(step);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn lines(b: &Buffer) -> Vec<String> {
        (0..b.line_count()).map(|l| b.line(l).to_string()).collect()
    }

    fn typed(b: &mut Buffer, text: &str) {
        for c in text.chars() {
            b.insert_char(c);
        }
    }

    #[test]
    fn typing_splitting_and_joining_lines() {
        let mut b = Buffer::new(Language::Isel, "");
        assert_eq!(lines(&b), [""]);
        typed(&mut b, "77\n9");
        assert_eq!(lines(&b), ["77", "9"]);
        assert_eq!(b.program().command_count(), 2);
        b.move_to(Cursor::new(1, 0));
        b.delete_back();
        assert_eq!(lines(&b), ["779"]);
        assert_eq!(b.cursor(), Cursor::new(0, 2));
        b.newline();
        b.delete_forward();
        assert_eq!(lines(&b), ["77", ""]);
        b.left();
        b.delete_forward();
        assert_eq!(lines(&b), ["77"]);
    }

    #[test]
    fn a_run_of_typing_is_one_undo_step_and_undo_restores_the_state() {
        let mut b = Buffer::new(Language::Isel, "9\n");
        let s0 = b.state();
        typed(&mut b, "; note");
        assert_eq!(lines(&b), ["; note9"]);
        let s1 = b.state();
        b.move_to(Cursor::new(0, 0));
        typed(&mut b, "x");
        assert!(b.undo());
        assert_eq!(lines(&b), ["; note9"]);
        assert_eq!(b.state(), s1);
        assert!(b.undo());
        assert_eq!(lines(&b), ["9"]);
        assert_eq!(b.state(), s0, "the content is the original again");
        assert!(!b.undo());
        assert!(b.redo());
        assert_eq!(lines(&b), ["; note9"]);
        assert_eq!(b.state(), s1);
    }

    #[test]
    fn cursor_moves_by_characters_and_keeps_its_column() {
        let mut b = Buffer::new(Language::Isel, "; Größe\n7\n; längere Zeile\n");
        b.move_to(Cursor::new(0, 7));
        b.vertical(1);
        assert_eq!(b.cursor(), Cursor::new(1, 1));
        b.vertical(1);
        assert_eq!(
            b.cursor(),
            Cursor::new(2, 7),
            "the column aimed at comes back"
        );
        b.insert_char('ß');
        assert_eq!(b.line(2), "; längeßre Zeile");
        b.vertical(-10);
        assert_eq!(b.cursor().line, 0);
        b.end();
        b.right();
        assert_eq!(
            b.cursor(),
            Cursor::new(1, 0),
            "right at a line end goes to the next"
        );
        b.left();
        assert_eq!(b.cursor(), Cursor::new(0, 7));
    }

    #[test]
    fn fixes_may_add_lines() {
        let mut b = Buffer::new(Language::Isel, "77\n");
        b.replace_in_line(0, 2..2, "\n9");
        assert_eq!(lines(&b), ["77", "9"]);
        assert_eq!(b.cursor(), Cursor::new(1, 1));
        b.replace_in_line(0, 0..1, "m");
        assert_eq!(lines(&b), ["m7", "9"]);
        b.replace_in_line(7, 0..1, "x");
        assert_eq!(
            lines(&b),
            ["m7", "9"],
            "a line that is not there is left alone"
        );
    }

    #[test]
    fn lines_ending_in_cr_survive_edits() {
        let mut b = Buffer::new(Language::Isel, "; a\r\r\n9\n");
        assert_eq!(b.line(0), "; a\r");
        b.move_to(Cursor::new(1, 1));
        b.insert_char(' ');
        assert_eq!(b.line(0), "; a\r");
        b.move_to(Cursor::new(0, 0));
        b.insert_char('x');
        assert_eq!(b.line(0), "x; a\r");
    }

    #[test]
    fn teaching_into_an_empty_buffer_replaces_its_empty_line() {
        let mut b = Buffer::new(Language::Isel, "");
        b.insert_lines(1, vec!["77".into()]);
        assert_eq!(lines(&b), ["77"]);
        assert_eq!(b.cursor(), Cursor::new(0, 2));
        b.insert_lines(1, vec!["f-1".into(), "9".into()]);
        assert_eq!(lines(&b), ["77", "f-1", "9"]);
        assert_eq!(b.cursor(), Cursor::new(2, 1));
        b.insert_lines(0, vec!["; first".into()]);
        assert_eq!(lines(&b), ["; first", "77", "f-1", "9"]);
        assert_eq!(b.cursor(), Cursor::new(0, 7));
    }

    #[test]
    fn changes_say_where_lines_went() {
        let c = Change {
            at: 2,
            removed: 1,
            inserted: 3,
        };
        assert_eq!(c.map_line(1), Some(1));
        assert_eq!(c.map_line(2), None);
        assert_eq!(c.map_line(3), Some(5));
    }

    #[derive(Debug, Clone)]
    enum Op {
        Char(char),
        Newline,
        Back,
        Forward,
        DeleteLine,
        Move(usize, usize),
        Undo,
        Redo,
        Fix(usize, usize, usize, String),
    }

    fn op() -> impl Strategy<Value = Op> {
        prop_oneof![
            4 => prop::sample::select(vec!['7', ';', 'm', ',', '-', '9', 'ä', '\r', ' ']).prop_map(Op::Char),
            1 => Just(Op::Newline),
            2 => Just(Op::Back),
            1 => Just(Op::Forward),
            1 => Just(Op::DeleteLine),
            2 => (0..12usize, 0..12usize).prop_map(|(l, c)| Op::Move(l, c)),
            1 => Just(Op::Undo),
            1 => Just(Op::Redo),
            1 => (0..8usize, 0..6usize, 0..6usize, "[9a\n]{0,3}").prop_map(|(l, s, e, t)| Op::Fix(l, s, e, t)),
        ]
    }

    proptest! {
        /// Any sequence of edits keeps the program in step with its text
        /// (as if parsed afresh), and undoing everything gives the start back.
        #[test]
        fn edits_keep_the_parse_exact_and_undo_all_restores(
            start in "[79m;, \n]{0,20}",
            ops in prop::collection::vec(op(), 0..60),
        ) {
            let mut b = Buffer::new(Language::Isel, &start);
            let original = b.text();
            let original_state = b.state();
            for op in ops {
                match op {
                    Op::Char(c) => b.insert_char(c),
                    Op::Newline => b.newline(),
                    Op::Back => b.delete_back(),
                    Op::Forward => b.delete_forward(),
                    Op::DeleteLine => b.delete_line(),
                    Op::Move(l, c) => b.move_to(Cursor::new(l, c)),
                    Op::Undo => { b.undo(); }
                    Op::Redo => { b.redo(); }
                    Op::Fix(l, s, e, t) => {
                        // Byte columns on character boundaries, as lint gives them.
                        let text = b.line(l).to_string();
                        let s = byte_of(&text, s);
                        let e = byte_of(&text, e).max(s);
                        b.replace_in_line(l, s..e, &t);
                    }
                }
                let c = b.cursor();
                prop_assert!(c.line < b.line_count());
                prop_assert!(c.col <= b.line(c.line).chars().count());
                let fresh = Program::parse(Language::Isel, &b.text());
                prop_assert_eq!(fresh.items(), b.program().items());
                prop_assert_eq!(fresh.lines().len(), b.line_count());
            }
            while b.undo() {}
            prop_assert_eq!(b.text(), original);
            prop_assert_eq!(b.state(), original_state);
        }
    }
}
