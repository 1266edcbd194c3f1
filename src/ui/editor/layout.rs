//! Where the program screen's parts go: status bar and message line on top
//! (as on the machine screen), a line with the machine's position below
//! them (the machine stays in sight while a program is edited), the key
//! hints at the bottom, the editor on
//! the left and the toolpath preview on the right when the terminal is wide
//! enough (at 70 columns and more; 80x24 gives the editor 50 columns).
//! Inside the editor panel: the title rule, the text, the upload bar while
//! there is something to say about an upload, and the cursor's status line.

use ratatui::layout::Rect;

use super::upload::Phase;
use super::{Editor, Planes};

/// Narrowest terminal with a preview beside the editor.
pub const PREVIEW_FROM: u16 = 70;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProgramAreas {
    pub status: Rect,
    pub message: Rect,
    /// The machine's position in one line (`ui::view::dro::compact_line`).
    pub machine: Rect,
    /// The editor panel, frame included.
    pub editor: Rect,
    /// Inside the editor: the lines of text (gutter included).
    pub text: Rect,
    pub upload: Option<Rect>,
    /// The cursor's line, command and diagnostic.
    pub line_info: Rect,
    pub preview: Option<Rect>,
    pub hints: Option<Rect>,
}

fn row(area: Rect, y: u16) -> Rect {
    let y = y.clamp(area.y, area.bottom());
    Rect::new(area.x, y, area.width, u16::from(y < area.bottom()))
}

pub fn areas(e: &Editor, area: Rect) -> ProgramAreas {
    let status = row(area, area.y);
    let message = row(area, area.y + 1);
    let machine = row(area, area.y + 2);
    let hints = (area.height >= 12).then(|| row(area, area.bottom().saturating_sub(1)));
    let top = (area.y + 3).min(area.bottom());
    let bottom = hints.map_or(area.bottom(), |h| h.y).max(top);
    let body = Rect::new(area.x, top, area.width, bottom - top);
    let show_preview = e.planes != Planes::Off && body.width >= PREVIEW_FROM;
    let preview_w = if !show_preview {
        0
    } else if body.width >= 120 {
        body.width * 2 / 5
    } else {
        (body.width * 3 / 8).max(28)
    };
    let editor = Rect::new(body.x, body.y, body.width - preview_w, body.height);
    let preview = (preview_w > 0).then(|| {
        Rect::new(
            editor.right(),
            body.y,
            body.width - editor.width,
            body.height,
        )
    });
    // Title rule, then the text, the upload bar, the line info.
    let inner_top = (editor.y + 1).min(editor.bottom());
    let line_info = row(editor, editor.bottom().saturating_sub(1).max(inner_top));
    let has_upload = e.upload.phase != Phase::Idle;
    let upload = (has_upload && line_info.y > inner_top).then(|| row(editor, line_info.y - 1));
    let text_bottom = upload.map_or(line_info.y, |u| u.y).max(inner_top);
    let text = Rect::new(editor.x, inner_top, editor.width, text_bottom - inner_top);
    ProgramAreas {
        status,
        message,
        machine,
        editor,
        text,
        upload,
        line_info,
        preview,
        hints,
    }
}

/// The text rows of the editor at a terminal of `size`.
pub fn text_rows(editor: &Editor, (w, h): (u16, u16)) -> usize {
    usize::from(areas(editor, Rect::new(0, 0, w, h)).text.height)
}

/// The text columns (after the gutter) at a terminal of `size`.
pub fn text_cols(editor: &Editor, (w, h): (u16, u16)) -> usize {
    let text = areas(editor, Rect::new(0, 0, w, h)).text;
    usize::from(text.width).saturating_sub(gutter_width(editor))
}

/// Columns of the gutter: the command number (as many digits as the
/// largest needs), a mark, a blank.
pub fn gutter_width(editor: &Editor) -> usize {
    let commands = editor.buffer.program().command_count().max(1);
    commands.to_string().len().max(2) + 2
}

/// Scrolling follows the layout: it lives beside it (the editor's module
/// does not import its layout, `docs/architecture.md`, "Inside the UI").
impl Editor {
    /// Keep the cursor within the rows and columns shown at a terminal of
    /// `size`.
    pub fn scroll_into_view(&mut self, size: (u16, u16)) {
        let rows = text_rows(self, size).max(1);
        let cols = text_cols(self, size).max(1);
        let c = self.buffer.cursor();
        if c.line < self.top {
            self.top = c.line;
        } else if c.line >= self.top + rows {
            self.top = c.line + 1 - rows;
        }
        // A little context to the left when scrolling sideways.
        if c.col < self.left {
            self.left = c.col.saturating_sub(cols / 4);
        } else if c.col >= self.left + cols {
            self.left = c.col + 1 - cols;
        }
    }
}
