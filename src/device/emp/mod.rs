//! The EMP driver: a sans-IO [`Driver`] for MSR DRS-500-ECS servo drives on
//! one link (Easy Motion Protocol, manual `msr-emp-drs500-command-set.de.txt`;
//! `docs/decisions.md` EMP, `docs/protocols.md` EMP).
//!
//! Line discipline: one request at a time waits for its first answer (the
//! drives answer in order; a round trip is 10.8 ms at 38400 baud). Long
//! actions (`26` homing, TP `2A`) answer `55` at once and `22` on their own
//! when done (decision 1): the core's `Correlator` matches those completions
//! to their request by CMD and DS, so the line is free while they run and
//! positions are polled (`2C`, always measured). Stops (`08` or `2A 03` per
//! `emp.stop`) go out at once, whatever is outstanding. A request answered
//! `EE` is followed by `0A` to the same drive, and the fault is reported
//! with the meaning of its code.
//!
//! What runs, in order of priority:
//! 1. stops;
//! 2. `0A` after a rejection;
//! 3. the current operation: read-back ([`readback`]), initialise
//!    ([`init`]), reference runs ([`home`]), moves and jogs ([`motion_op`],
//!    planned in [`plan`]), outputs ([`output`]), raw frames ([`raw`]);
//!    long actions that stay busy are given up at their deadline
//!    ([`deadline`]) or, reference runs planned or raw, when they stall
//!    ([`stall`]), both through [`guard`];
//! 4. raw queries, between the operation's frames;
//! 5. the next queued request, checked when it is its turn;
//! 6. polling ([`poll`]).

mod context;
mod deadline;
mod drive;
mod drive_stops;
mod guard;
mod home;
mod init;
mod io;
mod limit_op;
mod motion_op;
mod op;
mod output;
pub(crate) mod plan;
mod poll;
mod probe_op;
mod raw;
mod readback;
mod script;
mod settings;
mod speed;
mod stall;

#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::time::{Duration, Instant};

pub use output::output_id;
pub use poll::{OFF_POLL_EVERY, PollItem, wire_limit_hz};
pub use raw::{STARTED, parse_raw, reply_text};
pub use settings::{DriveAxis, EmpSettings, Timing};
pub use speed::DriveSpeed;

use crate::axis::AxisSet;
use crate::config::Profile;
use crate::device::api::{Activity, Event, JogEnd, JogId, Refusal, ReplyKind, Request};
use crate::device::common::admit::parse_raw_request;
use crate::device::common::core::{Core, Family};
use crate::device::common::limits::{invalid, named_axes, record_work_zero};
use crate::device::common::op::operations;
use crate::device::common::{Queued, SettingsError, Sink, link};
use crate::device::driver::Outgoing;
use crate::proto::emp::{
    Command, Correlator, DriveAddress, Event as Matched, FrameDecoder, Incoming, Reply, ReplyBody,
    Request as Frame,
};
use crate::traffic::{self, MessageEnd};

use context::Context;
use home::Home;
use init::Init;
use limit_op::LimitJogOp;
use motion_op::MotionOp;
use op::Operation;
use output::output_request;
use probe_op::ProbeOp;
use raw::{RawOp, frame_text, is_query};
use readback::Readback;
use script::{Next, Outcome, Script};

operations! {
    #[derive(Debug)]
    pub enum Op: Operation {
        Readback(Readback) => Setup,
        Init(Init) => Setup,
        Home(Home) => Setup,
        Output(Script) => Setup,
        Motion(Box<MotionOp> as MotionOp) => Motion,
        Limit(Box<LimitJogOp> as LimitJogOp) => Motion,
        Probe(Box<ProbeOp> as ProbeOp) => Motion,
        Raw(RawOp) => User,
    }
}

/// Who waits for the answers to a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Owner {
    Poll(PollItem),
    Op,
    /// A raw query between an operation's frames.
    Side,
    /// `0A` after `rejected` was answered `EE`; `quiet`: "not switched on"
    /// is a notice, not a fault (a query or a stop to a drive that is off).
    ErrorQuery {
        rejected: Frame,
        quiet: bool,
    },
    /// A stop frame.
    Stop,
    /// A stop frame typed by the operator: also answered as `Event::Reply`.
    RawStop,
}

