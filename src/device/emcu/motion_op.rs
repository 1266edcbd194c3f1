//! Moves the driver plans itself: steps (coalesced while one runs), go-to
//! moves and continuous jogs. Each is a batch `#E<slot>,<hz>` (when the
//! slot's speed changes) and `L<slot>,…` ended by 0x01; the interface runs
//! it and reports its end with 0x02 CR (decision 1). Positions are polled
//! during the move (`@LX`…, master commands run at once, manual 1.4.2), so
//! every position is measured.
//!
//! A jog is one long move towards the soft limits, kept alive by leases.
//! When the lease runs out (dead-man), on release or on stop, `@B` halts it
//! with its ramp, positions kept (manual 1.5.11); the jog has ended when
//! the run's 0x02 CR has come and `@X` reads idle.
//!
//! A jog never runs faster than its lease allows within `jog.max_overrun`
//! (`plan::overrun_cap`): the first lease covers the terminal's delay before
//! its first key repeat and is long, so the jog starts slow; the first
//! renewal with the short lease lets it speed up (`common::jog_speed`). The
//! interface cannot change the speed of a running move: `#E` is a buffered
//! command and only master commands are read while a run is under way
//! (manual 1.4.2, 1.5.6); `@A`/`@C` resume at the same speed (1.5.13,
//! 1.5.14). So the move is halted with `@B` (ramp, positions kept, 1.5.11),
//! its end confirmed and the positions read, and a faster batch sent from
//! there: a dip of one brake ramp and one start ramp, once per jog, only
//! when the speed asked for is above what the long lease allows
//! (`docs/jogging.md`).

use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::device::api::{Activity, Dir, Event, JogEnd, JogId, PerAxis, Recovery, Refusal};
use crate::device::common::RunningMove;
use crate::device::common::jog_speed::{self, JogSpeed, MoveState, Renewal};
use crate::device::common::link::unreadable;
use crate::device::common::motion::Coalescing;
use crate::device::common::sink::refuse_step;
use crate::device::common::{MotionKind, Sink};
use crate::proto::emcu::Reply;

use super::context::Context;
use super::measure::Measure;
use super::op::{Abandon, Next, Operation};
use super::plan::{self, Planned};
use super::run::{Run, RunEvent};

#[derive(Debug)]
enum Phase {
    /// The batch goes out and runs.
    Moving,
    /// The run has ended; the positions are read.
    Measure(Measure),
    Done,
}

#[derive(Debug)]
pub struct MotionOp {
    kind: MotionKind,
    /// Set for a continuous jog.
    jog_speed: Option<JogSpeed>,
    planned: Planned,
    run: Run,
    phase: Phase,
    failed: bool,
}

fn run_of(cx: &Context, planned: &Planned) -> Run {
    let d = planned.duration;
    Run::batch(cx, &planned.commands, Some(d + d / 4))
}

impl MotionOp {
    pub fn step(cx: &Context, planned: Planned) -> MotionOp {
        MotionOp::new(cx, MotionKind::step(), planned)
    }

    pub fn move_to(cx: &Context, planned: Planned) -> MotionOp {
        MotionOp::new(cx, MotionKind::MoveTo, planned)
    }

    /// A jog planned for `lease` (what is left of its lease when it
    /// starts), at most at the `requested` speeds.
    pub fn jog(
        cx: &Context,
        planned: Planned,
        id: JogId,
        axes: Vec<(Axis, Dir)>,
        requested: PerAxis<f64>,
        lease: Duration,
        lease_until: Instant,
    ) -> MotionOp {
        let mut op = MotionOp::new(cx, MotionKind::jog(id, lease_until), planned);
        op.jog_speed = Some(JogSpeed::new(axes, requested, lease));
        op
    }

    fn new(cx: &Context, kind: MotionKind, planned: Planned) -> MotionOp {
        MotionOp {
            kind,
            jog_speed: None,
            run: run_of(cx, &planned),
            planned,
            phase: Phase::Moving,
            failed: false,
        }
    }

    fn is_moving(&self) -> bool {
        matches!(self.phase, Phase::Moving)
    }

