//! Storing a job in ROM (`Request::Upload`, manual 1.5.17, decision 2):
//! `@F`, then every command ended by CR and the last by 0x01, which ends the
//! transfer without running anything. Every line waits for its answer
//! (manual 1.4.2). `@F` replaces the stored job, so `erase_first` changes
//! nothing. Every line is checked with the core (`JobUpload`: buffered
//! commands only, 256 at most) before anything is sent.
//!
//! - A line answered 0x03 CR (memory full) fails the upload at that line.
//! - A stop aborts it: the answer to the line on the wire is awaited, then a
//!   bare 0x01 ends the transfer. It is no command, so the interface
//!   discards the partial job (and sets its error flag, decision 4:
//!   `docs/protocols.md`, EMCU); it can never be run by mistake.
//! - Either way `@X` is read at the end.

use std::time::Instant;

use crate::device::api::{Activity, ControllerFault, ProgramState, Recovery, Refusal};
use crate::device::common::limits::invalid;
use crate::device::common::upload::UploadProgress;
use crate::device::common::{Sink, link};
use crate::proto::emcu::{Command, Expect, JobUpload, Reply, Terminator, parse_line};

use super::context::{Cmd, Context};
use super::op::{Abandon, Next, Operation};

/// `ControllerFault::code` of a job the store has no room for (the
/// interface's `0x03 CR`, `docs/protocols.md`, EMCU).
pub const MEMORY_FULL_CODE: &str = "0x03";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// Line `i` of `lines` (0 is `@F`) is due or awaited.
    Line(usize, bool),
    /// The bare 0x01 that ends a transfer early.
    End(bool),
    /// `@X` at the end.
    Status(bool),
    Done,
}

#[derive(Debug)]
pub struct UploadOp {
    commands: Vec<Command>,
    lines: Vec<Cmd>,
    stage: Stage,
    stopping: bool,
    progress: UploadProgress,
    /// Why the transfer is ended early, once it is.
    aborted: Option<String>,
}

/// The bare 0x01: a line with no command, which ends a transfer.
pub fn transfer_end(cx: &Context) -> Cmd {
    let expect = Expect::AckOrMemoryFull;
    Cmd {
        bytes: vec![crate::proto::emcu::command::RUN_BUFFER],
        text: "<01>".to_owned(),
        expect,
        timeout: cx.ack_timeout(1, expect),
        may_move: false,
    }
}

impl UploadOp {
    pub fn new(cx: &Context, lines: &[String]) -> Result<UploadOp, Refusal> {
        if cx.transfer {
            return Err(invalid(
                "a job transfer (@F) is open: end it first (its last line ended by \\x01)",
            ));
        }
        cx.memory_free()?;
        let mut commands = Vec::with_capacity(lines.len());
        for (i, line) in lines.iter().enumerate() {
            let command = parse_line(line).map_err(|e| invalid(format!("line {}: {e}", i + 1)))?;
            commands.push(command);
        }
        let job = JobUpload::new(&commands).map_err(|e| invalid(e.to_string()))?;
        let cmds = job
            .lines()
            .iter()
            .map(|l| {
                let end = if l.bytes.last() == Some(&crate::proto::emcu::command::RUN_BUFFER) {
                    Terminator::RunBuffer
                } else {
                    Terminator::Cr
                };
                cx.cmd(&l.command, end)
            })
            .collect();
        Ok(UploadOp {
            progress: UploadProgress::new(commands.len()),
            commands,
            lines: cmds,
            stage: Stage::Line(0, false),
            stopping: false,
            aborted: None,
        })
    }

    /// End the transfer early with the bare 0x01, once `@F` was answered
    /// (line `next` is the first not sent).
    fn end_transfer(&mut self, next: usize) {
        self.stage = if next == 0 {
            Stage::Status(false)
        } else {
            Stage::End(false)
        };
    }

    fn finish(&mut self, cx: &mut Context) {
        if let Some(reason) = self.aborted.take() {
            cx.state.program = ProgramState::Invalid;
            self.progress.aborted(reason, cx);
        }
        self.stage = Stage::Done;
    }
}

