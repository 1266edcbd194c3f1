//! A host on the other end of the line, for conversation-style tests: it puts
//! a request on the wire one byte time per byte (38400 baud 8N1), runs the
//! model through its deadlines with synthetic time, and takes the messages it
//! produces together with the moment they were produced. A reply reaches the
//! host 17 byte times after it was produced, as the shell would send it.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use super::super::{DriveSnapshot, EmpSim, EmpSimConfig};
use crate::config::{ConfigDirs, load_profile};
use crate::proto::emp::{self, DriveAddress, EOF, FRAME_WIRE_LEN, Frame, Position};
use crate::sim::{InputControl, SimDevice};
use crate::traffic::readable;

/// The longest a test waits for a message unless it says otherwise.
pub const PATIENCE: Duration = Duration::from_secs(600);

pub fn ms(v: f64) -> Duration {
    Duration::from_secs_f64(v / 1000.0)
}

pub fn secs(v: f64) -> Duration {
    Duration::from_secs_f64(v)
}

/// One message as the model produced it.
#[derive(Debug, Clone)]
pub struct Message {
    /// The 16 characters before the EOF.
    pub text: String,
    /// When the model produced it (the shell starts sending it then).
    pub at: Instant,
}

pub struct Conversation {
    pub sim: EmpSim,
    pub t0: Instant,
    /// The host's time: after the last byte it sent or received.
    pub now: Instant,
    inbox: VecDeque<Message>,
}

impl Conversation {
    pub fn new(config: EmpSimConfig) -> Conversation {
        let sim = EmpSim::new(config).expect("valid test configuration");
        Conversation::with(sim)
    }

    pub fn with(sim: EmpSim) -> Conversation {
        let t0 = Instant::now();
        Conversation {
            sim,
            t0,
            now: t0,
            inbox: VecDeque::new(),
        }
    }

    /// The machine of the shipped `emp` profile: one drive `11`, 11200
    /// counts/mm, soft limits 0-500 mm, switches 2 mm beyond, at 40 mm.
    pub fn emp_profile() -> Conversation {
        let profile = load_profile("emp", &ConfigDirs::builtin_only()).unwrap();
        Conversation::with(EmpSim::from_profile(&profile).unwrap())
    }

    pub fn byte_time() -> Duration {
        emp::LINE.byte_time()
    }

    /// Time since the start of the test.
    pub fn elapsed(&self, t: Instant) -> Duration {
        t - self.t0
    }

    /// Bring the model to `t`, keeping what it produces.
    pub fn run_until(&mut self, t: Instant) {
        while let Some(d) = self.sim.next_deadline().filter(|d| *d <= t) {
            self.sim.advance(d);
            self.collect(d);
        }
        self.sim.advance(t);
        self.collect(t);
    }

    fn collect(&mut self, at: Instant) {
        while let Some(bytes) = self.sim.poll_output() {
            assert_eq!(bytes.len(), FRAME_WIRE_LEN, "{}", readable(&bytes));
            assert_eq!(bytes.last(), Some(&EOF), "{}", readable(&bytes));
            let text = String::from_utf8(bytes[..16].to_vec()).expect("ASCII");
            self.inbox.push_back(Message { text, at });
        }
    }

    /// The host waits.
    pub fn wait(&mut self, d: Duration) {
        self.now += d;
        self.run_until(self.now);
    }

    /// Send raw bytes, one byte time apart from `now`; returns when the
    /// last one arrived.
    pub fn send_bytes(&mut self, bytes: &[u8]) -> Instant {
        for &b in bytes {
            self.now += Self::byte_time();
            self.run_until(self.now);
            self.sim.on_byte(b, self.now);
        }
        self.now
    }

    /// Send a frame given as 16 hex characters (spaces allowed); returns when
    /// its EOF arrived.
    pub fn send(&mut self, hex: &str) -> Instant {
        let frame: Frame = hex.parse().expect("test frame");
        self.send_bytes(&frame.encode())
    }

