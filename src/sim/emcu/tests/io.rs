//! Outputs `A1`/`A2` (manual 1.5.15), wait `W` (1.5.16) and the E1 linkage
//! `&V` (1.5.19) with the operator control `e1`.

use std::time::Duration;

use super::harness::{Conversation, ms};
use crate::proto::emcu::{EmcuAxis, Output};
use crate::sim::{InputControl, SimDevice};

const READY: &[u8] = b"\x02\r";

fn out(n: u16) -> Output {
    Output::new(n).unwrap()
}

fn e1(level: bool) -> InputControl {
    InputControl::Set {
        name: "e1".into(),
        level,
    }
}

#[test]
fn outputs_switch_in_turn_with_the_moves() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("A2,1\rL1,x1000\rA1,1\x01"), "<CR><CR><CR>");
    assert!(c.sim.output(out(2)));
    assert!(!c.sim.output(out(1)), "A1 waits for the move");
    assert!(c.sim.describe(c.now).contains("A1 off A2 on"));
    assert!(c.wait_for(READY, Duration::from_secs(5)).is_some());
    assert!(c.sim.output(out(1)));
    assert_eq!(c.send("A1,0\rA2,0\x01"), "<CR><CR><02><CR>");
    assert!(!c.sim.output(out(1)) && !c.sim.output(out(2)));
}

#[test]
fn a_wait_shows_the_waiting_flag_and_delays_what_follows() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("W250\rA1,1\x01"), "<CR><CR>");
    let sent = c.elapsed();
    assert_eq!(c.flags(), "010001");
    assert!(!c.sim.output(out(1)));
    let ready = c.wait_for(READY, Duration::from_secs(1)).unwrap();
    assert_eq!(ready - sent, ms(250));
    assert!(c.sim.output(out(1)));
    assert_eq!(c.flags(), "000000");
}

#[test]
fn linked_moves_wait_for_e1_high() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("&V1\rL1,x100\x01"), "<CR><CR>");
    assert_eq!(c.wait(Duration::from_secs(5)), "");
    assert_eq!(c.position(EmcuAxis::X), 0);
    assert_eq!(c.flags(), "000001", "the job waits, nothing moves");
    assert!(c.sim.describe(c.now).contains("awaiting E1"));
    c.sim.control(&e1(true), c.now).unwrap();
    assert_eq!(c.flags(), "100001");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 100);
    // E1 already high: the next linked move starts at once.
    assert_eq!(c.send("L1,x100\x01"), "<CR>");
    assert_eq!(c.flags(), "100001");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    // Low again: the linkage stays on for every following move.
    c.sim.control(&e1(false), c.now).unwrap();
    assert_eq!(c.send("L1,x100\x01"), "<CR>");
    assert_eq!(c.wait(Duration::from_secs(1)), "");
    assert_eq!(c.position(EmcuAxis::X), 200);
    // A push on E1 releases it; the move goes on after the button is let go.
    c.sim
        .control(&InputControl::Press { name: "E1".into() }, c.now)
        .unwrap();
    assert!(c.sim.describe(c.now).contains("E1 low"));
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 300);
    // Unlinked moves do not look at E1.
    assert_eq!(c.send("&V0\rL1,x100\x01"), "<CR><CR>");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 400);
}

#[test]
fn e1_does_not_hold_other_commands_or_reference_runs() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("&V1\rA1,1\rW10\r$HX\x01"), "<CR><CR><CR><CR>");
    assert!(c.wait_for(READY, Duration::from_secs(2)).is_some());
    assert!(c.sim.output(out(1)));
}

#[test]
fn a_move_waiting_for_e1_can_be_halted() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("&V1\rL1,x100\x01"), "<CR><CR>");
    assert_eq!(c.send("@B\r"), "<CR><02><CR>");
    c.sim.control(&e1(true), c.now).unwrap();
    assert_eq!(c.wait(Duration::from_secs(1)), "");
    assert_eq!(c.position(EmcuAxis::X), 0);
}

#[test]
fn unknown_inputs_are_refused_with_the_names_there_are() {
    let mut c = Conversation::new();
    assert_eq!(c.sim.input_names(), vec!["e1"]);
    let err = c
        .sim
        .control(
            &InputControl::Press {
                name: "start".into(),
            },
            c.now,
        )
        .unwrap_err();
    assert!(err.contains("start") && err.contains("e1"), "{err}");
    assert!(c.sim.describe(c.now).contains("E1 low"));
    c.sim.control(&e1(true), c.now).unwrap();
    assert!(c.sim.describe(c.now).contains("E1 high"));
}

#[test]
fn e1_level_is_reported() {
    let mut c = Conversation::referenced();
    assert_eq!(c.sim.input_level("E1"), Some(false));
    c.sim.control(&e1(true), c.now).unwrap();
    assert_eq!(c.sim.input_level("e1"), Some(true));
    assert_eq!(c.sim.input_level("E2"), None);
}
