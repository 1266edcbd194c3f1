//! Faults: missing replies, garbage, unsolicited frames, a rejected move,
//! a link lost mid-jog. The right event and recovery, no panic, no hang, no
//! motion command sent twice.

use std::time::Duration;

use crate::axis::Axis;
use crate::device::api::{Dir, Event, JogEnd, JogId, LinkState, Recovery, Request};
use crate::device::driver::Driver;

use super::harness::{Harness, frame, ms, x_speed};

fn jog(id: u64) -> Request {
    Request::Jog {
        id: JogId(id),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: x_speed(2240.0),
        lease: Duration::from_millis(750),
    }
}

#[test]
fn a_reply_that_never_comes_loses_the_link() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.poll();
    h.expect_frame("2C 11 00 00 00000000");
    // Round trip 10.45 ms for this and one queued stop, plus 100 ms.
    h.advance(ms(110));
    assert!(h.faults().is_empty());
    h.advance(ms(20));
    let faults = h.faults();
    assert!(
        faults.len() == 1 && faults[0].ends_with(" timeout"),
        "{faults:?}"
    );
    assert!(
        h.events
            .iter()
            .any(|e| matches!(e, Event::Link(LinkState::Lost { .. })))
    );
    assert!(!h.state().link_up);
    h.expect_nothing();
}

fn link_lost(h: &Harness) -> bool {
    h.events
        .iter()
        .any(|e| matches!(e, Event::Link(LinkState::Lost { .. })))
}

/// As the isel and EMCU drivers do: once an answer's bytes flow, it may
/// take the rest of its frame (and the margin) from there. A busy machine
/// that delivers the first half of a frame just before the deadline is not
/// a dead link.
#[test]
fn an_answer_that_is_arriving_at_its_deadline_is_not_overdue() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.poll();
    h.expect_frame("2C 11 00 00 00000000");
    h.advance(ms(110));
    let answer = frame("2D 11 00 22 00000100");
    h.reply(&answer[..8]);
    h.advance(ms(20));
    assert!(!link_lost(&h), "{:?}", h.faults());
    h.reply(&answer[8..]);
    assert!(h.faults().is_empty() && h.state().link_up);
    // The next one that stays silent still loses the link in time.
    h.expect_frame("40 11 01 00 00000000");
    h.advance(ms(130));
    assert!(link_lost(&h));
}

/// The wait for the first answer starts when the frame is on the line (the
/// writer's report), not when it was handed over: a writer that a busy
/// machine held up does not eat the controller's time.
#[test]
fn the_answer_time_counts_from_the_frame_on_the_line() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.poll();
    assert!(h.take().is_some(), "a poll");
    h.advance(ms(60));
    h.written();
    h.advance(ms(110));
    assert!(!link_lost(&h), "{:?}", h.faults());
    h.advance(ms(20));
    assert!(link_lost(&h));
}

#[test]
fn garbage_is_reported_and_polling_goes_on() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.poll();
    h.expect_frame("2C 11 00 00 00000000");
    h.reply(b"2D11xx\x1a");
    assert!(h.notices().iter().any(|n| n.starts_with("framing error")));
    // The answer itself never came: the link is declared dead after its
    // deadline, not before.
    h.answer("2D 11 00 22 00000010");
    h.expect_frame("40 11 01 00 00000000");
}

#[test]
fn an_unsolicited_frame_is_ignored_with_a_notice() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.answer("27 11 00 22 00000000");
    assert!(
        h.notices()
            .iter()
            .any(|n| n.starts_with("unexpected frame"))
    );
    assert_eq!(h.state().referenced, crate::axis::AxisSet::EMPTY);
    h.expect_nothing();
}

#[test]
fn a_rejected_move_ends_the_jog_and_reports_the_code() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.request(jog(1));
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 00 0B 00000000");
    h.answer("2B 11 00 EE 00000000");
    // The drive may be moving after all: stop it, then ask why.
    h.expect_frame("08 11 00 00 00000000");
    h.expect_nothing();
    h.answer("09 11 00 22 00000000");
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 22 00000005");
    h.expect_nothing();
    assert!(matches!(h.jog_ends().as_slice(), [(1, JogEnd::Fault(_))]));
    let s = h.state();
    assert_eq!(s.fault.map(|f| f.recovery), Some(Recovery::Reference));
    assert!(!s.referenced.contains(Axis::X));
    assert!(h.faults().iter().any(|f| f.ends_with("EE 05")));
}

