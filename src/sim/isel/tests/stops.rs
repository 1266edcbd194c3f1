//! Control bytes and the start and stop keys (isel manual 2.2.23, 2.2.31;
//! decision 6).

use std::time::Duration;

use super::{Conv, assert_close};
use crate::motion::{Motion, Ramp};
use crate::sim::SimDevice;

const MINUTE: Duration = Duration::from_secs(60);
const SOFT_STOP: u8 = 0xFD;
const RESET: u8 = 0xFE;
const BREAK: u8 = 0xFF;

fn ramp(hz: f64) -> Ramp {
    Ramp {
        start_hz: 300.0,
        max_hz: hz,
        accel_hz_per_s: 100_000.0,
    }
}

#[test]
fn a_soft_stop_ramps_down_answers_f_and_start_finishes_the_move() {
    let mut c = Conv::referenced();
    c.send("@0A20000,4000,10000,4000,0,100,0,100");
    let start = c.sent_at;
    c.wait(Duration::from_secs(1));
    c.send_bytes(&[SOFT_STOP]);
    // The move answers `F` when the ramp down is over, without step loss.
    let mut motion = Motion::new(20_000, ramp(4000.0));
    motion.brake(c.now - start);
    let (reply, _) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "F");
    assert_close(c.now - start, motion.end_time(), "after the braking ramp");
    let x = motion.position_at(motion.end_time());
    assert!(x < 20_000.0);
    let steps = [x.round() as i32, (x / 2.0).round() as i32, 0];
    assert_eq!(c.position(), steps);
    // `@0S` finishes the rest and answers `0`.
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.position(), [20_000, 10_000, 0]);
    c.expect("@0S", "G");
}

#[test]
fn a_soft_stop_keeps_the_rest_of_a_two_and_a_half_d_move() {
    let mut c = Conv::referenced();
    c.send("@0A4000,4000,0,100,500,1000,-200,1000");
    c.wait(Duration::from_millis(300));
    c.send_bytes(&[SOFT_STOP]);
    assert_eq!(c.next_reply(MINUTE).expect("reply").0, "F");
    assert_eq!(c.position()[2], 0, "stopped in the XY leg");
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.position(), [4000, 0, 300]);
}

#[test]
fn break_discards_the_rest() {
    let mut c = Conv::referenced();
    c.send("@0A20000,4000,0,100,0,100,0,100");
    c.wait(Duration::from_secs(1));
    c.send_bytes(&[SOFT_STOP]);
    assert_eq!(c.next_reply(MINUTE).expect("reply").0, "F");
    // With nothing moving, 0xFF answers nothing and forgets the rest.
    c.send_bytes(&[BREAK]);
    c.silent_for(Duration::from_millis(50));
    c.expect("@0S", "G");
    // During a move: ramp down, `F`, nothing kept.
    c.send("@0A20000,4000,0,100,0,100,0,100");
    c.wait(Duration::from_secs(1));
    c.send_bytes(&[BREAK]);
    assert_eq!(c.next_reply(MINUTE).expect("reply").0, "F");
    let x = c.position()[0];
    assert!(x < 20_000 + 4000);
    c.expect("@0S", "G");
}

#[test]
fn control_bytes_with_nothing_moving_answer_nothing() {
    let mut c = Conv::referenced();
    c.send_bytes(&[SOFT_STOP, BREAK]);
    c.silent_for(Duration::from_millis(50));
    // Between the bytes of a command they leave the line alone.
    c.send_bytes(b"@0\xfdP\xff\r");
    assert_eq!(c.take(), "0000000000000000000");
}

#[test]
fn reset_stops_at_once_and_forgets_everything() {
    let mut c = Conv::referenced();
    c.send("@0A20000,4000,0,100,0,100,0,100");
    c.wait(Duration::from_secs(1));
    let before = c.physical()[0];
    c.send_bytes(&[RESET]);
    let x = c.physical()[0];
    c.silent_for(Duration::from_millis(100));
    // Stopped where it was when the byte arrived, without a ramp.
    assert_eq!(c.physical()[0], x);
    let one_byte = c.sim.line().byte_time().as_secs_f64();
    assert!(x >= before.round() && x <= before + 4000.0 * one_byte + 1.0);
    assert_eq!(c.position(), [0, 0, 0], "counters start over at 0");
    c.expect("@0A1,100,0,100,0,100,0,100", "4");
    c.expect("@07", "0");
    c.expect("@0A1,100,0,100,0,100,0,100", "R");
    // A partial line is gone too.
    c.send_bytes(b"@0\xfe");
    c.expect("@0P", "0000000000000000000");
}

#[test]
fn the_stop_key_is_a_soft_stop_and_the_start_key_resumes_silently() {
    let mut c = Conv::referenced();
    c.send("@0A20000,4000,0,100,0,100,0,100");
    c.wait(Duration::from_secs(1));
    c.press("stop");
    assert_eq!(c.next_reply(MINUTE).expect("reply").0, "F");
    // Held for a finger's instant, then let go (`controls::KEY_HOLD`).
    assert_eq!(c.ask("@0b1"), "013", "the key is still down");
    c.wait(super::super::controls::KEY_HOLD);
    assert_eq!(c.ask("@0b1"), "003", "the key is released again");
    c.press("start");
    // No command, so no answer; the move runs to its end.
    c.silent_for(Duration::from_secs(10));
    assert_eq!(c.position(), [20_000, 0, 0]);
    // Nothing to start: nothing happens, nothing answers.
    c.press("start");
    c.silent_for(super::super::controls::KEY_HOLD);
    // A held key shows on port 1.
    c.set("stop", true);
    assert_eq!(c.ask("@0b1"), "013");
    c.set("stop", false);
}
