//! The message history (`M`): every message of the session whole, wrapped
//! to the box, newest at the bottom, with its age and level; scrolled back
//! line by line or a page at a time. On a large terminal the latest of them
//! also have a panel of their own ([`LatestView`]).

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::ui::messages::wrap;
use crate::ui::model::Model;

use super::frame;
use super::popup::{centred, framed};
use super::status::{note_marker, note_style};

pub struct MessagesView<'a> {
    pub model: &'a Model,
    pub back: usize,
}

/// The box on a screen of `area`.
fn box_area(area: Rect) -> Rect {
    centred(area, 100, area.height.saturating_sub(2).max(3))
}

/// Every line of the history at `width`: (message index, text), oldest
/// first; a message's first line carries its age and marker.
fn lines(model: &Model, width: usize) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, m) in model.history.iter().enumerate() {
        let age = model.now.saturating_duration_since(m.at).as_secs();
        let head = format!("{:<2} {age:>4}s ", note_marker(m.level));
        let indent = head.chars().count();
        for (n, line) in wrap(&m.text, width.saturating_sub(indent))
            .into_iter()
            .enumerate()
        {
            let lead = if n == 0 {
                head.clone()
            } else {
                " ".repeat(indent)
            };
            out.push((i, format!("{lead}{line}")));
        }
    }
    out
}

/// The most the history can be scrolled back on the model's screen.
pub fn max_back(model: &Model) -> usize {
    let (w, h) = model.size;
    let inner = box_area(Rect::new(0, 0, w, h));
    let rows = usize::from(inner.height.saturating_sub(2));
    lines(model, usize::from(inner.width.saturating_sub(2)))
        .len()
        .saturating_sub(rows)
}

impl Widget for MessagesView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.model;
        let p = &model.palette;
        let outer = box_area(area);
        let all = {
            let width = usize::from(outer.width.saturating_sub(2));
            lines(model, width)
        };
        let rows = usize::from(outer.height.saturating_sub(2));
        let back = self.back.min(all.len().saturating_sub(rows));
        let end = all.len() - back;
        let start = end.saturating_sub(rows);
        let title = if back > 0 {
            format!(
                "Messages: {} of {}, {back} lines back (End: newest)",
                model.history.len(),
                model.history.len() + model.history.dropped()
            )
        } else {
            format!("Messages: {} (Up/PgUp: older)", model.history.len())
        };
        let inner = framed(model, &title, outer, buf);
        if all.is_empty() {
            Line::from(Span::styled("no messages yet", p.dim))
                .render(Rect::new(inner.x, inner.y, inner.width, 1), buf);
            return;
        }
        draw(model, all.get(start..end).unwrap_or_default(), inner, buf);
    }
}

/// History lines (of [`lines`]) into `inner`, one a row from the top, each
/// in its message's level style.
fn draw(model: &Model, rows: &[(usize, String)], inner: Rect, buf: &mut Buffer) {
    let p = &model.palette;
    let history: Vec<_> = model.history.iter().collect();
    for (row, (i, text)) in rows.iter().enumerate() {
        let style = history.get(*i).map_or(p.text, |m| note_style(p, m.level));
        let y = inner.y + row as u16;
        if y >= inner.bottom() {
            break;
        }
        Line::from(Span::styled(text.clone(), style))
            .render(Rect::new(inner.x, y, inner.width, 1), buf);
    }
}

/// The latest messages in a panel of the machine screen (large terminals,
/// `view::layout`): as many as fit, wrapped, newest at the bottom, each
/// with its marker and age; `M` shows them all.
pub struct LatestView<'a>(pub &'a Model);

impl Widget for LatestView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let inner = frame::panel(
            "Messages",
            vec![Span::styled("(M: all) ", p.dim)],
            false,
            p,
            area,
            buf,
        );
        let all = lines(model, usize::from(inner.width));
        if all.is_empty() {
            Line::from(Span::styled("no messages yet", p.dim)).render(
                Rect::new(inner.x, inner.y, inner.width, 1.min(inner.height)),
                buf,
            );
            return;
        }
        let start = all.len().saturating_sub(usize::from(inner.height));
        draw(model, all.get(start..).unwrap_or_default(), inner, buf);
    }
}
