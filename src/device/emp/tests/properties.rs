//! Whatever bytes arrive, in whatever pieces and at whatever times, and
//! whatever requests that do not ask for motion: no panic, and no frame
//! that could move an axis.

use std::time::Duration;

use proptest::prelude::*;

use crate::axis::{Axis, AxisSet};
use crate::device::api::Request;
use crate::device::driver::Driver;
use crate::proto::emp::Request as EmpFrame;

use super::harness::Harness;

fn requests() -> impl Strategy<Value = Request> {
    prop_oneof![
        Just(Request::Initialise),
        Just(Request::SetZero {
            axes: AxisSet::EMPTY.with(Axis::X)
        }),
        Just(Request::Poll {
            rate_hz: None,
            ports_every: 2
        }),
        Just(Request::Raw {
            line: "2C 11 00 00 00000000".into()
        }),
        Just(Request::Raw {
            line: "0A1100000000000".into()
        }),
    ]
}

fn moves(bytes: &[u8]) -> bool {
    let hex: Vec<u8> = bytes.iter().copied().filter(|b| *b != 0x1A).collect();
    let Ok(text) = std::str::from_utf8(&hex) else {
        return false;
    };
    text.parse::<EmpFrame>().is_ok_and(|f| f.command.may_move())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn any_input_no_panic_no_motion(
        steps in prop::collection::vec(
            (prop::collection::vec(any::<u8>(), 0..40), 0u64..80, prop::option::of(requests())),
            1..60
        ),
        answers in prop::collection::vec("[0-9A-F]{16}", 0..20),
    ) {
        let mut h = Harness::emp(|_| {});
        h.driver.connected(h.now);
        let mut answers = answers.into_iter();
        for (bytes, wait, request) in steps {
            if let Some(r) = request {
                h.request(r);
            }
            while let Some(out) = h.take() {
                prop_assert!(!moves(&out), "sent {:?}", String::from_utf8_lossy(&out));
                h.written();
            }
            h.reply(&bytes);
            if let Some(a) = answers.next() {
                let mut f = a.into_bytes();
                f.push(0x1A);
                h.reply(&f);
            }
            h.advance(Duration::from_millis(wait));
        }
        let _ = h.driver.stop(h.now);
    }
}
