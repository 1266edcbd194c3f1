//! Jogging, as pure logic: which requests a key press, repeat or release
//! becomes ([`pad`]), whether motion may be asked for now ([`gate`]), and
//! how fast a jog may run so that it stops within the profile's bound when
//! the operator lets go (the arithmetic is `crate::motion::overrun`, which
//! the drivers share). Sans-IO: time is an argument, nothing
//! here reads a clock or talks to the device; the keypad panel
//! (`ui::jog`) feeds it and hands its requests to the device task, which
//! holds every jog on a lease (the dead-man). `docs/jogging.md` explains the
//! design and its measurements.

pub mod gate;
pub mod held;
pub mod pad;
pub mod settings;
pub mod vector;

pub use gate::{Gate, Motion};
pub use held::{Arrival, HeldKey};
pub use pad::{ActiveJog, JogKind, Jogger, KeyPhase, LastOutcome, Selection};
pub use settings::{JogAxis, JogSettings};
pub use vector::Vector;

#[cfg(test)]
mod tests;
