//! The jog off a limit switch (`Request::LimitJog`, `docs/jogging.md`,
//! "Jog off a limit switch") on an isel controller.
//!
//! The controller moves nothing while a monitored limit switch is active (a
//! move answers `2`, chapter 5) nor, after a `2`, until it is referenced
//! (`R`, `docs/decisions.md` isel 4). Test mode (`@0T1`, manual
//! 2.2.24) lifts both: "Die Endschalter werden weiterhin überwacht können
//! aber überfahren werden. Dies ist sehr nützlich wenn eine Achse … in einem
//! Endschalter steht und freigefahren werden muss." It lifts them for every
//! axis and both directions, so jogterm does the limiting: short, slow
//! relative moves of the one axis away from the switch, the switches (port
//! 3) and the position read after each (a move cannot be interrupted by a
//! query, manual 2.2.2), until the switch reads released or
//! `jog.limit_jog_distance` is travelled; then `@0T0` at once. A move is
//! at most [`STEP_TIME`] at the jog's speed, so the axis leaves the switch
//! by at most that much more than it must.
//!
//! `@0F` (manual 2.2.9, "Freifahren") would free the axis on the
//! controller's own terms: the manual gives no distance it stops at, no
//! speed, and which switch it means ("aus dem Referenzschalter heraus" in
//! one sentence, "aus dem Endschalter" in the next). jogterm keeps the
//! bound and the direction the profile's wiring gives.
//!
//! Test mode left on would let every later move run over the switches, and
//! a controller in test mode passes the reference probe: so `@0T0` follows
//! every way this ends, a stop too; if the link is lost before, the next
//! connection sends it before anything else (`Context::test_mode_left_on`,
//! `readback`). Unless the operator had test mode on already (raw `@0T1`
//! with `isel.test_mode`): then it is left as it was.

use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::device::api::{ActiveLimit, Activity, Dir, Event, JogEnd, JogId, Refusal};
use crate::device::common::limit_jog::{self, Reading};
use crate::device::common::limits::machine_has;
use crate::proto::isel::{Command, ControlByte, InputPort, Reply, ReplyCode};

use super::context::{Context, control_outgoing, is_limit_fault};
use super::deadline;
use super::op::{Abandon, Next, Operation};
use super::plan::{self, Planned};

/// The longest one of its moves runs at its speed: how far the axis may go
/// on past the point where the switch released before jogterm reads it.
pub const STEP_TIME: Duration = Duration::from_millis(100);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// `@0b3`: the switches as they are now, before anything moves.
    Check,
    /// `@0T1`: moves without reference and out of the switch.
    TestOn,
    /// A short move is planned, not yet handed out.
    Move,
    /// The move is out; it answers when it is done.
    Moving,
    /// `@0b3` after a move.
    Read,
    /// `@0P` after a move.
    Measure,
    /// `@0T0`: test mode off again.
    TestOff,
    Done,
}

#[derive(Debug)]
pub struct LimitJogOp {
    id: JogId,
    axis: Axis,
    dir: Dir,
    /// The switch it leaves.
    switch: ActiveLimit,
    /// Steps per move, the bound, the speed.
    step: i64,
    bound: i64,
    hz: u32,
    stage: Stage,
    /// Where the axis stood when it started, and now (measured).
    from: Option<i64>,
    at: Option<i64>,
    planned: Option<Planned>,
    /// Test mode was on before (the operator's): it stays on.
    keep_test_mode: bool,
    /// `@0T1` was answered `0` and `@0T0` not yet.
    test_mode_on: bool,
    /// It found the axis in the switch and went on: the axis counts as not
    /// referenced when it ends.
    entered: bool,
    /// Why it ends, once known; reported when test mode is off again.
    end: Option<JogEnd>,
    /// The last reading of the switches.
    reading: Option<Reading>,
    stopping: bool,
    reported: bool,
}

impl LimitJogOp {
    /// Checked against the machine state and the switches as last read
    /// (`common::limit_jog::check`); the op reads them again first.
    pub fn new(
        cx: &Context,
        id: JogId,
        axis: Axis,
        dir: Dir,
        now: Instant,
    ) -> Result<LimitJogOp, Refusal> {
        machine_has(cx.settings.axis_set(), AxisSet::EMPTY.with(axis))?;
        let active = cx.ports.snapshot(now, &cx.settings.wiring).active_limits();
        let switch = limit_jog::check(
            &cx.state,
            cx.profile_ready(),
            axis,
            dir,
            &active,
            is_limit_fault,
        )?;
        let limit = cx.settings.jog.limit_jog_of(axis)?;
        let hz = plan::speed_hz(cx, axis, Some(limit.hz))?;
        let step = ((f64::from(hz) * STEP_TIME.as_secs_f64()).round() as i64).max(1);
        Ok(LimitJogOp {
            id,
            axis,
            dir,
            switch,
            step,
            bound: limit.distance,
            hz,
            stage: Stage::Check,
            from: None,
            at: None,
            planned: None,
            keep_test_mode: cx.state.test_mode,
            test_mode_on: false,
            entered: false,
            end: None,
            reading: None,
            stopping: false,
            reported: false,
        })
    }

