//! The isel @-format driver: a sans-IO [`Driver`] for iMC-M, iMC-MP and
//! iMC-S8 controllers.
//!
//! The line discipline is the controller's: strictly one command at a time,
//! answered only when it is done (manual 2.1; a move answers when the move
//! is complete, manual 2.2.2). Only the control bytes 0xFD, 0xFE and 0xFF act
//! at once, even between the bytes of a command (manual 2.2.31); the driver
//! hands them out whenever they are due.
//!
//! What runs, in order of priority:
//! 1. control bytes (stop sequence, reset);
//! 2. the current operation ([`op`]): state read-back on connect
//!    ([`readback`]), initialise ([`init`]), home ([`home`]), set zero
//!    ([`zero`]), outputs ([`output`]), moves and jogs ([`motion_op`]), raw
//!    lines ([`raw`]), uploads ([`upload`]) and program runs ([`program`]);
//! 3. the next queued request, checked when it is its turn;
//! 4. polling ([`poll`]): position and ports, between requests.
//!
//! Reply deadlines come from physics ([`deadline`]); a reply that does not
//! come means the link is dead: the driver reports a fault and
//! `Event::Link(LinkState::Lost)`, which the device task treats like a
//! vanished port. Garbled replies are dropped and the line must be quiet for
//! a moment before the next command, so stray bytes are never taken for an
//! answer. See `docs/device.md` for the behaviour as a whole.

mod checkout_op;
mod context;
mod deadline;
mod home;
mod init;
mod io;
mod limit_op;
mod motion_op;
mod op;
mod output;
mod plan;
mod poll;
mod probe_op;
mod program;
mod raw;
mod readback;
mod reply_text;
mod settings;
mod upload;
mod zero;

#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::time::{Duration, Instant};

pub use crate::proto::isel::estimate::{MoveEstimate, RampParams};
pub use context::STOP_BYTES;
pub use io::{PortImage, describe_input, input_group, output_group};
pub use plan::overrun_cap;
pub use poll::{PollItem, wire_limit_hz};
pub use reply_text::{code_text, reply_text};
pub use settings::{
    AxisLimits, IselSettings, JogSettings, PollPlan, PollRate, SettingsError, Timing,
};
pub use upload::abort_line;

use crate::config::Profile;
use crate::device::api::{
    ANSWERS_AGAIN_NOTICE, BUSY_NOTICE, Event, JogEnd, JogId, Refusal, ReplyKind, Request,
};
use crate::device::common::core::{Core, Family};
use crate::device::common::limits::named_axes;
use crate::device::common::op::operations;
use crate::device::common::sink::refuse;
use crate::device::common::{Queued, link};
use crate::device::driver::Outgoing;
use crate::proto::isel::{
    Command, ControlByte, Event as Decoded, Expect, Reply, ReplyDecoder, TEXT_SILENCE,
};
use crate::traffic::{self, MessageEnd, readable};

use checkout_op::CheckoutOp;
use context::{Cmd, Context, PositionRead, control_outgoing, stop_outgoing};
use home::HomeOp;
use init::InitOp;
use limit_op::LimitJogOp;
use motion_op::MotionOp;
use op::{Abandon, Next, Operation};
use output::OutputOp;
use probe_op::ProbeOp;
use program::ProgramOp;
use raw::{RawOp, control_of};
use readback::Readback;
use upload::UploadOp;
use zero::ZeroOp;

operations! {
    #[derive(Debug)]
    pub enum Op: Operation {
        Readback(Readback) => Setup,
        Init(InitOp) => Setup,
        Home(HomeOp) => Setup,
        Zero(ZeroOp) => Setup,
        Output(OutputOp) => Setup,
        Motion(MotionOp) => Motion,
        Limit(LimitJogOp) => Motion,
        Probe(Box<ProbeOp> as ProbeOp) => Motion,
        Raw(RawOp) => User,
        Checkout(CheckoutOp) => Motion,
        Upload(UploadOp) => Upload,
        Program(ProgramOp) => Program,
    }
}

/// Who waits for the outstanding reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Owner {
    Poll(PollItem),
    Op,
}

/// The command on the wire and its reply.
#[derive(Debug)]
struct Exchange {
    seq: u64,
    /// The command's bytes, for a repeat while the controller is busy.
    bytes: Vec<u8>,
    repeatable: bool,
    text: String,
    expect: Expect,
    owner: Owner,
    /// Whose the command and its reply are, for the traffic records.
    shown_as: traffic::Owner,
    may_move: bool,
    timeout: Option<Duration>,
    /// Set once the last byte has gone out.
    deadline: Option<Instant>,
    transmitted: bool,
    transmitted_at: Option<Instant>,
    last_byte: Option<Instant>,
    /// A stop went out before this (moving) command was complete on the
    /// wire: the controller reads the control bytes at once but still
    /// executes the command after them, so the stop is sent again.
    restop: bool,
}

