//! `Home`: one reference run `$H` of the asked axes, Z first, then Y, X
//! (manual 1.5.9 runs them in the order written; jogterm takes the tool up
//! first, like the isel controller). The axes search their switches at the
//! start speed (manual 1.5.8); `@X` shows the run (referencing, position
//! unknown) until it has completed. A run that was stopped leaves the
//! position unknown (`$H` sets the flag when it starts, `docs/protocols.md`,
//! EMCU), so no axis counts as referenced then.

use crate::axis::AxisSet;
use crate::device::api::Activity;
use crate::device::common::Sink;
use crate::device::common::settings::reference_order;
use crate::proto::emcu::{Command, EmcuAxis, ReferenceOrder, Status};

use super::context::Context;
use super::plan;
use super::run::Run;
use super::run_op::{Purpose, RunOp};

/// `$H` with the axes in jogterm's order.
pub fn reference_command(axes: AxisSet) -> Option<Command> {
    let order: Vec<EmcuAxis> = reference_order(axes)
        .into_iter()
        .filter_map(Context::axis_of)
        .collect();
    ReferenceOrder::new(&order).ok().map(Command::Reference)
}

#[derive(Debug)]
pub struct Home {
    axes: AxisSet,
    text: String,
}

pub fn home_op(cx: &Context, axes: AxisSet) -> Option<RunOp<Home>> {
    let command = reference_command(axes)?;
    let run = Run::batch(cx, &[command], Some(plan::home_deadline(cx, axes)));
    Some(RunOp::new(
        Home {
            axes,
            text: command.to_string(),
        },
        run,
    ))
}

impl Purpose for Home {
    fn text(&self) -> String {
        self.text.clone()
    }

    fn ended(&mut self, cx: &mut Context, status: Status, stopped: bool) {
        if stopped || status.position_unknown {
            cx.state.referenced = AxisSet::EMPTY;
            cx.notice(format!(
                "the reference run of {} was {}: no axis is referenced",
                self.axes,
                if stopped { "stopped" } else { "not completed" }
            ));
        } else {
            cx.referenced(self.axes);
        }
    }

    fn unknown(&mut self, cx: &mut Context) {
        cx.state.referenced = AxisSet::EMPTY;
    }

    fn activity(&self) -> Activity {
        Activity::Homing
    }
}
