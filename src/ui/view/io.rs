//! The port bit panels, drawn from whatever the driver delivers
//! (`IoSnapshot`: groups of named bits with raw bytes): each group starts a
//! line with its name and raw hex, its bits flow after it as symbol + name,
//! lit or unlit, a recent change highlighted. Names that share a leading
//! word (`limit X1` … `limit A2`) are written once (`limit ●X1 ○X2 …`), so
//! every bit keeps its manual name even at 80 columns. When the panel has
//! focus, its last line tells the selected bit in full.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::ui::io::{BitState, GroupState, IoPanel, Selection};
use crate::ui::model::{Model, PanelId};

use super::flow::{Flowed, Item, fit, flow};
use super::frame;

pub struct IoView<'a>(pub &'a Model);

/// From this panel width on, groups are named in full (`in 3: limit
/// switches`); narrower, by the part before the colon (`in 3`).
pub const FULL_GROUP_NAMES: usize = 90;

/// The short form of a group name: the part before `: `, if any.
fn short_name(name: &str) -> &str {
    name.split_once(": ").map_or(name, |(short, _)| short)
}

/// The lines of the panel body at `width`, and the line to keep in view
/// (`IoPanel::in_view`).
///
/// A group with several bits starts a line: its name, the raw byte in hex,
/// the bits. Groups of one bit (isel's on/off output ports) follow each other
/// on a line. The name travels with the first bit, so it never ends a line
/// alone.
fn body(model: &Model, width: usize) -> (Flowed<'static>, Option<usize>) {
    let p = &model.palette;
    let focused = model.focus == PanelId::Io && model.popup.is_none();
    let in_view = model.io.in_view(model.now);
    let mut items: Vec<Item<'static>> = Vec::new();
    let mut view_item = None;
    let mut previous_single = false;
    for (gi, group) in model.io.groups.iter().enumerate() {
        let single = group.bits.len() == 1;
        // A one-bit group named after its bit (`out 2: spindle`) says it once.
        let says_its_bit = single
            && group.bits.first().is_some_and(|b| {
                group.name.split_once(": ").map(|(_, long)| long) == Some(b.bit.name.as_str())
            });
        let name = if width >= FULL_GROUP_NAMES && !says_its_bit {
            group.name.as_str()
        } else {
            short_name(&group.name)
        };
        let mut head = vec![Span::styled(name.to_string(), p.title)];
        // The raw byte of a one-bit group is the bit itself.
        if let Some(raw) = group.raw.filter(|_| !single) {
            head.push(Span::styled(format!(" {raw:02X}"), p.dim));
        }
        head.push(Span::raw(" "));
        let new_line = !(single && previous_single);
        previous_single = single;
        let mut head = Some(head);
        let mut push = |items: &mut Vec<Item<'static>>, spans: Vec<Span<'static>>| {
            let mut all = head.take().unwrap_or_default();
            let first = !all.is_empty();
            all.extend(spans);
            let item = Item::new(all);
            items.push(if first && new_line {
                item.on_new_line()
            } else {
                item
            });
        };
        let prefix = common_prefix(group);
        if let Some(prefix) = prefix {
            push(&mut items, vec![Span::styled(prefix.to_string(), p.dim)]);
        }
        for (bi, bit) in group.bits.iter().enumerate() {
            let label = prefix
                .and_then(|pre| bit.bit.name.get(pre.len() + 1..))
                .unwrap_or(&bit.bit.name);
            let here = Some(Selection { group: gi, bit: bi });
            let is_selected = focused && model.io.selected == here;
            if in_view == here {
                view_item = Some(items.len());
            }
            push(&mut items, bit_spans(model, bit, label, is_selected));
        }
        if group.bits.is_empty() {
            push(&mut items, Vec::new());
        }
    }
    let flowed = flow(items, width, 2);
    let view_line = view_item.and_then(|i| flowed.line_of.get(i).copied());
    (flowed, view_line)
}

fn bit_spans(model: &Model, bit: &BitState, label: &str, selected: bool) -> Vec<Span<'static>> {
    let p = &model.palette;
    let (sym, mut style): (&str, Style) = if bit.bit.value {
        (p.symbols.lit, p.lit)
    } else {
        (p.symbols.unlit, p.unlit)
    };
    // A bit the profile says nothing is connected to: shown, dimmed.
    if !bit.bit.wired() {
        style = style.patch(p.dim);
    }
    if IoPanel::highlighted(bit, model.now) {
        style = style.patch(p.changed);
    }
    if selected {
        style = style.patch(p.selected);
    }
    vec![Span::styled(format!("{sym}{label}"), style)]
}