impl Operation for UploadOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        match self.stage {
            Stage::Line(i, false) => match self.lines.get(i) {
                Some(line) => {
                    if i == 0 {
                        self.progress.start(now, cx);
                    }
                    self.stage = Stage::Line(i, true);
                    Next::Send(line.clone())
                }
                None => Next::Done,
            },
            Stage::End(false) => {
                self.stage = Stage::End(true);
                Next::Send(transfer_end(cx))
            }
            Stage::Status(false) => {
                self.stage = Stage::Status(true);
                Next::Send(cx.cmd(&Command::Status, Terminator::Cr))
            }
            Stage::Line(_, true) | Stage::End(true) | Stage::Status(true) => Next::Wait,
            Stage::Done => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        match self.stage {
            Stage::Line(i, true) => {
                let last = i + 1 >= self.lines.len();
                if i == 0 {
                    // `@F` discards the stored job (decision 2).
                    cx.transfer = true;
                    cx.job = None;
                    cx.state.program = ProgramState::Invalid;
                } else if reply == Reply::MemoryFull {
                    let text = self
                        .lines
                        .get(i)
                        .map(|l| l.text.clone())
                        .unwrap_or_default();
                    let fault = ControllerFault {
                        command: text,
                        code: MEMORY_FULL_CODE.into(),
                        meaning: "memory full: the job store has no room for this command (shorten the job or split it)"
                            .into(),
                        recovery: Recovery::None,
                    };
                    cx.emit(crate::device::api::Event::Fault(fault.clone()));
                    self.progress.failed(i - 1, fault, cx);
                    cx.state.program = ProgramState::Invalid;
                    if last {
                        cx.transfer = false;
                        self.stage = Stage::Status(false);
                    } else {
                        self.end_transfer(i + 1);
                    }
                    return;
                } else {
                    self.progress.line_done(i, now, cx);
                }
                if last {
                    cx.transfer = false;
                    cx.job = Some(self.commands.clone());
                    cx.state.program = ProgramState::Stored;
                    self.progress.finished(now, cx);
                    if self.stopping {
                        cx.notice("the stop came after the last line: the job is stored");
                    }
                    self.stage = Stage::Status(false);
                } else if self.stopping {
                    self.aborted = Some("stopped by the operator".into());
                    self.end_transfer(i + 1);
                } else {
                    self.stage = Stage::Line(i + 1, false);
                }
            }
            Stage::End(true) => {
                cx.transfer = false;
                self.stage = Stage::Status(false);
            }
            Stage::Status(true) => {
                if let Reply::Status(s) = reply {
                    cx.status_read(s, now);
                }
                self.finish(cx);
            }
            _ => {}
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        match self.stage {
            Stage::Line(i, true) => {
                // Whether the line was stored is unknown: end the transfer
                // for sure.
                cx.emit(crate::device::api::Event::Fault(link::unreadable(
                    &self
                        .lines
                        .get(i)
                        .map(|l| l.text.clone())
                        .unwrap_or_default(),
                    "garbled answer",
                )));
                self.aborted = Some("an answer was garbled".into());
                self.end_transfer(i.max(1));
            }
            Stage::End(true) => {
                cx.transfer_left_open = true;
                self.stage = Stage::Status(false);
            }
            _ => self.finish(cx),
        }
    }

    fn stop(&mut self, _cx: &mut Context, _now: Instant) {
        self.stopping = true;
        if let Stage::Line(i, false) = self.stage {
            self.aborted = Some("stopped by the operator".into());
            self.end_transfer(i);
        }
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        if self.stage != Stage::Done {
            if cx.transfer {
                cx.transfer_left_open = matches!(cause, Abandon::LinkLost(_));
                cx.transfer = false;
            }
            cx.state.program = ProgramState::Invalid;
            self.progress.abandoned(cause, "interface", cx);
            self.stage = Stage::Done;
        }
    }

    fn activity(&self) -> Activity {
        match self.stage {
            Stage::Done => Activity::Idle,
            _ if self.stopping => Activity::Stopping,
            _ => Activity::Uploading,
        }
    }
}
