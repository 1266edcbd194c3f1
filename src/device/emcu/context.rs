//! The EMCU driver's knowledge of the interface and the machine, shared by
//! all operations: what jogterm set (ramp, slot speed, outputs, E1 link),
//! what the interface reported (`@X` flags, positions), what waits in its
//! data memory, and the events for the clients.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::axis::{Axis, AxisSet};
use crate::device::api::{
    ControllerFault, Event, IoSnapshot, MachineState, PerAxis, PositionSample, PositionSource,
    ProgramState, Recovery, Refusal,
};
use crate::device::common::{Sink, gate};
use crate::device::driver::Outgoing;
use crate::proto::emcu::{Command, EmcuAxis, Expect, Status, StatusFlag, Terminator};

use super::io;
use super::settings::EmcuSettings;

/// The code of the fault the `@X` error flag raises.
pub const ERROR_FLAG: &str = "error flag";
/// The code of the fault a lost position raises.
pub const POSITION_LOST: &str = "position unknown";

/// A command line ready for the wire, with its answer and how long it may
/// take to come.
#[derive(Debug, Clone, PartialEq)]
pub struct Cmd {
    pub bytes: Vec<u8>,
    /// The line as it goes out, in `traffic::readable` form without the CR
    /// (`@LX`, `L9,x100<01>`), for events and logs.
    pub text: String,
    pub expect: Expect,
    pub timeout: Duration,
    /// Whether the interface may move while it is outstanding or after it
    /// (a line that starts a run).
    pub may_move: bool,
}

/// `@B` CR: halt every axis with its ramp; the job ends, positions are
/// kept (manual 1.5.11). jogterm's stop, on every path.
pub const HALT: &[u8] = b"@B\r";

/// What opens every connection: a CR, then `@B`. The interface may hold
/// the start of a line that was cut when the link broke (`@X` without its
/// CR); the CR ends it (an empty line is no command, `docs/protocols.md`,
/// EMCU), so that `@B` is read as a line of its own and not as the tail of
/// a malformed one, which would leave the axes running.
pub const CONNECT_HALT: &[u8] = b"\r@B\r";

/// How the driver names a line in its events: the command, and `<01>` for
/// a 0x01 at its end (`@LX`, `L1,x500<01>`).
pub fn line_text(command: &Command, end: Terminator) -> String {
    let mut bytes = command.to_string().into_bytes();
    if end != Terminator::Cr {
        bytes.push(end.byte());
    }
    crate::traffic::readable(&bytes)
}

/// Lines in a message, each of which is answered: one per terminator.
pub fn lines_in(bytes: &[u8]) -> u32 {
    let n = bytes.iter().filter(|b| matches!(**b, b'\r' | 0x01)).count();
    u32::try_from(n).unwrap_or(u32::MAX)
}

pub fn halt_outgoing() -> Outgoing {
    Outgoing::message(HALT.to_vec(), false, crate::traffic::Owner::Stop)
}

#[derive(Debug)]
pub struct Context {
    pub settings: EmcuSettings,
    pub state: MachineState,
    pub events: VecDeque<Event>,
    /// Lines to write at once, even while an answer is outstanding: the
    /// halts jogterm decides on (dead-man, release) and `@R`. Each is
    /// answered by a CR that nobody else waits for.
    pub control: VecDeque<Outgoing>,
    /// The last complete position read, machine steps.
    pub position: Option<PerAxis<i64>>,
    /// Positions of the cycle being read.
    reading: PerAxis<i64>,
    /// The last `@X`.
    pub status: Option<Status>,
    /// When it arrived, for the input recorder.
    pub status_read: Option<Instant>,
    /// What jogterm last set the move slot's end speed to (`#E`), Hz.
    pub slot_hz: Option<u16>,
    /// jogterm has set `#S` and `#R` from the profile since it connected.
    pub ramp_set: bool,
    /// A1 and A2 as jogterm last switched them (they cannot be read back).
    pub outputs: [Option<bool>; 2],
    /// The E1 link (`&V`) as jogterm last set it.
    pub e1_link: Option<bool>,
    /// Commands jogterm stored in the data memory and did not run yet.
    pub stored: Vec<Command>,
    /// A ROM transfer (raw `@F`) is open: buffered lines go into the job.
    pub transfer: bool,
    /// The lines of the job in ROM, when jogterm stored it.
    pub job: Option<Vec<Command>>,
    /// Read `@X` at the next chance (a 0x02 CR came that no run waited for).
    pub status_wanted: bool,
    /// The state is in doubt: read it back before anything else.
    pub readback_wanted: bool,
    /// An operation wants `@B` sent (its run is overdue or in doubt).
    pub halt_wanted: bool,
    /// A ROM transfer was open when the link was lost: end it on the next
    /// connection, or the next buffered command would go into the job.
    pub transfer_left_open: bool,
}

