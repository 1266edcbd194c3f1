//! EMCU interface on SMC3000 stepper cards: master and buffered commands, CR
//! acknowledgements, the unsolicited ready/memory-full lines.
//!
//! Sans-IO protocol core (manual `emcu-smc3000-programming.de.txt`, chapter 1;
//! `docs/decisions.md`, EMCU; jogterm's own decisions in
//! `docs/protocols.md`, EMCU):
//! - [`values`]: validated parameters (speeds, slots, steps, axes) and ranges;
//! - [`command`]: typed [`Command`]s, master/buffered [`Class`], encoder with an
//!   explicit [`Terminator`];
//! - [`parse`]: text line to [`Command`] with errors that say what was expected
//!   where; [`framer`]: the interface's side, bytes to command lines;
//! - [`reply`], [`status`]: typed [`Reply`]s and the six `@X` flags;
//! - [`decoder`]: streaming reply decoder with resynchronisation;
//! - [`exchange`]: which reply answers a command, and which is unsolicited;
//! - [`job`]: ROM job uploads (`@F`) and data-memory batches.

pub mod command;
pub mod decoder;
pub mod exchange;
pub mod framer;
pub mod job;
pub mod parse;
pub mod reply;
pub mod status;
pub mod values;

#[cfg(test)]
mod tests;

use std::time::Duration;

pub use command::{Class, Command, EncodeError, Move, MoveMode, ReferenceOrder, Terminator};
pub use decoder::{Garbage, GarbageReason, ReplyDecoder, ReplyEvent};
pub use exchange::{Disposition, Expect};
pub use framer::{CommandFramer, Received};
pub use job::{JobError, JobUpload, SequenceLine, job_problems, run_batch};
pub use parse::{Found, ParseError, ParseErrorKind, parse_bytes, parse_line};
pub use reply::{Reply, ReplyError, VersionText};
pub use status::{Status, StatusFlag};
pub use values::{EmcuAxis, Output, RampMillis, Slot, Speed, Steps, ValueError, WaitMillis};

/// Longest time the interface may take to acknowledge a command (manual
/// 1.4.2: "max. 500 msec."). A reader that has waited longer has lost the
/// answer.
pub const MAX_ACK_DELAY: Duration = Duration::from_millis(500);

/// Steps the axis moves off the reference switch after a reference run
/// (manual 1.4.2 defaults; 1.3 lists a command to change it, but 1.5
/// describes none, so jogterm cannot set it).
pub const REFERENCE_OFFSET_STEPS: u32 = 25;
