//! Test benches for every driver, on synthetic time (nothing here reads a
//! clock except the one `Instant::now()` that anchors a time line):
//!
//! - [`Harness`]: a driver alone, byte conversations: what it sends, what
//!   it is answered, when time passes.
//! - [`Bench`]: a driver and a simulator model in memory, joined by a wire
//!   modelled at the line's baud rate in both directions (bytes from
//!   `poll_transmit` go to `SimDevice::on_byte`, bytes from `poll_output` to
//!   `received`).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::device::api::{
    Event, JogEnd, PerAxis, PositionSample, PositionSource, Refusal, Request,
};
use crate::device::driver::{Driver, Outgoing};
use crate::sim::{InputControl, SimDevice};
use crate::traffic::{MessageEnd, Owner, readable};
use crate::wire::LineSettings;

pub fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A driver alone on synthetic time.
pub struct Harness<D> {
    pub driver: D,
    pub now: Instant,
    pub events: Vec<Event>,
    /// Every message the driver handed out, in order.
    pub sent: Vec<Vec<u8>>,
    /// The same with whose they are and where their messages end.
    pub outgoing: Vec<Outgoing>,
    /// Where messages ended in the last bytes `reply` fed in.
    pub ends: Vec<MessageEnd>,
}

impl<D: Driver> Harness<D> {
    pub fn on(driver: D) -> Harness<D> {
        Harness {
            driver,
            now: Instant::now(),
            events: Vec::new(),
            sent: Vec::new(),
            outgoing: Vec::new(),
            ends: Vec::new(),
        }
    }

    pub fn collect(&mut self) {
        while let Some(e) = self.driver.poll_event() {
            self.events.push(e);
        }
    }

    /// Move the clock forward, handling every timeout on the way. A timeout
    /// that stays due after it was handled wants a message sent (a poll):
    /// the clock stops there, as the device task would send it.
    pub fn advance(&mut self, d: Duration) {
        let end = self.now + d;
        loop {
            match self.driver.next_timeout() {
                Some(t) if t <= end => {
                    self.now = self.now.max(t);
                    self.driver.handle_timeout(self.now);
                    self.collect();
                    if self.driver.next_timeout().is_some_and(|n| n <= self.now) {
                        return;
                    }
                }
                _ => break,
            }
        }
        self.now = end;
    }

    /// The next message, not yet reported written.
    pub fn take(&mut self) -> Option<Vec<u8>> {
        let out = self.driver.poll_transmit(self.now);
        self.collect();
        let bytes = out.as_ref().map(|o| o.bytes.clone());
        if let Some(out) = out {
            self.sent.push(out.bytes.clone());
            self.outgoing.push(out);
        }
        bytes
    }

    /// Whether a message starting with `prefix` was handed out.
    pub fn sent_any(&self, prefix: &[u8]) -> bool {
        self.sent.iter().any(|m| m.starts_with(prefix))
    }

    /// The writer reports the last message written.
    pub fn written(&mut self) {
        self.driver.transmitted(self.now);
        self.collect();
    }

    /// The next message, written at once.
    pub fn send(&mut self) -> Option<Vec<u8>> {
        let out = self.take();
        if out.is_some() {
            self.written();
        }
        out
    }

    #[track_caller]
    pub fn expect(&mut self, bytes: &[u8]) {
        let got = self.send();
        assert_eq!(
            got.as_deref().map(readable),
            Some(readable(bytes)),
            "expected the driver to send {}",
            readable(bytes)
        );
    }

    /// `text` and CR.
    #[track_caller]
    pub fn expect_text(&mut self, text: &str) {
        let mut bytes = text.as_bytes().to_vec();
        bytes.push(b'\r');
        self.expect(&bytes);
    }

    #[track_caller]
    pub fn expect_nothing(&mut self) {
        let got = self.take();
        assert_eq!(got.as_deref().map(readable), None, "expected silence");
    }

    pub fn reply(&mut self, bytes: &[u8]) {
        self.ends = self.driver.received(bytes, self.now);
        self.collect();
    }

    /// The owner of the last message handed out, and where its messages
    /// end.
    pub fn last_owner(&self) -> Option<(Owner, Vec<usize>)> {
        let out = self.outgoing.last()?;
        let owner = out.messages.first()?.owner;
        assert!(
            out.messages.iter().all(|m| m.owner == owner),
            "one owner per message handed out"
        );
        Some((owner, out.messages.iter().map(|m| m.end).collect()))
    }

