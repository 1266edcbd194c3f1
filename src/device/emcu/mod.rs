//! The EMCU driver: a sans-IO [`Driver`] for the EMCU interface on SMC3000
//! stepper cards (manual `emcu-smc3000-programming.de.txt`, chapter 1).
//!
//! The line discipline is the interface's: every line is acknowledged, and
//! the next line waits for the answer (manual 1.4.2, at most 500 ms).
//! Master commands (`@…`) run at once, also during a move; buffered
//! commands go into the data memory and run when a line ends with 0x01, and
//! the interface reports the end with an unsolicited 0x02 CR (decision 1),
//! which can arrive between any two lines and is told apart by the core's
//! `Expect::classify`. So positions are polled during moves (always
//! measured), and a stop (`@B`, manual 1.5.11) goes out at once, even while
//! an answer is outstanding (its CR is expected on top).
//!
//! What runs, in order of priority:
//! 1. stops and resets (`@B`, `@R`, `@S`), at once;
//! 2. the current operation ([`op`]): state read-back ([`readback`]),
//!    initialise ([`init`]), reference runs ([`home`]), outputs
//!    ([`output`]), moves and jogs ([`motion_op`]), the stored job
//!    ([`program`]), raw lines ([`raw`]), uploads ([`upload`]); batches and
//!    their runs are [`run`] and [`run_op`];
//! 3. raw queries, between the operation's lines;
//! 4. the next queued request, checked when it is its turn;
//! 5. polling ([`poll`]): positions, and `@X` every `ports_every` cycles.
//!
//! An answer that does not come within its deadline means the link is dead
//! (`Event::Link(Lost)`). A line that does not fit what is awaited (a
//! garbled answer, a CR too many) puts the exchange in doubt: a late answer
//! is still taken, and after a moment of quiet the answer counts as lost
//! and the operation decides (`docs/device.md`).

mod checkout_op;
mod context;
mod effects;
mod home;
mod init;
mod io;
mod measure;
mod motion_op;
mod op;
mod output;
mod plan;
mod poll;
mod program;
mod raw;
mod readback;
mod run;
mod run_op;
mod settings;
mod upload;
pub use upload::MEMORY_FULL_CODE;

#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::time::{Duration, Instant};

pub use context::HALT;
pub use io::{describe_status, output_id, status_byte, status_group};
pub use poll::{PollItem, wire_limit_hz};
pub use raw::{RUN_MARK, RawKind, RawLine, line_text, parse_raw};
pub use settings::{EmcuSettings, StatusPoll, Timing};

use crate::config::Profile;
use crate::device::api::{Event, JogEnd, JogId, Refusal, ReplyKind, Request};
use crate::device::common::admit::parse_raw_request;
use crate::device::common::core::{Core, Family};
use crate::device::common::limits::{invalid, named_axes, record_work_zero};
use crate::device::common::op::operations;
use crate::device::common::sink::refuse;
use crate::device::common::{Queued, SettingsError, Sink, link};
use crate::device::driver::Outgoing;
use crate::proto::emcu::{
    Command, Disposition, Expect, Garbage, Reply, ReplyDecoder, ReplyEvent, Terminator,
};
use crate::traffic::{self, MessageEnd};

use checkout_op::CheckoutOp;
use context::{CONNECT_HALT, Cmd, Context, halt_outgoing, lines_in, reply_len};
use home::{Home, home_op};
use init::{Init, init_op};
use motion_op::MotionOp;
use op::{Abandon, Next, Operation};
use output::{Switch, output_op};
use program::{Job, job_op};
use raw::RawOp;
use readback::Readback;
use run_op::RunOp;
use upload::UploadOp;

operations! {
    #[derive(Debug)]
    pub enum Op: Operation {
        Readback(Readback) => Setup,
        Init(RunOp<Init>) => Setup,
        Home(RunOp<Home>) => Setup,
        Output(RunOp<Switch>) => Setup,
        Job(RunOp<Job>) => Program,
        // Boxed: a jog's speed bookkeeping makes it the largest by far.
        Motion(Box<MotionOp> as MotionOp) => Motion,
        Raw(RawOp) => User,
        Checkout(CheckoutOp) => Motion,
        Upload(UploadOp) => Upload,
    }
}

