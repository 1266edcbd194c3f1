//! Check-out lines (`Request::Checkout`) against the simulator: held by a
//! lease, paused with 0xFD alone when it runs out or the key is let go,
//! resumed with `@0S` to the exact end, and never resumed when the rest is
//! gone.

use std::time::Duration;

use crate::device::api::{CheckoutEnd, Event, JogId, Request};
use crate::device::isel::PollRate;

use super::harness::ms;
use super::with_sim::{Bench, IselBench, homed};

fn ends(b: &Bench) -> Vec<(u64, CheckoutEnd)> {
    b.events
        .iter()
        .filter_map(|e| match e {
            Event::Checkout { id, end } => Some((id.0, end.clone())),
            _ => None,
        })
        .collect()
}

fn line(id: u64, text: &str, resume: Option<u64>) -> Request {
    Request::Checkout {
        id: JogId(id),
        line: text.into(),
        lease: ms(150),
        resume: resume.map(JogId),
        read_back: true,
    }
}

/// Renew line `id` every 33 ms for `d`.
fn hold(b: &mut Bench, id: u64, d: Duration) {
    let mut t = Duration::ZERO;
    while t < d {
        b.run(ms(33));
        b.request(Request::JogRenew {
            id: JogId(id),
            lease: ms(150),
        });
        t += ms(33);
    }
}

#[test]
fn a_line_held_to_its_end_is_done_and_nothing_else_is_sent() {
    let mut b = homed(PollRate::Off);
    b.request(line(1, "@0A2000,2000,0,2000,0,2000,0,2000", None));
    hold(&mut b, 1, Duration::from_millis(1300));
    b.run(ms(300));
    assert_eq!(ends(&b), [(1, CheckoutEnd::Done { byte: None })]);
    assert_eq!(b.counters()[0], 2000.0);
    let after = sent_after(&b, "@0A2000");
    assert_eq!(after, ["@0P<CR>"], "{after:?}");
}

#[test]
fn a_line_let_go_pauses_with_0xfd_alone_and_at_0s_finishes_it_exactly() {
    let mut b = homed(PollRate::Off);
    // 4000 steps at 2000 Hz: 2 s.
    b.request(line(1, "@0A4000,2000,0,2000,0,2000,0,2000", None));
    hold(&mut b, 1, ms(800));
    // The repeats stop: the lease runs out and the move pauses.
    b.run(ms(800));
    assert_eq!(
        ends(&b),
        [(
            1,
            CheckoutEnd::Paused {
                dead_man: true,
                rest: true
            }
        )]
    );
    let stopped_at = b.counters()[0];
    assert!(stopped_at > 500.0 && stopped_at < 4000.0, "{stopped_at}");
    let fd = b
        .sent
        .iter()
        .position(|s| s == &vec![0xFD])
        .expect("0xFD sent");
    assert!(
        !b.sent[fd..].iter().any(|s| s.contains(&0xFF)),
        "no break: {:?}",
        b.sent_text()
    );
    // The position was read while paused.
    assert_eq!(
        b.last_measured().and_then(|p| p.get(crate::axis::Axis::X)),
        Some(stopped_at as i64)
    );
    b.run(ms(500));
    assert_eq!(b.counters()[0], stopped_at, "it stays paused");
    b.events.clear();
    b.request(line(2, "@0A4000,2000,0,2000,0,2000,0,2000", Some(1)));
    hold(&mut b, 2, Duration::from_millis(2500));
    b.run(ms(200));
    assert_eq!(ends(&b), [(2, CheckoutEnd::Done { byte: None })]);
    assert_eq!(b.counters()[0], 4000.0, "no step lost");
    assert!(b.sent_text().iter().any(|s| s.starts_with("@0S")));
}

#[test]
fn a_release_pauses_at_once_and_a_resume_after_anything_else_is_refused() {
    let mut b = homed(PollRate::Off);
    b.request(line(1, "@0A4000,2000,0,2000,0,2000,0,2000", None));
    hold(&mut b, 1, ms(400));
    b.request(Request::JogRelease { id: JogId(1) });
    b.run(ms(400));
    assert_eq!(
        ends(&b),
        [(
            1,
            CheckoutEnd::Paused {
                dead_man: false,
                rest: true
            }
        )]
    );
    // Another command runs: the rest is no longer the check-out's to resume
    // (an `@0S` now could start a stored program, manual 2.2.23).
    b.request(Request::Raw { line: "@0P".into() });
    b.run(ms(200));
    b.events.clear();
    b.request(line(2, "@0A4000,2000,0,2000,0,2000,0,2000", Some(1)));
    b.run(ms(200));
    assert!(
        matches!(ends(&b)[..], [(2, CheckoutEnd::Refused(_))]),
        "{:?}",
        ends(&b)
    );
    assert!(!b.sent_text().iter().any(|s| s.starts_with("@0S")));
}

