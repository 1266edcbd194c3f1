//! What a component of the console asks of the rest of it after an input
//! (the command line, the I/O panel, the named outputs, the simulator panel,
//! the go-to prompt, the popups, the macros): effects in order, notes for
//! the message line, a question to ask first ([`Confirmation`], the
//! `Confirm` popup), its popup to show. `ui::update` applies it in one
//! place (`show`). The jog screen's outcome carries one, with flags of its
//! own; the editor's is its own (a focus change, a quit).

use std::convert::Infallible;

use super::msg::Effect;
use super::traffic_log::NoteLevel;

/// A line for the message line (and the console).
pub type Note = (NoteLevel, String);

/// A question that must be answered before its effects are carried out.
#[derive(Debug, Clone, PartialEq)]
pub struct Confirmation {
    pub title: String,
    pub question: String,
    pub effects: Vec<Effect>,
    /// What starts once confirmed, after `effects`, in a component of its
    /// own.
    pub then: Option<Then>,
}

/// What a confirmed question starts besides its effects.
#[derive(Debug, Clone, PartialEq)]
pub enum Then {
    /// The profile's macro of this name (`ui::macros`).
    Macro(String),
    /// The frame of the G-code job (`ui::frame`): armed only by the answer.
    Frame(super::frame::plan::Plan),
}

/// `P` is the component's popup (`Infallible`: it has none).
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome<P = Infallible> {
    pub effects: Vec<Effect>,
    /// Said in order: the last one stays in the message line.
    pub notes: Vec<Note>,
    /// A question before any effect (the `Confirm` popup), in place of any
    /// popup.
    pub confirm: Option<Confirmation>,
    /// The component's popup to show: a key of an open popup took it out
    /// of the popup slot, and it stays open only if given back here.
    pub popup: Option<P>,
}

impl<P> Default for Outcome<P> {
    fn default() -> Self {
        Outcome {
            effects: Vec::new(),
            notes: Vec::new(),
            confirm: None,
            popup: None,
        }
    }
}

impl<P> Outcome<P> {
    pub fn effects(effects: Vec<Effect>) -> Self {
        Outcome {
            effects,
            ..Outcome::default()
        }
    }

    pub fn note(level: NoteLevel, text: impl Into<String>) -> Self {
        Outcome {
            notes: vec![(level, text.into())],
            ..Outcome::default()
        }
    }

    pub fn popup(popup: P) -> Self {
        Outcome::default().with_popup(popup)
    }

    /// Ask `question` before `effects` are carried out.
    pub fn ask(title: &str, question: String, effects: Vec<Effect>) -> Self {
        Outcome {
            confirm: Some(Confirmation {
                title: title.to_string(),
                question,
                effects,
                then: None,
            }),
            ..Outcome::default()
        }
    }

    /// The same, with `popup` shown (or kept open) too.
    pub fn with_popup(mut self, popup: P) -> Self {
        self.popup = Some(popup);
        self
    }
}
