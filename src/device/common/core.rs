//! The driver core: what every controller family's driver does the same
//! way, written once. A family ([`Family`]) brings its context, its
//! operations, its poll items and its line discipline (how a command goes
//! out and its answer comes back: isel one command at a time, EMCU
//! acknowledged lines with runs that end on their own, EMP frames matched
//! by a correlator); the core owns the rest:
//! - the connection: what a new link and a lost one do around the family's
//!   own steps (the stop sequence, read-back first, every waiting request
//!   refused, the operation abandoned);
//! - request dispatch ([`route`]): polls, leases, resets, raw lines, and
//!   admission (run, queue, coalesce, refuse) with the machine state;
//! - supervision: the quiet after a connect, an operation's timer, poll
//!   statistics, the state published when it changes;
//! - the [`Driver`] the device task talks to.
//!
//! `docs/architecture.md`, "Adding a controller family", lists what a new
//! family writes.

use std::collections::VecDeque;
use std::fmt::Debug;
use std::time::{Duration, Instant};

use crate::device::api::{Activity, Event, JogEnd, JogId, MachineState, Refusal, Request};
use crate::device::driver::{Driver, Outgoing};
use crate::traffic::MessageEnd;

use super::admit::{RunningMove, admit};
use super::route::{Requests, route};
use super::sink::{Sink, refuse};
use super::{PollRate, Poller, RequestQueue, StateReport};

/// A family's driver state that the core reads: the machine state it
/// publishes and the events it hands out.
pub trait FamilyContext: Sink + Send + Debug {
    fn state(&self) -> &MachineState;
    fn state_mut(&mut self) -> &mut MachineState;
    /// The state and the event queue together, to publish the one into
    /// the other.
    fn state_and_events(&mut self) -> (&MachineState, &mut VecDeque<Event>);
    fn next_event(&mut self) -> Option<Event>;
}

/// The operation a driver runs: when it wants to be woken, and what the
/// machine is doing meanwhile (`operations!` implements it for a family's
/// enum of operations).
pub trait Running {
    fn timer(&self) -> Option<Instant>;
    fn activity(&self) -> Activity;
}

/// What a controller family does its own way. `Self` is the family's line
/// state (the exchange on the wire, the decoder, what is handed out and not
/// yet written); every hook gets the whole driver.
pub trait Family: Sized + Send + Debug {
    type Context: FamilyContext;
    type Op: Running + Send + Debug;
    type PollItem: Copy + Send + Debug;
    /// A running move that takes a step pressed while it runs.
    type Motion: RunningMove<Cx = Self::Context>;

    /// The operation that reads the controller's state back on a new link.
    fn readback(d: &Core<Self>) -> Self::Op;
    /// How long the line stays quiet after a connect: answers to what was
    /// in flight before, and to the stop sequence, fall into it.
    fn connect_settle(cx: &Self::Context) -> Duration;
    /// The family's part of a new link, after the core has marked it up:
    /// the stop sequence (when `connect_halt`), what is known no longer.
    fn connect(d: &mut Core<Self>, now: Instant);
    /// The link is gone: the line state dropped, the operation abandoned.
    /// Then the core refuses every waiting request.
    fn drop_line(d: &mut Core<Self>, reason: &str);
    /// After the waiting requests were refused: what is unknown until read
    /// back.
    fn forget(d: &mut Core<Self>);

    /// The next message, if the line discipline allows one now.
    fn transmit(d: &mut Core<Self>, now: Instant) -> Option<Outgoing>;
    /// Bytes from the port (the link is up); where messages ended in them.
    fn received(d: &mut Core<Self>, bytes: &[u8], now: Instant) -> Vec<MessageEnd>;
    /// Bytes that came while the link was down.
    fn received_while_down(_bytes: &[u8]) -> Vec<MessageEnd> {
        Vec::new()
    }
    fn transmitted(d: &mut Core<Self>, now: Instant);
    /// Stop everything now: the bytes that go ahead of all, and the family's
    /// bookkeeping (waiting requests cancelled, the operation braking).
    fn stop(d: &mut Core<Self>, now: Instant) -> Outgoing;
    fn emergency_stop(d: &Core<Self>) -> Outgoing;
    /// Whether a typed line may set an axis in motion; a line that does not
    /// parse counts as motion (the safe side).
    fn raw_may_move(line: &str) -> bool;

    /// The family's own wake-up times (reply deadlines, repeats, polls).
    fn timeouts(d: &Core<Self>, consider: &mut dyn FnMut(Option<Instant>));
    /// The family's own timeouts at `now`; `quiet_over`: the quiet after a
    /// connect or a reset has just ended.
    fn line_timeout(d: &mut Core<Self>, now: Instant, quiet_over: bool);
    /// The operation's timer has run out.
    fn op_timer(d: &mut Core<Self>, now: Instant);
    /// The rate the line allows polls at, for the statistics.
    fn wire_limit_hz(d: &Core<Self>) -> f64;
    /// After a timeout was handled, before the state is settled.
    fn timeout_done(_d: &mut Core<Self>, _now: Instant) {}

