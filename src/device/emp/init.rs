//! `Initialise`: every drive switched on (`02`, manual "02"), then the mode
//! jogs run in set (`22 … 03` IV for `emp.jog = velocity`, `22 … 07` TPWM
//! for `position`, manual "22"). Initialising is the first half of what a
//! long action given up at its deadline asks for; the reference run is the
//! second.

use std::time::Instant;

use crate::device::api::{Activity, Recovery};
use crate::proto::emp::{Command, DriveAddress, Reply, Request};

use crate::device::common::Sink;

use super::context::Context;
use super::op::Operation;
use super::script::{Next, Outcome, Script};

#[derive(Debug)]
pub struct Init {
    script: Script,
}

impl Init {
    pub fn new(cx: &Context) -> Init {
        let scope = cx.on_scope();
        let mode = cx.jog_mode();
        let on = cx
            .addresses()
            .into_iter()
            .map(|ds| Request::new(ds, Command::On(scope)));
        let modes = cx
            .addresses()
            .into_iter()
            .map(|ds| Request::new(ds, Command::MotorEnable(mode)));
        Init {
            script: Script::sends(on.chain(modes).collect::<Vec<_>>()),
        }
    }
}

impl Operation for Init {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        let next = self.script.next();
        if next == Next::Done && !self.script.failed() {
            // A long action given up at its deadline (`emp::deadline`) asked
            // to initialise and reference: now only the reference is left.
            if let Some(f) = cx.state.fault.as_mut()
                && f.recovery == Recovery::ReinitialiseAndReference
            {
                f.recovery = Recovery::Reference;
            }
            cx.refresh();
            cx.notice(format!(
                "initialised: drives {} on, mode {}",
                cx.addresses()
                    .iter()
                    .map(|d| d.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
                cx.jog_mode()
            ));
        }
        next
    }

    fn outcome(
        &mut self,
        _cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        _reply: Option<&Reply>,
        _now: Instant,
    ) {
        self.script.outcome(request, outcome);
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request)
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }

    fn stopped(&mut self, _cx: &mut Context, _drives: &[DriveAddress]) {
        self.script.cancel();
    }
}