/// The EMP driver: the driver core with the EMP line discipline. Build it
/// from a profile, hand it to the device task (or drive it by hand in
/// tests: every method takes the time).
pub type EmpDriver = Core<EmpLine>;

/// The EMP line: frames matched to their answers by the correlator, one
/// first answer awaited at a time, stops at once.
#[derive(Debug)]
pub struct EmpLine {
    decoder: FrameDecoder,
    correlator: Correlator,
    /// Frames sent whose answers are awaited, with who awaits them.
    owners: Vec<(Frame, Owner)>,
    side: VecDeque<Frame>,
    errors: VecDeque<(Frame, bool)>,
    /// Stop frames to send at once.
    stops: VecDeque<Frame>,
    /// Typed stop frames, sent right after those.
    raw_stops: VecDeque<Frame>,
    /// Holds back the polls of drives that are switched off.
    off_polls: poll::OffDrives,
    /// Frames handed to the writer and not yet reported written.
    unsent: VecDeque<Frame>,
    /// A stop overtook a frame that may move (the stop lane jumps the
    /// writer's queue): stop its drive again once it is written.
    restop: Vec<Frame>,
    /// Bytes of an answer are arriving: the first answers awaited are not
    /// overdue before this (the rest of a frame, and the margin), as the
    /// isel and EMCU drivers give a reply its length once it flows.
    arriving_until: Option<Instant>,
}

impl Core<EmpLine> {
    pub fn new(settings: EmpSettings) -> EmpDriver {
        let step_queue = settings.jog.step_queue;
        let line = EmpLine {
            decoder: FrameDecoder::new(),
            correlator: Correlator::new(settings.reply_timeout()),
            owners: Vec::new(),
            side: VecDeque::new(),
            errors: VecDeque::new(),
            stops: VecDeque::new(),
            raw_stops: VecDeque::new(),
            off_polls: poll::OffDrives::default(),
            unsent: VecDeque::new(),
            restop: Vec::new(),
            arriving_until: None,
        };
        let poller = poll::poller(&settings);
        Core::with(Context::new(settings), line, poller, step_queue)
    }

    pub fn from_profile(profile: &Profile) -> Result<EmpDriver, SettingsError> {
        EmpSettings::from_profile(profile).map(EmpDriver::new)
    }

    pub fn settings(&self) -> &EmpSettings {
        &self.cx.settings
    }

    // ----- the line ------------------------------------------------------

    /// Hand a frame to the writer and expect its answers.
    fn send(&mut self, frame: Frame, owner: Owner, now: Instant) -> Outgoing {
        let shown_as = self.shown_as(Some(owner));
        self.register(frame, owner, now);
        self.line.unsent.push_back(frame);
        Outgoing::message(frame.encode().to_vec(), false, shown_as)
    }

    /// Whose frames of `owner` are, for the traffic records.
    fn shown_as(&self, owner: Option<Owner>) -> traffic::Owner {
        match owner {
            Some(Owner::Poll(_)) => traffic::Owner::Poll,
            Some(Owner::Op) => self.op.as_ref().map_or(traffic::Owner::Setup, Op::owner),
            Some(Owner::Side) => traffic::Owner::User,
            Some(Owner::ErrorQuery { .. }) => traffic::Owner::Setup,
            Some(Owner::Stop | Owner::RawStop) => traffic::Owner::Stop,
            None => traffic::Owner::Controller,
        }
    }

    /// Whose a frame that came is (the request it answers), and whether
    /// it is a rejection (INFO `EE`); what answers nothing, or could not
    /// be read, is the controller's own.
    fn answer_of(&self, m: &Matched) -> (traffic::Owner, bool) {
        match m {
            Matched::Answered { request, .. }
            | Matched::Started { request, .. }
            | Matched::Completed { request, .. }
            | Matched::Ended { request, .. } => (self.shown_as(self.owner_of(request)), false),
            Matched::Rejected { request, .. } | Matched::Failed { request, .. } => {
                (self.shown_as(self.owner_of(request)), true)
            }
            Matched::TimedOut { .. } | Matched::Malformed { .. } | Matched::Unexpected { .. } => {
                (traffic::Owner::Controller, false)
            }
        }
    }

