//! Moves the driver plans itself: steps (coalesced while one runs), go-to
//! moves and continuous jogs. While a move runs the controller cannot be
//! asked anything (manual 2.2.2, 2.2.21): the position is estimated at a
//! steady rate, and read with `@0P` as soon as the move has answered.
//!
//! A jog is one long move towards the soft limits, kept alive by leases. When
//! the lease runs out (dead-man), on release or on stop, the stop sequence
//! 0xFD 0xFF ends it (`../shared/protocols.md` isel 6: the break makes sure a
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
use crate::device::api::{Activity, Dir, Event, JogEnd, JogId, PerAxis, Recovery, Refusal};
use crate::proto::isel::{Command, ControlByte, Reply, ReplyCode};

use super::context::{Context, control_outgoing};
use super::deadline;
use super::op::{Abandon, Next, Operation};
use super::plan::{self, Planned};

#[derive(Debug)]
enum Kind {
    Step {
        /// Presses that arrived while the step ran: delta and speeds.
        pending: Vec<(PerAxis<i64>, PerAxis<f64>)>,
    },
    MoveTo,
    Jog {
        id: JogId,
        axes: Vec<(Axis, Dir)>,
        /// The speeds the client asked for (the plan may run slower).
        requested: PerAxis<f64>,
        /// The lease length the jog holds now; the speed cap follows it.
        lease: Duration,
        lease_until: Instant,
        end: Option<JogEnd>,
        reported: bool,
        /// Stopping to restart faster: the stop is not the jog's end.
        speeding_up: bool,
    },
}

/// A faster move is worth its dip only when it is faster by this factor.
const SPEED_UP_FACTOR: f64 = 1.05;

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
    kind: Kind,
    planned: Planned,
    phase: Phase,
    stopping: bool,
    failed: bool,
    next_estimate: Option<Instant>,
}

impl MotionOp {
    pub fn step(planned: Planned) -> MotionOp {
        MotionOp::new(
            Kind::Step {
                pending: Vec::new(),
            },
            planned,
        )
    }

    pub fn move_to(planned: Planned) -> MotionOp {
        MotionOp::new(Kind::MoveTo, planned)
    }

    pub fn jog(
        planned: Planned,
        id: JogId,
        axes: Vec<(Axis, Dir)>,
        requested: PerAxis<f64>,
        lease: Duration,
        lease_until: Instant,
    ) -> MotionOp {
        MotionOp::new(
            Kind::Jog {
                id,
                axes,
                requested,
                lease,
                lease_until,
                end: None,
                reported: false,
                speeding_up: false,
            },
            planned,
        )
    }

    fn new(kind: Kind, planned: Planned) -> MotionOp {
        MotionOp {
            kind,
            planned,
            phase: Phase::Send,
            stopping: false,
            failed: false,
            next_estimate: None,
        }
    }

    pub fn jog_id(&self) -> Option<JogId> {
        match self.kind {
            Kind::Jog { id, .. } => Some(id),
            _ => None,
        }
    }

    /// Whether the operation still has a move running or about to run.
    pub fn is_moving(&self) -> bool {
        matches!(self.phase, Phase::Send | Phase::Moving)
    }

    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// A step pressed while this step runs: remember it (up to the bound),
    /// checking the soft limits from where the steps before it end.
    pub fn coalesce(
        &mut self,
        cx: &Context,
        delta: PerAxis<i64>,
        speeds: PerAxis<f64>,
    ) -> Result<(), Refusal> {
        let moving = self.is_moving();
        let activity = self.activity();
        let Kind::Step { pending } = &mut self.kind else {
            return Err(Refusal::Busy { activity });
        };
        if self.stopping || self.failed || (!moving && pending.is_empty()) {
            return Err(Refusal::Busy { activity });
        }
        if pending.len() >= cx.settings.step_queue {
            return Err(Refusal::StepQueueFull);
        }
        let mut base = cx.position.unwrap_or_default();
        let add = |d: &PerAxis<i64>, base: &mut PerAxis<i64>| {
            for (axis, v) in d.iter() {
                base.set(axis, base.get(axis).unwrap_or(0).saturating_add(v));
            }
        };
        if moving {
            add(&self.planned.estimate.deltas(), &mut base);
        }
        for (d, _) in pending.iter() {
            add(d, &mut base);
        }
        plan::step(cx, &base, &delta, &speeds)?;
        pending.push((delta, speeds));
        Ok(())
    }