    /// A lease renewal for jog `id`: `None` when this is not that jog, else
    /// whether the jog should now speed up (`@B`, then a faster batch).
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
        let granted = plan::granted(cx, &self.planned, lease);
        if !self.kind.renew(id, granted, now) {
            return None;
        }
        let at = if self.kind.jog_end().is_some() || !self.is_moving() || self.is_stopping() {
            MoveState::Other
        } else if self.run.is_running() {
            MoveState::Running
        } else if self.run.untouched() {
            MoveState::Unsent
        } else {
            // Its lines are on their way: too late to plan, too early to halt.
            MoveState::Other
        };
        let speed = self.jog_speed.as_mut()?;
        let planned = &self.planned;
        let renewal = speed.renewed(
            lease,
            at,
            |axis| planned.speeds.get(axis).unwrap_or(0.0),
            |axis, lease| plan::overrun_cap(cx, axis, lease),
        );
        match renewal {
            Renewal::Replan => {
                if let Ok(planned) = plan::jog(cx, &speed.axes, &speed.requested, lease) {
                    self.run = run_of(cx, &planned);
                    self.planned = planned;
                }
                Some(false)
            }
            Renewal::SpeedUp => Some(true),
            Renewal::Keep => Some(false),
        }
    }

    /// The move is halted (the driver sends `@B`) to be followed by a
    /// faster one: like a stop, but the jog goes on.
    pub fn speed_up(&mut self, cx: &Context, now: Instant) {
        if self.is_moving() {
            self.run.stop(plan::brake_time(cx), now);
        }
    }

    /// Halting to restart faster, and the jog has not ended otherwise.
    fn is_speeding_up(&self) -> bool {
        self.jog_speed
            .as_ref()
            .is_some_and(JogSpeed::is_speeding_up)
            && self.kind.jog_end().is_none()
    }

    /// After a jog halted to speed up has been measured: the faster batch
    /// from where it stopped, if the lease is still alive.
    fn restart_jog(&mut self, cx: &mut Context, now: Instant) {
        self.phase = Phase::Done;
        let Some(speed) = self.jog_speed.as_mut() else {
            return;
        };
        if self.failed {
            // Where it stands is unknown: no faster move from there.
            speed.sped_up();
            self.kind.report_jog(cx);
            return;
        }
        let faster = plan::jog(cx, &speed.axes, &speed.requested, speed.lease);
        let faster = jog_speed::restart(speed, &mut self.kind, cx, now, faster);
        if let Some(planned) = faster {
            self.run = run_of(cx, &planned);
            self.planned = planned;
            self.phase = Phase::Moving;
        }
    }

    /// Jog `id` was released. Returns whether `@B` must be sent.
    pub fn release(&mut self, cx: &mut Context, id: JogId, now: Instant) -> Option<bool> {
        if self.kind.jog_id() != Some(id) {
            return None;
        }
        self.kind.set_jog_end(JogEnd::Released, false);
        if !self.is_moving() {
            return Some(false);
        }
        if self.run.is_running() {
            return Some(!self.is_stopping());
        }
        // Its move has not started: it does not.
        self.run.stop(Duration::ZERO, now);
        if self.run.is_done() {
            self.finish_move(cx);
            return Some(false);
        }
        // The move's line is on its way: it starts, and is halted.
        Some(true)
    }

    /// The move's run is over: the jog has ended (unless it halted to speed
    /// up), the positions are read.
    fn finish_move(&mut self, cx: &mut Context) {
        if !self.is_speeding_up() {
            self.kind.report_jog(cx);
            self.phase = Phase::Measure(Measure::new(cx));
            return;
        }
        // The restart waits for this: only the jog's own axes are read
        // (the others stood still and were polled meanwhile), which keeps
        // the standstill at the first repeat to `@X`, their `@L`, `#E` and
        // `L` (`docs/jogging.md`, "Speed caps").
        let axes = self
            .jog_speed
            .as_ref()
            .map(|s| s.axes.iter().map(|(a, _)| *a).collect())
            .unwrap_or_default();
        self.phase = Phase::Measure(Measure::of(cx, axes));
    }

    fn failed(&mut self, cx: &mut Context, what: &str) {
        let fault = unreadable(&self.command_text(), what);
        cx.emit(Event::Fault(fault.clone()));
        self.kind.set_jog_end(JogEnd::Fault(fault), true);
        self.kind.drop_pending(
            cx,
            Refusal::Fault {
                recovery: Recovery::CheckLink,
            },
        );
        self.failed = true;
        // Whether it moves is unknown: halt it and read the state back.
        cx.halt_wanted = true;
        cx.readback_wanted = true;
        self.kind.report_jog(cx);
        self.phase = Phase::Done;
    }

    fn command_text(&self) -> String {
        self.planned
            .commands
            .last()
            .map(|c| c.to_string())
            .unwrap_or_default()
    }

    /// After the positions were read: the next coalesced step, if any.
    fn continue_steps(&mut self, cx: &mut Context) {
        self.phase = Phase::Done;
        if self.failed || self.is_stopping() {
            return;
        }
        let Some((total, speeds)) = self.kind.take_pending() else {
            return;
        };
        let base = cx.position.unwrap_or_default();
        match plan::step(cx, &base, &total, &speeds) {
            Ok(planned) => {
                self.run = run_of(cx, &planned);
                self.planned = planned;
                self.phase = Phase::Moving;
            }
            Err(reason) => refuse_step(cx, &total, reason),
        }
    }
}