    fn register(&mut self, frame: Frame, owner: Owner, now: Instant) {
        let ended = self.line.correlator.sent(frame, now);
        self.line.owners.push((frame, owner));
        for m in ended {
            self.matched(m, now);
        }
    }

    fn owner_of(&self, frame: &Frame) -> Option<Owner> {
        self.line
            .owners
            .iter()
            .find(|(f, _)| f == frame)
            .map(|(_, o)| *o)
    }

    fn take_owner(&mut self, frame: &Frame) -> Option<Owner> {
        let i = self.line.owners.iter().position(|(f, _)| f == frame)?;
        Some(self.line.owners.remove(i).1)
    }

    fn transmit(&mut self, now: Instant) -> Option<Outgoing> {
        if !self.link_up {
            return None;
        }
        if let Some(frame) = self.line.stops.pop_front() {
            return Some(self.send(frame, Owner::Stop, now));
        }
        if let Some(frame) = self.line.raw_stops.pop_front() {
            return Some(self.send(frame, Owner::RawStop, now));
        }
        // One first answer at a time (stops aside).
        if self.line.correlator.next_deadline().is_some() || self.quiet(now) {
            return None;
        }
        if let Some((rejected, quiet)) = self.line.errors.pop_front() {
            let frame = Frame::new(rejected.ds, Command::LastError);
            return Some(self.send(frame, Owner::ErrorQuery { rejected, quiet }, now));
        }
        loop {
            if let Some(op) = self.op.as_mut() {
                match op.get().next(&mut self.cx, now) {
                    Next::Send(frame) => return Some(self.send(frame, Owner::Op, now)),
                    Next::Wait => break,
                    Next::Done => {
                        self.op = None;
                        continue;
                    }
                }
            }
            match self.queue.pop(now, &mut self.cx) {
                Some(q) => self.begin(q, now),
                None => break,
            }
        }
        if let Some(frame) = self.line.side.pop_front() {
            return Some(self.send(frame, Owner::Side, now));
        }
        self.next_poll(now)
    }

    /// The next poll due; the polls of a drive that is off are held back
    /// (`poll::OffDrives`) and the cycle goes on without them.
    fn next_poll(&mut self, now: Instant) -> Option<Outgoing> {
        // A cycle's items at most, so a line-speed poller whose every item
        // is held back does not spin.
        let most = self.cx.drives.len() * 2 + 1;
        self.line.off_polls.look();
        for _ in 0..most {
            let Some(item) = self.poller.next(now) else {
                // Nothing more in this cycle: the poller wakes for the next.
                self.line.off_polls.look();
                return None;
            };
            let off = self.cx.known_off(item.ds());
            if self.line.off_polls.admit(item, off, now) {
                self.line.off_polls.look();
                return Some(self.send(item.request(), Owner::Poll(item), now));
            }
        }
        None
    }

    /// Stop frames for `drives`, sent ahead of everything.
    fn stop_drives(&mut self, drives: &[DriveAddress]) {
        for ds in drives {
            let frame = self.cx.stop_request(*ds);
            if !self.line.stops.contains(&frame) {
                self.line.stops.push_back(frame);
            }
        }
    }

    fn collect_stops(&mut self) {
        let wanted = self
            .op
            .as_mut()
            .map(|o| o.get().take_stops())
            .unwrap_or_default();
        if !wanted.is_empty() && self.link_up {
            self.stop_drives(&wanted);
        }
    }

    /// A frame that came; whose it was, and whether a rejection.
    fn incoming(&mut self, incoming: Incoming, now: Instant) -> (traffic::Owner, bool) {
        let m = self.line.correlator.received(incoming);
        let answer = self.answer_of(&m);
        self.matched(m, now);
        answer
    }

