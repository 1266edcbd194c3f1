//! `Initialise`: bring the interface into the state the profile describes.
//! With its error flag set it is reset first (`@R`, the only command that
//! clears the flag, manual 1.5.1/1.5.3; the position is lost, a reference
//! run follows). Then `#S` and `#R` from the profile as one batch (manual
//! 1.5.5, 1.5.7), its end read with `@X`, and the positions. The move slot's
//! `#E` goes with each move, when its speed changes.

use std::time::Duration;

use crate::device::api::{Activity, Recovery};
use crate::device::common::Sink;
use crate::proto::emcu::{Command, Status, Terminator};

use super::context::{Context, ERROR_FLAG};
use super::run::Run;
use super::run_op::{Purpose, RunOp};

#[derive(Debug)]
pub struct Init {
    reset_first: bool,
}

pub fn init_op(cx: &Context) -> RunOp<Init> {
    let reset_first =
        cx.state.fault.as_ref().is_some_and(|f| {
            f.code == ERROR_FLAG && f.recovery == Recovery::ReinitialiseAndReference
        });
    let s = &cx.settings;
    let mut lines = Vec::new();
    if reset_first {
        lines.push(cx.cmd(&Command::Reset, Terminator::Cr));
    }
    lines.push(cx.cmd(&Command::StartSpeed(s.start_speed), Terminator::Cr));
    lines.push(cx.cmd(&Command::Ramp(s.ramp), Terminator::RunBuffer));
    let run = Run::new(lines, Some(Duration::ZERO), s.timing.run_margin);
    RunOp::new(Init { reset_first }, run)
}

impl Purpose for Init {
    fn text(&self) -> String {
        "initialise".to_owned()
    }

    fn acked(&mut self, cx: &mut Context, index: usize) {
        if self.reset_first && index == 0 {
            cx.apply_reset();
            cx.notice("the interface was reset (@R): reference the axes (h)");
        }
    }

    fn ended(&mut self, cx: &mut Context, _status: Status, stopped: bool) {
        if stopped {
            return;
        }
        cx.set_ramp(true);
        let s = &cx.settings;
        let text = format!(
            "initialised: start speed {} Hz, ramp {} ms",
            s.start_speed, s.ramp
        );
        cx.notice(text);
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }

    fn measure(&self) -> bool {
        true
    }
}
