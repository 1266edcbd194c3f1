//! The command line.

pub mod tui;
