//! Moves the driver plans itself: steps (coalesced while one runs), go-to
//! moves and continuous jogs. While a move runs the controller cannot be
//! asked anything (manual 2.2.2, 2.2.21): the position is estimated at a
//! steady rate, and read with `@0P` as soon as the move has answered.
//!
//! A jog is one long move towards the soft limits, kept alive by leases. When
//! the lease runs out (dead-man), on release or on stop, the stop sequence
//! 0xFD 0xFF ends it (`docs/decisions.md` isel 6: the break makes sure a
//! later start cannot resume it). The jog has ended when the move answers.
//!
//! A jog never runs faster than its lease allows: one lease at speed plus
//! braking stays within `jog.max_overrun` (`plan::overrun_cap`). The first
//! lease covers the terminal's delay before its first key repeat and is
//! long, so the jog starts slow; the first renewal with the short lease lets
//! it speed up. The controller cannot change the speed of a running move
//! (manual 2.2.2), so the move is stopped (0xFD 0xFF), its end read, and a
//! faster one sent from there: a short dip, once per jog, and only when the
//! speed asked for is above what the long lease allows
//! (`docs/jogging.md`, "Speed-up after the first repeat").

use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::device::api::{Activity, Dir, JogEnd, JogId, PerAxis, Recovery, Refusal};
use crate::device::common::MotionKind;
use crate::device::common::RunningMove;
use crate::device::common::jog_speed::{self, JogSpeed, MoveState, Renewal};
use crate::device::common::motion::Coalescing;
use crate::device::common::sink::refuse_step;
use crate::proto::isel::{Command, ControlByte, Reply, ReplyCode};

use super::context::{Context, control_outgoing};
use super::deadline;
use super::op::{Abandon, Next, Operation};
use super::plan::{self, Planned};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The move is planned, not yet handed out.
    Send,
    /// The move command is out; its reply comes when the move is done.
    Moving,
    /// The move has answered; `@0P` reads where it ended.
    Measure,
    Done,
}

#[derive(Debug)]
pub struct MotionOp {
    kind: MotionKind,
    /// Set for a continuous jog.
    jog_speed: Option<JogSpeed>,
    planned: Planned,
    phase: Phase,
    stopping: bool,
    failed: bool,
    next_estimate: Option<Instant>,
}

impl MotionOp {
    pub fn step(planned: Planned) -> MotionOp {
        MotionOp::new(MotionKind::step(), planned)
    }

    pub fn move_to(planned: Planned) -> MotionOp {
        MotionOp::new(MotionKind::MoveTo, planned)
    }

    pub fn jog(
        planned: Planned,
        id: JogId,
        axes: Vec<(Axis, Dir)>,
        requested: PerAxis<f64>,
        lease: Duration,
        lease_until: Instant,
    ) -> MotionOp {
        let mut op = MotionOp::new(MotionKind::jog(id, lease_until), planned);
        op.jog_speed = Some(JogSpeed::new(axes, requested, lease));
        op
    }

    fn new(kind: MotionKind, planned: Planned) -> MotionOp {
        MotionOp {
            kind,
            jog_speed: None,
            planned,
            phase: Phase::Send,
            stopping: false,
            failed: false,
            next_estimate: None,
        }
    }

    /// Whether the operation still has a move running or about to run.
    pub fn is_moving(&self) -> bool {
        matches!(self.phase, Phase::Send | Phase::Moving)
    }

    /// A lease renewal for jog `id`: `None` when this is not that jog, else
    /// whether the jog should now speed up (stop, then a faster move).
    ///
    /// The lease is never longer than the running speed allows within
    /// `jog.max_overrun` ([`plan::granted`]); a shorter lease than the jog
    /// holds raises its speed cap.
    pub fn renew(
        &mut self,
        cx: &Context,
        id: JogId,
        lease: Duration,
        now: Instant,
    ) -> Option<bool> {
        let granted = plan::granted(cx, &self.planned.speeds, lease);
        if !self.kind.renew(id, granted, now) {
            return None;
        }
        let at = if self.kind.jog_end().is_some() {
            MoveState::Other
        } else if self.phase == Phase::Send {
            MoveState::Unsent
        } else if self.phase == Phase::Moving && !self.stopping {
            MoveState::Running
        } else {
            MoveState::Other
        };
        let speed = self.jog_speed.as_mut()?;
        let planned = &self.planned;
        let renewal = speed.renewed(
            lease,
            at,
            |axis| planned.speeds.get(axis).map_or(0.0, f64::from),
            |axis, lease| {
                cx.settings
                    .limits(axis)
                    .map_or(0.0, |l| plan::overrun_cap(cx.ramp, lease, l.max_overrun))
            },
        );
        match renewal {
            Renewal::Replan => {
                // Not on the wire yet: plan it for the new lease straight away.
                if let Ok(planned) = plan::jog(cx, &speed.axes, &speed.requested, lease) {
                    self.planned = planned;
                }
                Some(false)
            }
            Renewal::SpeedUp => Some(true),
            Renewal::Keep => Some(false),
        }
    }

