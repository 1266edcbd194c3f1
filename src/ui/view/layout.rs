//! Where each panel goes, sized to the terminal: side by side from 76
//! columns (position, jog keypad and simulator left, port bits right,
//! traffic below),
//! stacked below that. The status bar and message line are always on top,
//! the key hints at the bottom; the traffic console gets what is left, and
//! never less than a few lines. On a large terminal (from 120x44) the room
//! goes to what the operator watches: the position in large digits, the
//! port bits and the toolpath preview below them, the latest messages in
//! the rows the left column has to spare; the traffic console is held to a
//! few lines.

use ratatui::layout::Rect;

use crate::ui::jog::view as keypad;
use crate::ui::model::{Model, PanelId};

use super::{big_dro, dro, io, sim};

/// Narrowest terminal that gets panels side by side.
pub const SIDE_BY_SIDE: u16 = 76;

/// The smallest terminal that is large: the position in large digits and
/// the toolpath preview, the traffic console held to [`LARGE_CONSOLE`].
/// 44 rows hold four axes' digits, the keypad and a console of six lines
/// (a 200x40 terminal keeps the position table).
pub const LARGE: (u16, u16) = (120, 44);

/// Most rows the traffic console gets on a large terminal.
pub const LARGE_CONSOLE: u16 = 10;

/// Fewest rows worth a toolpath preview.
const PREVIEW_ROWS: u16 = 8;

/// Fewest rows worth the panel of the latest messages (title and three).
const MESSAGES_ROWS: u16 = 4;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Areas {
    pub status: Rect,
    pub message: Rect,
    pub dro: Rect,
    pub keypad: Rect,
    pub io: Rect,
    pub sim: Option<Rect>,
    pub console: Rect,
    pub hints: Option<Rect>,
    /// The toolpath preview (large terminals, where there is room).
    pub preview: Option<Rect>,
    /// The latest messages, below the keypad and simulator inputs (large
    /// terminals, where the left column has rows to spare).
    pub messages: Option<Rect>,
    /// The position panel is drawn in large digits.
    pub big_dro: bool,
}

fn rows(area: Rect, y: u16, height: u16) -> Rect {
    let y = y.min(area.bottom());
    Rect::new(area.x, y, area.width, height.min(area.bottom() - y))
}

pub fn areas(model: &Model, area: Rect) -> Areas {
    let status = rows(area, area.y, 1);
    let message = rows(area, area.y + 1, 1);
    let hints = (area.height >= 12).then(|| rows(area, area.bottom() - 1, 1));
    let body_top = area.y + 2;
    let body_bottom = hints.map_or(area.bottom(), |h| h.y).max(body_top);
    let body = Rect::new(area.x, body_top, area.width, body_bottom - body_top);
    if area.width >= LARGE.0 && area.height >= LARGE.1 {
        large(model, body, status, message, hints)
    } else if area.width >= SIDE_BY_SIDE {
        side_by_side(model, body, status, message, hints)
    } else {
        stacked(model, body, status, message, hints)
    }
}

fn side_by_side(
    model: &Model,
    body: Rect,
    status: Rect,
    message: Rect,
    hints: Option<Rect>,
) -> Areas {
    // The position panel gets what its columns need (more on wide
    // terminals), the port bits the rest.
    let left_w = dro::width(model)
        .max((body.width * 2 / 5).min(72))
        .min(body.width / 2);
    let right_x = body.x + left_w + 1;
    let right_w = body.right().saturating_sub(right_x);
    let dro_h = dro::height(model);
    let pad_h = keypad::height(model);
    let sim_h = sim::height(model, left_w);
    let io_h = io::height(model, right_w);
    let console_min = (body.height / 4).max(5);
    let top_max = body.height.saturating_sub(console_min);
    let top = (dro_h + pad_h + sim_h).max(io_h).min(top_max);
    let dro_rect = Rect::new(body.x, body.y, left_w, dro_h.min(top));
    let pad_rect = Rect::new(
        body.x,
        body.y + dro_rect.height,
        left_w,
        pad_h.min(top - dro_rect.height),
    );
    let used = dro_rect.height + pad_rect.height;
    let sim_rect =
        (sim_h > 0 && top > used + 1).then(|| Rect::new(body.x, body.y + used, left_w, top - used));
    let io_rect = Rect::new(right_x, body.y, right_w, top);
    let console = Rect::new(body.x, body.y + top, body.width, body.height - top);
    Areas {
        status,
        message,
        dro: dro_rect,
        keypad: pad_rect,
        io: io_rect,
        sim: sim_rect,
        console,
        hints,
        preview: None,
        messages: None,
        big_dro: false,
    }
}

