//! Command lines typed by the operator (`Request::Raw`, `jogterm send`).
//!
//! A line is parsed and checked with the core's parser and checks against
//! the controller's axis configuration before a byte is sent (`parse_frame`
//! and `check_with`, as `validate_frame` does; `validate_cnc` while the
//! controller is storing a program after `@0i`).
//! Motion commands are refused in E-stop and after a `2`/`9` until the axes
//! have been initialised again; whether they need a reference is left to the
//! controller, which answers `R` itself (`docs/decisions.md` isel 4).
//! What a command changes in the controller (axes, reference, zero, ramp,
//! test mode, program memory, outputs, device number) is followed, so the
//! driver's picture stays right.
//!
//! A line that is a single control character U+00FD, U+00FE or U+00FF is the
//! control byte itself (manual 2.2.31); the driver sends it at once.

use std::time::{Duration, Instant};

use crate::axis::AxisSet;
use crate::device::api::{Activity, Event, ProgramState, Refusal, ReplyKind};
use crate::device::common::limits::invalid;
use crate::proto::isel::{
    AxisConfig, CncCommand, Command, ControlByte, InitCommand, Rejection, Reply, ReplyCode,
    SyncChar, check_with, parse_frame, validate_cnc,
};

use super::context::{Cmd, Context};
use super::deadline;
use super::op::{Abandon, Next, Operation};
use super::reply_text::{code_text, reply_text};
use crate::proto::isel::estimate::MoveEstimate;

/// The control byte a raw line stands for, if it is one.
pub fn control_of(line: &str) -> Option<ControlByte> {
    let mut chars = line.chars();
    match (chars.next(), chars.next()) {
        (Some(c), None) => u8::try_from(u32::from(c))
            .ok()
            .and_then(ControlByte::from_byte),
        _ => None,
    }
}

/// Whether a raw line may set an axis in motion: a DNC command that may
/// (`Command::may_move`), or a line that does not parse as one (a stored
/// CNC line, a mistake: the safe side). Control bytes stop.
pub fn line_may_move(line: &str) -> bool {
    if control_of(line).is_some() {
        return false;
    }
    parse_frame(line).map_or(true, |f| f.value.command.may_move())
}

#[derive(Debug, Clone, PartialEq)]
enum Line {
    Dnc(Command),
    Cnc(CncCommand),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Send,
    Waiting,
    Measure,
    Done,
}

#[derive(Debug)]
pub struct RawOp {
    line: Line,
    cmd: Cmd,
    estimate: Option<MoveEstimate>,
    phase: Phase,
    stopping: bool,
    /// The stop sequence broke the command off: nothing is left to resume.
    broken_off: bool,
    syncs: String,
    next_estimate: Option<Instant>,
    /// A line of a program check-out (`checkout_op`): its answers are the
    /// check-out's to tell, not replies for the console, and an `F` after
    /// its own 0xFD is the pause it asked for, no fault.
    checkout: bool,
    /// Whether the position is read (`@0P`) after a move that ended; a
    /// stream leaves it out where the move's end is exactly known
    /// ([`RawOp::skip_read_back`]).
    read_back: bool,
}

impl RawOp {
    pub fn new(cx: &Context, text: &str) -> Result<RawOp, Refusal> {
        if cx.cnc_store {
            return RawOp::stored_line(cx, text);
        }
        let frame = parse_frame(text)
            .map_err(|e| invalid(Rejection::from(e).to_string()))?
            .value;
        if frame.device != cx.device {
            return Err(invalid(format!(
                "`{text}` is addressed to device {}; the controller is device {}",
                frame.device, cx.device
            )));
        }
        let command = frame.command;
        // Safety first: a move in E-stop is refused as such, whatever else
        // is wrong with it.
        if command.may_move() {
            cx.raw_motion_allowed()?;
        }
        check_with(&command, cx.config).map_err(|e| invalid(e.to_string()))?;
        if command == Command::SetTestMode(true) && !cx.settings.test_mode_allowed {
            return Err(invalid(
                "test mode (moves without reference and over limit switches) is not allowed \
                 by the profile (isel.test_mode)",
            ));
        }
        let mut cmd = cx.cmd(command.clone());
        let estimate = RawOp::estimate(cx, &command);
        if let Some(e) = &estimate {
            cmd.timeout = Some(deadline::motion(e.duration()));
        }
        let estimate = estimate.filter(|_| RawOp::estimate_trusted(cx, &command));
        Ok(RawOp {
            line: Line::Dnc(command),
            cmd,
            estimate,
            phase: Phase::Send,
            stopping: false,
            broken_off: false,
            syncs: String::new(),
            next_estimate: None,
            checkout: false,
            read_back: true,
        })
    }