    /// The move is stopped to be followed by a faster one: like a stop, but
    /// the jog goes on. Returns the time the move's answer may still take.
    pub fn speed_up(&mut self, now: Instant) -> Option<Duration> {
        if self.phase != Phase::Moving || self.stopping {
            return None;
        }
        self.stopping = true;
        self.planned.estimate.brake(now);
        Some(deadline::motion(self.planned.estimate.remaining(now)))
    }

    fn is_speeding_up(&self) -> bool {
        self.jog_speed
            .as_ref()
            .is_some_and(JogSpeed::is_speeding_up)
            && self.kind.jog_end().is_none()
    }

    /// Jog `id` was released. Returns whether the stop sequence must be sent.
    pub fn release(&mut self, cx: &mut Context, id: JogId) -> Option<bool> {
        if self.kind.jog_id() != Some(id) {
            return None;
        }
        self.kind.set_jog_end(JogEnd::Released, false);
        match self.phase {
            Phase::Send => {
                // Never handed out: it simply does not start.
                self.phase = Phase::Done;
                self.kind.report_jog(&mut cx.events);
                Some(false)
            }
            Phase::Moving => Some(!self.stopping),
            Phase::Measure | Phase::Done => Some(false),
        }
    }

    fn drop_pending(&mut self, cx: &mut Context, reason: Refusal) {
        self.kind.drop_pending(&mut cx.events, reason);
    }

    /// After a jog that stopped to speed up has been measured: the faster
    /// move from where it stopped, if the lease is still alive.
    fn restart_jog(&mut self, cx: &mut Context, now: Instant) {
        let Some(speed) = self.jog_speed.as_mut() else {
            return;
        };
        let faster = plan::jog(cx, &speed.axes, &speed.requested, speed.lease);
        let faster = jog_speed::restart(speed, &mut self.kind, &mut cx.events, now, faster);
        if let Some(planned) = faster {
            self.planned = planned;
            self.phase = Phase::Send;
            self.stopping = false;
            self.next_estimate = None;
        }
    }

    /// After the position was read: the next coalesced step, if any.
    fn continue_steps(&mut self, cx: &mut Context) {
        self.phase = Phase::Done;
        if self.failed || self.stopping {
            return;
        }
        let Some((total, speeds)) = self.kind.take_pending() else {
            return;
        };
        let base = cx.position.unwrap_or_default();
        match plan::step(cx, &base, &total, &speeds) {
            Ok(planned) => {
                self.planned = planned;
                self.phase = Phase::Send;
                self.next_estimate = None;
            }
            Err(reason) => refuse_step(&mut cx.events, &total, reason),
        }
    }
}

impl RunningMove for MotionOp {
    type Cx = Context;

    fn jog_id(&self) -> Option<JogId> {
        self.kind.jog_id()
    }

    fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// A step pressed while this step runs: remember it (up to the bound),
    /// checking the soft limits from where the steps before it end.
    fn coalesce(
        &mut self,
        cx: &Context,
        delta: PerAxis<i64>,
        speeds: PerAxis<f64>,
    ) -> Result<(), Refusal> {
        let moving = self.is_moving();
        let position = cx.position.unwrap_or_default();
        let in_flight = self.planned.estimate.deltas();
        let at = Coalescing {
            open: !(self.stopping || self.failed || (!moving && self.kind.pending_steps() == 0)),
            bound: cx.settings.jog.step_queue,
            position: &position,
            in_flight: moving.then_some(&in_flight),
            activity: self.activity(),
        };
        self.kind.coalesce(at, delta, speeds, |base| {
            plan::step(cx, base, &delta, &speeds).map(|_| ())
        })
    }
}