    /// Where messages ended in the last reply, and whose they were.
    pub fn reply_ends(&self) -> Vec<(usize, Owner)> {
        self.ends.iter().map(|m| (m.end, m.owner)).collect()
    }

    pub fn request(&mut self, r: Request) {
        self.driver.request(r, self.now);
        self.collect();
    }

    pub fn stop(&mut self) -> Vec<u8> {
        let out = self.driver.stop(self.now);
        self.collect();
        out.bytes
    }

    pub fn take_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    pub fn refusals(&self) -> Vec<String> {
        refusals(&self.events)
    }

    pub fn faults(&self) -> Vec<String> {
        self.events
            .iter()
            .filter_map(|e| match e {
                Event::Fault(f) => Some(format!("{} {}", f.command, f.code)),
                _ => None,
            })
            .collect()
    }

    pub fn notices(&self) -> Vec<String> {
        self.events
            .iter()
            .filter_map(|e| match e {
                Event::Notice(n) => Some(n.clone()),
                _ => None,
            })
            .collect()
    }

    pub fn positions(&self) -> Vec<PositionSample> {
        positions(&self.events)
    }

    pub fn jog_ends(&self) -> Vec<(u64, JogEnd)> {
        jog_ends(&self.events)
    }

    pub fn replies(&self) -> Vec<(String, String)> {
        self.events
            .iter()
            .filter_map(|e| match e {
                Event::Reply { command, text, .. } => Some((command.clone(), text.clone())),
                _ => None,
            })
            .collect()
    }
}

pub fn refusals(events: &[Event]) -> Vec<String> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Refused { request, reason } => Some(format!("{request}: {reason}")),
            _ => None,
        })
        .collect()
}

pub fn refusal_reasons(events: &[Event]) -> Vec<Refusal> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Refused { reason, .. } => Some(reason.clone()),
            _ => None,
        })
        .collect()
}

pub fn positions(events: &[Event]) -> Vec<PositionSample> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Position(p) => Some(*p),
            _ => None,
        })
        .collect()
}

pub fn jog_ends(events: &[Event]) -> Vec<(u64, JogEnd)> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::JogEnded { id, end } => Some((id.0, end.clone())),
            _ => None,
        })
        .collect()
}

/// A driver and a simulator joined by a modelled wire.
pub struct Bench<D, S> {
    pub driver: D,
    pub sim: S,
    pub now: Instant,
    byte: Duration,
    /// Bytes on their way to the controller: when each has arrived, and
    /// whether it ends its message.
    to_sim: VecDeque<(Instant, u8, bool)>,
    /// When the writer reports a message written (its last byte starts).
    written_at: VecDeque<Instant>,
    to_driver: VecDeque<(Instant, u8)>,
    pub events: Vec<Event>,
    /// Every message the driver sent, in order.
    pub sent: Vec<Vec<u8>>,
}

impl<D: Driver, S: SimDevice> Bench<D, S> {
    /// Connected at once.
    pub fn new(driver: D, sim: S, line: LineSettings) -> Bench<D, S> {
        let now = Instant::now();
        let mut bench = Bench {
            driver,
            sim,
            now,
            byte: line.byte_time(),
            to_sim: VecDeque::new(),
            written_at: VecDeque::new(),
            to_driver: VecDeque::new(),
            events: Vec::new(),
            sent: Vec::new(),
        };
        bench.sim.advance(now);
        bench.driver.connected(now);
        bench
    }

    fn wire_free(last: Option<Instant>, now: Instant) -> Instant {
        last.map_or(now, |t| t.max(now))
    }

    fn to_sim_free(&self) -> Instant {
        Bench::<D, S>::wire_free(self.to_sim.back().map(|(t, _, _)| *t), self.now)
    }

    /// Queue a message for the controller after what is on its way.
    fn queue_to_sim(&mut self, bytes: Vec<u8>) -> Instant {
        let mut at = self.to_sim_free();
        let n = bytes.len();
        for (i, b) in bytes.into_iter().enumerate() {
            at += self.byte;
            self.to_sim.push_back((at, b, i + 1 == n));
        }
        at
    }

    /// Hand whatever the driver and the controller want to send to the wire.
    pub fn pump(&mut self) {
        while let Some(out) = self.driver.poll_transmit(self.now) {
            self.sent.push(out.bytes.clone());
            let at = self.queue_to_sim(out.bytes);
            self.written_at.push_back(at - self.byte);
        }
        while let Some(msg) = self.sim.poll_output() {
            let last = self.to_driver.back().map(|(t, _)| *t);
            let mut at = Bench::<D, S>::wire_free(last, self.now);
            for b in msg {
                at += self.byte;
                self.to_driver.push_back((at, b));
            }
        }
        while let Some(e) = self.driver.poll_event() {
            self.events.push(e);
        }
    }

