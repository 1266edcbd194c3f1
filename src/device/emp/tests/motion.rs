//! Jogs, steps, go-to moves and reference runs as byte conversations.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Frame, JogEnd, JogId, PerAxis, Refusal, Request};
use crate::device::common::testing::refusal_reasons;

use super::harness::{Harness, ms, x_speed};

fn jog(id: u64, dir: Dir, hz: f64) -> Request {
    Request::Jog {
        id: JogId(id),
        axes: vec![(Axis::X, dir)],
        speed_hz: x_speed(hz),
        lease: Duration::from_millis(750),
    }
}

#[test]
fn reference_run_sets_the_mode_and_1_khz_then_waits_for_the_ready() {
    let mut h = Harness::emp(|_| {});
    h.ready(0);
    assert!(h.notices().iter().any(|n| n == "X referenced (drive 11)"));
    assert_eq!(h.state().activity, crate::device::api::Activity::Idle);
}

#[test]
fn a_velocity_jog_runs_until_released_then_holds() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    // 0.2 mm/s = 2240 counts/s: v = 11 at reload EFC7 (61383).
    h.request(jog(1, Dir::Minus, 2240.0));
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 00 F5 00000000");
    h.answer("2B 11 00 22 000F4240");
    h.expect_nothing();
    assert_eq!(h.state().activity, crate::device::api::Activity::Jogging);
    h.request(Request::JogRelease { id: JogId(1) });
    h.expect_frame("08 11 00 00 00000000");
    assert!(h.jog_ends().is_empty());
    h.answer("09 11 00 22 000F4000");
    h.expect_nothing();
    assert_eq!(h.jog_ends(), vec![(1, JogEnd::Released)]);
    assert_eq!(h.state().activity, crate::device::api::Activity::Idle);
}

#[test]
fn a_jog_without_renewal_stops_when_its_lease_runs_out() {
    let mut h = Harness::emp(|s| s.stop = crate::config::profile::EmpStop::Fast);
    h.ready(1_000_000);
    h.request(jog(2, Dir::Plus, 2240.0));
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 00 0B 00000000");
    h.answer("2B 11 00 22 000F4240");
    h.advance(ms(500));
    h.request(Request::JogRenew {
        id: JogId(2),
        lease: Duration::from_millis(150),
    });
    h.advance(ms(149));
    h.expect_nothing();
    h.advance(ms(1));
    // emp.stop = fast: 2A 03.
    h.expect_frame("2A 11 03 00 00000000");
    h.answer("2B 11 00 22 000F5000");
    h.expect_nothing();
    assert_eq!(h.jog_ends(), vec![(2, JogEnd::DeadMan)]);
    // The motor is without current: the next jog sets the mode again.
    h.request(jog(3, Dir::Plus, 2240.0));
    h.expect_frame("22 11 03 00 00000000");
}

#[test]
fn a_velocity_jog_stops_ahead_of_the_soft_limit() {
    let mut h = Harness::emp(|_| {});
    h.ready(5_500_000);
    h.poll();
    h.request(jog(4, Dir::Plus, 28_000.0));
    h.expect_frame("20 11 19 00 0000DD78");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 00 7F 00000000");
    h.answer("2B 11 00 22 0053EC60");
    h.expect_frame("2C 11 00 00 00000000");
    h.answer("2D 11 00 22 00545000");
    h.expect_frame("40 11 01 00 00000000");
    h.answer("41 11 00 22 00000000");
    h.expect_frame("2C 11 00 00 00000000");
    // 5 600 000 is the limit; 2 000 counts of room at 28 000 counts/s is
    // inside the look-ahead.
    h.answer("2D 11 00 22 00556C30");
    h.expect_frame("08 11 00 00 00000000");
    h.answer("09 11 00 22 00556D00");
    h.expect_frame("2C 11 00 00 00000000");
    assert_eq!(h.jog_ends(), vec![(4, JogEnd::SoftLimit)]);
}

#[test]
fn a_jog_at_the_soft_limit_is_refused() {
    let mut h = Harness::emp(|_| {});
    h.ready(0);
    h.request(jog(5, Dir::Minus, 2240.0));
    h.expect_nothing();
    assert!(matches!(
        refusal_reasons(&h.events).as_slice(),
        [Refusal::SoftLimit { axis: Axis::X, .. }]
    ));
    assert!(matches!(
        h.jog_ends().as_slice(),
        [(5, JogEnd::Refused(Refusal::SoftLimit { .. }))]
    ));
}

#[test]
fn an_unreferenced_jog_is_refused_unless_allowed() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.request(jog(6, Dir::Plus, 2240.0));
    h.expect_nothing();
    assert_eq!(
        refusal_reasons(&h.events),
        vec![Refusal::NotReferenced {
            axes: AxisSet::EMPTY.with(Axis::X)
        }]
    );
    let mut h = Harness::emp(|s| s.jog.allow_unreferenced = true);
    h.connect(0, true);
    h.request(jog(7, Dir::Plus, 2240.0));
    h.expect_frame("22 11 03 00 00000000");
}

