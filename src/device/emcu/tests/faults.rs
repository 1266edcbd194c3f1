//! What goes wrong on the line: answers that never come, garbled or out of
//! step, memory full, bytes nobody asked for, a run that does not end.

use crate::axis::Axis;
use crate::device::api::{Activity, Event, LinkState, PerAxis, Recovery, Request};
use crate::device::common::PollRate;
use crate::device::driver::Driver;

use super::harness::{Harness, ms, speeds};

#[test]
fn an_answer_that_never_comes_means_the_link_is_dead() {
    let mut h = Harness::ready();
    h.request(Request::Raw { line: "@X".into() });
    h.expect_text("@X");
    // 3 + 9 bytes at 19200 baud, 500 ms (manual 1.4.2), 100 ms margin.
    h.advance(ms(605));
    assert!(h.state().link_up);
    h.advance(ms(2));
    assert_eq!(h.faults(), ["@X timeout"]);
    assert!(h.events.iter().any(|e| matches!(
        e,
        Event::Link(LinkState::Lost { reason }) if reason.starts_with("no reply to @X")
    )));
    assert!(!h.state().link_up);
    let fault = h.events.iter().find_map(|e| match e {
        Event::Fault(f) => Some(f.clone()),
        _ => None,
    });
    assert_eq!(fault.map(|f| f.recovery), Some(Recovery::CheckLink));
}

#[test]
fn a_garbled_poll_answer_is_lost_and_polling_goes_on() {
    let mut h = Harness::with(|s| s.poll.rate = PollRate::LineSpeed);
    h.connect();
    h.readback("000000", 0, 0, 0);
    h.expect_text("@LX");
    h.reply(b"@LX1\xb32\r");
    h.expect_nothing();
    h.advance(ms(40));
    // The cycle is given up; the next starts.
    h.expect_text("@LX");
    assert!(h.state().link_up);
    assert!(
        h.notices().iter().any(|n| n.contains("was lost")),
        "{:?}",
        h.notices()
    );
}

#[test]
fn a_corrupted_ready_before_the_answer_does_not_cost_the_answer() {
    let mut h = Harness::ready();
    h.request(Request::Raw { line: "@LY".into() });
    h.expect_text("@LY");
    h.reply(b"\x82\r");
    h.reply(b"@LY-7\r");
    h.advance(ms(100));
    assert_eq!(
        h.replies(),
        [("@LY".to_owned(), "@LY-7: Y = -7 steps".to_owned())]
    );
}

#[test]
fn an_answer_cut_short_is_lost_not_a_dead_link() {
    let mut h = Harness::ready();
    h.request(Request::Raw { line: "@LX".into() });
    h.expect_text("@LX");
    h.reply(b"@LX12");
    h.advance(ms(700));
    assert!(h.state().link_up);
    assert_eq!(h.faults(), ["@LX garbled answer"]);
    h.request(Request::Raw { line: "@LX".into() });
    h.expect_text("@LX");
    h.reply(b"@LX15\r");
    assert_eq!(
        h.replies().last().map(|r| r.1.as_str()),
        Some("@LX15: X = 15 steps")
    );
}

#[test]
fn a_garbled_move_answer_halts_and_reads_the_state_back() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 1_000),
        speed_hz: speeds(400.0),
    });
    h.expect_text("#E9,400");
    h.reply(b"\r");
    h.expect(b"L9,x1000\x01");
    h.reply(b"\x8d");
    h.advance(ms(700));
    // Whether the move runs is unknown: it is watched, `@X` tells.
    h.expect_text("@X");
    h.reply(b"@X100001\r");
    h.reply(b"\x02\r");
    h.expect_text("@X");
    h.reply(b"@X000000\r");
    h.positions_read(1_000, 0, 0);
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn memory_full_waits_for_room_before_the_next_line() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 100),
        speed_hz: speeds(400.0),
    });
    h.expect_text("#E9,400");
    // Commands left in the memory filled it: it runs now.
    h.reply(b"\x03\r");
    h.expect_nothing();
    h.reply(b"\x02\r");
    h.expect(b"L9,x100\x01");
    h.reply(b"\r");
    h.run_ends();
    h.positions_read(100, 0, 0);
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn unsolicited_lines_are_reported_and_a_stray_ready_reads_the_status() {
    let mut h = Harness::ready();
    h.reply(b"\r");
    assert!(
        h.notices().iter().any(|n| n.contains("unexpected")),
        "{:?}",
        h.notices()
    );
    h.reply(b"\x02\r");
    h.expect_text("@X");
    h.reply(b"@X000100\r");
    // The positions were lost behind jogterm's back.
    assert_eq!(h.faults(), ["@X position unknown"]);
    assert_eq!(
        h.state().fault.map(|f| f.recovery),
        Some(Recovery::Reference)
    );
}

#[test]
fn a_move_that_does_not_end_in_time_is_halted() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 400),
        speed_hz: speeds(400.0),
    });
    h.expect_text("#E9,400");
    h.reply(b"\r");
    h.expect(b"L9,x400\x01");
    h.reply(b"\r");
    // About 1.2 s planned: checked every second, overdue after 2.5 s.
    for _ in 0..2 {
        h.advance(ms(1_000));
        h.expect_text("@X");
        h.reply(b"@X010001\r");
    }
    h.advance(ms(600));
    h.expect_text("@X");
    h.reply(b"@X010001\r");
    h.expect(b"@B\r");
    assert!(
        h.notices()
            .iter()
            .any(|n| n.contains("did not end in time")),
        "{:?}",
        h.notices()
    );
}

#[test]
fn stops_expect_their_own_cr() {
    let mut h = Harness::ready();
    h.request(Request::Raw { line: "@LZ".into() });
    h.expect_text("@LZ");
    h.stop();
    // The stop's CR comes after the answer: neither is out of step.
    h.reply(b"@LZ5\r\r");
    assert!(h.notices().is_empty(), "{:?}", h.notices());
    assert_eq!(h.replies().len(), 1);
    let _ = h.driver.next_timeout();
}

/// The emergency stop (panic hook, hang-up, a signal) is written by another
/// thread between any two bytes of a line on its way. Wherever it lands,
/// the interface, which ends a line at CR or 0x01 (manual 1.4.2), reads
/// `@B` as a line of its own: the stop is never lost in a malformed line.
#[test]
fn an_emergency_stop_cut_into_a_line_is_still_a_halt_of_its_own() {
    let h = Harness::new();
    let stop = h.driver.emergency_stop().bytes;
    for line in [&b"@LZ\r"[..], b"#E9,200\r", b"L9,x30000\x01"] {
        for cut in 0..=line.len() {
            let mut wire = line[..cut].to_vec();
            wire.extend_from_slice(&stop);
            wire.extend_from_slice(&line[cut..]);
            let halts = wire
                .split(|b| matches!(*b, b'\r' | 0x01))
                .filter(|l| *l == b"@B")
                .count();
            assert_eq!(
                halts,
                1,
                "cut at {cut}: {}",
                crate::traffic::readable(&wire)
            );
        }
    }
}
