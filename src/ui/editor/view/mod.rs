//! The program screen: status bar and message line as on the machine
//! screen, the editor panel, the toolpath preview beside it, the key hints.

pub mod dialog;
pub mod panel;
pub mod preview;

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::widgets::Widget;

use crate::ui::model::Model;
use crate::ui::view::status;

use super::layout;

/// The whole program screen (popups are drawn over it by `view::Screen`).
pub struct ProgramScreen<'a>(pub &'a Model);

impl Widget for ProgramScreen<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        let a = layout::areas(model, area);
        status::StatusBar(model).render(a.status, buf);
        status::MessageLine(model).render(a.message, buf);
        panel::EditorView { model, areas: &a }.render(a.editor, buf);
        if let Some(preview) = a.preview {
            preview::PreviewView(model).render(preview, buf);
        }
        if let Some(hints) = a.hints {
            status::Hints(model).render(hints, buf);
        }
    }
}
