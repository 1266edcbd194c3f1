//! State read-back on connect, and Initialise.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Event, ProgramState, Recovery, Refusal, Request};
use crate::device::driver::Driver;

use super::harness::{Harness, ms, position_reply, speeds, xyz};

#[test]
fn a_referenced_controller_is_read_back_and_its_ramp_set() {
    let mut h = Harness::new();
    h.connect();
    h.readback(256, 131_087, -2, b"0");
    h.expect_nothing();
    let s = h.state();
    assert!(s.link_up);
    assert_eq!(s.initialised, AxisSet::XYZ);
    assert_eq!(s.referenced, AxisSet::XYZ);
    assert!(!s.estop && !s.limit && s.fault.is_none());
    let measured = h.positions();
    assert_eq!(
        measured.first().map(|p| p.steps),
        Some(xyz(256, 131_087, -2))
    );
    assert!(
        h.events.iter().any(|e| matches!(e, Event::Io(_))),
        "ports are reported"
    );
    assert!(
        h.notices()
            .iter()
            .any(|n| n == "state read back: axes XYZ initialised, XYZ referenced")
    );
}

#[test]
fn an_uninitialised_controller_is_not_probed() {
    let mut h = Harness::new();
    h.connect();
    h.expect_text("@0P");
    h.reply(b"4");
    h.advance(ms(60));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b2");
    h.reply(b"0E2");
    h.expect_text("@0b3");
    h.reply(b"000");
    h.expect_nothing();
    let s = h.state();
    assert_eq!(s.initialised, AxisSet::EMPTY);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    h.request(Request::Step {
        delta: xyz(10, 0, 0),
        speed_hz: speeds(1000.0),
    });
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["step X=10 Y=0 Z=0: controller not initialised: initialise (i) first"]
    );
}

#[test]
fn an_unreferenced_controller_answers_r_to_the_probe() {
    let mut h = Harness::new();
    h.connect();
    h.readback(0, 0, 0, b"R");
    let s = h.state();
    assert_eq!(s.initialised, AxisSet::XYZ);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    h.request(Request::Jog {
        id: crate::device::api::JogId(1),
        axes: vec![(Axis::X, crate::device::api::Dir::Plus)],
        speed_hz: speeds(1000.0),
        lease: ms(500),
    });
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["jog X+ (#1): axes XYZ not referenced: reference them (h) first"]
    );
}

#[test]
fn a_different_axis_setting_is_found_by_probing_the_pair_counts() {
    let mut h = Harness::new();
    h.connect();
    h.expect_text("@0P");
    h.reply(&position_reply(5, 0, 0));
    h.advance(ms(60));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b2");
    h.reply(b"0E2");
    h.expect_text("@0b3");
    h.reply(b"000");
    h.expect_text("@0A0,300,0,300,0,300,0,300");
    h.reply(b"7");
    h.expect_text("@0A0,300,0,300");
    h.reply(b"0");
    // No ramp settings for a controller set up differently from the profile.
    h.expect_nothing();
    let s = h.state();
    assert_eq!(s.initialised, AxisSet::from_mask(0b011));
    assert!(
        h.notices()
            .iter()
            .any(|n| n.contains("set up for XY, the profile for XYZ"))
    );
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_nothing();
    assert!(h.refusals()[0].ends_with("controller not initialised: initialise (i) first"));
}

#[test]
fn a_four_axis_reply_reveals_the_a_axis() {
    let mut h = Harness::new();
    h.connect();
    h.expect_text("@0P");
    h.reply(b"0000B00044000000FFE003040");
    h.advance(ms(60));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b2");
    h.reply(b"0E2");
    h.expect_text("@0b3");
    h.reply(b"000");
    // Only XYZA reports 24 digits: one probe with four pairs confirms it.
    h.expect_text("@0A0,300,0,300,0,300,0,300");
    h.reply(b"0");
    h.expect_nothing();
    assert_eq!(h.state().initialised, AxisSet::XYZA);
    let p = h.positions()[0].steps;
    assert_eq!(p.get(Axis::A), Some(12_352));
    assert_eq!(p.get(Axis::Y), Some(278_528));
}

