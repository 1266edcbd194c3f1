//! One line of a program check-out on an EMCU (`Request::Checkout`,
//! `docs/editor.md`, "Check-out"): the job line sent as a raw line ended by
//! 0x01 is ([`RawOp`]: checked, its run watched to its end), held while it
//! moves by a lease as a continuous jog is ([`JogLease`], renewed and let
//! go with the jog's requests). When the lease runs out or the key is let
//! go the driver halts (`@B`, manual 1.5.11: the ramp, positions kept, the
//! rest of the move dropped): the line ends `Paused { rest: false }` and
//! the check-out sends what is left of it on the next hold
//! (`program::checkout_emcu::EmcuPlan::rest_of_move`).

use std::time::{Duration, Instant};

use crate::device::api::{Activity, CheckoutEnd, Event, JogId, Refusal};
use crate::device::common::Sink;
use crate::device::common::motion::JogLease;
use crate::proto::emcu::{Reply, Status};

use super::context::Context;
use super::op::{Abandon, Next, Operation};
use super::raw::{RawOp, parse_raw};

#[derive(Debug)]
pub struct CheckoutOp {
    id: JogId,
    raw: RawOp,
    moves: bool,
    lease: JogLease,
    lease_len: Duration,
    pausing: bool,
    dead_man: bool,
    stopped: bool,
    reported: bool,
}

impl CheckoutOp {
    pub fn new(
        cx: &Context,
        id: JogId,
        line: &str,
        resume: Option<JogId>,
        lease: (Instant, Duration),
    ) -> Result<CheckoutOp, Refusal> {
        if resume.is_some() {
            return Err(Refusal::Invalid {
                reason: "an EMCU keeps no rest of a halted move: send what is left of it".into(),
            });
        }
        let parsed = parse_raw(line)?;
        let moves = parsed.command.may_move();
        Ok(CheckoutOp {
            id,
            raw: RawOp::new(cx, parsed)?,
            moves,
            lease: JogLease::new(id, lease.0),
            lease_len: lease.1,
            pausing: false,
            dead_man: false,
            stopped: false,
            reported: false,
        })
    }

    /// A renewal for line `id`: whether it was this line.
    pub fn renew(&mut self, id: JogId, lease: Duration, now: Instant) -> bool {
        if id != self.id {
            return false;
        }
        if !self.pausing {
            self.lease.until = now + lease.min(self.lease_len);
        }
        true
    }

    /// Line `id` was let go: `Some(true)` when the driver is to halt.
    pub fn release(&mut self, id: JogId) -> Option<bool> {
        if id != self.id {
            return None;
        }
        if !self.moves || self.pausing || self.stopped || self.reported {
            return Some(false);
        }
        self.pausing = true;
        Some(true)
    }

    fn report(&mut self, cx: &mut Context) {
        if self.reported {
            return;
        }
        self.reported = true;
        let end = if self.stopped {
            CheckoutEnd::Stopped
        } else if self.pausing {
            CheckoutEnd::Paused {
                dead_man: self.dead_man,
                rest: false,
            }
        } else {
            CheckoutEnd::Done { byte: None }
        };
        cx.emit(Event::Checkout { id: self.id, end });
    }
}

impl Operation for CheckoutOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        if self.reported {
            return Next::Done;
        }
        let next = self.raw.next(cx, now);
        if matches!(next, Next::Done) {
            self.report(cx);
        }
        next
    }

    fn transmitted(&mut self, cx: &mut Context, now: Instant) {
        self.raw.transmitted(cx, now);
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        self.raw.reply(cx, reply, now);
    }

    fn ready(&mut self, cx: &mut Context, now: Instant) {
        self.raw.ready(cx, now);
    }

    fn status(&mut self, cx: &mut Context, status: Status, now: Instant) {
        self.raw.status(cx, status, now);
    }

    fn lost_reply(&mut self, cx: &mut Context, now: Instant) {
        self.raw.lost_reply(cx, now);
    }

    /// A halt: the check-out's own pause, or the operator's stop.
    fn stop(&mut self, cx: &mut Context, now: Instant) {
        if !self.pausing {
            self.stopped = true;
        }
        self.raw.stop(cx, now);
    }

    fn timer(&self) -> Option<Instant> {
        let lease = (self.moves && !self.pausing && !self.stopped && !self.reported)
            .then_some(self.lease.until);
        match (self.raw.timer(), lease) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) -> bool {
        let overdue = self.raw.on_timer(cx, now);
        if self.moves && !self.pausing && !self.stopped && !self.reported && self.lease.expired(now)
        {
            self.pausing = true;
            self.dead_man = true;
            return true;
        }
        overdue
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        self.raw.abandon(cx, cause);
        if !self.reported {
            self.reported = true;
            let end = match cause {
                Abandon::LinkLost(_) => CheckoutEnd::LinkLost,
                Abandon::Reset => CheckoutEnd::Stopped,
            };
            cx.emit(Event::Checkout { id: self.id, end });
        }
    }

    fn activity(&self) -> Activity {
        self.raw.activity()
    }
}
