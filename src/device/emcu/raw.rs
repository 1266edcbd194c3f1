//! Command lines typed by the operator (`Request::Raw`, `jogterm send`).
//!
//! A line is checked with the core's parser before a byte is sent: the
//! interface answers every line with CR and only sets its error flag for a
//! bad one (decision 4), so refusing is jogterm's job. A line ends with CR;
//! one whose last character is U+0001 (written `\x01` in `jogterm send`)
//! ends with 0x01 instead and runs the data memory (manual 1.4.2). So the
//! operator writes batches as the interface takes them: `#E1,800`,
//! `L1,x500,y1000\x01`. After each batch has run, `@X` is read and its
//! flags reported.
//!
//! - `@X`, `@LX`/`@LY`/`@LZ`, `@V` answer at once, also while something
//!   runs (they go between the polls); `@B` and `@S` are stops and go out
//!   at once whatever runs; `@R` resets.
//! - A buffered line ended by CR is stored in the data memory (or, after
//!   `@F`, in the ROM job) and answered at its CR; one ended by 0x01 is
//!   answered at its CR too, and the run it starts is watched until its end
//!   (`Activity` shows it), so that positions can be read meanwhile.
//! - Moves (`L`, `@J`, `@C`, a batch with `L` in it) are refused with the
//!   error flag set and while the position is unknown; `$H` only with the
//!   error flag (manual 1.5.3).

use std::time::Instant;

use crate::axis::AxisSet;
use crate::device::api::{Activity, Event, ProgramState, Recovery, Refusal, ReplyKind};
use crate::device::common::limits::invalid;
use crate::device::common::{Sink, gate};
use crate::proto::emcu::{Command, Reply, Status, Terminator, parse_line};

pub use super::context::line_text;
use super::context::{Cmd, Context, ERROR_FLAG};
use super::effects;
use super::io::describe_status;
use super::op::{Abandon, Next, Operation};
use super::run::Run;
use super::run_op::{Purpose, RunOp};

/// The character that stands for 0x01 at the end of a raw line.
pub const RUN_MARK: char = '\u{1}';

/// A raw line: the command and the byte that ends it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawLine {
    pub command: Command,
    pub end: Terminator,
}

/// What the driver does with a raw line before it is its turn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RawKind {
    /// Answered at once, also while something runs: queries, and `@A` /
    /// `@C`, the pause and continue of a running job (manual 1.5.13,
    /// 1.5.14: master commands, taken during a job).
    Query,
    /// `@B`: jogterm's stop.
    Halt,
    /// `@S`: stop without a ramp, positions lost.
    Abort,
    /// `@R`.
    Reset,
    /// Everything else: its turn comes like any request's.
    Other,
}

impl RawLine {
    pub fn kind(&self) -> RawKind {
        match self.command {
            Command::Status
            | Command::Version
            | Command::Position(_)
            | Command::Pause
            | Command::Resume => RawKind::Query,
            Command::Halt => RawKind::Halt,
            Command::Stop => RawKind::Abort,
            Command::Reset => RawKind::Reset,
            _ => RawKind::Other,
        }
    }
}

impl RawLine {
    /// See [`line_text`].
    pub fn text(&self) -> String {
        line_text(&self.command, self.end)
    }
}

/// Parse and check a raw line (`docs/protocols.md`, EMCU, for the syntax).
pub fn parse_raw(line: &str) -> Result<RawLine, Refusal> {
    let (text, end) = match line.strip_suffix(RUN_MARK) {
        Some(text) => (text, Terminator::RunBuffer),
        None => (line, Terminator::Cr),
    };
    let command = parse_line(text).map_err(|e| invalid(format!("`{text}`: {e}")))?;
    if end == Terminator::RunBuffer && command.is_master() {
        return Err(invalid(format!(
            "`{text}` is a master command: it runs at once and cannot be ended with 0x01"
        )));
    }
    Ok(RawLine { command, end })
}

/// A batch or job started by a raw line, watched until its end.
#[derive(Debug)]
pub struct Batch {
    text: String,
    commands: Option<Vec<Command>>,
    activity: Activity,
}

impl Purpose for Batch {
    fn text(&self) -> String {
        self.text.clone()
    }

    fn ended(&mut self, cx: &mut Context, status: Status, stopped: bool) {
        match &self.commands {
            Some(commands) => effects::apply(cx, commands, !stopped && !status.position_unknown),
            None => effects::unknown(cx),
        }
        cx.notice(format!(
            "{} has {}: @X {}",
            self.text,
            if stopped { "been stopped" } else { "run" },
            describe_status(&status)
        ));
    }

    fn unknown(&mut self, cx: &mut Context) {
        effects::unknown(cx);
    }

    fn activity(&self) -> Activity {
        self.activity
    }
}