#[test]
fn a_stop_breaks_the_line_off_and_keeps_nothing() {
    let mut b = homed(PollRate::Off);
    b.request(line(1, "@0A4000,2000,0,2000,0,2000,0,2000", None));
    hold(&mut b, 1, ms(400));
    b.stop();
    b.run(ms(500));
    assert_eq!(ends(&b), [(1, CheckoutEnd::Stopped)]);
    b.events.clear();
    b.request(line(2, "@0A4000,2000,0,2000,0,2000,0,2000", Some(1)));
    b.run(ms(200));
    assert!(matches!(ends(&b)[..], [(2, CheckoutEnd::Refused(_))]));
}

#[test]
fn a_line_the_controller_refuses_ends_with_its_code() {
    let mut b = homed(PollRate::Off);
    // 50 000 Hz is outside 1..=40000: `D` (chapter 5), or refused before
    // it is sent.
    b.request(line(1, "@0A100,50000,0,900,0,900,0,900", None));
    hold(&mut b, 1, ms(300));
    let e = ends(&b);
    match &e[..] {
        [(1, CheckoutEnd::Fault(f))] => assert_eq!(f.code, "D"),
        [(1, CheckoutEnd::Refused(_))] => {}
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_port_read_answers_its_byte() {
    let mut b = homed(PollRate::Off);
    b.request(line(1, "@0b1", None));
    b.run(ms(200));
    assert!(matches!(
        ends(&b)[..],
        [(1, CheckoutEnd::Done { byte: Some(_) })]
    ));
}

/// A stream's line (`read_back: false`).
/// What went out after the first line that starts with `command`.
fn sent_after(b: &Bench, command: &str) -> Vec<String> {
    let text = b.sent_text();
    let at = text
        .iter()
        .position(|s| s.starts_with(command))
        .expect("sent");
    text[at + 1..].to_vec()
}

fn streamed(id: u64, text: &str) -> Request {
    match line(id, text, None) {
        Request::Checkout {
            id,
            line,
            lease,
            resume,
            ..
        } => Request::Checkout {
            id,
            line,
            lease,
            resume,
            read_back: false,
        },
        other => other,
    }
}

#[test]
fn a_streamed_move_with_a_known_end_sends_no_position_read_and_says_its_target() {
    let mut b = homed(PollRate::Off);
    b.events.clear();
    b.request(streamed(1, "@0A2000,2000,0,2000,0,2000,0,2000"));
    hold(&mut b, 1, Duration::from_millis(1300));
    b.run(ms(300));
    assert_eq!(ends(&b), [(1, CheckoutEnd::Done { byte: None })]);
    assert_eq!(b.counters()[0], 2000.0);
    let after = sent_after(&b, "@0A2000");
    assert!(after.is_empty(), "no @0P after it: {after:?}");
    // The position the driver takes is the move's end: the counters'.
    let last = b
        .events
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::Position(p) => Some(p.steps.get(crate::axis::Axis::X)),
            _ => None,
        })
        .flatten();
    assert_eq!(last, Some(2000));
    // A second move from there is as exact: relative to the known end.
    b.request(streamed(2, "@0A-500,2000,0,2000,0,2000,0,2000"));
    hold(&mut b, 2, Duration::from_millis(800));
    b.run(ms(300));
    assert_eq!(b.counters()[0], 1500.0);
    let after = sent_after(&b, "@0A-500");
    assert!(after.is_empty(), "no @0P after it: {after:?}");
}

#[test]
fn a_streamed_move_paused_is_still_read_back() {
    let mut b = homed(PollRate::Off);
    b.request(streamed(1, "@0A4000,2000,0,2000,0,2000,0,2000"));
    hold(&mut b, 1, ms(800));
    b.run(ms(800));
    assert!(matches!(
        ends(&b)[..],
        [(1, CheckoutEnd::Paused { rest: true, .. })]
    ));
    let stopped_at = b.counters()[0];
    // The end is not the target: the position is read.
    assert_eq!(
        b.last_measured().and_then(|p| p.get(crate::axis::Axis::X)),
        Some(stopped_at as i64)
    );
}
