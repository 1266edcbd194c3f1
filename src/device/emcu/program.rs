//! `RunProgram`: `@J` runs the job stored in ROM (manual 1.5.18); the
//! interface sends 0x02 CR when it has ended (decision 2). A job has no
//! deadline (it may wait for E1 or run for hours); a run that has not
//! reported its end is checked with `@X` once a second. What the job set
//! (speeds, ramp, outputs, references) is known only when jogterm uploaded
//! it: then it is applied at the end, otherwise those settings count as
//! unknown (`docs/protocols.md`, EMCU).
//!
//! On axes not referenced the job is refused unless it references them
//! itself: jogterm stored it in this session and its first commands are
//! `$H` reference runs (manual 1.5.9) covering those axes
//! ([`leading_reference`], `device::common::gate::program_start`); a job
//! jogterm does not know runs only with `emcu.start_unreferenced = "allow"`.

use crate::axis::AxisSet;
use crate::device::api::{Activity, ProgramState, Recovery, Refusal};
use crate::device::common::Sink;
use crate::device::common::gate::{self, StoredProgram};
use crate::proto::emcu::{Command, Status, Terminator};

use super::context::Context;
use super::effects;
use super::run::Run;
use super::run_op::{Purpose, RunOp};

#[derive(Debug)]
pub struct Job;

/// The axes the `$H` reference runs at the start of a job cover: the runs
/// before its first command that is not a setting. Only the start speed
/// `#S`, end speeds `#E` and the ramp `#R` may come before; a move, a wait,
/// an output or the E1 link ends the lead (`docs/protocols.md`,
/// "Assumptions").
pub fn leading_reference(commands: &[Command]) -> AxisSet {
    let mut axes = AxisSet::EMPTY;
    for command in commands {
        match command {
            Command::Reference(order) => {
                axes = AxisSet::from_mask(axes.mask() | order.set().mask());
            }
            Command::StartSpeed(_) | Command::EndSpeed { .. } | Command::Ramp(_) => {}
            _ => break,
        }
    }
    axes
}

/// Whether the stored job may be run; the operation that runs it.
pub fn job_op(cx: &Context) -> Result<RunOp<Job>, Refusal> {
    let stored = match (&cx.job, cx.state.program) {
        (Some(job), ProgramState::Stored) => StoredProgram::Known {
            leading_reference: leading_reference(job),
        },
        _ => StoredProgram::Unknown,
    };
    gate::program_start(
        cx.motion_allowed(false),
        stored,
        cx.settings.start_unreferenced,
    )?;
    cx.memory_free()?;
    match cx.state.program {
        ProgramState::None => Err(Refusal::Invalid {
            reason: "no job is stored: upload one first".into(),
        }),
        ProgramState::Invalid => Err(Refusal::Fault {
            recovery: Recovery::EraseProgram,
        }),
        ProgramState::Unknown | ProgramState::Stored => {
            let cmd = cx.cmd(&Command::RunJob, Terminator::Cr);
            let run = Run::new(vec![cmd], None, cx.settings.timing.run_margin);
            Ok(RunOp::new(Job, run))
        }
    }
}

impl Purpose for Job {
    fn text(&self) -> String {
        Command::RunJob.to_string()
    }

    fn ended(&mut self, cx: &mut Context, status: Status, stopped: bool) {
        match cx.job.clone() {
            Some(job) => effects::apply(cx, &job, !stopped && !status.position_unknown),
            None => effects::unknown(cx),
        }
        cx.notice(if stopped {
            "the job was stopped"
        } else {
            "the job has ended"
        });
    }

    fn unknown(&mut self, cx: &mut Context) {
        effects::unknown(cx);
    }

    fn activity(&self) -> Activity {
        Activity::RunningProgram
    }
}
