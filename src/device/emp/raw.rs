//! Raw frames typed by the operator: validated with the core's
//! `Request::from_str` (16 hex characters, spaces allowed, every field
//! checked) before anything is sent; the answer comes back as
//! `Event::Reply`. A long action (`26`, TP `2A`) keeps the operation alive
//! until its completion, so a stop can end it and nothing starts meanwhile;
//! it has a deadline like a planned one ([`super::deadline`]), and a
//! reference run a stall watchdog ([`super::stall`]). When either fires, the
//! drive is stopped and the fault says why and what to do.

use std::time::{Duration, Instant};

use crate::device::api::{Activity, Event, Refusal};
use crate::proto::emp::{Command, DriveAddress, Reply, Request};

use crate::device::common::Sink;

use super::context::Context;
use super::deadline::{self, GivenUp, LongKind};
use super::op::Operation;
use super::script::{Next, Outcome, Script};
use super::stall::{STILL_READS, StallWatch};

/// How the first answer of a long action (`55`) starts its `Event::Reply`
/// text; the completion follows as another reply to the same frame.
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

/// The frame as typed, for replies and faults.
pub fn frame_text(request: &Request) -> String {
    request.to_frame().to_string()
}

/// What guards a raw long action once it was sent.
#[derive(Debug)]
struct Guard {
    kind: LongKind,
    timeout: Duration,
    deadline: Instant,
    /// Reference runs only.
    watch: Option<StallWatch>,
    /// The `2C` of the watchdog on its way.
    reading: Option<Request>,
    /// Given up: the stop is asked for and the fault told.
    expired: bool,
    /// The operator stopped: nothing more to guard.
    disarmed: bool,
}

impl Guard {
    fn live(&self) -> bool {
        !self.expired && !self.disarmed
    }
}

#[derive(Debug)]
pub struct RawOp {
    request: Request,
    script: Script,
    guard: Option<Guard>,
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

    /// The watchdog's read, when one is due.
    fn watch_read(&mut self, now: Instant) -> Option<Request> {
        let running = self.running();
        let g = self.guard.as_mut().filter(|g| g.live() && running)?;
        let w = g.watch.as_mut()?;
        if w.read_due().is_none_or(|t| t > now) {
            return None;
        }
        w.read_sent();
        let read = Request::new(self.request.ds, Command::ReadPosition);
        g.reading = Some(read);
        Some(read)
    }

    /// Stop the drive (the driver sends the frame ahead of everything),
    /// then tell the operator.
    fn give_up(&mut self, cx: &mut Context, why: GivenUp) {
        let Some(g) = self.guard.as_mut().filter(|g| g.live()) else {
            return;
        };
        g.expired = true;
        let kind = g.kind;
        self.script.cancel();
        self.stops = vec![self.request.ds];
        let _ = deadline::give_up(cx, &self.request, kind, why);
    }

    fn expired(&self) -> bool {
        self.guard.as_ref().is_some_and(|g| g.expired)
    }
}

/// The text of an answer to a raw request.
pub fn reply_text(reply: &Reply) -> String {
    reply.to_string()
}

impl Operation for RawOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        if let Some(read) = self.watch_read(now) {
            return Next::Send(read);
        }
        let next = self.script.next();
        if next == Next::Send(self.request)
            && let Some((kind, timeout)) = deadline::raw(cx, &self.request)
        {
            self.guard = Some(Guard {
                kind,
                timeout,
                deadline: deadline::due(now, timeout),
                watch: (kind == LongKind::Homing).then(|| StallWatch::new(now)),
                reading: None,
                expired: false,
                disarmed: false,
            });
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
            && g.reading.as_ref() == Some(request)
        {
            g.reading = None;
            let position = match outcome {
                Outcome::Answered => cx.drive(request.ds).and_then(|d| d.position),
                _ => None,
            };
            let stalled = g.watch.as_mut().is_some_and(|w| w.sample(position, now));
            if stalled && self.running() {
                self.give_up(cx, GivenUp::Stalled { reads: STILL_READS });
            }
            return;
        }
        self.script.outcome(request, outcome);
        let command = frame_text(request);
        let text = match (outcome, reply) {
            (Outcome::Answered, Some(r)) => reply_text(r),
            (Outcome::Started, Some(r)) => format!("{STARTED}{}", reply_text(r)),
            (Outcome::Completed, Some(r)) => format!("completed: {}", reply_text(r)),
            // Given up: the fault has told what happened.
            (Outcome::Ended, _) if self.expired() => return,
            (Outcome::Ended, _) => "ended by a later request".to_owned(),
            // A rejection is told by the fault with the error code (`0A`).
            _ => return,
        };
        cx.emit(Event::Reply { command, text });
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request)
            || self
                .guard
                .as_ref()
                .is_some_and(|g| g.reading.as_ref() == Some(request))
    }

    fn timer(&self) -> Option<Instant> {
        let g = self.guard.as_ref().filter(|g| g.live())?;
        if self.script.idle() {
            return None;
        }
        if !self.running() {
            // The first answer is awaited: the deadline only.
            return Some(g.deadline);
        }
        let read = g.watch.as_ref().and_then(StallWatch::read_due);
        Some(read.map_or(g.deadline, |r| r.min(g.deadline)))
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) {
        // A due read is sent by `next`; only the deadline acts here.
        let Some(g) = self.guard.as_ref().filter(|g| g.live()) else {
            return;
        };
        if g.deadline <= now {
            let why = GivenUp::Deadline(g.timeout);
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
            g.disarmed = true;
        }
    }

    fn link_lost(&mut self, _cx: &mut Context) {}
}
