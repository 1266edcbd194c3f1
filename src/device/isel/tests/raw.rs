//! Raw lines: validated before a byte goes out, replies decoded, state
//! followed, control bytes at once.

use crate::axis::AxisSet;
use crate::device::api::{Event, ProgramState, Recovery, Request};

use super::harness::{Harness, ms, position_reply};

fn raw(line: &str) -> Request {
    Request::Raw { line: line.into() }
}

fn replies(h: &Harness) -> Vec<(String, String)> {
    h.events
        .iter()
        .filter_map(|e| match e {
            Event::Reply { command, text, .. } => Some((command.clone(), text.clone())),
            _ => None,
        })
        .collect()
}

#[test]
fn a_bad_line_is_refused_with_the_validators_message() {
    let mut h = Harness::ready();
    h.request(raw("@0A5000,900"));
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        [
            "raw @0A5000,900: `A` with XYZ takes 4 steps,speed pairs (x, y, z1, z2), got 1 (a controller answers `7` wrong parameter count)"
        ]
    );
    h.request(raw("@3P"));
    h.expect_nothing();
    assert!(h.refusals()[1].contains("addressed to device 3"));
}

#[test]
fn replies_are_decoded_as_text() {
    let mut h = Harness::ready();
    h.request(raw("@0P"));
    h.expect_text("@0P");
    h.reply(&position_reply(256, 131_087, -2));
    h.request(raw("@0b1"));
    h.expect_text("@0b1");
    h.reply(b"003");
    assert_eq!(
        replies(&h),
        [
            ("@0P".to_owned(), "0 X=256 Y=131087 Z=-2 (steps)".to_owned()),
            (
                "@0b1".to_owned(),
                "0 0x03 (00000011): E-stop circuit 1, E-stop circuit 2".to_owned()
            ),
        ]
    );
}

#[test]
fn controller_errors_become_faults_with_recovery() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(raw("@0A 100,900,0,900,0,900,0,900"));
    h.expect_text("@0A100,900,0,900,0,900,0,900");
    h.reply(b"2");
    let fault = h
        .events
        .iter()
        .find_map(|e| match e {
            Event::Fault(f) => Some(f.clone()),
            _ => None,
        })
        .expect("fault");
    assert_eq!(fault.code, "2");
    assert_eq!(fault.recovery, Recovery::ReinitialiseAndReference);
    assert_eq!(h.state().referenced, AxisSet::EMPTY);
    // After the move, the position is read.
    h.expect_text("@0P");
}

#[test]
fn the_reference_state_is_left_to_the_controller() {
    let mut h = Harness::new();
    h.connect();
    h.readback(0, 0, 0, b"R");
    h.request(raw("@0A100,900,0,900,0,900,0,900"));
    h.expect_text("@0A100,900,0,900,0,900,0,900");
    h.reply(b"R");
    h.expect_text("@0P");
}

#[test]
fn raw_motion_is_refused_after_a_limit_switch_fault() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(raw("@0A100,900,0,900,0,900,0,900"));
    h.expect_text("@0A100,900,0,900,0,900,0,900");
    h.reply(b"2");
    h.expect_text("@0P");
    h.reply(&position_reply(90, 0, 0));
    h.request(raw("@0A-100,900,0,900,0,900,0,900"));
    h.expect_nothing();
    assert_eq!(
        h.refusals(),
        [
            "raw @0A-100,900,0,900,0,900,0,900: limit switch hit: initialise (i) and reference (h) the axes"
        ]
    );
    // Queries still go.
    h.request(raw("@0b3"));
    h.expect_text("@0b3");
}

#[test]
fn a_soft_stop_leaves_the_rest_to_resume() {
    let mut h = Harness::ready_at(0, 0, 0);
    h.request(raw("@0A50000,2000,0,900,0,900,0,900"));
    h.expect_text("@0A50000,2000,0,900,0,900,0,900");
    h.advance(ms(300));
    h.request(raw("\u{fd}"));
    // Only the byte asked for: the rest of the move stays for `@0S`.
    h.expect(&[0xFD]);
    h.reply(b"F");
    let fault = h
        .events
        .iter()
        .find_map(|e| match e {
            Event::Fault(f) => Some(f.clone()),
            _ => None,
        })
        .expect("fault F");
    assert_eq!(fault.code, "F");
    assert_eq!(fault.recovery, Recovery::ResumeOrDiscard);
}