#[derive(Debug)]
enum Phase {
    Send,
    Await,
    /// The line started a run: watched until its end.
    Watch(RunOp<Batch>),
    /// A transfer was ended: `@X` tells whether the interface took it.
    Confirm(bool),
    Done,
}

#[derive(Debug)]
pub struct RawOp {
    line: RawLine,
    cmd: Cmd,
    phase: Phase,
}

fn has_move(commands: &[Command]) -> bool {
    commands
        .iter()
        .any(|c| matches!(c, Command::Move(_) | Command::RunJob | Command::Resume))
}

impl RawOp {
    pub fn new(cx: &Context, line: RawLine) -> Result<RawOp, Refusal> {
        let cmd = cx.cmd(&line.command, line.end);
        let starts_run = !cx.transfer
            && (line.end == Terminator::RunBuffer
                || matches!(line.command, Command::RunJob | Command::Resume));
        if starts_run {
            let mut commands = cx.stored.clone();
            commands.push(line.command);
            RawOp::check_run(cx, &commands)?;
        }
        if line.command == Command::RunJob {
            match cx.state.program {
                ProgramState::None => {
                    return Err(invalid(
                        "no job is stored: upload one first (@F)".to_owned(),
                    ));
                }
                ProgramState::Invalid => {
                    return Err(Refusal::Fault {
                        recovery: Recovery::EraseProgram,
                    });
                }
                ProgramState::Unknown | ProgramState::Stored => {}
            }
        }
        Ok(RawOp {
            line,
            cmd,
            phase: Phase::Send,
        })
    }

    /// A run that may move: not with the error flag set; moves not while the
    /// position is unknown (`$H` is what makes it known).
    fn check_run(cx: &Context, commands: &[Command]) -> Result<(), Refusal> {
        if !commands.iter().any(Command::may_move) {
            return Ok(());
        }
        gate::faults(&cx.state, |_| false)?;
        if let Some(f) = &cx.state.fault
            && f.code == ERROR_FLAG
        {
            return Err(Refusal::Fault {
                recovery: f.recovery,
            });
        }
        let missing: AxisSet = cx
            .settings
            .axes
            .iter()
            .filter(|a| !cx.state.referenced.contains(*a))
            .collect();
        if has_move(commands) && !missing.is_empty() {
            return Err(Refusal::NotReferenced { axes: missing });
        }
        Ok(())
    }

    fn reply_text(&self, cx: &Context, reply: &Reply) -> String {
        match reply {
            Reply::Status(_) | Reply::Position { .. } | Reply::Version(_) => query_text(reply),
            Reply::MemoryFull => {
                "0x03 CR: the data memory is full and runs; more buffered lines wait for 0x02 CR"
                    .to_owned()
            }
            // Said before `answered` has stored the line: counts include it.
            Reply::Ack | Reply::Ready => match (self.line.command.is_master(), self.line.end) {
                (true, _) => "CR (done)".to_owned(),
                (false, Terminator::Cr) if cx.transfer => {
                    format!("CR: stored in the job ({} lines)", job_len(cx) + 1)
                }
                (false, Terminator::Cr) => format!(
                    "CR: stored in the data memory ({} waiting; a line ended by \\x01 runs them)",
                    cx.stored.len() + 1
                ),
                (false, Terminator::RunBuffer) if cx.transfer => format!(
                    "CR: the job is stored ({} lines; @J runs it)",
                    job_len(cx) + 1
                ),
                (false, Terminator::RunBuffer) => "CR: running".to_owned(),
            },
        }
    }

    /// What the answered line changed.
    fn answered(&mut self, cx: &mut Context, reply: &Reply, now: Instant) {
        let command = self.line.command;
        self.phase = Phase::Done;
        match reply {
            Reply::Status(s) => return cx.status_read(*s, now),
            Reply::Position { axis, steps } => return cx.position_of(*axis, *steps),
            _ => {}
        }
        if command.is_master() {
            match command {
                Command::StoreJob => {
                    cx.transfer = true;
                    cx.job = Some(Vec::new());
                    cx.state.program = ProgramState::Invalid;
                }
                Command::RunJob => {
                    let commands = cx.job.clone();
                    self.watch(cx, commands, Activity::RunningProgram, now);
                }
                Command::Resume => self.watch(cx, None, Activity::Moving, now),
                _ => {}
            }
            return;
        }
        if cx.transfer {
            if let Some(job) = cx.job.as_mut() {
                job.push(command);
            }
            if self.line.end == Terminator::RunBuffer {
                // The last line of the job ends the transfer (decision 2).
                cx.transfer = false;
                cx.state.program = ProgramState::Stored;
                self.phase = Phase::Confirm(false);
            }
            return;
        }
        if self.line.end == Terminator::RunBuffer || *reply == Reply::MemoryFull {
            // The data memory runs: what was stored, then this line.
            let mut commands = std::mem::take(&mut cx.stored);
            commands.push(command);
            let activity = if commands.iter().any(Command::may_move) {
                Activity::Moving
            } else {
                Activity::Idle
            };
            self.watch(cx, Some(commands), activity, now);
        } else {
            cx.stored.push(command);
        }
    }

