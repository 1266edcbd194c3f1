//! Jogs, steps and go-to moves as one operation: the mode each drive needs
//! (`22 … 03` IV for velocity, `22 … 07` TPWM for positioning, manual "22"),
//! the sample rate for the speed (`20 19`), then the move (`2A 00 v` or
//! `2A 01 Vmax target`). Positioning answers `55` and later `22` on its own
//! (decision 1); a velocity jog runs until it is released, its lease runs
//! out, it reaches the soft-limit look-ahead or the operator stops; the
//! driver then sends `08` or `2A 03` (`emp.stop`) to its drives and the
//! operation ends when they have answered.
//!
//! A jog never runs faster than its lease allows within `jog.max_overrun`
//! (`plan::overrun_cap`): the first lease covers the terminal's delay before
//! its first key repeat and is long, so the jog starts slow; the first
//! renewal with the short lease lets it speed up (`common::jog_speed`)
//! without a stop: in IV mode `20 19` changes the running speed at once and
//! a new `2A 00` sets the velocity byte; in TPWM a new `2A 01` with the new
//! Vmax to the same target takes over from the running positioning (manual
//! "20 : Abtastrate", "2A"; `docs/protocols.md` EMP). The sample rate goes
//! first: the velocity byte only grows with the speed, so the speed between
//! the two frames is at most the new one.

use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::device::api::{Activity, ControllerFault, Dir, JogEnd, JogId, PerAxis, Refusal};
use crate::device::common::MotionKind;
use crate::device::common::RunningMove;
use crate::device::common::jog_speed::{JogSpeed, MoveState, Renewal};
use crate::device::common::motion::Coalescing;
use crate::device::common::op::Abandon;
use crate::device::common::sink::refuse_step;
use crate::proto::emp::{Command, DriveAddress, OperatingMode, Reply, Request};

use super::context::{Context, limit_hit, rejected};
use super::deadline::{self, GivenUp, LongKind};
use super::drive_stops::DriveStops;
use super::op::Operation;
use super::plan::{self, Plan, Style, lookahead};
use super::script::{Next, Outcome, Script, Step};

#[derive(Debug)]
pub struct MotionOp {
    kind: MotionKind,
    /// Set for a continuous jog.
    jog_speed: Option<JogSpeed>,
    plan: Plan,
    script: Script,
    stops: DriveStops,
    failed: bool,
    /// The change the running step makes.
    in_flight: Option<PerAxis<i64>>,
    deadline: Option<Instant>,
    timeout: Duration,
}

pub(super) fn script_for(cx: &Context, plan: &Plan) -> Script {
    let mode = match plan.style {
        Style::Velocity => OperatingMode::Iv,
        Style::Position => OperatingMode::Tpwm,
    };
    let mut steps = Vec::new();
    for leg in &plan.legs {
        let d = cx.drive(leg.ds);
        if d.and_then(|d| d.mode) != Some(mode) {
            steps.push(Step::Send(Request::new(leg.ds, Command::MotorEnable(mode))));
        }
        steps.extend(leg_steps(plan.style, leg, d.and_then(|d| d.reload)));
    }
    if plan.style == Style::Position {
        steps.push(Step::Barrier);
    }
    Script::new(steps)
}

/// The sample rate when the drive's differs from `reload`, then the move
/// of one leg.
fn leg_steps(
    style: Style,
    leg: &plan::Leg,
    reload: Option<crate::proto::emp::ReloadValue>,
) -> Vec<Step> {
    let mut steps = Vec::new();
    if reload != Some(leg.speed.reload) {
        steps.push(Step::Send(Request::new(
            leg.ds,
            Command::SampleRate(leg.speed.reload),
        )));
    }
    let command = match (style, leg.target) {
        (Style::Position, Some(target)) => Command::MoveTo {
            vmax: leg.speed.speed,
            target,
        },
        _ => Command::Drive {
            velocity: leg.speed.velocity(leg.dir.sign() < 0),
            target: crate::proto::emp::Position::ZERO,
        },
    };
    steps.push(Step::Send(Request::new(leg.ds, command)));
    steps
}

/// How long a positioning may take: the longest leg at its speed, with the
/// margins of `emp::deadline::positioning`.
pub(super) fn timeout_for(cx: &Context, plan: &Plan) -> Duration {
    let secs = plan
        .legs
        .iter()
        .map(|l| l.distance as f64 / l.hz().max(1.0))
        .fold(0.0, f64::max);
    deadline::positioning(cx, secs, plan.legs.len())
}

/// The fault of a positioning given up at its deadline (`timeout`): for
/// the frame still `running`, else for the first TP frame of `plan`.
pub(super) fn overdue(
    cx: &mut Context,
    running: Option<Request>,
    plan: Option<&Plan>,
    timeout: Duration,
) -> Option<ControllerFault> {
    let request = running.or_else(|| plan?.legs.first()?.move_request())?;
    let why = GivenUp::Deadline(timeout);
    Some(deadline::give_up(cx, &request, LongKind::Positioning, why))
}

