//! The operations the EMCU driver runs, one at a time: each is a small state
//! machine that says which line comes next and what an answer means. The
//! driver (`mod.rs`) owns the line discipline (one line until it is
//! acknowledged, manual 1.4.2; deadlines; polls while an operation waits for
//! its run); an operation owns the meaning.

use std::time::Instant;

use crate::device::api::Activity;
use crate::proto::emcu::{Reply, Status};

use super::context::{Cmd, Context};

pub use crate::device::common::op::Abandon;

/// What an operation wants next: a command line ([`Cmd`]) to send.
pub type Next = crate::device::common::op::Next<Cmd>;

pub trait Operation: Send + std::fmt::Debug {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next;

    /// The last byte of this operation's current line has gone out.
    fn transmitted(&mut self, _cx: &mut Context, _now: Instant) {}

    /// The answer to this operation's line.
    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant);

    /// 0x02 CR: a run has finished, or the data memory has room again
    /// (manual 1.4.2, decision 1).
    fn ready(&mut self, _cx: &mut Context, _now: Instant) {}

    /// An `@X` read by a poll while the operation waits.
    fn status(&mut self, _cx: &mut Context, _status: Status, _now: Instant) {}

    /// The answer did not fit or was garbled: the line's outcome is unknown.
    fn lost_reply(&mut self, cx: &mut Context, now: Instant);

    /// The operator stopped everything (`@B` is on its way).
    fn stop(&mut self, _cx: &mut Context, _now: Instant) {}

    /// When `on_timer` is due.
    fn timer(&self) -> Option<Instant> {
        None
    }

    /// Returns true when the operation wants `@B` sent (a jog's lease ran
    /// out, a run is overdue).
    fn on_timer(&mut self, _cx: &mut Context, _now: Instant) -> bool {
        false
    }

    /// The link is gone or the interface was reset: the operation ends
    /// without another byte.
    fn abandon(&mut self, cx: &mut Context, cause: &Abandon);

    fn activity(&self) -> Activity;
}
