//! The traffic console: the bytes sent and received, readable, newest at
//! the bottom, jogterm's own notes between them, and the command line with
//! the reason a typed command was refused, the offending characters marked.

use ratatui::buffer::Buffer;
use ratatui::layout::{Position, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::ui::keymap::{Action, Mode};
use crate::ui::model::{Model, PanelId};
use crate::ui::traffic_log::{ConsoleLine, LineKind};

use super::flow::fit;
use super::frame;
use super::status::{note_marker, note_style};

pub struct ConsoleView<'a>(pub &'a Model);

fn prefix_and_style(model: &Model, line: &ConsoleLine) -> (String, Style) {
    let p = &model.palette;
    match line.kind {
        LineKind::Sent => (">> ".into(), p.sent),
        LineKind::Received => ("<< ".into(), p.received),
        LineKind::Reply => ("=  ".into(), p.text),
        LineKind::Note(level) => (format!("{:<3}", note_marker(level)), note_style(p, level)),
    }
}

/// Split `text` into pieces of at most `width` characters: bytes (traffic)
/// anywhere, words (notes) at blanks where a line allows.
fn wrap(text: &str, width: usize, at_words: bool) -> Vec<String> {
    let width = width.max(1);
    let mut out: Vec<String> = Vec::new();
    let mut current = String::new();
    let mut used = 0;
    let words: Vec<&str> = if at_words {
        text.split_inclusive(' ').collect()
    } else {
        vec![text]
    };
    for word in words {
        // A blank after the word may hang over the edge.
        let core = word.trim_end_matches(' ').chars().count();
        if used > 0 && used + core > width && core <= width {
            out.push(std::mem::take(&mut current));
            used = 0;
        }
        for c in word.chars() {
            if used == width {
                if c == ' ' {
                    continue;
                }
                out.push(std::mem::take(&mut current));
                used = 0;
            }
            current.push(c);
            used += 1;
        }
    }
    if !current.is_empty() || out.is_empty() {
        out.push(current);
    }
    out
}

impl Widget for ConsoleView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let focused = model.focus == PanelId::Console && model.popup.is_none();
        let log = &model.console.traffic;
        let toggle = model
            .keymap
            .key_for(Mode::Main, Action::TogglePolls)
            .map(|k| format!(" ({k})"))
            .unwrap_or_default();
        let polls = if log.show_polls {
            format!("polls shown{toggle} ")
        } else {
            format!("polls hidden: {}{toggle} ", log.poll_count)
        };
        let mut extra = Vec::new();
        if focused {
            // Typing goes to the command line now, not to the keypad.
            let leave = model
                .keymap
                .key_for(Mode::Main, Action::FocusNext)
                .map(|k| format!(", {k} leaves"))
                .unwrap_or_default();
            extra.push(Span::styled(format!(" TYPING{leave} "), p.selected));
        }
        extra.push(Span::styled(polls, p.dim));
        let inner = frame::panel("Traffic", extra, focused, p, area, buf);
        if inner.height == 0 || inner.width < 4 {
            return;
        }
        let width = usize::from(inner.width);
        // The reason a command was refused, on up to two lines above it.
        let error_lines: Vec<String> = model
            .console
            .command
            .error
            .as_ref()
            .map(|e| {
                let mut lines = wrap(&e.message, width.saturating_sub(2), true);
                lines.truncate(2);
                lines
            })
            .unwrap_or_default();
        let error_rows = (error_lines.len() as u16).min(inner.height.saturating_sub(1));
        let reserved = 1 + error_rows;
        let rows = usize::from(inner.height.saturating_sub(reserved));
        // Wrap the newest lines until the rows are full.
        let mut shown: Vec<Line> = Vec::new();
        for line in log.tail(rows).into_iter().rev() {
            let (prefix, style) = prefix_and_style(model, line);
            let at_words = matches!(line.kind, LineKind::Note(_) | LineKind::Reply);
            let pieces = wrap(&line.text, width.saturating_sub(3), at_words);
            let mut wrapped: Vec<Line> = pieces
                .into_iter()
                .enumerate()
                .map(|(i, piece)| {
                    let lead = if i == 0 { prefix.clone() } else { "   ".into() };
                    Line::from(vec![Span::styled(lead, style), Span::styled(piece, style)])
                })
                .collect();
            while let Some(l) = wrapped.pop() {
                shown.push(l);
            }
            if shown.len() >= rows {
                break;
            }
        }
        shown.truncate(rows);
        shown.reverse();
        let top = inner.y + (rows - shown.len()) as u16;
        for (i, line) in shown.into_iter().enumerate() {
            line.render(Rect::new(inner.x, top + i as u16, inner.width, 1), buf);
        }
        let input_y = inner.bottom() - 1;
        for (i, text) in error_lines.iter().take(usize::from(error_rows)).enumerate() {
            let lead = if i == 0 { "^ " } else { "  " };
            let y = input_y - error_rows + i as u16;
            Line::from(Span::styled(fit(&format!("{lead}{text}"), width), p.danger))
                .render(Rect::new(inner.x, y, inner.width, 1), buf);
        }
        input_line(model, focused, width).render(Rect::new(inner.x, input_y, inner.width, 1), buf);
    }
}