    /// The stop lane: the stop bytes go right after the byte on the wire
    /// (`interruptible`, isel) or after the message on the wire (a line or
    /// frame is never cut), ahead of everything else queued.
    pub fn stop(&mut self) {
        let out = self.driver.stop(self.now);
        self.sent.push(out.bytes.clone());
        let mut started = self
            .to_sim
            .iter()
            .take_while(|(t, _, _)| *t - self.byte <= self.now)
            .count();
        if !out.interruptible {
            while started > 0
                && started < self.to_sim.len()
                && !self
                    .to_sim
                    .get(started - 1)
                    .is_some_and(|(_, _, last)| *last)
            {
                started += 1;
            }
        }
        let rest: Vec<(u8, bool)> = self
            .to_sim
            .drain(started..)
            .map(|(_, b, last)| (b, last))
            .collect();
        self.queue_to_sim(out.bytes);
        let mut at = self.to_sim_free();
        for (b, last) in rest {
            at += self.byte;
            self.to_sim.push_back((at, b, last));
        }
        self.pump();
    }

    pub fn request(&mut self, r: Request) {
        self.driver.request(r, self.now);
        self.pump();
    }

    pub fn control(&mut self, control: InputControl) {
        self.sim.control(&control, self.now).expect("input");
        self.pump();
    }

    /// Run the wire, the controller and the driver until `d` has passed.
    pub fn run(&mut self, d: Duration) {
        let end = self.now + d;
        loop {
            self.pump();
            let next = [
                self.to_sim.front().map(|(t, _, _)| *t),
                self.to_driver.front().map(|(t, _)| *t),
                self.written_at.front().copied(),
                self.sim.next_deadline(),
                self.driver.next_timeout(),
            ]
            .into_iter()
            .flatten()
            .min();
            let Some(t) = next.filter(|t| *t <= end) else {
                break;
            };
            self.now = self.now.max(t);
            while self.to_sim.front().is_some_and(|(t, _, _)| *t <= self.now) {
                if let Some((t, b, _)) = self.to_sim.pop_front() {
                    self.sim.on_byte(b, t);
                }
            }
            while self.written_at.front().is_some_and(|t| *t <= self.now) {
                self.written_at.pop_front();
                self.driver.transmitted(self.now);
            }
            self.sim.advance(self.now);
            while self.to_driver.front().is_some_and(|(t, _)| *t <= self.now) {
                if let Some((t, b)) = self.to_driver.pop_front() {
                    self.driver.received(&[b], t);
                }
            }
            if self.driver.next_timeout().is_some_and(|t| t <= self.now) {
                self.driver.handle_timeout(self.now);
            }
        }
        self.now = end;
        self.sim.advance(end);
        self.pump();
    }

    /// Run until `done` holds for the events so far, at most `within`.
    pub fn run_until(&mut self, within: Duration, done: impl Fn(&[Event]) -> bool) -> bool {
        let end = self.now + within;
        while self.now < end {
            self.run(ms(5));
            if done(&self.events) {
                return true;
            }
        }
        false
    }

    /// Hold jog `id` as a terminal does: its first repeat `first` after
    /// now, then one every 33 ms until `until`, each renewing for `lease`;
    /// the simulated position `x` read every millisecond meanwhile.
    pub fn hold_trace(
        &mut self,
        id: crate::device::api::JogId,
        lease: Duration,
        first: Duration,
        until: Duration,
        x: impl Fn(&mut S, Instant) -> f64,
    ) -> Vec<(Instant, f64)> {
        let start = self.now;
        let mut next = start + first;
        let mut trace = Vec::new();
        while self.now < start + until {
            if self.now >= next {
                self.request(Request::JogRenew { id, lease });
                next += ms(33);
            }
            self.run(ms(1));
            let now = self.now;
            trace.push((now, x(&mut self.sim, now)));
        }
        trace
    }

    pub fn last_measured(&self) -> Option<PerAxis<i64>> {
        self.events.iter().rev().find_map(|e| match e {
            Event::Position(p) if p.source == PositionSource::Measured => Some(p.steps),
            _ => None,
        })
    }

    /// What the driver sent, readable.
    pub fn sent_text(&self) -> Vec<String> {
        self.sent.iter().map(|b| readable(b)).collect()
    }
}