    fn travelled(&self) -> i64 {
        match (self.from, self.at) {
            (Some(a), Some(b)) => (b - a).abs(),
            _ => 0,
        }
    }

    /// It ends (`end`, unless it has an end already): test mode off first.
    fn finish(&mut self, end: JogEnd) {
        self.end.get_or_insert(end);
        self.stage = if self.test_mode_on {
            Stage::TestOff
        } else {
            Stage::Done
        };
    }

    /// After `@0b3` and `@0P`: released, the bound, or the next move.
    fn decide(&mut self) {
        if self.end.is_some() || self.stopping {
            self.stage = if self.test_mode_on {
                Stage::TestOff
            } else {
                Stage::Done
            };
            return;
        }
        match self.reading {
            Some(Reading::Off) => self.finish(JogEnd::OffLimit),
            Some(Reading::Other) => self.finish(JogEnd::StillOnLimit),
            _ if self.travelled() >= self.bound => self.finish(JogEnd::StillOnLimit),
            _ => self.stage = Stage::Move,
        }
    }

    /// The next short move, at most what is left of the bound.
    fn plan_move(&mut self, cx: &Context) -> Result<Planned, Refusal> {
        let left = (self.bound - self.travelled()).max(0);
        let steps = self.step.min(left).max(1);
        plan::limit_step(cx, self.axis, self.dir.sign() * steps, self.hz)
    }

    fn report(&mut self, cx: &mut Context) {
        if self.reported {
            return;
        }
        self.reported = true;
        let end = self.end.clone().unwrap_or(JogEnd::Stopped);
        if self.entered {
            // It stood in the switch: the reference is the next thing to do
            // (after a `2` it is lost anyway, chapter 5; `@0F` leaves its
            // axis unreferenced too, 2.2.9).
            let referenced = cx.state.referenced.iter().filter(|a| *a != self.axis);
            cx.state.referenced = referenced.collect();
        }
        let travelled = self.travelled() as f64;
        let notice = match (&end, self.reading) {
            (JogEnd::OffLimit, _) => Some(Reading::Off),
            (JogEnd::StillOnLimit, Some(r)) => Some(r),
            (JogEnd::StillOnLimit, None) => Some(Reading::Still),
            _ => None,
        };
        if let Some(r) = notice {
            let text = limit_jog::end_notice(self.axis, &self.switch, travelled, &r);
            cx.notice(text);
        }
        cx.emit(Event::JogEnded { id: self.id, end });
    }

    fn controller_fault(&mut self, cx: &mut Context, command: &str, code: ReplyCode) {
        let fault = cx.controller_error(command, code);
        self.finish(JogEnd::Fault(fault));
    }
}

