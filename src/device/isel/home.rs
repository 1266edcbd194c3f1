//! `Home`: reference runs, `@0R<mask>` for X, Y, Z together (the controller
//! runs them Z, Y, X) and A on its own afterwards (manual 2.2.22,
//! `docs/decisions.md` isel 3). A reference run also puts the virtual
//! zero back on the reference point and ends 3D mode (manual 2.2.22).
//!
//! A reference run that was stopped counts as not done, whatever the
//! controller answers: the stop key (and 0xFD) can stand in for the
//! reference switch (manual 2.2.22), so the axis may have been referenced at
//! the wrong place (`docs/protocols.md`, isel).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::axis::AxisSet;
use crate::device::api::Activity;
use crate::proto::isel::{Command, Reply, ReplyCode};

use super::context::Context;
use super::deadline;
use super::op::{Abandon, Next, Operation};

#[derive(Debug)]
pub struct HomeOp {
    masks: VecDeque<AxisSet>,
    running: Option<AxisSet>,
    measure: bool,
    done: bool,
    stopping: bool,
}

impl HomeOp {
    pub fn new(axes: AxisSet) -> HomeOp {
        HomeOp {
            masks: deadline::reference_masks(axes).into(),
            running: None,
            measure: false,
            done: false,
            stopping: false,
        }
    }
}

impl Operation for HomeOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        if self.done {
            return Next::Done;
        }
        if self.measure {
            return Next::Send(cx.cmd(Command::ReadPosition));
        }
        match self.masks.pop_front() {
            Some(mask) => {
                self.running = Some(mask);
                Next::Send(cx.cmd(Command::Reference(mask)))
            }
            None => {
                self.measure = true;
                Next::Send(cx.cmd(Command::ReadPosition))
            }
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        if self.measure {
            cx.position_reply(reply, now);
            self.done = true;
            return;
        }
        let Some(mask) = self.running.take() else {
            return;
        };
        let text = cx.cmd(Command::Reference(mask)).text;
        match reply {
            Reply::Code(ReplyCode::Ok) if !self.stopping => {
                cx.referenced(mask);
                cx.zero_reset(mask);
                cx.three_d = false;
            }
            Reply::Code(ReplyCode::Ok | ReplyCode::UserStop) => {
                cx.state.referenced = AxisSet::from_mask(cx.state.referenced.mask() & !mask.mask());
                cx.notice(format!(
                    "the reference run of {mask} was stopped: {mask} is not referenced"
                ));
                cx.quiet_request = Some(cx.settings.timing.resync_gap);
            }
            Reply::Code(code) => {
                cx.controller_error(&text, code);
                self.masks.clear();
            }
            other => {
                cx.link_suspect(&text, &format!("{other:?}"));
                cx.readback_wanted = true;
                self.masks.clear();
            }
        }
        if self.stopping {
            self.masks.clear();
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        if let Some(mask) = self.running.take() {
            cx.state.referenced = AxisSet::from_mask(cx.state.referenced.mask() & !mask.mask());
        }
        cx.readback_wanted = true;
        self.done = true;
    }

    fn stop(&mut self, cx: &mut Context, _now: Instant) -> Option<Duration> {
        self.stopping = true;
        self.masks.clear();
        self.running.map(|_| {
            let ramp = cx.ramp.ramp(f64::from(cx.reference_hz));
            deadline::motion(ramp.braking_time(f64::from(cx.reference_hz)))
        })
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.done = true;
    }

    fn activity(&self) -> Activity {
        match (self.running.is_some(), self.stopping) {
            (true, true) => Activity::Stopping,
            (true, false) => Activity::Homing,
            _ => Activity::Idle,
        }
    }
}
