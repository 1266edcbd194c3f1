//! A probe on an isel controller (`Request::Probe`, `docs/probing.md`):
//! the cycle of `common::probe`, each pass one `@0Z` (manual 2.2.30), a
//! relative move that ends when `port & mask == value`, on the port and
//! bit of the profile's probe input (in1.5, "Längenmesstaster", by
//! default). The manual does not say whether `@0Z` answers otherwise when
//! the port ended it than when its steps ran out, so after every pass the
//! input is read (`@0b`) and then the position (`@0P`): the input says
//! whether it tripped, the position where the axis stopped.

use std::time::{Duration, Instant};

use crate::device::api::{Activity, Event, JogId, ProbeEnd, ProbeMove, Refusal};
use crate::device::common::link;
use crate::device::common::probe::{self, Cycle, Pass, ProbeInput, Step, Until};
use crate::proto::isel::{Command, ControlByte, InputPort, PortMove, Reply, ReplyCode};

use super::context::{Context, control_outgoing, is_limit_fault};
use super::deadline;
use super::op::{Abandon, Next, Operation};
use super::plan::{self, Planned};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// The input, then the position, before anything moves.
    ReadStart,
    MeasureStart,
    /// A pass or the return is planned, not yet handed out.
    Move,
    /// It is out; it answers when it is done.
    Moving,
    /// The input after a pass, then the position.
    Read,
    Measure,
    Done,
}

#[derive(Debug)]
pub struct ProbeOp {
    id: JogId,
    probe: ProbeMove,
    input: ProbeInput,
    port: InputPort,
    stage: Stage,
    cycle: Option<Cycle>,
    /// What the cycle asked for last.
    step: Option<Step>,
    planned: Option<Planned>,
    /// The input as read after the last pass.
    touched: bool,
    end: Option<ProbeEnd>,
    stopping: bool,
    reported: bool,
    /// When the DRO gets the next estimate while a pass runs: the
    /// controller cannot be asked during a move (manual 2.2.2).
    next_estimate: Option<Instant>,
}

impl ProbeOp {
    pub fn new(cx: &Context, id: JogId, probe: ProbeMove) -> Result<ProbeOp, Refusal> {
        let input = probe::probe_input(&cx.settings.wiring)?;
        let port = match input.key.source {
            crate::device::api::InputSource::IselPort(p) => InputPort::from_number(u64::from(p)),
            _ => None,
        }
        .ok_or_else(|| {
            crate::device::common::limits::invalid(format!(
                "the probe input {} is no isel input port",
                input.address
            ))
        })?;
        probe::check(
            &cx.state,
            cx.profile_ready(),
            cx.settings.axis_set(),
            &cx.settings.axes,
            &probe,
            cx.position.and_then(|p| p.get(probe.axis)),
            is_limit_fault,
        )?;
        // isel stops from the start-stop frequency without a ramp (2.2.16):
        // the slow pass never runs faster, whatever was asked.
        let slow_hz = probe.slow_hz.min(f64::from(cx.ramp.start_stop_hz));
        Ok(ProbeOp {
            id,
            probe: ProbeMove { slow_hz, ..probe },
            input,
            port,
            stage: Stage::ReadStart,
            cycle: None,
            step: None,
            planned: None,
            touched: false,
            end: None,
            stopping: false,
            reported: false,
            next_estimate: None,
        })
    }

    fn finish(&mut self, end: ProbeEnd) {
        self.end.get_or_insert(end);
        self.stage = Stage::Done;
    }

    /// The command of the step the cycle asked for.
    fn plan(&self, cx: &Context, step: &Step) -> Result<Planned, Refusal> {
        match *step {
            Step::Pass(pass) => self.pass(cx, pass),
            Step::Return { axis, to, hz } => {
                let here = cx
                    .position
                    .and_then(|p| p.get(axis))
                    .ok_or(Refusal::NotConnected)?;
                let hz = plan::speed_hz(cx, axis, Some(hz))?;
                plan::limit_step(cx, axis, to - here, hz)
            }
            Step::End(_) => Err(crate::device::common::limits::invalid(
                "the probe has ended",
            )),
        }
    }

