//! Controller errors during motion (`2`, `9`, `R`) and the recovery path:
//! refused until initialised, then until referenced.

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, Event, JogEnd, JogId, Recovery, Refusal, Request};

use super::harness::{Harness, ms, position_reply, speeds, xyz};

#[test]
fn a_limit_switch_ends_a_jog_and_blocks_motion_until_initialised_and_referenced() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Jog {
        id: JogId(9),
        axes: vec![(Axis::X, Dir::Plus)],
        speed_hz: speeds(2_000.0),
        lease: ms(750),
    });
    h.send();
    h.advance(ms(200));
    h.reply(b"2");
    let ended = h.events.iter().find_map(|e| match e {
        Event::JogEnded { id, end } => Some((*id, end.clone())),
        _ => None,
    });
    assert!(matches!(ended, Some((JogId(9), JogEnd::Fault(ref f))) if f.code == "2"));
    h.expect_text("@0P");
    h.reply(&position_reply(300, 0, 0));
    let s = h.state();
    assert!(s.limit);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    assert_eq!(
        s.fault.as_ref().map(|f| f.recovery),
        Some(Recovery::ReinitialiseAndReference)
    );
    h.take_events();
    h.request(Request::Step {
        delta: xyz(-10, 0, 0),
        speed_hz: speeds(500.0),
    });
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        [
            "step X=-10 Y=0 Z=0: limit switch hit: initialise (i) and reference (h) the axes",
            "home XYZ: limit switch hit: initialise (i) and reference (h) the axes"
        ]
    );
    h.request(Request::Initialise);
    for (cmd, r) in [
        ("@07", b"0".to_vec()),
        ("@0j300", b"0".to_vec()),
        ("@0J100", b"0".to_vec()),
        ("@0d4000,4000,4000", b"0".to_vec()),
        ("@0A0,300,0,300,0,300,0,300", b"R".to_vec()),
        ("@0P", position_reply(300, 0, 0)),
    ] {
        h.expect_text(cmd);
        h.reply(&r);
    }
    assert_eq!(
        h.state().fault.as_ref().map(|f| f.recovery),
        Some(Recovery::Reference)
    );
    h.take_events();
    h.request(Request::Step {
        delta: xyz(-10, 0, 0),
        speed_hz: speeds(500.0),
    });
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        ["step X=-10 Y=0 Z=0: axes XYZ not referenced: reference them (h) first"]
    );
    h.request(Request::Home { axes: AxisSet::XYZ });
    h.expect_text("@0R7");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    let s = h.state();
    assert!(s.fault.is_none());
    assert_eq!(s.referenced, AxisSet::XYZ);
}

#[test]
fn an_estop_reply_blocks_motion_as_emergency_stop() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: xyz(100, 0, 0),
        speed_hz: speeds(1_000.0),
    });
    h.send();
    h.reply(b"9");
    h.expect_text("@0P");
    h.reply(&position_reply(40, 0, 0));
    assert!(h.state().estop);
    h.take_events();
    h.request(Request::Step {
        delta: xyz(100, 0, 0),
        speed_hz: speeds(1_000.0),
    });
    h.expect_nothing();
    assert!(matches!(
        h.events.iter().find_map(|e| match e {
            Event::Refused { reason, .. } => Some(reason.clone()),
            _ => None,
        }),
        Some(Refusal::EmergencyStop)
    ));
}

#[test]
fn a_reference_required_reply_clears_the_reference() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: xyz(100, 0, 0),
        speed_hz: speeds(1_000.0),
    });
    h.send();
    h.reply(b"R");
    let fault = h
        .events
        .iter()
        .find_map(|e| match e {
            Event::Fault(f) => Some(f.clone()),
            _ => None,
        })
        .expect("fault");
    assert_eq!(fault.recovery, Recovery::Reference);
    assert_eq!(h.state().referenced, AxisSet::EMPTY);
    assert!(
        h.state().fault.is_none(),
        "`R` blocks by the reference, not as a fault"
    );
}

