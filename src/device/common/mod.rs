//! Driver pieces that are the same for every controller family: what a
//! request may do given the machine state, how far a jog may go, how steps
//! are coalesced and leases kept, how polls are scheduled and counted, how
//! requests wait for their turn. Each family's driver (`isel`, `emcu`, `emp`)
//! supplies what only it knows (commands, replies, timing of its line) and
//! uses these for the rest, so the behaviour a client sees is one behaviour.
//!
//! Sans-IO like the drivers: time comes in as `Instant` arguments, events go
//! out through a [`Sink`].
//!
//! - [`core`]: the driver core, what every family's driver does the same
//!   way, and [`core::Family`], what a family says of its own.
//! - [`sink`]: where events go; refusals in the shape every driver uses.
//! - [`admit`]: what runs when a request arrives, coalescing a step into it,
//!   the start of a typed raw line.
//! - [`settings`]: profile values every family converts the same way (axis
//!   limits in steps, jog settings), and the settings error.
//! - [`limits`]: axes of the machine, soft limits, speed caps.
//! - [`vector`]: a jog's travel towards the soft limits along its speed vector.
//! - [`op`]: the skeleton of the operations a driver runs one at a time
//!   ([`op::Next`], [`op::Abandon`], the enum of them: `operations!`).
//! - [`motion`]: a running move's kind (step, go-to, jog), its jog lease and
//!   its end, and the steps coalesced behind it.
//! - [`jog_speed`]: a jog's speed following its lease (granted leases, the
//!   speed-up at the first short renewal).
//! - [`gate`]: refusals of motion from the machine state.
//! - [`limit_jog`]: the jog off a limit switch: its refusals, where it
//!   stands after a reading of the switches.
//! - [`queue`]: requests waiting for their turn, and what is refused at once.
//! - [`route`]: where each request goes in a driver (`Driver::request`).
//! - [`poll`]: poll rates, cycles, statistics.
//! - [`upload`]: progress of a program upload.
//! - [`link`]: declaring a silent link dead.
//! - [`deadline`]: reply and move deadlines from physics.
//! - [`io`]: building `IoSnapshot` groups.
//! - [`state`]: telling the clients when the machine state changed.

pub mod admit;
#[cfg(test)]
mod behaviour;
pub mod core;
pub mod deadline;
pub mod gate;
pub mod io;
pub mod jog_speed;
pub mod limit_jog;
pub mod limits;
pub mod link;
pub mod motion;
pub mod op;
pub mod poll;
pub mod probe;
pub mod queue;
pub mod route;
pub mod settings;
pub mod sink;
pub mod state;
#[cfg(test)]
pub mod testing;
pub mod upload;
pub mod vector;

pub use admit::RunningMove;
pub use limits::AxisLimits;
pub use motion::{MotionKind, StepQueue};
pub use poll::{PollPlan, PollRate, Poller, Polling};
pub use queue::{Queued, RequestQueue, Running};
pub use settings::{JogSettings, SettingsError};
pub use sink::Sink;
pub use state::StateReport;
