//! The console's command line: a one-line editor with a cursor and a
//! history browsed with Up/Down (the line being typed is kept while
//! browsing and comes back below the newest entry).

use std::ops::Range;

/// Entries kept in the history.
pub const HISTORY: usize = 100;
/// Longest line accepted; no command of any family comes near it.
pub const MAX_LEN: usize = 256;

/// A rejected line: the message and the characters it concerns.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineError {
    pub message: String,
    /// Character range in the line (not bytes), for underlining.
    pub span: Option<Range<usize>>,
}

#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LineEdit {
    text: String,
    /// Cursor as a character index, 0..=len.
    cursor: usize,
    history: Vec<String>,
    /// Index into `history` while browsing.
    browsing: Option<usize>,
    /// What was typed before browsing started.
    draft: String,
    pub error: Option<LineError>,
}

impl LineEdit {
    pub fn text(&self) -> &str {
        &self.text
    }

    pub fn cursor(&self) -> usize {
        self.cursor
    }

    pub fn history(&self) -> &[String] {
        &self.history
    }

    fn len(&self) -> usize {
        self.text.chars().count()
    }

    fn byte_at(&self, char_index: usize) -> usize {
        self.text
            .char_indices()
            .nth(char_index)
            .map_or(self.text.len(), |(i, _)| i)
    }

    fn edited(&mut self) {
        self.browsing = None;
        self.error = None;
    }

    pub fn insert(&mut self, c: char) {
        if self.len() >= MAX_LEN {
            return;
        }
        let at = self.byte_at(self.cursor);
        self.text.insert(at, c);
        self.cursor += 1;
        self.edited();
    }

    pub fn delete_back(&mut self) {
        if self.cursor == 0 {
            return;
        }
        self.cursor -= 1;
        let at = self.byte_at(self.cursor);
        self.text.remove(at);
        self.edited();
    }

    pub fn delete_forward(&mut self) {
        if self.cursor >= self.len() {
            return;
        }
        let at = self.byte_at(self.cursor);
        self.text.remove(at);
        self.edited();
    }

    pub fn left(&mut self) {
        self.cursor = self.cursor.saturating_sub(1);
    }

    pub fn right(&mut self) {
        self.cursor = (self.cursor + 1).min(self.len());
    }

    pub fn home(&mut self) {
        self.cursor = 0;
    }

    pub fn end(&mut self) {
        self.cursor = self.len();
    }

    pub fn clear(&mut self) {
        self.set_text(String::new());
        self.edited();
    }

    fn set_text(&mut self, text: String) {
        self.text = text;
        self.cursor = self.len();
    }

    /// Older entry (Up).
    pub fn history_prev(&mut self) {
        let next = match self.browsing {
            None if self.history.is_empty() => return,
            None => {
                self.draft = self.text.clone();
                self.history.len() - 1
            }
            Some(0) => 0,
            Some(i) => i - 1,
        };
        self.browsing = Some(next);
        if let Some(entry) = self.history.get(next).cloned() {
            self.set_text(entry);
        }
        self.error = None;
    }

    /// Newer entry (Down); past the newest, the draft comes back.
    pub fn history_next(&mut self) {
        let Some(i) = self.browsing else { return };
        if i + 1 < self.history.len() {
            self.browsing = Some(i + 1);
            if let Some(entry) = self.history.get(i + 1).cloned() {
                self.set_text(entry);
            }
        } else {
            self.browsing = None;
            let draft = std::mem::take(&mut self.draft);
            self.set_text(draft);
        }
        self.error = None;
    }

    /// Pasted text at the cursor, if it is one line that fits (see
    /// [`one_line`]); nothing changes otherwise. Never sends anything: the
    /// operator checks the line and presses Enter.
    pub fn paste(&mut self, text: &str) -> Result<(), PasteRefused> {
        let line = one_line(text)?;
        let room = MAX_LEN - self.len().min(MAX_LEN);
        let chars = line.chars().count();
        if chars > room {
            return Err(PasteRefused::TooLong { chars, room });
        }
        let at = self.byte_at(self.cursor);
        self.text.insert_str(at, &line);
        self.cursor += chars;
        self.edited();
        Ok(())
    }

    /// The line was sent: remember it (not twice in a row) and start afresh.
    pub fn accept(&mut self) -> String {
        let line = std::mem::take(&mut self.text);
        if self.history.last() != Some(&line) {
            self.history.push(line.clone());
            if self.history.len() > HISTORY {
                self.history.remove(0);
            }
        }
        self.cursor = 0;
        self.browsing = None;
        self.draft.clear();
        self.error = None;
        line
    }
}

/// Why pasted text did not go into a one-line field.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PasteRefused {
    #[error(
        "paste refused: this line takes one line, the paste has {lines} \
         (programs go into the editor)"
    )]
    Lines { lines: usize },
    #[error("paste refused: {chars} characters, the line has room for {room}")]
    TooLong { chars: usize, room: usize },
}

