//! The fault-injection suite's harness (`docs/faults.md`): a simulator
//! process operated on its stdin ([`sim`]), the real console in a pty
//! ([`console`]), what the controller received split into commands
//! ([`wire`]), and the runner that runs the scenarios and prints the totals
//! ([`runner`]).

#![allow(dead_code)]

#[path = "../ui_pty/mod.rs"]
pub mod ui_pty;

pub mod console;
pub mod runner;
pub mod sim;
pub mod wire;

use std::time::Duration;

pub const JOGTERM: &str = env!("CARGO_BIN_EXE_jogterm");

/// Every wait of the suite is bounded by this: generous under load, and a
/// hang still ends the scenario.
pub const WAIT: Duration = Duration::from_secs(20);

/// Whether a process' output carries a Rust panic message.
pub fn contains_panic(output: &[u8]) -> bool {
    output.windows(b"panicked".len()).any(|w| w == b"panicked")
}
