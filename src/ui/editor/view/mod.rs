//! The editor's part of the program screen, drawn from the editor and its
//! read-only [`Context`] (nothing else of the model): the editor panel and
//! the toolpath preview beside it ([`ProgramView`]), and the editor's
//! dialogs. `ui::view` puts the status bar, message line and key hints
//! around it and the dialogs over it.

pub mod dialog;
pub mod job_panel;
pub mod panel;
pub mod preview;

use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::widgets::Widget;

use super::layout::ProgramAreas;
use super::{Context, Editor};

/// The editor panel and the preview in the program screen's `areas`
/// (`layout::areas`); the area given to `render` is not used.
pub struct ProgramView<'a> {
    pub editor: &'a Editor,
    pub context: &'a Context<'a>,
    pub areas: &'a ProgramAreas,
}

impl Widget for ProgramView<'_> {
    fn render(self, _area: Rect, buf: &mut Buffer) {
        let (editor, context, a) = (self.editor, self.context, self.areas);
        panel::EditorView {
            editor,
            context,
            areas: a,
        }
        .render(a.editor, buf);
        if let Some(side) = a.preview {
            match (&editor.job, editor.planes) {
                (Some(job), super::Planes::Job) => {
                    job_panel::JobPanelView { job, context }.render(side, buf);
                }
                _ => preview::PreviewView { editor, context }.render(side, buf),
            }
        }
    }
}
