//! Work offsets: six named work coordinate systems, G54 to G59, as LinuxCNC,
//! bCNC and UGS operators know them (`docs/jogging.md`, "Work offsets").
//!
//! - [`table`]: the systems and which one is active; each work zero is a
//!   machine position in steps from the reference point (the one source
//!   of truth for work coordinates: the position display, go-to, the work
//!   zero moves and "set X = 10 here" all count from it).
//! - [`file`]: the state file as text, sans-IO: written with what
//!   identifies the machine (profile, family, port, each axis' unit and
//!   steps per unit), read back only when all of that still holds; a file
//!   of another machine or of other steps per unit is refused with what
//!   differs, a broken one with its line and column. Never applied silently.
//! - [`store`]: the small file layer: where the file lives (the state
//!   directory, per profile and port), reading it, writing it atomically on
//!   a thread of its own, a refused file put aside before the first write.
//!
//! - [`tools`]: the tool-length offsets measured on the tool sensor, kept
//!   beside the work offsets.
//!
//! The controller's own zero (isel `@0n`, manual 2.2.19) is not this: it can
//! only be set where the axis stands, and stored programs count from it.
//! How the two relate is in `docs/protocols.md` (isel) and the console keeps
//! them together where it can (`ui::jog::offsets`).

pub mod file;
pub mod store;
pub mod tools;

pub use file::{Identity, Loaded};
// The table of work zeros is part of the G-code core (jogterm-gcode); the
// state file and its store are the application's.
pub use jogterm_gcode::offsets::{MAX_ZERO_STEPS, System, WorkOffsets};