/// Who waits for the outstanding answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Owner {
    Poll(PollItem),
    Op,
    /// A raw query that went between an operation's lines.
    Side,
}

/// The line on the wire and its answer.
#[derive(Debug)]
struct Exchange {
    seq: u64,
    text: String,
    expect: Expect,
    owner: Owner,
    /// Whose the line and its answer are, for the traffic records.
    shown_as: traffic::Owner,
    timeout: Duration,
    /// Set once the last byte has gone out.
    deadline: Option<Instant>,
    transmitted_at: Option<Instant>,
    may_move: bool,
    /// When a line came that did not fit (garbage, an answer out of step).
    doubt: Option<Instant>,
    /// A stop went out before this line, which starts a run, was complete on
    /// the wire: the run starts after the `@B`, so `@B` goes again.
    restop: bool,
}

/// CRs that answer lines nobody waits for: the stops and resets, which go
/// out whatever is outstanding. Forgotten after their deadline.
#[derive(Debug, Default)]
struct ControlAcks {
    count: u32,
    until: Option<Instant>,
}

impl ControlAcks {
    fn expect(&mut self, until: Instant) {
        self.count += 1;
        self.until = Some(self.until.map_or(until, |u| u.max(until)));
    }

    /// A CR came: one of ours?
    fn take(&mut self) -> bool {
        if self.count == 0 {
            return false;
        }
        self.count -= 1;
        if self.count == 0 {
            self.until = None;
        }
        true
    }

    fn expire(&mut self, now: Instant) {
        if self.until.is_some_and(|u| u <= now) {
            *self = ControlAcks::default();
        }
    }
}

/// The EMCU driver: the driver core with the EMCU line discipline. Build
/// it from a profile, hand it to the device task (or drive it by hand in
/// tests: every method takes the time).
pub type EmcuDriver = Core<EmcuLine>;

/// The EMCU line: every line acknowledged before the next goes, stops and
/// resets at once.
#[derive(Debug)]
pub struct EmcuLine {
    exchange: Option<Exchange>,
    seq: u64,
    decoder: ReplyDecoder,
    /// Messages handed out and not yet reported written: the sequence number
    /// of a line, `None` for a control line.
    unsent: VecDeque<Option<u64>>,
    /// Raw queries waiting to go between an operation's lines.
    side: VecDeque<Cmd>,
    acks: ControlAcks,
    poll_error: Option<String>,
    last_byte: Option<Instant>,
}

impl Core<EmcuLine> {
    pub fn new(settings: EmcuSettings) -> EmcuDriver {
        let step_queue = settings.jog.step_queue;
        let line = EmcuLine {
            exchange: None,
            seq: 0,
            decoder: ReplyDecoder::new(),
            unsent: VecDeque::new(),
            side: VecDeque::new(),
            acks: ControlAcks::default(),
            poll_error: None,
            last_byte: None,
        };
        let poller = poll::poller(&settings);
        Core::with(Context::new(settings), line, poller, step_queue)
    }

    pub fn from_profile(profile: &Profile) -> Result<EmcuDriver, SettingsError> {
        EmcuSettings::from_profile(profile).map(EmcuDriver::new)
    }

    pub fn settings(&self) -> &EmcuSettings {
        &self.cx.settings
    }

    // ----- line discipline ---------------------------------------------

    fn start(&mut self, cmd: Cmd, owner: Owner) -> Outgoing {
        self.line.seq += 1;
        self.line.unsent.push_back(Some(self.line.seq));
        let shown_as = match owner {
            Owner::Poll(_) => traffic::Owner::Poll,
            Owner::Op => self.op.as_ref().map_or(traffic::Owner::Setup, Op::owner),
            Owner::Side => traffic::Owner::User,
        };
        self.line.exchange = Some(Exchange {
            seq: self.line.seq,
            text: cmd.text,
            expect: cmd.expect,
            owner,
            shown_as,
            timeout: cmd.timeout,
            deadline: None,
            transmitted_at: None,
            may_move: cmd.may_move,
            doubt: None,
            restop: false,
        });
        Outgoing::message(cmd.bytes, false, shown_as)
    }