/// The isel driver: the driver core with the isel line discipline. Build
/// it from a profile, hand it to the device task (or drive it by hand in
/// tests: every method takes the time).
pub type IselDriver = Core<IselLine>;

/// The isel line: strictly one command at a time, answered when done.
#[derive(Debug)]
pub struct IselLine {
    exchange: Option<Exchange>,
    seq: u64,
    decoder: ReplyDecoder,
    /// Messages handed out and not yet reported written: the sequence number
    /// of a command, `None` for a control byte.
    unsent: VecDeque<Option<u64>>,
    stray: Vec<u8>,
    /// The quiet after the connect's stop sequence is on: an `F` in it is
    /// that stop's answer, not noise.
    settling_after_connect: bool,
    poll_error: Option<String>,
    /// Since when the controller has not answered a session that has not
    /// moved (a stored program or a move runs): it waits, and repeats its
    /// read at `resend_at`, instead of calling the link dead.
    busy_since: Option<Instant>,
    resend_at: Option<Instant>,
    /// How long of the wait has been said so far (`busy_tell`).
    busy_told: Duration,
}

/// How often a session that has not moved repeats its read while the
/// controller does not answer: the controller drops what it reads while a
/// command or program runs (`docs/protocols.md`, isel), so one of them is
/// answered once it is done.
const BUSY_REPEAT: Duration = Duration::from_millis(500);

/// How often the wait for a busy controller is said: every 10 s, at least
/// four times within a shorter `isel.busy_wait_s`, never more than once a
/// second.
fn busy_tell_every(limit: Duration) -> Duration {
    (limit / 4).clamp(Duration::from_secs(1), Duration::from_secs(10))
}

impl Core<IselLine> {
    pub fn new(settings: IselSettings) -> IselDriver {
        let step_queue = settings.jog.step_queue;
        let line = IselLine {
            exchange: None,
            seq: 0,
            decoder: ReplyDecoder::new(),
            unsent: VecDeque::new(),
            stray: Vec::new(),
            settling_after_connect: false,
            poll_error: None,
            busy_since: None,
            resend_at: None,
            busy_told: Duration::ZERO,
        };
        let poller = poll::poller(&settings.poll);
        Core::with(Context::new(settings), line, poller, step_queue)
    }

    pub fn from_profile(profile: &Profile) -> Result<IselDriver, SettingsError> {
        IselSettings::from_profile(profile).map(IselDriver::new)
    }

    pub fn settings(&self) -> &IselSettings {
        &self.cx.settings
    }

    // ----- line discipline ---------------------------------------------

    fn start(&mut self, cmd: Cmd, owner: Owner) -> Outgoing {
        if self.line.decoder.expect(cmd.expect).is_err() {
            // Cannot happen (one command at a time), but never wedge on it.
            self.line.decoder.abandon();
            let _ = self.line.decoder.expect(cmd.expect);
        }
        self.line.seq += 1;
        self.line.unsent.push_back(Some(self.line.seq));
        let shown_as = match owner {
            Owner::Poll(_) => traffic::Owner::Poll,
            Owner::Op => self.op.as_ref().map_or(traffic::Owner::Setup, Op::owner),
        };
        self.line.exchange = Some(Exchange {
            seq: self.line.seq,
            bytes: cmd.bytes.clone(),
            repeatable: cmd.repeatable,
            text: cmd.text,
            expect: cmd.expect,
            owner,
            shown_as,
            may_move: cmd.may_move,
            timeout: cmd.timeout,
            deadline: None,
            transmitted: false,
            transmitted_at: None,
            last_byte: None,
            restop: false,
        });
        Outgoing::message(cmd.bytes, true, shown_as)
    }

    /// The read the busy controller did not answer, again (`reply_timeout`).
    fn repeat_when_busy(&mut self, now: Instant) -> Option<Outgoing> {
        if !self.link_up || self.line.resend_at.is_none_or(|t| now < t) {
            return None;
        }
        if !self.line.decoder.pending().is_empty() {
            // A late reply is arriving: let it end (or fall silent) first.
            self.line.resend_at = Some(now + self.cx.settings.timing.resync_gap);
            return None;
        }
        self.line.resend_at = None;
        let ex = self.line.exchange.as_mut()?;
        if self.line.decoder.expect(ex.expect).is_err() {
            self.line.decoder.abandon();
            let _ = self.line.decoder.expect(ex.expect);
        }
        self.line.seq += 1;
        ex.seq = self.line.seq;
        self.line.unsent.push_back(Some(ex.seq));
        Some(Outgoing::message(ex.bytes.clone(), true, ex.shown_as))
    }