impl Operation for LimitJogOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        loop {
            return match self.stage {
                Stage::Check | Stage::Read => {
                    Next::Send(cx.cmd(Command::ReadPort(InputPort::LimitSwitches)))
                }
                Stage::TestOn => {
                    // From the moment it may arrive: an answer lost with
                    // the link must still be followed by `@0T0`.
                    cx.test_mode_left_on = true;
                    Next::Send(cx.cmd(Command::SetTestMode(true)))
                }
                Stage::Move => match self.plan_move(cx) {
                    Ok(planned) => {
                        let cmd = planned.cmd.clone();
                        self.planned = Some(planned);
                        self.stage = Stage::Moving;
                        Next::Send(cmd)
                    }
                    Err(reason) => {
                        self.finish(JogEnd::Refused(reason));
                        continue;
                    }
                },
                Stage::Moving => Next::Wait,
                Stage::Measure => Next::Send(cx.cmd(Command::ReadPosition)),
                Stage::TestOff => Next::Send(cx.cmd(Command::SetTestMode(false))),
                Stage::Done => {
                    self.report(cx);
                    Next::Done
                }
            };
        }
    }

    fn transmitted(&mut self, _cx: &mut Context, now: Instant) {
        if self.stage == Stage::Moving
            && let Some(p) = self.planned.as_mut()
        {
            p.estimate.start(now);
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match (self.stage, reply) {
            (Stage::Check | Stage::Read, Reply::Byte(v)) => {
                let port = InputPort::LimitSwitches;
                cx.port_read(port, v, now);
                cx.emit_io(now);
                let active = cx.ports.snapshot(now, &cx.settings.wiring).active_limits();
                let reading = limit_jog::reading(self.axis, self.switch.side, &active);
                self.reading = Some(reading);
                if self.stage == Stage::Check {
                    match reading {
                        // Off the switch already: nothing to move.
                        Reading::Off => self.finish(JogEnd::OffLimit),
                        Reading::Other => self.finish(JogEnd::StillOnLimit),
                        Reading::Still if self.end.is_some() || self.stopping => {
                            self.finish(JogEnd::Stopped)
                        }
                        Reading::Still => {
                            self.entered = true;
                            self.stage = if self.keep_test_mode {
                                Stage::Measure
                            } else {
                                Stage::TestOn
                            };
                        }
                    }
                } else {
                    self.stage = Stage::Measure;
                }
            }
            (Stage::TestOn, Reply::Code(ReplyCode::Ok)) => {
                self.test_mode_on = true;
                self.stage = if self.end.is_some() || self.stopping {
                    Stage::TestOff
                } else {
                    Stage::Measure
                };
            }
            (Stage::TestOn, Reply::Code(code)) => {
                cx.test_mode_left_on = false;
                let text = cx.cmd(Command::SetTestMode(true)).text;
                self.controller_fault(cx, &text, code);
            }
            (Stage::Moving, Reply::Code(ReplyCode::Ok)) => {
                self.planned = None;
                self.stage = Stage::Read;
            }
            (Stage::Moving, Reply::Code(ReplyCode::UserStop)) => {
                if !self.stopping {
                    // The controller's stop key: its rest is kept for a
                    // start; break it off (isel decision 6).
                    cx.control.push_back(control_outgoing(ControlByte::Break));
                    cx.notice("the jog off the limit switch was stopped at the controller");
                }
                cx.quiet_request = Some(cx.settings.timing.resync_gap);
                self.planned = None;
                self.end.get_or_insert(JogEnd::Stopped);
                self.stage = Stage::Read;
            }
            (Stage::Moving, Reply::Code(code)) => {
                if let Some(p) = self.planned.as_mut() {
                    p.estimate.halt(now);
                }
                let text = self.planned.take().map(|p| p.cmd.text).unwrap_or_default();
                self.controller_fault(cx, &text, code);
            }
            (Stage::Measure, reply) => {
                if cx.position_reply(reply, now) {
                    let here = cx.position.and_then(|p| p.get(self.axis));
                    if self.from.is_none() {
                        self.from = here;
                    }
                    self.at = here;
                    self.decide();
                } else {
                    // The answer was a fault (reported) or nonsense.
                    let fault = cx.position_fault();
                    self.finish(JogEnd::Fault(fault));
                }
            }
            (Stage::TestOff, reply) => {
                if reply == Reply::Code(ReplyCode::Ok) {
                    cx.test_mode_left_on = false;
                } else {
                    let text = cx.cmd(Command::SetTestMode(false)).text;
                    cx.link_suspect(&text, &format!("{reply:?}"));
                    cx.notice(
                        "test mode may still be on (@0T0 was not confirmed): moves could run \
                         over the limit switches; reset the controller (ctrl-r)",
                    );
                }
                self.test_mode_on = false;
                self.stage = Stage::Done;
            }
            (stage, other) => {
                let what = format!("{stage:?}: {other:?}");
                let fault = cx.link_suspect("jog off limit", &what);
                cx.readback_wanted = true;
                self.planned = None;
                self.finish(JogEnd::Fault(fault));
            }
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        let fault = cx.link_suspect("jog off limit", "garbled reply");
        // Whether a move ended with `0`, `F`, `2` or `9` is unknown.
        cx.readback_wanted = self.stage == Stage::Moving;
        self.planned = None;
        self.finish(JogEnd::Fault(fault));
    }

    fn stop(&mut self, _cx: &mut Context, now: Instant) -> Option<Duration> {
        self.end.get_or_insert(JogEnd::Stopped);
        if self.stopping {
            return None;
        }
        self.stopping = true;
        match (self.stage, self.planned.as_mut()) {
            (Stage::Moving, Some(p)) => {
                p.estimate.brake(now);
                Some(deadline::motion(p.estimate.remaining(now)))
            }
            _ => {
                if self.stage == Stage::Move {
                    self.finish(JogEnd::Stopped);
                }
                None
            }
        }
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        let end = match cause {
            Abandon::LinkLost(_) => JogEnd::LinkLost,
            Abandon::Reset => {
                // 0xFE: test mode is off with everything else (2.2.31).
                cx.test_mode_left_on = false;
                JogEnd::Stopped
            }
        };
        self.end.get_or_insert(end);
        self.test_mode_on = false;
        self.stage = Stage::Done;
        self.report(cx);
    }

    fn activity(&self) -> Activity {
        match self.stage {
            Stage::Moving if self.stopping => Activity::Stopping,
            // Idle only once its end is told: a client sees the end before
            // the machine at rest.
            Stage::Done if self.reported => Activity::Idle,
            _ => Activity::Jogging,
        }
    }
}
