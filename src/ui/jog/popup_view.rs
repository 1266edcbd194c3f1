//! The keypad's popups drawn: the work offsets (`O`: each system's zero in
//! machine units, the active one marked, the isel zero stored programs
//! count from, why a file was refused), the work position set here (`s`)
//! and the typed step and speed (`J`).

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Paragraph, Widget, Wrap};

use crate::offsets::System;
use crate::proto::Protocol;
use crate::ui::keymap::{Action, Mode};
use crate::ui::line_edit::LineEdit;
use crate::ui::model::Model;
use crate::ui::position::format_units;
use crate::ui::view::flow::fit;
use crate::ui::view::popup::{centred, framed};

use super::offsets::{OffsetsChoice, programs_differ};
use super::popups::JogPopup;
use super::values::ValuesForm;

pub struct JogPopupView<'a> {
    pub model: &'a Model,
    pub popup: &'a JogPopup,
}

impl Widget for JogPopupView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        match self.popup {
            JogPopup::Offsets(choice) => offsets(self.model, choice, area, buf),
            JogPopup::SetPosition(line) => set_position(self.model, line, area, buf),
            JogPopup::Values(form) => values(self.model, form, area, buf),
        }
    }
}

/// `Enter ok  Esc cancel`, from the keymap in use.
fn hints(model: &Model, mode: Mode, items: &[(Action, &str)]) -> Line<'static> {
    let p = &model.palette;
    let mut spans = Vec::new();
    for (action, label) in items {
        if let Some(k) = model.keymap.key_for(mode, *action) {
            spans.push(Span::styled(k.to_string(), p.key));
            spans.push(Span::styled(format!(" {label}   "), p.text));
        }
    }
    Line::from(spans)
}

/// `> text▮` (the cursor reversed while the line has the input).
pub fn typed_line(
    model: &Model,
    label: &str,
    line: &LineEdit,
    active: bool,
    w: usize,
) -> Line<'static> {
    let p = &model.palette;
    let label_w = label.chars().count();
    let mut spans = vec![
        Span::styled(label.to_string(), p.key),
        Span::styled(
            fit(line.text(), w.saturating_sub(label_w + 1)),
            if active { p.text } else { p.dim },
        ),
    ];
    if active {
        spans.push(Span::styled(" ", p.selected));
    }
    Line::from(spans)
}

/// The most rows a popup gives a refusal; a longer one ends in `…`.
const ERROR_ROWS: usize = 3;

/// `message` broken at blanks into at most [`ERROR_ROWS`] rows of at most
/// `w` characters (a longer one ends in `…`).
fn wrap(message: &str, w: usize) -> Vec<String> {
    let w = w.max(1);
    let mut rows: Vec<String> = Vec::new();
    let mut current = String::new();
    for word in message.split(' ') {
        let len = current.chars().count();
        if len > 0 && len + 1 + word.chars().count() > w {
            rows.push(std::mem::take(&mut current));
        }
        if !current.is_empty() {
            current.push(' ');
        }
        current.push_str(word);
    }
    rows.push(current);
    let more = rows.len() > ERROR_ROWS;
    rows.truncate(ERROR_ROWS);
    if more && let Some(last) = rows.last_mut() {
        last.push('…');
    }
    rows
}

/// A refusal in the danger style, wrapped: it names its limit, which must
/// not be cut off.
pub fn error_rows(model: &Model, message: &str, w: usize) -> Vec<Line<'static>> {
    wrap(message, w)
        .into_iter()
        .map(|r| Line::from(Span::styled(fit(&r, w), model.palette.danger)))
        .collect()
}

/// The rows a popup of inner width `w` needs for its line's refusal.
pub fn error_height(message: Option<&str>, w: usize) -> u16 {
    message.map_or(0, |m| wrap(m, w).len() as u16)
}

fn draw_rows(rows: Vec<Line<'static>>, inner: Rect, buf: &mut Buffer) {
    for (i, row) in rows.into_iter().enumerate() {
        let y = inner.y + i as u16;
        if y < inner.bottom() {
            row.render(Rect::new(inner.x, y, inner.width, 1), buf);
        }
    }
}

