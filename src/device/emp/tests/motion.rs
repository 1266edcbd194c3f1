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
    // v (L + R + T) + v B / 2 <= 1000 with the lease L = 750 ms it holds,
    // the stop's way to the wire R = 10 ms, a round trip T and B = 100 ms:
    // v <= 1 219 counts/s.
    let rt = super::harness::settings().timing.round_trip;
    let cap = crate::motion::speed_cap(&crate::device::emp::plan::braking(), ms(750) + rt, 1_000.0);
    assert!(cap > 1_200.0 && cap < 1_230.0, "{cap}");
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
    assert!(hz <= cap && hz > cap * 0.999, "{hz} {cap}");
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

/// The overrun bound of X in counts and the stop frame's round trip.
fn bound_and_way() -> (f64, Duration) {
    let s = super::harness::settings();
    let bound = s.limits.get(Axis::X).expect("X").max_overrun;
    (bound, s.timing.round_trip)
}

/// The fastest X jog the bound allows with `lease` (`plan::overrun_cap`).
fn lease_speed(lease: Duration) -> f64 {
    let (bound, rt) = bound_and_way();
    crate::motion::speed_cap(&crate::device::emp::plan::braking(), lease + rt, bound)
}

/// The velocity move the driver sends next (`20 19` first when the sample
/// rate changes), answered; its speed in counts/s.
fn velocity_move(h: &mut Harness, reload: &mut u32) -> f64 {
    let next = |h: &mut Harness| {
        let sent = h.send().expect("a frame");
        String::from_utf8_lossy(&sent).into_owned()
    };
    let mut f = next(h);
    if f.starts_with("20111900") {
        *reload = u32::from_str_radix(&f[12..16], 16).expect("hex");
        h.answer("21 11 00 22 00000000");
        f = next(h);
    }
    assert!(f.starts_with("2A1100"), "{f}");
    let v = u32::from_str_radix(&f[6..8], 16).expect("hex");
    h.answer("2B 11 00 22 000F4240");
    f64::from(v) * 12_500_000.0 / f64::from(*reload)
}

#[test]
fn a_velocity_jog_speeds_up_once_at_the_first_short_renewal_without_a_stop() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    let top = 56_000.0;
    h.request(jog(9, Dir::Plus, top));
    let mut reload = 0;
    let grace = velocity_move(&mut h, &mut reload);
    // The first lease (750 ms) allows less than the axis's top speed.
    assert!(grace <= lease_speed(ms(750)) && grace > lease_speed(ms(750)) * 0.999);
    assert!(grace < top);
    h.expect_nothing();
    h.advance(ms(500));
    h.request(Request::JogRenew {
        id: JogId(9),
        lease: ms(150),
    });
    // The new sample rate and velocity: no stop frame in between.
    let fast = velocity_move(&mut h, &mut reload);
    assert!(lease_speed(ms(150)) > top);
    assert!((fast - top).abs() / top < 1e-4, "{fast}");
    assert!(h.jog_ends().is_empty());
    // Once: the next repeat only renews.
    h.advance(ms(33));
    h.request(Request::JogRenew {
        id: JogId(9),
        lease: ms(150),
    });
    h.expect_nothing();
    h.advance(ms(150));
    h.expect_frame("08 11 00 00 00000000");
    h.answer("09 11 00 22 00100000");
    h.expect_nothing();
    assert_eq!(h.jog_ends(), vec![(9, JogEnd::DeadMan)]);
}

/// Released between the speed-up's sample rate (`20 19`) and its new
/// velocity: the faster `2A` never goes out, the drive is stopped at once.
#[test]
fn a_release_in_the_middle_of_a_speed_up_sends_no_faster_velocity() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.request(jog(9, Dir::Plus, 56_000.0));
    let mut reload = 0;
    velocity_move(&mut h, &mut reload);
    h.advance(ms(500));
    h.request(Request::JogRenew {
        id: JogId(9),
        lease: ms(150),
    });
    let rate = h.send().expect("the sample rate");
    assert!(rate.starts_with(b"20111900"), "{rate:?}");
    h.request(Request::JogRelease { id: JogId(9) });
    h.answer("21 11 00 22 00000000");
    h.expect_frame("08 11 00 00 00000000");
    h.answer("09 11 00 22 00100000");
    h.expect_nothing();
    h.advance(ms(1_000));
    h.expect_nothing();
    assert_eq!(
        h.sent.iter().filter(|f| f.starts_with(b"2A1100")).count(),
        1,
        "only the grace velocity"
    );
    assert_eq!(h.jog_ends(), vec![(9, JogEnd::Released)]);
}

#[test]
fn a_renewal_is_granted_no_longer_lease_than_the_speed_allows() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.request(Request::Jog {
        id: JogId(10),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: x_speed(56_000.0),
        lease: ms(150),
    });
    let mut reload = 0;
    let hz = velocity_move(&mut h, &mut reload);
    h.advance(ms(100));
    // A late repeat or a toggle tick asking for 750 ms at this speed.
    h.request(Request::JogRenew {
        id: JogId(10),
        lease: ms(750),
    });
    let (bound, rt) = bound_and_way();
    let allowed = crate::motion::lease_cap(
        &crate::device::emp::plan::braking(),
        hz,
        bound - hz * rt.as_secs_f64(),
    );
    assert!(allowed < ms(740), "{allowed:?}");
    h.advance(allowed - ms(1));
    h.expect_nothing();
    h.advance(ms(2));
    h.expect_frame("08 11 00 00 00000000");
    h.answer("09 11 00 22 00100000");
    h.expect_nothing();
    assert_eq!(h.jog_ends(), vec![(10, JogEnd::DeadMan)]);
}
