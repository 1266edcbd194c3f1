//! The probe on an EMP drive (`Request::Probe`, `probe_op`): each pass
//! short TP positionings of the probe axis's drive, each followed by a
//! read of its inputs (`40 01`), the position (`2C`) once a pass has ended,
//! then back to where it started; its refusals; a stop during a pass; and
//! against the simulated drive, a surface that trips the input.

use std::time::Duration;

use crate::axis::Axis;
use crate::config::Profile;
use crate::device::api::{Activity, Dir, Event, JogId, PerAxis, ProbeEnd, ProbeMove, Request};
use crate::device::driver::Driver;
use crate::device::emp::{EmpDriver, EmpSettings};
use crate::proto::emp::DriveAddress;
use crate::sim::InputControl;

use super::harness::{Harness, ms, profile};
use super::with_sim::{Bench, bench_for, counter, run_until_homed};

const ID: JogId = JogId(9);

/// The shipped EMP profile with a touch probe on drive 11's I1.
fn probe_profile() -> Profile {
    let mut p = profile();
    p.io.insert(
        "11.I1".into(),
        crate::wiring::BitPatch {
            name: Some("touch probe".into()),
            role: Some(crate::wiring::RoleName::Probe),
            ..Default::default()
        },
    );
    p
}

/// One drive at 11 with the probe on I1, polling off.
fn harness() -> Harness {
    let mut s = EmpSettings::from_profile(&probe_profile()).expect("settings");
    s.poll = crate::device::common::PollRate::Off;
    Harness::on(EmpDriver::new(s))
}

/// X toward smaller counts: 10 mm at 11 200 counts/mm, 5 mm/s fast and
/// 0.5 mm/s slow (the `[probe]` defaults).
fn probe_x(travel: i64) -> Request {
    Request::Probe {
        id: ID,
        probe: ProbeMove {
            axis: Axis::X,
            dir: Dir::Minus,
            travel,
            fast_hz: 56_000.0,
            slow_hz: 5_600.0,
        },
    }
}

fn ends(events: &[Event]) -> Vec<ProbeEnd> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::ProbeEnded { id, end } if *id == ID => Some(end.clone()),
            _ => None,
        })
        .collect()
}

const FREE: &str = "41 11 00 22 00000000";
const TOUCHED: &str = "41 11 00 22 00000001";

/// The fast speed's sample rate and `2A` speed byte (56 000 counts/s: 127
/// counts a sample at 440.9 Hz), the slow speed's (5600 counts/s: 29 at
/// 193.1 Hz).
const FAST_RATE: &str = "20 11 19 00 00006EBC";
const SLOW_RATE: &str = "20 11 19 00 0000FCDC";
const FAST: &str = "7F";
const SLOW: &str = "1D";

/// One move to `target` at speed byte `v`: started, in position, then the
/// inputs read as `inputs`.
fn step(h: &mut Harness, v: &str, target: u32, inputs: &str) {
    h.expect_frame(&format!("2A 11 01 {v} {target:08X}"));
    h.answer("2B 11 00 55 00000000");
    h.advance(ms(20));
    h.answer(&format!("2B 11 00 22 {target:08X}"));
    h.expect_frame("40 11 01 00 00000000");
    h.answer(inputs);
}

fn position(h: &mut Harness, at: u32) {
    h.expect_frame("2C 11 00 00 00000000");
    h.answer(&format!("2D 11 00 22 {at:08X}"));
}

/// Ready at 1 000 000 counts; the probe read free there.
fn started(travel: i64) -> Harness {
    let mut h = harness();
    h.ready(1_000_000);
    h.events.clear();
    h.request(probe_x(travel));
    h.expect_frame("40 11 01 00 00000000");
    h.answer(FREE);
    position(&mut h, 1_000_000);
    assert_eq!(h.state().activity, Activity::Probing);
    h.expect_frame("22 11 07 00 00000000");
    h.answer("23 11 00 22 000F4240");
    h.expect_frame(FAST_RATE);
    h.answer("21 11 00 22 00000000");
    h
}

