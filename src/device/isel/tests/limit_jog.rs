//! The jog off a limit switch (`Request::LimitJog`, `limit_op`): the
//! conversation on the wire, its ends and its refusals; then against the
//! simulated controller, after a real `2`.

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Event, JogEnd, JogId, PerAxis, Request};
use crate::device::common::settings::LimitJog;
use crate::device::driver::Driver;
use crate::device::isel::PollRate;
use crate::sim::SimDevice;

use super::harness::{Harness, ms, position_reply};
use super::with_sim::{IselBench, homed};

const ID: JogId = JogId(7);

/// Connected to an XYZ controller at (x, 0, 0) whose limit switches read
/// `port3`, initialised (`@0P` answers), nothing referenced: the probe is
/// skipped with a switch active (`readback`).
fn in_switch(h: &mut Harness, x: i32, port3: &[u8]) {
    h.connect();
    h.expect_text("@0P");
    h.reply(&position_reply(x, 0, 0));
    h.advance(ms(60));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b2");
    h.reply(b"0E2");
    h.expect_text("@0b3");
    h.reply(port3);
    h.expect_nothing();
    h.take_events();
}

fn limit_jog(axis: Axis, dir: Dir) -> Request {
    Request::LimitJog { id: ID, axis, dir }
}

fn ends(h: &Harness) -> Vec<JogEnd> {
    h.jog_ends().into_iter().map(|(_, e)| e).collect()
}

/// One short move of X at the profile's limit-jog speed (0.5 mm/s at 400
/// steps/mm: 200 Hz, 20 steps a move), answered; then the switches and the
/// position.
fn one_move(h: &mut Harness, steps: i32, x_after: i32, port3: &[u8]) {
    h.expect_text(&format!("@0A{steps},200,0,300,0,300,0,300"));
    h.advance(ms(100));
    h.reply(b"0");
    h.expect_text("@0b3");
    h.reply(port3);
    h.expect_text("@0P");
    h.reply(&position_reply(x_after, 0, 0));
}

#[test]
fn test_mode_short_moves_and_a_read_after_each_until_the_switch_releases() {
    let mut h = Harness::new();
    // Limit X1 (in3.0): the min switch of X.
    in_switch(&mut h, -800, b"001");
    h.request(limit_jog(Axis::X, Dir::Plus));
    // The switches as they are now, then test mode, then where it stands.
    h.expect_text("@0b3");
    h.reply(b"001");
    h.expect_text("@0T1");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(-800, 0, 0));
    assert_eq!(h.state().activity, crate::device::api::Activity::Jogging);
    one_move(&mut h, 20, -780, b"001");
    one_move(&mut h, 20, -760, b"000");
    // Released: test mode off at once, and the jog has ended.
    h.expect_text("@0T0");
    assert!(ends(&h).is_empty(), "not before test mode is off");
    h.reply(b"0");
    h.expect_nothing();
    assert_eq!(ends(&h), [JogEnd::OffLimit]);
    let notices = h.notices().join("\n");
    assert!(
        notices.contains("X is off its limit switch limit X1 after 40 steps"),
        "{notices}"
    );
    let s = h.state();
    assert!(!s.limit);
    assert!(!s.referenced.contains(Axis::X));
    assert_eq!(s.activity, crate::device::api::Activity::Idle);
    // Every move named X alone, every one away from the switch.
    let moves: Vec<String> = h
        .sent
        .iter()
        .map(|m| String::from_utf8_lossy(m).into_owned())
        .filter(|m| m.starts_with("@0A"))
        .collect();
    assert_eq!(moves.len(), 2, "{moves:?}");
}

#[test]
fn a_switch_that_never_releases_stops_at_the_bound_and_says_so() {
    let mut h = Harness::with(|s| {
        s.jog.limit_jog.set(
            Axis::X,
            LimitJog {
                distance: 50,
                hz: 200.0,
            },
        );
    });
    in_switch(&mut h, 120_800, b"002");
    // Limit X2: the max switch, left in X-.
    h.request(limit_jog(Axis::X, Dir::Minus));
    h.expect_text("@0b3");
    h.reply(b"002");
    h.expect_text("@0T1");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(120_800, 0, 0));
    one_move(&mut h, -20, 120_780, b"002");
    one_move(&mut h, -20, 120_760, b"002");
    // The last move is what is left of the bound.
    one_move(&mut h, -10, 120_750, b"002");
    h.expect_text("@0T0");
    h.reply(b"0");
    h.expect_nothing();
    assert_eq!(ends(&h), [JogEnd::StillOnLimit]);
    let notices = h.notices().join("\n");
    assert!(
        notices.contains("X travelled 50 steps") && notices.contains("still reads active"),
        "{notices}"
    );
}

