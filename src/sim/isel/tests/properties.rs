//! Whatever arrives on the line and whatever the operator does, the model
//! neither panics nor falls behind its own deadlines, and it only ever
//! sends bytes a controller sends.

use std::time::Duration;

use proptest::prelude::*;

use super::Conv;
use crate::sim::{InputControl, SimDevice};

#[derive(Debug, Clone)]
enum Op {
    Bytes(Vec<u8>),
    Wait(u64),
    Set(&'static str, bool),
    Press(&'static str),
}

const LINES: &[&str] = &[
    "@07\r",
    "@03\r",
    "@08\r",
    "@0R7\r",
    "@0N7\r",
    "@0T1\r",
    "@0z1\r",
    "@0A3000,4000,-2000,3000,100,1000,-100,1000\r",
    "@0M-900,4000,900,4000,0,100,0,100\r",
    "@0Z0,4,4,600,0,0,3000\r",
    "@0f-1\r",
    "@0y400,1500,119,-141,141,-1,-1\r",
    "@0w400,1500,119,-141,141,-1,-1,50\r",
    "@0F1\r",
    "@0P\r",
    "@0b3\r",
    "@0H\r",
    "@0V\r",
    "@0S\r",
    "@0i\r",
    "3 0,0\r",
    "o0,0,1,-1\r",
    "0100,900,0,900,0,900,0,900\r",
    "2 65,-1\r",
    "9\r",
    "@0k\r",
    "@0IR7\r",
    "@0ID1\r",
    "@0IE0\r",
];

const INPUTS: &[&str] = &[
    "limit-x1",
    "limit-y2",
    "estop1",
    "hood",
    "key-switch",
    "in0.0",
    "in0.2",
    "probe",
    "overtemp",
];

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => prop::sample::select(LINES).prop_map(|l| Op::Bytes(l.as_bytes().to_vec())),
        1 => prop::collection::vec(any::<u8>(), 1..12).prop_map(Op::Bytes),
        1 => prop::sample::select(&[0xFDu8, 0xFE, 0xFF][..]).prop_map(|b| Op::Bytes(vec![b])),
        2 => (0u64..3000).prop_map(Op::Wait),
        1 => (prop::sample::select(INPUTS), any::<bool>()).prop_map(|(n, l)| Op::Set(n, l)),
        1 => prop::sample::select(&["start", "stop"][..]).prop_map(Op::Press),
    ]
}

fn reply_byte(b: u8) -> bool {
    b.is_ascii_graphic() || b == b' ' || b == b'\r' || b == b'\n'
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn any_traffic_and_any_operator_keep_the_model_sane(
        ops in prop::collection::vec(op(), 0..60)
    ) {
        let mut c = Conv::new();
        for op in ops {
            match op {
                Op::Bytes(bytes) => c.send_bytes(&bytes),
                Op::Wait(ms) => c.wait(Duration::from_millis(ms)),
                Op::Set(name, level) => {
                    let now = c.now;
                    c.sim
                        .control(&InputControl::Set { name: name.into(), level }, now)
                        .map_err(TestCaseError::fail)?;
                }
                Op::Press(name) => {
                    let now = c.now;
                    c.sim
                        .control(&InputControl::Press { name: name.into() }, now)
                        .map_err(TestCaseError::fail)?;
                }
            }
            let deadline = c.sim.next_deadline();
            prop_assert!(deadline.is_none_or(|d| d > c.now), "behind: {deadline:?}");
            let line = c.sim.describe(c.now);
            prop_assert!(!line.contains('\n'));
        }
        let sent = c.take();
        prop_assert!(sent.bytes().all(reply_byte), "{sent:?}");
    }
}
