//! Polling: the order of a cycle, requests between polls, rates, stats.

use crate::axis::Axis;
use crate::device::api::{Event, PerAxis, Request};
use crate::device::isel::{PollPlan, PollRate};
use crate::proto::isel::InputPort;

use super::harness::{Harness, ms, position_reply, speeds};

fn polling(rate: PollRate, every: u32) -> Harness {
    let mut h = Harness::with(|s| {
        s.poll = PollPlan {
            rate,
            positions: true,
            ports_every: every,
            ports: PollPlan::DEFAULT_PORTS.to_vec(),
        };
    });
    h.connect();
    h.readback(0, 0, 0, b"0");
    h.take_events();
    h
}

#[test]
fn a_cycle_reads_the_position_and_every_nth_the_safety_ports_first() {
    let mut h = polling(PollRate::LineSpeed, 2);
    h.expect_text("@0P");
    h.reply(&position_reply(1, 0, 0));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b3");
    h.reply(b"000");
    h.expect_text("@0b2");
    h.reply(b"0E2");
    assert_eq!(
        h.events
            .iter()
            .filter(|e| matches!(e, Event::Io(_)))
            .count(),
        1,
        "one snapshot per port cycle"
    );
    h.expect_text("@0P");
    h.reply(&position_reply(2, 0, 0));
    h.expect_text("@0P");
    h.reply(&position_reply(3, 0, 0));
    h.expect_text("@0b1");
}

#[test]
fn a_request_goes_between_two_polls() {
    let mut h = polling(PollRate::LineSpeed, 4);
    h.expect_text("@0P");
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 10),
        speed_hz: speeds(1_000.0),
    });
    // Not while the poll is outstanding: one command at a time.
    h.expect_nothing();
    h.reply(&position_reply(0, 0, 0));
    h.expect_text("@0A10,1000,0,300,0,300,0,300");
}

#[test]
fn a_rate_spaces_the_cycles() {
    let mut h = polling(PollRate::Hz(10.0), 1_000);
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    for port in ["@0b1", "@0b3", "@0b2"] {
        h.expect_text(port);
        h.reply(b"000");
    }
    h.expect_nothing();
    h.advance(ms(99));
    h.expect_nothing();
    h.advance(ms(1));
    h.expect_text("@0P");
}

#[test]
fn polling_can_be_switched_off_and_on() {
    let mut h = polling(PollRate::LineSpeed, 4);
    h.request(Request::Poll {
        rate_hz: Some(0.0),
        ports_every: 4,
    });
    h.expect_nothing();
    h.request(Request::Poll {
        rate_hz: None,
        ports_every: 4,
    });
    h.expect_text("@0P");
}

#[test]
fn stats_report_the_rate_and_the_wire_limit_once_a_second() {
    let mut h = polling(PollRate::LineSpeed, 1_000);
    // The first cycle also reads the ports.
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    for _ in 0..3 {
        h.send();
        h.reply(b"000");
    }
    for _ in 0..90 {
        h.advance(ms(12));
        h.expect_text("@0P");
        h.reply(&position_reply(0, 0, 0));
    }
    let stats: Vec<_> = h
        .events
        .iter()
        .filter_map(|e| match e {
            Event::Stats(s) => Some(*s),
            _ => None,
        })
        .collect();
    assert_eq!(stats.len(), 1);
    let s = stats[0];
    assert!((s.position_rate_hz - 1000.0 / 12.0).abs() < 1.0, "{s:?}");
    assert!(s.wire_limit_hz > 80.0 && s.wire_limit_hz < 83.5, "{s:?}");
}

#[test]
fn port_bits_update_the_machine_state() {
    let mut h = polling(PollRate::LineSpeed, 1);
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b3");
    h.reply(b"010");
    assert!(h.state().limit, "Z1 active");
    h.expect_text("@0b2");
    h.reply(b"0E2");
    let io = h
        .events
        .iter()
        .rev()
        .find_map(|e| match e {
            Event::Io(io) => Some(io.clone()),
            _ => None,
        })
        .expect("snapshot");
    let limits = io
        .groups
        .iter()
        .find(|g| g.name.contains("limit"))
        .expect("port 3");
    assert_eq!(limits.raw, Some(0x10));
    assert!(limits.bits[4].value && limits.bits[4].name == "limit Z1");
    let _ = InputPort::LimitSwitches;
}

#[test]
fn an_uninitialised_controller_answering_4_is_no_fault() {
    let mut h = Harness::with(|s| s.poll.rate = PollRate::LineSpeed);
    h.connect();
    h.expect_text("@0P");
    h.reply(b"4");
    h.advance(ms(60));
    for r in [b"003", b"0E2", b"000"] {
        h.send();
        h.reply(r);
    }
    h.expect_text("@0P");
    h.reply(b"4");
    h.expect_text("@0b1");
    assert!(h.faults().is_empty(), "{:?}", h.faults());
}

#[test]
fn a_port_the_controller_has_not_got_is_left_out_of_polling() {
    let mut h = Harness::with(|s| {
        s.poll = PollPlan {
            rate: PollRate::LineSpeed,
            positions: true,
            ports_every: 1,
            ports: PollPlan::DEFAULT_PORTS.to_vec(),
        };
    });
    h.connect();
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.advance(ms(60));
    h.expect_text("@0b1");
    h.reply(b"003");
    // No port 2 on this controller (manual chapter 5, `1`).
    h.expect_text("@0b2");
    h.reply(b"1");
    h.expect_text("@0b3");
    h.reply(b"000");
    h.expect_text("@0A0,300,0,300,0,300,0,300");
    h.reply(b"0");
    for (cmd, r) in [
        ("@0j300", b"0"),
        ("@0J100", b"0"),
        ("@0d4000,4000,4000", b"0"),
    ] {
        h.expect_text(cmd);
        h.reply(r);
    }
    assert!(
        h.notices().iter().any(|n| n.contains("no input port 2")),
        "{:?}",
        h.notices()
    );
    assert!(h.state().fault.is_none(), "no fault: {:?}", h.state().fault);
    // Two poll cycles: ports 1 and 3, never 2 again.
    for _ in 0..2 {
        h.expect_text("@0P");
        h.reply(&position_reply(0, 0, 0));
        h.expect_text("@0b1");
        h.reply(b"003");
        h.expect_text("@0b3");
        h.reply(b"000");
    }
    h.expect_text("@0P");
    // Moves are not held up by the missing port.
    h.reply(&position_reply(0, 0, 0));
    h.take_events();
    h.request(Request::Step {
        delta: PerAxis::new().with(Axis::X, 10),
        speed_hz: speeds(500.0),
    });
    h.expect_text("@0A10,500,0,300,0,300,0,300");
}