#[test]
fn raw_state_changes_are_followed() {
    let mut h = Harness::new();
    h.connect();
    h.expect_text("@0P");
    h.reply(b"4");
    h.advance(ms(60));
    for r in [b"003", b"0E2", b"000"] {
        h.send();
        h.reply(r);
    }
    h.request(raw("@07"));
    h.expect_text("@07");
    h.reply(b"0");
    assert_eq!(h.state().initialised, AxisSet::XYZ);
    h.request(raw("@0R7"));
    h.expect_text("@0R7");
    h.reply(b"0");
    assert_eq!(h.state().referenced, AxisSet::XYZ);
    h.expect_text("@0P");
    h.reply(&position_reply(0, 0, 0));
    h.request(raw("@0T1"));
    h.expect_nothing();
    assert!(h.refusals()[0].contains("test mode"));
    h.request(raw("@0i"));
    h.expect_text("@0i");
    h.reply(b"0");
    assert_eq!(h.state().program, ProgramState::Invalid);
    // Storing: lines are CNC lines now, and no polls.
    h.request(raw("@0P"));
    h.expect_nothing();
    assert!(h.refusals()[1].contains("storing a program"));
    h.request(raw("0100,900,0,900,0,900,0,900"));
    h.expect_text("0100,900,0,900,0,900,0,900");
    h.reply(b"0");
    h.request(raw("9"));
    h.expect_text("9");
    h.reply(b"0");
    assert_eq!(h.state().program, ProgramState::Stored);
    h.request(raw("@0S"));
    h.expect_text("@0S");
    h.reply(b"!");
    h.reply(b"0");
    assert!(
        replies(&h)
            .iter()
            .any(|(c, t)| c == "@0S" && t == "0 ok (sync characters: !)")
    );
    h.expect_text("@0P");
}

#[test]
fn reset_leaves_the_controller_uninitialised() {
    let mut h = Harness::ready();
    h.request(raw("\u{fe}"));
    h.expect(&[0xFE]);
    let s = h.state();
    assert_eq!(s.initialised, AxisSet::EMPTY);
    assert_eq!(s.referenced, AxisSet::EMPTY);
    assert!(s.fault.is_none());
}

#[test]
fn a_control_byte_goes_out_at_once_whatever_is_outstanding() {
    let mut h = Harness::ready();
    h.request(raw("@0P"));
    h.expect_text("@0P");
    h.request(raw("\u{ff}"));
    h.expect(&[0xFF]);
    h.reply(&position_reply(1, 2, 3));
    assert!(
        replies(&h)
            .iter()
            .any(|(c, t)| c == "<FF>" && t == "break sent (control bytes have no reply)")
    );
}

/// What makes a console a session that moves (issue 24,
/// `SessionMoves::OnceAsked`): a typed read or a control byte is no motion,
/// a typed move, reference or start is, and so is a line that does not
/// parse (the safe side).
#[test]
fn a_typed_read_is_no_motion_a_typed_move_is() {
    use crate::device::driver::Driver;
    let h = Harness::new();
    let raw = |line: &str| Request::Raw { line: line.into() };
    for line in ["@0P", "@0b1", "@0V", "\u{fd}", "\u{ff}", "@07", "@0B1,1"] {
        assert!(!h.driver.may_move(&raw(line)), "{line:?}");
    }
    for line in [
        "@0M100,900,0,900,0,900,0,900",
        "@0R7",
        "@0S",
        "7 7",
        "nonsense",
    ] {
        assert!(h.driver.may_move(&raw(line)), "{line:?}");
    }
    assert!(h.driver.may_move(&Request::RunProgram));
    assert!(!h.driver.may_move(&Request::Initialise));
}
