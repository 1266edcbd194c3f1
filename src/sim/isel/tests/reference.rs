//! Reference runs (isel manual 2.2.5, 2.2.20, 2.2.22, 4.2.1, 4.2.2, 4.2.9;
//! decision 4) and clearing a limit switch (2.2.9).

use std::time::Duration;

use super::{Conv, START, assert_close};
use crate::motion::{Profile, Ramp};

const MINUTE: Duration = Duration::from_secs(60);

fn ramp(start_hz: f64, max_hz: f64) -> Ramp {
    Ramp {
        start_hz,
        max_hz,
        accel_hz_per_s: 100_000.0,
    }
}

/// One axis referenced from `start` with the default machine: seek the
/// switch at -800 at `hz`, step out 40 steps at 300 Hz, travel `clear`.
fn one_axis(start: f64, hz: f64, clear: u64) -> (Duration, Duration) {
    // Seek: the switch is reached during the cruise of a very long move.
    let to_switch = start + 800.0;
    // Time to cover `to_switch` steps: ramp then cruise.
    let t_ramp = (hz - 300.0) / 100_000.0;
    let ramp_steps = (hz * hz - 300.0 * 300.0) / 200_000.0;
    let seek_time = if to_switch >= ramp_steps {
        t_ramp + (to_switch - ramp_steps) / hz
    } else {
        ((300.0f64.powi(2) + 200_000.0 * to_switch).sqrt() - 300.0) / 100_000.0
    };
    let step_out = Duration::from_secs_f64(40.0 / 300.0_f64.min(hz));
    let travel = Profile::new(clear, ramp(300.0, hz)).duration();
    (Duration::from_secs_f64(seek_time), step_out + travel)
}

#[test]
fn the_reference_run_goes_z_y_x_and_lands_on_machine_zero() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    c.send("@0R7");
    let (seek, rest) = one_axis(START, 2000.0, 760);
    let axis = seek + rest;
    // Z first: X and Y wait.
    c.run_until(c.sent_at + seek / 2);
    let p = c.physical();
    assert_eq!((p[0], p[1]), (START, START), "{p:?}");
    assert!(p[2] < START - 1000.0, "{p:?}");
    // Then Y; Z is done at machine 0.
    c.run_until(c.sent_at + axis + seek / 2);
    let p = c.physical();
    assert_eq!((p[0], p[2]), (START, 0.0), "{p:?}");
    assert!(p[1] < START - 1000.0, "{p:?}");
    // Then X.
    c.run_until(c.sent_at + 2 * axis + seek / 2);
    let p = c.physical();
    assert_eq!((p[1], p[2]), (0.0, 0.0), "{p:?}");
    assert!(p[0] < START - 1000.0, "{p:?}");
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "0");
    assert_close(took, 3 * axis, "three axes in turn");
    assert_eq!(c.physical(), [0.0, 0.0, 0.0, 0.0]);
    assert_eq!(c.position(), [0, 0, 0]);
    c.expect_after("@0A100,900,100,900,100,900,0,900", "0", MINUTE);
}

#[test]
fn reference_speed_and_clearing_steps_are_the_controllers() {
    let mut c = Conv::new();
    c.expect("@01", "0");
    c.expect("@0d4000", "0");
    c.expect("@0IF100,100,100,0", "0");
    let took = c.expect_after("@0R1", "0", MINUTE);
    let (seek, rest) = one_axis(START, 4000.0, 100);
    assert_close(took, seek + rest, "at 4000 Hz, 100 clearing steps");
    // The switch trips at -800, closes at -760; 100 steps on.
    assert_eq!(c.physical()[0], -660.0);
    assert_eq!(c.position()[0], 0);
    // `@0Id` sets the default and the speed in use.
    c.expect("@0Id1000,1000,1000,1000", "0");
    c.expect("@0IF760,760,760,0", "0");
    c.expect_after("@0A2000,3000,0,0", "7", MINUTE);
    c.expect_after("@0A2000,3000", "0", MINUTE);
    let took = c.expect_after("@0R1", "0", MINUTE);
    let (seek, rest) = one_axis(2000.0 - 660.0, 1000.0, 760);
    assert_close(took, seek + rest, "at the new default 1000 Hz");
    assert_eq!(c.physical()[0], 0.0);
}

