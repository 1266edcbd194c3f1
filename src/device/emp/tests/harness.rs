//! Byte conversations with the EMP driver: frames written as their 16 hex
//! characters (spaces allowed), EOF appended.

use crate::axis::Axis;
use crate::config::{ConfigDirs, Profile, load_profile};
use crate::device::api::{MachineState, PerAxis};
use crate::device::driver::Driver;
use crate::device::emp::{EmpDriver, EmpSettings};

pub use crate::device::common::testing::ms;

pub fn profile() -> Profile {
    load_profile("emp", &ConfigDirs::builtin_only()).expect("emp profile")
}

pub fn settings() -> EmpSettings {
    EmpSettings::from_profile(&profile()).expect("emp settings")
}

/// A frame on the wire: hex (spaces ignored) and EOF.
pub fn frame(hex: &str) -> Vec<u8> {
    let mut bytes: Vec<u8> = hex.bytes().filter(|b| *b != b' ').collect();
    bytes.push(0x1A);
    bytes
}

pub fn x_speed(hz: f64) -> PerAxis<f64> {
    PerAxis::new().with(Axis::X, hz)
}

pub type Harness = crate::device::common::testing::Harness<EmpDriver>;

impl Harness {
    /// One drive at 11, polling off unless `poll`.
    pub fn emp(adjust: impl FnOnce(&mut EmpSettings)) -> Harness {
        let mut s = settings();
        s.poll = crate::device::common::PollRate::Off;
        adjust(&mut s);
        Harness::on(EmpDriver::new(s))
    }

    pub fn state(&self) -> MachineState {
        self.driver.state().clone()
    }

    #[track_caller]
    pub fn expect_frame(&mut self, hex: &str) {
        self.expect(&frame(hex));
    }

    pub fn answer(&mut self, hex: &str) {
        self.reply(&frame(hex));
    }

    /// Connected: the stop first, the quiet, then the read-back of a drive
    /// at `position` that is switched on (`on`) or not.
    pub fn connect(&mut self, position: u32, on: bool) {
        self.driver.connected(self.now);
        self.collect();
        let fast = self.driver.settings().stop == crate::config::profile::EmpStop::Fast;
        let (stop, answer) = if fast {
            ("2A 11 03 00 00000000", "2B")
        } else {
            ("08 11 00 00 00000000", "09")
        };
        self.expect_frame(stop);
        self.expect_nothing();
        if on {
            self.answer(&format!("{answer} 11 00 22 00000000"));
        } else {
            self.answer(&format!("{answer} 11 00 EE 00000000"));
            self.advance(ms(50));
            self.expect_frame("0A 11 00 00 00000000");
            self.answer("0B 11 00 22 00000002");
        }
        self.advance(ms(50));
        self.expect_frame("0A 11 00 00 00000000");
        self.answer(if on {
            "0B 11 00 22 00000000"
        } else {
            "0B 11 00 22 00000002"
        });
        self.expect_frame("2C 11 00 00 00000000");
        if on {
            self.answer(&format!("2D 11 00 22 {position:08X}"));
        } else {
            // Known to be off since the stop's `0A`: not asked again.
            self.answer("2D 11 00 EE 00000000");
        }
        self.expect_frame("40 11 01 00 00000000");
        if on {
            self.answer("41 11 00 22 00000000");
        } else {
            self.answer("41 11 00 EE 00000000");
        }
        self.expect_nothing();
    }

    /// Switched on, in IV mode, and referenced; the counter at `position`.
    pub fn ready(&mut self, position: u32) {
        self.connect(position, true);
        self.request(crate::device::api::Request::Home {
            axes: crate::axis::AxisSet::EMPTY.with(Axis::X),
        });
        self.expect_frame("22 11 03 00 00000000");
        self.answer(&format!("23 11 00 22 {position:08X}"));
        self.expect_frame("20 11 19 00 000030D4");
        self.answer("21 11 00 22 00000000");
        self.expect_frame("26 11 00 00 00140400");
        self.answer(&format!("27 11 00 55 {position:08X}"));
        self.answer(&format!("27 11 00 22 {position:08X}"));
        self.expect_nothing();
        assert!(
            self.state().referenced.contains(Axis::X),
            "{:?}",
            self.events
        );
    }

    /// The next frame is a poll of drive 11 (`2C` or `40 01`, whichever
    /// was due): answer it `EE`, as a drive that is switched off does.
    #[track_caller]
    pub fn reject_poll(&mut self) {
        let sent = self.send().unwrap_or_default();
        if sent.starts_with(b"2C11") {
            self.answer("2D 11 00 EE 00000000");
        } else {
            assert_eq!(sent, frame("40 11 01 00 00000000"));
            self.answer("41 11 00 EE 00000000");
        }
    }

    /// Turn polling on at line speed.
    pub fn poll(&mut self) {
        self.request(crate::device::api::Request::Poll {
            rate_hz: None,
            ports_every: 4,
        });
    }
}
