//! jogterm: a keyboard-only terminal console for stepper and servo machines on
//! isel, EMCU and EMP serial motion controllers.
//!
//! Layers, from the wire up (`docs/architecture.md`, "Layer order"; a module
//! uses only the layers below it, checked by the test in `src/layers.rs`):
//! - [`wire`], [`motion`], [`axis`], [`traffic`]: shared arithmetic and types
//!   (step-motor ramps and the jog overrun caps in [`motion`]).
//! - [`proto`]: sans-IO protocol cores, one per controller family.
//! - [`wiring`]: what each controller bit is wired to (names, roles, limit
//!   switches' axis and side), the manuals' tables patched by a profile.
//! - [`config`]: machine profiles and themes.
//! - [`transport`]: serial port, pseudo-terminal, in-process socket pair.
//! - [`sim`]: built-in simulators of the three controllers.
//! - [`device`]: the drivers and the one task that owns the port.
//! - [`program`]: isel CNC programs and EMCU jobs as code: parser, linter,
//!   formatter, path simulation.
//! - [`jog`]: jogging as pure logic: keys to requests, leases.
//! - [`offsets`]: work offsets G54-G59 and their state file.
//! - [`gcode`]: G-code from CAM: reader, interpreter, the machine check and
//!   each family's output.
//! - [`ui`]: the terminal UI (Elm architecture: model, update, view).
//! - [`cli`]: the commands.

// stdout and stderr only through `cli::out` (or a `Write` whose errors are
// handled): `println!` and `eprintln!` panic on a closed stdout/stderr.
// Tests may print.
#![cfg_attr(not(test), deny(clippy::print_stdout, clippy::print_stderr))]

pub mod cli;
pub mod config;
pub mod device;
pub mod gcode;
pub mod joblog;
pub mod jog;
#[cfg(test)]
mod layers;
pub mod offsets;
pub mod probing;
pub mod program;
pub mod sim;
pub mod traffic;
pub mod transport;
pub mod ui;

// The protocol cores live in their own crate (crates/jogterm-proto), with no
// runtime, terminal or serial library; the application names them where they
// always were.
pub use jogterm_proto as proto;
pub use jogterm_proto::{axis, motion, wire, wiring};
