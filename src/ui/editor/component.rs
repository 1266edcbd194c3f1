//! The editor as a component (`docs/architecture.md`, "The editor
//! component"): its state is [`Editor`](super::Editor), and everything else
//! crosses one boundary. [`Editor::update`](super::Editor::update) takes a
//! read-only [`Context`] (what the editor needs to know of the console and
//! the machine) and an [`Input`], changes nothing but the editor, and
//! returns an [`Outcome`]: what the rest of the console is to do (effects
//! for the device and the worker threads, notes for the message line, a
//! dialog to show, a focus change, a quit). `ui::update` builds the context
//! (`Model::editor_parts`) and applies the outcome in one place; the
//! editor's view draws from the editor and the same context.
//!
//! Later features of the program screen (a compact position display beside
//! the text, program check-out runs that pause, resume and run from a line)
//! read the machine from the context and ask the device through
//! [`Effect::Device`], so that they too need nothing from the model.

use std::time::Instant;

use crate::device::api::{Event, MachineState, Request};
use crate::ui::keymap::{Action, Keymap};
use crate::ui::palette::Palette;
use crate::ui::position::Positions;
use crate::ui::setup::Setup;
use crate::ui::traffic_log::NoteLevel;

use super::dialog::Dialog;
use super::io::{EditorIo, EditorMsg};

/// What the editor may read of the rest of the console, for one update or
/// one frame. Built fresh each time from the model; never kept.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The machine as the profile describes it: protocol, axes (units,
    /// soft limits, speeds), the jog speeds taught moves choose from.
    pub setup: &'a Setup,
    /// What the controller last reported: activity, references, work zero,
    /// the stored program.
    pub machine: &'a MachineState,
    /// The axes' positions as last reported (measured or estimated).
    pub positions: &'a Positions,
    /// The session's work offsets (`O`, `s`, a probe): what a G-code job
    /// opened here is placed with, and checked again with when they change.
    pub offsets: &'a crate::offsets::WorkOffsets,
    /// The tool table: the tool in the spindle shifts every Z of a G-code
    /// job imported here; a tool change measures into it.
    pub tools: &'a crate::ui::tools::ToolsState,
    /// The model's time (the last tick or key).
    pub now: Instant,
    pub palette: &'a Palette,
    /// For the keys the view names (upload bar, dialogs).
    pub keymap: &'a Keymap,
    /// The terminal's size, columns and rows: what scrolling keeps in view.
    pub size: (u16, u16),
    /// The program screen is shown (the editor has the focus).
    pub focused: bool,
    /// A popup is open (one of the editor's or another): recovered edits
    /// and the erase offer wait until it is closed.
    pub popup_open: bool,
}

/// What reaches the editor.
#[derive(Debug, Clone, PartialEq)]
pub enum Input<'a> {
    /// A key action of the editor panel (it has the focus).
    Key(Action),
    /// A character typed into the text.
    Char(char),
    /// A main-screen action the editor owns: the program screen, teach-in,
    /// upload, run. Other actions do nothing.
    Main(Action),
    /// A key action while the editor's `Dialog` is open; the caller took it
    /// out of the popup slot, the outcome gives it back if it stays open.
    Dialog(Dialog, Action),
    /// A character typed while the editor's `Dialog` is open (into a form's
    /// focused field).
    DialogChar(Dialog, char),
    /// A key of the check-out's mode with its phase (press, repeat, or the
    /// release a kitty-protocol terminal reports).
    Checkout(Action, crate::jog::KeyPhase),
    /// Pasted text (bracketed paste), the one way a paste reaches the
    /// editor: into the program at the cursor, its lines as they are (one
    /// undo step).
    Paste(&'a str),
    /// Pasted text while the editor's `Dialog` is open: a form's focused
    /// field takes one line (`line_edit::one_line`).
    DialogPaste(Dialog, &'a str),
    /// A result of the editor's effects, or a request from outside.
    Msg(EditorMsg),
    /// Time passed (the context's `now`): lint, recovery file, offers.
    Tick,
    /// An event of the device task, before the model takes it (the
    /// context's machine state is the one before the event).
    Device(&'a Event),
    /// The operator asks to quit: unsaved edits ask first (the outcome
    /// shows that dialog; without one nothing holds the quit).
    Quit,
    /// The session ends without asking (signal, hang-up): the last edits
    /// go to the recovery file.
    Terminate,
    /// The machine was stopped (the stop key, or any stop the console
    /// sends): whatever the editor runs in steps goes no further.
    Stopped,
}

/// An effect the editor asks for, carried out outside `update`.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// A file or lint job for the editor's worker threads; the result comes
    /// back as [`Input::Msg`].
    Io(EditorIo),
    /// A request to the device task (upload, run).
    Device(Request),
    /// Stop all motion (the stop lane), as the stop key does.
    Stop,
    /// `tool` touched the tool sensor at machine Z `z` (units): into the
    /// console's tool table (`ui::tools`), which is written.
    ToolMeasured { tool: String, z: f64 },
}

/// A line for the message line and the console.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Note {
    pub level: NoteLevel,
    pub text: String,
}

/// Where the focus goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Focus {
    /// To the editor: the program screen is shown.
    Editor,
    /// Back to the panel that had it before the editor.
    Back,
}

/// What the rest of the console is to do after an update, applied by
/// `ui::update` in one place, in this order: focus, notes, dialog, effects
/// (a quit last).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Outcome {
    /// In the order asked for.
    pub effects: Vec<Effect>,
    /// Said in order: the last one stays in the message line.
    pub notes: Vec<Note>,
    /// A dialog to show, in place of whatever popup is open.
    pub dialog: Option<Dialog>,
    pub focus: Option<Focus>,
    /// Stop the machine and leave, after the effects (unsaved edits dealt
    /// with on the way out).
    pub quit: bool,
}

impl Effect {
    /// The console's effect, or the tool measured that the console's own
    /// state takes (`ui::update` applies it).
    pub fn console(self) -> Result<crate::ui::msg::Effect, (String, f64)> {
        match self {
            Effect::Io(io) => Ok(crate::ui::msg::Effect::Editor(io)),
            Effect::Device(request) => Ok(crate::ui::msg::Effect::Request(request)),
            Effect::Stop => Ok(crate::ui::msg::Effect::Stop),
            Effect::ToolMeasured { tool, z } => Err((tool, z)),
        }
    }
}
