//! Connecting, reading the state back, initialising, the error flag.

use crate::axis::AxisSet;
use crate::device::api::{Activity, Event, PositionSource, Recovery, Refusal, Request};
use crate::device::driver::Driver;

use super::harness::{Harness, ms, speeds, xyz};

#[test]
fn a_connection_halts_first_then_reads_the_state_back() {
    let mut h = Harness::new();
    h.connect();
    h.readback("000000", 120, -40, 7);
    h.expect_nothing();
    let s = h.state();
    assert!(s.link_up);
    assert_eq!(s.referenced, AxisSet::XYZ);
    assert_eq!(s.initialised, AxisSet::EMPTY, "ramp not set yet");
    let p = h.positions().last().copied().expect("position");
    assert_eq!(p.steps, xyz(120, -40, 7));
    assert_eq!(p.source, PositionSource::Measured);
    assert!(
        h.notices().iter().any(|n| n.starts_with("state read back")),
        "{:?}",
        h.notices()
    );
    // Nothing moves before the profile's ramp is set.
    h.request(Request::Step {
        delta: xyz(10, 0, 0),
        speed_hz: speeds(500.0),
    });
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["step X=10 Y=0 Z=0: controller not initialised: initialise (i) first"]
    );
}

#[test]
fn an_unknown_position_needs_a_reference_run() {
    let mut h = Harness::new();
    h.connect();
    h.readback("000100", 0, 0, 0);
    h.initialise(0, 0, 0);
    assert_eq!(h.state().referenced, AxisSet::EMPTY);
    assert_eq!(h.state().initialised, AxisSet::XYZ);
    h.take_events();
    h.request(Request::MoveTo {
        target: xyz(100, 0, 0),
        frame: crate::device::api::Frame::Machine,
        speed_hz: speeds(500.0),
    });
    h.expect_nothing();
    assert_eq!(
        crate::device::common::testing::refusal_reasons(&h.events),
        [Refusal::NotReferenced { axes: AxisSet::XYZ }]
    );
}

#[test]
fn the_error_flag_needs_a_reset_and_a_reference_run() {
    let mut h = Harness::new();
    h.connect();
    h.readback("001000", 5, 5, 5);
    let fault = h.state().fault.expect("fault");
    assert_eq!(fault.code, "error flag");
    assert_eq!(fault.recovery, Recovery::ReinitialiseAndReference);
    assert!(h.faults().contains(&"@X error flag".to_owned()));
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_nothing();
    assert_eq!(
        crate::device::common::testing::refusal_reasons(&h.events),
        [Refusal::Fault {
            recovery: Recovery::ReinitialiseAndReference
        }]
    );
    h.take_events();
    // Initialise resets first (the only way to clear the flag).
    h.request(Request::Initialise);
    h.expect_text("@R");
    h.reply(b"\r");
    h.expect_text("#S200");
    h.reply(b"\r");
    h.expect(b"#R500\x01");
    h.reply(b"\r");
    h.reply(b"\x02\r");
    h.expect_text("@X");
    h.reply(b"@X000100\r");
    h.positions_read(0, 0, 0);
    let s = h.state();
    assert_eq!(
        s.fault.as_ref().map(|f| f.recovery),
        Some(Recovery::Reference)
    );
    assert_eq!(s.initialised, AxisSet::XYZ);
    // The reference run clears what is left of it.
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect(b"$HZYX\x01");
    h.reply(b"\r");
    assert_eq!(h.state().activity, Activity::Homing);
    h.run_ends();
    h.positions_read(0, 0, 0);
    let s = h.state();
    assert_eq!(s.fault, None);
    assert_eq!(s.referenced, AxisSet::XYZ);
}

#[test]
fn a_transfer_left_open_by_a_lost_link_is_ended_on_the_next_connection() {
    let mut h = Harness::ready();
    h.request(Request::Upload {
        lines: vec!["W10".into(), "A1,1".into()],
        erase_first: false,
    });
    h.expect_text("@F");
    h.reply(b"\r");
    h.expect_text("W10");
    h.driver.disconnected("test", h.now);
    h.collect();
    assert!(h.events.iter().any(|e| matches!(
        e,
        Event::Upload(crate::device::api::UploadEvent::Aborted { .. })
    )));
    h.driver.connected(h.now);
    h.collect();
    h.expect(b"\r@B\r");
    h.expect(b"\x01");
    h.reply(b"\r\r\r");
    h.expect_nothing();
    h.advance(ms(100));
    h.expect_text("@X");
    assert_eq!(h.state().program, crate::device::api::ProgramState::Invalid);
}

#[test]
fn a_lost_link_refuses_and_reads_back_on_reconnect() {
    let mut h = Harness::ready();
    h.driver.disconnected("gone", h.now);
    h.collect();
    assert!(!h.state().link_up);
    assert_eq!(h.state().initialised, AxisSet::EMPTY);
    h.request(Request::Initialise);
    assert_eq!(
        h.refusals(),
        ["initialise: not connected to the controller: wait for the link"]
    );
    h.connect();
    h.readback("000000", 1, 2, 3);
    h.expect_nothing();
}
