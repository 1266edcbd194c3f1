//! Connecting, reading the state back, initialising, polling.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Event, PositionSource, Recovery, Refusal, Request};
use crate::device::common::testing::refusal_reasons;
use crate::device::driver::Driver;
use crate::proto::emp::DriveAddress;

use super::harness::{Harness, ms};
use crate::device::emp::OFF_POLL_EVERY;

#[test]
fn the_first_frame_stops_then_the_state_is_read_back() {
    let mut h = Harness::emp(|_| {});
    h.connect(100, true);
    let s = h.state();
    assert!(s.link_up);
    assert_eq!(s.initialised, AxisSet::EMPTY.with(Axis::X));
    assert_eq!(s.referenced, AxisSet::EMPTY);
    let p = h.positions();
    assert_eq!(p.last().map(|p| p.steps.get(Axis::X)), Some(Some(100)));
    assert_eq!(p.last().map(|p| p.source), Some(PositionSource::Measured));
    assert!(
        h.notices()
            .iter()
            .any(|n| n.starts_with("state read back: drive 11 (X) on, at 100"))
    );
    assert!(h.events.iter().any(|e| matches!(e, Event::Io(_))));
    assert!(h.faults().is_empty(), "{:?}", h.faults());
}

#[test]
fn a_drive_that_is_not_on_is_not_initialised_and_motion_is_refused() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, false);
    assert_eq!(h.state().initialised, AxisSet::EMPTY);
    assert!(
        h.notices()
            .iter()
            .any(|n| n == "drive 11 is switched off: switch it on (i)"),
        "{:?}",
        h.notices()
    );
    // No fault for what the read-back expected.
    assert!(h.faults().is_empty(), "{:?}", h.faults());
    h.request(Request::Home {
        axes: AxisSet::EMPTY.with(Axis::X),
    });
    h.expect_nothing();
    assert_eq!(refusal_reasons(&h.events), vec![Refusal::NotInitialised]);
}

#[test]
fn initialise_switches_every_drive_on_then_sets_the_jog_mode() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, false);
    h.request(Request::Initialise);
    h.expect_frame("02 11 11 00 00000000");
    h.answer("03 11 00 22 00000000");
    h.expect_frame("22 11 03 00 00000000");
    h.answer("23 11 00 22 00000000");
    h.expect_nothing();
    assert_eq!(h.state().initialised, AxisSet::EMPTY.with(Axis::X));
    assert!(h.notices().iter().any(|n| n.starts_with("initialised")));
}

#[test]
fn position_mode_jogs_initialise_tpwm() {
    let mut h = Harness::emp(|s| s.jog_style = crate::config::profile::EmpJog::Position);
    h.connect(0, true);
    h.request(Request::Initialise);
    h.expect_frame("02 11 11 00 00000000");
    h.answer("03 11 00 22 00000000");
    h.expect_frame("22 11 07 00 00000000");
}

#[test]
fn polls_read_positions_and_every_nth_cycle_the_inputs() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.poll();
    h.events.clear();
    h.expect_frame("2C 11 00 00 00000000");
    h.answer("2D 11 00 22 00000010");
    h.expect_frame("40 11 01 00 00000000");
    h.answer("41 11 04 22 00000005");
    for n in 0..3u32 {
        h.expect_frame("2C 11 00 00 00000000");
        h.answer(&format!("2D 11 00 22 {:08X}", 0x20 + n));
    }
    h.expect_frame("2C 11 00 00 00000000");
    let xs: Vec<Option<i64>> = h.positions().iter().map(|p| p.steps.get(Axis::X)).collect();
    assert_eq!(xs, [Some(16), Some(32), Some(33), Some(34)]);
    let io = h
        .events
        .iter()
        .find_map(|e| match e {
            Event::Io(s) => Some(s.clone()),
            _ => None,
        })
        .expect("io");
    let on: Vec<&str> = io.groups[0]
        .bits
        .iter()
        .filter(|b| b.value)
        .map(|b| b.name.as_str())
        .collect();
    assert_eq!(on, ["reference", "I1", "I3"]);
}

#[test]
fn a_poll_rate_spaces_the_cycles() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.request(Request::Poll {
        rate_hz: Some(10.0),
        ports_every: 1000,
    });
    h.expect_frame("2C 11 00 00 00000000");
    h.answer("2D 11 00 22 00000000");
    h.expect_frame("40 11 01 00 00000000");
    h.answer("41 11 00 22 00000000");
    h.expect_nothing();
    h.advance(ms(99));
    h.expect_nothing();
    h.advance(ms(1));
    h.expect_frame("2C 11 00 00 00000000");
}

#[test]
fn an_ee_is_read_with_0a_and_reported_with_its_meaning() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.request(Request::Raw {
        line: "24 11 00 00 00 00 00 00".into(),
    });
    h.expect_frame("24 11 00 00 00000000");
    h.answer("25 11 00 EE 00000000");
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 22 00000004");
    let fault = h
        .events
        .iter()
        .find_map(|e| match e {
            Event::Fault(f) => Some(f.clone()),
            _ => None,
        })
        .expect("fault");
    assert_eq!(fault.code, "EE 04");
    assert_eq!(
        fault.meaning,
        "drive 11: not possible in this operating mode"
    );
    assert_eq!(fault.recovery, Recovery::None);
    assert!(h.state().fault.is_none());
}