    /// `@0Z` for one pass: the relative move it stands for gives the
    /// estimate and the deadline, the port condition ends it.
    fn pass(&self, cx: &Context, pass: Pass) -> Result<Planned, Refusal> {
        let hz = plan::speed_hz(cx, pass.axis, Some(pass.hz))?;
        let steps = pass.dir.sign() * pass.steps;
        let mut planned = plan::limit_step(cx, pass.axis, steps, hz)?;
        let mask = 1u8 << self.input.key.bit;
        let touched_level = if self.input.active_high { mask } else { 0 };
        let value = match pass.until {
            Until::Touched => touched_level,
            Until::Released => mask ^ touched_level,
        };
        let axes = cx.settings.config.axes();
        let all_steps = axes
            .iter()
            .map(|a| {
                if a == pass.axis {
                    i32::try_from(steps).unwrap_or(0)
                } else {
                    0
                }
            })
            .collect();
        let timeout = planned.cmd.timeout;
        planned.cmd = cx.cmd(Command::MoveUntilPort(PortMove {
            port: self.port,
            mask,
            value,
            speed: hz,
            steps: all_steps,
        }));
        planned.cmd.timeout = timeout;
        Ok(planned)
    }

    /// Where the cycle goes after a pass, the input and position read.
    fn advance(&mut self, cx: &Context) {
        if self.stopping {
            self.finish(ProbeEnd::Stopped);
            return;
        }
        let Some(at) = cx.position else {
            self.finish(ProbeEnd::Fault(link::unreadable("@0P", "no position")));
            return;
        };
        let here = at.get(self.probe.axis).unwrap_or(0);
        let next = Cycle::advance(
            &mut self.cycle,
            self.probe,
            self.step.as_ref(),
            self.touched,
            &at,
            here,
        );
        match next {
            Step::End(end) => self.finish(end),
            step => {
                self.step = Some(step);
                self.stage = Stage::Move;
            }
        }
    }

    fn report(&mut self, cx: &mut Context) {
        if self.reported {
            return;
        }
        self.reported = true;
        let end = self.end.clone().unwrap_or(ProbeEnd::Stopped);
        cx.emit(Event::ProbeEnded { id: self.id, end });
    }

    fn fault(&mut self, cx: &mut Context, command: &str, code: ReplyCode) {
        let fault = cx.controller_error(command, code);
        self.finish(ProbeEnd::Fault(fault));
    }
}

