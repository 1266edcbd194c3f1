//! Conversation tests of the isel simulator with synthetic time: the
//! harness feeds a command's bytes one byte time apart (19200 baud, as the
//! shell would), runs the model's deadlines in order and collects what it
//! answers, so a test reads "send `@0P`, expect `0000100…`".

mod faults;
mod init;
mod motion;
mod ports;
mod probe;
mod program;
mod properties;
mod reference;
mod stops;
mod texts;
mod variants;

use std::time::{Duration, Instant};

use crate::config::{ConfigDirs, load_profile};
use crate::sim::isel::{IselSim, IselSimConfig};
use crate::sim::{InputControl, SimDevice};

/// Physical start of every axis on the default profile: 40 mm at 400 steps/mm.
pub const START: f64 = 16_000.0;

/// The simulated machine of the shipped default profile (X 0-300 mm,
/// Y 0-200 mm, Z 0-80 mm, 400 steps/mm, switches 2 mm beyond).
pub fn default_config() -> IselSimConfig {
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("default profile");
    IselSimConfig::from_profile(&profile).expect("config")
}

/// A conversation with a simulator.
pub struct Conv {
    pub sim: IselSim,
    pub t0: Instant,
    pub now: Instant,
    byte: Duration,
    /// Messages in the order produced, with the time they were produced.
    pub out: Vec<(Instant, Vec<u8>)>,
    /// When the last byte of the last line sent arrived.
    pub sent_at: Instant,
}

impl Conv {
    pub fn new() -> Conv {
        Conv::with(default_config())
    }

    pub fn with(config: IselSimConfig) -> Conv {
        let sim = IselSim::new(config);
        let t0 = Instant::now();
        let byte = sim.line().byte_time();
        Conv {
            sim,
            t0,
            now: t0,
            byte,
            out: Vec::new(),
            sent_at: t0,
        }
    }

    /// A controller with XYZ initialised and referenced: every axis at
    /// machine 0.
    pub fn referenced() -> Conv {
        let mut c = Conv::new();
        c.expect("@07", "0");
        c.expect_after("@0R7", "0", Duration::from_secs(60));
        c
    }

    fn drain(&mut self) {
        while let Some(m) = self.sim.poll_output() {
            self.out.push((self.now, m));
        }
    }

    /// Bytes one byte time apart, each handed over when it has arrived.
    pub fn send_bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.run_until(self.now + self.byte);
            self.sim.on_byte(b, self.now);
            self.drain();
        }
        self.sent_at = self.now;
    }

    /// A line and its CR.
    pub fn send(&mut self, line: &str) {
        let mut bytes = line.as_bytes().to_vec();
        bytes.push(b'\r');
        self.send_bytes(&bytes);
    }

    /// Run the model's deadlines in order up to `until`.
    pub fn run_until(&mut self, until: Instant) {
        while let Some(d) = self.sim.next_deadline() {
            if d > until {
                break;
            }
            self.now = self.now.max(d);
            self.sim.advance(self.now);
            self.drain();
        }
        self.now = self.now.max(until);
        self.sim.advance(self.now);
        self.drain();
    }

    pub fn wait(&mut self, d: Duration) {
        self.run_until(self.now + d);
    }

    /// Everything produced so far and not yet taken, as text.
    pub fn take(&mut self) -> String {
        let text: Vec<u8> = self.out.drain(..).flat_map(|(_, m)| m).collect();
        String::from_utf8_lossy(&text).into_owned()
    }

    /// Wait (at most `limit`) for the next message: its text and how long
    /// after the end of the last line sent it was produced.
    pub fn next_reply(&mut self, limit: Duration) -> Option<(String, Duration)> {
        let end = self.now + limit;
        loop {
            if !self.out.is_empty() {
                let (at, m) = self.out.remove(0);
                return Some((
                    String::from_utf8_lossy(&m).into_owned(),
                    at.saturating_duration_since(self.sent_at),
                ));
            }
            match self.sim.next_deadline() {
                Some(d) if d <= end => {
                    self.now = self.now.max(d);
                    self.sim.advance(self.now);
                    self.drain();
                }
                _ => {
                    self.run_until(end);
                    if self.out.is_empty() {
                        return None;
                    }
                }
            }
        }
    }

    /// Send `line`, return the reply (within `limit`) and its delay.
    pub fn ask_within(&mut self, line: &str, limit: Duration) -> (String, Duration) {
        assert!(self.out.is_empty(), "unread output: {:?}", self.take());
        self.send(line);
        self.next_reply(limit)
            .unwrap_or_else(|| panic!("no reply to {line} within {limit:?}"))
    }

    /// Send a command that answers at once; its reply.
    pub fn ask(&mut self, line: &str) -> String {
        let (reply, after) = self.ask_within(line, Duration::from_millis(1));
        assert!(after.is_zero(), "{line} answered after {after:?}");
        reply
    }

    pub fn expect(&mut self, line: &str, reply: &str) {
        assert_eq!(self.ask(line), reply, "reply to {line}");
    }

    /// Send a command that may take up to `limit`; check its reply and
    /// return how long it took.
    pub fn expect_after(&mut self, line: &str, reply: &str, limit: Duration) -> Duration {
        let (got, after) = self.ask_within(line, limit);
        assert_eq!(got, reply, "reply to {line} after {after:?}");
        after
    }

    /// Nothing at all is produced for `d`.
    pub fn silent_for(&mut self, d: Duration) {
        self.wait(d);
        assert!(self.out.is_empty(), "unexpected output {:?}", self.take());
    }

    pub fn set(&mut self, name: &str, level: bool) {
        self.sim
            .control(
                &InputControl::Set {
                    name: name.into(),
                    level,
                },
                self.now,
            )
            .expect("control");
        self.drain();
    }

    pub fn press(&mut self, name: &str) {
        self.sim
            .control(&InputControl::Press { name: name.into() }, self.now)
            .expect("press");
        self.drain();
    }

    /// The counters `@0P` reports, decoded (X, Y, Z).
    pub fn position(&mut self) -> [i32; 3] {
        let reply = self.ask("@0P");
        assert_eq!(reply.len(), 19, "{reply}");
        let field = |i: usize| {
            let hex = reply.get(1 + 6 * i..7 + 6 * i).expect("field");
            let v = i32::from_str_radix(hex, 16).expect("hex");
            (v << 8) >> 8
        };
        [field(0), field(1), field(2)]
    }

    pub fn physical(&self) -> [f64; 4] {
        self.sim.physical_positions(self.now)
    }
}

/// Close enough for durations computed two ways (f64 seconds and the
/// nanosecond bisection of switch times).
pub fn assert_close(got: Duration, want: Duration, what: &str) {
    let diff = got.abs_diff(want);
    assert!(
        diff <= Duration::from_micros(2),
        "{what}: got {got:?}, want {want:?}"
    );
}
