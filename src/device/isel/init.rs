//! `Initialise`: the axis setting for the profile's axes (`@07`, then `@08`
//! for A, manual 2.2.1), the profile's ramp (`@0j`, `@0J`) and reference
//! speeds (`@0d`), then the reference probe (the axis setting does not say
//! whether the axes stay referenced, `docs/decisions.md` isel 4) and
//! the position.

use std::time::Instant;

use crate::axis::AxisSet;
use crate::device::api::Activity;
use crate::proto::isel::{AxisConfig, AxisSetting, Command, Reply, ReplyCode};

use super::context::Context;
use super::op::{Abandon, Next, Operation};
use super::readback::{probe_command, ramp_applied, ramp_command};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Axes(usize),
    Ramp(usize),
    Probe,
    Measure,
    Done,
}

#[derive(Debug)]
pub struct InitOp {
    stage: Stage,
    sequence: &'static [AxisSetting],
}

impl InitOp {
    pub fn new(cx: &Context) -> InitOp {
        InitOp {
            stage: Stage::Axes(0),
            sequence: AxisSetting::sequence_for(cx.settings.config),
        }
    }

    fn failed(&mut self, cx: &mut Context, text: &str, code: ReplyCode) {
        cx.controller_error(text, code);
        self.stage = Stage::Measure;
    }
}

impl Operation for InitOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        if let Stage::Axes(i) = self.stage
            && i >= self.sequence.len()
        {
            self.stage = Stage::Ramp(0);
        }
        match self.stage {
            Stage::Axes(i) => match self.sequence.get(i) {
                Some(s) => Next::Send(cx.cmd(Command::SetAxes(*s))),
                None => Next::Done,
            },
            Stage::Ramp(i) => match ramp_command(cx, i) {
                Some(c) => Next::Send(cx.cmd(c)),
                None => {
                    self.stage = Stage::Probe;
                    Next::Send(probe_command(cx, cx.settings.config))
                }
            },
            Stage::Probe => Next::Send(probe_command(cx, cx.settings.config)),
            Stage::Measure => Next::Send(cx.cmd(Command::ReadPosition)),
            Stage::Done => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match (self.stage, reply) {
            (Stage::Axes(i), Reply::Code(ReplyCode::Ok)) => {
                if let Some(s) = self.sequence.get(i) {
                    // The axis setting keeps counters, reference and zero
                    // (`docs/protocols.md`, isel).
                    cx.set_config(AxisConfig::after_setting(cx.config, *s).ok());
                }
                self.stage = Stage::Axes(i + 1);
            }
            (Stage::Axes(i), Reply::Code(code)) => {
                let text = self
                    .sequence
                    .get(i)
                    .map(|s| cx.cmd(Command::SetAxes(*s)).text)
                    .unwrap_or_default();
                self.failed(cx, &text, code);
            }
            (Stage::Ramp(i), Reply::Code(code)) => {
                if let Some(c) = ramp_command(cx, i) {
                    if code == ReplyCode::Ok {
                        ramp_applied(cx, &c);
                    } else {
                        let text = cx.cmd(c).text;
                        cx.controller_error(&text, code);
                    }
                }
                self.stage = Stage::Ramp(i + 1);
            }
            (Stage::Probe, Reply::Code(code)) => {
                match code {
                    ReplyCode::Ok => cx.referenced(cx.settings.axis_set()),
                    ReplyCode::ReferenceRequired => cx.state.referenced = AxisSet::EMPTY,
                    other => {
                        cx.state.referenced = AxisSet::EMPTY;
                        let text = probe_command(cx, cx.settings.config).text;
                        cx.controller_error(&text, other);
                    }
                }
                if cx.profile_ready() {
                    cx.initialised_after_fault();
                }
                self.stage = Stage::Measure;
            }
            (Stage::Measure, reply) => {
                cx.position_reply(reply, now);
                self.stage = Stage::Done;
            }
            (_, other) => {
                cx.link_suspect("initialise", &format!("{other:?}"));
                cx.readback_wanted = true;
                self.stage = Stage::Done;
            }
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        cx.readback_wanted = true;
        self.stage = Stage::Done;
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.stage = Stage::Done;
    }

    fn activity(&self) -> Activity {
        Activity::Idle
    }
}