#[test]
fn towards_the_switch_another_axis_or_no_switch_is_refused_and_nothing_is_sent() {
    let mut h = Harness::new();
    in_switch(&mut h, -800, b"001");
    let refused = |h: &mut Harness, r: Request| {
        h.request(r);
        h.expect_nothing();
        let events = h.take_events();
        let reason = events.iter().find_map(|e| match e {
            Event::Refused { reason, .. } => Some(reason.to_string()),
            _ => None,
        });
        let ended = events.iter().any(|e| {
            matches!(
                e,
                Event::JogEnded {
                    id: ID,
                    end: JogEnd::Refused(_)
                }
            )
        });
        assert!(ended, "{events:?}");
        reason.unwrap_or_default()
    };
    let towards = refused(&mut h, limit_jog(Axis::X, Dir::Minus));
    assert!(towards.contains("X- leads into the switch"), "{towards}");
    let other = refused(&mut h, limit_jog(Axis::Y, Dir::Plus));
    assert!(
        other.contains("no limit switch of Y reads active"),
        "{other}"
    );
    let absent = refused(&mut h, limit_jog(Axis::A, Dir::Plus));
    assert!(absent.contains("no A axis"), "{absent}");
    // A normal jog stays refused as before.
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 100),
        speed_hz: PerAxis::new().with(Axis::X, 1000.0),
    });
    h.expect_nothing();

    let mut h = Harness::new();
    h.connect();
    h.readback(0, 0, 0, b"R");
    h.expect_nothing();
    h.take_events();
    let none = refused(&mut h, limit_jog(Axis::X, Dir::Plus));
    assert!(none.contains("no limit switch reads active"), "{none}");
}

#[test]
fn after_a_2_it_waits_for_the_axes_to_be_initialised() {
    let mut h = Harness::new();
    in_switch(&mut h, -800, b"001");
    h.request(Request::Raw {
        line: "@0A-100,300,0,300,0,300,0,300".into(),
    });
    h.expect_text("@0A-100,300,0,300,0,300,0,300");
    h.reply(b"2");
    h.advance(ms(20));
    // The raw move's end is read.
    h.expect_text("@0P");
    h.reply(&position_reply(-800, 0, 0));
    h.expect_nothing();
    h.take_events();
    h.request(limit_jog(Axis::X, Dir::Plus));
    h.expect_nothing();
    let refusals = h.refusals();
    assert!(
        refusals.iter().any(|r| r.contains("initialise (i) first")),
        "{refusals:?}"
    );
}

#[test]
fn a_stop_brakes_the_move_and_test_mode_still_goes_off() {
    let mut h = Harness::new();
    in_switch(&mut h, -800, b"001");
    h.request(limit_jog(Axis::X, Dir::Plus));
    h.expect_text("@0b3");
    h.reply(b"001");
    h.expect_text("@0T1");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(-800, 0, 0));
    h.expect_text("@0A20,200,0,300,0,300,0,300");
    assert_eq!(h.stop(), vec![0xFD, 0xFF]);
    h.expect_nothing();
    h.reply(b"F");
    h.advance(ms(20));
    h.expect_text("@0b3");
    h.reply(b"001");
    h.expect_text("@0P");
    h.reply(&position_reply(-790, 0, 0));
    h.expect_text("@0T0");
    h.reply(b"0");
    h.expect_nothing();
    assert_eq!(ends(&h), [JogEnd::Stopped]);
    // No move after the stop.
    let moves = h.sent.iter().filter(|m| m.starts_with(b"@0A")).count();
    assert_eq!(moves, 1);
}

#[test]
fn a_lost_link_ends_it_and_the_next_connection_switches_test_mode_off_first() {
    let mut h = Harness::new();
    in_switch(&mut h, -800, b"001");
    h.request(limit_jog(Axis::X, Dir::Plus));
    h.expect_text("@0b3");
    h.reply(b"001");
    h.expect_text("@0T1");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(-800, 0, 0));
    h.expect_text("@0A20,200,0,300,0,300,0,300");
    h.driver.disconnected("cable pulled", h.now);
    h.collect();
    assert_eq!(ends(&h), [JogEnd::LinkLost]);
    h.take_events();
    // Nothing resumes: the stop goes first, then test mode off, then the
    // read-back.
    h.connect_stop();
    h.expect_text("@0T0");
    h.reply(b"0");
    h.expect_text("@0P");
    let notices = h.notices().join("\n");
    assert!(notices.contains("test mode switched off"), "{notices}");
    assert!(ends(&h).is_empty());
}

