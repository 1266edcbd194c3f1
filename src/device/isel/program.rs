//! `RunProgram`: `@0S` starts the stored program (manual 2.2.23). While it
//! runs the controller sends only the program's sync characters (CNC `1`,
//! manual 3.2.3) and finally a reply code; positions are unknown meanwhile
//! and read with `@0P` at its end. A run has no deadline: a program may wait
//! for a sync character or sit in a delay for as long as it likes (manual
//! 3.2.4, 3.2.6), and a delay is not even ended by a stop. Reset (0xFE)
//! always ends it.

use std::time::{Duration, Instant};

use crate::device::api::{Activity, ProgramState, Refusal};
use crate::proto::isel::{Command, Reply, ReplyCode, SyncChar};

use super::context::Context;
use super::op::{Abandon, Next, Operation};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Start,
    Running,
    Measure,
    Done,
}

#[derive(Debug)]
pub struct ProgramOp {
    phase: Phase,
    stopping: bool,
}

impl ProgramOp {
    pub fn new(cx: &Context) -> Result<ProgramOp, Refusal> {
        cx.motion_allowed(false)?;
        match cx.state.program {
            ProgramState::None => Err(Refusal::Invalid {
                reason: "no program is stored: upload one first".into(),
            }),
            ProgramState::Invalid => Err(Refusal::Fault {
                recovery: crate::device::api::Recovery::EraseProgram,
            }),
            ProgramState::Unknown | ProgramState::Stored => Ok(ProgramOp {
                phase: Phase::Start,
                stopping: false,
            }),
        }
    }
}

impl Operation for ProgramOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        match self.phase {
            Phase::Start => {
                self.phase = Phase::Running;
                // A stored program may write any port (CNC `p`, `@0Ia`).
                cx.ports.forget_outputs();
                Next::Send(cx.cmd(Command::Start))
            }
            Phase::Running => Next::Wait,
            Phase::Measure => Next::Send(cx.cmd(Command::ReadPosition)),
            Phase::Done => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match self.phase {
            Phase::Running => {
                match reply {
                    Reply::Code(ReplyCode::Ok) => cx.notice("the program has ended"),
                    // The stop sequence's break ends the run (isel decision 6).
                    Reply::Code(ReplyCode::UserStop) if self.stopping => {
                        cx.notice("the program was stopped")
                    }
                    Reply::Code(code) => {
                        let text = cx.cmd(Command::Start).text;
                        cx.controller_error(&text, code);
                    }
                    other => {
                        cx.link_suspect("program run", &format!("{other:?}"));
                        cx.readback_wanted = true;
                    }
                }
                if self.stopping {
                    cx.quiet_request = Some(cx.settings.timing.resync_gap);
                }
                self.phase = Phase::Measure;
            }
            Phase::Measure => {
                cx.position_reply(reply, now);
                self.phase = Phase::Done;
            }
            Phase::Start | Phase::Done => {}
        }
    }

    fn sync(&mut self, cx: &mut Context, sync: SyncChar, _now: Instant) {
        cx.notice(format!("program sync character `{sync}`"));
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        cx.link_suspect("program run", "garbled reply");
        cx.readback_wanted = true;
        self.phase = Phase::Done;
    }

    fn stop(&mut self, _cx: &mut Context, _now: Instant) -> Option<Duration> {
        if self.phase == Phase::Running {
            self.stopping = true;
        }
        None
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.phase = Phase::Done;
    }

    fn activity(&self) -> Activity {
        match self.phase {
            Phase::Start | Phase::Running if self.stopping => Activity::Stopping,
            Phase::Start | Phase::Running => Activity::RunningProgram,
            _ => Activity::Idle,
        }
    }
}
