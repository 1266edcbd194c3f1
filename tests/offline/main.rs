//! Tests that run in memory only: `update()` with message sequences, views
//! on ratatui's `TestBackend` with insta snapshots, the program languages.
//! No process, no terminal, no socket, no wall clock: every test may run on
//! any thread beside any other.
//!
//! One test crate: each crate links the whole of jogterm, so these share one
//! binary (docs/architecture.md, "Tests").

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod ui_support;

mod checkout_ui;
mod editor_gcode;
mod editor_update;
mod frame_ui;
mod gcode_golden;
mod jog_keypad;
mod jog_limit_ui;
mod jog_ui;
mod offsets_ui;
mod operator_ui;
mod program_examples;
mod program_format;
mod program_lint;
mod program_parse;
mod program_path;
mod program_sim;
mod ui_layout;
mod ui_snapshots;
mod ui_timeline;
mod ui_typing;
mod ui_update;