fn offsets(model: &Model, choice: &OffsetsChoice, area: Rect, buf: &mut Buffer) {
    let p = &model.palette;
    let table = &model.keypad.offsets.table;
    let ascii = p.symbols.lit.is_ascii();
    let mark = if ascii { "*" } else { "●" };
    let width = area.width.clamp(24, 66);
    let inner_w = usize::from(width.saturating_sub(2));
    let note = model.keypad.offsets.note.clone().unwrap_or_default();
    let note_rows = if note.is_empty() {
        0
    } else {
        note.chars().count().div_ceil(inner_w.max(1)) as u16
    };
    let isel = model.setup.protocol == Protocol::Isel;
    let height = 2 + 1 + System::COUNT as u16 + u16::from(isel) + note_rows + 1;
    let box_area = centred(area, width, height);
    let inner = framed(
        model,
        "Work offsets: zeros in machine coordinates",
        box_area,
        buf,
    );
    let col = model
        .setup
        .axes
        .iter()
        .map(|(_, a)| {
            let span = a.max.abs().max(a.min.abs()).max(1.0);
            (span.log10().floor() as usize) + 3 + super::super::position::decimals(a)
        })
        .max()
        .unwrap_or(8)
        .max(6);
    let mut rows = Vec::new();
    let mut header = String::from("        ");
    for (axis, profile) in &model.setup.axes {
        header += &format!("{:>col$}", format!("{axis} {}", profile.unit.symbol()));
    }
    rows.push(Line::from(Span::styled(fit(&header, inner_w), p.dim)));
    for system in System::ALL {
        let active = system == table.active();
        let mut text = format!(
            "{} {} {} ",
            system.index() + 1,
            system.name(),
            if active { mark } else { " " }
        );
        for (axis, profile) in &model.setup.axes {
            text += &format!("{:>col$}", format_units(profile, table.zero(system, *axis)));
        }
        let mut style: Style = if active { p.title } else { p.text };
        if system == choice.selected {
            style = style.patch(p.selected);
        }
        rows.push(Line::from(Span::styled(fit(&text, inner_w), style)));
    }
    if isel {
        let zeros: Vec<String> = model
            .setup
            .axes
            .iter()
            .map(|(axis, profile)| match model.machine.work_zero.get(*axis) {
                Some(v) => format!("{axis} {}", format_units(profile, v)),
                None => format!("{axis} ?"),
            })
            .collect();
        let differ = programs_differ(&model.keypad.offsets, &model.jog_context());
        let text = format!("programs count from @0n: {}", zeros.join(" "));
        let style = if differ.is_empty() { p.dim } else { p.warning };
        rows.push(Line::from(Span::styled(fit(&text, inner_w), style)));
    }
    let used = rows.len() as u16;
    draw_rows(rows, inner, buf);
    if note_rows > 0 {
        Paragraph::new(Span::styled(note, p.warning))
            .wrap(Wrap { trim: true })
            .render(
                Rect::new(
                    inner.x,
                    inner.y + used,
                    inner.width,
                    note_rows.min(inner.height.saturating_sub(used + 1)),
                ),
                buf,
            );
    }
    if inner.height > 0 {
        hints(
            model,
            Mode::Offsets,
            &[(Action::Activate, "activate"), (Action::Cancel, "close")],
        )
        .render(Rect::new(inner.x, inner.bottom() - 1, inner.width, 1), buf);
    }
}

fn set_position(model: &Model, line: &LineEdit, area: Rect, buf: &mut Buffer) {
    let p = &model.palette;
    let system = model.keypad.offsets.table.active();
    let width = area.width.clamp(24, 64);
    let error = line.error.as_ref().map(|e| e.message.as_str());
    let height = 5 + error_height(error, usize::from(width.saturating_sub(2)));
    let box_area = centred(area, width, height);
    let inner = framed(
        model,
        &format!("Set the work position here ({system})"),
        box_area,
        buf,
    );
    let w = usize::from(inner.width);
    let mut rows = vec![
        Line::from(Span::styled(
            fit(
                "e.g. X0 or X10 Y-2.5: where the machine stands reads that",
                w,
            ),
            p.dim,
        )),
        typed_line(model, "> ", line, true, w),
    ];
    if let Some(e) = error {
        rows.extend(error_rows(model, e, w));
    }
    rows.push(hints(
        model,
        Mode::Entry,
        &[(Action::Submit, "set"), (Action::Cancel, "cancel")],
    ));
    draw_rows(rows, inner, buf);
}

fn values(model: &Model, form: &ValuesForm, area: Rect, buf: &mut Buffer) {
    let p = &model.palette;
    let width = area.width.clamp(24, 64);
    let error = form
        .step
        .error
        .as_ref()
        .or(form.speed.error.as_ref())
        .map(|e| e.message.as_str());
    let height = 6 + error_height(error, usize::from(width.saturating_sub(2)));
    let box_area = centred(area, width, height);
    let inner = framed(model, "Jog step and speed", box_area, buf);
    let w = usize::from(inner.width);
    let unit = unit_label(model);
    let now_step = model
        .jog_step()
        .map(super::super::position::format_amount)
        .unwrap_or_default();
    let now_speed = model
        .jog_speed()
        .map(super::super::position::format_amount)
        .unwrap_or_default();
    let mut rows = vec![
        Line::from(Span::styled(
            fit(
                &format!("now {now_step} {unit}, {now_speed} {unit}/s; empty keeps it"),
                w,
            ),
            p.dim,
        )),
        typed_line(
            model,
            &format!("step {unit}:    "),
            &form.step,
            form.field == 0,
            w,
        ),
        typed_line(
            model,
            &format!("speed {unit}/s: "),
            &form.speed,
            form.field == 1,
            w,
        ),
    ];
    if let Some(e) = error {
        rows.extend(error_rows(model, e, w));
    }
    rows.push(hints(
        model,
        Mode::Entry,
        &[
            (Action::Submit, "ok"),
            (Action::NextField, "next field"),
            (Action::Cancel, "cancel"),
        ],
    ));
    draw_rows(rows, inner, buf);
}

/// The unit the keypad and its popups name: the axes' common one, else
/// `units`.
pub(super) fn unit_label(model: &Model) -> &'static str {
    crate::ui::position::common_unit(model.setup.axes.iter().map(|(_, p)| p))
        .map_or("units", |u| u.symbol())
}
