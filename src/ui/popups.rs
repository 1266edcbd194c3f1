//! The popup slot (`Model::popup`), which takes every key but the stop
//! keys. The help, the message history, a question and the axis choice are
//! one component here ([`Popup::update`]); the other popups are components
//! of their own. A key takes the popup out of the slot; the outcome gives
//! it back while it stays open.

use super::editor::dialog::Dialog;
use super::io::Outputs;
use super::jog::axes::AxisChoice;
use super::jog::goto::GoToPrompt;
use super::jog::popups::JogPopup;
use super::keymap::{Action, Mode};
use super::msg::Effect;
use super::outcome::{Confirmation, Outcome};
use super::traffic_log::NoteLevel;

#[derive(Debug, Clone, PartialEq)]
pub enum Popup {
    Help {
        scroll: usize,
    },
    Confirm(Confirmation),
    /// A form or question of the program editor.
    Editor(Dialog),
    /// A position to go to, typed.
    GoTo(GoToPrompt),
    /// An axis for a reference run or a work zero.
    Axes(AxisChoice),
    /// The keypad's work offsets, set position, typed step and speed.
    Jog(JogPopup),
    /// The named outputs (spindle, coolant …).
    Outputs(Outputs),
    /// The message history; `back` is how many lines it is scrolled back
    /// from the newest.
    Messages {
        back: usize,
    },
}

/// What the popups read for a key, built per call.
#[derive(Debug, Clone, Copy)]
pub struct Context {
    /// The terminal's rows: a page of scrolling.
    pub rows: u16,
    /// Lines of the help.
    pub help_lines: usize,
    /// How many lines the message history scrolls back at most.
    pub oldest: usize,
}

impl Popup {
    pub fn mode(&self) -> Mode {
        match self {
            Popup::Help { .. } => Mode::Help,
            Popup::Confirm(_) => Mode::Confirm,
            Popup::Editor(dialog) => dialog.mode(),
            Popup::GoTo(_) => Mode::GoTo,
            Popup::Axes(_) => Mode::Axes,
            Popup::Jog(p) => p.mode(),
            Popup::Outputs(_) => Mode::Outputs,
            Popup::Messages { .. } => Mode::Messages,
        }
    }

    /// The line typed text goes into: the go-to prompt's, a keypad
    /// popup's that types (`typing::TextField::Prompt`).
    pub fn line(&mut self) -> Option<&mut super::line_edit::LineEdit> {
        match self {
            Popup::GoTo(prompt) => Some(&mut prompt.line),
            Popup::Jog(popup) => popup.line(),
            _ => None,
        }
    }

    /// A key of the help, the message history, a question (its `Confirm`
    /// is the caller's: a macro may start) or the axis choice (a work
    /// zero is the keypad's).
    pub fn update(self, ctx: &Context, action: Action) -> Outcome<Popup> {
        let cancelled = |what: &str| Outcome::note(NoteLevel::Info, format!("{what}: cancelled"));
        match (self, action) {
            (Popup::Confirm(c), Action::Cancel) => cancelled(&c.title),
            (Popup::Help { .. } | Popup::Messages { .. }, Action::Close) => Outcome::default(),
            (Popup::Help { scroll }, action) => {
                let page = usize::from(ctx.rows.saturating_sub(6)).max(1);
                let scroll = match action {
                    Action::ScrollUp => scroll.saturating_sub(1),
                    Action::ScrollDown => scroll + 1,
                    Action::PageUp => scroll.saturating_sub(page),
                    Action::PageDown => scroll + page,
                    _ => scroll,
                };
                let scroll = scroll.min(ctx.help_lines.saturating_sub(1));
                Outcome::popup(Popup::Help { scroll })
            }
            (Popup::Messages { back }, action) => {
                let page = usize::from(ctx.rows.saturating_sub(8)).max(1);
                let back = match action {
                    Action::ScrollUp => back + 1,
                    Action::ScrollDown => back.saturating_sub(1),
                    Action::PageUp => back + page,
                    Action::PageDown => back.saturating_sub(page),
                    Action::ScrollTop => ctx.oldest,
                    Action::ScrollBottom => 0,
                    _ => back,
                };
                let back = back.min(ctx.oldest);
                Outcome::popup(Popup::Messages { back })
            }
            (Popup::Axes(choice), Action::Cancel) => cancelled(choice.title()),
            (Popup::Axes(choice), action) => match choice.chosen(action) {
                Some(axes) => Outcome::effects(vec![Effect::Request(choice.request(axes))]),
                None => Outcome::note(
                    NoteLevel::Warning,
                    format!("the machine has axes {} only", choice.axes),
                )
                .with_popup(Popup::Axes(choice)),
            },
            (popup, _) => Outcome::popup(popup),
        }
    }
}
