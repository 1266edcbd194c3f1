//! The large position display (`D`, and the position panel where a large
//! terminal has the room): each axis' work position in digits five rows
//! high, readable from across the workshop, with its marks, unit, machine
//! position and steps in small type beside it. In themes with ASCII symbols
//! (mono16) the digits are drawn with `#`. Where the digits do not fit the
//! area, the ordinary position panel is drawn instead.

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;

use crate::ui::model::Model;

use super::dro::{self, DroView};
use super::frame;

/// Rows of one digit at the smallest size.
pub const GLYPH_ROWS: u16 = 5;

/// The digits, signs and axis letters, five rows each, `#` where the
/// glyph is inked (drawn as a full block, or `#` in ASCII themes).
fn glyph(c: char) -> Option<[&'static str; 5]> {
    Some(match c {
        '0' => ["###", "# #", "# #", "# #", "###"],
        '1' => [" # ", "## ", " # ", " # ", "###"],
        '2' => ["###", "  #", "###", "#  ", "###"],
        '3' => ["###", "  #", " ##", "  #", "###"],
        '4' => ["# #", "# #", "###", "  #", "  #"],
        '5' => ["###", "#  ", "###", "  #", "###"],
        '6' => ["###", "#  ", "###", "# #", "###"],
        '7' => ["###", "  #", "  #", "  #", "  #"],
        '8' => ["###", "# #", "###", "# #", "###"],
        '9' => ["###", "# #", "###", "  #", "###"],
        '-' => ["   ", "   ", "###", "   ", "   "],
        '.' => [" ", " ", " ", " ", "#"],
        ' ' => ["   ", "   ", "   ", "   ", "   "],
        'X' => ["# #", "# #", " # ", "# #", "# #"],
        'Y' => ["# #", "# #", " # ", " # ", " # "],
        'Z' => ["###", "  #", " # ", "#  ", "###"],
        'A' => [" # ", "# #", "###", "# #", "# #"],
        _ => return None,
    })
}

/// Columns `text` takes in digits of `scale` (a blank after each).
fn big_width(text: &str, scale: usize) -> usize {
    text.chars()
        .filter_map(glyph)
        .map(|g| (g[0].chars().count() + 1) * scale)
        .sum()
}

/// Draw `text` in digits of `scale` (each dot `scale` cells square) at
/// (x, y), at most `max_w` columns.
fn draw_big(
    text: &str,
    (x, y): (u16, u16),
    scale: u16,
    max_w: u16,
    ink: &str,
    style: Style,
    buf: &mut Buffer,
) {
    let mut col = x;
    for g in text.chars().filter_map(glyph) {
        let w = g[0].chars().count() as u16 * scale;
        if col + w > x + max_w {
            break;
        }
        for (row, line) in g.iter().enumerate() {
            for (i, _) in line.chars().enumerate().filter(|(_, c)| *c == '#') {
                for dy in 0..scale {
                    for dx in 0..scale {
                        let cell = (col + i as u16 * scale + dx, y + row as u16 * scale + dy);
                        buf[cell].set_symbol(ink).set_style(style);
                    }
                }
            }
        }
        col += w + scale;
    }
}

/// Columns of the large display with digits of `scale`: axis letter,
/// digits for the widest value the profile allows, and the small type
/// beside.
pub fn width_at(model: &Model, scale: usize) -> u16 {
    let widest = "8".repeat(dro::work_chars(model).saturating_sub(1)) + "-.";
    (big_width("X", scale) + 2 + big_width(&widest, scale) + 1 + SMALL) as u16
}

/// [`width_at`] the smallest digits.
pub fn width(model: &Model) -> u16 {
    width_at(model, 1)
}

/// Columns of the small type beside the digits.
const SMALL: usize = 22;

/// Rows the large display needs with digits of `scale`: the title, then
/// each axis' digits, with a blank row between axes when `spaced`.
pub fn height_at(model: &Model, scale: u16, spaced: bool) -> u16 {
    let axes = model.setup.axes.len() as u16;
    let gap = u16::from(spaced);
    1 + axes * GLYPH_ROWS * scale + axes.saturating_sub(1) * gap
}

/// [`height_at`] the smallest digits.
pub fn height(model: &Model, spaced: bool) -> u16 {
    height_at(model, 1, spaced)
}

/// The largest digits that fit `area` (1 to 3), if any do.
fn scale_for(model: &Model, area: Rect) -> Option<u16> {
    (1..=3u16).rev().find(|&s| {
        height_at(model, s, false) <= area.height && width_at(model, usize::from(s)) <= area.width
    })
}

pub struct BigDroView<'a>(pub &'a Model);

impl Widget for BigDroView<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let p = &model.palette;
        let Some(scale) = scale_for(model, area) else {
            DroView(model).render(area, buf);
            return;
        };
        let spaced = area.height >= height_at(model, scale, true);
        let inner = frame::panel("Position", dro::title_extra(model), false, p, area, buf);
        let ink = if p.symbols.lit.is_ascii() { "#" } else { "█" };
        let s = usize::from(scale);
        let value_w = usize::from(width_at(model, s)) - big_width("X", s) - 2 - 1 - SMALL;
        let rows = GLYPH_ROWS * scale;
        let gap = u16::from(spaced);
        for (i, ((axis, r), (_, profile))) in dro::readings(model)
            .into_iter()
            .zip(&model.setup.axes)
            .enumerate()
        {
            let y = inner.y + i as u16 * (rows + gap);
            if y + rows > inner.bottom() {
                break;
            }
            let letter = axis.to_string();
            draw_big(&letter, (inner.x, y), scale, inner.width, ink, p.title, buf);
            let x = inner.x + big_width(&letter, s) as u16;
            Line::from(vec![
                Span::styled(r.referenced.0, r.referenced.1),
                Span::styled(r.source.0, r.source.1),
            ])
            .render(Rect::new(x, y, 2, 1), buf);
            // Right-aligned, so the digits of one value stay in place.
            let shift = value_w.saturating_sub(big_width(&r.work, s)) as u16;
            let at = (x + 2 + shift, y);
            draw_big(&r.work, at, scale, value_w as u16, ink, r.value_style, buf);
            let sx = x + 2 + value_w as u16 + 1;
            let sw = inner.right().saturating_sub(sx);
            let small = [
                Line::from(Span::styled(profile.unit.symbol().to_string(), p.dim)),
                Line::from(vec![
                    Span::styled("machine ", p.dim),
                    Span::styled(r.machine, r.other_style),
                ]),
                Line::from(vec![
                    Span::styled("steps ", p.dim),
                    Span::styled(r.steps, r.other_style),
                ]),
                Line::from(Span::styled(r.words, p.dim)),
            ];
            for (row, line) in small.into_iter().enumerate() {
                line.render(Rect::new(sx, y + row as u16, sw, 1), buf);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_glyph_is_five_rows_of_one_width() {
        for c in "0123456789-. XYZA".chars() {
            let g = glyph(c).expect("a glyph");
            let w = g[0].chars().count();
            assert!(g.iter().all(|row| row.chars().count() == w), "{c}");
        }
        assert_eq!(big_width("-1.5", 1), 4 + 4 + 2 + 4);
        assert_eq!(big_width("-1.5", 2), 2 * (4 + 4 + 2 + 4));
    }
}
