//! Whatever arrives, whenever: the driver never panics and never sends a
//! motion line nobody asked for.

use proptest::prelude::*;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, JogId, PerAxis, Request};
use crate::device::common::PollRate;
use crate::device::driver::Driver;

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
                Just(b'@'),
                Just(b'X'),
                Just(b'L'),
                Just(b'0'),
                Just(b'1'),
                Just(0x02),
                Just(0x03),
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
        5 => Request::Raw { line: "@LX".into() },
        6 => Request::Raw {
            line: "L1,x10\u{1}".into(),
        },
        7 => Request::Upload {
            lines: vec!["W10".into(), "L1,x100".into()],
            erase_first: false,
        },
        8 => Request::RunProgram,
        9 => Request::Reset,
        10 => Request::SetZero { axes: AxisSet::XYZ },
        _ => Request::Raw { line: "@B".into() },
    }
}

/// A line that can start motion when it arrives: a move or reference run
/// ended by 0x01 (or a line that runs the data memory), `@J`, `@C`.
fn may_start_motion(bytes: &[u8]) -> bool {
    bytes.starts_with(b"@J") || bytes.starts_with(b"@C") || bytes.last() == Some(&0x01)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn the_driver_survives_any_conversation(actions in proptest::collection::vec(action(), 1..120)) {
        let mut h = Harness::with(|s| s.poll.rate = PollRate::LineSpeed);
        h.connect();
        let mut written_pending = 0usize;
        // Lines that may start motion the requests so far may cause: a
        // step, a jog, a home, a raw move, a job run are one each; the
        // initialise's `#R…<01>` and an upload's last line run nothing
        // that moves but end with 0x01 too.
        let mut budget = 0usize;
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
                    if r.may_move() || matches!(r, Request::Initialise | Request::Upload { .. }) {
                        budget += 1;
                    }
                    h.request(r);
                }
                Action::Disconnect => {
                    h.driver.disconnected("test", h.now);
                    written_pending = 0;
                }
                Action::Connect => {
                    h.driver.connected(h.now);
                    written_pending = 0;
                }
            }
            while let Some(out) = h.take() {
                written_pending += 1;
                // A bare 0x01 ends a job transfer; it starts nothing.
                if may_start_motion(&out) && out != [0x01] {
                    prop_assert!(
                        budget > 0,
                        "unrequested motion {:?}",
                        String::from_utf8_lossy(&out)
                    );
                    budget -= 1;
                }
            }
        }
    }
}
