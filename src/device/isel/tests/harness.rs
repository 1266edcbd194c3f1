//! A test bench for the driver: synthetic time, bytes in and out, events
//! collected. Nothing here reads a clock except the one `Instant::now()`
//! that anchors the synthetic time line.

use std::time::{Duration, Instant};

use crate::axis::Axis;
use crate::config::{ConfigDirs, load_profile};
use crate::device::api::{Event, MachineState, PerAxis, Request};
use crate::device::driver::Driver;
use crate::device::isel::{IselDriver, IselSettings, PollRate};
use crate::traffic::readable;

pub fn settings() -> IselSettings {
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("default profile");
    let mut s = IselSettings::from_profile(&profile).expect("isel settings");
    s.poll.rate = PollRate::Off;
    s
}

pub fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// `@0P` reply for these positions (3 axes).
pub fn position_reply(x: i32, y: i32, z: i32) -> Vec<u8> {
    let field = |v: i32| format!("{:06X}", (v as u32) & 0xFF_FFFF);
    format!("0{}{}{}", field(x), field(y), field(z)).into_bytes()
}

pub struct Harness {
    pub driver: IselDriver,
    pub now: Instant,
    pub events: Vec<Event>,
}

impl Harness {
    pub fn new() -> Harness {
        Harness::with(|_| {})
    }

    pub fn with(adjust: impl FnOnce(&mut IselSettings)) -> Harness {
        let mut s = settings();
        adjust(&mut s);
        Harness {
            driver: IselDriver::new(s),
            now: Instant::now(),
            events: Vec::new(),
        }
    }

    fn collect(&mut self) {
        while let Some(e) = self.driver.poll_event() {
            self.events.push(e);
        }
    }

    pub fn state(&self) -> MachineState {
        self.driver.state().clone()
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
        let out = self.driver.poll_transmit(self.now).map(|o| o.bytes);
        self.collect();
        out
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
        self.driver.received(bytes, self.now);
        self.collect();
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

    /// Connected: the stop sequence goes first, then the line settles.
    pub fn connect(&mut self) {
        self.driver.connected(self.now);
        self.collect();
        self.expect(&[0xFD, 0xFF]);
        self.expect_nothing();
        self.advance(ms(100));
    }

    pub fn take_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// The read-back of a controller at `(x, y, z)` that answers the probe
    /// with `probe` (`0` referenced, `R` not).
    pub fn readback(&mut self, x: i32, y: i32, z: i32, probe: &[u8]) {
        self.expect_text("@0P");
        self.reply(&position_reply(x, y, z));
        self.advance(ms(60));
        self.expect_text("@0b1");
        self.reply(b"003");
        self.expect_text("@0b2");
        self.reply(b"0E2");
        self.expect_text("@0b3");
        self.reply(b"000");
        self.expect_text("@0A0,300,0,300,0,300,0,300");
        self.reply(probe);
        if probe == b"0" || probe == b"R" {
            self.expect_text("@0j300");
            self.reply(b"0");
            self.expect_text("@0J100");
            self.reply(b"0");
            self.expect_text("@0d4000,4000,4000");
            self.reply(b"0");
        }
    }

    /// Connected to an initialised, referenced XYZ controller at `(x, y, z)`.
    pub fn ready_at(x: i32, y: i32, z: i32) -> Harness {
        let mut h = Harness::new();
        h.connect();
        h.readback(x, y, z, b"0");
        h.expect_nothing();
        h.take_events();
        h
    }

    pub fn ready() -> Harness {
        Harness::ready_at(40_000, 40_000, 16_000)
    }

    pub fn refusals(&self) -> Vec<String> {
        self.events
            .iter()
            .filter_map(|e| match e {
                Event::Refused { request, reason } => Some(format!("{request}: {reason}")),
                _ => None,
            })
            .collect()
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

    pub fn positions(&self) -> Vec<crate::device::api::PositionSample> {
        self.events
            .iter()
            .filter_map(|e| match e {
                Event::Position(p) => Some(*p),
                _ => None,
            })
            .collect()
    }
}

pub fn xyz(x: i64, y: i64, z: i64) -> PerAxis<i64> {
    PerAxis::new()
        .with(Axis::X, x)
        .with(Axis::Y, y)
        .with(Axis::Z, z)
}

pub fn speeds(hz: f64) -> PerAxis<f64> {
    PerAxis::new()
        .with(Axis::X, hz)
        .with(Axis::Y, hz)
        .with(Axis::Z, hz)
}
