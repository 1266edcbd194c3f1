//! The editor's popups drawn: forms (fields, what is wrong, what it will
//! do), the unsaved-changes question, yes/no questions (drawn like the
//! machine screen's confirmation).

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Widget, Wrap};

use crate::ui::editor::dialog::{Dialog, Form};
use crate::ui::editor::{Context, Editor};
use crate::ui::keymap::{Action, Mode};
use crate::ui::model::Confirmation;
use crate::ui::view::flow::fit;
use crate::ui::view::popup::{QuestionView, centred, frame_in};

pub struct DialogView<'a> {
    pub editor: &'a Editor,
    pub context: &'a Context<'a>,
    pub dialog: &'a Dialog,
}

fn keys(ctx: &Context, mode: Mode, action: Action) -> String {
    ctx.keymap
        .keys_for(mode, action)
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("/")
}

impl Widget for DialogView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let ctx = self.context;
        match self.dialog {
            Dialog::Ask(q) => QuestionView {
                palette: ctx.palette,
                keymap: ctx.keymap,
                confirmation: &Confirmation {
                    title: q.title.clone(),
                    question: q.text.clone(),
                    effects: Vec::new(),
                    then: None,
                },
            }
            .render(area, buf),
            Dialog::Unsaved(_) => unsaved(self.editor, ctx, area, buf),
            Dialog::Form(form) => form_view(ctx, form, area, buf),
        }
    }
}

fn unsaved(editor: &Editor, ctx: &Context, area: Rect, buf: &mut Buffer) {
    let p = ctx.palette;
    let width = area.width.clamp(20, 60);
    let box_area = centred(area, width, 7);
    let inner = frame_in(p, "Unsaved changes", box_area, buf);
    let text = format!(
        "{} has changes that are not saved. Save them first?",
        editor.name()
    );
    Paragraph::new(Span::styled(text, p.warning))
        .wrap(Wrap { trim: true })
        .render(
            Rect::new(
                inner.x,
                inner.y,
                inner.width,
                inner.height.saturating_sub(2),
            ),
            buf,
        );
    if inner.height > 0 {
        Line::from(vec![
            Span::styled(keys(ctx, Mode::Unsaved, Action::Save), p.key),
            Span::styled(" save  ", p.text),
            Span::styled(keys(ctx, Mode::Unsaved, Action::Discard), p.key),
            Span::styled(" discard  ", p.text),
            Span::styled(keys(ctx, Mode::Unsaved, Action::Cancel), p.key),
            Span::styled(" back", p.text),
        ])
        .render(Rect::new(inner.x, inner.bottom() - 1, inner.width, 1), buf);
    }
}

fn form_view(ctx: &Context, form: &Form, area: Rect, buf: &mut Buffer) {
    let p = ctx.palette;
    let width = area.width.clamp(24, 72);
    let inner_w = usize::from(width.saturating_sub(2));
    let label_w = form
        .fields
        .iter()
        .map(|f| f.label.chars().count())
        .max()
        .unwrap_or(0)
        .min(inner_w / 2);
    let extra = u16::from(form.error.is_some()) + u16::from(form.note.is_some());
    let height = form.fields.len() as u16 + extra + 4;
    let box_area = centred(area, width, height);
    let inner = frame_in(p, form.kind.title(), box_area, buf);
    let mut y = inner.y;
    for (i, field) in form.fields.iter().enumerate() {
        if y >= inner.bottom() {
            return;
        }
        let focused = i == form.focus;
        let room = inner_w.saturating_sub(label_w + 2).max(1);
        let chars: Vec<char> = field.edit.text().chars().collect();
        let cursor = field.edit.cursor();
        let start = if focused {
            cursor.saturating_sub(room.saturating_sub(1))
        } else {
            0
        };
        let mut spans = vec![Span::styled(
            format!("{:>label_w$}: ", fit(&field.label, label_w)),
            if focused { p.title } else { p.dim },
        )];
        for (k, c) in chars.iter().enumerate().skip(start).take(room) {
            let style = if focused && k == cursor {
                p.text.patch(p.selected)
            } else {
                p.text
            };
            spans.push(Span::styled(c.to_string(), style));
        }
        if focused && cursor >= chars.len() {
            spans.push(Span::styled(" ", p.selected));
        }
        Line::from(spans).render(Rect::new(inner.x, y, inner.width, 1), buf);
        y += 1;
    }
    y += 1;
    if let Some(error) = &form.error
        && y < inner.bottom()
    {
        Line::from(Span::styled(fit(&format!("! {error}"), inner_w), p.danger))
            .render(Rect::new(inner.x, y, inner.width, 1), buf);
        y += 1;
    }
    if let Some(note) = &form.note
        && y < inner.bottom()
    {
        Line::from(Span::styled(fit(note, inner_w), p.ok))
            .render(Rect::new(inner.x, y, inner.width, 1), buf);
    }
    if inner.height > 0 {
        Line::from(vec![
            Span::styled(keys(ctx, Mode::Form, Action::Submit), p.key),
            Span::styled(" ok  ", p.text),
            Span::styled(keys(ctx, Mode::Form, Action::NextField), p.key),
            Span::styled(" next field  ", p.text),
            Span::styled(keys(ctx, Mode::Form, Action::Cancel), p.key),
            Span::styled(" cancel", p.text),
        ])
        .render(Rect::new(inner.x, inner.bottom() - 1, inner.width, 1), buf);
    }
}