#[test]
fn an_inverted_reference_direction_uses_switch_2() {
    let mut c = Conv::new();
    c.expect("@03", "0");
    c.expect("@0IR2", "0");
    c.expect_after("@0R2", "0", MINUTE);
    // Y: switch 2 at 80800, closes at 80760, 760 steps back.
    assert_eq!(c.physical()[1], 80_000.0);
    assert_eq!(c.position()[1], 0);
}

#[test]
fn an_axis_without_a_switch_runs_until_stopped() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    c.expect("@08", "0");
    // The default machine has no A axis: nothing ever trips.
    c.send("@0R8");
    c.silent_for(Duration::from_secs(30));
    assert!(c.physical()[3] < -50_000.0);
    // Manual 2.2.22: the stop key stands in for the switch.
    c.press("stop");
    let (reply, _) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "0");
    assert_eq!(c.ask("@0P").len(), 25);
    assert!(c.ask("@0P").ends_with("000000"));
}

#[test]
fn simulate_reference_and_test_mode_take_the_current_point() {
    let mut c = Conv::new();
    c.expect("@07", "0");
    c.expect("@0N3", "0");
    c.expect("@0A1,100,0,100,0,100,0,100", "R");
    c.expect("@0N4", "0");
    c.expect_after("@0A1,100,0,100,0,100,0,100", "0", MINUTE);
    assert_eq!(c.physical()[0], START + 1.0);
    let mut c = Conv::new();
    c.expect("@07", "0");
    c.expect("@0T1", "0");
    c.expect_after("@0A5,100,0,100,0,100,0,100", "0", MINUTE);
    c.expect("@0R7", "0");
    c.expect("@0T0", "0");
    assert_eq!(c.position(), [0, 0, 0]);
    assert_eq!(c.physical()[0], START + 5.0);
}

#[test]
fn a_reference_run_turns_3d_off() {
    let mut c = Conv::referenced();
    c.expect("@0z1", "0");
    c.expect_after("@0R4", "0", MINUTE);
    // 2.5D again: Y has the longer way and leads at its own speed (3D
    // would run 5000 steps at the x speed).
    let took = c.expect_after("@0A3000,1000,4000,2000,0,5,0,5", "0", MINUTE);
    let y = Profile::new(4000, ramp(300.0, 2000.0)).duration();
    assert_close(took, y, "Y leads at 2000 Hz");
}

#[test]
fn clearing_a_limit_switch_steps_out_and_needs_a_reference() {
    let mut c = Conv::referenced();
    // Into switch 1 of X in test mode, where switches may be overrun.
    c.expect("@0T1", "0");
    c.expect_after("@0A-1000,2000,0,100,0,100,0,100", "0", MINUTE);
    c.expect("@0T0", "0");
    assert_eq!(c.ask("@0DRn"), "001");
    c.expect("@0A10,100,0,100,0,100,0,100", "2");
    c.expect("@07", "0");
    let took = c.expect_after("@0F1", "0", MINUTE);
    // Out until the switch closes (-760), then the 760 clearing steps.
    assert_eq!(c.physical()[0], 0.0);
    let want =
        Duration::from_secs_f64(240.0 / 300.0) + Profile::new(760, ramp(300.0, 2000.0)).duration();
    assert_close(took, want, "step out at 300 Hz, then 760 steps");
    assert_eq!(c.ask("@0DRn"), "000");
    c.expect("@0A10,100,0,100,0,100,0,100", "R");
    // Nothing to clear: done at once.
    c.expect("@0F2", "0");
}