    /// What the correlator made of a frame (or of a frame sent).
    fn matched(&mut self, m: Matched, now: Instant) {
        match m {
            Matched::Answered { request, reply } => {
                let owner = self.take_owner(&request);
                self.observe(&request, &reply, now);
                self.dispatch(owner, &request, Outcome::Answered, Some(&reply), now);
            }
            Matched::Started { request, reply } => {
                let owner = self.owner_of(&request);
                self.observe(&request, &reply, now);
                self.dispatch(owner, &request, Outcome::Started, Some(&reply), now);
            }
            Matched::Completed { request, reply } => {
                let owner = self.take_owner(&request);
                self.observe(&request, &reply, now);
                if owner.is_none() {
                    self.cx
                        .notice(format!("{} completed: {reply}", frame_text(&request)));
                }
                self.dispatch(owner, &request, Outcome::Completed, Some(&reply), now);
            }
            Matched::Rejected { request, reply } | Matched::Failed { request, reply } => {
                let owner = self.take_owner(&request);
                self.rejected(&request, owner);
                self.dispatch(owner, &request, Outcome::Rejected, Some(&reply), now);
            }
            Matched::Ended { request, .. } => {
                let owner = self.take_owner(&request);
                self.dispatch(owner, &request, Outcome::Ended, None, now);
            }
            Matched::TimedOut { request } => {
                let waited = self.cx.settings.reply_timeout();
                let reason = link::no_reply(&frame_text(&request), waited, &mut self.cx);
                self.go_down(&reason);
            }
            Matched::Malformed {
                request,
                incoming,
                error,
            } => {
                let owner = self.take_owner(&request);
                let mut fault = link::unreadable(&frame_text(&request), "unreadable reply");
                fault.meaning = format!("{incoming}: {error}. {}", fault.meaning);
                match owner {
                    Some(Owner::Poll(_)) => {
                        self.poller.abandon_cycle();
                        self.cx.notice(fault.meaning);
                    }
                    _ => self.cx.emit(Event::Fault(fault)),
                }
                if request.command.may_move() {
                    // Whether it moves is unknown: stop it.
                    self.stop_drives(&[request.ds]);
                }
                self.dispatch(owner, &request, Outcome::Rejected, None, now);
            }
            Matched::Unexpected { incoming, reason } => {
                if !self.quiet(now) {
                    self.cx
                        .notice(format!("unexpected frame {incoming} ignored: {reason}"));
                }
            }
        }
    }

    fn observe(&mut self, request: &Frame, reply: &Reply, now: Instant) {
        if let Some(body) = reply.body() {
            let limits_before = self.cx.drive(request.ds).and_then(|d| d.limits);
            self.cx.observe(request, body, now);
            if let ReplyBody::Inputs { limits, .. } | ReplyBody::Outputs { limits, .. } = body {
                let was = limits_before.is_some_and(|l| l.plus || l.minus);
                if (limits.plus || limits.minus) && !was {
                    self.limit_hit(request.ds, *limits);
                }
            }
        }
    }

    /// A limit switch has become active: the drive has braked on its own
    /// (manual, introduction); the axis needs a reference run.
    fn limit_hit(&mut self, ds: DriveAddress, limits: crate::proto::emp::Limits) {
        let Some(axis) = self.cx.settings.axis_of(ds) else {
            return;
        };
        // The switches under the profile's names (`[io]`, `11.limit+`).
        let wiring = &self.cx.settings.wiring;
        let names: Vec<String> = [("limit+", limits.plus), ("limit-", limits.minus)]
            .into_iter()
            .filter(|(_, on)| *on)
            .map(|(suffix, _)| {
                let address = format!("{ds}.{suffix}");
                wiring.bit(&address).map_or(address, |b| b.label())
            })
            .collect();
        let fault = crate::device::api::ControllerFault {
            command: format!("{ds}: 40 01"),
            code: "limit".into(),
            meaning: format!(
                "drive {ds} ({axis}): {}: the drive braked at the switch",
                names.join(", ")
            ),
            recovery: crate::device::api::Recovery::Reference,
        };
        self.cx.unreference(axis);
        self.cx.state.fault = Some(fault.clone());
        self.cx.emit(Event::Fault(fault));
        if let Some(op) = self.op.as_mut() {
            op.get().limit_hit(&mut self.cx, ds);
        }
        self.collect_stops();
    }