/// A large terminal: the left column has the position in large digits,
/// the keypad, the simulator's inputs and the latest messages; the right one the port bits and,
/// below them, the toolpath preview; the traffic console a few lines at
/// the bottom (all of it with `p`/F2 or `:` still, and `M` for messages).
fn large(model: &Model, body: Rect, status: Rect, message: Rect, hints: Option<Rect>) -> Areas {
    let console_h = (body.height / 5).clamp(6, LARGE_CONSOLE);
    let top = body.height.saturating_sub(console_h);
    let left_w = big_dro::width(model)
        .max(dro::width(model))
        .max((body.width * 2 / 5).min(72))
        .min(body.width / 2);
    let right_x = body.x + left_w + 1;
    let right_w = body.right().saturating_sub(right_x);
    let dro_h = big_dro::height(model, true).min(top);
    let pad_h = keypad::height(model).min(top - dro_h);
    let used = dro_h + pad_h;
    let sim_h = sim::height(model, left_w);
    let sim_rect = (sim_h > 0 && top > used + 1)
        .then(|| Rect::new(body.x, body.y + used, left_w, (top - used).min(sim_h + 1)));
    // What the left column has left goes to the latest messages, not to an
    // empty block.
    let left_used = used + sim_rect.map_or(0, |r| r.height);
    let messages = (top.saturating_sub(left_used) >= MESSAGES_ROWS)
        .then(|| Rect::new(body.x, body.y + left_used, left_w, top - left_used));
    let io_h = io::height(model, right_w).min(top);
    let preview_h = top - io_h;
    let preview =
        (preview_h >= PREVIEW_ROWS).then(|| Rect::new(right_x, body.y + io_h, right_w, preview_h));
    let io_rect = Rect::new(
        right_x,
        body.y,
        right_w,
        if preview.is_some() { io_h } else { top },
    );
    Areas {
        status,
        message,
        dro: Rect::new(body.x, body.y, left_w, dro_h),
        keypad: Rect::new(body.x, body.y + dro_h, left_w, pad_h),
        io: io_rect,
        sim: sim_rect,
        console: Rect::new(body.x, body.y + top, body.width, body.height - top),
        hints,
        preview,
        messages,
        big_dro: true,
    }
}

fn stacked(model: &Model, body: Rect, status: Rect, message: Rect, hints: Option<Rect>) -> Areas {
    let w = body.width;
    let console_min = 4.min(body.height);
    let dro_h = dro::height(model).min(body.height.saturating_sub(console_min));
    let pad_h = keypad::height(model).min(body.height - dro_h - console_min);
    let left = body.height - dro_h - pad_h - console_min;
    let io_need = io::height(model, w);
    let sim_need = sim::height(model, w);
    // The focused panel is never squeezed out: the simulator panel takes
    // the port bits' room when it has focus and both do not fit.
    let (io_h, sim_h) = if io_need + sim_need <= left {
        (io_need, sim_need)
    } else if model.focus == PanelId::Sim && sim_need > 0 {
        let sim_h = sim_need.min(left);
        (left - sim_h, sim_h)
    } else {
        (left, 0)
    };
    let mut y = body.y;
    let dro_rect = Rect::new(body.x, y, w, dro_h);
    y += dro_h;
    let pad_rect = Rect::new(body.x, y, w, pad_h);
    y += pad_h;
    let io_rect = Rect::new(body.x, y, w, io_h);
    y += io_h;
    let sim_rect = (sim_h > 0).then(|| Rect::new(body.x, y, w, sim_h));
    y += sim_h;
    let console = Rect::new(body.x, y, w, body.bottom() - y);
    Areas {
        status,
        message,
        dro: dro_rect,
        keypad: pad_rect,
        io: io_rect,
        sim: sim_rect,
        console,
        hints,
        preview: None,
        messages: None,
        big_dro: false,
    }
}
