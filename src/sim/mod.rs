//! Built-in controller simulators.
//!
//! A simulator is split the same way as the rest of jogterm:
//! - a **device model** per family (`SimDevice`): a sans-IO state machine that is
//!   told when each byte has arrived and what time it is, and hands back whole
//!   messages to transmit. It models the controller (axes, ramps, ports, program
//!   memory), not a reply table.
//! - one **shell** for all families (`shell`): owns the line, models wire timing in
//!   both directions at the device's baud rate, applies injected faults to the
//!   messages on their way out, and feeds operator controls (flip an input,
//!   press a button) to the device. It serves a pseudo-terminal, or any byte
//!   stream, on its own threads with precise sleeps (tokio's timer has 1 ms
//!   granularity, a byte at 19200 baud takes 0.52 ms).

pub mod control;
pub mod emcu;
pub mod emp;
pub mod engine;
pub mod fault;
pub mod isel;
mod line;
pub mod pty;
pub mod received;
pub mod registry;
pub mod shell;
pub mod start_key;
pub mod timescale;

use std::time::{Duration, Instant};

use crate::wire::LineSettings;

/// An operator action on the simulated machine's inputs, as typed on the
/// simulator's stdin (see `docs/simulator.md` for the control language).
#[derive(Debug, Clone, PartialEq)]
pub enum InputControl {
    /// Set a named input to a level: `true` = the bit reads 1 (active-high as
    /// read, `docs/decisions.md` isel 7). For safety circuits and the hood
    /// `closed` means 1 (healthy), `open` means 0 (tripped / opened).
    Set { name: String, level: bool },
    /// Press and release a momentary button (start, stop).
    Press { name: String },
    /// Set an analogue input to a value in its own unit (EMP ADC channels: mV).
    Value { name: String, value: f64 },
}

/// What a timed operator control does (`pulse`, `chatter`, or a plain
/// control `after` a delay).
#[derive(Debug, Clone, PartialEq)]
pub enum Timed {
    Input(InputControl),
    /// Flip the input, and flip it back `hold` later.
    Pulse {
        name: String,
        hold: Duration,
    },
    /// Flip the input `changes` times, one flip every `every`, the first at
    /// once: an even number leaves it as it was.
    Chatter {
        name: String,
        changes: u32,
        every: Duration,
    },
}

/// A timed control, starting `delay` after it is given. Its changes happen
/// at their modelled times, not when a thread gets round to them, so a
/// pulse lasts exactly `hold` on the simulated machine.
#[derive(Debug, Clone, PartialEq)]
pub struct TimedControl {
    pub delay: Duration,
    pub what: Timed,
}

impl InputControl {
    /// The input the control acts on.
    pub fn name(&self) -> &str {
        match self {
            InputControl::Set { name, .. }
            | InputControl::Press { name }
            | InputControl::Value { name, .. } => name,
        }
    }
}

/// A controller model driven by the simulator shell.
///
/// Time is always passed in; a model never reads a clock, sleeps or does I/O, so
/// it can be tested with synthetic instants.
pub trait SimDevice: Send + 'static {
    /// The line the device talks on; the shell paces both directions to it.
    fn line(&self) -> LineSettings;

    /// One byte has completely arrived over the wire at `now`.
    fn on_byte(&mut self, byte: u8, now: Instant);

    /// Bring the model up to `now`: motion, dwells, ramps, delayed replies.
    fn advance(&mut self, now: Instant);

    /// When the model next needs `advance` without any input (a move ends, a
    /// processing delay is over); `None` while nothing is pending.
    fn next_deadline(&self) -> Option<Instant>;

    /// The next complete message to put on the wire (a reply, an unsolicited
    /// frame). The shell transmits messages in order, byte by byte at line speed.
    fn poll_output(&mut self) -> Option<Vec<u8>>;

    /// Apply an operator action. `Err` says what was wrong (unknown input name
    /// for this family, with the names that exist).
    fn control(&mut self, control: &InputControl, now: Instant) -> Result<(), String>;

    /// The names `control` understands, for the simulator's `help`.
    fn input_names(&self) -> Vec<&'static str>;

    /// The level the operator's controls left a two-level input at (`true` =
    /// on / closed), so a panel can show it before anyone flipped it.
    /// `None` for a name that is not such an input here (an analogue
    /// channel, a step button, an unknown name).
    fn input_level(&self, name: &str) -> Option<bool>;

    /// One line of state (positions, ports, flags) for the simulator's `show`.
    fn describe(&self, now: Instant) -> String;

    /// `fault stall`: the next long action stays busy without moving and
    /// without reporting ready, until a request ends it. `Err` says why
    /// this device cannot (it has no such actions).
    fn stall_next(&mut self, _now: Instant) -> Result<(), String> {
        Err("`fault stall` needs a device with long actions that report their end (EMP)".into())
    }

    /// How many commands the controller's program store takes from now on
    /// (`memory <n>`): a controller with less memory than its profile says,
    /// or memory partly used. `Err` says why not (a controller that stores no
    /// programs, more than the controller's own memory).
    fn set_program_memory(&mut self, commands: usize) -> Result<(), String> {
        let _ = commands;
        Err("this controller stores no programs".into())
    }
}