    fn rejected(&mut self, request: &Frame, owner: Option<Owner>) {
        if request.command == Command::LastError {
            // A drive that is on answers `0A` (manual "0A"); one that is not
            // takes no command at all ("Ohne diesen Einschalt-Befehl werden
            // keine Kommandos angenommen", manual "02"), and some reject `0A`
            // too (docs/decisions.md "EMP before 02"). So the drive is
            // off, and asking again would only loop.
            let (rejected, quiet) = match owner {
                Some(Owner::ErrorQuery { rejected, quiet }) => (rejected, quiet),
                // The read-back's own `0A`, or one typed (answered as such).
                _ => (*request, true),
            };
            self.cx.rejected_while_off(&rejected, quiet);
            return;
        }
        // What jogterm sent on its own to a drive that is off is a notice;
        // what the operator asked for is a fault.
        let quiet = matches!(owner, Some(Owner::Stop | Owner::Poll(_)))
            || (owner == Some(Owner::Op) && matches!(self.op, Some(Op::Readback(_))));
        // Sent on its own to a drive known to be off: nothing new to ask.
        if quiet && self.cx.known_off(request.ds) {
            return;
        }
        self.line.errors.push_back((*request, quiet));
    }

    fn dispatch(
        &mut self,
        owner: Option<Owner>,
        request: &Frame,
        outcome: Outcome,
        reply: Option<&Reply>,
        now: Instant,
    ) {
        match owner {
            Some(Owner::Op) | None => {
                if let Some(op) = self.op.as_mut()
                    && (owner.is_some() || op.peek().owns(request))
                {
                    op.get().outcome(&mut self.cx, request, outcome, reply, now);
                }
            }
            Some(Owner::Poll(item)) => self.poll_reply(item, outcome, now),
            Some(Owner::Side) => {
                if let Some(r) = reply {
                    self.cx.emit(Event::Reply {
                        kind: ReplyKind::Answer,
                        command: frame_text(request),
                        text: reply_text(r),
                    });
                }
            }
            Some(Owner::ErrorQuery { rejected, quiet }) => {
                if let Some(Reply::Ready {
                    body: ReplyBody::LastError(code),
                    ..
                }) = reply
                {
                    self.cx.error_read(&rejected, *code, quiet);
                }
            }
            Some(Owner::Stop) => {
                if let Some(op) = self.op.as_mut() {
                    op.get().stop_answered(request.ds);
                }
            }
            Some(Owner::RawStop) => {
                if let Some(op) = self.op.as_mut() {
                    op.get().stop_answered(request.ds);
                }
                if let Some(r) = reply {
                    self.cx.emit(Event::Reply {
                        kind: ReplyKind::Answer,
                        command: frame_text(request),
                        text: reply_text(r),
                    });
                }
            }
        }
        self.collect_stops();
    }

    fn poll_reply(&mut self, item: PollItem, outcome: Outcome, now: Instant) {
        if outcome == Outcome::Rejected && self.cx.known_off(item.ds()) {
            // Still off: nothing was lost, the other drives' polls go on.
            return;
        }
        if outcome != Outcome::Answered {
            self.poller.abandon_cycle();
            return;
        }
        match item {
            PollItem::Position(ds) => {
                if let Some(op) = self.op.as_mut() {
                    op.get().polled(&mut self.cx, ds, now);
                }
                let last = self.cx.drives.last().map(|d| d.ds);
                if last == Some(ds) {
                    self.cx.position_complete(now);
                    self.poller.position_read(now);
                    if let Some(op) = self.op.as_mut() {
                        op.get().position(&mut self.cx, now);
                    }
                }
            }
            PollItem::Io(ds) => {
                let last = self.poller.ports().last().copied();
                if last == Some(PollItem::Io(ds)) {
                    let snapshot = io::snapshot(&self.cx.drives, &self.cx.settings.wiring, now);
                    self.cx.emit(Event::Io(snapshot));
                }
            }
        }
    }