crate::device::common::core::family_context!(Context);

impl Context {
    pub fn new(settings: EmcuSettings) -> Context {
        Context {
            settings,
            state: MachineState::default(),
            events: VecDeque::new(),
            control: VecDeque::new(),
            position: None,
            reading: PerAxis::new(),
            status: None,
            status_read: None,
            slot_hz: None,
            ramp_set: false,
            outputs: [None; 2],
            e1_link: None,
            stored: Vec::new(),
            transfer: false,
            job: None,
            status_wanted: false,
            readback_wanted: false,
            halt_wanted: false,
            transfer_left_open: false,
        }
    }

    /// The machine's axes in X, Y, Z order.
    pub fn axes(&self) -> Vec<EmcuAxis> {
        EmcuAxis::ALL
            .into_iter()
            .filter(|a| self.settings.axes.contains(a.axis()))
            .collect()
    }

    /// `command` ended by `end`, with the answer it expects.
    pub fn cmd(&self, command: &Command, end: Terminator) -> Cmd {
        let mut bytes = command.to_string().into_bytes();
        bytes.push(end.byte());
        let expect = command.expect();
        Cmd {
            text: line_text(command, end),
            timeout: self.ack_timeout(bytes.len(), expect),
            may_move: command.may_move() && (end == Terminator::RunBuffer || command.is_master()),
            bytes,
            expect,
        }
    }

    /// The longest an answer may take: the bytes both ways, the interface's
    /// 500 ms (manual 1.4.2) and the host's margin.
    pub fn ack_timeout(&self, sent: usize, expect: Expect) -> Duration {
        let t = &self.settings.timing;
        self.settings.line.transfer_time(sent + reply_len(expect)) + t.ack + t.reply_margin
    }

    /// Whether jogterm's own moves may start: `#S`/`#R` set as the profile says.
    pub fn ready(&self) -> bool {
        self.ramp_set
    }

    /// `ramp_set` and what it means for `MachineState::initialised`.
    pub fn set_ramp(&mut self, set: bool) {
        self.ramp_set = set;
        self.state.initialised = if set {
            self.settings.axes
        } else {
            AxisSet::EMPTY
        };
    }

    pub fn motion_allowed(&self, unreferenced_ok: bool) -> Result<(), Refusal> {
        gate::motion_allowed(
            &self.state,
            self.ready(),
            self.settings.axes,
            unreferenced_ok,
            |_| false,
        )
    }

    /// The data memory must be empty before jogterm runs a batch of its
    /// own, or the operator's stored commands would run with it.
    pub fn memory_free(&self) -> Result<(), Refusal> {
        if self.stored.is_empty() {
            return Ok(());
        }
        Err(Refusal::Invalid {
            reason: format!(
                "{} command(s) wait in the data memory: run them (a line ended by \\x01) or stop (@B drops them)",
                self.stored.len()
            ),
        })
    }

    // ----- what the interface reports -----------------------------------

    /// One axis of a position cycle was read.
    pub fn position_part(&mut self, axis: EmcuAxis, steps: i32) {
        self.reading.set(axis.axis(), i64::from(steps));
    }

    /// One axis read on its own (a raw `@LX`): what jogterm knows of the
    /// position follows.
    pub fn position_of(&mut self, axis: EmcuAxis, steps: i32) {
        if let Some(p) = self.position.as_mut() {
            p.set(axis.axis(), i64::from(steps));
        }
    }