    fn stored_line(cx: &Context, text: &str) -> Result<RawOp, Refusal> {
        let config = cx.config.ok_or_else(|| {
            invalid("the controller is storing a program but its axes are unknown")
        })?;
        let parsed = validate_cnc(text, config).map_err(|r| {
            invalid(format!(
                "{r} (the controller is storing a program after @0i)"
            ))
        })?;
        let cmd = cx.cnc(&parsed.value);
        Ok(RawOp {
            line: Line::Cnc(parsed.value),
            cmd,
            estimate: None,
            phase: Phase::Send,
            stopping: false,
            broken_off: false,
            syncs: String::new(),
            next_estimate: None,
            checkout: false,
            read_back: true,
        })
    }

    /// The move's estimate: exact for `A` from a known position, for `M`
    /// with a known virtual zero too; otherwise only its duration counts
    /// (from position 0, zero 0) for the deadline.
    fn estimate(cx: &Context, command: &Command) -> Option<MoveEstimate> {
        let config = cx.config?;
        let start = cx.position.unwrap_or_default();
        match command {
            Command::MoveRelative(pairs) => Some(MoveEstimate::relative(
                config, pairs, start, cx.ramp, cx.three_d,
            )),
            Command::MoveAbsolute(pairs) => Some(MoveEstimate::absolute(
                config,
                pairs,
                start,
                cx.state.work_zero,
                cx.ramp,
                cx.three_d,
            )),
            _ => None,
        }
    }

    fn estimate_trusted(cx: &Context, command: &Command) -> bool {
        let known = |config: AxisConfig| config.axes().iter().all(|a| cx.zero_known.contains(a));
        cx.position.is_some()
            && match command {
                Command::MoveRelative(_) => true,
                Command::MoveAbsolute(_) => cx.config.is_some_and(known),
                _ => false,
            }
    }

    /// A check-out line (`checkout_op`): a DNC line, quiet.
    pub fn for_checkout(cx: &Context, text: &str) -> Result<RawOp, Refusal> {
        if cx.cnc_store {
            return Err(invalid(
                "the controller is storing a program: a check-out sends DNC lines",
            ));
        }
        let mut op = RawOp::new(cx, text)?;
        op.checkout = true;
        Ok(op)
    }

    /// A move of a stream: no `@0P` after it when it ends with `0` and its
    /// end is exactly known (a trusted estimate: an absolute move from a
    /// known zero, a relative one from a known position). The counters are
    /// the controller's own step counts, so `@0P` would say the target
    /// too; on the wire it costs 23 bytes, time the tool stands in the part
    /// before the next move (`docs/gcode.md`, "Measured").
    pub fn skip_read_back(&mut self) {
        self.read_back = false;
    }

    /// The deadline of the line's answer, once sent.
    pub fn timeout(&self) -> Option<Duration> {
        self.cmd.timeout
    }

    /// Resuming with `@0S` waits as long as the move it resumes may take.
    pub fn set_timeout(&mut self, timeout: Option<Duration>) {
        self.cmd.timeout = timeout;
    }

    /// The line's answer is awaited.
    pub fn waiting(&self) -> bool {
        self.phase == Phase::Waiting
    }

    pub fn moves(&self) -> bool {
        self.cmd.may_move
    }

    pub fn text(&self) -> &str {
        &self.cmd.text
    }