impl Operation for MotionOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        match self.phase {
            Phase::Send => {
                self.phase = Phase::Moving;
                Next::Send(self.planned.cmd.clone())
            }
            Phase::Moving => Next::Wait,
            Phase::Measure => Next::Send(cx.cmd(Command::ReadPosition)),
            Phase::Done => Next::Done,
        }
    }

    fn transmitted(&mut self, cx: &mut Context, now: Instant) {
        if self.phase == Phase::Moving && self.planned.estimate.started().is_none() {
            self.planned.estimate.start(now);
            cx.estimated(self.planned.estimate.position_at(now), now);
            self.next_estimate = Some(now + cx.settings.timing.estimate_interval);
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match self.phase {
            Phase::Moving => {
                self.next_estimate = None;
                match reply {
                    Reply::Code(ReplyCode::Ok) => self.kind.set_jog_end(JogEnd::SoftLimit, false),
                    Reply::Code(ReplyCode::UserStop) => {
                        if !self.stopping {
                            // The controller's stop key: the rest of the move is
                            // kept for a start; break it off (isel decision 6).
                            cx.control.push_back(control_outgoing(ControlByte::Break));
                            cx.notice("the move was stopped at the controller (stop key); its rest was discarded");
                            self.drop_pending(
                                cx,
                                Refusal::Invalid {
                                    reason: "cancelled: the steps before it were stopped".into(),
                                },
                            );
                        }
                        if !self.is_speeding_up() {
                            self.kind.set_jog_end(JogEnd::Stopped, false);
                        }
                        cx.quiet_request = Some(cx.settings.timing.resync_gap);
                    }
                    Reply::Code(code) => {
                        self.planned.estimate.halt(now);
                        self.failed = true;
                        let fault = cx.controller_error(&self.planned.cmd.text, code);
                        self.kind.set_jog_end(JogEnd::Fault(fault.clone()), true);
                        self.drop_pending(
                            cx,
                            Refusal::Fault {
                                recovery: fault.recovery,
                            },
                        );
                    }
                    other => {
                        let fault = cx.link_suspect(&self.planned.cmd.text, &format!("{other:?}"));
                        self.kind.set_jog_end(JogEnd::Fault(fault), true);
                        self.failed = true;
                        cx.readback_wanted = true;
                    }
                }
                if self.stopping {
                    // A stray second `F` must not be taken for the next reply.
                    cx.quiet_request = Some(cx.settings.timing.resync_gap);
                }
                if !self.is_speeding_up() {
                    self.kind.report_jog(&mut cx.events);
                }
                self.phase = Phase::Measure;
            }
            Phase::Measure => {
                if !cx.position_reply(reply, now) {
                    self.failed = true;
                }
                if self.is_speeding_up() && !self.failed {
                    self.phase = Phase::Done;
                    self.restart_jog(cx, now);
                    return;
                }
                // A jog that was to speed up but failed ends here.
                self.kind.report_jog(&mut cx.events);
                self.continue_steps(cx);
            }
            Phase::Send | Phase::Done => {}
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        match self.phase {
            Phase::Moving => {
                let fault = cx.link_suspect(&self.planned.cmd.text, "garbled reply");
                self.kind.set_jog_end(JogEnd::Fault(fault), true);
                self.failed = true;
                self.drop_pending(
                    cx,
                    Refusal::Fault {
                        recovery: Recovery::CheckLink,
                    },
                );
                self.kind.report_jog(&mut cx.events);
                // Whether it ended with `0`, `F`, `2` or `9` is unknown.
                cx.readback_wanted = true;
                self.phase = Phase::Done;
            }
            _ => self.phase = Phase::Done,
        }
    }

    fn stop(&mut self, cx: &mut Context, now: Instant) -> Option<Duration> {
        self.kind.stopped(&mut cx.events);
        match self.phase {
            Phase::Send => {
                self.phase = Phase::Done;
                self.kind.report_jog(&mut cx.events);
                None
            }
            Phase::Moving if !self.stopping => {
                self.stopping = true;
                self.planned.estimate.brake(now);
                Some(deadline::motion(self.planned.estimate.remaining(now)))
            }
            _ => None,
        }
    }

    fn timer(&self) -> Option<Instant> {
        if self.phase != Phase::Moving {
            return None;
        }
        let lease = self.kind.lease_until().filter(|_| !self.stopping);
        match (self.next_estimate, lease) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) -> bool {
        if self.phase != Phase::Moving {
            return false;
        }
        if let Some(at) = self.next_estimate
            && at <= now
        {
            cx.estimated(self.planned.estimate.position_at(now), now);
            let interval = cx.settings.timing.estimate_interval;
            let mut next = at + interval;
            if next <= now {
                next = now + interval;
            }
            self.next_estimate = Some(next);
        }
        self.kind.lease_ran_out(now, self.stopping)
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        self.kind.abandoned(&mut cx.events, cause, "controller");
        self.phase = Phase::Done;
    }

    fn activity(&self) -> Activity {
        if self.is_speeding_up() {
            return Activity::Jogging;
        }
        let stopping = self.stopping && self.phase == Phase::Moving;
        self.kind.activity(self.is_moving(), stopping)
    }
}
