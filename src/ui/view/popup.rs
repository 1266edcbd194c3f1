//! The popups: the help overlay (every key, from the keymap) and the
//! confirmation box for actions that move or power the machine.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Clear, Paragraph, Widget, Wrap};

use crate::ui::help::{HelpLine, help_lines};
use crate::ui::keymap::{Action, Keymap, Mode};
use crate::ui::model::{Confirmation, Model};
use crate::ui::palette::Palette;

use super::flow::fit;

/// A box of at most `width` x `height` in the middle of `area`.
pub fn centred(area: Rect, width: u16, height: u16) -> Rect {
    let w = width.min(area.width);
    let h = height.min(area.height);
    Rect::new(
        area.x + (area.width - w) / 2,
        area.y + (area.height - h) / 2,
        w,
        h,
    )
}

/// Clear `area` and draw a popup's frame with `title`; the area inside.
pub fn framed(model: &Model, title: &str, area: Rect, buf: &mut Buffer) -> Rect {
    frame_in(&model.palette, title, area, buf)
}

/// [`framed`] in the colours of `p` (for a component that has no model).
pub fn frame_in(p: &Palette, title: &str, area: Rect, buf: &mut Buffer) -> Rect {
    Clear.render(area, buf);
    let block = Block::new()
        .borders(Borders::ALL)
        .border_style(p.focus_border)
        .style(p.text)
        .title(Span::styled(format!(" {title} "), p.title));
    let inner = block.inner(area);
    block.render(area, buf);
    inner
}

pub struct HelpView<'a> {
    pub model: &'a Model,
    pub scroll: usize,
}

impl Widget for HelpView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.model;
        let p = &model.palette;
        let lines = help_lines(&model.keymap, &model.setup.macros);
        let key_w = lines
            .iter()
            .filter_map(|l| match l {
                HelpLine::Entry { keys, .. } => Some(keys.chars().count()),
                _ => None,
            })
            .max()
            .unwrap_or(0)
            .min(24);
        let box_area = centred(area, 78, area.height.saturating_sub(2).max(3));
        let close = model
            .keymap
            .key_for(Mode::Help, Action::Close)
            .map(|k| format!("Help: every key ({k} closes)"))
            .unwrap_or_else(|| "Help: every key".into());
        let inner = framed(model, &close, box_area, buf);
        let width = usize::from(inner.width);
        let rows = usize::from(inner.height);
        let scroll = self.scroll.min(lines.len().saturating_sub(rows));
        for (i, line) in lines.iter().skip(scroll).take(rows).enumerate() {
            let rendered = match line {
                HelpLine::Heading(text) => Line::from(Span::styled(fit(text, width), p.title)),
                HelpLine::Entry { keys, description } => Line::from(vec![
                    Span::styled(format!(" {:<key_w$} ", fit(keys, key_w)), p.key),
                    Span::styled(fit(description, width.saturating_sub(key_w + 2)), p.text),
                ]),
                HelpLine::Text(text) => Line::from(Span::styled(fit(text, width), p.dim)),
                HelpLine::Blank => Line::default(),
            };
            rendered.render(Rect::new(inner.x, inner.y + i as u16, inner.width, 1), buf);
        }
    }
}

pub struct ConfirmView<'a> {
    pub model: &'a Model,
    pub confirmation: &'a Confirmation,
}

impl Widget for ConfirmView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        QuestionView {
            palette: &self.model.palette,
            keymap: &self.model.keymap,
            confirmation: self.confirmation,
        }
        .render(area, buf);
    }
}

/// A yes/no question box: the confirmation's title and question, the keys
/// that answer it. [`ConfirmView`] draws with it, and so do the editor's
/// questions (which have no model, only the palette and keymap).
pub struct QuestionView<'a> {
    pub palette: &'a Palette,
    pub keymap: &'a Keymap,
    pub confirmation: &'a Confirmation,
}

impl Widget for QuestionView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let p = self.palette;
        let c = self.confirmation;
        let width = area.width.clamp(20, 60);
        let text_w = usize::from(width.saturating_sub(2)).max(1);
        // Each line of the question wraps on its own.
        let text_rows = (c
            .question
            .split('\n')
            .map(|l| super::flow::wrapped_rows(l, text_w))
            .sum::<usize>()
            + 1) as u16;
        // Borders, the question, a blank line, the answer keys.
        let box_area = centred(area, width, text_rows + 3);
        let inner = frame_in(p, &c.title, box_area, buf);
        let keys = |action| {
            self.keymap
                .keys_for(Mode::Confirm, action)
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("/")
        };
        let answer = Line::from(vec![
            Span::styled(keys(Action::Confirm), p.key),
            Span::styled(" yes   ", p.text),
            Span::styled(keys(Action::Cancel), p.key),
            Span::styled(" no", p.text),
        ]);
        let lines: Vec<Line> = c
            .question
            .split('\n')
            .map(|l| Line::from(Span::styled(l.to_string(), p.warning)))
            .collect();
        let question = Paragraph::new(lines).wrap(Wrap { trim: true });
        let q_area = Rect::new(
            inner.x,
            inner.y,
            inner.width,
            inner.height.saturating_sub(2),
        );
        question.render(q_area, buf);
        if inner.height > 0 {
            answer.render(Rect::new(inner.x, inner.bottom() - 1, inner.width, 1), buf);
        }
    }
}