    /// A lease renewal for jog `id`: `None` when this is not that jog, else
    /// whether the jog should now speed up (stop, then a faster move).
    ///
    /// The lease is never longer than the running speed allows within
    /// `jog.max_overrun` ([`plan::lease_cap`]); a shorter lease than the jog
    /// holds raises its speed cap.
    pub fn renew(
        &mut self,
        cx: &Context,
        id: JogId,
        lease: Duration,
        now: Instant,
    ) -> Option<bool> {
        let moving = self.phase == Phase::Moving && !self.stopping;
        let unsent = self.phase == Phase::Send;
        let Kind::Jog {
            id: mine,
            axes,
            requested,
            lease: held,
            lease_until,
            end,
            speeding_up,
            ..
        } = &mut self.kind
        else {
            return None;
        };
        if *mine != id {
            return None;
        }
        let granted = lease.min(plan::lease_cap(cx, &self.planned.speeds));
        *lease_until = now + granted;
        if lease >= *held {
            return Some(false);
        }
        *held = lease;
        if unsent && end.is_none() {
            // Not on the wire yet: plan it for the new lease straight away.
            if let Ok(planned) = plan::jog(cx, axes, requested, lease) {
                self.planned = planned;
            }
            return Some(false);
        }
        if !moving || end.is_some() || *speeding_up {
            return Some(false);
        }
        // The speed the shorter lease allows, per axis, against the plan's.
        let faster = axes.iter().any(|(axis, _)| {
            let now_hz = self.planned.speeds.get(*axis).map_or(0.0, f64::from);
            let cap = cx
                .settings
                .limits(*axis)
                .map_or(0.0, |l| plan::overrun_cap(cx.ramp, lease, l.max_overrun));
            let want = requested.get(*axis).unwrap_or(0.0).min(cap);
            want > now_hz * SPEED_UP_FACTOR
        });
        *speeding_up = faster;
        Some(faster)
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
        matches!(
            self.kind,
            Kind::Jog {
                speeding_up: true,
                end: None,
                ..
            }
        )
    }

    /// Jog `id` was released. Returns whether the stop sequence must be sent.
    pub fn release(&mut self, cx: &mut Context, id: JogId) -> Option<bool> {
        let Kind::Jog { id: mine, end, .. } = &mut self.kind else {
            return None;
        };
        if *mine != id {
            return None;
        }
        if end.is_none() {
            *end = Some(JogEnd::Released);
        }
        match self.phase {
            Phase::Send => {
                // Never handed out: it simply does not start.
                self.phase = Phase::Done;
                self.report_jog(cx);
                Some(false)
            }
            Phase::Moving => Some(!self.stopping),
            Phase::Measure | Phase::Done => Some(false),
        }
    }

    fn report_jog(&mut self, cx: &mut Context) {
        if let Kind::Jog {
            id, end, reported, ..
        } = &mut self.kind
            && !*reported
        {
            *reported = true;
            let end = end.clone().unwrap_or(JogEnd::Stopped);
            cx.emit(Event::JogEnded { id: *id, end });
        }
    }

    fn set_jog_end(&mut self, value: JogEnd, overwrite: bool) {
        if let Kind::Jog { end, .. } = &mut self.kind
            && (overwrite || end.is_none())
        {
            *end = Some(value);
        }
    }

    fn drop_pending(&mut self, cx: &mut Context, reason: Refusal) {
        if let Kind::Step { pending } = &mut self.kind {
            for (delta, _) in pending.drain(..) {
                cx.emit(Event::Refused {
                    request: format!("step {}", describe_delta(&delta)),
                    reason: reason.clone(),
                });
            }
        }
    }

    /// After a jog that stopped to speed up has been measured: the faster
    /// move from where it stopped, if the lease is still alive.
    fn restart_jog(&mut self, cx: &mut Context, now: Instant) {
        let Kind::Jog {
            axes,
            requested,
            lease,
            lease_until,
            speeding_up,
            ..
        } = &mut self.kind
        else {
            return;
        };
        *speeding_up = false;
        if *lease_until <= now {
            self.set_jog_end(JogEnd::DeadMan, false);
            self.report_jog(cx);
            return;
        }
        match plan::jog(cx, axes, requested, *lease) {
            Ok(planned) => {
                self.planned = planned;
                self.phase = Phase::Send;
                self.stopping = false;
                self.next_estimate = None;
            }
            Err(Refusal::SoftLimit { .. }) => {
                self.set_jog_end(JogEnd::SoftLimit, false);
                self.report_jog(cx);
            }
            Err(reason) => {
                self.set_jog_end(JogEnd::Refused(reason), false);
                self.report_jog(cx);
            }
        }
    }