    // ----- requests ------------------------------------------------------

    fn raw(&mut self, line: String, now: Instant) {
        let Some((request, frame)) = parse_raw_request(line, self.link_up, &mut self.cx, parse_raw)
        else {
            return;
        };
        if frame.command.is_stop() {
            // A typed stop goes at once, like the stop key.
            self.queue.refuse_all(
                || Refusal::Invalid {
                    reason: "cancelled by stop".into(),
                },
                JogEnd::Stopped,
                &mut self.cx,
            );
            if let Some(op) = self.op.as_mut() {
                op.get().stopped(&mut self.cx, &[frame.ds]);
            }
            self.line.raw_stops.push_back(frame);
            return;
        }
        if is_query(&frame.command) && self.op.is_some() {
            self.line.side.push_back(frame);
            return;
        }
        self.admit(request, now);
    }

    /// A queued request's turn has come: check it against the state now.
    fn begin(&mut self, queued: Queued, now: Instant) {
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
            Request::Probe { id, probe } => {
                ProbeOp::new(cx, *id, *probe).map(|op| Some(Op::Probe(Box::new(op))))
            }
            Request::LimitJog { id, axis, dir } => {
                LimitJogOp::new(cx, *id, *axis, *dir, now).map(|op| Some(Op::Limit(Box::new(op))))
            }
            Request::Step { delta, speed_hz } => match cx.positions() {
                Some(base) => plan::step(cx, &base, delta, speed_hz)
                    .map(|p| Some(Op::Motion(Box::new(MotionOp::step(cx, p, *delta))))),
                None => Err(Refusal::NotInitialised),
            },
            Request::MoveTo {
                target,
                frame,
                speed_hz,
            } => plan::move_to(cx, target, *frame, speed_hz)
                .map(|p| Some(Op::Motion(Box::new(MotionOp::move_to(cx, p))))),
            Request::Home { axes } => named_axes(cx.settings.axes, *axes)
                .and_then(|()| cx.motion_allowed(*axes, true))
                .and_then(|()| {
                    Home::new(cx, *axes)
                        .map(|h| Some(Op::Home(h)))
                        .ok_or_else(|| invalid(format!("{axes} cannot be referenced")))
                }),
            Request::SetZero { axes } => self.set_zero(*axes).map(|()| None),
            Request::SetOutput { output, value } => {
                output_request(cx, *output, *value).map(|f| Some(Op::Output(Script::sends([f]))))
            }
            Request::Raw { line } => parse_raw(line)
                .and_then(|f| RawOp::new(cx, f))
                .map(|op| Some(Op::Raw(op))),
            Request::Initialise => Ok(Some(Op::Init(Init::new(cx)))),
            Request::Upload { .. } | Request::RunProgram | Request::Checkout { .. } => Err(
                invalid("EMP drives store no programs (EMP manual: every command runs at once)"),
            ),
            Request::Reset => Err(invalid(
                "EMP drives have no reset command: stop, then initialise (i)",
            )),
            Request::JogRenew { .. }
            | Request::JogRelease { .. }
            | Request::Poll { .. }
            | Request::Shutdown
            | Request::Hold { .. }
            | Request::HoldEnd => Ok(None),
        };
        self.started(&queued.request, started);
    }

    /// jogterm's work zero: `20 05` would set the drive's counter, but it
    /// switches the controller off (manual "20 05": "Der Regler wird
    /// abgeschaltet") and the counter would no longer count from the
    /// reference point, so `SetZero` only records the position
    /// (docs/protocols.md, EMP).
    fn set_zero(&mut self, axes: AxisSet) -> Result<(), Refusal> {
        let position = self.cx.positions();
        let cx = &mut self.cx;
        record_work_zero(&mut cx.state.work_zero, cx.settings.axes, axes, position)
    }

    fn renew(&mut self, id: JogId, lease: Duration, now: Instant) {
        if let Some(Op::Motion(m)) = self.op.as_mut()
            && m.renew(&self.cx, id, lease, now)
        {
            return;
        }
        self.queue.renew(id, lease, now);
    }

    fn release(&mut self, id: JogId) {
        if let Some(Op::Motion(m)) = self.op.as_mut()
            && m.release(id)
        {
            self.collect_stops();
            return;
        }
        self.queue.release(id, &mut self.cx);
    }

    /// The stop frames for every drive, after `head`, as one message for
    /// the writer (each frame a message on the line).
    fn stop_frames(&self, head: Vec<u8>) -> Outgoing {
        let mut bytes = head;
        let mut ends = Vec::new();
        if !bytes.is_empty() {
            ends.push(bytes.len());
        }
        for ds in self.cx.addresses() {
            bytes.extend(self.cx.stop_request(ds).encode());
            ends.push(bytes.len());
        }
        Outgoing::messages(bytes, false, traffic::Owner::Stop, &ends)
    }
}