    fn control_deadline(&self, now: Instant) -> Instant {
        now + self.cx.ack_timeout(3, Expect::Ack)
    }

    fn transmit(&mut self, now: Instant) -> Option<Outgoing> {
        if let Some(out) = self.cx.control.pop_front() {
            self.line.unsent.push_back(None);
            let until = self.control_deadline(now);
            for _ in 0..lines_in(&out.bytes) {
                self.line.acks.expect(until);
            }
            return Some(out);
        }
        if !self.link_up || self.line.exchange.is_some() || self.quiet(now) {
            return None;
        }
        loop {
            if let Some(op) = self.op.as_mut() {
                match op.get().next(&mut self.cx, now) {
                    Next::Send(cmd) => return Some(self.start(cmd, Owner::Op)),
                    Next::Wait => break,
                    Next::Done => {
                        self.op = None;
                        continue;
                    }
                }
            }
            if self.cx.readback_wanted {
                self.cx.readback_wanted = false;
                self.op = Some(Op::Readback(Readback::new()));
                continue;
            }
            match self.queue.pop(now, &mut self.cx) {
                Some(q) => self.begin(q, now),
                None => break,
            }
        }
        // Between an operation's lines: raw queries, then polls.
        if let Some(cmd) = self.line.side.pop_front() {
            return Some(self.start(cmd, Owner::Side));
        }
        if self.cx.status_wanted {
            self.cx.status_wanted = false;
            let cmd = self.cx.cmd(&Command::Status, Terminator::Cr);
            return Some(self.start(cmd, Owner::Poll(PollItem::Status)));
        }
        let item = self.poller.next(now)?;
        let command = match item {
            PollItem::Position(axis) => Command::Position(axis),
            PollItem::Status => Command::Status,
        };
        let cmd = self.cx.cmd(&command, Terminator::Cr);
        Some(self.start(cmd, Owner::Poll(item)))
    }

    /// An answer to whoever awaits it; whose it was.
    fn route(&mut self, reply: Reply, now: Instant) -> traffic::Owner {
        if let Some(ex) = &self.line.exchange
            && ex.expect.classify(&reply) == Disposition::Answer
            && let Some(ex) = self.line.exchange.take()
        {
            let owner = ex.shown_as;
            self.answered(ex, reply, now);
            return owner;
        }
        if reply == Reply::Ack && self.line.acks.take() {
            return traffic::Owner::Stop;
        }
        let quiet = self.quiet(now);
        match self.line.exchange.as_mut() {
            Some(ex) => {
                ex.doubt = Some(now);
                let text = format!(
                    "unexpected answer {reply} while waiting for the answer to {}",
                    ex.text
                );
                self.cx.notice(text);
            }
            None if !quiet => self.cx.stray(&reply.to_string()),
            None => {}
        }
        traffic::Owner::Controller
    }

    fn garbage(&mut self, garbage: Garbage, now: Instant) {
        let quiet = self.quiet(now);
        match self.line.exchange.as_mut() {
            Some(ex) => {
                ex.doubt = Some(now);
                let text = format!("{garbage} (waiting for the answer to {})", ex.text);
                self.cx.notice(text);
            }
            None if !quiet => self.cx.stray(&garbage.to_string()),
            None => {}
        }
    }

    /// 0x02 CR: a run has ended (or there is room again).
    fn ready(&mut self, now: Instant) {
        match self.op.as_mut() {
            Some(op) => op.get().ready(&mut self.cx, now),
            // Nobody waits for a run: something ran that jogterm did not
            // start (or a stop ended one). Read `@X`.
            None => self.cx.status_wanted = true,
        }
    }

