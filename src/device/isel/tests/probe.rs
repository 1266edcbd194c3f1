//! The probe (`Request::Probe`, `probe_op`): two passes of `@0Z` (manual
//! 2.2.30) on the probe input in1.5, each followed by a read of the input
//! and of the position, then back to where it started; its refusals; a
//! stop during a pass.

use crate::axis::Axis;
use crate::device::api::{Activity, Dir, Event, JogId, ProbeEnd, ProbeMove, Request};

use super::harness::{Harness, ms, position_reply, xyz};

const ID: JogId = JogId(9);

fn probe_z() -> Request {
    Request::Probe {
        id: ID,
        probe: ProbeMove {
            axis: Axis::Z,
            dir: Dir::Minus,
            travel: 4000,
            fast_hz: 2000.0,
            slow_hz: 200.0,
        },
    }
}

fn ends(h: &mut Harness) -> Vec<ProbeEnd> {
    h.take_events()
        .into_iter()
        .filter_map(|e| match e {
            Event::ProbeEnded { id, end } if id == ID => Some(end),
            _ => None,
        })
        .collect()
}

/// A pass answered, then the input (`port1` as `@0b1` answers it) and the
/// position.
fn pass(h: &mut Harness, command: &str, port1: &[u8], z_after: i32) {
    h.expect_text(command);
    h.advance(ms(100));
    h.reply(b"0");
    h.expect_text("@0b1");
    h.reply(port1);
    h.expect_text("@0P");
    h.reply(&position_reply(40_000, 40_000, z_after));
}

const FREE: &[u8] = b"003";
const TOUCHED: &[u8] = b"023";

#[test]
fn a_fast_pass_a_back_off_until_released_and_a_slow_pass_then_back_up() {
    let mut h = Harness::ready_at(40_000, 40_000, 16_000);
    h.request(probe_z());
    h.expect_text("@0b1");
    h.reply(FREE);
    h.expect_text("@0P");
    h.reply(&position_reply(40_000, 40_000, 16_000));
    assert_eq!(h.state().activity, Activity::Probing);
    // Down until bit 5 of port 1 reads 1, at most the travel, fast.
    pass(&mut h, "@0Z1,32,32,2000,0,0,-4000", TOUCHED, 12_080);
    // Up until it reads 0, slowly, at most back to the start.
    pass(&mut h, "@0Z1,32,0,200,0,0,3920", FREE, 12_101);
    // Down again, slowly, as far as the fast pass went and a step.
    pass(&mut h, "@0Z1,32,32,200,0,0,-22", TOUCHED, 12_100);
    // Back to where it started, a plain move away from the surface.
    h.expect_text("@0A0,300,0,300,3900,2000,0,2000");
    h.advance(ms(2000));
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(40_000, 40_000, 16_000));
    h.expect_nothing();
    assert_eq!(
        ends(&mut h),
        [ProbeEnd::Touched {
            at: xyz(40_000, 40_000, 12_100),
            fast_stop: 12_080
        }]
    );
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn no_surface_within_the_travel_goes_back_and_says_so() {
    let mut h = Harness::ready_at(40_000, 40_000, 16_000);
    h.request(probe_z());
    h.expect_text("@0b1");
    h.reply(FREE);
    h.expect_text("@0P");
    h.reply(&position_reply(40_000, 40_000, 16_000));
    pass(&mut h, "@0Z1,32,32,2000,0,0,-4000", FREE, 12_000);
    h.expect_text("@0A0,300,0,300,4000,2000,0,2000");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(40_000, 40_000, 16_000));
    h.expect_nothing();
    assert_eq!(ends(&mut h), [ProbeEnd::NoTrip { travel: 4000 }]);
}

#[test]
fn a_probe_touched_before_it_moves_is_refused_with_nothing_moving() {
    let mut h = Harness::ready_at(40_000, 40_000, 16_000);
    let before = h.sent.len();
    h.request(probe_z());
    h.expect_text("@0b1");
    h.reply(TOUCHED);
    h.expect_nothing();
    let ended = ends(&mut h);
    assert!(
        matches!(&ended[..], [ProbeEnd::Refused(r)] if r.to_string().contains("reads touched")),
        "{ended:?}"
    );
    let after = h.sent.get(before..).unwrap_or_default();
    assert!(
        !after
            .iter()
            .any(|m| m.starts_with(b"@0Z") || m.starts_with(b"@0A"))
    );
}

#[test]
fn unreferenced_or_beyond_the_soft_limits_nothing_is_sent() {
    let mut h = Harness::new();
    h.connect();
    h.readback(40_000, 40_000, 16_000, b"R");
    h.expect_nothing();
    h.take_events();
    h.request(probe_z());
    h.expect_nothing();
    let ended = ends(&mut h);
    assert!(
        matches!(
            &ended[..],
            [ProbeEnd::Refused(
                crate::device::api::Refusal::NotReferenced { .. }
            )]
        ),
        "{ended:?}"
    );
    // 4000 steps down from Z 3000 leave the soft limits (Z 0).
    let mut h = Harness::ready_at(40_000, 40_000, 3000);
    h.request(probe_z());
    h.expect_nothing();
    let ended = ends(&mut h);
    assert!(
        matches!(
            &ended[..],
            [ProbeEnd::Refused(
                crate::device::api::Refusal::SoftLimit { .. }
            )]
        ),
        "{ended:?}"
    );
}

#[test]
fn a_stop_during_a_pass_ends_the_probe_and_nothing_resumes() {
    let mut h = Harness::ready_at(40_000, 40_000, 16_000);
    let before = h.sent.len();
    h.request(probe_z());
    h.expect_text("@0b1");
    h.reply(FREE);
    h.expect_text("@0P");
    h.reply(&position_reply(40_000, 40_000, 16_000));
    h.expect_text("@0Z1,32,32,2000,0,0,-4000");
    h.advance(ms(100));
    assert_eq!(h.stop(), vec![0xFD, 0xFF]);
    h.reply(b"F");
    h.advance(ms(200));
    h.expect_nothing();
    let ended = ends(&mut h);
    assert_eq!(ended, [ProbeEnd::Stopped]);
    let after = h.sent.get(before..).unwrap_or_default();
    assert!(
        !after.iter().any(|m| m.starts_with(b"@0A")),
        "no return after a stop"
    );
}