    /// Reports the bytes that arrived while the line was quiet. After a
    /// connect, 0xFD answers `F` only if a move was still running
    /// (`docs/decisions.md` isel 6): the operator must hear that the
    /// machine was moving, not read it as noise.
    fn report_stray(&mut self) {
        let bytes = std::mem::take(&mut self.line.stray);
        let rest = match bytes.split_first() {
            Some((b'F', rest)) if std::mem::take(&mut self.line.settling_after_connect) => {
                self.cx.notice(
                    "the controller was still moving when the link came up: jogterm stopped it \
                     (it answered F); check the position before the next move",
                );
                rest
            }
            _ => &bytes[..],
        };
        self.line.settling_after_connect = false;
        self.cx.stray_bytes(rest);
    }

    fn take_quiet_request(&mut self, now: Instant) {
        if let Some(d) = self.cx.quiet_request.take() {
            let until = now + d;
            self.quiet_until = Some(self.quiet_until.map_or(until, |q| q.max(until)));
        }
    }

    fn transmit(&mut self, now: Instant) -> Option<Outgoing> {
        if let Some(out) = self.cx.control.pop_front() {
            self.line.unsent.push_back(None);
            return Some(out);
        }
        if let Some(out) = self.repeat_when_busy(now) {
            return Some(out);
        }
        if !self.link_up || self.line.exchange.is_some() || self.quiet(now) {
            return None;
        }
        loop {
            if let Some(op) = self.op.as_mut() {
                match op.get().next(&mut self.cx, now) {
                    Next::Send(cmd) => return Some(self.start(cmd, Owner::Op)),
                    Next::Wait => return None,
                    Next::Done => {
                        self.op = None;
                        self.take_quiet_request(now);
                        if let Some(out) = self.cx.control.pop_front() {
                            self.line.unsent.push_back(None);
                            return Some(out);
                        }
                        if self.quiet(now) {
                            return None;
                        }
                        continue;
                    }
                }
            }
            if self.cx.readback_wanted {
                self.cx.readback_wanted = false;
                self.op = Some(Op::Readback(Readback::new()));
                continue;
            }
            if let Some(q) = self.queue.pop(now, &mut self.cx.events) {
                self.begin(q, now);
                continue;
            }
            if self.cx.cnc_store {
                // Storing a program: a poll would be stored or refused.
                return None;
            }
            // `@0P` even without axes: some controllers report positions
            // then, others answer `4`, which only updates the state.
            self.drop_absent_ports();
            let item = self.poller.next(now)?;
            let cmd = match item {
                PollItem::Position => self.cx.cmd(Command::ReadPosition),
                PollItem::Port(p) => self.cx.cmd(Command::ReadPort(p)),
            };
            return Some(self.start(cmd, Owner::Poll(item)));
        }
    }

    /// `bytes` through the decoder, and where messages ended in them: where
    /// a reply was complete, and after each line of a text reply (CR LF,
    /// protocols.md isel 8), owned by the command on the wire; a reply found
    /// garbled, and whatever follows a reply, is the controller's own. Fed
    /// a byte at a time, which gives the events a whole feed gives (the
    /// decoder's split property, `fuzz_isel`).
    fn decode(&mut self, bytes: &[u8]) -> (Vec<Decoded>, Vec<MessageEnd>) {
        let mut owner = self
            .line
            .exchange
            .as_ref()
            .map_or(traffic::Owner::Controller, |ex| ex.shown_as);
        let mut events = Vec::new();
        let mut ends = Vec::new();
        for (i, byte) in bytes.iter().enumerate() {
            let fed = self.line.decoder.feed(std::slice::from_ref(byte));
            let replied = fed.iter().any(|e| matches!(e, Decoded::Reply(_)));
            let garbled = fed.iter().any(|e| matches!(e, Decoded::Error(_)));
            if replied || garbled || *byte == b'\n' {
                let whose = if garbled && !replied {
                    traffic::Owner::Controller
                } else {
                    owner
                };
                ends.push(MessageEnd::new(i + 1, whose));
            }
            if replied || garbled {
                owner = traffic::Owner::Controller;
            }
            events.extend(fed);
        }
        (events, ends)
    }