    /// The next message, produced within `limit` from now.
    pub fn next_within(&mut self, limit: Duration) -> Option<Message> {
        let end = self.now + limit;
        while self.inbox.is_empty() {
            match self.sim.next_deadline().filter(|d| *d <= end) {
                Some(d) => {
                    self.sim.advance(d);
                    self.collect(d);
                }
                None => {
                    self.run_until(end);
                    break;
                }
            }
        }
        let m = self.inbox.pop_front()?;
        // The host has it once its 17 bytes crossed the line.
        let received = m.at + emp::LINE.transfer_time(FRAME_WIRE_LEN);
        self.now = self.now.max(received);
        Some(m)
    }

    #[track_caller]
    pub fn next(&mut self) -> Message {
        match self.next_within(PATIENCE) {
            Some(m) => m,
            None => panic!(
                "no message within {PATIENCE:?}; state: {}",
                self.sim.describe(self.now)
            ),
        }
    }

    /// Expect the next message; returns when it was produced.
    #[track_caller]
    pub fn expect(&mut self, expected: &str) -> Instant {
        let m = self.next();
        assert_eq!(
            m.text,
            expected.replace(' ', ""),
            "at {:?}; state: {}",
            self.elapsed(m.at),
            self.sim.describe(m.at)
        );
        m.at
    }

    /// Send a request and expect its reply.
    #[track_caller]
    pub fn exchange(&mut self, request: &str, reply: &str) -> Instant {
        self.send(request);
        self.expect(reply)
    }

    /// Nothing is produced for `d`.
    #[track_caller]
    pub fn silence(&mut self, d: Duration) {
        if let Some(m) = self.next_within(d) {
            panic!(
                "expected silence, got {} at {:?}",
                m.text,
                self.elapsed(m.at)
            );
        }
    }

    /// `2C` to `ds`: the position counter.
    #[track_caller]
    pub fn position_of(&mut self, ds: u8) -> i32 {
        self.send(&format!("2C{ds:02X}000000000000"));
        let m = self.next();
        let frame: Frame = m.text.parse().unwrap();
        assert_eq!(
            (frame.cmd, frame.ds, frame.info),
            (0x2D, ds, 0x22),
            "{}",
            m.text
        );
        Position::from_bytes(frame.data).unwrap().increments()
    }

    #[track_caller]
    pub fn position(&mut self) -> i32 {
        self.position_of(0x11)
    }

    /// `0A` to drive 11: the last error code.
    #[track_caller]
    pub fn last_error(&mut self) -> u8 {
        self.send("0A11000000000000");
        let frame: Frame = self.next().text.parse().unwrap();
        assert_eq!((frame.cmd, frame.info), (0x0B, 0x22));
        frame.d0()
    }

    pub fn snapshot_of(&self, ds: u8) -> DriveSnapshot {
        let ds = DriveAddress::from_byte(ds).unwrap();
        self.sim.snapshot(ds, self.now).unwrap()
    }

    pub fn snapshot(&self) -> DriveSnapshot {
        self.snapshot_of(0x11)
    }

    pub fn set(&mut self, name: &str, level: bool) -> Result<(), String> {
        let c = InputControl::Set {
            name: name.into(),
            level,
        };
        self.sim.control(&c, self.now)
    }

    pub fn press(&mut self, name: &str) -> Result<(), String> {
        let c = InputControl::Press { name: name.into() };
        self.sim.control(&c, self.now)
    }

    /// An analogue input to a value (`value <name> <number>`).
    pub fn value(&mut self, name: &str, value: f64) -> Result<(), String> {
        let c = InputControl::Value {
            name: name.into(),
            value,
        };
        self.sim.control(&c, self.now)
    }

    /// `02 11 11` and its answer.
    #[track_caller]
    pub fn switch_on(&mut self) {
        self.exchange("0211110000000000", "0311002200000000");
    }
}

/// A 25-bit position as the 8 hex digits of D3..D0.
pub fn pos_hex(p: i64) -> String {
    format!("{:08X}", Position::new(p).unwrap().to_word())
}
