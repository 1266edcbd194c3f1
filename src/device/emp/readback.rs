//! State read-back on connect: for every drive the last error (`0A`), the
//! position (`2C`) and the switches and inputs (`40 01`). A drive that
//! answers "not switched on" is not initialised; nothing is sent that moves.

use std::time::Instant;

use crate::device::api::Activity;
use crate::proto::emp::{Command, Reply, ReplyBody, Request};

use crate::device::common::Sink;

use super::context::Context;
use super::io::snapshot;
use super::op::Operation;
use super::script::{Next, Outcome, Script};

#[derive(Debug)]
pub struct Readback {
    script: Script,
    reported: bool,
}

impl Readback {
    pub fn new(cx: &Context) -> Readback {
        let mut frames = Vec::new();
        for ds in cx.addresses() {
            frames.push(Request::new(ds, Command::LastError));
            frames.push(Request::new(ds, Command::ReadPosition));
            frames.push(Request::new(ds, Command::ReadInputs));
        }
        Readback {
            script: Script::sends(frames),
            reported: false,
        }
    }

    fn report(&mut self, cx: &mut Context, now: Instant) {
        if self.reported {
            return;
        }
        self.reported = true;
        // A drive that is not on lost its reference with its power (or was
        // never referenced in this session); one that stayed on keeps it.
        for d in cx.drives.clone() {
            if d.on != Some(true) {
                cx.unreference(d.axis);
            }
        }
        cx.refresh();
        cx.position_complete(now);
        let io = snapshot(&cx.drives, &cx.settings.wiring, now);
        cx.emit(crate::device::api::Event::Io(io));
        let drives: Vec<String> = cx
            .drives
            .iter()
            .map(|d| {
                let on = match d.on {
                    Some(true) => "on",
                    Some(false) => "not switched on",
                    None => "unknown",
                };
                let pos = d
                    .position
                    .map_or_else(|| "position unknown".to_owned(), |p| format!("at {p}"));
                format!("drive {} ({}) {on}, {pos}", d.ds, d.axis)
            })
            .collect();
        cx.notice(format!("state read back: {}", drives.join("; ")));
    }
}

impl Operation for Readback {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        let next = self.script.next();
        if next == Next::Done {
            self.report(cx, now);
        }
        next
    }

    fn outcome(
        &mut self,
        cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        reply: Option<&Reply>,
        _now: Instant,
    ) {
        if let Some(Reply::Ready {
            body: ReplyBody::LastError(code),
            ..
        }) = reply
            && !code.is_none()
        {
            cx.notice(format!(
                "drive {} reports its last error {code}",
                request.ds
            ));
        }
        // A rejection is an answer here: the next drive is still read.
        let outcome = match outcome {
            Outcome::Rejected => Outcome::Answered,
            o => o,
        };
        self.script.outcome(request, outcome);
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request)
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }

    fn stopped(&mut self, _cx: &mut Context, _drives: &[crate::proto::emp::DriveAddress]) {}
}
