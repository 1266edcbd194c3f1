//! Raw frames typed by the operator: validated with the core's
//! `Request::from_str` (16 hex characters, spaces allowed, every field
//! checked) before anything is sent; the answer comes back as
//! `Event::Reply`. A long action (`26`, TP `2A`) keeps the operation alive
//! until its completion, so a stop can end it and nothing starts meanwhile.

use std::time::Instant;

use crate::device::api::{Activity, Event, Refusal};
use crate::proto::emp::{Command, DriveAddress, Reply, Request};

use crate::device::common::Sink;

use super::context::Context;
use super::op::Operation;
use super::script::{Next, Outcome, Script};

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

#[derive(Debug)]
pub struct RawOp {
    request: Request,
    script: Script,
}

impl RawOp {
    pub fn new(cx: &Context, request: Request) -> Result<RawOp, Refusal> {
        if request.command.may_move() {
            cx.faults_allow()?;
        }
        Ok(RawOp {
            request,
            script: Script::sends([request]),
        })
    }
}

/// The text of an answer to a raw request.
pub fn reply_text(reply: &Reply) -> String {
    reply.to_string()
}

impl Operation for RawOp {
    fn next(&mut self, _cx: &mut Context, _now: Instant) -> Next {
        self.script.next()
    }

    fn outcome(
        &mut self,
        cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        reply: Option<&Reply>,
        _now: Instant,
    ) {
        self.script.outcome(request, outcome);
        let command = frame_text(request);
        let text = match (outcome, reply) {
            (Outcome::Answered, Some(r)) => reply_text(r),
            (Outcome::Started, Some(r)) => format!("{STARTED}{}", reply_text(r)),
            (Outcome::Completed, Some(r)) => format!("completed: {}", reply_text(r)),
            (Outcome::Ended, _) => "ended by a later request".to_owned(),
            // A rejection is told by the fault with the error code (`0A`).
            _ => return,
        };
        cx.emit(Event::Reply { command, text });
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request)
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
    }

    fn link_lost(&mut self, _cx: &mut Context) {}
}
