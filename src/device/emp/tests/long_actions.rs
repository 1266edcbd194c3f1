//! Long actions that answer busy (`55`) and never ready (`22`): raw TP
//! moves and planned go-to moves are given up at their deadline, reference
//! runs, raw or planned, also when their position stands still
//! (`emp::guard`, `emp::deadline`, `emp::stall`). The drive is stopped first, the fault names drive and
//! frame and asks to initialise and reference, and nothing moves until then.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Event, Frame, PerAxis, Recovery, Refusal, Request};
use crate::device::common::testing::refusal_reasons;
use crate::device::emp::stall::{READ_EVERY, STILL_READS};

use super::harness::{Harness, ms, x_speed};

fn raw(line: &str) -> Request {
    Request::Raw { line: line.into() }
}

/// The one fault reported so far, as (command, code, meaning).
fn the_fault(h: &Harness) -> (String, String, String) {
    let faults: Vec<_> = h
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Fault(f) => Some((f.command.clone(), f.code.clone(), f.meaning.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(faults.len(), 1, "{faults:?}");
    faults.into_iter().next().unwrap_or_default()
}

/// After a long action was given up: every move is refused with the
/// recovery, nothing is sent; initialising leaves only the reference run,
/// which is allowed again and clears the fault.
fn assert_blocked_until_initialised_and_referenced(h: &mut Harness) {
    let s = h.state();
    assert_eq!(
        s.fault.as_ref().map(|f| f.recovery),
        Some(Recovery::ReinitialiseAndReference)
    );
    assert!(!s.referenced.contains(Axis::X));
    h.events.clear();
    h.request(raw("2A 11 01 64 000F4240"));
    h.request(Request::MoveTo {
        target: PerAxis::new().with(Axis::X, 5000),
        frame: Frame::Machine,
        speed_hz: x_speed(2240.0),
    });
    h.request(Request::Home {
        axes: AxisSet::EMPTY.with(Axis::X),
    });
    h.expect_nothing();
    let refused = refusal_reasons(&h.events);
    assert_eq!(refused.len(), 3, "{refused:?}");
    for r in refused {
        assert_eq!(
            r,
            Refusal::Fault {
                recovery: Recovery::ReinitialiseAndReference
            }
        );
    }
    h.request(Request::Initialise);
    h.expect_frame("02 11 11 00 00000000");
    h.answer("03 11 00 22 00000000");
    h.expect_frame("22 11 03 00 00000000");
    h.answer("23 11 00 22 000F4240");
    h.expect_nothing();
    assert_eq!(
        h.state().fault.map(|f| f.recovery),
        Some(Recovery::Reference)
    );
    h.request(Request::Home {
        axes: AxisSet::EMPTY.with(Axis::X),
    });
    h.expect_frame("20 11 19 00 000030D4");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("26 11 00 00 00140400");
    h.answer("27 11 00 55 000F4240");
    h.answer("27 11 00 22 00000000");
    let s = h.state();
    assert_eq!(s.fault, None);
    assert!(s.referenced.contains(Axis::X));
}

#[test]
fn a_raw_tp_move_that_stays_busy_is_stopped_at_its_deadline() {
    let mut h = Harness::emp(|_| {});
    // Referenced at 1 000 000 with the sample rate at 1 kHz (`30D4`).
    h.ready(1_000_000);
    h.events.clear();
    // 200 000 counts at 100 counts/ms: 2 s; the deadline 2 s + 1/4 + 1 s
    // and three round trips (31 ms).
    h.request(raw("2A 11 01 64 00124F80"));
    h.expect_frame("2A 11 01 64 00124F80");
    h.answer("2B 11 00 55 000F4240");
    h.advance(ms(3500));
    h.expect_nothing();
    assert!(h.faults().is_empty(), "{:?}", h.faults());
    h.advance(ms(40));
    // The stop first, then the fault.
    h.expect_frame("08 11 00 00 00000000");
    let (command, code, meaning) = the_fault(&h);
    assert_eq!(command, "2A11016400124F80");
    assert_eq!(code, "55");
    assert!(
        meaning.contains("drive 11 (X) stayed busy (55)")
            && meaning.contains("within 3531 ms")
            && meaning.contains("stopped with 08"),
        "{meaning}"
    );
    h.answer("09 11 00 22 000F4240");
    h.expect_nothing();
    assert_eq!(h.state().activity, crate::device::api::Activity::Idle);
    // The move was sent once.
    let moves = h.sent.iter().filter(|m| m.starts_with(b"2A1101")).count();
    assert_eq!(moves, 1);
    assert_blocked_until_initialised_and_referenced(&mut h);
}

#[test]
fn a_raw_tp_move_without_a_known_sample_rate_assumes_the_slowest() {
    let mut h = Harness::emp(|_| {});
    h.connect(0, true);
    h.events.clear();
    // The position is known (read back), the sample rate is not: the
    // slowest (FFFF, 190.7 counts/s per unit of Vmax). 100 000 counts at
    // Vmax 100: 5.24 s, deadline 7.55 s plus round trips.
    h.request(raw("2A 11 01 64 000186A0"));
    h.expect_frame("2A 11 01 64 000186A0");
    h.answer("2B 11 00 55 00000000");
    h.advance(ms(7500));
    h.expect_nothing();
    h.advance(ms(100));
    h.expect_frame("08 11 00 00 00000000");
    assert_eq!(the_fault(&h).1, "55");
}

#[test]
fn a_raw_homing_whose_position_stands_still_is_stalled() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.events.clear();
    h.request(raw("26 11 00 00 00140400"));
    h.expect_frame("26 11 00 00 00140400");
    h.answer("27 11 00 55 000F4240");
    // Moving: the reads see the position change, no stall.
    let mut pos = 1_000_000u32;
    for _ in 0..5 {
        h.advance(READ_EVERY);
        h.expect_frame("2C 11 00 00 00000000");
        pos -= 2000;
        h.answer(&format!("2D 11 00 22 {pos:08X}"));
    }
    // Standing still while busy: STILL_READS reads in a row make a stall.
    for i in 1..STILL_READS {
        h.advance(READ_EVERY);
        h.expect_frame("2C 11 00 00 00000000");
        h.answer(&format!("2D 11 00 22 {pos:08X}"));
        assert!(h.faults().is_empty(), "read {i}: {:?}", h.faults());
    }
    h.advance(READ_EVERY);
    h.expect_frame("2C 11 00 00 00000000");
    h.answer(&format!("2D 11 00 22 {pos:08X}"));
    h.expect_frame("08 11 00 00 00000000");
    let (command, code, meaning) = the_fault(&h);
    assert_eq!(
        (command.as_str(), code.as_str()),
        ("2611000000140400", "55")
    );
    assert!(
        meaning.starts_with("homing stalled: drive 11 (X) stayed busy (55)")
            && meaning.contains("Check the axis"),
        "{meaning}"
    );
    h.answer("09 11 00 22 000F0000");
    h.advance(READ_EVERY * 3);
    h.expect_nothing();
    // No "ended by a later request" on top of the fault.
    assert!(h.replies().iter().all(|(_, t)| !t.contains("ended")));
    assert_blocked_until_initialised_and_referenced(&mut h);
}

#[test]
fn a_raw_homing_that_moves_but_never_arrives_ends_at_its_deadline() {
    let mut h = Harness::emp(|s| {
        if let Some(x) = s.limits.get(Axis::X) {
            s.limits.set(
                Axis::X,
                crate::device::common::AxisLimits { max: 40_000, ..x },
            );
        }
    });
    h.ready(20_000);
    h.events.clear();
    // Vslow 4 counts/ms at 1 kHz: 4000 counts/s over 40 000 counts:
    // 40 000 * 1.5 / 4000 + 1 = 16 s, * 1.25 + 1 s, + 1 s: 22 s.
    h.request(raw("26 11 00 00 00140400"));
    h.expect_frame("26 11 00 00 00140400");
    h.answer("27 11 00 55 00004E20");
    let start = h.now;
    let mut pos = 20_000u32;
    while h.now < start + ms(21_900) {
        h.advance(READ_EVERY);
        h.expect_frame("2C 11 00 00 00000000");
        pos += 1;
        h.answer(&format!("2D 11 00 22 {pos:08X}"));
    }
    assert!(h.faults().is_empty(), "{:?}", h.faults());
    h.advance(ms(150));
    h.expect_frame("08 11 00 00 00000000");
    let (_, code, meaning) = the_fault(&h);
    assert_eq!(code, "55");
    assert!(
        meaning.contains("did not reach the reference point (22) within 22 s"),
        "{meaning}"
    );
}

#[test]
fn an_operator_stop_disarms_the_deadline() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.events.clear();
    h.request(raw("2A 11 01 64 00124F80"));
    h.expect_frame("2A 11 01 64 00124F80");
    h.answer("2B 11 00 55 000F4240");
    let _ = h.stop();
    h.answer("09 11 00 22 000F4240");
    h.advance(ms(10_000));
    h.expect_nothing();
    assert!(h.faults().is_empty(), "{:?}", h.faults());
    assert_eq!(h.state().fault, None);
}

