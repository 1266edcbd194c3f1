//! Deadlines: a missing reply means a dead link; a garbled or cut reply is
//! dropped and the line must be quiet before the next command.

use crate::device::api::{Event, LinkState, Request};
use crate::device::isel::PollRate;
use crate::wire::LineSettings;

use super::harness::{Harness, ms, position_reply};

fn polling() -> Harness {
    let mut h = Harness::with(|s| {
        s.poll.rate = PollRate::LineSpeed;
        s.poll.ports.clear();
    });
    h.connect();
    h.readback(0, 0, 0, b"0");
    h.take_events();
    h
}

fn lost(h: &Harness) -> Option<String> {
    h.events.iter().find_map(|e| match e {
        Event::Link(LinkState::Lost { reason }) => Some(reason.clone()),
        _ => None,
    })
}

#[test]
fn a_query_waits_its_wire_time_plus_the_margin() {
    let mut h = polling();
    h.expect_text("@0P");
    // @0P CR and 19 bytes back at 19200 baud, plus 100 ms.
    let deadline = LineSettings::new(19200).transfer_time(23) + ms(100);
    h.advance(deadline - ms(1));
    assert_eq!(lost(&h), None);
    h.advance(ms(1));
    assert_eq!(lost(&h).as_deref(), Some("no reply to @0P within 111 ms"),);
    assert_eq!(h.faults(), ["@0P timeout"]);
    assert!(!h.state().link_up);
    // Dead: nothing more goes out until the task reconnects.
    h.expect_nothing();
}

#[test]
fn a_cut_reply_is_dropped_and_the_line_settles_first() {
    let mut h = polling();
    h.expect_text("@0P");
    let mut reply = position_reply(7, 7, 7);
    reply.remove(9);
    h.reply(&reply);
    h.advance(ms(120));
    assert_eq!(lost(&h), None, "bytes came: the link is alive");
    assert!(h.notices().iter().any(|n| n.contains("garbled")));
    h.advance(ms(10));
    h.expect_text("@0P");
}

#[test]
fn a_corrupted_byte_drops_the_reply_and_its_tail() {
    let mut h = polling();
    h.expect_text("@0P");
    let mut reply = position_reply(7, 7, 7);
    reply[5] ^= 0x80;
    h.reply(&reply[..8]);
    // The rest of the garbled reply arrives; it must not be taken for the
    // next reply.
    h.expect_nothing();
    h.advance(ms(3));
    h.reply(&reply[8..]);
    h.expect_nothing();
    h.advance(ms(9));
    h.expect_nothing();
    h.advance(ms(2));
    h.expect_text("@0P");
    h.reply(&position_reply(7, 7, 7));
    assert!(
        h.positions()
            .iter()
            .all(|p| p.steps == super::harness::xyz(7, 7, 7))
    );
}

#[test]
fn a_garbled_move_reply_leads_to_a_state_read_back() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: super::harness::xyz(100, 0, 0),
        speed_hz: super::harness::speeds(1_000.0),
    });
    h.expect_text("@0A100,1000,0,300,0,300,0,300");
    h.reply(&[b'0' ^ 0x80]);
    assert!(h.faults().iter().any(|f| f.ends_with("garbled reply")));
    h.advance(ms(10));
    h.readback(100, 0, 0, b"0");
}

#[test]
fn unsolicited_bytes_are_reported() {
    let mut h = Harness::ready();
    h.reply(b"xyz");
    assert!(
        h.notices()
            .iter()
            .any(|n| n == "unexpected bytes from the controller: xyz")
    );
}

#[test]
fn a_text_reply_ends_on_silence() {
    let mut h = Harness::ready();
    h.request(Request::Raw { line: "@0V".into() });
    h.expect_text("@0V");
    h.reply(b"iMC-S8 V1.0\r\n");
    h.advance(ms(30));
    h.reply(b"(c) isel\r\n");
    h.advance(ms(49));
    assert!(h.events.iter().all(|e| !matches!(e, Event::Reply { .. })));
    h.advance(ms(1));
    assert!(h.events.iter().any(|e| matches!(
        e,
        Event::Reply { command, text, .. } if command == "@0V" && text == "iMC-S8 V1.0\n(c) isel"
    )));
}