    fn answered(&mut self, ex: Exchange, reply: Reply, now: Instant) {
        match ex.owner {
            Owner::Op => {
                if let Some(op) = self.op.as_mut() {
                    op.get().reply(&mut self.cx, reply, now);
                }
            }
            Owner::Poll(item) => self.poll_reply(item, reply, now),
            Owner::Side => {
                match reply {
                    Reply::Status(s) => self.cx.status_read(s, now),
                    Reply::Position { axis, steps } => self.cx.position_of(axis, steps),
                    _ => {}
                }
                let text = raw::query_text(&reply);
                self.cx.emit(Event::Reply {
                    kind: ReplyKind::Answer,
                    command: ex.text,
                    text,
                });
            }
        }
    }

    fn poll_reply(&mut self, item: PollItem, reply: Reply, now: Instant) {
        match (item, reply) {
            (PollItem::Position(axis), Reply::Position { steps, .. }) => {
                self.cx.position_part(axis, steps);
                if self.cx.axes().last() == Some(&axis) {
                    self.cx.position_complete(now);
                    self.poller.position_read(now);
                }
                self.line.poll_error = None;
            }
            (PollItem::Status, Reply::Status(status)) => {
                self.cx.status_read(status, now);
                if let Some(op) = self.op.as_mut() {
                    op.get().status(&mut self.cx, status, now);
                }
            }
            // `classify` lets only the awaited answer through.
            _ => {}
        }
    }

    /// The answer to the outstanding line is lost (garbled, out of step, cut).
    fn lost(&mut self, now: Instant) {
        let Some(ex) = self.line.exchange.take() else {
            return;
        };
        self.line.decoder.reset();
        match ex.owner {
            Owner::Op => {
                if let Some(op) = self.op.as_mut() {
                    op.get().lost_reply(&mut self.cx, now);
                }
            }
            Owner::Poll(_) => {
                self.poller.abandon_cycle();
                if self.line.poll_error.as_deref() != Some(&ex.text) {
                    self.cx.notice(format!(
                        "the answer to {} was lost; polling goes on",
                        ex.text
                    ));
                    self.line.poll_error = Some(ex.text);
                }
            }
            Owner::Side => {
                let fault = link::unreadable(&ex.text, "garbled answer");
                self.cx.emit(Event::Fault(fault));
            }
        }
    }

    fn reply_timeout(&mut self, now: Instant) {
        let Some(ex) = self.line.exchange.take() else {
            return;
        };
        let waited = ex
            .transmitted_at
            .map_or(Duration::ZERO, |t| now.saturating_duration_since(t));
        let reason = link::no_reply(&ex.text, waited, &mut self.cx);
        self.go_down(&reason);
    }

    // ----- stopping ------------------------------------------------------

    /// What every stop does besides sending `@B`: waiting requests are
    /// refused, the operation brakes, the data memory is dropped.
    fn stop_all(&mut self, now: Instant) {
        self.queue.refuse_all(
            || Refusal::Invalid {
                reason: "cancelled by stop".into(),
            },
            JogEnd::Stopped,
            &mut self.cx,
        );
        self.halted(now);
    }

    fn halted(&mut self, now: Instant) {
        if let Some(op) = self.op.as_mut() {
            op.get().stop(&mut self.cx, now);
        }
        self.cx.after_halt();
    }

    /// A halt the driver decides on (dead-man, release, an overdue run):
    /// `@B` after whatever is already on its way.
    fn halt(&mut self, now: Instant) {
        self.cx.control.push_back(halt_outgoing());
        self.halted(now);
    }