#[test]
fn an_open_estop_circuit_skips_the_probe_and_blocks_motion() {
    let mut h = Harness::new();
    h.connect();
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.advance(ms(60));
    h.expect_text("@0b1");
    h.reply(b"002");
    h.expect_text("@0b2");
    h.reply(b"0E2");
    h.expect_text("@0b3");
    h.reply(b"000");
    h.expect_nothing();
    let s = h.state();
    assert!(s.estop);
    assert_eq!(
        s.fault.as_ref().map(|f| f.recovery),
        Some(Recovery::ClearEmergencyStop)
    );
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["home XYZ: emergency stop active: release it, then initialise (i) and reference (h)"]
    );
}

#[test]
fn a_controller_left_storing_a_program_is_read_back_again() {
    let mut h = Harness::new();
    h.connect();
    h.expect_text("@0P");
    h.reply(b"8");
    h.advance(ms(60));
    // The line settles, then the read-back starts over.
    h.advance(ms(20));
    h.readback(0, 0, 0, b"0");
    assert_eq!(h.state().program, ProgramState::Invalid);
}

#[test]
fn initialise_sets_axes_ramp_and_reference_speeds_then_probes() {
    let mut h = Harness::new();
    h.connect();
    h.expect_text("@0P");
    h.reply(b"4");
    h.advance(ms(60));
    for port in ["@0b1", "@0b2", "@0b3"] {
        h.expect_text(port);
        h.reply(if port == "@0b2" {
            b"0E2"
        } else if port == "@0b1" {
            b"003"
        } else {
            b"000"
        });
    }
    h.request(Request::Initialise);
    h.expect_text("@07");
    h.reply(b"0");
    h.expect_text("@0j300");
    h.reply(b"0");
    h.expect_text("@0J100");
    h.reply(b"0");
    h.expect_text("@0d4000,4000,4000");
    h.reply(b"0");
    h.expect_text("@0A0,300,0,300,0,300,0,300");
    h.reply(b"R");
    h.expect_text("@0P");
    h.reply(&position_reply(1, 2, 3));
    h.expect_nothing();
    let s = h.state();
    assert_eq!(s.initialised, AxisSet::XYZ);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    // The axis setting keeps the virtual zero, which jogterm does not know.
    assert_eq!(s.work_zero.axes(), AxisSet::EMPTY);
}

#[test]
fn initialise_a_four_axis_machine_switches_a_on_separately() {
    let mut h = Harness::with(|s| {
        s.config = crate::proto::isel::AxisConfig::XYZA;
        let x = s.limits(Axis::X).expect("X");
        s.axes.set(Axis::A, x);
    });
    h.connect();
    h.expect_text("@0P");
    h.reply(b"4");
    h.advance(ms(60));
    for reply in [b"003", b"0E2", b"000"] {
        h.send();
        h.reply(reply);
    }
    h.request(Request::Initialise);
    h.expect_text("@07");
    h.reply(b"0");
    h.expect_text("@08");
    h.reply(b"0");
    h.expect_text("@0j300");
    h.reply(b"0");
    h.expect_text("@0J100");
    h.reply(b"0");
    h.expect_text("@0d4000,4000,4000,4000");
    h.reply(b"0");
    h.expect_text("@0A0,300,0,300,0,300,0,300");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(b"0000000000000000000000000");
    assert_eq!(h.state().referenced, AxisSet::XYZA);
}

#[test]
fn no_motion_command_is_repeated_after_a_reconnect() {
    let mut h = Harness::ready();
    h.request(Request::Step {
        delta: xyz(400, 0, 0),
        speed_hz: speeds(1000.0),
    });
    h.expect_text("@0A400,1000,0,300,0,300,0,300");
    h.driver.disconnected("unplugged", h.now);
    h.take_events();
    h.advance(ms(500));
    h.connect();
    // Only the read-back: the step is gone for good.
    h.readback(400, 0, 0, b"0");
    h.expect_nothing();
    assert!(
        h.events.iter().all(|e| !matches!(e, Event::Refused { .. })),
        "the step was not queued again"
    );
}

