//! The facts the traffic records and replies carry (`docs/device.md`,
//! "Traffic"): whose each frame is, which answer is a rejection, and a
//! long action's start told apart from its end.

use crate::device::api::{Event, ReplyKind, Request};
use crate::device::driver::Driver;
use crate::traffic::Owner;

use super::harness::{Harness, frame};

fn raw(line: &str) -> Request {
    Request::Raw { line: line.into() }
}

#[test]
fn polls_are_the_polls_their_rejections_marked_and_a_stray_frame_the_drives() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.poll();
    let sent = h.send().expect("a poll");
    assert_eq!(h.last_owner(), Some((Owner::Poll, vec![17])));
    let answer = if sent.starts_with(b"2C11") {
        "2D"
    } else {
        "41"
    };
    let mut wire = frame(&format!("{answer} 11 00 EE 00000000"));
    wire.extend(frame("2B 11 00 22 00000000"));
    h.reply(&wire);
    let ends: Vec<(usize, Owner, bool)> = h
        .ends
        .iter()
        .map(|m| (m.end, m.owner, m.rejected))
        .collect();
    assert_eq!(
        ends,
        [(17, Owner::Poll, true), (34, Owner::Controller, false)]
    );
}

#[test]
fn a_typed_long_action_is_started_then_answered() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.events.clear();
    h.request(raw("26 11 00 00 00140400"));
    h.expect_frame("26 11 00 00 00140400");
    assert_eq!(h.last_owner(), Some((Owner::User, vec![17])));
    h.answer("27 11 00 55 000F4240");
    assert_eq!(h.reply_ends(), [(17, Owner::User)]);
    h.answer("27 11 00 22 000F4240");
    let kinds: Vec<ReplyKind> = h
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Reply { kind, .. } => Some(*kind),
            _ => None,
        })
        .collect();
    assert_eq!(kinds, [ReplyKind::Started, ReplyKind::Answer]);
}

#[test]
fn the_stop_frames_are_a_message_each() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    let out = h.driver.stop(h.now);
    assert_eq!(
        out.messages
            .iter()
            .map(|m| (m.end, m.owner))
            .collect::<Vec<_>>(),
        [(17, Owner::Stop)]
    );
    let emergency = h.driver.emergency_stop();
    assert_eq!(
        emergency.messages.iter().map(|m| m.end).collect::<Vec<_>>(),
        [1, 18],
        "the EOF that ends a cut frame, then the stop frame"
    );
}