    fn decoded(&mut self, events: Vec<Decoded>, now: Instant) {
        for event in events {
            match event {
                Decoded::Reply(reply) => {
                    if let Some(ex) = self.line.exchange.take() {
                        if let Some(since) = self.line.busy_since.take() {
                            self.line.resend_at = None;
                            self.cx.notice(format!(
                                "{ANSWERS_AGAIN_NOTICE} (busy for {:.1} s)",
                                now.saturating_duration_since(since).as_secs_f64()
                            ));
                        }
                        self.answered(ex, reply, now);
                    }
                }
                Decoded::Sync(sync) => {
                    if let Some(op) = self.op.as_mut() {
                        op.get().sync(&mut self.cx, sync, now);
                    }
                }
                Decoded::Unsolicited(b) => self.line.stray.push(b),
                Decoded::Error(e) => {
                    let Some(ex) = self.line.exchange.take() else {
                        continue;
                    };
                    self.quiet_until = Some(now + self.cx.settings.timing.resync_gap);
                    match ex.owner {
                        Owner::Poll(_) => self
                            .cx
                            .notice(format!("the reply to {} was garbled: {e}", ex.text)),
                        Owner::Op => {
                            self.cx
                                .notice(format!("the reply to {} was garbled: {e}", ex.text));
                            if let Some(op) = self.op.as_mut() {
                                op.get().lost_reply(&mut self.cx, now);
                            }
                        }
                    }
                }
            }
        }
        if !self.line.stray.is_empty() && !self.quiet(now) {
            self.report_stray();
        }
    }

    fn answered(&mut self, ex: Exchange, reply: Reply, now: Instant) {
        match ex.owner {
            Owner::Op => {
                if let Some(op) = self.op.as_mut() {
                    op.get().reply(&mut self.cx, reply, now);
                }
            }
            Owner::Poll(item) => self.poll_reply(item, &ex.text, reply, now),
        }
    }

    fn poll_reply(&mut self, item: PollItem, text: &str, reply: Reply, now: Instant) {
        let trouble = match (item, reply) {
            // What a `@0P` says is read as for every operation that reads
            // the position (`Context::read_position`); only the reporting
            // of trouble is the poller's own.
            (PollItem::Position, reply) => match self.cx.read_position(reply, now) {
                PositionRead::Measured => {
                    self.poller.position_read(now);
                    self.line.poll_error = None;
                    None
                }
                PositionRead::NoAxes => None,
                PositionRead::Refused(code) => Some(Reply::Code(code)),
                PositionRead::Unexpected(other) => Some(other),
            },
            (PollItem::Port(port), Reply::Byte(v)) => {
                self.cx.port_read(port, v, now);
                if self.poller.cycle_done() {
                    self.cx.emit_io(now);
                }
                None
            }
            (PollItem::Port(port), Reply::Code(crate::proto::isel::ReplyCode::BadNumber)) => {
                self.cx.port_absent(port);
                self.drop_absent_ports();
                if self.poller.cycle_done() {
                    self.cx.emit_io(now);
                }
                None
            }
            (PollItem::Port(_), other) => Some(other),
        };
        match trouble {
            Some(Reply::Code(code)) => {
                // Once per kind of trouble, not on every poll.
                let key = format!("{text}{}", code.char());
                if self.line.poll_error.as_deref() != Some(&key) {
                    self.line.poll_error = Some(key);
                    self.cx.controller_error(text, code);
                }
            }
            Some(other) => self
                .cx
                .notice(format!("unexpected reply to {text}: {other:?}")),
            None => {}
        }
    }

    /// Poll only the ports of the plan the controller has
    /// (`Context::absent_ports`).
    fn drop_absent_ports(&mut self) {
        let absent = &self.cx.absent_ports;
        if self
            .poller
            .ports()
            .iter()
            .any(|i| matches!(i, PollItem::Port(p) if absent.contains(p)))
        {
            self.poll_plan_ports();
        }
    }

    fn poll_plan_ports(&mut self) {
        let absent = &self.cx.absent_ports;
        let ports = self
            .cx
            .settings
            .poll
            .ports
            .iter()
            .filter(|p| !absent.contains(p))
            .map(|p| PollItem::Port(*p))
            .collect();
        self.poller.set_ports(ports);
    }

