//! `SetZero`: `@0n<mask>` makes the current position the virtual zero of the
//! masked axes, A on its own (manual 2.2.19). `@0P` keeps reporting machine
//! coordinates; the virtual zero shifts the targets of `@0M`, which the
//! driver tracks as `work_zero` (machine steps).

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
    done: bool,
}

impl ZeroOp {
    pub fn new(axes: AxisSet) -> ZeroOp {
        ZeroOp {
            // The same rule as for reference masks: A only on its own.
            masks: deadline::reference_masks(axes).into(),
            running: None,
            done: false,
        }
    }
}

impl Operation for ZeroOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        if self.done {
            return Next::Done;
        }
        match self.masks.pop_front() {
            Some(mask) => {
                self.running = Some(mask);
                Next::Send(cx.cmd(Command::SetZero(mask)))
            }
            None => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, _now: Instant) {
        let Some(mask) = self.running.take() else {
            return;
        };
        match reply {
            Reply::Code(ReplyCode::Ok) => {
                let position = cx.position.unwrap_or_default();
                for axis in mask.iter() {
                    cx.state
                        .work_zero
                        .set(axis, position.get(axis).unwrap_or(0));
                }
                cx.zero_known = AxisSet::from_mask(cx.zero_known.mask() | mask.mask());
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