    /// Every axis of the cycle was read: one measured sample.
    pub fn position_complete(&mut self, now: Instant) {
        let steps = self.reading;
        self.position = Some(steps);
        self.emit(Event::Position(PositionSample {
            at: now,
            steps,
            source: PositionSource::Measured,
        }));
    }

    /// An `@X` answer: the flags become machine state (manual 1.5.3), and
    /// the clients get the flags as an `IoSnapshot`.
    pub fn status_read(&mut self, status: Status, now: Instant) {
        self.status = Some(status);
        self.status_read = Some(now);
        self.error_flag(status.error, status.position_unknown);
        if status.position_unknown && !self.state.referenced.is_empty() {
            // The interface lost the positions (`@S`, `@R`, a reference run
            // broken off, decision 5): no defined move until `$H`.
            self.state.referenced = AxisSet::EMPTY;
            if self.state.fault.is_none() {
                let fault = ControllerFault {
                    command: "@X".into(),
                    code: POSITION_LOST.into(),
                    meaning: StatusFlag::PositionUnknown.meaning().to_owned(),
                    recovery: Recovery::Reference,
                };
                self.state.fault = Some(fault.clone());
                self.emit(Event::Fault(fault));
            }
        }
        self.emit_io(now);
    }

    /// The error flag: set, it blocks motion until `@R` and `$H` (manual
    /// 1.5.3: "im Fehlerfall sollte immer ein Reset und eine Referenzfahrt
    /// ausgeführt werden"); cleared (only `@R` does), a reference run is
    /// still needed while the position is unknown.
    fn error_flag(&mut self, set: bool, position_unknown: bool) {
        let ours = self
            .state
            .fault
            .as_ref()
            .is_some_and(|f| f.code == ERROR_FLAG);
        if set {
            if ours {
                return;
            }
            let fault = ControllerFault {
                command: "@X".into(),
                code: ERROR_FLAG.into(),
                meaning: format!(
                    "{}: {}",
                    StatusFlag::Error.meaning(),
                    StatusFlag::Error.remedy()
                ),
                recovery: Recovery::ReinitialiseAndReference,
            };
            self.state.fault = Some(fault.clone());
            self.emit(Event::Fault(fault));
        } else if ours {
            match self.state.fault.as_mut() {
                Some(f) if position_unknown => f.recovery = Recovery::Reference,
                _ => self.state.fault = None,
            }
        }
    }

    /// Axes were referenced (a `$H` completed and `@X` reads the position
    /// as known): a fault that only asked for that is over.
    pub fn referenced(&mut self, axes: AxisSet) {
        self.state.referenced = AxisSet::from_mask(
            (self.state.referenced.mask() | axes.mask()) & self.settings.axes.mask(),
        );
        if gate::reference_fault_cleared(&self.state, self.settings.axes) {
            self.state.fault = None;
        }
    }

    pub fn io_snapshot(&self, at: Instant) -> IoSnapshot {
        let known = io::Known {
            status: self.status.as_ref(),
            status_read: self.status_read,
            outputs: self.outputs,
            e1_link: self.e1_link,
            wiring: &self.settings.wiring,
        };
        io::snapshot(known, at)
    }

    pub fn emit_io(&mut self, now: Instant) {
        let snapshot = self.io_snapshot(now);
        self.emit(Event::Io(snapshot));
    }

    /// What `@R` leaves (manual 1.5.1): counters 0 and the position lost,
    /// the data memory and an open transfer cleared, the error flag off; the
    /// configuration (`#S`, `#E`, `#R`, `&V`) and a stored job stay.
    pub fn apply_reset(&mut self) {
        self.after_abort();
        self.position = Some(self.settings.axes.iter().map(|a| (a, 0)).collect());
        // The flag is off; the reference run it asked for is still due.
        if let Some(f) = self.state.fault.as_mut()
            && f.code == ERROR_FLAG
        {
            f.recovery = Recovery::Reference;
        }
    }

