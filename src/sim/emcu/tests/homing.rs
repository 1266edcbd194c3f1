//! Reference runs (manual 1.5.8, 1.5.9): in the order given, at the start
//! speed, towards the switch in the negative direction, off it, then the
//! 25-step offset where the counter becomes 0.

use std::time::Duration;

use super::harness::{Conversation, ms};
use crate::proto::emcu::EmcuAxis;
use crate::sim::emcu::{AxisTravel, EmcuSimConfig, EndStops};

const READY: &[u8] = b"\x02\r";

fn machine(low: i64, high: i64, start: i64) -> EmcuSimConfig {
    EmcuSimConfig {
        axes: [AxisTravel {
            end_stops: Some(EndStops::new(low, high)),
            start,
        }; 3],
    }
}

#[test]
fn homing_zxy_runs_the_axes_in_that_order() {
    // Every carriage 8000 steps above its switch: 40 s of search at 200 Hz,
    // 5 ms off the switch, 125 ms of offset: 40.13 s per axis.
    let mut c = Conversation::new();
    assert_eq!(c.send("$HZXY\x01"), "<CR>");
    let start = c.elapsed();
    assert_eq!(c.flags(), "100110");
    let mut samples = Vec::new();
    while c.elapsed() < start + Duration::from_secs(125) {
        c.wait(Duration::from_secs(1));
        let t = (c.elapsed() - start).as_secs_f64();
        let z = c.position(EmcuAxis::Z);
        let x = c.position(EmcuAxis::X);
        let y = c.position(EmcuAxis::Y);
        samples.push((t, z, x, y));
    }
    let per_axis = 40.0 + 0.005 + 0.125;
    for (t, z, x, y) in &samples {
        if *t < 40.0 {
            assert!(*z < 0 && *x == 0 && *y == 0, "{t}: Z first {z} {x} {y}");
        } else if *t > per_axis && *t < 2.0 * per_axis - 0.2 {
            assert!(*z == 0 && *x < 0 && *y == 0, "{t}: X second {z} {x} {y}");
        } else if *t > 2.0 * per_axis && *t < 3.0 * per_axis - 0.2 {
            assert!(*z == 0 && *x == 0 && *y < 0, "{t}: Y last {z} {x} {y}");
        }
    }
    // The search reaches the switch 8000 steps down.
    assert!(samples.iter().any(|s| s.1 < -7_000));
    let ready = c.times_of(READY);
    assert_eq!(ready.len(), 1);
    let took = (ready[0] - start).as_secs_f64();
    assert!((took - 3.0 * per_axis).abs() < 1e-6, "{took}");
    assert_eq!(c.flags(), "000000");
    // Counter 0 sits one step off the switch plus the offset.
    for axis in EmcuAxis::ALL {
        assert_eq!(c.position(axis), 0);
        assert_eq!(c.sim.machine_position(axis, c.now), 26);
    }
}

#[test]
fn status_shows_moving_and_referencing_throughout_the_run() {
    let mut c = Conversation::with(machine(-400, 60_400, 1_000));
    assert_eq!(c.send("$HX\x01"), "<CR>");
    for _ in 0..10 {
        c.wait(ms(500));
        assert_eq!(c.flags(), "100110");
    }
    assert!(c.wait_for(READY, Duration::from_secs(10)).is_some());
    assert_eq!(c.flags(), "000000");
}

#[test]
fn the_counter_counts_down_during_the_search_and_up_during_the_offset() {
    let mut c = Conversation::with(machine(-400, 60_400, 1_000));
    assert_eq!(c.send("L1,x500\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(10)).is_some());
    assert_eq!(c.send("$HX\x01"), "<CR>");
    // 1500 steps to the switch at 200 Hz take 7.5 s.
    c.wait(ms(7_500));
    assert_eq!(c.position(EmcuAxis::X), -1000);
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 0);
    c.wait(ms(5 + 60));
    assert_eq!(c.position(EmcuAxis::X), -1000 + 1 + 12);
    assert!(c.wait_for(READY, Duration::from_secs(1)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 0);
}

#[test]
fn the_reference_speed_is_the_start_speed() {
    let mut c = Conversation::with(machine(-400, 60_400, 375));
    assert_eq!(c.send("#S400\r$HY\x01"), "<CR><CR>");
    let sent = c.elapsed();
    let ready = c.wait_for(READY, Duration::from_secs(10)).unwrap();
    // 375 + 1 + 25 steps at 400 Hz.
    let expected = Duration::from_micros(401 * 2_500);
    assert!((ready - sent).abs_diff(expected) < Duration::from_micros(10));
}

#[test]
fn a_carriage_on_the_switch_only_backs_off_it() {
    let mut c = Conversation::with(machine(-400, 60_400, -100));
    assert_eq!(c.send("$HX\x01"), "<CR>");
    c.wait(ms(100));
    assert_eq!(c.position(EmcuAxis::X), 20, "goes up from the start");
    assert!(c.wait_for(READY, Duration::from_secs(5)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 0);
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 26);
}

#[test]
fn a_switch_behind_the_end_stop_is_searched_until_halted() {
    let mut c = Conversation::with(machine(100, 60_400, 500));
    assert_eq!(c.send("$HX\x01"), "<CR>");
    assert_eq!(c.wait(Duration::from_secs(60)), "");
    assert_eq!(c.flags(), "100110");
    assert_eq!(c.position(EmcuAxis::X), -12_000);
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 100);
    // At the start speed there is no ramp: @B stops at once.
    assert_eq!(c.send("@B\r"), "<CR><02><CR>");
    assert_eq!(c.flags(), "000100");
}

#[test]
fn any_completed_reference_run_makes_the_position_known() {
    let mut c = Conversation::with(machine(-400, 60_400, 100));
    assert_eq!(c.send("$HY\x01"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(5)).is_some());
    assert_eq!(c.flags(), "000000");
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 100);
}

#[test]
fn an_interrupted_reference_run_leaves_the_position_unknown() {
    let mut c = Conversation::referenced();
    assert_eq!(c.send("$HX\x01"), "<CR>");
    c.wait(ms(100));
    assert_eq!(c.send("@B\r"), "<CR><02><CR>");
    assert_eq!(c.flags(), "000100");
}

#[test]
fn a_paused_reference_run_goes_on_where_it_stopped() {
    let mut c = Conversation::with(machine(-400, 60_400, 1_000));
    assert_eq!(c.send("$HX\x01"), "<CR>");
    c.wait(ms(1_000));
    assert_eq!(c.send("@A\r"), "<CR>");
    let at = c.position(EmcuAxis::X);
    c.wait(Duration::from_secs(3));
    assert_eq!(c.position(EmcuAxis::X), at);
    assert_eq!(c.flags(), "000110");
    assert_eq!(c.send("@C\r"), "<CR>");
    assert!(c.wait_for(READY, Duration::from_secs(10)).is_some());
    assert_eq!(c.position(EmcuAxis::X), 0);
    assert_eq!(c.sim.machine_position(EmcuAxis::X, c.now), 26);
    assert_eq!(c.flags(), "000000");
}
