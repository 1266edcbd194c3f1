//! Conversation tests of the EMCU device model: what a console sends, what
//! the interface answers and when, on a synthetic clock.

mod harness;

mod errors;
mod homing;
mod io;
mod master;
mod memory;
mod motion;
mod props;
mod rom;
mod stops;