fn input_line(model: &Model, focused: bool, width: usize) -> Line<'static> {
    let p = &model.palette;
    let edit = &model.console.command;
    if !focused && edit.text().is_empty() {
        let hint = model
            .keymap
            .key_for(Mode::Main, Action::FocusConsole)
            .map(|k| format!("{k} types a raw command"))
            .unwrap_or_else(|| "focus the console to type a raw command".into());
        return Line::from(vec![
            Span::styled("> ", p.dim),
            Span::styled(fit(&hint, width.saturating_sub(2)), p.dim),
        ]);
    }
    let chars: Vec<char> = edit.text().chars().collect();
    let start = scrolled(edit.cursor(), width);
    let room = width.saturating_sub(3).max(1);
    let span = edit.error.as_ref().and_then(|e| e.span.clone());
    // The prompt reversed while typing: the line has the keys now.
    let prompt = if focused { p.selected } else { p.key };
    let mut spans = vec![Span::styled("> ", prompt)];
    for (i, c) in chars.iter().enumerate().skip(start).take(room) {
        let mut style = p.text;
        if span.as_ref().is_some_and(|s| s.contains(&i)) {
            style = style.patch(p.danger);
        }
        if focused && i == edit.cursor() {
            style = style.patch(p.selected);
        }
        spans.push(Span::styled(c.to_string(), style));
    }
    if focused && edit.cursor() >= chars.len() {
        spans.push(Span::styled(" ", p.selected));
    }
    Line::from(spans)
}

/// The first character shown of a line `width` columns wide (the prompt
/// and a cell for the cursor at the end take three): scrolled so the
/// cursor stays visible.
fn scrolled(cursor: usize, width: usize) -> usize {
    let room = width.saturating_sub(3).max(1);
    cursor.saturating_sub(room.saturating_sub(1))
}

/// Where the terminal's cursor goes while the command line has the focus
/// (the console panel drawn in `area`): at the insertion point, so typing
/// is seen where it lands, in every theme.
pub fn cursor(model: &Model, area: Rect) -> Option<Position> {
    let focused = model.focus == PanelId::Console && model.popup.is_none();
    // The title rule takes the panel's first row.
    if !focused || area.height < 2 || area.width < 4 {
        return None;
    }
    let width = usize::from(area.width);
    let cursor = model.console.command.cursor();
    let column = 2 + cursor - scrolled(cursor, width);
    let x = area.x + u16::try_from(column).ok()?.min(area.width - 1);
    Some(Position::new(x, area.bottom() - 1))
}

#[cfg(test)]
mod tests {
    use super::wrap;

    #[test]
    fn bytes_wrap_anywhere_and_words_at_blanks() {
        assert_eq!(wrap("abcdefg", 3, false), ["abc", "def", "g"]);
        assert_eq!(wrap("ab cd efgh", 5, true), ["ab cd", "efgh"]);
        assert_eq!(wrap("release the stop", 8, true), ["release ", "the stop"]);
        assert_eq!(wrap("abcdefghij", 4, true), ["abcd", "efgh", "ij"]);
        assert_eq!(wrap("", 4, true), [""]);
    }
}
