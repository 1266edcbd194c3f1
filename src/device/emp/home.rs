//! Reference runs (`26`, manual "26"): one drive after the other in the
//! profile's reference order (Z, Y, X, A like isel), each in a mode the host
//! drives (the jog mode is set when the drive has none), with the sample
//! rate at 1 kHz so that `emp.home_fast`/`home_slow` are counts per
//! millisecond. `26` answers `55` at once and `22` when the reference point
//! is reached (decision 1); the position polls show the progress meanwhile.
//!
//! Every drive's `26` is guarded as a raw one is ([`super::guard`]): the
//! reference deadline over its axis' travel and the stall watchdog, which
//! takes the poller's samples when they come. Given up, the run stops every
//! drive of the run, counts as not done for all its axes, and the fault
//! blocks motion until the operator initialises and references
//! (`deadline::give_up`).

use std::time::Instant;

use crate::axis::{Axis, AxisSet};
use crate::device::api::Activity;
use crate::device::common::settings::reference_order;
use crate::proto::emp::{Command, DriveAddress, OperatingMode, ReloadValue, Reply, Request};

use crate::device::common::Sink;

use super::context::Context;
use super::deadline::GivenUp;
use super::guard::LongGuard;
use super::op::Operation;
use super::script::{Next, Outcome, Script, Step};
use super::settings::HOME_RELOAD;

#[derive(Debug)]
pub struct Home {
    script: Script,
    /// Axes still to be referenced.
    left: Vec<Axis>,
    /// Every axis of the run, in order, and its drive.
    axes: Vec<Axis>,
    drives: Vec<DriveAddress>,
    /// The guard of the `26` sent last (the drives run one after the other:
    /// a barrier follows every `26`).
    guard: Option<LongGuard>,
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
        let mut drives = Vec::new();
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
            drives.push(ds);
        }
        Some(Home {
            script: Script::new(steps),
            axes: order.clone(),
            left: order,
            drives,
            guard: None,
            stopped: false,
            stops: Vec::new(),
        })
    }

    /// The guarded `26` has answered `55` and not ended.
    fn running(&self) -> bool {
        self.guard
            .as_ref()
            .is_some_and(|g| self.script.running().contains(g.request()))
    }

    fn given_up(&self) -> bool {
        self.guard.as_ref().is_some_and(LongGuard::given_up)
    }

    /// Stop every drive of the run (sent ahead of everything), then tell
    /// the operator; nothing more is sent.
    fn give_up(&mut self, cx: &mut Context, why: GivenUp) {
        let Some(g) = self.guard.as_mut().filter(|g| g.live()) else {
            return;
        };
        self.script.cancel();
        self.stops.clone_from(&self.drives);
        let _ = g.give_up(cx, why);
        // A run given up counts as not done for all its axes, those it
        // already referenced too: the operator references them again.
        for a in &self.axes {
            cx.unreference(*a);
        }
        cx.refresh();
    }
}

impl Operation for Home {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        let running = self.running();
        if let Some(read) = self.guard.as_mut().and_then(|g| g.read(cx, running, now)) {
            return Next::Send(read);
        }
        let next = self.script.next();
        if let Next::Send(
            request @ Request {
                command: Command::Home { .. },
                ..
            },
        ) = next
        {
            // Armed with the sample rate just set (1 kHz): the reference
            // deadline of the axis at the slower of Vfast and Vslow.
            self.guard = LongGuard::arm(cx, &request, now);
        }
        if next == Next::Done {
            if !self.left.is_empty() && !self.stopped && !self.script.failed() && !self.given_up() {
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
        now: Instant,
    ) {
        if let Some(g) = self.guard.as_mut()
            && g.is_read(request)
        {
            if let Some(why) = g.read_answered(cx, outcome, now)
                && self.running()
            {
                self.give_up(cx, why);
            }
            return;
        }
        self.script.outcome(request, outcome);
        if !matches!(request.command, Command::Home { .. }) {
            return;
        }
        let axis = cx.settings.axis_of(request.ds);
        if let (Outcome::Completed, Some(a)) = (outcome, axis) {
            self.left.retain(|x| *x != a);
            cx.state.referenced = cx.state.referenced.with(a);
            cx.refresh();
            cx.notice(format!("{a} referenced (drive {})", request.ds));
        }
        if matches!(
            outcome,
            Outcome::Completed | Outcome::Rejected | Outcome::Ended
        ) && let Some(g) = self.guard.as_mut()
            && g.request() == request
        {
            // Over: nothing more to guard (a given-up run keeps its guard to
            // say so).
            g.disarm();
        }
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request) || self.guard.as_ref().is_some_and(|g| g.is_read(request))
    }

    fn activity(&self) -> Activity {
        if self.script.idle() {
            Activity::Idle
        } else {
            Activity::Homing
        }
    }

    fn timer(&self) -> Option<Instant> {
        self.guard.as_ref()?.timer()
    }

    fn send_due(&self) -> Option<Instant> {
        self.guard.as_ref()?.read_due(self.running())
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) {
        // A due read is sent by `next`; only the deadline acts here.
        if let Some(why) = self.guard.as_ref().and_then(|g| g.expired(now)) {
            self.give_up(cx, why);
        }
    }

    fn polled(&mut self, cx: &mut Context, ds: DriveAddress, now: Instant) {
        if !self.running() {
            return;
        }
        if let Some(why) = self.guard.as_mut().and_then(|g| g.polled(cx, ds, now)) {
            self.give_up(cx, why);
        }
    }

    fn take_stops(&mut self) -> Vec<DriveAddress> {
        std::mem::take(&mut self.stops)
    }

    fn stopped(&mut self, _cx: &mut Context, _drives: &[DriveAddress]) {
        // What runs is ended by the stop frames (the correlator's `Ended`).
        self.stopped = true;
        if let Some(g) = self.guard.as_mut() {
            g.disarm();
        }
        self.script.cancel();
    }
}
