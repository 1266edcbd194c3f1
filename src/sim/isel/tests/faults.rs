//! Limit switches, E-stop circuits, power, temperature and the hood
//! (isel manual 2.2.3, 2.2.24, chapter 5; decisions 4 and 7).

use std::time::Duration;

use super::{Conv, assert_close};
use crate::motion::{Profile, Ramp};

const MINUTE: Duration = Duration::from_secs(60);

/// When a move of `steps` at `hz` has covered `at` steps.
fn time_to(steps: u64, hz: f64, at: f64) -> Duration {
    let p = Profile::new(
        steps,
        Ramp {
            start_hz: 300.0,
            max_hz: hz,
            accel_hz_per_s: 100_000.0,
        },
    );
    let (mut lo, mut hi) = (Duration::ZERO, p.duration());
    while hi - lo > Duration::from_nanos(1) {
        let mid = lo + (hi - lo) / 2;
        if p.position_at(mid) >= at {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[test]
fn a_limit_switch_stops_the_move_where_it_is_with_2() {
    let mut c = Conv::referenced();
    // X 0-300 mm: switch 2 at 302 mm = 120800 steps.
    let took = c.expect_after("@0A130000,40000,0,100,0,100,0,100", "2", MINUTE);
    assert_close(took, time_to(130_000, 40_000.0, 120_800.0), "at the switch");
    assert_eq!(c.position(), [120_800, 0, 0]);
    assert_eq!(c.ask("@0b3"), "002");
    assert_eq!(c.ask("@0DRp"), "001");
    // Re-initialise and reference (chapter 5, code 2).
    c.expect("@0A-10,100,0,100,0,100,0,100", "4");
    c.expect("@07", "0");
    c.expect("@0A-10,100,0,100,0,100,0,100", "R");
    // Standing in the switch, any move answers `2` again.
    c.expect("@0N7", "0");
    c.expect("@0A-10,100,0,100,0,100,0,100", "2");
    c.expect("@07", "0");
    // X seeks 121600 steps back to switch 1 at 2000 Hz.
    c.expect_after("@0R7", "0", 2 * MINUTE);
    assert_eq!(c.physical()[0], 0.0);
    assert_eq!(c.ask("@0b3"), "000");
}

#[test]
fn an_operator_tripped_switch_stops_a_move() {
    let mut c = Conv::referenced();
    c.send("@0A20000,2000,0,100,0,100,0,100");
    c.wait(Duration::from_secs(1));
    let x = c.physical()[0];
    c.set("limit-y1", true);
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "2");
    assert_close(took, Duration::from_secs(1), "at once");
    assert_eq!(f64::from(c.position()[0]), x.round());
    assert_eq!(c.ask("@0b3"), "004");
    assert_eq!(c.ask("@0DRn"), "002");
    c.set("limit-y1", false);
    assert_eq!(c.ask("@0b3"), "000");
}

#[test]
fn test_mode_overruns_switches_and_still_reports_them() {
    let mut c = Conv::referenced();
    c.expect("@0T1", "0");
    c.expect_after("@0A0,100,0,100,-1000,4000,0,100", "0", MINUTE);
    assert_eq!(c.position(), [0, 0, -1000]);
    assert_eq!(c.ask("@0b3"), "010");
    c.expect_after("@0A0,100,0,100,1000,4000,0,100", "0", MINUTE);
    assert_eq!(c.ask("@0b3"), "000");
}

#[test]
fn an_open_emergency_stop_circuit_stops_at_once_with_9() {
    let mut c = Conv::referenced();
    c.send("@0A20000,2000,0,100,0,100,0,100");
    c.wait(Duration::from_millis(1500));
    let x = c.physical()[0];
    c.set("estop1", false);
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "9");
    assert_close(took, Duration::from_millis(1500), "at once, no ramp");
    assert_eq!(f64::from(c.position()[0]), x.round());
    assert_eq!(c.ask("@0b1"), "002");
    // While it is open: initialising works, motion answers `9`.
    c.expect("@0A1,100,0,100,0,100,0,100", "4");
    c.expect("@07", "0");
    c.expect("@0R7", "9");
    c.expect("@0A1,100,0,100,0,100,0,100", "9");
    c.set("estop1", true);
    c.expect("@0A1,100,0,100,0,100,0,100", "R");
    c.expect_after("@0R7", "0", MINUTE);
    // An E-stop while idle loses the reference too.
    c.set("estop2", false);
    c.set("estop2", true);
    c.expect("@0A1,100,0,100,0,100,0,100", "4");
}

#[test]
fn over_temperature_and_power_fail_answer_9() {
    for (name, bad) in [("overtemp", true), ("power-ok", false)] {
        let mut c = Conv::referenced();
        c.set(name, bad);
        c.expect("@07", "0");
        c.expect("@0A1,100,0,100,0,100,0,100", "9");
        c.set(name, !bad);
        c.expect("@0A1,100,0,100,0,100,0,100", "R");
    }
}

#[test]
fn the_hood_guards_motion_and_the_spindle() {
    let mut c = Conv::referenced();
    c.expect("@0B2,1", "0");
    assert_eq!(c.ask("@0b2"), "063");
    c.set("hood", false);
    // Opening the hood stops the spindle.
    assert_eq!(c.ask("@0b2"), "002");
    c.expect("@0A1,100,0,100,0,100,0,100", "H");
    c.expect("@0R7", "H");
    c.expect("@0F1", "H");
    c.expect("@0B2,1", "H");
    c.expect("@0B100,16", "H");
    c.expect("@0B0,255", "0");
    // Setup mode (key switch): motion with the hood open, no spindle.
    c.set("key-switch", true);
    assert_eq!(c.ask("@0b2"), "0C2");
    c.expect_after("@0A1,100,0,100,0,100,0,100", "0", MINUTE);
    c.expect("@0B2,1", "H");
    c.set("hood", true);
    c.expect("@0B2,1", "0");
}

#[test]
fn opening_the_hood_during_a_move_in_automatic_mode_is_an_emergency_stop() {
    let mut c = Conv::referenced();
    c.send("@0A20000,2000,0,100,0,100,0,100");
    c.wait(Duration::from_millis(500));
    c.set("hood", false);
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "9");
    assert_close(took, Duration::from_millis(500), "at once");
    c.set("hood", true);
    c.expect("@0A1,100,0,100,0,100,0,100", "4");
}