    /// After the position was read: the next coalesced step, if any.
    fn continue_steps(&mut self, cx: &mut Context) {
        self.phase = Phase::Done;
        let Kind::Step { pending } = &mut self.kind else {
            return;
        };
        if pending.is_empty() || self.failed || self.stopping {
            return;
        }
        let mut total = PerAxis::new();
        let mut speeds = PerAxis::new();
        for (delta, s) in pending.drain(..) {
            for (axis, v) in delta.iter() {
                total.set(axis, total.get(axis).unwrap_or(0i64).saturating_add(v));
            }
            speeds = s;
        }
        let base = cx.position.unwrap_or_default();
        match plan::step(cx, &base, &total, &speeds) {
            Ok(planned) => {
                self.planned = planned;
                self.phase = Phase::Send;
                self.next_estimate = None;
            }
            Err(reason) => cx.emit(Event::Refused {
                request: format!("step {}", describe_delta(&total)),
                reason,
            }),
        }
    }
}

/// `X+10 Y-5` for refusals of coalesced steps.
pub fn describe_delta(delta: &PerAxis<i64>) -> String {
    delta
        .iter()
        .map(|(a, d)| format!("{a}{d:+}"))
        .collect::<Vec<_>>()
        .join(" ")
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
                    Reply::Code(ReplyCode::Ok) => self.set_jog_end(JogEnd::SoftLimit, false),
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
                            self.set_jog_end(JogEnd::Stopped, false);
                        }
                        cx.quiet_request = Some(cx.settings.timing.resync_gap);
                    }
                    Reply::Code(code) => {
                        self.planned.estimate.halt(now);
                        self.failed = true;
                        let fault = cx.controller_error(&self.planned.cmd.text, code);
                        self.set_jog_end(JogEnd::Fault(fault.clone()), true);
                        self.drop_pending(
                            cx,
                            Refusal::Fault {
                                recovery: fault.recovery,
                            },
                        );
                    }
                    other => {
                        let fault = cx.link_suspect(&self.planned.cmd.text, &format!("{other:?}"));
                        self.set_jog_end(JogEnd::Fault(fault), true);
                        self.failed = true;
                        cx.readback_wanted = true;
                    }
                }
                if self.stopping {
                    // A stray second `F` must not be taken for the next reply.
                    cx.quiet_request = Some(cx.settings.timing.resync_gap);
                }
                if !self.is_speeding_up() {
                    self.report_jog(cx);
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
                self.report_jog(cx);
                self.continue_steps(cx);
            }
            Phase::Send | Phase::Done => {}
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        match self.phase {
            Phase::Moving => {
                let fault = cx.link_suspect(&self.planned.cmd.text, "garbled reply");
                self.set_jog_end(JogEnd::Fault(fault), true);
                self.failed = true;
                self.drop_pending(
                    cx,
                    Refusal::Fault {
                        recovery: Recovery::CheckLink,
                    },
                );
                self.report_jog(cx);
                // Whether it ended with `0`, `F`, `2` or `9` is unknown.
                cx.readback_wanted = true;
                self.phase = Phase::Done;
            }
            _ => self.phase = Phase::Done,
        }
    }

    fn stop(&mut self, cx: &mut Context, now: Instant) -> Option<Duration> {
        self.drop_pending(
            cx,
            Refusal::Invalid {
                reason: "cancelled by stop".into(),
            },
        );
        self.set_jog_end(JogEnd::Stopped, false);
        match self.phase {
            Phase::Send => {
                self.phase = Phase::Done;
                self.report_jog(cx);
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
        let lease = match self.kind {
            Kind::Jog { lease_until, .. } if !self.stopping => Some(lease_until),
            _ => None,
        };
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
        if let Kind::Jog { lease_until, .. } = self.kind
            && !self.stopping
            && lease_until <= now
        {
            self.set_jog_end(JogEnd::DeadMan, false);
            return true;
        }
        false
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        match cause {
            Abandon::LinkLost(_) => {
                self.set_jog_end(JogEnd::LinkLost, true);
                self.drop_pending(cx, Refusal::NotConnected);
            }
            Abandon::Reset => {
                self.set_jog_end(JogEnd::Stopped, false);
                self.drop_pending(
                    cx,
                    Refusal::Invalid {
                        reason: "cancelled: the controller was reset".into(),
                    },
                );
            }
        }
        self.report_jog(cx);
        self.phase = Phase::Done;
    }

    fn activity(&self) -> Activity {
        if self.is_speeding_up() {
            return Activity::Jogging;
        }
        if self.stopping && self.phase == Phase::Moving {
            return Activity::Stopping;
        }
        match (&self.kind, self.phase) {
            (_, Phase::Measure | Phase::Done) => match &self.kind {
                Kind::Step { pending } if !pending.is_empty() => Activity::Stepping,
                _ => Activity::Idle,
            },
            (Kind::Step { .. }, _) => Activity::Stepping,
            (Kind::MoveTo, _) => Activity::Moving,
            (Kind::Jog { .. }, _) => Activity::Jogging,
        }
    }
}