    /// `@R` (manual 1.5.1) or `@S` (manual 1.5.12): everything ends at once.
    fn abort(&mut self, command: Command, now: Instant) {
        let cmd = self.cx.cmd(&command, Terminator::Cr);
        self.cx
            .control
            .push_back(Outgoing::message(cmd.bytes, false, traffic::Owner::Stop));
        self.line.exchange = None;
        self.line.decoder.reset();
        if let Some(mut op) = self.op.take() {
            op.get().abandon(&mut self.cx, &Abandon::Reset);
        }
        self.queue.refuse_all(
            || Refusal::Invalid {
                reason: "cancelled: the interface was reset".into(),
            },
            JogEnd::Stopped,
            &mut self.cx,
        );
        if command == Command::Reset {
            self.cx.apply_reset();
            self.cx
                .notice("the interface was reset (@R): reference the axes (h)");
        } else {
            self.cx.after_abort();
            self.cx.notice(
                "the axes were stopped at once (@S): the positions are lost, reference the axes (h)",
            );
        }
        // Its answers (a CR, 0x02 CRs of ended runs) fall into the quiet.
        self.quiet_until = Some(now + self.cx.settings.timing.connect_settle);
    }

    // ----- requests ------------------------------------------------------

    fn raw(&mut self, line: String, now: Instant) {
        let Some((request, parsed)) =
            parse_raw_request(line, self.link_up, &mut self.cx, parse_raw)
        else {
            return;
        };
        let text = self.cx.cmd(&parsed.command, parsed.end).text;
        let answer = |cx: &mut Context, what: &str| {
            cx.emit(Event::Reply {
                kind: ReplyKind::Answer,
                command: text.clone(),
                text: what.to_owned(),
            })
        };
        match parsed.kind() {
            RawKind::Halt => {
                self.queue.refuse_all(
                    || Refusal::Invalid {
                        reason: "cancelled by stop".into(),
                    },
                    JogEnd::Stopped,
                    &mut self.cx,
                );
                self.halt(now);
                answer(
                    &mut self.cx,
                    "@B sent: the axes halt with their ramp (positions kept)",
                );
            }
            RawKind::Abort => {
                self.abort(Command::Stop, now);
                answer(
                    &mut self.cx,
                    "@S sent: the axes stopped at once (positions lost)",
                );
            }
            RawKind::Reset => {
                self.abort(Command::Reset, now);
                answer(&mut self.cx, "@R sent: the interface was reset");
            }
            RawKind::Query if self.op.is_some() => {
                let cmd = self.cx.cmd(&parsed.command, parsed.end);
                self.line.side.push_back(cmd);
            }
            RawKind::Query | RawKind::Other => self.admit(request, now),
        }
    }

    /// A queued request's turn has come: check it against the state now.
    fn begin(&mut self, queued: Queued, now: Instant) {
        if let Request::SetZero { axes } = queued.request {
            if let Err(reason) = self.set_zero(axes) {
                refuse(&mut self.cx, &queued.request, reason);
            }
            return;
        }
        let cx = &self.cx;
        let started: Result<Option<Op>, Refusal> = match &queued.request {
            Request::Jog {
                id, axes, speed_hz, ..
            } => {
                let (until, lease) = queued.held_lease(now);
                plan::jog(cx, axes, speed_hz, lease).map(|p| {
                    Some(Op::Motion(Box::new(MotionOp::jog(
                        cx,
                        p,
                        *id,
                        axes.clone(),
                        *speed_hz,
                        lease,
                        until,
                    ))))
                })
            }
            Request::LimitJog { .. } => Err(plan::no_limit_jog()),
            // `docs/probing.md`: E1, the EMCU's one input, only makes a
            // move wait (`&V`, manual 1.5.9); nothing reads it.
            Request::Probe { .. } => Err(invalid(
                "the EMCU has no input a probe can be read on (E1 only makes a move wait, &V)",
            )),
            Request::Step { delta, speed_hz } => match cx.position {
                Some(base) => plan::step(cx, &base, delta, speed_hz)
                    .map(|p| Some(Op::Motion(Box::new(MotionOp::step(cx, p))))),
                None => Err(Refusal::NotInitialised),
            },
            Request::MoveTo {
                target,
                frame,
                speed_hz,
            } => plan::move_to(cx, target, *frame, speed_hz)
                .map(|p| Some(Op::Motion(Box::new(MotionOp::move_to(cx, p))))),
            Request::Home { axes } => named_axes(cx.settings.axes, *axes)
                .and_then(|()| cx.motion_allowed(true))
                .and_then(|()| cx.memory_free())
                .and_then(|()| {
                    home_op(cx, *axes)
                        .map(|op| Some(Op::Home(op)))
                        .ok_or_else(|| invalid(format!("{axes} cannot be referenced")))
                }),
            Request::SetOutput { output, value } => {
                output_op(cx, *output, *value).map(|op| Some(Op::Output(op)))
            }
            Request::Raw { line } => parse_raw(line)
                .and_then(|l| RawOp::new(cx, l))
                .map(|op| Some(Op::Raw(op))),
            Request::Upload { lines, .. } => {
                UploadOp::new(cx, lines).map(|op| Some(Op::Upload(op)))
            }
            Request::RunProgram => job_op(cx).map(|op| Some(Op::Job(op))),
            Request::Checkout {
                id, line, resume, ..
            } => CheckoutOp::new(cx, *id, line, *resume, queued.held_lease(now))
                .map(|op| Some(Op::Checkout(op))),
            Request::Initialise => cx.memory_free().map(|()| Some(Op::Init(init_op(cx)))),
            Request::SetZero { .. }
            | Request::JogRenew { .. }
            | Request::JogRelease { .. }
            | Request::Reset
            | Request::Poll { .. }
            | Request::Shutdown
            | Request::Hold { .. }
            | Request::HoldEnd => Ok(None),
        };
        self.started(&queued.request, started);
    }

