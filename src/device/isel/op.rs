//! The operations the isel driver runs, one at a time: each is a small state
//! machine that says which command comes next and what a reply means. The
//! driver (`mod.rs`) owns the line discipline (one command at a time,
//! deadlines, polling between operations); an operation owns the meaning.

use std::time::{Duration, Instant};

use crate::device::api::Activity;
use crate::proto::isel::{Reply, SyncChar};

use super::context::{Cmd, Context};

pub use crate::device::common::op::Abandon;

/// What an operation wants next: a command line ([`Cmd`]) to send.
pub type Next = crate::device::common::op::Next<Cmd>;

pub trait Operation: Send + std::fmt::Debug {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next;

    /// The last byte of this operation's current command has gone out.
    fn transmitted(&mut self, _cx: &mut Context, _now: Instant) {}

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant);

    /// A sync character of a running program (manual 3.2.3).
    fn sync(&mut self, _cx: &mut Context, _sync: SyncChar, _now: Instant) {}

    /// The reply was garbled or cut short: the command's outcome is unknown.
    fn lost_reply(&mut self, cx: &mut Context, now: Instant);

    /// The operator stopped everything (0xFD 0xFF are on their way). Returns
    /// the time the outstanding reply may still take, if the stop changes it
    /// (a move brakes).
    fn stop(&mut self, _cx: &mut Context, _now: Instant) -> Option<Duration> {
        None
    }

    /// When `on_timer` is due.
    fn timer(&self) -> Option<Instant> {
        None
    }

    /// Returns true when the operation wants the stop sequence sent (a jog's
    /// lease ran out).
    fn on_timer(&mut self, _cx: &mut Context, _now: Instant) -> bool {
        false
    }

    /// The link is gone or the controller was reset: the operation ends
    /// without another byte.
    fn abandon(&mut self, cx: &mut Context, cause: &Abandon);

    fn activity(&self) -> Activity;
}
