//! The view: a pure function of the model. [`Screen`] draws everything;
//! each panel is its own widget so later panels (jog keypad) slot in beside
//! them. While the program editor has focus the program screen takes the
//! place of the machine screen: the editor's own view (`ui::editor::view`,
//! drawn from the editor and its context) inside the status bar, message
//! line and key hints.

pub mod big_dro;
pub mod console;
pub mod dro;
pub mod flow;
pub mod frame;
pub mod io;
pub mod layout;
pub mod messages;
pub mod outputs;
pub mod popup;
pub mod sim;
pub mod status;
pub mod timeline;

use ratatui::buffer::Buffer;
use ratatui::layout::{Position, Rect};
use ratatui::widgets::Widget;

use super::editor;
use super::jog::popup_view::JogPopupView;
use super::jog::view::{AxesView, GoToView, KeypadView};
use super::model::{Model, PanelId, Popup};

/// The whole screen.
pub struct Screen<'a>(pub &'a Model);

impl Widget for Screen<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let model = self.0;
        buf.set_style(area, model.palette.text);
        if model.focus == PanelId::Editor {
            program_screen(model, area, buf);
        } else if model.focus == PanelId::Timeline {
            timeline::TimelineScreen(model).render(area, buf);
        } else {
            machine_screen(model, area, buf);
        }
        match &model.popup {
            Some(Popup::Help { scroll }) => popup::HelpView {
                model,
                scroll: *scroll,
            }
            .render(area, buf),
            Some(Popup::Confirm(confirmation)) => popup::ConfirmView {
                model,
                confirmation,
            }
            .render(area, buf),
            Some(Popup::Editor(dialog)) => editor::view::dialog::DialogView {
                editor: &model.editor,
                context: &model.editor_context(),
                dialog,
            }
            .render(area, buf),
            Some(Popup::GoTo(prompt)) => GoToView { model, prompt }.render(area, buf),
            Some(Popup::Axes(choice)) => AxesView { model, choice }.render(area, buf),
            Some(Popup::Jog(popup)) => JogPopupView { model, popup }.render(area, buf),
            Some(Popup::Outputs(o)) => outputs::OutputsView {
                model,
                selected: o.selected,
            }
            .render(area, buf),
            Some(Popup::Messages { back }) => {
                messages::MessagesView { model, back: *back }.render(area, buf)
            }
            None => {}
        }
    }
}

/// The program screen: status bar and message line as on the machine
/// screen, the machine's position in one line, the editor panel and the
/// toolpath preview, the key hints.
fn program_screen(model: &Model, area: Rect, buf: &mut Buffer) {
    let a = editor::layout::areas(&model.editor, area);
    status::StatusBar(model).render(a.status, buf);
    status::MessageLine(model).render(a.message, buf);
    dro::compact_line(model).render(a.machine, buf);
    editor::view::ProgramView {
        editor: &model.editor,
        context: &model.editor_context(),
        areas: &a,
    }
    .render(a.editor, buf);
    if let Some(hints) = a.hints {
        status::Hints(model).render(hints, buf);
    }
}

/// Where the terminal shows its cursor on a screen of `area`: at the
/// insertion point of the command line while it has the focus; nowhere
/// (hidden) otherwise.
pub fn cursor(model: &Model, area: Rect) -> Option<Position> {
    if matches!(model.focus, PanelId::Editor | PanelId::Timeline) || model.large_dro {
        return None;
    }
    console::cursor(model, layout::areas(model, area).console)
}

/// The machine screen: position, jog keypad, ports, simulator inputs,
/// traffic.
fn machine_screen(model: &Model, area: Rect, buf: &mut Buffer) {
    if model.large_dro {
        large_dro_screen(model, area, buf);
        return;
    }
    let a = layout::areas(model, area);
    status::StatusBar(model).render(a.status, buf);
    status::MessageLine(model).render(a.message, buf);
    if a.big_dro {
        big_dro::BigDroView(model).render(a.dro, buf);
    } else {
        dro::DroView(model).render(a.dro, buf);
    }
    KeypadView(model).render(a.keypad, buf);
    if let Some(preview) = a.preview {
        editor::view::preview::PreviewView {
            editor: &model.editor,
            context: &model.editor_context(),
        }
        .render(preview, buf);
    }
    io::IoView(model).render(a.io, buf);
    if let Some(sim_area) = a.sim {
        sim::SimView(model).render(sim_area, buf);
    }
    if let Some(recent) = a.messages {
        messages::LatestView(model).render(recent, buf);
    }
    console::ConsoleView(model).render(a.console, buf);
    if let Some(hints) = a.hints {
        status::Hints(model).render(hints, buf);
    }
}

/// The large position display (`D`): status bar, message line, the
/// positions in large digits, the key hints. The keys mean what they mean
/// on the machine screen (the keypad jogs, Space stops).
fn large_dro_screen(model: &Model, area: Rect, buf: &mut Buffer) {
    let a = layout::areas(model, area);
    status::StatusBar(model).render(a.status, buf);
    status::MessageLine(model).render(a.message, buf);
    let top = a.message.bottom();
    let bottom = a.hints.map_or(area.bottom(), |h| h.y).max(top);
    big_dro::BigDroView(model).render(Rect::new(area.x, top, area.width, bottom - top), buf);
    if let Some(hints) = a.hints {
        status::Hints(model).render(hints, buf);
    }
}