    /// jogterm's work zero: the EMCU has no zero point of its own (manual
    /// 1.5.10 counts from the reference point), so `SetZero` only records
    /// the position (`docs/protocols.md`, EMCU).
    fn set_zero(&mut self, axes: crate::axis::AxisSet) -> Result<(), Refusal> {
        let cx = &mut self.cx;
        record_work_zero(&mut cx.state.work_zero, cx.settings.axes, axes, cx.position)
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

    /// A jog halts to go on faster (`motion_op`): `@B` after whatever is
    /// already on its way, the data memory dropped, and no jog end.
    fn speed_up(&mut self, now: Instant) {
        let Some(Op::Motion(m)) = self.op.as_mut() else {
            return;
        };
        m.speed_up(&self.cx, now);
        self.cx.control.push_back(halt_outgoing());
        self.cx.after_halt();
    }

    fn release(&mut self, id: JogId, now: Instant) {
        if let Some(Op::Checkout(c)) = self.op.as_mut()
            && let Some(halt) = c.release(id)
        {
            if halt {
                self.halt(now);
            }
            return;
        }
        if let Some(Op::Motion(m)) = self.op.as_mut()
            && let Some(halt) = m.release(&mut self.cx, id, now)
        {
            if halt {
                self.halt(now);
            }
            return;
        }
        self.queue.release(id, &mut self.cx);
    }
}

/// The request a raw query stood for, for refusals.
fn raw_request(cmd: &Cmd) -> Request {
    Request::Raw {
        line: String::from_utf8_lossy(cmd.bytes.strip_suffix(b"\r").unwrap_or(&cmd.bytes))
            .into_owned(),
    }
}

/// What opens every connection ([`CONNECT_HALT`]): the CR and `@B` are
/// two lines, each answered.
fn connect_halt() -> Outgoing {
    Outgoing::messages(CONNECT_HALT.to_vec(), false, traffic::Owner::Stop, &[1, 4])
}

impl Family for EmcuLine {
    type Context = Context;
    type Op = Op;
    type PollItem = PollItem;
    type Motion = MotionOp;

    fn readback(_: &EmcuDriver) -> Op {
        Op::Readback(Readback::new())
    }

    fn connect_settle(cx: &Context) -> Duration {
        cx.settings.timing.connect_settle
    }