#[test]
fn a_planned_move_that_stays_busy_blocks_motion_until_acknowledged() {
    let mut h = Harness::emp(|_| {});
    h.ready(1000);
    h.events.clear();
    // 99 000 counts at 2240 counts/s: 44.2 s, deadline 56.3 s.
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
    h.advance(ms(56_000));
    h.expect_nothing();
    h.advance(ms(500));
    h.expect_frame("08 11 00 00 00000000");
    let (command, code, meaning) = the_fault(&h);
    assert_eq!(
        (command.as_str(), code.as_str()),
        ("2A11010B000186A0", "55")
    );
    assert!(meaning.contains("did not report in position"), "{meaning}");
    h.answer("09 11 00 22 000003E8");
    h.expect_nothing();
    assert_blocked_until_initialised_and_referenced(&mut h);
}

fn home_x() -> Request {
    Request::Home {
        axes: AxisSet::EMPTY.with(Axis::X),
    }
}

/// A planned reference run of X from `position`: its frames up to the `55`.
fn start_planned_homing(h: &mut Harness, position: u32) {
    h.request(home_x());
    h.expect_frame("20 11 19 00 000030D4");
    h.answer("21 11 00 22 00000000");
    h.expect_frame("26 11 00 00 00140400");
    h.answer(&format!("27 11 00 55 {position:08X}"));
}

