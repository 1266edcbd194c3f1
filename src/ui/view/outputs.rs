//! The named outputs popup (`x`): the outputs the profile gives a role an
//! operator switches by name (spindle, coolant, clamp, vacuum, lamp, hood
//! unlock), each with its state and whether switching it asks first;
//! Enter switches the chosen one.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::ui::keymap::{Action, Mode};
use crate::ui::model::Model;

use super::flow::fit;
use super::popup::{centred, framed};

pub struct OutputsView<'a> {
    pub model: &'a Model,
    pub selected: usize,
}

/// `on`, `off`, or `?` for an output of a port jogterm has not written
/// (outputs cannot be read back).
fn state(model: &Model, s: crate::ui::io::Selection) -> &'static str {
    let Some((group, bit)) = model.io.bit_at(s) else {
        return "?";
    };
    let outputs_only = group.all_bits.iter().all(|b| b.output.is_some());
    if outputs_only && group.raw.is_none() {
        "?"
    } else if bit.bit.active() {
        "on"
    } else {
        "off"
    }
}

impl Widget for OutputsView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.model;
        let p = &model.palette;
        let entries = model.io.named_outputs();
        let height = entries.len() as u16 + 4;
        let box_area = centred(area, 56, height);
        let inner = framed(model, "Named outputs", box_area, buf);
        let width = usize::from(inner.width);
        let mut lines: Vec<Line> = Vec::new();
        for (i, s) in entries.iter().enumerate() {
            let Some((_, bit)) = model.io.bit_at(*s) else {
                continue;
            };
            let chosen = i == self.selected.min(entries.len().saturating_sub(1));
            let on = state(model, *s);
            let (sym, style) = match on {
                "on" => (p.symbols.lit, p.lit),
                _ => (p.symbols.unlit, p.unlit),
            };
            let role = bit
                .bit
                .wiring
                .as_ref()
                .map(|w| format!("{} {}", w.role, w.address))
                .unwrap_or_default();
            let asks = if bit.bit.hazardous { "asks first" } else { "" };
            let pointer = if chosen { "> " } else { "  " };
            let name_style = if chosen { p.selected } else { p.text };
            let name_w = 20.min(width.saturating_sub(5));
            lines.push(Line::from(vec![
                Span::styled(pointer, p.key),
                Span::styled(format!("{sym} "), style),
                Span::styled(
                    format!("{:<name_w$}", fit(&bit.bit.name, name_w)),
                    name_style,
                ),
                Span::styled(format!(" {on:<3}"), p.title),
                Span::styled(
                    fit(&format!(" {role} {asks}"), width.saturating_sub(name_w + 8)),
                    p.dim,
                ),
            ]));
        }
        lines.push(Line::default());
        let key = |a| {
            model
                .keymap
                .key_for(Mode::Outputs, a)
                .map(|k| k.to_string())
                .unwrap_or_default()
        };
        lines.push(Line::from(vec![
            Span::styled(key(Action::ToggleOutput), p.key),
            Span::styled(" switch  ", p.text),
            Span::styled(key(Action::Close), p.key),
            Span::styled(" close", p.text),
        ]));
        for (i, line) in lines.into_iter().enumerate() {
            let y = inner.y + i as u16;
            if y >= inner.bottom() {
                break;
            }
            line.render(Rect::new(inner.x, y, inner.width, 1), buf);
        }
    }
}
