//! Check-out lines on an EMCU against the simulator: held by a lease, the
//! move halted (`@B`) when it runs out, what is left of it sent after, to
//! the exact end.

use std::time::Duration;

use crate::device::api::{CheckoutEnd, Event, JogId, Request};
use crate::device::common::PollRate;

use super::harness::ms;
use super::with_sim::{Bench, counters, homed};

fn ends(b: &Bench) -> Vec<(u64, CheckoutEnd)> {
    b.events
        .iter()
        .filter_map(|e| match e {
            Event::Checkout { id, end } => Some((id.0, end.clone())),
            _ => None,
        })
        .collect()
}

fn line(id: u64, text: &str) -> Request {
    Request::Checkout {
        id: JogId(id),
        line: text.into(),
        lease: ms(150),
        resume: None,
        read_back: true,
    }
}

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
fn a_line_let_go_halts_and_what_is_left_of_it_ends_where_the_line_would() {
    let mut b = homed(PollRate::LineSpeed);
    b.request(line(1, "#E1,1000\u{1}"));
    b.run(ms(500));
    assert_eq!(ends(&b), [(1, CheckoutEnd::Done { byte: None })]);
    b.events.clear();
    // 4000 steps at 1000 Hz: 4 s.
    b.request(line(2, "L1,x4000\u{1}"));
    hold(&mut b, 2, ms(1500));
    b.run(ms(1500));
    assert_eq!(
        ends(&b),
        [(
            2,
            CheckoutEnd::Paused {
                dead_man: true,
                rest: false
            }
        )]
    );
    let at = counters(&mut b)[0];
    assert!(at > 0 && at < 4000, "{at}");
    b.run(ms(500));
    assert_eq!(counters(&mut b)[0], at, "it stands");
    b.events.clear();
    b.request(line(3, &format!("L1,x{}\u{1}", 4000 - at)));
    hold(&mut b, 3, Duration::from_secs(5));
    b.run(ms(500));
    assert_eq!(ends(&b), [(3, CheckoutEnd::Done { byte: None })]);
    assert_eq!(counters(&mut b)[0], 4000);
    // A release halts at once; a resume of a rest is refused: none is kept.
    b.events.clear();
    b.request(line(4, "L1,x-2000\u{1}"));
    hold(&mut b, 4, ms(600));
    b.request(Request::JogRelease { id: JogId(4) });
    b.run(ms(1500));
    assert!(matches!(
        ends(&b)[..],
        [(
            4,
            CheckoutEnd::Paused {
                dead_man: false,
                rest: false
            }
        )]
    ));
    b.events.clear();
    b.request(Request::Checkout {
        id: JogId(5),
        line: "L1,x-10\u{1}".into(),
        lease: ms(150),
        resume: Some(JogId(4)),
        read_back: true,
    });
    b.run(ms(200));
    assert!(matches!(ends(&b)[..], [(5, CheckoutEnd::Refused(_))]));
}