/// A session that was not asked to move (no connect halt), connected and
/// read back, whose first `@0P` has gone unanswered past its deadline.
fn unmoved_session_with_a_read_unanswered() -> Harness {
    use crate::device::driver::Driver;
    let mut h = Harness::with(|s| {
        s.poll.rate = PollRate::LineSpeed;
        s.poll.ports.clear();
    });
    h.driver.set_connect_halt(false);
    h.driver.connected(h.now);
    h.collect();
    h.advance(ms(100));
    h.expect_text("@0T0");
    h.reply(b"0");
    h.readback(0, 0, 0, b"0");
    h.take_events();
    h.expect_text("@0P");
    h.advance(ms(200));
    h
}

/// The driver said that the controller, busy so far, answers again.
fn assert_answers_again(h: &Harness) {
    use crate::device::api::ANSWERS_AGAIN_NOTICE;
    assert!(
        h.notices()
            .iter()
            .any(|n| n.starts_with(ANSWERS_AGAIN_NOTICE)),
        "{:?}",
        h.events
    );
}

/// Issue 24: a session that was not asked to move (no connect halt) takes
/// an unanswered read for a busy controller (a stored program runs, manual
/// 3.1), not a dead link: it says so once, sends nothing but the same read
/// again every 500 ms, and goes on when one is answered. A session that
/// has moved keeps the deadline (`a_query_waits_its_wire_time_plus_the_margin`).
#[test]
fn a_session_that_has_not_moved_waits_for_a_busy_controller_and_repeats_its_read() {
    use crate::device::api::BUSY_NOTICE;
    let mut h = unmoved_session_with_a_read_unanswered();
    assert_eq!(lost(&h), None);
    assert!(h.state().link_up);
    let busy: Vec<String> = h
        .notices()
        .into_iter()
        .filter(|n| n.starts_with(BUSY_NOTICE))
        .collect();
    assert_eq!(busy.len(), 1, "{:?}", h.events);
    assert!(busy[0].contains("no reply to @0P"), "{busy:?}");
    h.expect_nothing();
    for _ in 0..3 {
        h.advance(ms(500));
        h.expect_text("@0P");
        h.advance(ms(200));
    }
    assert_eq!(
        h.notices()
            .iter()
            .filter(|n| n.starts_with(BUSY_NOTICE))
            .count(),
        1,
        "said once"
    );
    h.advance(ms(500));
    h.expect_text("@0P");
    h.reply(&position_reply(5, 0, 0));
    assert_answers_again(&h);
    assert_eq!(lost(&h), None);
    assert_eq!(h.faults(), Vec::<String>::new());
}

/// A reply that comes after its deadline (a starved host, a slow
/// controller) to a read that is then repeated: it answers that read, and
/// the line must not be read one reply out of step afterwards.
#[test]
fn a_late_reply_to_a_repeated_read_answers_it_and_the_next_reply_stays_in_step() {
    use crate::device::api::BUSY_NOTICE;
    let mut h = unmoved_session_with_a_read_unanswered();
    assert!(h.notices().iter().any(|n| n.starts_with(BUSY_NOTICE)));
    // The answer arrives late, before the read is repeated.
    h.advance(ms(50));
    h.reply(&position_reply(5, 0, 0));
    h.advance(ms(20));
    let unexpected: Vec<String> = h
        .notices()
        .into_iter()
        .filter(|n| n.contains("unexpected"))
        .collect();
    assert_eq!(unexpected, Vec::<String>::new(), "{:?}", h.events);
    // Polling goes on in step: each reply is read as the answer to its read.
    for x in 6..9 {
        h.advance(ms(500));
        h.expect_text("@0P");
        h.reply(&position_reply(x, 0, 0));
        assert_eq!(
            h.positions().last().map(|p| p.steps),
            Some(super::harness::xyz(i64::from(x), 0, 0)),
            "{:?}",
            h.events
        );
    }
    assert_eq!(h.faults(), Vec::<String>::new());
    assert_eq!(lost(&h), None);
}

/// A late reply still arriving when its read is due to be repeated: the
/// repeat waits for it, so the two replies cannot overlap on the line.
#[test]
fn a_repeat_waits_for_a_late_reply_under_way() {
    let mut h = unmoved_session_with_a_read_unanswered();
    let reply = position_reply(5, 0, 0);
    h.advance(ms(490));
    h.reply(&reply[..8]);
    h.advance(ms(15));
    h.expect_nothing();
    h.reply(&reply[8..]);
    assert_answers_again(&h);
    assert_eq!(
        h.positions().last().map(|p| p.steps),
        Some(super::harness::xyz(5, 0, 0))
    );
    assert_eq!(h.faults(), Vec::<String>::new());
}