impl Family for EmpLine {
    type Context = Context;
    type Op = Op;
    type PollItem = PollItem;
    type Motion = MotionOp;

    fn readback(d: &EmpDriver) -> Op {
        Op::Readback(Readback::new(&d.cx))
    }

    fn connect_settle(cx: &Context) -> Duration {
        cx.settings.timing.connect_settle
    }

    /// The first frames on every connection stop every drive. A drive that
    /// is not switched on answers `EE` to it (a notice).
    fn connect(d: &mut EmpDriver, _now: Instant) {
        d.line.off_polls.reset();
        if d.connect_halt {
            let all = d.cx.addresses();
            d.stop_drives(&all);
        }
    }

    fn drop_line(d: &mut EmpDriver, _reason: &str) {
        let line = &mut d.line;
        line.correlator.clear();
        line.owners.clear();
        line.decoder.reset();
        line.unsent.clear();
        line.restop.clear();
        line.stops.clear();
        line.raw_stops.clear();
        line.errors.clear();
        line.side.clear();
        line.arriving_until = None;
        line.off_polls.reset();
        if let Some(mut op) = d.op.take() {
            op.get().link_lost(&mut d.cx);
        }
    }

    fn forget(d: &mut EmpDriver) {
        d.cx.forget();
        d.cx.state.activity = Activity::Idle;
    }

    fn transmit(d: &mut EmpDriver, now: Instant) -> Option<Outgoing> {
        d.transmit(now)
    }

    fn received(d: &mut EmpDriver, bytes: &[u8], now: Instant) -> Vec<MessageEnd> {
        if d.line.correlator.next_deadline().is_some() {
            let rest =
                d.cx.settings
                    .line
                    .transfer_time(crate::proto::emp::FRAME_WIRE_LEN)
                    + d.cx.settings.timing.reply_margin;
            d.line.arriving_until = Some(now + rest);
        }
        // A byte at a time, so that each frame's end is known (the decoder
        // gives the same frames for any split, `fuzz_emp`).
        let mut ends = Vec::new();
        for (i, byte) in bytes.iter().enumerate() {
            for result in d.line.decoder.feed(std::slice::from_ref(byte)) {
                let (owner, rejected) = match result {
                    Ok(incoming) => d.incoming(incoming, now),
                    Err(e) => {
                        if !d.quiet(now) {
                            d.cx.notice(format!("framing error on the line: {e}"));
                        }
                        (traffic::Owner::Controller, false)
                    }
                };
                ends.push(MessageEnd {
                    rejected,
                    ..MessageEnd::new(i + 1, owner)
                });
            }
        }
        ends
    }

    fn transmitted(d: &mut EmpDriver, now: Instant) {
        let frame = d.line.unsent.pop_front();
        if let Some(frame) = &frame {
            d.line.correlator.transmitted(frame, now);
        }
        if let Some(frame) = frame
            && let Some(i) = d.line.restop.iter().position(|f| *f == frame)
        {
            d.line.restop.remove(i);
            if d.link_up {
                d.stop_drives(&[frame.ds]);
            }
        }
    }