    fn reply_timeout(&mut self, now: Instant) {
        let Some(mut ex) = self.line.exchange.take() else {
            return;
        };
        // A session that was not asked to move never stops what the
        // controller runs, and a reconnect would (once it has moved) or would
        // only repeat the same read: the controller is busy (it answers
        // nothing while a stored program or a move runs, manual 2.2.2, 3.1;
        // `docs/device.md`, "Sessions that do not move"). Say so once, wait,
        // and repeat the read until it is answered.
        if !self.connect_halt && ex.repeatable {
            let limit = self.cx.settings.timing.busy_wait;
            match self.line.busy_since {
                None => {
                    self.line.busy_since = Some(now);
                    self.line.busy_told = Duration::ZERO;
                    self.cx.notice(format!(
                        "{BUSY_NOTICE} (no reply to {}: the controller answers nothing while a \
                         stored program or a move runs; nothing that changes motion is sent; if \
                         nothing runs, check the line; giving up after {} s, isel.busy_wait_s)",
                        ex.text,
                        limit.as_secs()
                    ));
                }
                Some(since) => {
                    // Bounded: a controller that never answers again is a
                    // dead line or a dead controller (issue 37).
                    let waited = now.saturating_duration_since(since);
                    if waited >= limit {
                        self.busy_given_up(&ex.text, waited);
                        return;
                    }
                    self.busy_tell(waited, limit);
                }
            }
            // The decoder still expects the read's reply: one that comes
            // after the deadline (a slow controller, a starved host) answers
            // this read, instead of being taken for unexpected bytes and its
            // repeat's reply for the answer to the read after it.
            ex.transmitted = false;
            ex.transmitted_at = None;
            ex.deadline = None;
            ex.last_byte = None;
            self.line.exchange = Some(ex);
            self.line.resend_at = Some(now + BUSY_REPEAT);
            return;
        }
        self.line.decoder.abandon();
        let waited = ex
            .transmitted_at
            .map_or(Duration::ZERO, |t| now.saturating_duration_since(t));
        let reason = link::no_reply(&ex.text, waited, &mut self.cx.events);
        self.go_down(&reason);
    }

    /// Say how long the wait for a busy controller has lasted, every
    /// [`busy_tell_every`] of it.
    fn busy_tell(&mut self, waited: Duration, limit: Duration) {
        let every = busy_tell_every(limit);
        if waited < self.line.busy_told + every {
            return;
        }
        self.line.busy_told = every * (waited.as_millis() / every.as_millis().max(1)) as u32;
        self.cx.notice(format!(
            "{BUSY_NOTICE}: {} s so far, giving up after {} s (isel.busy_wait_s)",
            waited.as_secs(),
            limit.as_secs()
        ));
    }

    /// The busy controller answered nothing within `isel.busy_wait_s`: the
    /// link counts as lost, and the command that waited ends with it.
    fn busy_given_up(&mut self, command: &str, waited: Duration) {
        self.line.decoder.abandon();
        let reason = format!(
            "no reply to {command} for {:.1} s: the controller answered nothing while jogterm \
             waited for a program to end (isel.busy_wait_s = {})",
            waited.as_secs_f64(),
            self.cx.settings.timing.busy_wait.as_secs()
        );
        self.cx
            .emit(Event::Link(crate::device::api::LinkState::Lost {
                reason: reason.clone(),
            }));
        self.go_down(&reason);
    }

    // ----- stopping ------------------------------------------------------

    /// What every stop does besides sending the bytes.
    fn stop_bookkeeping(&mut self, now: Instant) {
        if let Some(op) = self.op.as_mut()
            && let Some(t) = op.get().stop(&mut self.cx, now)
            && let Some(ex) = self.line.exchange.as_mut()
            && ex.owner == Owner::Op
        {
            if ex.transmitted {
                ex.deadline = Some(now + t);
            } else {
                ex.timeout = Some(t);
            }
        }
        if let Some(ex) = self.line.exchange.as_mut()
            && ex.may_move
            && !ex.transmitted
        {
            ex.restop = true;
        }
    }

    /// A stop the driver decides on (dead-man, release).
    fn halt(&mut self, now: Instant) {
        self.cx.checkout_rest = None;
        self.cx.send_stop();
        self.stop_bookkeeping(now);
    }

    /// A jog stops to go on faster (`motion_op`): the stop sequence, the
    /// move's answer awaited for as long as braking takes, and no jog end.
    fn speed_up(&mut self, now: Instant) {
        let Some(Op::Motion(m)) = self.op.as_mut() else {
            return;
        };
        let Some(t) = m.speed_up(now) else {
            return;
        };
        self.cx.send_stop();
        if let Some(ex) = self.line.exchange.as_mut()
            && ex.owner == Owner::Op
        {
            if ex.transmitted {
                ex.deadline = Some(now + t);
            } else {
                ex.timeout = Some(t);
                ex.restop = ex.may_move;
            }
        }
    }