    /// Before the state is settled: what an operation asked for (a halt,
    /// stops of drives).
    fn before_settle(_d: &mut Core<Self>, _now: Instant) {}
    /// After the activity and the link are set, before the state is
    /// published.
    fn after_state(_d: &mut Core<Self>) {}
    /// A program is being stored line by line: the controller takes nothing
    /// else, and the typed lines are the program's.
    fn storing(_cx: &Self::Context) -> bool {
        false
    }
    /// The running operation as a move that takes a coalesced step.
    fn motion(op: &mut Self::Op) -> Option<&mut Self::Motion>;

    fn renew_jog(d: &mut Core<Self>, id: JogId, lease: Duration, now: Instant);
    fn release_jog(d: &mut Core<Self>, id: JogId, now: Instant);
    fn reset(d: &mut Core<Self>, now: Instant);
    fn raw_line(d: &mut Core<Self>, line: String, now: Instant);
    fn set_reads_only(_d: &mut Core<Self>, _on: bool) {}
}

/// A controller family's driver: the core's state and the family's.
#[derive(Debug)]
pub struct Core<F: Family> {
    pub(in crate::device) cx: F::Context,
    /// The family's line state.
    pub(in crate::device) line: F,
    pub(in crate::device) link_up: bool,
    pub(in crate::device) op: Option<F::Op>,
    pub(in crate::device) queue: RequestQueue,
    pub(in crate::device) poller: Poller<F::PollItem>,
    pub(in crate::device) quiet_until: Option<Instant>,
    /// Off for a session that was not asked to move: its connect stops
    /// nothing (`docs/device.md`, "Sessions that do not move").
    pub(in crate::device) connect_halt: bool,
    report: StateReport,
}

impl<F: Family> Core<F> {
    pub(in crate::device) fn with(
        cx: F::Context,
        line: F,
        poller: Poller<F::PollItem>,
        step_queue: usize,
    ) -> Core<F> {
        Core {
            cx,
            line,
            link_up: false,
            op: None,
            queue: RequestQueue::new(step_queue),
            poller,
            quiet_until: None,
            connect_halt: true,
            report: StateReport::default(),
        }
    }

    /// The machine state as the driver sees it now.
    pub fn state(&self) -> &MachineState {
        self.cx.state()
    }

    pub(in crate::device) fn quiet(&self, now: Instant) -> bool {
        self.quiet_until.is_some_and(|q| now < q)
    }

    /// What runs that refuses other requests.
    pub(in crate::device) fn busy(&self) -> Option<Activity> {
        if F::storing(&self.cx) {
            return Some(Activity::Uploading);
        }
        let activity = self.op.as_ref().map(Running::activity)?;
        (activity != Activity::Idle).then_some(activity)
    }

    /// A request that runs on the machine: checked, then run, queued,
    /// coalesced or refused (`admit`).
    pub(in crate::device) fn admit(&mut self, request: Request, now: Instant) {
        if !self.link_up {
            refuse(&mut self.cx, &request, Refusal::NotConnected);
            return;
        }
        // While a program is being stored line by line, typed lines are the
        // program's: they are not refused as busy.
        let storing_line = F::storing(&self.cx) && matches!(request, Request::Raw { .. });
        let busy = self.busy().filter(|_| !storing_line);
        let motion = self.op.as_mut().and_then(F::motion);
        admit(&mut self.queue, request, now, busy, motion, &mut self.cx);
    }

    /// `begin`'s end for every family: the operation that starts, or the
    /// request refused with the reason.
    pub(in crate::device) fn started(
        &mut self,
        request: &Request,
        started: Result<Option<F::Op>, Refusal>,
    ) {
        match started {
            Ok(Some(op)) => self.op = Some(op),
            Ok(None) => {}
            Err(reason) => refuse(&mut self.cx, request, reason),
        }
    }

    /// Every waiting request cancelled by a stop.
    pub(in crate::device) fn cancel_waiting(&mut self) {
        self.queue.refuse_all(
            || Refusal::Invalid {
                reason: "cancelled by stop".into(),
            },
            JogEnd::Stopped,
            &mut self.cx,
        );
    }

    pub(in crate::device) fn go_down(&mut self, reason: &str) {
        if !self.link_up {
            return;
        }
        self.link_up = false;
        self.quiet_until = None;
        F::drop_line(self, reason);
        self.queue
            .refuse_all(|| Refusal::NotConnected, JogEnd::LinkLost, &mut self.cx);
        F::forget(self);
    }

    /// Bring the state up to date and tell the clients when it changed.
    pub(in crate::device) fn settle(&mut self, now: Instant) {
        F::before_settle(self, now);
        let activity = self.op.as_ref().map_or(Activity::Idle, Running::activity);
        let storing = F::storing(&self.cx);
        let link_up = self.link_up;
        let state = self.cx.state_mut();
        state.activity = if storing && activity == Activity::Idle {
            Activity::Uploading
        } else {
            activity
        };
        state.link_up = link_up;
        F::after_state(self);
        let (state, events) = self.cx.state_and_events();
        self.report.publish(state, events);
    }

