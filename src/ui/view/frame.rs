//! The frame every panel is drawn in: a title rule on top (no side borders,
//! so no columns are spent on lines and nothing needs redrawing but the
//! rule). The panel that has the focus gets its title reversed and its rule
//! drawn heavy (`━`, `=` in ASCII themes such as mono16), so focus is never
//! shown by colour alone, nor by one reversed word.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::symbols::border;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Widget};

use crate::ui::palette::Palette;

/// Draw the frame and return the area inside it.
pub fn panel(
    title: &str,
    extra: Vec<Span<'_>>,
    focused: bool,
    palette: &Palette,
    area: Rect,
    buf: &mut Buffer,
) -> Rect {
    let title_style = if focused {
        palette.selected.patch(palette.title)
    } else {
        palette.title
    };
    let border = if focused {
        palette.focus_border
    } else {
        palette.border
    };
    let mut spans = vec![Span::styled(format!(" {title} "), title_style)];
    spans.extend(extra);
    let mut block = Block::new()
        .borders(Borders::TOP)
        .border_style(border)
        .title(Line::from(spans));
    if focused {
        block = block.border_set(border::Set {
            horizontal_top: palette.symbols.focus_rule,
            ..border::PLAIN
        });
    }
    let inner = block.inner(area);
    block.render(area, buf);
    inner
}
