//! Reading where the axes are: `@LX`, `@LY`, `@LZ` for the machine's axes
//! (manual 1.5.4), one after the other, then one measured sample.

use std::time::Instant;

use crate::proto::emcu::{Command, EmcuAxis, Reply, Terminator};

use super::context::{Cmd, Context};

#[derive(Debug)]
pub struct Measure {
    axes: Vec<EmcuAxis>,
    index: usize,
}

impl Measure {
    pub fn new(cx: &Context) -> Measure {
        Measure {
            axes: cx.axes(),
            index: 0,
        }
    }

    /// Only `axes` of the machine's (a jog halted to speed up: the axes
    /// it does not move have not moved, and their last readings stand).
    pub fn of(cx: &Context, axes: crate::axis::AxisSet) -> Measure {
        let mut all = cx.axes();
        all.retain(|a| axes.contains(a.axis()));
        Measure {
            axes: all,
            index: 0,
        }
    }

    pub fn is_done(&self) -> bool {
        self.index >= self.axes.len()
    }

    /// The next query, `None` once every axis was read.
    pub fn next(&self, cx: &Context) -> Option<Cmd> {
        let axis = self.axes.get(self.index)?;
        Some(cx.cmd(&Command::Position(*axis), Terminator::Cr))
    }

    /// The answer to the query; the sample goes out with the last axis.
    pub fn reply(&mut self, cx: &mut Context, reply: &Reply, now: Instant) {
        if let (Reply::Position { axis, steps }, Some(want)) = (reply, self.axes.get(self.index))
            && axis == want
        {
            cx.position_part(*axis, *steps);
            self.index += 1;
            if self.is_done() {
                cx.position_complete(now);
            }
        }
    }

    /// An answer was lost: the sample is given up.
    pub fn give_up(&mut self) {
        self.index = self.axes.len();
    }
}