impl MotionOp {
    fn new(cx: &Context, kind: MotionKind, plan: Plan, delta: Option<PerAxis<i64>>) -> MotionOp {
        MotionOp {
            script: script_for(cx, &plan),
            timeout: timeout_for(cx, &plan),
            kind,
            jog_speed: None,
            plan,
            stops: DriveStops::default(),
            failed: false,
            in_flight: delta,
            deadline: None,
        }
    }

    /// A jog planned for `lease` (what is left of its lease when it
    /// starts), at most at the `requested` speeds.
    pub fn jog(
        cx: &Context,
        plan: Plan,
        id: JogId,
        axes: Vec<(Axis, Dir)>,
        requested: PerAxis<f64>,
        lease: Duration,
        until: Instant,
    ) -> MotionOp {
        let mut op = MotionOp::new(cx, MotionKind::jog(id, until), plan, None);
        op.jog_speed = Some(JogSpeed::new(axes, requested, lease));
        op
    }

    pub fn step(cx: &Context, plan: Plan, delta: PerAxis<i64>) -> MotionOp {
        MotionOp::new(cx, MotionKind::step(), plan, Some(delta))
    }

    pub fn move_to(cx: &Context, plan: Plan) -> MotionOp {
        MotionOp::new(cx, MotionKind::MoveTo, plan, None)
    }

    /// A lease renewal for jog `id`; false when this is not that jog or it
    /// is stopping. The lease is never longer than the running speed allows
    /// within `jog.max_overrun` ([`plan::granted`]); the first shorter lease
    /// than the jog holds raises its speed ([`Self::speed_up`]).
    pub fn renew(&mut self, cx: &Context, id: JogId, lease: Duration, now: Instant) -> bool {
        if self.stops.is_stopping() {
            return false;
        }
        let granted = plan::granted(cx, &self.plan, lease);
        if !self.kind.renew(id, granted, now) {
            return false;
        }
        // Frames still on their way (the first few ms of the jog): no
        // change in the middle of them.
        let at = if self.kind.jog_end().is_none() && !self.failed && self.script.settled() {
            MoveState::Running
        } else {
            MoveState::Other
        };
        let Some(speed) = self.jog_speed.as_mut() else {
            return true;
        };
        let legs = &self.plan.legs;
        let renewal = speed.renewed(
            lease,
            at,
            |axis| {
                legs.iter()
                    .find(|l| l.axis == axis)
                    .map_or(0.0, plan::Leg::hz)
            },
            |axis, lease| plan::overrun_cap(cx, axis, lease),
        );
        if renewal == Renewal::SpeedUp {
            self.speed_up(cx);
        }
        true
    }

    /// The running jog goes on faster, without a stop: the new speed's
    /// frames take over from the running ones. A jog whose faster plan is
    /// refused (its soft-limit look-ahead is longer at the new speed) goes
    /// on as it runs.
    fn speed_up(&mut self, cx: &Context) {
        let Some(speed) = self.jog_speed.as_mut() else {
            return;
        };
        speed.sped_up();
        let Ok(faster) = plan::jog(cx, &speed.axes, &speed.requested, speed.lease) else {
            return;
        };
        let mut steps = Vec::new();
        for leg in &faster.legs {
            let reload = self
                .plan
                .legs
                .iter()
                .find(|l| l.ds == leg.ds)
                .map(|l| l.speed.reload);
            steps.extend(leg_steps(faster.style, leg, reload));
        }
        if faster.style == Style::Position {
            steps.push(Step::Barrier);
        }
        self.script.replace_rest(steps);
        self.timeout = timeout_for(cx, &faster);
        self.deadline = None;
        self.plan = faster;
    }

    /// The jog `id` was let go: stop it. False when this is not that jog.
    pub fn release(&mut self, id: JogId) -> bool {
        if self.kind.jog_id() != Some(id) {
            return false;
        }
        self.kind.set_jog_end(JogEnd::Released, false);
        self.halt();
        true
    }

    /// Stop the drives of this move (the driver sends the frames).
    fn halt(&mut self) {
        if self.stops.halt(self.plan.drives()) {
            self.script.cancel();
            self.deadline = None;
        }
    }

    /// The steps waiting behind a finished step, as the next move.
    fn next_step(&mut self, cx: &mut Context) -> bool {
        let Some((delta, speeds)) = self.kind.take_pending() else {
            return false;
        };
        let Some(base) = cx.positions() else {
            refuse_step(cx, &delta, Refusal::NotInitialised);
            return false;
        };
        match plan::step(cx, &base, &delta, &speeds) {
            Ok(plan) => {
                self.script = script_for(cx, &plan);
                self.timeout = timeout_for(cx, &plan);
                self.plan = plan;
                self.in_flight = Some(delta);
                true
            }
            Err(reason) => {
                refuse_step(cx, &delta, reason);
                false
            }
        }
    }
}

impl RunningMove for MotionOp {
    type Cx = Context;

    fn jog_id(&self) -> Option<JogId> {
        self.kind.jog_id()
    }

    fn is_stopping(&self) -> bool {
        self.stops.is_stopping()
    }

