//! `RunProgram`: `@0S` starts the stored program (manual 2.2.23). While it
//! runs the controller sends only the program's sync characters (CNC `1`,
//! manual 3.2.3) and finally a reply code; positions are unknown meanwhile
//! and read with `@0P` at its end. A run has no deadline: a program may wait
//! for a sync character or sit in a delay for as long as it likes (manual
//! 3.2.4, 3.2.6), and a delay is not even ended by a stop. Reset (0xFE)
//! always ends it.
//!
//! On axes not referenced the start is refused unless the program
//! references them itself: jogterm stored it in this session and its first
//! commands are reference runs (`7`, manual 3.2.8) covering those axes
//! ([`leading_reference`], `device::common::gate::program_start`); a
//! program jogterm does not know starts only with
//! `isel.start_unreferenced = "allow"`.

use std::time::{Duration, Instant};

use crate::axis::AxisSet;
use crate::device::api::{Activity, ProgramState, Refusal};
use crate::device::common::gate::{self, StoredProgram};
use crate::proto::isel::{CncCommand, Command, Reply, ReplyCode, SyncChar};

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
    /// The axes the program references first (known programs only): they
    /// count as referenced once it has ended normally.
    references: AxisSet,
}

/// The axes the reference runs (`7`) at the start of a program cover: the
/// runs before its first command that is not a setting. Settings that may
/// come before are the reference speeds `d`, the circle plane `e` and
/// direction `f`, start-stop frequency `j`, acceleration `J`, 3D
/// interpolation `z` (none moves an axis, waits, branches or switches a
/// port or the brake); anything else ends the lead, so a program that moves,
/// waits, loops, branches, switches a port or the brake, sets test mode or
/// simulates a reference (`N`) before its reference run gets the axes it
/// referenced before that, often none (`docs/protocols.md`, "Assumptions").
pub fn leading_reference(lines: &[CncCommand]) -> AxisSet {
    let mut axes = AxisSet::EMPTY;
    for line in lines {
        match line {
            CncCommand::Reference(set) => {
                axes = AxisSet::from_mask(axes.mask() | set.mask());
            }
            CncCommand::SetReferenceSpeeds(_)
            | CncCommand::SetPlane(_)
            | CncCommand::SetCircleDirection(_)
            | CncCommand::SetStartStop(_)
            | CncCommand::SetAcceleration(_)
            | CncCommand::Set3dInterpolation(_) => {}
            _ => break,
        }
    }
    axes
}

impl ProgramOp {
    pub fn new(cx: &Context) -> Result<ProgramOp, Refusal> {
        let stored = match (&cx.stored, cx.state.program) {
            (Some(lines), ProgramState::Stored) => StoredProgram::Known {
                leading_reference: leading_reference(lines),
            },
            _ => StoredProgram::Unknown,
        };
        gate::program_start(
            cx.motion_allowed(false),
            stored,
            cx.settings.start_unreferenced,
        )?;
        let references = match stored {
            StoredProgram::Known { leading_reference } => leading_reference,
            StoredProgram::Unknown => AxisSet::EMPTY,
        };
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
                references,
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
                    Reply::Code(ReplyCode::Ok) => {
                        // Its reference runs have run (manual 3.2.8).
                        if !self.references.is_empty() {
                            cx.referenced(self.references);
                        }
                        cx.notice("the program has ended");
                    }
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