    fn stop(d: &mut EmpDriver, now: Instant) -> Outgoing {
        let all = d.cx.addresses();
        if d.link_up {
            d.cancel_waiting();
            d.line.side.clear();
            if let Some(op) = d.op.as_mut() {
                op.get().stopped(&mut d.cx, &all);
                let _ = op.get().take_stops();
            }
            // Frames handed out that may move and are not on the wire yet
            // go after the stop: stop their drives again once written.
            let line = &mut d.line;
            for f in &line.unsent {
                if f.command.may_move() && !line.restop.contains(f) {
                    line.restop.push(*f);
                }
            }
            for ds in &all {
                let frame = d.cx.stop_request(*ds);
                d.line.stops.retain(|f| *f != frame);
                d.register(frame, Owner::Stop, now);
            }
        }
        d.stop_frames(Vec::new())
    }

    /// The emergency handle writes from another thread, between any two
    /// bytes of a frame the writer has on its way; a stop frame glued to
    /// the cut frame's head would be dropped with it (`docs/protocols.md`,
    /// EMP framing) and the drive left running. An EOF first ends the cut
    /// frame (dropped as a short run; a lone EOF, when nothing was cut, is
    /// dropped too), so the stop frames are read as frames of their own.
    fn emergency_stop(d: &EmpDriver) -> Outgoing {
        d.stop_frames(vec![crate::proto::emp::EOF])
    }

    fn raw_may_move(line: &str) -> bool {
        raw::parse_raw(line).map_or(true, |r| r.command.may_move())
    }

    fn timeouts(d: &EmpDriver, consider: &mut dyn FnMut(Option<Instant>)) {
        let first_answer = d.line.correlator.next_deadline();
        consider(first_answer.map(|t| d.line.arriving_until.map_or(t, |a| t.max(a))));
        // What waits for the line to be free wakes the driver only then: a
        // due poll or watchdog read behind a first answer cannot be sent.
        if first_answer.is_none() {
            consider(d.poller.due());
            consider(d.op.as_ref().and_then(|o| o.peek().send_due()));
            consider(d.line.off_polls.wake());
        }
    }

    fn line_timeout(d: &mut EmpDriver, now: Instant, _quiet_over: bool) {
        if d.line.arriving_until.is_some_and(|a| now >= a) {
            d.line.arriving_until = None;
        }
        if d.link_up && d.line.arriving_until.is_none() {
            let timed_out = d.line.correlator.poll_timeouts(now);
            if let Some(first) = timed_out.into_iter().next() {
                d.matched(first, now);
            }
        }
    }

    fn op_timer(d: &mut EmpDriver, now: Instant) {
        if let Some(op) = d.op.as_mut() {
            op.get().on_timer(&mut d.cx, now);
        }
    }

    fn wire_limit_hz(d: &EmpDriver) -> f64 {
        wire_limit_hz(&d.poller, d.cx.settings.line, d.cx.drives.len())
    }

    /// Stops of drives an operation asked for.
    fn before_settle(d: &mut EmpDriver, _now: Instant) {
        d.collect_stops();
    }

    fn after_state(d: &mut EmpDriver) {
        d.cx.position_poll =
            poll::position_period(&d.poller, d.cx.settings.line, d.cx.drives.len());
        d.cx.refresh();
    }

    fn motion(op: &mut Op) -> Option<&mut MotionOp> {
        match op {
            Op::Motion(m) => Some(m.as_mut()),
            _ => None,
        }
    }

    fn renew_jog(d: &mut EmpDriver, id: JogId, lease: Duration, now: Instant) {
        d.renew(id, lease, now);
    }

    fn release_jog(d: &mut EmpDriver, id: JogId, _now: Instant) {
        d.release(id);
    }

    /// EMP drives have no reset command: admitted, and refused with what
    /// to do instead when its turn comes (`begin`).
    fn reset(d: &mut EmpDriver, now: Instant) {
        d.admit(Request::Reset, now);
    }

    fn raw_line(d: &mut EmpDriver, line: String, now: Instant) {
        d.raw(line, now);
    }
}