    /// Whether this is a move the operator may stop with a bare 0xFD.
    pub fn is_running_motion(&self) -> bool {
        self.cmd.may_move && self.phase == Phase::Waiting
    }

    /// A raw 0xFD or 0xFF went out while this command runs.
    pub fn control_sent(&mut self, cx: &Context, now: Instant) -> Option<Duration> {
        self.brake(cx, now)
    }

    fn brake(&mut self, cx: &Context, now: Instant) -> Option<Duration> {
        if !self.is_running_motion() || self.stopping {
            return None;
        }
        self.stopping = true;
        self.next_estimate = None;
        let is_program = self.command() == Some(&Command::Start);
        match &mut self.estimate {
            Some(e) => {
                e.brake(now);
                Some(deadline::motion(e.remaining(now)))
            }
            // A stored program may sit in a delay that no stop ends (manual
            // 3.2.6): it keeps having no deadline.
            None if is_program => None,
            // Circles, port moves, reference runs: braking from the fastest
            // speed the controller runs (isel decision 13).
            None => {
                let fastest = f64::from(*crate::proto::isel::SPEED_HZ.end());
                Some(deadline::motion(
                    cx.ramp.ramp(fastest).braking_time(fastest),
                ))
            }
        }
    }

    fn ok_effects(&self, cx: &mut Context, now: Instant) {
        let command = match &self.line {
            Line::Dnc(c) => c,
            Line::Cnc(CncCommand::End) => {
                cx.cnc_store = false;
                cx.state.program = ProgramState::Stored;
                return;
            }
            Line::Cnc(_) => return,
        };
        match command {
            Command::SetAxes(setting) => {
                cx.set_config(AxisConfig::after_setting(cx.config, *setting).ok());
                if cx.profile_ready() {
                    cx.initialised_after_fault();
                }
            }
            Command::Reference(mask) => {
                cx.referenced(*mask);
                cx.zero_reset(*mask);
                cx.three_d = false;
            }
            Command::SimulateReference(mask) => {
                // The counters become 0 where the axes stand (manual 2.2.20).
                cx.referenced(*mask);
                cx.zero_reset(*mask);
                if let Some(p) = cx.position.as_mut() {
                    for axis in mask.iter() {
                        p.set(axis, 0);
                    }
                }
            }
            Command::SetZero(mask) => cx.zero_set(*mask),
            Command::ClearLimitSwitch(axis) => {
                // The controller takes commands again only after a reference
                // run (manual 2.2.9).
                cx.state.referenced = AxisSet::from_mask(
                    cx.state.referenced.mask() & !axis.mask_bit(),
                );
            }
            Command::SetTestMode(on) => cx.state.test_mode = *on,
            Command::SetStartStop(_)
            | Command::SetAcceleration(_)
            | Command::SetReferenceSpeeds(_) => super::readback::ramp_applied(cx, command),
            Command::Set3dInterpolation(on) => cx.three_d = *on,
            Command::StoreProgram => {
                cx.cnc_store = true;
                cx.state.program = ProgramState::Invalid;
                cx.stored = None;
            }
            Command::EraseProgram => {
                cx.state.program = ProgramState::None;
                cx.stored = None;
            }
            Command::WritePort { port, value } => {
                cx.ports.set_output(*port, *value);
                cx.emit_io(now);
            }
            Command::SetDeviceNumber(n) => {
                cx.notice(format!(
                    "the controller is device {n} now; jogterm addresses it so until it disconnects"
                ));
                cx.device = *n;
            }
            Command::Init(InitCommand::RestoreDefaults) => {
                // `@0IX` costs the reference (`docs/decisions.md` isel 4).
                cx.state.referenced = AxisSet::EMPTY;
            }
            Command::Init(InitCommand::Baud9600(on)) => cx.notice(format!(
                "the controller talks at {} baud after the settings are stored (@0IW) and it is reset",
                if *on { 9600 } else { 19200 }
            )),
            _ => {}
        }
    }