/// Pasted text as one line for a one-line field (the command line, the
/// go-to prompt, an editor form): line ends at its end are dropped (a line
/// copied with its newline), a tab becomes a blank, other control
/// characters go. Text of more than one line is refused as a whole rather
/// than cut at the first line end: what the operator sees in the field is
/// then all of what was pasted, and nothing is left out unnoticed.
pub fn one_line(text: &str) -> Result<String, PasteRefused> {
    let body = text.trim_end_matches(['\r', '\n']);
    let lines = body.split(['\r', '\n']).filter(|l| !l.is_empty()).count();
    if lines > 1 {
        return Err(PasteRefused::Lines { lines });
    }
    Ok(body
        .chars()
        .filter_map(|c| match c {
            '\t' => Some(' '),
            c if c.is_control() => None,
            c => Some(c),
        })
        .collect())
}

/// A byte range of `text` as a character range (for a line that may hold
/// non-ASCII characters); clamped to the text.
pub fn char_span(text: &str, bytes: Range<usize>) -> Range<usize> {
    let to_char = |b: usize| text.char_indices().take_while(|(i, _)| *i < b).count();
    let start = to_char(bytes.start);
    let end = to_char(bytes.end).max(start);
    start..end
}

/// The editing keys of a one-line field (the go-to prompt, the keypad's
/// typed values); other actions do nothing here.
pub fn edit_line(line: &mut LineEdit, action: super::keymap::Action) {
    use super::keymap::Action;
    match action {
        Action::CursorLeft => line.left(),
        Action::CursorRight => line.right(),
        Action::CursorHome => line.home(),
        Action::CursorEnd => line.end(),
        Action::DeleteBack => line.delete_back(),
        Action::DeleteForward => line.delete_forward(),
        Action::ClearLine => line.clear(),
        Action::TypeBlank => line.insert(' '),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn typed(text: &str) -> LineEdit {
        let mut e = LineEdit::default();
        text.chars().for_each(|c| e.insert(c));
        e
    }

    #[test]
    fn editing_moves_by_characters_not_bytes() {
        let mut e = typed("@0ü");
        e.left();
        e.insert('x');
        assert_eq!(e.text(), "@0xü");
        e.delete_forward();
        e.delete_back();
        assert_eq!(e.text(), "@0");
        e.home();
        e.delete_back();
        e.delete_forward();
        assert_eq!((e.text(), e.cursor()), ("0", 0));
        e.end();
        e.right();
        assert_eq!(e.cursor(), 1);
    }

    #[test]
    fn history_browses_back_and_returns_to_the_draft() {
        let mut e = LineEdit::default();
        for line in ["@0P", "@0R7", "@0R7"] {
            line.chars().for_each(|c| e.insert(c));
            e.accept();
        }
        assert_eq!(e.history(), ["@0P", "@0R7"], "no duplicate in a row");
        "@0b".chars().for_each(|c| e.insert(c));
        e.history_prev();
        assert_eq!(e.text(), "@0R7");
        e.history_prev();
        e.history_prev();
        assert_eq!(e.text(), "@0P", "stops at the oldest");
        e.history_next();
        assert_eq!(e.text(), "@0R7");
        e.history_next();
        assert_eq!(e.text(), "@0b", "the draft is back");
        e.history_next();
        assert_eq!(e.text(), "@0b");
    }

    #[test]
    fn history_and_line_are_bounded() {
        let mut e = LineEdit::default();
        for i in 0..(HISTORY + 5) {
            i.to_string().chars().for_each(|c| e.insert(c));
            e.accept();
        }
        assert_eq!(e.history().len(), HISTORY);
        assert_eq!(e.history().first().map(String::as_str), Some("5"));
        for _ in 0..(MAX_LEN + 5) {
            e.insert('a');
        }
        assert_eq!(e.text().len(), MAX_LEN);
    }

    #[test]
    fn a_pasted_line_goes_in_at_the_cursor_without_its_line_end() {
        let mut e = typed("@0");
        e.paste("M5000,900\r\n").expect("one line");
        assert_eq!((e.text(), e.cursor()), ("@0M5000,900", 11));
        e.home();
        e.paste("\tx\u{1b}").expect("one line");
        assert_eq!(e.text(), " x@0M5000,900", "tab a blank, ESC dropped");
        let before = e.clone();
        assert_eq!(
            e.paste("@0A100,900\n@0A-100,900\n"),
            Err(PasteRefused::Lines { lines: 2 })
        );
        assert_eq!(
            e.paste("a\r\rb"),
            Err(PasteRefused::Lines { lines: 2 }),
            "CR alone ends a line too"
        );
        assert_eq!(e, before, "a refused paste changes nothing");
        let long = "a".repeat(MAX_LEN);
        assert!(matches!(e.paste(&long), Err(PasteRefused::TooLong { .. })));
        assert_eq!(e, before);
        assert!(
            PasteRefused::Lines { lines: 2 }
                .to_string()
                .contains("takes one line")
        );
    }

    #[test]
    fn byte_spans_become_character_spans() {
        assert_eq!(char_span("ab", 1..2), 1..2);
        assert_eq!(char_span("üa", 2..3), 1..2);
        assert_eq!(char_span("ab", 5..9), 2..2);
        #[allow(clippy::reversed_empty_ranges)]
        let reversed = 2..1;
        assert_eq!(char_span("ab", reversed), 2..2);
    }
}