    fn emit_stats(&mut self, now: Instant) {
        if self.poller.stats_due().is_some_and(|t| now >= t) {
            let limit = F::wire_limit_hz(self);
            if let Some(stats) = self.poller.take_stats(now, limit) {
                self.cx.emit(Event::Stats(stats));
            }
        }
    }
}

impl<F: Family> Requests for Core<F> {
    fn set_poll(&mut self, rate: PollRate, ports_every: u32) {
        self.poller.set_rate(rate, ports_every);
    }

    fn renew_jog(&mut self, id: JogId, lease: Duration, now: Instant) {
        F::renew_jog(self, id, lease, now);
    }

    fn release_jog(&mut self, id: JogId, now: Instant) {
        F::release_jog(self, id, now);
    }

    fn reset(&mut self, now: Instant) {
        F::reset(self, now);
    }

    fn raw_line(&mut self, line: String, now: Instant) {
        F::raw_line(self, line, now);
    }

    fn admit_request(&mut self, request: Request, now: Instant) {
        self.admit(request, now);
    }

    fn after_request(&mut self, now: Instant) {
        self.settle(now);
    }
}

impl<F: Family> Driver for Core<F> {
    /// Every connection opens with the family's stop sequence (unless the
    /// session was not asked to move): whatever the controller was doing
    /// must not go on while its state is unknown. Its answers fall into the
    /// quiet that follows; then the state is read back, before anything
    /// else.
    fn connected(&mut self, now: Instant) {
        self.go_down("reconnected");
        self.link_up = true;
        self.poller.reset();
        F::connect(self, now);
        self.quiet_until = Some(now + F::connect_settle(&self.cx));
        self.op = Some(F::readback(self));
        self.settle(now);
    }

    fn set_connect_halt(&mut self, on: bool) {
        self.connect_halt = on;
    }

    fn set_reads_only(&mut self, on: bool) {
        F::set_reads_only(self, on);
    }

    fn may_move(&self, request: &Request) -> bool {
        match request {
            Request::Raw { line } => F::raw_may_move(line),
            other => other.may_move(),
        }
    }

    fn disconnected(&mut self, reason: &str, now: Instant) {
        self.go_down(reason);
        self.settle(now);
    }

    fn request(&mut self, request: Request, now: Instant) {
        route(self, request, now);
    }

    fn stop(&mut self, now: Instant) -> Outgoing {
        let out = F::stop(self, now);
        self.settle(now);
        out
    }

    fn emergency_stop(&self) -> Outgoing {
        F::emergency_stop(self)
    }

    fn received(&mut self, bytes: &[u8], now: Instant) -> Vec<MessageEnd> {
        if !self.link_up || bytes.is_empty() {
            return F::received_while_down(bytes);
        }
        let ends = F::received(self, bytes, now);
        self.settle(now);
        ends
    }

    fn transmitted(&mut self, now: Instant) {
        F::transmitted(self, now);
        self.settle(now);
    }

    fn poll_transmit(&mut self, now: Instant) -> Option<Outgoing> {
        let out = F::transmit(self, now);
        self.settle(now);
        out
    }

    fn poll_event(&mut self) -> Option<Event> {
        self.cx.next_event()
    }

    fn next_timeout(&self) -> Option<Instant> {
        let mut at: Option<Instant> = None;
        let mut consider = |t: Option<Instant>| {
            if let Some(t) = t {
                at = Some(at.map_or(t, |a| a.min(t)));
            }
        };
        consider(self.quiet_until);
        consider(self.poller.stats_due());
        consider(self.op.as_ref().and_then(Running::timer));
        F::timeouts(self, &mut consider);
        at
    }

    fn handle_timeout(&mut self, now: Instant) {
        let quiet_over = self.quiet_until.is_some_and(|q| now >= q);
        if quiet_over {
            self.quiet_until = None;
        }
        F::line_timeout(self, now, quiet_over);
        if self
            .op
            .as_ref()
            .and_then(Running::timer)
            .is_some_and(|t| t <= now)
        {
            F::op_timer(self, now);
        }
        self.emit_stats(now);
        F::timeout_done(self, now);
        self.settle(now);
    }
}

/// `Sink` and [`FamilyContext`] for a family's context whose machine state
/// is its field `state` and whose events wait in its field `events`.
macro_rules! family_context {
    ($context:ty) => {
        impl $crate::device::common::sink::Sink for $context {
            fn emit(&mut self, event: $crate::device::api::Event) {
                self.events.push_back(event);
            }
        }

        impl $crate::device::common::core::FamilyContext for $context {
            fn state(&self) -> &$crate::device::api::MachineState {
                &self.state
            }

            fn state_mut(&mut self) -> &mut $crate::device::api::MachineState {
                &mut self.state
            }

            fn state_and_events(
                &mut self,
            ) -> (
                &$crate::device::api::MachineState,
                &mut std::collections::VecDeque<$crate::device::api::Event>,
            ) {
                (&self.state, &mut self.events)
            }

            fn next_event(&mut self) -> Option<$crate::device::api::Event> {
                self.events.pop_front()
            }
        }
    };
}

pub(crate) use family_context;
