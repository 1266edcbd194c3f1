//! Storing a program (`Request::Upload`, manual 2.2.13, chapter 3): `@0i`,
//! every line, `9`. Each stored line is answered `0` or an error; after an
//! error the controller is back in DNC mode and the partial program is
//! invalid (`docs/decisions.md` isel 9).
//!
//! - `@0i` answered `G`: a program (even a broken one) is stored. With
//!   `erase_first` it is erased (`@0k`, about 2 s) and `@0i` sent again;
//!   otherwise the upload fails with `Recovery::EraseProgram`.
//! - Every line is checked with `validate_cnc` before anything is sent; a
//!   `9` is appended when the program does not end with one, and a `9`
//!   anywhere else is refused (the lines after it would reach the
//!   controller in DNC mode).
//! - A stop aborts the upload: the reply of the line on the wire is awaited,
//!   then [`ABORT_LINE`] is sent. It is no CNC command (a `@` line answers
//!   `8`, manual chapter 5), so the controller ends storing with an error
//!   and marks the partial program invalid; it can never be mistaken for a
//!   complete program, which only `9` makes (manual 3.2.9). Should the
//!   controller not be storing after all, the line is an unknown DNC command
//!   and answers `5`. Either way nothing moves (`docs/protocols.md`, isel).

use std::time::{Duration, Instant};

use crate::device::api::{Activity, ProgramState, Refusal};
use crate::device::common::limits::invalid;
use crate::device::common::upload::UploadProgress;
use crate::proto::isel::{CncCommand, Command, ControlByte, Reply, ReplyCode, validate_cnc};

use super::context::{Context, control_outgoing};
use super::op::{Abandon, Next, Operation};

/// The line that ends storing on a stop: `@<device>#`.
pub fn abort_line(cx: &Context) -> String {
    format!("@{}#", cx.device)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Open,
    Erase,
    Lines(usize),
    Abort,
    Done,
}

#[derive(Debug)]
pub struct UploadOp {
    lines: Vec<CncCommand>,
    erase_first: bool,
    erased: bool,
    stage: Stage,
    storing: bool,
    stopping: bool,
    /// Client lines (the appended `9` is not among them) and how many the
    /// controller has acknowledged.
    progress: UploadProgress,
    abort_reason: String,
}

impl UploadOp {
    pub fn new(cx: &Context, lines: &[String], erase_first: bool) -> Result<UploadOp, Refusal> {
        if !cx.profile_ready() {
            return Err(Refusal::NotInitialised);
        }
        let config = cx.settings.config;
        if lines.is_empty() {
            return Err(invalid("the program has no lines"));
        }
        let mut parsed = Vec::with_capacity(lines.len() + 1);
        for (i, line) in lines.iter().enumerate() {
            let p =
                validate_cnc(line, config).map_err(|r| invalid(format!("line {}: {r}", i + 1)))?;
            if p.value == CncCommand::End && i + 1 != lines.len() {
                return Err(invalid(format!(
                    "line {}: `9` ends the program; only the last line may be `9`",
                    i + 1
                )));
            }
            parsed.push(p.value);
        }
        if parsed.last() != Some(&CncCommand::End) {
            parsed.push(CncCommand::End);
        }
        Ok(UploadOp {
            lines: parsed,
            erase_first,
            erased: false,
            stage: Stage::Open,
            storing: false,
            stopping: false,
            progress: UploadProgress::new(lines.len()),
            abort_reason: String::new(),
        })
    }

    fn aborted(&mut self, cx: &mut Context, reason: String) {
        self.progress.aborted(reason, &mut cx.events);
        self.stage = Stage::Done;
    }
}