#[test]
fn a_link_lost_mid_jog_ends_it_and_nothing_is_sent_again() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.request(jog(2));
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 00 0B 00000000");
    h.driver.disconnected("port vanished", h.now);
    h.collect();
    assert_eq!(h.jog_ends(), vec![(2, JogEnd::LinkLost)]);
    h.expect_nothing();
    h.advance(ms(500));
    h.driver.connected(h.now);
    h.collect();
    // The stop first, then the read-back; the jog is not resumed.
    h.expect_frame("08 11 00 00 00000000");
    h.answer("09 11 00 22 00000000");
    h.advance(ms(50));
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 22 00000000");
    h.expect_frame("2C 11 00 00 00000000");
    h.answer("2D 11 00 22 000F4300");
    h.expect_frame("40 11 01 00 00000000");
    h.answer("41 11 00 22 00000000");
    h.expect_nothing();
    let moves = h.sent.iter().filter(|m| m.starts_with(b"2A1100")).count();
    assert_eq!(moves, 1);
    // The drive stayed on: it keeps its reference.
    assert!(h.state().referenced.contains(Axis::X));
}

#[test]
fn a_stale_answer_after_reconnecting_falls_into_the_quiet() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.driver.disconnected("gone", h.now);
    h.driver.connected(h.now);
    h.collect();
    h.events.clear();
    h.expect_frame("08 11 00 00 00000000");
    h.reply(&frame("2D 11 00 22 00000010"));
    h.answer("09 11 00 22 00000000");
    assert!(h.notices().is_empty(), "{:?}", h.notices());
}

#[test]
fn upload_reset_and_programs_are_refused_with_a_reason() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.request(Request::Upload {
        lines: vec!["x".into()],
        erase_first: false,
    });
    h.request(Request::RunProgram);
    h.request(Request::Reset);
    h.request(Request::Raw {
        line: "2C 11 00".into(),
    });
    h.expect_nothing();
    let r = h.refusals();
    assert_eq!(r.len(), 4, "{r:?}");
    assert!(r[0].contains("not an EMP request"), "{}", r[0]);
    assert!(r[1].contains("store no programs"));
    assert!(r[3].contains("no reset"));
}

/// The emergency stop (panic hook, hang-up, a signal) is written by another
/// thread between any two bytes of a frame on its way. Wherever it lands,
/// the drive's framing (a frame is exactly what lies between two EOFs)
/// reads the stop frame whole: it is never lost with the cut frame.
#[test]
fn an_emergency_stop_cut_into_a_frame_is_still_a_stop_of_its_own() {
    use crate::proto::emp::{FrameDecoder, Incoming};
    let h = Harness::emp(|_| {});
    let emergency = h.driver.emergency_stop().bytes;
    let stop = frame("08 11 00 00 00000000");
    let polled = frame("2C 11 00 00 00000000");
    for cut in 0..=polled.len() {
        let mut wire = polled[..cut].to_vec();
        wire.extend_from_slice(&emergency);
        wire.extend_from_slice(&polled[cut..]);
        let stops = FrameDecoder::new()
            .feed(&wire)
            .into_iter()
            .filter(|r| matches!(r, Ok(Incoming::Frame(f)) if f.encode()[..] == stop[..]))
            .count();
        assert_eq!(
            stops,
            1,
            "cut at {cut}: {}",
            crate::traffic::readable(&wire)
        );
    }
}

/// What makes a console a session that moves (issue 24): a typed read is no
/// motion; a positioning, homing or a frame that does not parse is.
#[test]
fn a_typed_read_frame_is_no_motion_a_typed_move_is() {
    let h = Harness::emp(|_| {});
    let raw = |line: &str| Request::Raw { line: line.into() };
    for line in [
        "2C 11 00 00 00000000",
        "40 11 01 00 00000000",
        "0A 11 00 00 00000000",
    ] {
        assert!(!h.driver.may_move(&raw(line)), "{line:?}");
    }
    for line in ["2A 11 01 00 000186A0", "26 11 00 00 00001404", "nonsense"] {
        assert!(h.driver.may_move(&raw(line)), "{line:?}");
    }
}
