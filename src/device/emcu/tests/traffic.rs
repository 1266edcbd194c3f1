//! The facts the traffic records carry (`docs/device.md`, "Traffic"):
//! whose each line is, and where the interface's answers end.

use crate::device::api::Request;
use crate::device::common::PollRate;
use crate::device::driver::Driver;
use crate::traffic::Owner;

use super::harness::Harness;

#[test]
fn the_connect_halt_is_two_stop_lines_and_their_acks_are_the_stops() {
    let mut h = Harness::new();
    h.driver.connected(h.now);
    h.collect();
    h.expect(b"\r@B\r");
    assert_eq!(h.last_owner(), Some((Owner::Stop, vec![1, 4])));
    h.reply(b"\r\r");
    assert_eq!(h.reply_ends(), [(1, Owner::Stop), (2, Owner::Stop)]);
    let emergency = h.driver.emergency_stop();
    assert_eq!(emergency.bytes, b"\r@B\r");
    assert_eq!(emergency.messages, h.outgoing[0].messages);
}

#[test]
fn polls_are_the_polls_a_typed_query_the_operators_a_ready_line_the_interfaces() {
    let mut h = Harness::with(|s| {
        s.poll.rate = PollRate::LineSpeed;
        s.poll.ports_every = 1000;
    });
    h.connect();
    h.readback("000000", 0, 0, 0);
    h.expect_text("@LX");
    assert_eq!(h.last_owner(), Some((Owner::Poll, vec![4])));
    // The answer, then a run's end the interface reports on its own.
    h.reply(b"@LX0\r\x02\r");
    assert_eq!(h.reply_ends(), [(5, Owner::Poll), (7, Owner::Controller)]);
    h.request(Request::Raw { line: "@LX".into() });
    // The poll cycle goes on first (`@LY`, `@LZ`), or the typed query.
    let mut typed = false;
    for _ in 0..4 {
        let Some(sent) = h.send() else { break };
        let (owner, _) = h.last_owner().expect("an owner");
        let text = String::from_utf8_lossy(&sent).into_owned();
        if owner == Owner::User {
            assert_eq!(text, "@LX\r");
            h.reply(b"@LX0\r");
            assert_eq!(h.reply_ends(), [(5, Owner::User)]);
            typed = true;
            break;
        }
        assert_eq!(owner, Owner::Poll, "{text}");
        h.reply(format!("{}0\r", text.trim_end()).as_bytes());
    }
    assert!(typed, "the typed query went out");
}

#[test]
fn the_halt_and_its_ack_are_the_stops_garbage_the_interfaces() {
    let mut h = Harness::ready();
    let out = h.driver.stop(h.now);
    assert_eq!(out.bytes, b"@B\r");
    assert_eq!(
        out.messages
            .iter()
            .map(|m| (m.end, m.owner))
            .collect::<Vec<_>>(),
        [(3, Owner::Stop)]
    );
    h.reply(b"\r");
    assert_eq!(h.reply_ends(), [(1, Owner::Stop)]);
    h.reply(b"zz\r");
    assert_eq!(h.reply_ends(), [(3, Owner::Controller)]);
}
