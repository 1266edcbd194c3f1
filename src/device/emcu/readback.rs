//! Reading the interface's state back after every (re)connect; nothing
//! moves. `@X` tells the error flag, whether the position is known and
//! whether something runs (manual 1.5.3); then `@LX`, `@LY`, `@LZ`. A
//! position the interface knows counts as referenced for every axis of the
//! machine: there is one flag for all axes (`docs/protocols.md`, EMCU).
//!
//! The start speed, ramp and slot speeds cannot be read (manual 1.5 has no
//! query), so jogterm's own moves wait for `Initialise`, which sets them.

use std::time::Instant;

use crate::axis::AxisSet;
use crate::device::api::Activity;
use crate::device::common::Sink;
use crate::proto::emcu::{Command, Reply, Terminator};

use super::context::Context;
use super::measure::Measure;
use super::op::{Abandon, Next, Operation};

/// Read-backs started over after lost answers before giving up.
const MAX_RESTARTS: u32 = 3;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Status,
    Positions,
    Done,
}

#[derive(Debug)]
pub struct Readback {
    stage: Stage,
    measure: Option<Measure>,
    restarts: u32,
}

impl Readback {
    pub fn new() -> Readback {
        Readback {
            stage: Stage::Status,
            measure: None,
            restarts: 0,
        }
    }

    fn summary(cx: &Context) -> String {
        let status = cx
            .status
            .map_or_else(|| "unknown".to_owned(), |s| s.to_string());
        format!(
            "state read back: @X {status}; axes {} referenced; start speed and ramp {}",
            if cx.state.referenced.is_empty() {
                "none".to_owned()
            } else {
                cx.state.referenced.to_string()
            },
            if cx.ready() {
                "set"
            } else {
                "not set: initialise (i)"
            }
        )
    }
}

impl Default for Readback {
    fn default() -> Self {
        Readback::new()
    }
}

impl Operation for Readback {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        match self.stage {
            Stage::Status => Next::Send(cx.cmd(&Command::Status, Terminator::Cr)),
            Stage::Positions => {
                let measure = self.measure.get_or_insert_with(|| Measure::new(cx));
                match measure.next(cx) {
                    Some(cmd) => Next::Send(cmd),
                    None => {
                        self.stage = Stage::Done;
                        let summary = Readback::summary(cx);
                        cx.notice(summary);
                        Next::Done
                    }
                }
            }
            Stage::Done => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match self.stage {
            Stage::Status => {
                if let Reply::Status(status) = reply {
                    cx.state.referenced = if status.position_unknown {
                        AxisSet::EMPTY
                    } else {
                        cx.settings.axes
                    };
                    cx.status_read(status, now);
                    self.stage = Stage::Positions;
                }
            }
            Stage::Positions => {
                if let Some(m) = self.measure.as_mut() {
                    m.reply(cx, &reply, now);
                }
            }
            Stage::Done => {}
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        self.restarts += 1;
        if self.restarts > MAX_RESTARTS {
            cx.notice("state read-back failed: the interface's state is unknown");
            cx.state.referenced = AxisSet::EMPTY;
            self.stage = Stage::Done;
        } else {
            cx.notice("state read-back starts again: an answer was lost");
            self.stage = Stage::Status;
            self.measure = None;
        }
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.stage = Stage::Done;
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }
}
