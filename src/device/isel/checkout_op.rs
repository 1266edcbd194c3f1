//! One line of a program check-out (`Request::Checkout`, `docs/editor.md`,
//! "Check-out"): a DNC line sent as a raw line is ([`RawOp`]: checked,
//! its deadline and position estimate, what it changes in the controller
//! followed), held while it moves by a lease as a continuous jog is
//! ([`JogLease`], renewed and let go with the jog's requests).
//!
//! When the lease runs out or the key is let go the move is **paused**, not
//! broken off: 0xFD alone ramps it down without step loss and the
//! controller keeps its rest, which `@0S` finishes (manual 2.2.31;
//! `docs/decisions.md` isel 6). That is the one place jogterm sends
//! 0xFD without 0xFF, and the driver remembers whose rest is held
//! (`Context::checkout_rest`) so that an `@0S` goes out only while it is:
//! with no rest held `@0S` would start the stored program (manual 2.2.23).
//! A stop (Space) is the full stop sequence as everywhere: nothing is kept.

use std::time::{Duration, Instant};

use crate::device::api::{Activity, CheckoutEnd, Event, JogId, Refusal};
use crate::device::common::motion::JogLease;
use crate::proto::isel::{ControlByte, Reply, ReplyCode, SyncChar};

use super::context::{Context, control_outgoing};
use super::op::{Abandon, Next, Operation};
use super::raw::RawOp;

#[derive(Debug)]
pub struct CheckoutOp {
    id: JogId,
    raw: RawOp,
    lease: JogLease,
    /// The lease the line started with: renewals get no longer one (the
    /// speeds were capped for it).
    lease_len: Duration,
    /// The last byte of the line has gone out.
    sent: bool,
    /// 0xFD has gone out for the pause; `repause`: again once the line is
    /// out (a command completed after a control byte still runs).
    pausing: bool,
    repause: bool,
    dead_man: bool,
    stopped: bool,
    end: Option<CheckoutEnd>,
    reported: bool,
}

impl CheckoutOp {
    /// A line of a stream: see [`RawOp::skip_read_back`].
    pub fn skip_read_back(&mut self) {
        self.raw.skip_read_back();
    }

    /// `held`: the rest the driver holds (taken from it: whatever starts
    /// now, the rest is gone unless this line resumes it).
    pub fn new(
        cx: &Context,
        id: JogId,
        line: &str,
        resume: Option<JogId>,
        held: Option<JogId>,
        lease: (Instant, Duration),
    ) -> Result<CheckoutOp, Refusal> {
        let mut raw = RawOp::for_checkout(cx, line)?;
        if raw.moves() {
            cx.raw_motion_allowed()?;
        }
        if let Some(paused) = resume {
            if held != Some(paused) {
                return Err(Refusal::Invalid {
                    reason: "the rest of the paused move is no longer held by the controller \
                             (something else ran since): run the line again"
                        .into(),
                });
            }
            let timeout = raw.timeout();
            raw = RawOp::for_checkout(cx, &format!("@{}S", cx.device))?;
            raw.set_timeout(timeout);
        }
        Ok(CheckoutOp {
            id,
            raw,
            lease: JogLease::new(id, lease.0),
            lease_len: lease.1,
            sent: false,
            pausing: false,
            repause: false,
            dead_man: false,
            stopped: false,
            end: None,
            reported: false,
        })
    }

