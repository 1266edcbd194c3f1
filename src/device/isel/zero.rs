//! `SetZero`: `@0n<mask>` makes the current position the virtual zero of the
//! masked axes, A on its own (manual 2.2.19). `@0P` keeps reporting machine
//! coordinates; the virtual zero shifts the targets of `@0M`, which the
//! driver tracks as `work_zero` (machine steps). Each `@0n` is followed by
//! a `@0P`, which shows a controller that reports positions from the new
//! zero instead (checked at run time: `Context::zero_set`).

use std::collections::VecDeque;
use std::time::Instant;

use crate::axis::AxisSet;
use crate::device::api::Activity;
use crate::proto::isel::{Command, Reply, ReplyCode};

use super::context::Context;
use super::deadline;
use super::op::{Abandon, Next, Operation};

#[derive(Debug)]
pub struct ZeroOp {
    masks: VecDeque<AxisSet>,
    running: Option<AxisSet>,
    /// `@0P` is read right after each `@0n`: whether the controller reports
    /// positions from the new zero shows there (`Context::zero_set`).
    measure: bool,
    measuring: bool,
    done: bool,
}

impl ZeroOp {
    pub fn new(axes: AxisSet) -> ZeroOp {
        ZeroOp {
            // The same rule as for reference masks: A only on its own.
            masks: deadline::reference_masks(axes).into(),
            running: None,
            measure: false,
            measuring: false,
            done: false,
        }
    }
}

impl Operation for ZeroOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        if self.done {
            return Next::Done;
        }
        if std::mem::take(&mut self.measure) {
            self.measuring = true;
            return Next::Send(cx.cmd(Command::ReadPosition));
        }
        match self.masks.pop_front() {
            Some(mask) => {
                self.running = Some(mask);
                Next::Send(cx.cmd(Command::SetZero(mask)))
            }
            None => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        if std::mem::take(&mut self.measuring) {
            if !cx.position_reply(reply, now) {
                self.done = true;
            }
            return;
        }
        let Some(mask) = self.running.take() else {
            return;
        };
        match reply {
            Reply::Code(ReplyCode::Ok) => {
                cx.zero_set(mask);
                self.measure = true;
            }
            Reply::Code(code) => {
                let text = cx.cmd(Command::SetZero(mask)).text;
                cx.controller_error(&text, code);
                self.done = true;
            }
            other => {
                let text = cx.cmd(Command::SetZero(mask)).text;
                cx.link_suspect(&text, &format!("{other:?}"));
                cx.zero_known = AxisSet::from_mask(cx.zero_known.mask() & !mask.mask());
                self.done = true;
            }
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        if std::mem::take(&mut self.measuring) {
            // The check waits for the next `@0P` (`Context::zero_check`).
            self.done = true;
            return;
        }
        // Whether the zero moved is unknown.
        if let Some(mask) = self.running.take() {
            cx.zero_known = AxisSet::from_mask(cx.zero_known.mask() & !mask.mask());
        }
        self.done = true;
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.done = true;
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }
}