    fn error_effects(&self, cx: &mut Context, code: ReplyCode) {
        match &self.line {
            Line::Cnc(_) => {
                // After an error the controller is back in DNC mode and the
                // partial program is invalid (manual 3.1).
                cx.cnc_store = false;
                cx.state.program = ProgramState::Invalid;
            }
            Line::Dnc(Command::StoreProgram) if code == ReplyCode::InvalidDataField => {
                if matches!(cx.state.program, ProgramState::Unknown | ProgramState::None) {
                    cx.state.program = ProgramState::Stored;
                }
            }
            Line::Dnc(_) => {}
        }
    }

    fn command(&self) -> Option<&Command> {
        match &self.line {
            Line::Dnc(c) => Some(c),
            Line::Cnc(_) => None,
        }
    }
}

impl Operation for RawOp {
    fn next(&mut self, cx: &mut Context, _now: Instant) -> Next {
        match self.phase {
            Phase::Send => {
                self.phase = Phase::Waiting;
                if self.command() == Some(&Command::Start) {
                    // A stored program may write any port (CNC `p`, `@0Ia`).
                    cx.ports.forget_outputs();
                }
                Next::Send(self.cmd.clone())
            }
            Phase::Waiting => Next::Wait,
            Phase::Measure => Next::Send(cx.cmd(Command::ReadPosition)),
            Phase::Done => Next::Done,
        }
    }

    fn transmitted(&mut self, cx: &mut Context, now: Instant) {
        if self.phase != Phase::Waiting {
            return;
        }
        if let Some(e) = &mut self.estimate
            && e.started().is_none()
        {
            e.start(now);
            cx.estimated(e.position_at(now), now);
            self.next_estimate = Some(now + cx.settings.timing.estimate_interval);
        }
    }

    fn reply(&mut self, cx: &mut Context, reply: Reply, now: Instant) {
        if self.phase == Phase::Measure {
            cx.position_reply(reply, now);
            self.phase = Phase::Done;
            return;
        }
        self.next_estimate = None;
        let text = self.cmd.text.clone();
        match &reply {
            Reply::Code(ReplyCode::Ok) if self.checkout => self.ok_effects(cx, now),
            Reply::Code(ReplyCode::UserStop) if self.checkout => {}
            Reply::Byte(v) if self.checkout => {
                if let Some(Command::ReadPort(port)) = self.command() {
                    cx.port_read(*port, *v, now);
                    cx.emit_io(now);
                }
            }
            Reply::Code(ReplyCode::Ok) => {
                self.ok_effects(cx, now);
                let mut shown = code_text(ReplyCode::Ok);
                if !self.syncs.is_empty() {
                    shown.push_str(&format!(" (sync characters: {})", self.syncs));
                }
                cx.emit(Event::Reply {
                    kind: ReplyKind::Answer,
                    command: text,
                    text: shown,
                });
            }
            Reply::Code(ReplyCode::UserStop) if self.broken_off => cx.emit(Event::Reply {
                kind: ReplyKind::Answer,
                command: text,
                text: format!(
                    "{}: stopped, the rest was discarded",
                    code_text(ReplyCode::UserStop)
                ),
            }),
            Reply::Code(code) => {
                if let Some(e) = &mut self.estimate
                    && *code != ReplyCode::UserStop
                {
                    e.halt(now);
                }
                self.error_effects(cx, *code);
                cx.controller_error(&text, *code);
            }
            Reply::Positions(p) => {
                cx.measured(p, now);
                cx.emit(Event::Reply {
                    kind: ReplyKind::Answer,
                    command: text,
                    text: reply_text(self.command(), &reply, &cx.settings.wiring),
                });
            }
            Reply::Byte(v) => {
                if let Some(Command::ReadPort(port)) = self.command() {
                    cx.port_read(*port, *v, now);
                    cx.emit_io(now);
                }
                cx.emit(Event::Reply {
                    kind: ReplyKind::Answer,
                    command: text,
                    text: reply_text(self.command(), &reply, &cx.settings.wiring),
                });
            }
            Reply::Text { .. } => cx.emit(Event::Reply {
                kind: ReplyKind::Answer,
                command: text,
                text: reply_text(self.command(), &reply, &cx.settings.wiring),
            }),
        }
        if self.stopping {
            cx.quiet_request = Some(cx.settings.timing.resync_gap);
        }
        // After a move, and after `@0n`: whether `@0P` changed with the
        // zero is read at once (`Context::zero_set`).
        let zero_set = matches!(self.command(), Some(Command::SetZero(_)))
            && reply == Reply::Code(ReplyCode::Ok);
        let known_end = self
            .estimate
            .as_ref()
            .filter(|_| !self.read_back && reply == Reply::Code(ReplyCode::Ok))
            .map(MoveEstimate::end);
        if let Some(end) = known_end {
            cx.position = Some(end);
            cx.estimated(end, now);
            self.phase = Phase::Done;
            return;
        }
        self.phase = if (self.cmd.may_move || zero_set) && !cx.cnc_store {
            Phase::Measure
        } else {
            Phase::Done
        };
    }

