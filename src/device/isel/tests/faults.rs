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

/// The default wiring with `addresses` declared wired (`[io."…"] wired = true`).
fn wired(addresses: &[&str]) -> crate::wiring::Wiring {
    let patches = addresses
        .iter()
        .map(|a| {
            (
                a.to_string(),
                crate::wiring::BitPatch {
                    wired: Some(true),
                    ..Default::default()
                },
            )
        })
        .collect();
    let (wiring, problems) =
        crate::wiring::Wiring::defaults(crate::proto::Protocol::Isel, AxisSet::XYZ, &[])
            .patched(&patches, AxisSet::XYZ);
    assert!(problems.is_empty(), "{problems:?}");
    wiring
}

/// Connected and read back, polling at line speed with the ports read in
/// every cycle; with `wiring` instead of the default profile's.
fn polling_the_ports_every_cycle(wiring: Option<crate::wiring::Wiring>) -> Harness {
    let mut h = Harness::with(|s| {
        s.poll.rate = crate::device::isel::PollRate::LineSpeed;
        s.poll.ports_every = 1;
        if let Some(w) = wiring {
            s.wiring = w;
        }
    });
    h.connect();
    h.readback(0, 0, 0, b"0");
    h.take_events();
    h
}

/// [`polling_the_ports_every_cycle`] (referenced at 0), then one poll cycle
/// of the ports with port 2 reading `port2`.
fn polled_with_port2(wiring: Option<crate::wiring::Wiring>, port2: &[u8]) -> Harness {
    let mut h = polling_the_ports_every_cycle(wiring);
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.expect_text("@0b1");
    h.reply(b"003");
    h.expect_text("@0b3");
    h.reply(b"000");
    h.expect_text("@0b2");
    h.reply(port2);
    h
}

#[test]
fn hood_and_power_bits_the_profile_does_not_declare_wired_never_block_motion() {
    // A machine without a hood circuit (bits 5/6 read 0), and one whose
    // power-ok input reads 0: the controller decides (it moves, or answers
    // `9`/`H`), not jogterm's reading of the bits.
    for port2 in [b"002", b"000"] {
        let mut h = polled_with_port2(None, port2);
        assert_eq!(h.state().fault, None, "port 2 = {port2:?}");
        assert!(!h.state().estop);
        h.request(Request::Step {
            delta: xyz(10, 0, 0),
            speed_hz: speeds(500.0),
        });
        h.expect_text("@0A10,500,0,300,0,300,0,300");
        assert!(h.refusals().is_empty(), "{:?}", h.refusals());
    }
}

#[test]
fn a_hood_declared_wired_blocks_motion_while_it_is_open() {
    let mut h = polled_with_port2(Some(wired(&["in2.5", "in2.6"])), b"002");
    // Power ok, hood open, automatic.
    let fault = h.state().fault.expect("the hood");
    assert_eq!(fault.recovery, Recovery::CloseHood);
    assert!(
        fault.meaning.contains("hood closed or setup (in2.6)"),
        "{}",
        fault.meaning
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
    // Hood still open, key switch on setup: bit 6 reads 1, the controller
    // moves (manual 2.2.3), so does jogterm.
    for (cmd, r) in [("@0b1", b"003"), ("@0b3", b"000"), ("@0b2", b"0C2")] {
        h.expect_text(cmd);
        h.reply(r);
    }
    assert!(h.state().fault.is_none(), "setup mode");
}

#[test]
fn a_power_input_declared_wired_is_a_machine_fault() {
    let h = polled_with_port2(Some(wired(&["in2.1"])), b"060");
    let fault = h.state().fault.expect("power");
    assert_eq!(fault.recovery, Recovery::ClearEmergencyStop);
    assert!(
        fault.meaning.contains("power ok (in2.1)"),
        "{}",
        fault.meaning
    );
    assert_eq!(h.state().referenced, AxisSet::EMPTY);
}

#[test]
fn the_controllers_h_is_explained_with_the_hood_inputs() {
    let mut h = polled_with_port2(None, b"002");
    h.take_events();
    h.request(Request::Raw {
        line: "@0A10,500,0,300,0,300,0,300".into(),
    });
    h.expect_text("@0A10,500,0,300,0,300,0,300");
    h.reply(b"H");
    let fault = h
        .events
        .iter()
        .find_map(|e| match e {
            Event::Fault(f) => Some(f.clone()),
            _ => None,
        })
        .expect("the H");
    assert_eq!(fault.code, "H");
    assert_eq!(fault.recovery, Recovery::CloseHood);
    assert!(fault.meaning.contains("@0IH"), "{}", fault.meaning);
    assert!(
        fault
            .meaning
            .contains("hood closed or setup (in2.6) reads 0"),
        "{}",
        fault.meaning
    );
}

/// Issue 20, finding 6: once both E-stop circuits were closed again, the
/// fault still asked to release the emergency stop (and read "open.:").
/// Over-temperature counts only where the profile wires it (finding 1).
#[test]
fn an_estop_circuit_closed_again_leaves_initialise_and_reference_to_do() {
    let mut h = polling_the_ports_every_cycle(Some(wired(&["in1.2"])));
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
    assert_eq!(fault.meaning, "E-stop circuit 2 (in1.1) opened");
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

/// What jogterm knows of the outputs (`docs/protocols.md`, isel): the byte
/// of its own `@0B` that was answered `0`, kept over an axis setting, lost
/// with a reset (0xFE), a program run and a new connection.
#[test]
fn outputs_are_known_from_jogterms_own_writes_only() {
    use crate::device::api::OutputId;
    let bit = |b: u8, value: u8| Request::SetOutput {
        output: OutputId {
            group: 0,
            bit: Some(b),
        },
        value,
    };
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(bit(1, 1));
    h.expect_nothing();
    assert!(h.refusals()[0].contains("the other bits of port 0 are unknown"));
    h.take_events();
    h.request(Request::SetOutput {
        output: OutputId {
            group: 0,
            bit: None,
        },
        value: 0x02,
    });
    h.expect_text("@0B0,2");
    h.reply(b"0");
    h.request(bit(0, 1));
    h.expect_text("@0B0,3");
    h.reply(b"0");
    // An axis setting leaves the outputs alone.
    h.request(Request::Raw { line: "@07".into() });
    h.expect_text("@07");
    h.reply(b"0");
    h.request(bit(7, 1));
    h.expect_text("@0B0,131");
    h.reply(b"0");
    // A stored program may write any port.
    h.request(Request::RunProgram);
    h.expect_text("@0S");
    h.reply(b"0");
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.take_events();
    h.request(bit(7, 0));
    h.expect_nothing();
    assert!(h.refusals()[0].contains("unknown"), "{:?}", h.refusals());
    // Written again; then the reset forgets it.
    h.take_events();
    h.request(Request::SetOutput {
        output: OutputId {
            group: 0,
            bit: None,
        },
        value: 0,
    });
    h.expect_text("@0B0,0");
    h.reply(b"0");
    h.request(Request::Reset);
    h.expect(&[0xFE]);
    h.advance(ms(200));
    h.take_events();
    h.request(bit(3, 1));
    h.expect_nothing();
    assert!(
        h.refusals().iter().any(|r| r.contains("unknown")),
        "{:?}",
        h.refusals()
    );
}
