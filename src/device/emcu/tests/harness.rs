//! The common driver harness with the EMCU driver in it, and the
//! conversations most tests start with.

use crate::axis::Axis;
use crate::config::{ConfigDirs, load_profile};
use crate::device::api::{MachineState, PerAxis, Request};
use crate::device::common::PollRate;
use crate::device::driver::Driver;
use crate::device::emcu::{EmcuDriver, EmcuSettings};

pub use crate::device::common::testing::ms;

pub fn settings() -> EmcuSettings {
    let profile = load_profile("emcu", &ConfigDirs::builtin_only()).expect("emcu profile");
    let mut s = EmcuSettings::from_profile(&profile).expect("emcu settings");
    s.poll.rate = PollRate::Off;
    s
}

pub type Harness = crate::device::common::testing::Harness<EmcuDriver>;

impl Default for Harness {
    fn default() -> Harness {
        Harness::new()
    }
}

impl Harness {
    pub fn new() -> Harness {
        Harness::with(|_| {})
    }

    pub fn with(adjust: impl FnOnce(&mut EmcuSettings)) -> Harness {
        let mut s = settings();
        adjust(&mut s);
        Harness::on(EmcuDriver::new(s))
    }

    pub fn state(&self) -> MachineState {
        self.driver.state().clone()
    }

    /// Connected: a CR and `@B` go first, their CRs come, the line settles.
    pub fn connect(&mut self) {
        self.driver.connected(self.now);
        self.collect();
        self.expect(b"\r@B\r");
        self.reply(b"\r\r");
        self.expect_nothing();
        self.advance(ms(100));
    }

    /// `@LX`, `@LY`, `@LZ` answered with these positions.
    pub fn positions_read(&mut self, x: i32, y: i32, z: i32) {
        for (axis, v) in [("X", x), ("Y", y), ("Z", z)] {
            self.expect_text(&format!("@L{axis}"));
            self.reply(format!("@L{axis}{v}\r").as_bytes());
        }
    }

    /// The read-back of an interface whose `@X` reads `flags`.
    pub fn readback(&mut self, flags: &str, x: i32, y: i32, z: i32) {
        self.expect_text("@X");
        self.reply(format!("@X{flags}\r").as_bytes());
        self.positions_read(x, y, z);
    }

    /// A run is over: 0x02 CR, then `@X` reads idle.
    pub fn run_ends(&mut self) {
        self.reply(b"\x02\r");
        self.expect_text("@X");
        self.reply(b"@X000000\r");
    }

    /// `Initialise` on an interface without error: `#S`, `#R` and the end.
    pub fn initialise(&mut self, x: i32, y: i32, z: i32) {
        self.request(Request::Initialise);
        self.expect_text("#S200");
        self.reply(b"\r");
        self.expect(b"#R500\x01");
        self.reply(b"\r");
        self.expect_nothing();
        self.run_ends();
        self.positions_read(x, y, z);
    }

    /// Connected to a referenced interface at `(x, y, z)`, initialised.
    pub fn ready_at(x: i32, y: i32, z: i32) -> Harness {
        let mut h = Harness::new();
        h.connect();
        h.readback("000000", x, y, z);
        h.initialise(x, y, z);
        h.expect_nothing();
        h.take_events();
        h
    }

    pub fn ready() -> Harness {
        Harness::ready_at(20_000, 20_000, 8_000)
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