    fn watch(
        &mut self,
        cx: &Context,
        commands: Option<Vec<Command>>,
        activity: Activity,
        now: Instant,
    ) {
        let run = Run::watching(None, cx.settings.timing.run_margin, now);
        let batch = Batch {
            text: self.cmd.text.clone(),
            commands,
            activity,
        };
        self.phase = Phase::Watch(RunOp::new(batch, run));
    }
}

/// The answer to a query, decoded: `@X100110: moving, position unknown,
/// referencing`, `@LX1234: X = 1234 steps`, `@V SMC3000i 1.00`.
pub fn query_text(reply: &Reply) -> String {
    match reply {
        Reply::Status(s) => format!(
            "@X{}: {}",
            String::from_utf8_lossy(&s.digits()),
            describe_status(s)
        ),
        Reply::Position { axis, steps } => format!("@L{axis}{steps}: {axis} = {steps} steps"),
        Reply::Version(v) => format!("@V {v}"),
        other => other.to_string(),
    }
}

fn job_len(cx: &Context) -> usize {
    cx.job.as_ref().map_or(0, Vec::len)
}

impl Operation for RawOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        match &mut self.phase {
            Phase::Send => {
                self.phase = Phase::Await;
                Next::Send(self.cmd.clone())
            }
            Phase::Await | Phase::Confirm(true) => Next::Wait,
            Phase::Watch(op) => op.next(cx, now),
            Phase::Confirm(false) => {
                self.phase = Phase::Confirm(true);
                Next::Send(cx.cmd(&Command::Status, Terminator::Cr))
            }
            Phase::Done => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match &mut self.phase {
            Phase::Await => {
                let text = self.reply_text(cx, &reply);
                self.answered(cx, &reply, now);
                cx.emit(Event::Reply {
                    kind: ReplyKind::Answer,
                    command: self.cmd.text.clone(),
                    text,
                });
            }
            Phase::Watch(op) => op.reply(cx, reply, now),
            Phase::Confirm(true) => {
                if let Reply::Status(s) = reply {
                    cx.status_read(s, now);
                    if s.error {
                        cx.state.program = ProgramState::Invalid;
                    }
                }
                self.phase = Phase::Done;
            }
            Phase::Send | Phase::Confirm(false) | Phase::Done => {}
        }
    }

    fn ready(&mut self, cx: &mut Context, now: Instant) {
        if let Phase::Watch(op) = &mut self.phase {
            op.ready(cx, now);
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, now: Instant) {
        match &mut self.phase {
            Phase::Watch(op) => op.lost_reply(cx, now),
            _ => {
                cx.emit(Event::Fault(crate::device::common::link::unreadable(
                    &self.cmd.text,
                    "garbled answer",
                )));
                if self.cmd.may_move || self.line.end == Terminator::RunBuffer {
                    cx.halt_wanted = true;
                    cx.readback_wanted = true;
                }
                self.phase = Phase::Done;
            }
        }
    }

    fn stop(&mut self, cx: &mut Context, now: Instant) {
        match &mut self.phase {
            Phase::Watch(op) => op.stop(cx, now),
            // A line that is answered starts nothing after the `@B`; one on
            // its way is stopped again by the driver once it is out.
            Phase::Send => self.phase = Phase::Done,
            _ => {}
        }
    }

    fn timer(&self) -> Option<Instant> {
        match &self.phase {
            Phase::Watch(op) => op.timer(),
            _ => None,
        }
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) -> bool {
        match &mut self.phase {
            Phase::Watch(op) => op.on_timer(cx, now),
            _ => false,
        }
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        if let Phase::Watch(op) = &mut self.phase {
            op.abandon(cx, cause);
        }
        self.phase = Phase::Done;
    }

    fn activity(&self) -> Activity {
        match &self.phase {
            Phase::Watch(op) => op.activity(),
            Phase::Send | Phase::Await if self.cmd.may_move => Activity::Moving,
            _ => Activity::Idle,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_run_mark_ends_a_line_with_0x01() {
        let l = parse_raw("L1,x100\u{1}").expect("line");
        assert_eq!(l.end, Terminator::RunBuffer);
        assert_eq!(l.kind(), RawKind::Other);
        assert_eq!(parse_raw("@LX").map(|l| l.kind()), Ok(RawKind::Query));
        assert_eq!(parse_raw("@B").map(|l| l.kind()), Ok(RawKind::Halt));
        let err = parse_raw("@X\u{1}").unwrap_err();
        assert!(err.to_string().contains("master command"), "{err}");
        let err = parse_raw("L1,X5,y5").unwrap_err();
        assert!(err.to_string().contains("mixes absolute"), "{err}");
        assert!(parse_raw("").is_err());
    }
}
