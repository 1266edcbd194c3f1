//! What goes into `update` ([`Msg`]) and what comes out of it ([`Effect`]).

use std::time::Instant;

use ratatui::crossterm::event::KeyEvent;

use crate::device::api::{Event, Request};
use crate::sim::InputControl;

use super::editor::io::{EditorIo, EditorMsg};
use crate::offsets::store::{SaveJob, Saved};

/// Everything that can change the model.
#[derive(Debug, Clone, PartialEq)]
pub enum Msg {
    /// A key from the terminal (presses, repeats and releases), at the
    /// model's time.
    Key(KeyEvent),
    /// A key as the input thread read it, and when: the jog keypad's
    /// dead-man arithmetic needs the key's own time, not the last tick's.
    KeyAt(KeyEvent, Instant),
    /// Keys the input thread found waiting together (one read of the
    /// terminal), each with the time it was read: more than one key press
    /// in one batch is a burst, never motion (`ui::typing`).
    KeysAt(Vec<(KeyEvent, Instant)>),
    /// Text the terminal pasted (bracketed paste): text where text is typed,
    /// never keys.
    Paste(String),
    /// Time passes: highlights fade, messages age, half-read replies are
    /// shown. Sent by the runtime a few times a second.
    Tick(Instant),
    /// An event from the device task.
    Device(Event),
    /// The terminal has a new size.
    Resize { width: u16, height: u16 },
    /// The built-in simulator has carried out (or refused) an input change.
    Simulator {
        control: InputControl,
        result: Result<(), String>,
    },
    /// A request could not be handed to the device task (`request` in
    /// words, `device::describe`).
    NotSent { request: String, reason: String },
    /// The terminal hung up or a terminating signal arrived: stop and leave.
    Terminate { reason: String },
    /// A file or lint result for the program editor, or a request to it.
    Editor(EditorMsg),
    /// How a write of the work offsets file or the tool table went, with
    /// what the file keeps.
    OffsetsSaved(&'static str, Saved),
    /// The job log as read for `Effect::ReadJobLog`: its table, newest
    /// last, and its notes.
    JobLog(Vec<String>),
}

/// What `update` asks the runtime to do. The runtime carries effects out in
/// order; `Stop` goes on the device's stop lane ahead of anything queued.
#[derive(Debug, Clone, PartialEq)]
pub enum Effect {
    /// Stop all motion now.
    Stop,
    /// Hand a request to the device task.
    Request(Request),
    /// Flip an input of the built-in simulator.
    Simulator(InputControl),
    /// A file or lint request of the program editor (carried out off the
    /// loop; the result comes back as `Msg::Editor`).
    Editor(EditorIo),
    /// Write the work offsets file (on its own thread, in order).
    SaveOffsets(SaveJob),
    /// Read the job log (off the loop); it comes back as `Msg::JobLog`.
    ReadJobLog,
    /// Close the device and leave (after the effects before it).
    Quit,
}