/// The simulator runs X into its min switch with a raw move: `2`. After
/// initialising, the jog leaves the switch by its hysteresis and a little
/// more, test mode goes off, and a reference run is what comes next.
#[test]
fn against_the_simulator_after_a_2_the_axis_leaves_its_switch_and_test_mode_is_off() {
    let mut b = homed(PollRate::LineSpeed);
    // Machine 0 is 2 mm (800 steps) above switch X1 (`[sim] limit_margin`).
    b.request(Request::Raw {
        line: "@0A-2000,2000,0,300,0,300,0,300".into(),
    });
    b.run(Duration::from_secs(2));
    let s = b.driver.state().clone();
    assert_eq!(s.fault.as_ref().map(|f| f.code.as_str()), Some("2"));
    assert!(s.limit);
    let stands = b.counters()[0];
    b.request(Request::Initialise);
    b.run(ms(500));
    b.events.clear();
    b.request(limit_jog(Axis::X, Dir::Plus));
    let ended = b.run_until(Duration::from_secs(10), |e| {
        e.iter()
            .any(|e| matches!(e, Event::JogEnded { id: ID, .. }))
    });
    assert!(ended, "{:?}", b.events);
    let ends: Vec<JogEnd> = b
        .events
        .iter()
        .filter_map(|e| match e {
            Event::JogEnded { end, .. } => Some(end.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(ends, [JogEnd::OffLimit]);
    let moved = b.counters()[0] - stands;
    // Out by the switch's hysteresis (0.1 mm = 40 steps), at most one move
    // (20 steps) more.
    assert!((40.0..=60.0).contains(&moved), "{moved}");
    assert!(!b.driver.state().limit);
    let sim = b.sim.describe(b.now);
    assert!(!sim.contains("test mode"), "{sim}");
    // What is left to do: a reference run (the fault says so).
    let s = b.driver.state().clone();
    assert_eq!(
        s.fault.as_ref().map(|f| f.recovery),
        Some(crate::device::api::Recovery::Reference)
    );
    b.request(Request::Home { axes: AxisSet::XYZ });
    b.run(Duration::from_secs(120));
    assert!(b.driver.state().fault.is_none());
    assert_eq!(b.driver.state().referenced, AxisSet::XYZ);
}

#[test]
fn against_the_simulator_a_forced_switch_is_left_at_the_bound() {
    let mut b = homed(PollRate::LineSpeed);
    b.set("limit-x2", true);
    b.run(ms(300));
    assert!(b.driver.state().limit);
    let from = b.counters()[0];
    b.events.clear();
    b.request(limit_jog(Axis::X, Dir::Minus));
    let ended = b.run_until(Duration::from_secs(15), |e| {
        e.iter()
            .any(|e| matches!(e, Event::JogEnded { id: ID, .. }))
    });
    assert!(ended, "{:?}", b.events);
    assert!(
        b.events.iter().any(|e| matches!(
            e,
            Event::JogEnded {
                end: JogEnd::StillOnLimit,
                ..
            }
        )),
        "{:?}",
        b.events
    );
    // 2 mm at 400 steps/mm, in X- only.
    assert_eq!(b.counters()[0] - from, -800.0);
    assert_eq!(b.counters()[1], 0.0);
    let sim = b.sim.describe(b.now);
    assert!(!sim.contains("test mode"), "{sim}");
    // Test mode is off: a move runs into the switch's `2` again.
    b.request(Request::Raw {
        line: "@0A-10,300,0,300,0,300,0,300".into(),
    });
    b.run(ms(300));
    assert!(
        b.events
            .iter()
            .any(|e| matches!(e, Event::Fault(f) if f.code == "2")),
        "{:?}",
        b.events
    );
}

#[test]
fn a_link_lost_before_test_mode_was_confirmed_still_switches_it_off_next_time() {
    let mut h = Harness::new();
    in_switch(&mut h, -800, b"001");
    h.request(limit_jog(Axis::X, Dir::Plus));
    h.expect_text("@0b3");
    h.reply(b"001");
    h.expect_text("@0T1");
    // The answer never comes: the link is declared dead.
    h.driver.disconnected("no answer", h.now);
    h.collect();
    assert_eq!(ends(&h), [JogEnd::LinkLost]);
    h.take_events();
    h.connect_stop();
    h.expect_text("@0T0");
}