impl RunningMove for MotionOp {
    type Cx = Context;

    fn jog_id(&self) -> Option<JogId> {
        self.kind.jog_id()
    }

    fn is_stopping(&self) -> bool {
        self.run.is_stopping()
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
        let at = Coalescing {
            open: !(self.is_stopping()
                || self.failed
                || (!moving && self.kind.pending_steps() == 0)),
            bound: cx.settings.jog.step_queue,
            position: &position,
            in_flight: moving.then_some(&self.planned.deltas),
            activity: self.activity(),
        };
        self.kind.coalesce(at, delta, speeds, |base| {
            plan::step(cx, base, &delta, &speeds).map(|_| ())
        })
    }
}

impl Operation for MotionOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        loop {
            match &mut self.phase {
                Phase::Moving => match self.run.next(cx) {
                    Next::Done => self.finish_move(cx),
                    other => return other,
                },
                Phase::Measure(m) => match m.next(cx) {
                    Some(cmd) => return Next::Send(cmd),
                    None if self
                        .jog_speed
                        .as_ref()
                        .is_some_and(JogSpeed::is_speeding_up) =>
                    {
                        self.restart_jog(cx, now);
                    }
                    None => self.continue_steps(cx),
                },
                Phase::Done => return Next::Done,
            }
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match &mut self.phase {
            Phase::Moving => {
                let slot_line = self
                    .run
                    .current()
                    .is_some_and(|c| c.bytes.starts_with(b"#E"));
                match self.run.reply(&reply, now) {
                    RunEvent::Nothing | RunEvent::Started => {
                        if slot_line {
                            cx.slot_hz = Some(self.planned.end_hz);
                        }
                    }
                    RunEvent::StillRunning { overdue: false } => {}
                    RunEvent::StillRunning { overdue: true } => {
                        if self.is_stopping() {
                            self.failed(cx, "still moving after @B");
                        } else {
                            cx.notice(format!(
                                "{} did not end in time: halting it",
                                self.command_text()
                            ));
                            cx.halt_wanted = true;
                        }
                    }
                    RunEvent::Ended(status) => {
                        cx.status_read(status, now);
                        if !self.is_speeding_up() {
                            self.kind.set_jog_end(JogEnd::SoftLimit, false);
                        }
                        self.finish_move(cx);
                    }
                    RunEvent::Lost => self.failed(cx, "answers lost"),
                }
            }
            Phase::Measure(m) => m.reply(cx, &reply, now),
            Phase::Done => {}
        }
    }

    fn ready(&mut self, _cx: &mut Context, _now: Instant) {
        if let Phase::Moving = self.phase {
            self.run.ready();
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, now: Instant) {
        match &mut self.phase {
            Phase::Moving => {
                if self.run.lost_reply() == RunEvent::Lost {
                    self.failed(cx, "garbled answer");
                }
            }
            Phase::Measure(m) => {
                m.give_up();
                if self
                    .jog_speed
                    .as_ref()
                    .is_some_and(JogSpeed::is_speeding_up)
                {
                    // Where the halted jog stands is unknown: it ends here.
                    self.failed = true;
                    self.restart_jog(cx, now);
                } else {
                    self.phase = Phase::Done;
                }
            }
            Phase::Done => {}
        }
    }

    fn stop(&mut self, cx: &mut Context, now: Instant) {
        self.kind.stopped(cx);
        if self.is_moving() {
            self.run.stop(plan::brake_time(cx), now);
            if self.run.is_done() {
                self.finish_move(cx);
            }
        }
    }

    fn timer(&self) -> Option<Instant> {
        if !self.is_moving() {
            return None;
        }
        let lease = self.kind.lease_until().filter(|_| !self.is_stopping());
        [self.run.timer(), lease].into_iter().flatten().min()
    }

    fn on_timer(&mut self, _cx: &mut Context, now: Instant) -> bool {
        if !self.is_moving() {
            return false;
        }
        self.run.on_timer(now);
        self.kind.lease_ran_out(now, self.is_stopping())
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        self.kind.abandoned(cx, cause, "interface");
        self.phase = Phase::Done;
    }

    fn activity(&self) -> Activity {
        if self.is_speeding_up() {
            return Activity::Jogging;
        }
        self.kind.activity(self.is_moving(), self.is_stopping())
    }
}
