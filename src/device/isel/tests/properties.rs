//! Whatever arrives, whenever: the driver never panics and never sends a
//! motion command nobody asked for.

use proptest::prelude::*;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, JogId, PerAxis, Request};
use crate::device::driver::Driver;
use crate::device::isel::PollRate;

use super::harness::{Harness, ms, speeds};

#[derive(Debug, Clone)]
enum Action {
    Bytes(Vec<u8>),
    Wait(u64),
    Written,
    Stop,
    Request(u8),
    Disconnect,
    Connect,
}

fn action() -> impl Strategy<Value = Action> {
    prop_oneof![
        4 => proptest::collection::vec(
            prop_oneof![
                Just(b'0'),
                Just(b'R'),
                Just(b'F'),
                Just(b'2'),
                Just(b'9'),
                Just(b'\r'),
                any::<u8>()
            ],
            0..30
        )
        .prop_map(Action::Bytes),
        3 => (0u64..2_000).prop_map(Action::Wait),
        3 => Just(Action::Written),
        1 => Just(Action::Stop),
        3 => any::<u8>().prop_map(Action::Request),
        1 => Just(Action::Disconnect),
        1 => Just(Action::Connect),
    ]
}

fn request(n: u8) -> Request {
    match n % 12 {
        0 => Request::Initialise,
        1 => Request::Home { axes: AxisSet::XYZ },
        2 => Request::Step {
            delta: PerAxis::new().with(Axis::X, i64::from(n) - 100),
            speed_hz: speeds(1_000.0),
        },
        3 => Request::Jog {
            id: JogId(u64::from(n)),
            axes: vec![(Axis::Y, Dir::Plus)],
            speed_hz: speeds(2_000.0),
            lease: ms(300),
        },
        4 => Request::JogRelease {
            id: JogId(u64::from(n)),
        },
        5 => Request::Raw { line: "@0P".into() },
        6 => Request::Raw {
            line: "@0A10,900,0,900,0,900,0,900".into(),
        },
        7 => Request::Upload {
            lines: vec!["133".into(), "0100,900,0,900,0,900,0,900".into()],
            erase_first: n.is_multiple_of(2),
        },
        8 => Request::RunProgram,
        9 => Request::Reset,
        10 => Request::SetZero { axes: AxisSet::XYZ },
        _ => Request::Raw {
            line: "\u{fd}".into(),
        },
    }
}

/// A motion command: relative, absolute, reference, start.
fn is_motion(bytes: &[u8]) -> bool {
    matches!(bytes, [b'@', _, b'A' | b'M' | b'R' | b'S', ..])
}

/// The reference probe: a relative move of zero steps on every axis.
fn is_probe(bytes: &[u8]) -> bool {
    let Some(params) = bytes
        .strip_prefix(b"@0A")
        .and_then(|p| p.strip_suffix(b"\r"))
    else {
        return false;
    };
    params
        .split(|b| *b == b',')
        .step_by(2)
        .all(|steps| steps == b"0")
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn the_driver_survives_any_conversation(actions in proptest::collection::vec(action(), 1..120)) {
        let mut h = Harness::with(|s| s.poll.rate = PollRate::LineSpeed);
        h.connect();
        let mut written_pending = 0usize;
        // Motion commands the requests so far may cause (a step, a jog, a
        // home of XYZ are one each; a raw move one; the probes of read-backs
        // are zero-step moves and do not count).
        let mut motion_budget = 0usize;
        for a in actions {
            match a {
                Action::Bytes(b) => h.reply(&b),
                Action::Wait(d) => h.advance(ms(d)),
                Action::Written => {
                    if written_pending > 0 {
                        h.written();
                        written_pending -= 1;
                    }
                }
                Action::Stop => {
                    h.stop();
                }
                Action::Request(n) => {
                    let r = request(n);
                    if r.may_move() {
                        motion_budget += 1;
                    }
                    h.request(r);
                }
                Action::Disconnect => {
                    h.driver.disconnected("test", h.now);
                    written_pending = 0;
                }
                Action::Connect => {
                    h.connect();
                    written_pending = 0;
                }
            }
            while let Some(out) = h.take() {
                written_pending += 1;
                if is_motion(&out) && !is_probe(&out) {
                    prop_assert!(
                        motion_budget > 0,
                        "unrequested motion {:?}",
                        String::from_utf8_lossy(&out)
                    );
                    motion_budget -= 1;
                }
            }
        }
    }
}
