//! jogterm: a keyboard-only terminal console for stepper and servo machines on
//! isel, EMCU and EMP serial motion controllers.
//!
//! Layers, from the wire up (see `docs/architecture.md`):
//! - [`proto`]: sans-IO protocol cores, one per controller family.
//! - [`sim`]: built-in simulators of the three controllers.
//! - [`transport`]: serial port, pseudo-terminal, in-process socket pair.
//! - [`program`]: isel CNC programs and EMCU jobs as code: parser, linter,
//!   formatter, path simulation.
//! - [`wire`], [`motion`], [`axis`], [`traffic`]: shared arithmetic and types.
//! - [`jog`]: jogging as pure logic: keys to requests, leases, speed caps.
//! - [`ui`]: the terminal UI (Elm architecture: model, update, view).

// stdout and stderr only through `cli::out` (or a `Write` whose errors are
// handled): `println!` and `eprintln!` panic on a closed stdout/stderr.
// Tests may print.
#![cfg_attr(not(test), deny(clippy::print_stdout, clippy::print_stderr))]

pub mod axis;
pub mod cli;
pub mod config;
pub mod device;
pub mod jog;
pub mod motion;
pub mod program;
pub mod proto;
pub mod sim;
pub mod traffic;
pub mod transport;
pub mod ui;
pub mod wire;