#[test]
fn busy_requests_are_refused_while_a_move_runs() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Step {
        delta: xyz(100, 0, 0),
        speed_hz: speeds(1_000.0),
    });
    h.send();
    h.request(Request::Initialise);
    h.request(Request::Raw { line: "@0P".into() });
    assert_eq!(
        h.refusals(),
        [
            "initialise: busy (Stepping): stop it first",
            "raw @0P: busy (Stepping): stop it first"
        ]
    );
}

#[test]
fn a_stop_cancels_queued_requests() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(Request::Raw { line: "@0P".into() });
    h.request(Request::Raw {
        line: "@0b1".into(),
    });
    h.expect_text("@0P");
    h.stop();
    assert_eq!(h.refusals(), ["raw @0b1: cancelled by stop"]);
}

/// Connected and read back, polling at line speed with the ports read in
/// every cycle.
fn polling_the_ports_every_cycle() -> Harness {
    let mut h = Harness::with(|s| {
        s.poll.rate = crate::device::isel::PollRate::LineSpeed;
        s.poll.ports_every = 1;
        // The safety ports; the user inputs (port 0) play no part here.
        s.poll.ports = crate::device::isel::PollPlan::DEFAULT_PORTS.to_vec();
    });
    h.connect();
    h.readback(0, 0, 0, b"0");
    h.take_events();
    h
}

#[test]
fn an_open_hood_blocks_motion_while_it_is_open() {
    let mut h = polling_the_ports_every_cycle();
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b3");
    h.reply(b"000");
    h.expect_text("@0b2");
    // Power ok, hood open, automatic.
    h.reply(b"002");
    assert_eq!(
        h.state().fault.as_ref().map(|f| f.recovery),
        Some(Recovery::CloseHood)
    );
    h.request(Request::Step {
        delta: xyz(10, 0, 0),
        speed_hz: speeds(500.0),
    });
    h.expect_text("@0P");
    assert_eq!(
        h.refusals(),
        ["step X=10 Y=0 Z=0: controller error: close the hood"]
    );
    h.reply(&position_reply(0, 0, 0));
    for (cmd, r) in [("@0b1", b"003"), ("@0b3", b"000"), ("@0b2", b"062")] {
        h.expect_text(cmd);
        h.reply(r);
    }
    assert!(h.state().fault.is_none(), "closed again");
}

/// Issue 20, finding 6: once both E-stop circuits were closed again, the
/// fault still asked to release the emergency stop (and read "open.:").
#[test]
fn an_estop_circuit_closed_again_leaves_initialise_and_reference_to_do() {
    let mut h = polling_the_ports_every_cycle();
    let cycle = |h: &mut Harness, port1: &[u8]| {
        h.expect_text("@0P");
        h.reply(&position_reply(0, 0, 0));
        for (cmd, r) in [("@0b1", port1), ("@0b3", b"000"), ("@0b2", b"0E2")] {
            h.expect_text(cmd);
            h.reply(r);
        }
    };
    // Circuit 2 opens.
    cycle(&mut h, b"001");
    let s = h.state();
    assert!(s.estop);
    let fault = s.fault.expect("a fault");
    assert_eq!(fault.recovery, Recovery::ClearEmergencyStop);
    assert_eq!(fault.meaning, "An emergency stop circuit opened");
    // Closed again: what is left to do is initialise and reference.
    cycle(&mut h, b"003");
    let s = h.state();
    assert!(!s.estop);
    let fault = s.fault.expect("still a fault: the axes are lost");
    assert_eq!(fault.recovery, Recovery::ReinitialiseAndReference);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    // Over temperature keeps it asking to clear the fault first.
    cycle(&mut h, b"007");
    assert_eq!(
        h.state().fault.map(|f| f.recovery),
        Some(Recovery::ClearEmergencyStop)
    );
    cycle(&mut h, b"003");
    assert_eq!(
        h.state().fault.map(|f| f.recovery),
        Some(Recovery::ReinitialiseAndReference)
    );
}