#[test]
fn a_motion_command_to_a_drive_that_is_off_asks_to_switch_it_on() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.request(Request::Raw {
        line: "2A 11 00 05 00000000".into(),
    });
    h.expect_frame("2A 11 00 05 00000000");
    h.answer("2B 11 00 EE 00000000");
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 22 00000002");
    let s = h.state();
    assert_eq!(s.fault.map(|f| f.recovery), Some(Recovery::SwitchOn));
    assert_eq!(s.initialised, AxisSet::EMPTY);
    h.request(Request::Initialise);
    h.expect_frame("02 11 11 00 00000000");
    h.answer("03 11 00 22 00000000");
    assert!(h.state().fault.is_none());
    assert_eq!(DriveAddress::SINGLE.byte(), 0x11);
}

#[test]
fn a_drive_known_to_be_off_is_polled_once_a_second_without_asking_again() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, false);
    h.poll();
    h.events.clear();
    // The first poll at line speed, answered `EE`.
    h.expect_frame("2C 11 00 00 00000000");
    h.answer("2D 11 00 EE 00000000");
    // Then one poll a second (`OFF_POLL_EVERY`): the position or the
    // inputs, whichever is due; no `0A` again.
    for _ in 0..4 {
        h.expect_nothing();
        h.advance(OFF_POLL_EVERY - ms(1));
        h.expect_nothing();
        h.advance(ms(1));
        h.reject_poll();
    }
    h.expect_nothing();
    assert!(h.notices().is_empty(), "{:?}", h.notices());
    assert!(h.faults().is_empty());
    assert!(!h.state().initialised.contains(crate::axis::Axis::X));
    // Switched on (`02`): the full rate again, each poll after the answer.
    h.advance(ms(300));
    h.request(crate::device::api::Request::Initialise);
    h.expect_frame("02 11 11 00 00000000");
    h.answer("03 11 00 22 00000000");
    h.expect_frame("22 11 03 00 00000000");
    h.answer("23 11 00 22 00000000");
    let mut reads = 0;
    for _ in 0..8 {
        let sent = h.send().unwrap_or_default();
        if sent.starts_with(b"2C11") {
            reads += 1;
            h.answer("2D 11 00 22 00000000");
        } else {
            assert!(sent.starts_with(b"4011"), "{sent:?}");
            h.answer("41 11 00 22 00000000");
        }
    }
    assert!(reads >= 6, "{reads}");
}

/// A drive that takes nothing before `02`, `0A` included
/// (docs/decisions.md "EMP before 02"): the `EE` to `0A` says it is
/// off. It used to be asked `0A` after every poll, at line speed.
#[test]
fn a_drive_that_rejects_0a_too_is_known_off_and_polled_once_a_second() {
    let mut h = Harness::emp(|_| {});
    h.driver.connected(h.now);
    h.collect();
    h.expect_frame("08 11 00 00 00000000");
    h.answer("09 11 00 EE 00000000");
    h.advance(ms(50));
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 EE 00000000");
    // The read-back: its own `0A` is rejected as well; nothing is asked
    // again.
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 EE 00000000");
    h.expect_frame("2C 11 00 00 00000000");
    h.answer("2D 11 00 EE 00000000");
    h.expect_frame("40 11 01 00 00000000");
    h.answer("41 11 00 EE 00000000");
    h.expect_nothing();
    h.poll();
    let from = h.sent.len();
    for _ in 0..5 {
        h.reject_poll();
        h.expect_nothing();
        h.advance(OFF_POLL_EVERY);
    }
    assert_eq!(h.sent.len() - from, 5);
    let told: Vec<String> = h
        .notices()
        .into_iter()
        .filter(|n| !n.starts_with("state read back"))
        .collect();
    assert_eq!(told, vec!["drive 11 is switched off: switch it on (i)"]);
    assert!(h.faults().is_empty(), "{:?}", h.faults());
    assert!(!h.state().initialised.contains(Axis::X));
    // `02` is answered: on, at the full rate.
    h.request(Request::Initialise);
    h.expect_frame("02 11 11 00 00000000");
    h.answer("03 11 00 22 00000000");
    h.expect_frame("22 11 03 00 00000000");
    h.answer("23 11 00 22 00000000");
    assert!(h.state().initialised.contains(Axis::X));
}

#[test]
fn a_motion_command_to_a_drive_that_rejects_0a_too_asks_to_switch_it_on() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.request(Request::Raw {
        line: "2A 11 00 05 00000000".into(),
    });
    h.expect_frame("2A 11 00 05 00000000");
    h.answer("2B 11 00 EE 00000000");
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 EE 00000000");
    h.expect_nothing();
    let fault = h.state().fault.expect("a fault");
    assert_eq!(fault.recovery, Recovery::SwitchOn);
    assert_eq!(fault.code, "EE");
    assert_eq!(fault.command, "2A11000500000000");
    assert!(
        fault.meaning.starts_with("drive 11: switched off"),
        "{}",
        fault.meaning
    );
    assert!(h.state().initialised.is_empty());
}

#[test]
fn a_drive_switched_off_by_a_typed_04_is_polled_slowly_without_a_stale_position() {
    let mut h = Harness::emp(|_| {});
    h.connect(1000, true);
    h.request(Request::Raw {
        line: "04 11 00 00 00000000".into(),
    });
    h.expect_frame("04 11 00 00 00000000");
    h.answer("05 11 00 22 000003E8");
    h.poll();
    h.events.clear();
    let from = h.sent.len();
    for _ in 0..3 {
        h.reject_poll();
        h.expect_nothing();
        h.advance(OFF_POLL_EVERY);
    }
    // Known off since its `04`: no `0A`, no position sample.
    assert!(h.sent[from..].iter().all(|m| !m.starts_with(b"0A")));
    assert!(h.positions().is_empty(), "{:?}", h.positions());
    assert!(!h.state().initialised.contains(Axis::X));
}