#[test]
fn requests_while_disconnected_are_refused() {
    let mut h = Harness::new();
    h.request(Request::Initialise);
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["initialise: not connected to the controller: wait for the link"]
    );
    assert!(matches!(
        h.events.iter().find_map(|e| match e {
            Event::Refused { reason, .. } => Some(reason.clone()),
            _ => None,
        }),
        Some(Refusal::NotConnected)
    ));
}

/// A move still running when the link came up answers the connect's 0xFD
/// with `F`: the operator is told the machine was moving and was stopped,
/// and only bytes that mean nothing are called unexpected.
#[test]
fn a_move_stopped_by_the_connect_is_reported_as_stopped_not_as_noise() {
    let notices = notices_after_a_connect_answered(b"F");
    assert!(
        notices
            .iter()
            .any(|n| n.starts_with("the controller was still moving when the link came up")),
        "{notices:?}"
    );
    assert!(
        !notices.iter().any(|n| n.starts_with("unexpected bytes")),
        "{notices:?}"
    );
}

#[test]
fn noise_after_the_connect_is_still_called_unexpected() {
    let notices = notices_after_a_connect_answered(b"Fxy");
    assert!(
        notices
            .iter()
            .any(|n| n == "unexpected bytes from the controller: xy"),
        "{notices:?}"
    );
}

/// The notices of a connect whose stop sequence was answered with `answer`
/// during the settle, once the state is read back.
fn notices_after_a_connect_answered(answer: &[u8]) -> Vec<String> {
    let mut h = Harness::new();
    h.driver.connected(h.now);
    h.collect();
    h.expect(&[0xFD, 0xFF]);
    h.reply(answer);
    h.advance(ms(100));
    h.expect_text("@0T0");
    h.reply(b"0");
    h.readback(0, 0, 0, b"0");
    h.notices()
}

#[test]
fn every_connect_switches_test_mode_off_first_and_quietly() {
    // Test mode cannot be read back, and a controller left in it passes the
    // reference probe (manual 2.2.24): `@0T0` before the read-back.
    let mut h = Harness::new();
    h.connect_stop();
    h.expect_text("@0T0");
    h.reply(b"0");
    h.readback(0, 0, 0, b"0");
    let notices = h.notices().join("\n");
    assert!(!notices.contains("test mode"), "{notices}");
    // And again on every new link: the controller was out of sight.
    h.driver.disconnected("cable pulled", h.now);
    h.collect();
    h.connect_stop();
    h.expect_text("@0T0");
}

#[test]
fn a_refused_test_mode_off_is_said_with_what_it_means() {
    let mut h = Harness::new();
    h.connect_stop();
    h.expect_text("@0T0");
    h.reply(b"3");
    h.expect_text("@0P");
    let notices = h.notices().join("\n");
    assert!(notices.contains("test mode may still be on"), "{notices}");
}

#[test]
fn a_profile_that_allows_test_mode_leaves_it_as_it_is() {
    let mut h = Harness::with(|s| s.test_mode_allowed = true);
    h.connect_stop();
    h.expect_text("@0P");
}

#[test]
fn an_unanswered_test_mode_off_is_a_dead_link_like_any_unanswered_command() {
    // Every isel command answers a handshake character (manual 2.2): silence
    // after `@0T0` is a dead line, and the task reconnects with the stop
    // first, as after an unanswered `@0P`.
    let mut h = Harness::new();
    h.connect_stop();
    h.expect_text("@0T0");
    h.advance(ms(1000));
    let lost = h.events.iter().find_map(|e| match e {
        crate::device::api::Event::Link(crate::device::api::LinkState::Lost { reason }) => {
            Some(reason.clone())
        }
        _ => None,
    });
    assert_eq!(lost.as_deref(), Some("no reply to @0T0 within 103 ms"));
    h.expect_nothing();
}