    fn reset_controller(&mut self, now: Instant) {
        self.cx.checkout_rest = None;
        self.cx
            .control
            .push_back(control_outgoing(ControlByte::Reset));
        self.line.decoder.abandon();
        self.line.exchange = None;
        if let Some(mut op) = self.op.take() {
            op.get().abandon(&mut self.cx, &Abandon::Reset);
        }
        self.queue.refuse_all(
            || Refusal::Invalid {
                reason: "cancelled: the controller was reset".into(),
            },
            JogEnd::Stopped,
            &mut self.cx.events,
        );
        self.cx.apply_reset();
        self.quiet_until = Some(now + self.cx.settings.timing.reset_settle);
        self.cx
            .notice("the controller was reset (0xFE): initialise (i) and reference (h)");
    }

    fn raw_control(&mut self, control: ControlByte, now: Instant) {
        let text = readable(&[control.byte()]);
        if !self.link_up {
            self.cx.emit(Event::Refused {
                request: format!("raw {text}"),
                reason: Refusal::NotConnected,
            });
            return;
        }
        // 0xFF discards a paused move's rest, 0xFD may stop what resumed it.
        self.cx.checkout_rest = None;
        match control {
            ControlByte::Reset => self.reset_controller(now),
            ControlByte::SoftStop | ControlByte::Break => {
                let own_motion = match self.op.as_mut() {
                    // The operator's own move: exactly the byte asked for
                    // (0xFD keeps the rest for `@0S`).
                    Some(Op::Raw(raw)) if raw.is_running_motion() => {
                        if let Some(t) = raw.control_sent(&self.cx, now)
                            && let Some(ex) = self.line.exchange.as_mut()
                        {
                            ex.deadline = Some(now + t);
                        }
                        false
                    }
                    Some(op) => op.peek().activity() != crate::device::api::Activity::Idle,
                    None => false,
                };
                if own_motion {
                    // A move jogterm planned is always broken off completely.
                    self.halt(now);
                } else {
                    let typed =
                        Outgoing::message(control.encode().to_vec(), true, traffic::Owner::User);
                    self.cx.control.push_back(typed);
                }
            }
        }
        self.cx.emit(Event::Reply {
            kind: ReplyKind::Answer,
            command: text,
            text: format!("{} sent (control bytes have no reply)", control.name()),
        });
    }

    // ----- requests ------------------------------------------------------

    /// A queued request's turn has come: check it against the state now.
    fn begin(&mut self, queued: Queued, now: Instant) {
        // Whatever runs now, a paused check-out move's rest is the
        // controller's no longer, unless this resumes it.
        let held = self.cx.checkout_rest.take();
        let cx = &self.cx;
        let started: Result<Op, Refusal> = match &queued.request {
            Request::Jog {
                id, axes, speed_hz, ..
            } => {
                let (lease_until, lease) = queued.held_lease(now);
                plan::jog(cx, axes, speed_hz, lease).map(|p| {
                    Op::Motion(MotionOp::jog(
                        p,
                        *id,
                        axes.clone(),
                        *speed_hz,
                        lease,
                        lease_until,
                    ))
                })
            }
            Request::LimitJog { id, axis, dir } => {
                LimitJogOp::new(cx, *id, *axis, *dir, now).map(Op::Limit)
            }
            Request::Probe { id, probe } => {
                ProbeOp::new(cx, *id, *probe).map(|op| Op::Probe(Box::new(op)))
            }
            Request::Step { delta, speed_hz } => match cx.position {
                Some(base) => {
                    plan::step(cx, &base, delta, speed_hz).map(|p| Op::Motion(MotionOp::step(p)))
                }
                None => Err(Refusal::NotInitialised),
            },
            Request::MoveTo {
                target,
                frame,
                speed_hz,
            } => plan::move_to(cx, target, *frame, speed_hz)
                .map(|p| Op::Motion(MotionOp::move_to(p))),
            Request::Home { axes } => named_axes(cx.settings.axis_set(), *axes).and_then(|()| {
                self.cx.motion_allowed(true)?;
                Ok(Op::Home(HomeOp::new(*axes)))
            }),
            Request::SetZero { axes } => named_axes(cx.settings.axis_set(), *axes).and_then(|()| {
                if !self.cx.profile_ready() {
                    return Err(Refusal::NotInitialised);
                }
                if self.cx.position.is_none() {
                    return Err(Refusal::NotInitialised);
                }
                Ok(Op::Zero(ZeroOp::new(*axes)))
            }),
            Request::SetOutput { output, value } => {
                OutputOp::new(cx, *output, *value).map(Op::Output)
            }
            Request::Raw { line } => RawOp::new(cx, line).map(Op::Raw),
            Request::Upload { lines, erase_first } => {
                UploadOp::new(cx, lines, *erase_first).map(Op::Upload)
            }
            Request::RunProgram => ProgramOp::new(cx).map(Op::Program),
            Request::Checkout {
                id,
                line,
                resume,
                read_back,
                ..
            } => CheckoutOp::new(cx, *id, line, *resume, held, queued.held_lease(now)).map(
                |mut op| {
                    if !read_back {
                        op.skip_read_back();
                    }
                    Op::Checkout(op)
                },
            ),
            Request::Initialise => Ok(Op::Init(InitOp::new(cx))),
            Request::JogRenew { .. }
            | Request::JogRelease { .. }
            | Request::Reset
            | Request::Poll { .. }
            | Request::Shutdown
            | Request::Hold { .. }
            | Request::HoldEnd => return,
        };
        self.started(&queued.request, started.map(Some));
    }