    fn holds(&self) -> bool {
        self.raw.moves() && !self.stopped
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

    /// Line `id` was let go (or its lease ran out): pause it. Whether it was
    /// this line.
    pub fn release(&mut self, cx: &mut Context, id: JogId, dead_man: bool) -> bool {
        if id != self.id {
            return false;
        }
        if !self.holds() || self.pausing || self.end.is_some() {
            return true;
        }
        if !self.raw.waiting() {
            // Never handed out: it does not start.
            self.end = Some(CheckoutEnd::Paused {
                dead_man,
                rest: false,
            });
            self.report(cx);
            return true;
        }
        self.pausing = true;
        self.dead_man = dead_man;
        cx.control
            .push_back(control_outgoing(ControlByte::SoftStop));
        self.repause = !self.sent;
        true
    }

    fn report(&mut self, cx: &mut Context) {
        if self.reported {
            return;
        }
        self.reported = true;
        let end = self.end.clone().unwrap_or(CheckoutEnd::Stopped);
        if matches!(end, CheckoutEnd::Paused { rest: true, .. }) {
            cx.checkout_rest = Some(self.id);
        }
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
        self.sent = true;
        if std::mem::take(&mut self.repause) {
            cx.control
                .push_back(control_outgoing(ControlByte::SoftStop));
        }
        self.raw.transmitted(cx, now);
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        if self.raw.waiting() {
            self.end = Some(match &reply {
                Reply::Code(ReplyCode::Ok) => CheckoutEnd::Done { byte: None },
                Reply::Byte(v) => CheckoutEnd::Done { byte: Some(*v) },
                Reply::Code(ReplyCode::UserStop) if self.stopped => CheckoutEnd::Stopped,
                Reply::Code(ReplyCode::UserStop) if self.pausing => CheckoutEnd::Paused {
                    dead_man: self.dead_man,
                    rest: true,
                },
                Reply::Code(ReplyCode::UserStop) => {
                    // The controller's stop key: its rest is discarded as
                    // after any move (isel decision 6); the check-out stops.
                    cx.control.push_back(control_outgoing(ControlByte::Break));
                    cx.notice("the check-out was stopped at the controller (stop key)");
                    CheckoutEnd::Stopped
                }
                Reply::Code(code) => {
                    CheckoutEnd::Fault(cx.controller_error(self.raw.text(), *code))
                }
                other => {
                    CheckoutEnd::Fault(cx.link_suspect(self.raw.text(), &format!("{other:?}")))
                }
            });
            if self.pausing || self.stopped {
                // A stray second `F` must not be taken for the next reply.
                cx.quiet_request = Some(cx.settings.timing.resync_gap);
            }
        }
        self.raw.reply(cx, reply, now);
    }

    fn sync(&mut self, cx: &mut Context, sync: SyncChar, now: Instant) {
        self.raw.sync(cx, sync, now);
    }

    fn lost_reply(&mut self, cx: &mut Context, now: Instant) {
        self.raw.lost_reply(cx, now);
        if self.end.is_none() {
            self.end = Some(CheckoutEnd::Fault(
                cx.link_suspect(self.raw.text(), "garbled reply"),
            ));
        }
        self.report(cx);
    }

    fn stop(&mut self, cx: &mut Context, now: Instant) -> Option<Duration> {
        self.stopped = true;
        if !self.raw.waiting() && self.end.is_none() {
            // Never handed out: it does not start.
            self.end = Some(CheckoutEnd::Stopped);
            self.report(cx);
        }
        self.raw.stop(cx, now)
    }

    fn timer(&self) -> Option<Instant> {
        let lease =
            (self.holds() && !self.pausing && self.raw.waiting()).then_some(self.lease.until);
        match (self.raw.timer(), lease) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) -> bool {
        self.raw.on_timer(cx, now);
        if self.holds() && !self.pausing && self.raw.waiting() && self.lease.expired(now) {
            let id = self.id;
            self.release(cx, id, true);
        }
        false
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        self.raw.abandon(cx, cause);
        if !self.reported {
            self.end = Some(match cause {
                Abandon::LinkLost(_) => CheckoutEnd::LinkLost,
                Abandon::Reset => CheckoutEnd::Stopped,
            });
            self.report(cx);
        }
    }

    fn activity(&self) -> Activity {
        match self.raw.activity() {
            Activity::Moving | Activity::RunningProgram | Activity::Homing if self.pausing => {
                Activity::Stopping
            }
            // `@0S` resumes a move here, it starts no program.
            Activity::RunningProgram => Activity::Moving,
            other => other,
        }
    }
}
