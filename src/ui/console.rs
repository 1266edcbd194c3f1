//! The console as a component: its state is the traffic log and the
//! command line ([`Console`]); [`Console::update`] takes a [`Context`] and a
//! key, a typed character or a paste ([`Input`]), and returns an
//! [`Outcome`]: the checked line for the device task, notes.

use crate::device::api::Request;

use super::keymap::Action;
use super::line_edit::{LineEdit, edit_line};
use super::msg::Effect;
use super::outcome::Outcome;
use super::raw::{self, RawContext};
use super::traffic_log::{NoteLevel, TrafficLog};

#[derive(Debug, Clone, Default)]
pub struct Console {
    /// What went over the line and what jogterm said, newest last.
    pub traffic: TrafficLog,
    /// The line being typed (entered with `:`, `ui::typing`).
    pub command: LineEdit,
}

/// What the console reads, built per call.
#[derive(Debug, Clone)]
pub struct Context {
    /// What a typed line is checked against.
    pub raw: RawContext,
    /// The macro running (`macro park, line 2 of 3`): a typed line waits.
    pub macro_running: Option<String>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Input<'a> {
    /// A key action of the focused command line, or `TogglePolls`.
    Key(Action),
    Char(char),
    /// Pasted text: one line at the cursor (`LineEdit::paste`).
    Paste(&'a str),
}

impl Console {
    pub fn update(&mut self, ctx: &Context, input: Input) -> Outcome {
        let line = &mut self.command;
        match input {
            Input::Key(Action::Submit) => {
                if let Some(place) = &ctx.macro_running {
                    let text = format!("not sent: {place} is running (Space stops it)");
                    return Outcome::note(NoteLevel::Warning, text);
                }
                match raw::validate(&ctx.raw, line.text()) {
                    Ok(checked) => {
                        line.accept();
                        let raw = Effect::Request(Request::Raw { line: checked });
                        return Outcome::effects(vec![raw]);
                    }
                    Err(e) => line.error = Some(e),
                }
            }
            Input::Key(Action::TogglePolls) => self.traffic.show_polls ^= true,
            Input::Key(Action::HistoryPrev) => line.history_prev(),
            Input::Key(Action::HistoryNext) => line.history_next(),
            Input::Key(action) => edit_line(line, action),
            Input::Char(c) => line.insert(c),
            Input::Paste(text) => {
                if let Err(refused) = line.paste(text) {
                    return Outcome::note(NoteLevel::Warning, refused.to_string());
                }
            }
        }
        Outcome::default()
    }
}