    /// What `@S` and `@R` share (manual 1.5.12, decision 5): the axes stop
    /// without a ramp, positions are lost, the data memory is cleared.
    pub fn after_abort(&mut self) {
        self.state.referenced = AxisSet::EMPTY;
        self.stored.clear();
        if self.transfer {
            self.transfer = false;
            self.state.program = ProgramState::Invalid;
        }
        // The manual does not say what happens to the outputs.
        self.outputs = [None; 2];
        self.status_wanted = true;
    }

    /// `@B` went out: the data memory is dropped with the job (manual
    /// 1.5.11 ends the job; `docs/protocols.md`, EMCU).
    pub fn after_halt(&mut self) {
        self.stored.clear();
    }

    /// The raw bytes of lines nobody asked for, for a notice.
    pub fn stray(&mut self, what: &str) {
        self.notice(format!("unexpected from the interface: {what}"));
    }

    pub fn axis_of(axis: Axis) -> Option<EmcuAxis> {
        EmcuAxis::new(axis).ok()
    }
}

/// The longest answer to a command expecting `expect`, CR included.
pub fn reply_len(expect: Expect) -> usize {
    match expect {
        Expect::Ack => 1,
        Expect::AckOrMemoryFull => 2,
        Expect::Status => 9,
        // `@LX-2147483648` CR.
        Expect::Position(_) => 15,
        Expect::Version => crate::proto::emcu::reply::MAX_REPLY_LINE + 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{ConfigDirs, load_profile};

    fn cx() -> Context {
        let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("profile");
        Context::new(EmcuSettings::from_profile(&profile).expect("settings"))
    }

    #[test]
    fn lines_carry_their_terminator_answer_and_deadline() {
        let cx = cx();
        let mv: Command = "L9,x100".parse().expect("command");
        let run = cx.cmd(&mv, Terminator::RunBuffer);
        assert_eq!(run.bytes, b"L9,x100\x01");
        assert_eq!(run.text, "L9,x100<01>");
        assert!(run.may_move);
        let stored = cx.cmd(&mv, Terminator::Cr);
        assert_eq!(stored.text, "L9,x100");
        assert!(!stored.may_move);
        let q = cx.cmd(&Command::Status, Terminator::Cr);
        assert_eq!(q.expect, Expect::Status);
        // 3 + 9 bytes at 19200 baud, 500 ms, 100 ms.
        assert_eq!(q.timeout.as_millis(), 606);
    }

    #[test]
    fn the_error_flag_needs_a_reset_then_a_reference() {
        let mut cx = cx();
        cx.state.referenced = AxisSet::XYZ;
        let now = Instant::now();
        let flagged = Status {
            error: true,
            ..Status::default()
        };
        cx.status_read(flagged, now);
        let f = cx.state.fault.clone().expect("fault");
        assert_eq!(f.recovery, Recovery::ReinitialiseAndReference);
        cx.status_read(flagged, now);
        let faults = cx
            .events
            .iter()
            .filter(|e| matches!(e, Event::Fault(_)))
            .count();
        assert_eq!(faults, 1, "reported once");
        // `@R`: the flag is off, the position unknown.
        cx.status_read(
            Status {
                position_unknown: true,
                ..Status::default()
            },
            now,
        );
        assert_eq!(
            cx.state.fault.as_ref().map(|f| f.recovery),
            Some(Recovery::Reference)
        );
        assert_eq!(cx.state.referenced, AxisSet::EMPTY);
        cx.referenced(AxisSet::XYZ);
        assert_eq!(cx.state.fault, None);
    }

    #[test]
    fn a_lost_position_is_a_fault_that_asks_for_a_reference() {
        let mut cx = cx();
        cx.state.referenced = AxisSet::XYZ;
        cx.status_read(
            Status {
                position_unknown: true,
                ..Status::default()
            },
            Instant::now(),
        );
        assert_eq!(
            cx.state
                .fault
                .as_ref()
                .map(|f| (f.code.as_str(), f.recovery)),
            Some((POSITION_LOST, Recovery::Reference))
        );
    }
}