impl Operation for UploadOp {
    fn next(&mut self, cx: &mut Context, now: Instant) -> Next {
        match self.stage {
            Stage::Open => {
                self.progress.start(now, &mut cx.events);
                Next::Send(cx.cmd(Command::StoreProgram))
            }
            Stage::Erase => Next::Send(cx.cmd(Command::EraseProgram)),
            Stage::Lines(i) => match self.lines.get(i) {
                Some(line) => Next::Send(cx.cnc(line)),
                None => Next::Done,
            },
            Stage::Abort => Next::Send(cx.literal(abort_line(cx))),
            Stage::Done => Next::Done,
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        let code = match reply {
            Reply::Code(code) => code,
            other => {
                cx.link_suspect("upload", &format!("{other:?}"));
                self.lost_reply(cx, now);
                return;
            }
        };
        match self.stage {
            Stage::Open => match code {
                ReplyCode::Ok => {
                    self.storing = true;
                    cx.state.program = ProgramState::Invalid;
                    cx.stored = None;
                    if self.stopping {
                        self.abort_reason = "stopped by the operator".into();
                        self.stage = Stage::Abort;
                    } else {
                        self.stage = Stage::Lines(0);
                    }
                }
                ReplyCode::InvalidDataField
                    if self.erase_first && !self.erased && !self.stopping =>
                {
                    self.stage = Stage::Erase;
                }
                code => {
                    if code == ReplyCode::InvalidDataField
                        && matches!(cx.state.program, ProgramState::Unknown | ProgramState::None)
                    {
                        cx.state.program = ProgramState::Stored;
                    }
                    let text = cx.cmd(Command::StoreProgram).text;
                    let fault = cx.controller_error(&text, code);
                    let reason = if code == ReplyCode::InvalidDataField {
                        "a program is already stored: erase it first (upload with erase)".to_owned()
                    } else {
                        format!("{text} answered {}: {}", code.char(), fault.meaning)
                    };
                    self.aborted(cx, reason);
                }
            },
            Stage::Erase => {
                if code == ReplyCode::Ok {
                    self.erased = true;
                    cx.state.program = ProgramState::None;
                    cx.stored = None;
                    self.stage = if self.stopping {
                        Stage::Done
                    } else {
                        Stage::Open
                    };
                    if self.stopping {
                        self.aborted(cx, "stopped by the operator".into());
                    }
                } else {
                    let text = cx.cmd(Command::EraseProgram).text;
                    let fault = cx.controller_error(&text, code);
                    self.aborted(cx, format!("erasing failed: {}", fault.meaning));
                }
            }
            Stage::Lines(i) => {
                let is_end = self.lines.get(i) == Some(&CncCommand::End);
                if code == ReplyCode::Ok {
                    if is_end {
                        self.storing = false;
                        cx.state.program = ProgramState::Stored;
                        cx.stored = Some(self.lines.clone());
                        self.progress.finished(now, &mut cx.events);
                        if self.stopping {
                            cx.notice("the stop came after the last line: the program is stored");
                        }
                        self.stage = Stage::Done;
                        return;
                    }
                    self.progress.line_done(i + 1, now, &mut cx.events);
                    if self.stopping {
                        self.abort_reason = "stopped by the operator".into();
                        self.stage = Stage::Abort;
                    } else {
                        self.stage = Stage::Lines(i + 1);
                    }
                } else {
                    // Back in DNC mode, the partial program is invalid (manual 3.1).
                    self.storing = false;
                    cx.state.program = ProgramState::Invalid;
                    let text = self.lines.get(i).map(|l| l.to_string()).unwrap_or_default();
                    let fault = cx.controller_error(&text, code);
                    self.progress.failed(i, fault, &mut cx.events);
                    self.stage = Stage::Done;
                }
            }
            Stage::Abort => {
                if code == ReplyCode::Ok {
                    // The controller stored the abort line: it is still storing.
                    // Only a reset gets it out without completing the program.
                    cx.notice(
                        "the controller kept storing after the abort line: resetting it (0xFE)",
                    );
                    cx.control.push_back(control_outgoing(ControlByte::Reset));
                    cx.apply_reset();
                    cx.quiet_request = Some(cx.settings.timing.reset_settle);
                }
                self.storing = false;
                cx.state.program = ProgramState::Invalid;
                let reason = std::mem::take(&mut self.abort_reason);
                self.aborted(cx, reason);
            }
            Stage::Done => {}
        }
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        // Whether the line was stored is unknown: end storing for sure.
        self.abort_reason = "a reply was garbled".into();
        cx.state.program = ProgramState::Invalid;
        self.storing = true;
        self.stage = Stage::Abort;
    }

    fn stop(&mut self, _cx: &mut Context, _now: Instant) -> Option<Duration> {
        self.stopping = true;
        None
    }

    fn abandon(&mut self, cx: &mut Context, cause: &Abandon) {
        if self.stage != Stage::Done {
            if self.storing {
                cx.state.program = ProgramState::Invalid;
            }
            self.progress.abandoned(cause, "controller", &mut cx.events);
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