#[test]
fn a_planned_homing_whose_position_stands_still_is_stalled() {
    // Polling off: the watchdog reads the position itself.
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.events.clear();
    start_planned_homing(&mut h, 1_000_000);
    let mut pos = 1_000_000u32;
    for _ in 0..5 {
        h.advance(READ_EVERY);
        h.expect_frame("2C 11 00 00 00000000");
        pos -= 2000;
        h.answer(&format!("2D 11 00 22 {pos:08X}"));
    }
    for i in 1..STILL_READS {
        h.advance(READ_EVERY);
        h.expect_frame("2C 11 00 00 00000000");
        h.answer(&format!("2D 11 00 22 {pos:08X}"));
        assert!(h.faults().is_empty(), "read {i}: {:?}", h.faults());
    }
    h.advance(READ_EVERY);
    h.expect_frame("2C 11 00 00 00000000");
    h.answer(&format!("2D 11 00 22 {pos:08X}"));
    // The stop first, then the fault naming drive and frame.
    h.expect_frame("08 11 00 00 00000000");
    let (command, code, meaning) = the_fault(&h);
    assert_eq!(
        (command.as_str(), code.as_str()),
        ("2611000000140400", "55")
    );
    assert!(
        meaning.starts_with("homing stalled: drive 11 (X) stayed busy (55)")
            && meaning.contains("stopped with 08"),
        "{meaning}"
    );
    h.answer("09 11 00 22 000F0000");
    h.advance(READ_EVERY * 3);
    h.expect_nothing();
    assert_eq!(h.state().activity, crate::device::api::Activity::Idle);
    assert!(h.notices().iter().all(|n| !n.contains("ended early")));
    assert_blocked_until_initialised_and_referenced(&mut h);
}