#[test]
fn jog_speeds_are_capped_by_the_overrun() {
    let mut h = Harness::emp(|s| {
        if let Some(mut l) = s.limits.get(Axis::X) {
            l.max_overrun = 1_000.0;
            s.limits.set(Axis::X, l);
        }
    });
    h.ready(1_000_000);
    h.request(jog(8, Dir::Plus, 50_000.0));
    // v T + v B / 2 <= 1000 with T = 150 ms + 10.45 ms, B = 100 ms:
    // v <= 4 752 counts/s.
    let hex = |h: &mut Harness| {
        let sent = h.send().expect("a frame");
        String::from_utf8_lossy(&sent).into_owned()
    };
    let rate = hex(&mut h);
    assert!(rate.starts_with("20111900"), "{rate}");
    let reload = u32::from_str_radix(&rate[12..16], 16).expect("hex");
    h.answer("21 11 00 22 00000000");
    let drive = hex(&mut h);
    assert!(drive.starts_with("2A1100"), "{drive}");
    let v = u32::from_str_radix(&drive[6..8], 16).expect("hex");
    let hz = f64::from(v) * 12_500_000.0 / f64::from(reload);
    assert!(hz <= 4_752.0 && hz > 4_700.0, "{hz}");
}

#[test]
fn steps_position_with_tp_and_coalesce() {
    let mut h = Harness::emp(|_| {});
    h.ready(1000);
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 500),
        speed_hz: x_speed(2240.0),
    });
    h.expect_frame("22 11 07 00 00000000");
    h.answer("23 11 00 22 000003E8");
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 01 0B 000005DC");
    h.answer("2B 11 00 55 000003E8");
    // Two more presses while it runs: remembered, a third is refused.
    for _ in 0..3 {
        h.request(Request::Step {
            delta: PerAxis::new().with(Axis::X, 100),
            speed_hz: x_speed(2240.0),
        });
    }
    assert_eq!(refusal_reasons(&h.events), vec![Refusal::StepQueueFull]);
    h.expect_nothing();
    h.answer("2B 11 00 22 000005DC");
    // The remembered steps as one move from where the first ended.
    h.expect_frame("2A 11 01 0B 000006A4");
    h.answer("2B 11 00 55 000005DC");
    h.answer("2B 11 00 22 000006A4");
    h.expect_nothing();
    assert_eq!(h.state().activity, crate::device::api::Activity::Idle);
}

#[test]
fn move_to_uses_the_work_zero_and_checks_the_soft_limits() {
    let mut h = Harness::emp(|_| {});
    h.ready(2000);
    h.request(Request::SetZero {
        axes: AxisSet::EMPTY.with(Axis::X),
    });
    h.expect_nothing();
    assert_eq!(h.state().work_zero.get(Axis::X), Some(2000));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, -3000),
        frame: Frame::Work,
        speed_hz: x_speed(2240.0),
    });
    h.expect_nothing();
    assert!(matches!(
        refusal_reasons(&h.events).as_slice(),
        [Refusal::SoftLimit { target: -1000, .. }]
    ));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 1000),
        frame: Frame::Work,
        speed_hz: x_speed(2240.0),
    });
    h.expect_frame("22 11 07 00 00000000");
    h.answer("23 11 00 22 000007D0");
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 01 0B 00000BB8");
}

#[test]
fn a_stop_during_positioning_ends_it_and_nothing_is_sent_again() {
    let mut h = Harness::emp(|_| {});
    h.ready(1000);
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 100_000),
        frame: Frame::Machine,
        speed_hz: x_speed(2240.0),
    });
    h.expect_frame("22 11 07 00 00000000");
    h.answer("23 11 00 22 000003E8");
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("2A 11 01 0B 000186A0");
    h.answer("2B 11 00 55 000003E8");
    let stop = h.stop();
    assert_eq!(stop, super::harness::frame("08 11 00 00 00000000"));
    h.answer("09 11 00 22 00000500");
    h.expect_nothing();
    h.advance(ms(2000));
    h.expect_nothing();
    assert_eq!(h.state().activity, crate::device::api::Activity::Idle);
    assert!(h.faults().is_empty(), "{:?}", h.faults());
}

#[test]
fn a_stop_that_overtakes_a_move_in_the_writer_stops_again_after_it() {
    let mut h = Harness::emp(|_| {});
    h.ready(1000);
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 100_000),
        frame: Frame::Machine,
        speed_hz: x_speed(2240.0),
    });
    h.expect_frame("22 11 07 00 00000000");
    h.answer("23 11 00 22 000003E8");
    h.expect_frame("20 11 19 00 0000EFC7");
    h.answer("21 11 00 22 00000000");
    // Handed to the writer, not yet written: the stop lane jumps ahead.
    let moving = h.take().expect("move");
    assert_eq!(moving, super::harness::frame("2A 11 01 0B 000186A0"));
    let _ = h.stop();
    h.written();
    h.expect_frame("08 11 00 00 00000000");
}