    /// The first line on every connection is `@B` (after a CR that ends any
    /// line the broken link cut, [`CONNECT_HALT`]): it also drops commands
    /// left in the data memory. A job transfer that was open when the link
    /// was lost is ended with a bare 0x01 (`upload`).
    fn connect(d: &mut EmcuDriver, _now: Instant) {
        d.line.poll_error = None;
        if d.connect_halt {
            d.cx.control.push_back(connect_halt());
        }
        if std::mem::take(&mut d.cx.transfer_left_open) {
            let end = upload::transfer_end(&d.cx);
            d.cx.control
                .push_back(Outgoing::message(end.bytes, false, traffic::Owner::Stop));
            d.cx.state.program = crate::device::api::ProgramState::Invalid;
            d.cx.notice(
                "a job transfer was open when the link was lost: it was ended with a bare 0x01 \
                 (the partial job is discarded, the error flag set)",
            );
        }
    }

    fn drop_line(d: &mut EmcuDriver, reason: &str) {
        d.line.exchange = None;
        d.line.decoder.reset();
        d.line.unsent.clear();
        d.line.acks = ControlAcks::default();
        d.cx.control.clear();
        if let Some(mut op) = d.op.take() {
            op.get()
                .abandon(&mut d.cx, &Abandon::LinkLost(reason.to_owned()));
        }
    }

    fn forget(d: &mut EmcuDriver) {
        for cmd in std::mem::take(&mut d.line.side) {
            refuse(&mut d.cx, &raw_request(&cmd), Refusal::NotConnected);
        }
        // Unknown until read back and initialised again.
        let cx = &mut d.cx;
        cx.position = None;
        cx.status = None;
        cx.set_ramp(false);
        cx.slot_hz = None;
        cx.outputs = [None; 2];
        cx.e1_link = None;
        cx.stored.clear();
        if cx.transfer {
            cx.transfer = false;
            cx.transfer_left_open = true;
        }
        cx.readback_wanted = false;
        cx.status_wanted = false;
        cx.halt_wanted = false;
    }

    fn transmit(d: &mut EmcuDriver, now: Instant) -> Option<Outgoing> {
        d.transmit(now)
    }

    fn received(d: &mut EmcuDriver, bytes: &[u8], now: Instant) -> Vec<MessageEnd> {
        d.line.last_byte = Some(now);
        if let Some(ex) = d.line.exchange.as_mut()
            && let Some(deadline) = ex.deadline
        {
            // Bytes are flowing: the answer may take its length from here.
            let rest = d.cx.settings.line.transfer_time(reply_len(ex.expect))
                + d.cx.settings.timing.reply_margin;
            ex.deadline = Some(deadline.max(now + rest));
        }
        // A byte at a time, so that each answer's end is known (the
        // decoder gives the same events for any split, `fuzz_emcu`).
        let mut ends = Vec::new();
        for (i, byte) in bytes.iter().enumerate() {
            for event in d.line.decoder.feed(std::slice::from_ref(byte)) {
                let owner = match event {
                    ReplyEvent::Reply(Reply::Ready) => {
                        d.ready(now);
                        traffic::Owner::Controller
                    }
                    ReplyEvent::Reply(reply) => d.route(reply, now),
                    ReplyEvent::Garbage(g) => {
                        d.garbage(g, now);
                        traffic::Owner::Controller
                    }
                };
                ends.push(MessageEnd::new(i + 1, owner));
            }
        }
        ends
    }

    fn transmitted(d: &mut EmcuDriver, now: Instant) {
        let Some(Some(seq)) = d.line.unsent.pop_front() else {
            return;
        };
        let mut restop = false;
        let mut op_owned = false;
        if let Some(ex) = d.line.exchange.as_mut()
            && ex.seq == seq
            && ex.transmitted_at.is_none()
        {
            ex.transmitted_at = Some(now);
            ex.deadline = Some(now + ex.timeout);
            restop = std::mem::take(&mut ex.restop);
            op_owned = ex.owner == Owner::Op;
        }
        if op_owned && let Some(op) = d.op.as_mut() {
            op.get().transmitted(&mut d.cx, now);
        }
        if restop {
            d.cx.control.push_back(halt_outgoing());
        }
    }