    fn renew(&mut self, id: JogId, lease: Duration, now: Instant) {
        if let Some(Op::Checkout(c)) = self.op.as_mut()
            && c.renew(id, lease, now)
        {
            return;
        }
        if let Some(Op::Motion(m)) = self.op.as_mut()
            && let Some(speed_up) = m.renew(&self.cx, id, lease, now)
        {
            if speed_up {
                self.speed_up(now);
            }
            return;
        }
        self.queue.renew(id, lease, now);
    }

    fn release(&mut self, id: JogId, now: Instant) {
        if let Some(Op::Checkout(c)) = self.op.as_mut()
            && c.release(&mut self.cx, id, false)
        {
            return;
        }
        if let Some(Op::Motion(m)) = self.op.as_mut()
            && let Some(stop) = m.release(&mut self.cx, id)
        {
            if stop {
                self.halt(now);
            }
            return;
        }
        self.queue.release(id, &mut self.cx.events);
    }

    fn idle(&self) -> bool {
        self.link_up
            && self.line.exchange.is_none()
            && self.op.is_none()
            && self.queue.is_empty()
            && !self.cx.cnc_store
            && !self.cx.readback_wanted
    }
}

impl Family for IselLine {
    type Context = Context;
    type Op = Op;
    type PollItem = PollItem;
    type Motion = MotionOp;

    fn readback(_: &IselDriver) -> Op {
        Op::Readback(Readback::new())
    }

    fn connect_settle(cx: &Context) -> Duration {
        cx.settings.timing.connect_settle
    }

    /// The stop sequence opens the link (`0xFD`, [`stop_outgoing`]); an `F`
    /// in the quiet that follows is its answer.
    fn connect(d: &mut IselDriver, _now: Instant) {
        // Another controller may be on the line now: every port is tried,
        // no output is known (it may have been switched off and on).
        d.cx.absent_ports.clear();
        d.cx.ports.forget_outputs();
        d.cx.test_mode_unknown = !d.cx.settings.test_mode_allowed;
        d.poll_plan_ports();
        d.line.poll_error = None;
        if d.connect_halt {
            d.cx.send_stop();
        }
        d.line.settling_after_connect = d.connect_halt;
    }

    fn drop_line(d: &mut IselDriver, reason: &str) {
        let line = &mut d.line;
        line.exchange = None;
        line.busy_since = None;
        line.resend_at = None;
        line.decoder.abandon();
        line.unsent.clear();
        line.stray.clear();
        line.settling_after_connect = false;
        d.cx.control.clear();
        if let Some(mut op) = d.op.take() {
            op.get()
                .abandon(&mut d.cx, &Abandon::LinkLost(reason.to_owned()));
        }
    }

    fn forget(d: &mut IselDriver) {
        // Unknown until read back.
        d.cx.set_config(None);
        d.cx.position = None;
        d.cx.cnc_store = false;
        d.cx.readback_wanted = false;
        d.cx.checkout_rest = None;
    }

    fn transmit(d: &mut IselDriver, now: Instant) -> Option<Outgoing> {
        d.transmit(now)
    }

    fn received(d: &mut IselDriver, bytes: &[u8], now: Instant) -> Vec<MessageEnd> {
        if d.line.exchange.is_none() && d.quiet(now) {
            // Stray bytes while the line settles: keep it quiet a little longer.
            d.line.stray.extend_from_slice(bytes);
            d.quiet_until = Some(now + d.cx.settings.timing.resync_gap);
            return line_ends(bytes, traffic::Owner::Controller);
        }
        if let Some(ex) = d.line.exchange.as_mut() {
            ex.last_byte = Some(now);
            if ex.transmitted
                && let Some(deadline) = ex.deadline
            {
                // Bytes are flowing: the reply may take its length from here.
                let rest =
                    d.cx.settings
                        .line
                        .transfer_time(ex.expect.max_len().min(64))
                        + d.cx.settings.timing.reply_margin;
                ex.deadline = Some(deadline.max(now + rest));
            }
        }
        let (events, ends) = d.decode(bytes);
        d.decoded(events, now);
        d.take_quiet_request(now);
        ends
    }

