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
#[path = "../sim_process/mod.rs"]
pub mod sim;
pub mod wire;

pub use sim::{JOGTERM, WAIT, contains_panic};