    fn stop(d: &mut EmcuDriver, now: Instant) -> Outgoing {
        d.stop_all(now);
        if let Some(ex) = d.line.exchange.as_mut()
            && ex.may_move
            && ex.transmitted_at.is_none()
        {
            ex.restop = true;
        }
        let until = d.control_deadline(now);
        d.line.acks.expect(until);
        halt_outgoing()
    }

    /// The emergency handle writes from another thread, between any two
    /// bytes of a line the writer has on its way: `@LZ` cut into `@L` +
    /// `@B` CR + `Z` CR would be the malformed line `@L@B`, the stop lost
    /// and the axes left running. The CR first ends the cut line, so `@B`
    /// is a line of its own, as on every connection ([`CONNECT_HALT`]).
    fn emergency_stop(_: &EmcuDriver) -> Outgoing {
        connect_halt()
    }

    /// A line ended by 0x01 runs the data memory, whatever it holds.
    fn raw_may_move(line: &str) -> bool {
        raw::parse_raw(line).map_or(true, |l| {
            l.command.may_move() || l.end == Terminator::RunBuffer
        })
    }

    fn timeouts(d: &EmcuDriver, consider: &mut dyn FnMut(Option<Instant>)) {
        consider(d.line.acks.until);
        match &d.line.exchange {
            Some(ex) => {
                let resync = d.cx.settings.timing.resync_gap;
                consider(ex.deadline);
                consider(
                    ex.doubt
                        .map(|t| d.line.last_byte.unwrap_or(t).max(t) + resync),
                );
            }
            None => consider(d.poller.due()),
        }
    }

    fn line_timeout(d: &mut EmcuDriver, now: Instant, _quiet_over: bool) {
        d.line.acks.expire(now);
        if let Some(ex) = &d.line.exchange {
            let resync = d.cx.settings.timing.resync_gap;
            let quiet_since = d.line.last_byte.unwrap_or(now);
            let doubt_over = ex.doubt.is_some_and(|t| now >= quiet_since.max(t) + resync);
            let overdue = ex.deadline.is_some_and(|t| now >= t);
            if doubt_over || (overdue && !d.line.decoder.pending().is_empty()) {
                d.lost(now);
            } else if overdue {
                d.reply_timeout(now);
            }
        }
    }

    fn op_timer(d: &mut EmcuDriver, now: Instant) {
        if let Some(op) = d.op.as_mut()
            && op.get().on_timer(&mut d.cx, now)
        {
            d.halt(now);
        }
    }

    fn wire_limit_hz(d: &EmcuDriver) -> f64 {
        let axes = d.cx.axes();
        wire_limit_hz(&d.poller, d.cx.settings.line, &axes, d.cx.position.as_ref())
    }

    /// A halt an operation asked for.
    fn before_settle(d: &mut EmcuDriver, now: Instant) {
        if std::mem::take(&mut d.cx.halt_wanted) && d.link_up {
            d.halt(now);
        }
    }

    fn storing(cx: &Context) -> bool {
        cx.transfer
    }

    fn motion(op: &mut Op) -> Option<&mut MotionOp> {
        match op {
            Op::Motion(m) => Some(m.as_mut()),
            _ => None,
        }
    }

    fn renew_jog(d: &mut EmcuDriver, id: JogId, lease: Duration, now: Instant) {
        d.renew(id, lease, now);
    }

    fn release_jog(d: &mut EmcuDriver, id: JogId, now: Instant) {
        d.release(id, now);
    }

    /// `@R` (manual 1.5.1).
    fn reset(d: &mut EmcuDriver, now: Instant) {
        if d.link_up {
            d.abort(Command::Reset, now);
        } else {
            refuse(&mut d.cx, &Request::Reset, Refusal::NotConnected);
        }
    }

    fn raw_line(d: &mut EmcuDriver, line: String, now: Instant) {
        d.raw(line, now);
    }
}