    fn received_while_down(bytes: &[u8]) -> Vec<MessageEnd> {
        line_ends(bytes, traffic::Owner::Controller)
    }

    fn transmitted(d: &mut IselDriver, now: Instant) {
        let Some(Some(seq)) = d.line.unsent.pop_front() else {
            return;
        };
        let mut restop = false;
        let mut op_owned = false;
        if let Some(ex) = d.line.exchange.as_mut()
            && ex.seq == seq
            && !ex.transmitted
        {
            ex.transmitted = true;
            ex.transmitted_at = Some(now);
            ex.deadline = ex.timeout.map(|t| now + t);
            restop = std::mem::take(&mut ex.restop);
            op_owned = ex.owner == Owner::Op;
        }
        if op_owned && let Some(op) = d.op.as_mut() {
            op.get().transmitted(&mut d.cx, now);
        }
        if restop {
            d.cx.send_stop();
        }
    }

    fn stop(d: &mut IselDriver, now: Instant) -> Outgoing {
        d.cx.checkout_rest = None;
        d.cancel_waiting();
        d.stop_bookkeeping(now);
        stop_outgoing()
    }

    fn emergency_stop(_: &IselDriver) -> Outgoing {
        stop_outgoing()
    }

    fn raw_may_move(line: &str) -> bool {
        raw::line_may_move(line)
    }

    fn timeouts(d: &IselDriver, consider: &mut dyn FnMut(Option<Instant>)) {
        consider(d.line.resend_at);
        if let Some(ex) = &d.line.exchange {
            consider(ex.deadline);
            if matches!(ex.expect, Expect::TextUntilSilence | Expect::TextThenCode) {
                consider(ex.last_byte.map(|t| t + TEXT_SILENCE));
            }
        }
        if d.idle() {
            consider(d.poller.due());
        }
    }

    fn line_timeout(d: &mut IselDriver, now: Instant, quiet_over: bool) {
        if quiet_over {
            d.report_stray();
        }
        if let Some(ex) = &d.line.exchange {
            let text = matches!(ex.expect, Expect::TextUntilSilence | Expect::TextThenCode);
            let silent = ex.last_byte.is_some_and(|t| now >= t + TEXT_SILENCE);
            let overdue = ex.deadline.is_some_and(|t| now >= t);
            if (text && silent) || (overdue && !d.line.decoder.pending().is_empty()) {
                let events = d.line.decoder.silence();
                d.decoded(events, now);
            } else if overdue {
                d.reply_timeout(now);
            }
        }
    }

    fn op_timer(d: &mut IselDriver, now: Instant) {
        if let Some(op) = d.op.as_mut()
            && op.get().on_timer(&mut d.cx, now)
        {
            d.halt(now);
        }
    }

    fn wire_limit_hz(d: &IselDriver) -> f64 {
        let with_a = d.cx.config == Some(crate::proto::isel::AxisConfig::XYZA);
        wire_limit_hz(&d.poller, d.cx.settings.line, with_a)
    }

    fn timeout_done(d: &mut IselDriver, now: Instant) {
        d.take_quiet_request(now);
    }

    fn storing(cx: &Context) -> bool {
        cx.cnc_store
    }

    fn motion(op: &mut Op) -> Option<&mut MotionOp> {
        match op {
            Op::Motion(m) => Some(m),
            _ => None,
        }
    }

    fn renew_jog(d: &mut IselDriver, id: JogId, lease: Duration, now: Instant) {
        d.renew(id, lease, now);
    }

    fn release_jog(d: &mut IselDriver, id: JogId, now: Instant) {
        d.release(id, now);
    }

    fn reset(d: &mut IselDriver, now: Instant) {
        if d.link_up {
            d.reset_controller(now);
        } else {
            refuse(&mut d.cx, &Request::Reset, Refusal::NotConnected);
        }
    }

    /// A control byte goes at once (manual 2.2.31); any other line is
    /// admitted like every request.
    fn raw_line(d: &mut IselDriver, line: String, now: Instant) {
        match control_of(&line) {
            Some(control) => d.raw_control(control, now),
            None => d.admit(Request::Raw { line }, now),
        }
    }

    fn set_reads_only(d: &mut IselDriver, on: bool) {
        d.cx.reads_only = on;
    }
}

/// Messages of `owner` in bytes no command awaits: each line ends one (CR
/// LF); the rest ends when the next command goes out or the line is quiet.
fn line_ends(bytes: &[u8], owner: traffic::Owner) -> Vec<MessageEnd> {
    bytes
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .map(|(i, _)| MessageEnd::new(i + 1, owner))
        .collect()
}