    /// A step pressed while this runs.
    fn coalesce(
        &mut self,
        cx: &Context,
        delta: PerAxis<i64>,
        speeds: PerAxis<f64>,
    ) -> Result<(), Refusal> {
        let position = cx.positions().unwrap_or_default();
        let at = Coalescing {
            open: !self.stops.is_stopping() && !self.failed,
            bound: cx.settings.jog.step_queue,
            position: &position,
            in_flight: self.in_flight.as_ref(),
            activity: self.activity(),
        };
        self.kind.coalesce(at, delta, speeds, |base| {
            let target = crate::device::common::limits::shifted(base, &delta);
            plan::within_limits(cx, &target)
        })
    }
}

impl Operation for MotionOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        loop {
            let next = self.script.next();
            match next {
                Next::Send(Request {
                    command: Command::MoveTo { .. },
                    ..
                }) => {
                    self.deadline
                        .get_or_insert(deadline::due(now, self.timeout));
                    return next;
                }
                Next::Send(_) => return next,
                Next::Wait => return Next::Wait,
                Next::Done => {}
            }
            if self.stops.is_stopping() {
                if !self.stops.answered() {
                    return Next::Wait;
                }
            } else if self.plan.style == Style::Velocity && !self.failed {
                // Runs until stopped.
                return Next::Wait;
            } else if !self.failed {
                self.deadline = None;
                self.in_flight = None;
                self.kind.set_jog_end(JogEnd::SoftLimit, false);
                if self.next_step(cx) {
                    continue;
                }
            }
            self.kind.drop_pending(
                cx,
                Refusal::Busy {
                    activity: Activity::Stopping,
                },
            );
            self.kind.report_jog(cx);
            return Next::Done;
        }
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
        if outcome == Outcome::Rejected {
            self.failed = true;
            self.kind
                .set_jog_end(JogEnd::Fault(rejected(request, "the move")), false);
            // Legs already sent may be moving: stop them all.
            self.halt();
        }
    }

    fn owns(&self, request: &Request) -> bool {
        self.script.owns(request)
    }

    fn activity(&self) -> Activity {
        // Over, only `next` has not yet said so: requests may queue.
        let over = self.script.idle()
            && self.kind.pending_steps() == 0
            && if self.stops.is_stopping() {
                self.stops.answered()
            } else {
                self.plan.style == Style::Position || self.failed
            };
        self.kind.activity(!over, self.stops.is_stopping())
    }

    fn timer(&self) -> Option<Instant> {
        if self.stops.is_stopping() {
            return self.deadline;
        }
        [self.kind.lease_until(), self.deadline]
            .into_iter()
            .flatten()
            .min()
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) {
        if self.stops.is_stopping() {
            self.deadline = None;
            return;
        }
        if self.kind.lease_ran_out(now, false) {
            self.halt();
        } else if self.deadline.is_some_and(|t| t <= now) {
            // Still busy: stop every drive of the move first (`halt`), then
            // the fault for the first leg still running, which blocks motion
            // until the operator initialises and references.
            self.failed = true;
            self.halt();
            let running = self.script.running().first().copied();
            if let Some(fault) = overdue(cx, running, Some(&self.plan), self.timeout) {
                self.kind.set_jog_end(JogEnd::Fault(fault), false);
            }
            for leg in &self.plan.legs {
                cx.unreference(leg.axis);
            }
            cx.refresh();
        }
    }

    fn position(&mut self, cx: &mut Context, _now: Instant) {
        if self.stops.is_stopping() || self.plan.style != Style::Velocity {
            return;
        }
        for leg in &self.plan.legs {
            if !cx.state.referenced.contains(leg.axis) {
                continue;
            }
            let (Some(pos), Some(l)) = (
                cx.drive(leg.ds).and_then(|d| d.position),
                cx.settings.limits.get(leg.axis),
            ) else {
                continue;
            };
            let room = if leg.dir.sign() > 0 {
                l.max - pos
            } else {
                pos - l.min
            };
            if (room as f64) <= lookahead(cx, leg.hz()) {
                self.kind.set_jog_end(JogEnd::SoftLimit, false);
                self.halt();
                return;
            }
        }
    }

    fn drive_stops(&mut self) -> Option<&mut DriveStops> {
        Some(&mut self.stops)
    }

    fn stopped(&mut self, cx: &mut Context, drives: &[DriveAddress]) {
        self.kind.stopped(cx);
        self.stops.stopped(drives);
        self.script.cancel();
        self.deadline = None;
    }

    fn link_lost(&mut self, cx: &mut Context) {
        let cause = Abandon::LinkLost(String::new());
        self.kind.abandoned(cx, &cause, "drive");
    }

    fn limit_hit(&mut self, _cx: &mut Context, ds: DriveAddress) {
        if !self.plan.drives().contains(&ds) || self.stops.is_stopping() {
            return;
        }
        self.failed = true;
        self.kind
            .set_jog_end(JogEnd::Fault(limit_hit(ds, "move")), false);
        self.halt();
    }
}
