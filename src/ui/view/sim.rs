//! The simulator panel: the built-in simulator's inputs with the level last
//! set from here (`?` until then, `…` while the simulator has not yet
//! confirmed a change).

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::ui::model::{Model, PanelId};

use super::flow::{Flowed, Item, flow};
use super::frame;

pub struct SimView<'a>(pub &'a Model);

fn body(model: &Model, width: usize) -> Flowed<'static> {
    let p = &model.palette;
    let Some(sim) = &model.sim else {
        return Flowed::default();
    };
    let focused = model.focus == PanelId::Sim && model.popup.is_none();
    let items = sim
        .inputs
        .iter()
        .enumerate()
        .map(|(i, input)| {
            let (level, mut style) = match (input.pending, input.level) {
                (true, _) => ("…", p.dim),
                (false, Some(true)) => ("1", p.lit),
                (false, Some(false)) => ("0", p.unlit),
                (false, None) => ("?", p.dim),
            };
            if focused && i == sim.selected {
                style = style.patch(p.selected);
            }
            Item::new(vec![Span::styled(format!("{}={level}", input.name), style)])
        })
        .collect();
    flow(items, width, 0)
}

/// Rows the panel needs at `width` (title included); 0 without a simulator.
pub fn height(model: &Model, width: u16) -> u16 {
    if model.sim.is_none() {
        return 0;
    }
    1 + body(model, usize::from(width)).lines.len().max(1) as u16
}

impl Widget for SimView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let focused = model.focus == PanelId::Sim && model.popup.is_none();
        let inner = frame::panel("Simulator inputs", Vec::new(), focused, p, area, buf);
        let lines = body(model, usize::from(inner.width)).lines;
        if lines.is_empty() {
            Line::from(Span::styled("the simulator names no inputs", p.dim)).render(inner, buf);
            return;
        }
        for (row, line) in lines
            .into_iter()
            .take(usize::from(inner.height))
            .enumerate()
        {
            line.render(
                Rect::new(inner.x, inner.y + row as u16, inner.width, 1),
                buf,
            );
        }
    }
}
