//! A console on a synthetic clock: sends a line one byte time per byte at
//! 19200 baud, lets time pass deadline by deadline, and collects what the
//! interface says, with when. Replies are read with the protocol core's
//! decoder, so a reply the core would not understand fails the test.

use std::time::{Duration, Instant};

use crate::proto::emcu::{EmcuAxis, Reply, ReplyDecoder, ReplyEvent, Status};
use crate::sim::SimDevice;
use crate::sim::emcu::{EmcuSim, EmcuSimConfig};
use crate::traffic::readable;

pub fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

pub struct Conversation {
    pub sim: EmcuSim,
    pub t0: Instant,
    pub now: Instant,
    byte_time: Duration,
    /// Every line the interface sent and when (since `t0`).
    pub log: Vec<(Duration, Vec<u8>)>,
    /// Lines not yet handed out by `send`, `wait` or `wait_for`. A query's
    /// answer is taken out by the query; a 0x02 CR that came meanwhile stays.
    pending: Vec<(Duration, Vec<u8>)>,
}

impl Conversation {
    pub fn new() -> Conversation {
        Conversation::with(EmcuSimConfig::default())
    }

    pub fn with(config: EmcuSimConfig) -> Conversation {
        let sim = EmcuSim::new(config);
        let t0 = Instant::now();
        let byte_time = sim.line().byte_time();
        Conversation {
            sim,
            t0,
            now: t0,
            byte_time,
            log: Vec::new(),
            pending: Vec::new(),
        }
    }

    /// A machine whose carriages stand 100 steps above their reference
    /// switches, after `$HXYZ` has run: counters 0, position known.
    pub fn referenced() -> Conversation {
        let mut config = EmcuSimConfig::default();
        for axis in &mut config.axes {
            axis.start = 100;
        }
        let mut c = Conversation::with(config);
        assert_eq!(c.send("$HXYZ\x01"), "<CR>");
        assert!(c.wait_for(b"\x02\r", Duration::from_secs(10)).is_some());
        assert_eq!(c.flags(), "000000");
        c
    }

    /// Time since the start.
    pub fn elapsed(&self) -> Duration {
        self.now - self.t0
    }

    fn collect(&mut self) {
        while let Some(message) = self.sim.poll_output() {
            let entry = (self.now - self.t0, message);
            self.log.push(entry.clone());
            self.pending.push(entry);
        }
    }

    /// Output not yet handed out.
    fn take_new(&mut self) -> Vec<u8> {
        self.pending
            .drain(..)
            .flat_map(|(_, m)| m.into_iter())
            .collect()
    }

    /// Lets time pass up to `until`, stopping at every deadline on the way.
    fn run_to(&mut self, until: Instant) {
        let mut guard = 0;
        while let Some(due) = self.sim.next_deadline() {
            if due > until {
                break;
            }
            guard += 1;
            assert!(guard < 1_000_000, "deadlines do not move on");
            self.now = self.now.max(due);
            self.sim.advance(self.now);
            self.collect();
        }
        self.now = self.now.max(until);
        self.sim.advance(self.now);
        self.collect();
    }

    /// Sends the bytes as given (terminator included), one byte time apart,
    /// and returns what the interface said meanwhile.
    pub fn send(&mut self, bytes: &str) -> String {
        readable(&self.send_bytes(bytes.as_bytes()))
    }

    pub fn send_bytes(&mut self, bytes: &[u8]) -> Vec<u8> {
        self.feed(bytes);
        self.take_new()
    }

    fn feed(&mut self, bytes: &[u8]) {
        for b in bytes {
            let at = self.now + self.byte_time;
            self.run_to(at);
            self.sim.on_byte(*b, self.now);
            self.collect();
        }
    }

    /// Lets `d` pass and returns what the interface said meanwhile.
    pub fn wait(&mut self, d: Duration) -> String {
        let until = self.now + d;
        self.run_to(until);
        readable(&self.take_new())
    }

    /// Lets time pass until the interface sends `line` (or has sent it
    /// unseen); when (since `t0`). Lines before it are dropped.
    pub fn wait_for(&mut self, line: &[u8], limit: Duration) -> Option<Duration> {
        let until = self.now + limit;
        loop {
            if let Some(i) = self.pending.iter().position(|(_, m)| m == line) {
                return self.pending.drain(..=i).next_back().map(|(t, _)| t);
            }
            if self.now >= until {
                return None;
            }
            let next = self.sim.next_deadline().map_or(until, |d| d.min(until));
            self.run_to(next.max(self.now));
        }
    }

    /// The one reply of a query, decoded by the core.
    fn query(&mut self, line: &str) -> Reply {
        let before = self.pending.len();
        self.feed(line.as_bytes());
        let mut answers = Vec::new();
        let mut i = before;
        while let Some((_, message)) = self.pending.get(i) {
            let reply = match ReplyDecoder::new().feed(message).as_slice() {
                [ReplyEvent::Reply(reply)] => reply.clone(),
                other => panic!("`{}` is no reply: {other:?}", readable(message)),
            };
            if reply.is_unsolicited() {
                i += 1;
            } else {
                answers.push(reply);
                self.pending.remove(i);
            }
        }
        match answers.as_slice() {
            [reply] => reply.clone(),
            other => panic!("`{line}` answered {other:?}"),
        }
    }

    /// `@L<axis>`.
    pub fn position(&mut self, axis: EmcuAxis) -> i32 {
        let letter = char::from(axis.upper());
        match self.query(&format!("@L{letter}\r")) {
            Reply::Position { axis: a, steps } if a == axis => steps,
            other => panic!("@L{letter} answered {other:?}"),
        }
    }

    /// `@X`.
    pub fn status(&mut self) -> Status {
        match self.query("@X\r") {
            Reply::Status(s) => s,
            other => panic!("@X answered {other:?}"),
        }
    }

    /// `@X` as its six digits.
    pub fn flags(&mut self) -> String {
        String::from_utf8_lossy(&self.status().digits()).into_owned()
    }

    /// Polls `@L<axis>` until the machine is at rest; the positions seen.
    pub fn trace(&mut self, axis: EmcuAxis, every: Duration, limit: Duration) -> Vec<i32> {
        let until = self.now + limit;
        let mut seen = vec![self.position(axis)];
        while self.status().moving {
            assert!(self.now < until, "still moving after {limit:?}");
            self.wait(every);
            seen.push(self.position(axis));
        }
        seen
    }

    /// When the interface sent `line`, over the whole conversation.
    pub fn times_of(&self, line: &[u8]) -> Vec<Duration> {
        self.log
            .iter()
            .filter(|(_, m)| m == line)
            .map(|(t, _)| *t)
            .collect()
    }
}