/// Answer what the driver sends during a reference run that stands at
/// `pos`, `step` by `step` until `until`: polls and watchdog reads with the
/// position, `40 01` with nothing active. Returns every frame sent, and
/// stops at the first stop frame (unanswered).
fn serve_standing(
    h: &mut Harness,
    pos: u32,
    step: std::time::Duration,
    until: std::time::Instant,
) -> Vec<String> {
    let mut frames = Vec::new();
    while h.now < until {
        h.advance(step);
        while let Some(bytes) = h.send() {
            let text: String = bytes
                .iter()
                .filter(|b| **b != 0x1A)
                .map(|b| char::from(*b))
                .collect();
            frames.push(text.clone());
            if text.starts_with("2C11") {
                h.answer(&format!("2D 11 00 22 {pos:08X}"));
            } else if text.starts_with("4011") {
                h.answer("41 11 00 22 00000000");
            } else {
                return frames;
            }
        }
    }
    frames
}

#[test]
fn a_planned_homing_takes_the_poll_samples_and_reads_nothing_itself() {
    let mut h = Harness::emp(|_| {});
    h.ready(1_000_000);
    h.events.clear();
    start_planned_homing(&mut h, 1_000_000);
    // Polling at 20 Hz: a `2C` every 50 ms, `40 01` on the first cycle.
    h.request(Request::Poll {
        rate_hz: Some(20.0),
        ports_every: 1000,
    });
    let start = h.now;
    let frames = serve_standing(&mut h, 1_000_000, ms(5), start + ms(2000));
    let elapsed = h.now - start;
    assert_eq!(
        frames.last().map(String::as_str),
        Some("0811000000000000"),
        "{frames:?}"
    );
    // Stalled after about a second of samples, not at the deadline.
    assert!(
        elapsed >= ms(1000) && elapsed <= ms(1100),
        "{elapsed:?}: {frames:?}"
    );
    // Every `2C` was the poller's: one per 50 ms cycle, none extra.
    let reads = frames.iter().filter(|f| f.starts_with("2C11")).count();
    let cycles = elapsed.as_millis() / 50 + 1;
    assert!(
        u128::try_from(reads).unwrap_or(u128::MAX) <= cycles,
        "{reads} reads in {cycles} cycles: {frames:?}"
    );
    let (command, code, meaning) = the_fault(&h);
    assert_eq!(
        (command.as_str(), code.as_str()),
        ("2611000000140400", "55")
    );
    assert!(meaning.starts_with("homing stalled"), "{meaning}");
    h.answer("09 11 00 22 000F4240");
    assert_eq!(
        h.state().fault.map(|f| f.recovery),
        Some(Recovery::ReinitialiseAndReference)
    );
}

#[test]
fn a_planned_homing_that_moves_but_never_arrives_ends_at_its_deadline() {
    let mut h = Harness::emp(|s| {
        if let Some(x) = s.limits.get(Axis::X) {
            s.limits.set(
                Axis::X,
                crate::device::common::AxisLimits { max: 40_000, ..x },
            );
        }
    });
    h.ready(20_000);
    h.events.clear();
    // The reference deadline of a raw `26` with the same speeds: 22 s.
    start_planned_homing(&mut h, 20_000);
    let start = h.now;
    let mut pos = 20_000u32;
    while h.now < start + ms(21_900) {
        h.advance(READ_EVERY);
        h.expect_frame("2C 11 00 00 00000000");
        pos += 1;
        h.answer(&format!("2D 11 00 22 {pos:08X}"));
    }
    assert!(h.faults().is_empty(), "{:?}", h.faults());
    h.advance(ms(150));
    h.expect_frame("08 11 00 00 00000000");
    let (command, code, meaning) = the_fault(&h);
    assert_eq!(
        (command.as_str(), code.as_str()),
        ("2611000000140400", "55")
    );
    assert!(
        meaning.contains("drive 11 (X) stayed busy (55)")
            && meaning.contains("did not reach the reference point (22) within 22 s"),
        "{meaning}"
    );
    h.answer("09 11 00 22 00009C40");
    h.expect_nothing();
    assert_blocked_until_initialised_and_referenced(&mut h);
}