/// A leading word (or words) every bit name of the group shares, when the
/// group has at least three bits: written once before the bits.
fn common_prefix(group: &GroupState) -> Option<&str> {
    if group.bits.len() < 3 {
        return None;
    }
    let first = group.bits.first()?.bit.name.as_str();
    let mut best: Option<&str> = None;
    for (i, c) in first.char_indices() {
        if c != ' ' {
            continue;
        }
        let candidate = first.get(..i)?;
        let shared = group.bits.iter().all(|b| {
            b.bit
                .name
                .get(..=i)
                .is_some_and(|head| head == format!("{candidate} "))
                && b.bit.name.len() > i + 1
        });
        if shared {
            best = Some(candidate);
        }
    }
    best
}

/// Rows the panel needs at `width` (title included).
pub fn height(model: &Model, width: u16) -> u16 {
    let (flowed, _) = body(model, usize::from(width));
    let detail = u16::from(model.focus == PanelId::Io);
    let lines = flowed.lines.len().max(1) as u16;
    1 + lines + detail
}

impl Widget for IoView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let focused = model.focus == PanelId::Io && model.popup.is_none();
        let (flowed, selected_line) = body(model, usize::from(area.width));
        let detail_rows = u16::from(model.focus == PanelId::Io);
        let rows = usize::from(area.height.saturating_sub(1 + detail_rows));
        let total = flowed.lines.len();
        // Keep a fresh change or the selected bit in view; else the top.
        let start = match selected_line {
            Some(l) if l >= rows => (l + 1 - rows).min(total.saturating_sub(rows)),
            _ => 0,
        };
        let mut extra = Vec::new();
        if start > 0 {
            extra.push(Span::styled("more above ", p.dim));
        }
        if start + rows < total {
            extra.push(Span::styled("more below ", p.dim));
        }
        let inner = frame::panel("I/O", extra, focused, p, area, buf);
        if model.io.groups.is_empty() {
            Line::from(Span::styled(
                fit("no port bits read yet", usize::from(inner.width)),
                p.dim,
            ))
            .render(inner, buf);
            return;
        }
        for (row, line) in flowed.lines.into_iter().skip(start).take(rows).enumerate() {
            let y = inner.y + row as u16;
            line.render(Rect::new(inner.x, y, inner.width, 1), buf);
        }
        if detail_rows > 0 && inner.height > 0 {
            let y = inner.bottom() - 1;
            fit_line(detail(model), usize::from(inner.width))
                .render(Rect::new(inner.x, y, inner.width, 1), buf);
        }
    }
}

/// A line cut to `width` columns with an ellipsis.
fn fit_line(line: Line<'static>, width: usize) -> Line<'static> {
    let mut flowed = flow(vec![Item::new(line.spans)], width, 0);
    flowed.lines.pop().unwrap_or_default()
}

/// Group and bit name, the bit's name once when the group is named after it
/// (`out 2: spindle`).
fn full_name(group: &str, bit: &str) -> String {
    match group.split_once(": ") {
        Some((_, long)) if long == bit => group.to_string(),
        _ => format!("{group} {bit}"),
    }
}

/// The selected bit in full: group, name, value, what Enter does.
fn detail(model: &Model) -> Line<'static> {
    let p = &model.palette;
    let Some((group, bit)) = model.io.selected_bit() else {
        return Line::from(Span::styled("no bit selected", p.dim));
    };
    let what = match (bit.bit.output, bit.bit.hazardous) {
        (Some(_), true) => "output, Enter switches (asks first)",
        (Some(_), false) => "output, Enter switches",
        (None, _) => "input",
    };
    let changes = if bit.changes > 0 {
        format!(", changed {}x", bit.changes)
    } else {
        String::new()
    };
    // What the profile says of it: address, role, and when nothing is
    // connected (jogterm then never acts on it).
    let wiring = bit.bit.wiring.as_ref().map_or(String::new(), |w| {
        let wired = if w.wired { "" } else { ", not wired" };
        format!(", {} {}{wired}", w.address, w.role)
    });
    // An output jogterm has not written: its state is unknown.
    let outputs_only = group.all_bits.iter().all(|b| b.output.is_some());
    let value = if bit.bit.output.is_some() && outputs_only && group.raw.is_none() {
        "?".to_string()
    } else {
        u8::from(bit.bit.value).to_string()
    };
    Line::from(vec![
        Span::styled("> ", p.key),
        Span::styled(full_name(&group.name, &bit.bit.name), p.text),
        Span::styled(format!(" = {value}"), p.title),
        Span::styled(format!(" ({what}{wiring}{changes})"), p.dim),
    ])
}