impl Operation for ProbeOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        loop {
            return match self.stage {
                Stage::ReadStart | Stage::Read => Next::Send(cx.cmd(Command::ReadPort(self.port))),
                Stage::MeasureStart | Stage::Measure => Next::Send(cx.cmd(Command::ReadPosition)),
                Stage::Move => {
                    let planned = match &self.step {
                        Some(step) => self.plan(cx, step),
                        None => Err(Refusal::NotConnected),
                    };
                    match planned {
                        Ok(p) => {
                            let cmd = p.cmd.clone();
                            self.planned = Some(p);
                            self.stage = Stage::Moving;
                            Next::Send(cmd)
                        }
                        Err(reason) => {
                            self.finish(ProbeEnd::Refused(reason));
                            continue;
                        }
                    }
                }
                Stage::Moving => Next::Wait,
                Stage::Done => {
                    self.report(cx);
                    Next::Done
                }
            };
        }
    }

    fn transmitted(&mut self, cx: &mut Context, now: Instant) {
        if self.stage == Stage::Moving
            && let Some(p) = self.planned.as_mut()
        {
            p.estimate.start(now);
            cx.estimated(p.estimate.position_at(now), now);
            self.next_estimate = Some(now + cx.settings.timing.estimate_interval);
        }
    }

    fn timer(&self) -> Option<Instant> {
        self.next_estimate
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) -> bool {
        match (self.stage, self.planned.as_ref()) {
            (Stage::Moving, Some(p)) => {
                cx.estimated(p.estimate.position_at(now), now);
                self.next_estimate = Some(now + cx.settings.timing.estimate_interval);
            }
            _ => self.next_estimate = None,
        }
        false
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        self.next_estimate = None;
        match (self.stage, reply) {
            (Stage::ReadStart | Stage::Read, Reply::Byte(v)) => {
                cx.port_read(self.port, v, now);
                cx.emit_io(now);
                self.touched = self.input.touched(v);
                if self.stage == Stage::ReadStart && self.touched {
                    self.finish(ProbeEnd::Refused(Cycle::tripped_at_start(&self.input)));
                } else if self.stopping {
                    self.finish(ProbeEnd::Stopped);
                } else {
                    self.stage = if self.stage == Stage::ReadStart {
                        Stage::MeasureStart
                    } else {
                        Stage::Measure
                    };
                }
            }
            (Stage::MeasureStart | Stage::Measure, reply) => {
                if cx.position_reply(reply, now) {
                    self.advance(cx);
                } else {
                    let fault = cx.position_fault();
                    self.finish(ProbeEnd::Fault(fault));
                }
            }
            (Stage::Moving, Reply::Code(ReplyCode::Ok)) => {
                self.planned = None;
                let returning = matches!(self.step, Some(Step::Return { .. }));
                self.stage = if returning || self.stopping {
                    Stage::Measure
                } else {
                    Stage::Read
                };
            }
            (Stage::Moving, Reply::Code(ReplyCode::UserStop)) => {
                if !self.stopping {
                    // The controller's stop key: its rest is kept for a
                    // start; break it off (isel decision 6).
                    cx.control.push_back(control_outgoing(ControlByte::Break));
                    cx.notice("the probe was stopped at the controller");
                }
                cx.quiet_request = Some(cx.settings.timing.resync_gap);
                self.planned = None;
                self.finish(ProbeEnd::Stopped);
            }
            (Stage::Moving, Reply::Code(code)) => {
                if let Some(p) = self.planned.as_mut() {
                    p.estimate.halt(now);
                }
                let text = self.planned.take().map(|p| p.cmd.text).unwrap_or_default();
                self.fault(cx, &text, code);
            }
            (stage, other) => {
                let what = format!("{stage:?}: {other:?}");
                let fault = cx.link_suspect("probe", &what);
                cx.readback_wanted = true;
                self.planned = None;
                self.finish(ProbeEnd::Fault(fault));
            }
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        let fault = cx.link_suspect("probe", "garbled reply");
        // Whether a move ended with `0`, `F`, `2` or `9` is unknown.
        cx.readback_wanted = self.stage == Stage::Moving;
        self.planned = None;
        self.finish(ProbeEnd::Fault(fault));
    }

    fn stop(&mut self, _cx: &mut Context, now: Instant) -> Option<Duration> {
        self.end.get_or_insert(ProbeEnd::Stopped);
        if self.stopping {
            return None;
        }
        self.stopping = true;
        match (self.stage, self.planned.as_mut()) {
            (Stage::Moving, Some(p)) => {
                p.estimate.brake(now);
                Some(deadline::motion(p.estimate.remaining(now)))
            }
            (Stage::Move, _) => {
                self.finish(ProbeEnd::Stopped);
                None
            }
            _ => None,
        }
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        let end = match cause {
            Abandon::LinkLost(_) => ProbeEnd::LinkLost,
            Abandon::Reset => ProbeEnd::Stopped,
        };
        self.end.get_or_insert(end);
        self.stage = Stage::Done;
        self.report(cx);
    }

    fn activity(&self) -> Activity {
        match self.stage {
            Stage::Moving if self.stopping => Activity::Stopping,
            Stage::Done if self.reported => Activity::Idle,
            _ => Activity::Probing,
        }
    }
}
