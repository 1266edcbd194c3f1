//! The facts the traffic records carry (`docs/device.md`, "Traffic"):
//! whose each message is, and where the controller's answers end.

use crate::device::api::Request;
use crate::device::driver::Driver;
use crate::device::isel::{PollPlan, PollRate};
use crate::traffic::Owner;

use super::harness::{Harness, ms, position_reply};

/// Ready, polling the position at line speed.
fn polling_positions() -> Harness {
    let mut h = Harness::with(|s| {
        s.poll = PollPlan {
            rate: PollRate::LineSpeed,
            positions: true,
            ports_every: 0,
            ports: Vec::new(),
        };
    });
    h.connect();
    h.readback(0, 0, 0, b"0");
    h
}

#[test]
fn a_poll_and_its_answer_are_the_polls_a_typed_line_the_operators() {
    let mut h = polling_positions();
    h.expect_text("@0P");
    assert_eq!(h.last_owner(), Some((Owner::Poll, vec![4])));
    // A reply in two pieces ends where the decoder completes it.
    let reply = position_reply(1, 2, 3);
    h.reply(&reply[..5]);
    assert_eq!(h.reply_ends(), []);
    h.reply(&reply[5..]);
    assert_eq!(h.reply_ends(), [(reply.len() - 5, Owner::Poll)]);
    // The same command typed is the operator's, however it reads.
    h.request(Request::Raw { line: "@0P".into() });
    h.expect_text("@0P");
    assert_eq!(h.last_owner(), Some((Owner::User, vec![4])));
    h.reply(&reply);
    assert_eq!(h.reply_ends(), [(reply.len(), Owner::User)]);
}

#[test]
fn a_garbled_reply_is_the_controllers_not_the_polls() {
    let mut h = polling_positions();
    h.expect_text("@0P");
    let mut reply = position_reply(7, 7, 7);
    reply[5] ^= 0x80;
    h.reply(&reply);
    let ends = h.reply_ends();
    assert_eq!(
        ends.first(),
        Some(&(6, Owner::Controller)),
        "ended where the decoder found it garbled, shown: {ends:?}"
    );
    assert!(
        ends.iter().all(|(_, o)| *o == Owner::Controller),
        "{ends:?}"
    );
}

#[test]
fn a_text_reply_ends_a_message_per_line_and_stray_bytes_are_the_controllers() {
    let mut h = Harness::ready();
    h.request(Request::Raw { line: "@0V".into() });
    h.expect_text("@0V");
    h.reply(b"iMC-S8\r\nV2.0\r\n");
    assert_eq!(h.reply_ends(), [(8, Owner::User), (14, Owner::User)]);
    // Silence ends the reply (`Expect::TextUntilSilence`); what comes then
    // answers nothing.
    h.advance(ms(500));
    assert!(!h.replies().is_empty(), "the text reply was taken");
    h.reply(b"?\r\n");
    assert_eq!(h.reply_ends(), [(3, Owner::Controller)]);
}

#[test]
fn the_stop_sequence_is_a_message_per_control_byte() {
    let mut h = Harness::ready();
    let out = h.driver.stop(h.now);
    let ends: Vec<(usize, Owner)> = out.messages.iter().map(|m| (m.end, m.owner)).collect();
    assert_eq!(ends, [(1, Owner::Stop), (2, Owner::Stop)]);
    let emergency = h.driver.emergency_stop();
    assert_eq!(emergency.bytes, out.bytes);
    assert_eq!(emergency.messages, out.messages);
}

#[test]
fn a_planned_move_is_motion_and_its_answer_too() {
    use crate::axis::Axis;
    use crate::device::api::PerAxis;
    let mut h = Harness::ready();
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 100),
        speed_hz: super::harness::speeds(1_000.0),
    });
    let sent = h.send().expect("the move");
    assert!(
        sent.starts_with(b"@0A"),
        "{}",
        crate::traffic::readable(&sent)
    );
    assert_eq!(h.last_owner().map(|(o, _)| o), Some(Owner::Motion));
    h.reply(b"0");
    assert_eq!(h.reply_ends(), [(1, Owner::Motion)]);
}
