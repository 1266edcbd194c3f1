//! Polling: positions and `@X`, between requests and during moves.

use crate::axis::Axis;
use crate::device::api::{Event, PerAxis, PositionSource, Request};
use crate::device::common::PollRate;

use super::harness::{Harness, ms, speeds};

fn polling(rate: PollRate, ports_every: u32) -> Harness {
    let mut h = Harness::with(|s| {
        s.poll.rate = rate;
        s.poll.ports_every = ports_every;
    });
    h.connect();
    h.readback("000000", 0, 0, 0);
    h
}

/// The first cycle reads the status too.
fn first_cycle(h: &mut Harness) {
    h.positions_read(0, 0, 0);
    h.expect_text("@X");
    h.reply(b"@X000000\r");
}

#[test]
fn a_cycle_reads_the_positions_and_every_nth_the_status() {
    let mut h = polling(PollRate::LineSpeed, 2);
    h.positions_read(1, 2, 3);
    h.expect_text("@X");
    h.reply(b"@X000000\r");
    h.positions_read(1, 2, 4);
    h.positions_read(1, 2, 5);
    h.expect_text("@X");
    let measured: Vec<i64> = h
        .positions()
        .iter()
        .filter(|p| p.source == PositionSource::Measured)
        .filter_map(|p| p.steps.get(Axis::Z))
        .collect();
    assert_eq!(measured, [0, 3, 4, 5]);
    let io = h
        .events
        .iter()
        .filter(|e| matches!(e, Event::Io(_)))
        .count();
    assert_eq!(io, 2, "one snapshot per @X");
}

#[test]
fn positions_are_measured_while_a_move_runs() {
    let mut h = polling(PollRate::LineSpeed, 1000);
    first_cycle(&mut h);
    // Initialise: the polls go on while its batch runs.
    h.request(Request::Initialise);
    h.expect_text("#S200");
    h.reply(b"\r");
    h.expect(b"#R500\x01");
    h.reply(b"\r");
    h.expect_text("@LX");
    h.reply(b"\x02\r@LX0\r");
    h.expect_text("@X");
    h.reply(b"@X000000\r");
    h.positions_read(0, 0, 0);
    h.take_events();
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 2_000),
        speed_hz: speeds(500.0),
    });
    h.expect_text("#E9,500");
    h.reply(b"\r");
    h.expect(b"L9,x2000\x01");
    h.reply(b"\r");
    // The move runs: polls go on, first the rest of the cycle that the
    // initialise's end interrupted.
    h.expect_text("@LY");
    h.reply(b"@LY0\r");
    h.expect_text("@LZ");
    h.reply(b"@LZ0\r");
    h.positions_read(150, 0, 0);
    h.positions_read(420, 0, 0);
    h.expect_text("@LX");
    h.reply(b"\x02\r@LX2000\r");
    h.expect_text("@X");
    h.reply(b"@X000000\r");
    // The move's own reading at its end, then the polls' cycle goes on.
    h.positions_read(2_000, 0, 0);
    h.expect_text("@LY");
    let xs: Vec<i64> = h
        .positions()
        .iter()
        .filter_map(|p| p.steps.get(Axis::X))
        .collect();
    assert_eq!(xs, [0, 150, 420, 2_000]);
    assert!(
        h.positions()
            .iter()
            .all(|p| p.source == PositionSource::Measured)
    );
}

#[test]
fn a_rate_spaces_the_cycles_and_stats_come_once_a_second() {
    let mut h = polling(PollRate::Hz(10.0), 1000);
    first_cycle(&mut h);
    h.expect_nothing();
    h.advance(ms(99));
    h.expect_nothing();
    h.advance(ms(1));
    h.positions_read(0, 0, 0);
    for _ in 0..10 {
        h.advance(ms(100));
        h.positions_read(0, 0, 0);
    }
    let stats = h
        .events
        .iter()
        .find_map(|e| match e {
            Event::Stats(s) => Some(*s),
            _ => None,
        })
        .expect("stats");
    assert!((stats.position_rate_hz - 10.0).abs() < 1.5, "{stats:?}");
    // Three axes of `@LX0` CR answered with `@LX0` CR: 9 bytes each.
    assert!(
        (stats.wire_limit_hz - 1920.0 / 27.0).abs() < 0.1,
        "{stats:?}"
    );
    h.request(Request::Poll {
        rate_hz: Some(0.0),
        ports_every: 1,
    });
    h.advance(ms(500));
    h.expect_nothing();
}