#[test]
fn short_fast_moves_until_touched_a_back_off_and_short_slow_moves_then_back() {
    let mut h = started(112_000);
    // Fast: 50 ms of 5 mm/s a move, 2800 counts (0.25 mm).
    step(&mut h, FAST, 997_200, FREE);
    step(&mut h, FAST, 994_400, TOUCHED);
    position(&mut h, 994_400);
    // Back off by `probe.step` (0.01 mm, 112 counts) a move until released.
    h.expect_frame(SLOW_RATE);
    h.answer("21 11 00 22 00000000");
    step(&mut h, SLOW, 994_512, TOUCHED);
    step(&mut h, SLOW, 994_624, FREE);
    position(&mut h, 994_624);
    // Toward the surface again by a step a move; the position read after
    // the move that tripped is the touched point.
    step(&mut h, SLOW, 994_512, FREE);
    step(&mut h, SLOW, 994_400, TOUCHED);
    position(&mut h, 994_402);
    // Back to where it started, one positioning at the fast speed.
    h.expect_frame(FAST_RATE);
    h.answer("21 11 00 22 00000000");
    h.expect_frame(&format!("2A 11 01 {FAST} 000F4240"));
    h.answer("2B 11 00 55 00000000");
    h.advance(ms(200));
    h.answer("2B 11 00 22 000F4240");
    position(&mut h, 1_000_000);
    h.expect_nothing();
    assert_eq!(
        ends(&h.events),
        [ProbeEnd::Touched {
            at: PerAxis::new().with(Axis::X, 994_402),
            fast_stop: 994_400
        }]
    );
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn no_surface_within_the_travel_goes_back_and_says_so() {
    // 0.5 mm: two fast moves, then the travel is used up.
    let mut h = started(5600);
    step(&mut h, FAST, 997_200, FREE);
    step(&mut h, FAST, 994_400, FREE);
    position(&mut h, 994_400);
    h.expect_frame(&format!("2A 11 01 {FAST} 000F4240"));
    h.answer("2B 11 00 55 00000000");
    h.answer("2B 11 00 22 000F4240");
    position(&mut h, 1_000_000);
    h.expect_nothing();
    assert_eq!(ends(&h.events), [ProbeEnd::NoTrip { travel: 5600 }]);
}

#[test]
fn a_probe_touched_before_it_moves_is_refused_with_nothing_moving() {
    let mut h = harness();
    h.ready(1_000_000);
    h.events.clear();
    let before = h.sent.len();
    h.request(probe_x(112_000));
    h.expect_frame("40 11 01 00 00000000");
    h.answer(TOUCHED);
    h.expect_nothing();
    let ended = ends(&h.events);
    assert!(
        matches!(&ended[..], [ProbeEnd::Refused(r)] if r.to_string().contains("reads touched")),
        "{ended:?}"
    );
    assert!(
        !h.sent[before..]
            .iter()
            .any(|m| m.starts_with(b"2A") || m.starts_with(b"22"))
    );
    assert_eq!(h.state().activity, Activity::Idle);
}

#[test]
fn a_stop_during_a_pass_ends_the_probe_and_nothing_resumes() {
    let mut h = started(112_000);
    step(&mut h, FAST, 997_200, FREE);
    h.expect_frame(&format!("2A 11 01 {FAST} 000F2C60"));
    h.answer("2B 11 00 55 00000000");
    h.advance(ms(10));
    assert_eq!(h.state().activity, Activity::Probing);
    h.stop();
    h.answer("09 11 00 22 000F3C00");
    h.advance(ms(500));
    h.expect_nothing();
    assert_eq!(ends(&h.events), [ProbeEnd::Stopped]);
    assert_eq!(h.state().activity, Activity::Idle);
    // The positioning's `22` after the stop changes nothing.
    h.answer("2B 11 00 22 000F3C00");
    h.advance(ms(500));
    h.expect_nothing();
}

#[test]
fn a_lost_link_ends_the_probe_and_nothing_is_sent_again() {
    let mut h = started(112_000);
    h.expect_frame(&format!("2A 11 01 {FAST} 000F3750"));
    h.answer("2B 11 00 55 00000000");
    h.driver.disconnected("port vanished", h.now);
    h.collect();
    assert_eq!(ends(&h.events), [ProbeEnd::LinkLost]);
    h.advance(ms(500));
    h.expect_nothing();
}

#[test]
fn a_move_the_drive_rejects_stops_it_and_ends_the_probe_with_the_fault() {
    let mut h = started(112_000);
    h.expect_frame(&format!("2A 11 01 {FAST} 000F3750"));
    h.answer("2B 11 00 EE 00000000");
    h.expect_frame("08 11 00 00 00000000");
    h.answer("09 11 00 22 000F4240");
    h.expect_frame("0A 11 00 00 00000000");
    h.answer("0B 11 00 22 00000005");
    h.advance(ms(100));
    h.expect_nothing();
    let ended = ends(&h.events);
    assert!(matches!(&ended[..], [ProbeEnd::Fault(_)]), "{ended:?}");
    assert!(!h.sent_any(b"2A11017F000F2C60"));
}

#[test]
fn the_probe_input_must_be_on_the_probe_axis_s_drive() {
    // X on drive 11, Y on drive 21 with the probe on its I1.
    let mut p = profile();
    p.machine.axes = "XY".into();
    let mut y = p.axes.get(&Axis::X).cloned().expect("X");
    y.drive = Some("21".into());
    p.axes.insert(Axis::Y, y);
    p.io.insert(
        "21.I1".into(),
        crate::wiring::BitPatch {
            role: Some(crate::wiring::RoleName::Probe),
            ..Default::default()
        },
    );
    let mut b = bench_for(&p, |_| {});
    b.run(ms(300));
    b.request(Request::Initialise);
    b.run(ms(300));
    let before = b.sent.len();
    b.request(probe_x(112_000));
    b.run(ms(100));
    let ended = ends(&b.events);
    assert!(
        matches!(&ended[..], [ProbeEnd::Refused(r)] if r.to_string().contains("not on drive 11")),
        "{ended:?}"
    );
    assert!(!b.sent_text()[before..].iter().any(|t| t.starts_with("2A")));
}

/// Run until the probe has ended, at most `within`, the simulated surface
/// at `surface` counts (X at or below it trips I1); the lowest counter seen.
fn probe_against(b: &mut Bench, surface: i64, within: Duration) -> i64 {
    let end = b.now + within;
    let mut touched = false;
    let mut lowest = i64::MAX;
    while b.now < end && ends(&b.events).is_empty() {
        b.run(ms(1));
        let x = counter(b, DriveAddress::SINGLE);
        lowest = lowest.min(x);
        if (x <= surface) != touched {
            touched = !touched;
            b.control(InputControl::Set {
                name: "i1".into(),
                level: touched,
            });
        }
    }
    lowest
}

#[test]
fn against_the_simulated_drive_it_touches_within_a_step_and_goes_back() {
    let mut b = bench_for(&probe_profile(), |_| {});
    b.run(ms(300));
    b.request(Request::Initialise);
    b.run(ms(300));
    b.request(Request::Home {
        axes: crate::axis::AxisSet::EMPTY.with(Axis::X),
    });
    run_until_homed(&mut b, Duration::from_secs(120));
    // From X 20 mm toward a surface at 15.4955 mm, between the ends of
    // the moves.
    b.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 224_000),
        frame: crate::device::api::Frame::Machine,
        speed_hz: PerAxis::new().with(Axis::X, 56_000.0),
    });
    b.run(Duration::from_secs(6));
    assert_eq!(counter(&b, DriveAddress::SINGLE), 224_000);
    b.events.clear();
    let surface = 173_550;
    let started = b.now;
    b.request(probe_x(112_000));
    let lowest = probe_against(&mut b, surface, Duration::from_secs(30));
    let took = b.now - started;
    let ended = ends(&b.events);
    let [ProbeEnd::Touched { at, fast_stop }] = &ended[..] else {
        panic!("{ended:?}");
    };
    let at = at.get(Axis::X).expect("X");
    // Within one step (`probe.step`, 112 counts) past the surface; the
    // fast pass within one of its moves (2800 counts).
    assert!(at <= surface && at > surface - 112, "{at}");
    assert!(
        *fast_stop <= surface && *fast_stop > surface - 2800,
        "{fast_stop}"
    );
    assert!(lowest > surface - 2800, "{lowest}");
    // Back where it started.
    b.run(ms(300));
    assert_eq!(counter(&b, DriveAddress::SINGLE), 224_000);
    assert_eq!(b.driver.state().activity, Activity::Idle);
    // 4.5 mm at up to 5 mm/s, the back-off and the slow pass.
    assert!(took < Duration::from_secs(8), "{took:?}");
}
