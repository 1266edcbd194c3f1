//! Reference runs (`26`, manual "26"): one drive after the other in the
//! profile's reference order (Z, Y, X, A like isel), each in a mode the host
//! drives (the jog mode is set when the drive has none), with the sample
//! rate at 1 kHz so that `emp.home_fast`/`home_slow` are counts per
//! millisecond. `26` answers `55` at once and `22` when the reference point
//! is reached (decision 1); the position polls show the progress meanwhile.

use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Activity, ControllerFault, Event, Recovery};
use crate::device::common::deadline;
use crate::device::common::settings::reference_order;
use crate::proto::emp::{Command, DriveAddress, OperatingMode, ReloadValue, Reply, Request};

use crate::device::common::Sink;

use super::context::Context;
use super::op::Operation;
use super::script::{Next, Outcome, Script, Step};
use super::settings::HOME_RELOAD;

#[derive(Debug)]
pub struct Home {
    script: Script,
    /// Axes still to be referenced.
    left: Vec<Axis>,
    deadline: Option<Instant>,
    timeout: Duration,
    stopped: bool,
    stops: Vec<DriveAddress>,
}

/// Modes in which `26` is taken (docs/protocols.md, EMP).
fn host_driven(mode: Option<OperatingMode>) -> bool {
    matches!(
        mode,
        Some(OperatingMode::Pv | OperatingMode::Iv | OperatingMode::Pwm | OperatingMode::Tpwm)
    )
}

impl Home {
    pub fn new(cx: &Context, axes: AxisSet) -> Option<Home> {
        let order = reference_order(axes);
        let reload = ReloadValue::new(HOME_RELOAD).ok()?;
        let mut steps = Vec::new();
        let mut spans = Vec::new();
        for axis in &order {
            let ds = cx.settings.drive_of(*axis)?;
            let d = cx.drive(ds)?;
            if !host_driven(d.mode) {
                steps.push(Step::Send(Request::new(
                    ds,
                    Command::MotorEnable(cx.jog_mode()),
                )));
            }
            steps.push(Step::Send(Request::new(ds, Command::SampleRate(reload))));
            steps.push(Step::Send(Request::new(
                ds,
                Command::Home {
                    fast: cx.settings.home_fast,
                    slow: cx.settings.home_slow,
                },
            )));
            steps.push(Step::Barrier);
            spans.push(cx.settings.limits.get(*axis).map_or(0, |l| l.span()));
        }
        let slow = cx.settings.home_hz(cx.settings.home_slow);
        let fast = cx.settings.home_hz(cx.settings.home_fast);
        // Out at the fast speed over the whole travel, back slowly off the
        // switch: the reference deadline at the slow speed covers both.
        let timeout = deadline::reference(spans, slow.min(fast));
        Some(Home {
            script: Script::new(steps),
            left: order,
            deadline: None,
            timeout,
            stopped: false,
            stops: Vec::new(),
        })
    }
}

impl Operation for Home {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        let next = self.script.next();
        if let Next::Send(Request {
            command: Command::Home { .. },
            ..
        }) = next
        {
            self.deadline = Some(now + self.timeout);
        }
        if next == Next::Done {
            if !self.left.is_empty() && !self.stopped && !self.script.failed() {
                // Cannot happen: every axis ends its step with a barrier.
                cx.notice("reference run ended early");
            }
            for a in std::mem::take(&mut self.left) {
                cx.unreference(a);
            }
        }
        next
    }

    fn outcome(
        &mut self,
        cx: &mut Context,
        request: &Request,
        outcome: Outcome,
        _reply: Option<&Reply>,
        _now: Instant,
    ) {
        self.script.outcome(request, outcome);
        if !matches!(request.command, Command::Home { .. }) {
            return;
        }
        let axis = cx.settings.axis_of(request.ds);
        match (outcome, axis) {
            (Outcome::Completed, Some(a)) => {
                self.deadline = None;
                self.left.retain(|x| *x != a);
                cx.state.referenced = cx.state.referenced.with(a);
                cx.refresh();
                cx.notice(format!("{a} referenced (drive {})", request.ds));
            }
            (Outcome::Rejected | Outcome::Ended, _) => self.deadline = None,
            _ => {}
        }
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request)
    }

    fn activity(&self) -> Activity {
        if self.script.idle() {
            Activity::Idle
        } else {
            Activity::Homing
        }
    }

    fn timer(&self) -> Option<Instant> {
        self.deadline
    }

    fn take_stops(&mut self) -> Vec<DriveAddress> {
        std::mem::take(&mut self.stops)
    }

    fn on_timer(&mut self, cx: &mut Context, _now: Instant) {
        self.deadline = None;
        self.stops = self.script.running().iter().map(|r| r.ds).collect();
        cx.emit(Event::Fault(ControllerFault {
            command: "26 (reference run)".into(),
            code: "timeout".into(),
            meaning: format!(
                "the reference run did not finish within {} s: stopped",
                self.timeout.as_secs()
            ),
            recovery: Recovery::Reference,
        }));
        self.script.cancel();
    }

    fn stopped(&mut self, _cx: &mut Context, _drives: &[DriveAddress]) {
        // What runs is ended by the stop frames (the correlator's `Ended`).
        self.stopped = true;
        self.deadline = None;
        self.script.cancel();
    }
}
