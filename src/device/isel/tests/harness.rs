//! A test bench for the driver: synthetic time, bytes in and out, events
//! collected. Nothing here reads a clock except the one `Instant::now()`
//! that anchors the synthetic time line.

use crate::axis::Axis;
use crate::config::{ConfigDirs, load_profile};
use crate::device::api::{MachineState, PerAxis};
use crate::device::driver::Driver;
use crate::device::isel::{IselDriver, IselSettings, PollRate};

pub fn settings() -> IselSettings {
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("default profile");
    let mut s = IselSettings::from_profile(&profile).expect("isel settings");
    s.poll.rate = PollRate::Off;
    s
}

pub use crate::device::common::testing::ms;

/// `@0P` reply for these positions (3 axes).
pub fn position_reply(x: i32, y: i32, z: i32) -> Vec<u8> {
    let field = |v: i32| format!("{:06X}", (v as u32) & 0xFF_FFFF);
    format!("0{}{}{}", field(x), field(y), field(z)).into_bytes()
}

/// The common driver harness with the isel driver in it.
pub type Harness = crate::device::common::testing::Harness<IselDriver>;

impl Default for Harness {
    fn default() -> Harness {
        Harness::new()
    }
}

impl Harness {
    pub fn new() -> Harness {
        Harness::with(|_| {})
    }

    pub fn with(adjust: impl FnOnce(&mut IselSettings)) -> Harness {
        let mut s = settings();
        adjust(&mut s);
        Harness::on(IselDriver::new(s))
    }

    pub fn state(&self) -> MachineState {
        self.driver.state().clone()
    }

    /// Connected: the stop sequence goes first, then the line settles;
    /// then test mode goes off (it cannot be read back), answered `0`.
    pub fn connect(&mut self) {
        self.connect_stop();
        self.expect_text("@0T0");
        self.reply(b"0");
    }

    /// Connected, up to the settled line: the stop sequence only.
    pub fn connect_stop(&mut self) {
        self.driver.connected(self.now);
        self.collect();
        self.expect(&[0xFD, 0xFF]);
        self.expect_nothing();
        self.advance(ms(100));
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
