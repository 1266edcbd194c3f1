//! What the jog screen reads of the rest of the console ([`Context`]) and
//! what its notes are ([`Note`]): a leaf, used by the keypad's state and by
//! the component above it (`component`), so that neither imports the other
//! for them.

use std::time::Instant;

use crate::device::api::{LinkState, MachineState};

use super::super::position::Positions;
use super::super::setup::Setup;

/// A line for the message line (and the console), from the keypad.
pub use super::super::outcome::Note;

/// What the jog screen may read of the rest of the console, for one update
/// or one frame. Built fresh each time from the model; never kept.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The machine as the profile describes it: protocol, axes, jog steps
    /// and speeds.
    pub setup: &'a Setup,
    pub link: &'a LinkState,
    /// What the controller last reported: activity, references, the
    /// controller's own zero.
    pub machine: &'a MachineState,
    /// The axes' positions as last reported (measured or estimated).
    pub positions: &'a Positions,
    /// The model's time (the last tick or key).
    pub now: Instant,
}