    fn sync(&mut self, _cx: &mut Context, sync: SyncChar, _now: Instant) {
        self.syncs.push(char::from(sync.byte()));
    }

    fn lost_reply(&mut self, cx: &mut Context, _now: Instant) {
        cx.link_suspect(&self.cmd.text, "garbled reply");
        if matches!(self.line, Line::Cnc(_)) || self.command() == Some(&Command::StoreProgram) {
            // Whether the controller is storing is unknown: the read-back
            // finds out (`@0P` answers `8` while storing).
            cx.cnc_store = false;
            cx.state.program = ProgramState::Invalid;
        }
        if self.cmd.may_move || matches!(self.line, Line::Cnc(_)) {
            cx.readback_wanted = true;
        }
        self.phase = Phase::Done;
    }

    fn stop(&mut self, cx: &mut Context, now: Instant) -> Option<Duration> {
        if self.is_running_motion() {
            self.broken_off = true;
        }
        self.brake(cx, now)
    }

    fn timer(&self) -> Option<Instant> {
        self.next_estimate.filter(|_| self.phase == Phase::Waiting)
    }

    fn on_timer(&mut self, cx: &mut Context, now: Instant) -> bool {
        if let (Some(at), Some(e)) = (self.next_estimate, &self.estimate)
            && at <= now
        {
            cx.estimated(e.position_at(now), now);
            let interval = cx.settings.timing.estimate_interval;
            self.next_estimate = Some((at + interval).max(now + interval / 2));
        }
        false
    }

    fn abandon(&mut self, _cx: &mut Context, _cause: &Abandon) {
        self.phase = Phase::Done;
    }

    fn activity(&self) -> Activity {
        match (self.phase, &self.line) {
            (Phase::Send | Phase::Waiting, Line::Cnc(_)) => Activity::Uploading,
            (Phase::Send | Phase::Waiting, Line::Dnc(Command::Start)) => {
                if self.stopping {
                    Activity::Stopping
                } else {
                    Activity::RunningProgram
                }
            }
            (Phase::Send | Phase::Waiting, Line::Dnc(Command::Reference(_))) if !self.stopping => {
                Activity::Homing
            }
            (Phase::Send | Phase::Waiting, Line::Dnc(c)) if c.may_move() => {
                if self.stopping {
                    Activity::Stopping
                } else {
                    Activity::Moving
                }
            }
            _ => Activity::Idle,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_control_characters_are_control_bytes() {
        assert_eq!(control_of("\u{fd}"), Some(ControlByte::SoftStop));
        assert_eq!(control_of("\u{fe}"), Some(ControlByte::Reset));
        assert_eq!(control_of("\u{ff}"), Some(ControlByte::Break));
        assert_eq!(control_of("\u{fd}\u{fd}"), None);
        assert_eq!(control_of("@0P"), None);
        assert_eq!(control_of(""), None);
        assert_eq!(control_of("\u{1fd}"), None);
    }
}
