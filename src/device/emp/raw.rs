//! Raw frames typed by the operator: validated with the core's
//! `Request::from_str` (16 hex characters, spaces allowed, every field
//! checked) before anything is sent; the answer comes back as
//! `Event::Reply`. A long action (`26`, TP `2A`) keeps the operation alive
//! until its completion, so a stop can end it and nothing starts meanwhile;
//! it is guarded like a planned one ([`super::guard`]: a deadline, and a
//! reference run a stall watchdog). When either fires, the drive is stopped
//! and the fault says why and what to do.

use std::time::Instant;

use crate::device::api::{Activity, Event, Refusal, ReplyKind};
use crate::proto::emp::{Command, DriveAddress, Reply, Request};

use crate::device::common::Sink;

use super::context::Context;
use super::deadline::GivenUp;
use super::guard::LongGuard;
use super::op::Operation;
use super::script::{Next, Outcome, Script};

/// How the first answer of a long action (`55`) starts its `Event::Reply`
/// text (of kind `ReplyKind::Started`); the completion follows as another
/// reply to the same frame.
pub const STARTED: &str = "started: ";

/// Parse a raw line; the error names what is wrong with it.
pub fn parse_raw(line: &str) -> Result<Request, Refusal> {
    line.trim()
        .parse::<Request>()
        .map_err(|e| Refusal::Invalid {
            reason: format!("not an EMP request: {e}"),
        })
}

/// Queries that change nothing: they may go between an operation's frames.
pub fn is_query(command: &Command) -> bool {
    matches!(
        command,
        Command::Identify(_)
            | Command::LastError
            | Command::ReadPosition
            | Command::ReadInputs
            | Command::ReadAdc(_)
            | Command::ReadTime
            | Command::ReadDate
            | Command::EepromRead { .. }
    )
}

pub use super::script::frame_text;

#[derive(Debug)]
pub struct RawOp {
    request: Request,
    script: Script,
    guard: Option<LongGuard>,
    stops: Vec<DriveAddress>,
}

impl RawOp {
    pub fn new(cx: &Context, request: Request) -> Result<RawOp, Refusal> {
        if request.command.may_move() {
            cx.faults_allow()?;
        }
        Ok(RawOp {
            request,
            script: Script::sends([request]),
            guard: None,
            stops: Vec::new(),
        })
    }

    /// The long action is running: its `55` came, its end has not.
    fn running(&self) -> bool {
        self.script.running().contains(&self.request)
    }

    /// Stop the drive (the driver sends the frame ahead of everything),
    /// then tell the operator.
    fn give_up(&mut self, cx: &mut Context, why: GivenUp) {
        let Some(g) = self.guard.as_mut().filter(|g| g.live()) else {
            return;
        };
        self.script.cancel();
        self.stops = vec![self.request.ds];
        let _ = g.give_up(cx, why);
    }

    fn given_up(&self) -> bool {
        self.guard.as_ref().is_some_and(LongGuard::given_up)
    }
}

/// The text of an answer to a raw request.
pub fn reply_text(reply: &Reply) -> String {
    reply.to_string()
}

impl Operation for RawOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        let running = self.running();
        if let Some(read) = self.guard.as_mut().and_then(|g| g.read(cx, running, now)) {
            return Next::Send(read);
        }
        let next = self.script.next();
        if next == Next::Send(self.request) {
            self.guard = LongGuard::arm(cx, &self.request, now);
        }
        next
    }

    fn outcome(
        &mut self,
        cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        reply: Option<&Reply>,
        now: Instant,
    ) {
        if let Some(g) = self.guard.as_mut()
            && g.is_read(request)
        {
            if let Some(why) = g.read_answered(cx, outcome, now)
                && self.running()
            {
                self.give_up(cx, why);
            }
            return;
        }
        self.script.outcome(request, outcome);
        let command = frame_text(request);
        let (text, kind) = match (outcome, reply) {
            (Outcome::Answered, Some(r)) => (reply_text(r), ReplyKind::Answer),
            (Outcome::Started, Some(r)) => {
                (format!("{STARTED}{}", reply_text(r)), ReplyKind::Started)
            }
            (Outcome::Completed, Some(r)) => {
                (format!("completed: {}", reply_text(r)), ReplyKind::Answer)
            }
            // Given up: the fault has told what happened.
            (Outcome::Ended, _) if self.given_up() => return,
            (Outcome::Ended, _) => ("ended by a later request".to_owned(), ReplyKind::Answer),
            // A rejection is told by the fault with the error code (`0A`).
            _ => return,
        };
        cx.emit(Event::Reply {
            command,
            text,
            kind,
        });
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request) || self.guard.as_ref().is_some_and(|g| g.is_read(request))
    }

    fn timer(&self) -> Option<Instant> {
        if self.script.idle() {
            return None;
        }
        self.guard.as_ref()?.timer()
    }

    fn send_due(&self) -> Option<Instant> {
        self.guard.as_ref()?.read_due(self.running())
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) {
        // A due read is sent by `next`; only the deadline acts here.
        if let Some(why) = self.guard.as_ref().and_then(|g| g.expired(now)) {
            self.give_up(cx, why);
        }
    }

    fn polled(&mut self, cx: &mut Context, ds: DriveAddress, now: Instant) {
        if !self.running() {
            return;
        }
        if let Some(why) = self.guard.as_mut().and_then(|g| g.polled(cx, ds, now)) {
            self.give_up(cx, why);
        }
    }

    fn take_stops(&mut self) -> Vec<DriveAddress> {
        std::mem::take(&mut self.stops)
    }

    fn activity(&self) -> Activity {
        if self.request.command.may_move() && !self.script.idle() {
            Activity::Moving
        } else {
            Activity::Idle
        }
    }

    fn stopped(&mut self, _cx: &mut Context, _drives: &[DriveAddress]) {
        // What runs is ended by the stop frames (the correlator's `Ended`).
        self.script.cancel();
        if let Some(g) = self.guard.as_mut() {
            g.disarm();
        }
    }

    fn link_lost(&mut self, _cx: &mut Context) {}
}
