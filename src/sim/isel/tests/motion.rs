//! Moves: trapezoidal timing, 2.5D and 3D interpolation, absolute targets
//! and the virtual zero, circles, helices, move until a port event
//! (isel manual 2.2.2, 2.2.18, 2.2.19, 2.2.27-2.2.30, 2.3).

use std::time::Duration;

use super::{Conv, assert_close};
use crate::motion::{Profile, Ramp};

fn profile(steps: u64, hz: f64) -> Duration {
    Profile::new(
        steps,
        Ramp {
            start_hz: 300.0,
            max_hz: hz,
            accel_hz_per_s: 100_000.0,
        },
    )
    .duration()
}

const MINUTE: Duration = Duration::from_secs(60);

#[test]
fn a_move_answers_when_the_trapezoid_is_over() {
    let mut c = Conv::referenced();
    let took = c.expect_after("@0A10000,5300,0,100,0,100,0,100", "0", MINUTE);
    assert_close(took, profile(10_000, 5300.0), "10000 steps at 5300 Hz");
    assert_eq!(c.position(), [10_000, 0, 0]);
    // Start-stop frequency and acceleration shape the ramp.
    c.expect("@0j1000", "0");
    c.expect("@0J10", "0");
    let took = c.expect_after("@0A-10000,5300,0,100,0,100,0,100", "0", MINUTE);
    let want = Profile::new(
        10_000,
        Ramp {
            start_hz: 1000.0,
            max_hz: 5300.0,
            accel_hz_per_s: 10_000.0,
        },
    )
    .duration();
    assert_close(took, want, "with j1000 and J10");
    assert_eq!(c.position(), [0, 0, 0]);
}

#[test]
fn two_and_a_half_d_runs_xy_then_z1_then_z2() {
    let mut c = Conv::referenced();
    c.send("@0A4000,2000,2000,4000,800,1000,-400,500");
    let xy = profile(4000, 2000.0);
    let z1 = profile(800, 1000.0);
    let z2 = profile(400, 500.0);
    // Halfway through XY: both move, Z waits.
    c.run_until(c.sent_at + xy / 2);
    let p = c.physical();
    assert!(
        (p[0] - 2000.0).abs() < 1.0 && (p[1] - 1000.0).abs() < 1.0,
        "{p:?}"
    );
    assert_eq!(p[2], 0.0);
    // Halfway through Z1: X and Y are there.
    c.run_until(c.sent_at + xy + z1 / 2);
    let p = c.physical();
    assert_eq!((p[0], p[1]), (4000.0, 2000.0));
    assert!((p[2] - 400.0).abs() < 1.0, "{p:?}");
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "0");
    assert_close(took, xy + z1 + z2, "three legs");
    assert_eq!(c.position(), [4000, 2000, 400]);
}

#[test]
fn the_longer_way_leads_with_its_own_speed() {
    let mut c = Conv::referenced();
    let took = c.expect_after("@0A1000,5000,3000,1500,0,100,0,100", "0", MINUTE);
    assert_close(took, profile(3000, 1500.0), "Y leads at 1500 Hz");
}

#[test]
fn three_d_runs_one_line_at_the_x_speed() {
    let mut c = Conv::referenced();
    c.expect("@0z1", "0");
    let took = c.expect_after("@0A3000,1000,4000,5,0,5,700,5", "0", MINUTE);
    assert_close(took, profile(5000, 1000.0), "5000 steps at 1000 Hz");
    assert_eq!(c.position(), [3000, 4000, 0], "z2 is ignored in 3D");
    c.expect("@0z0", "0");
}

#[test]
fn absolute_targets_count_from_the_virtual_zero_and_positions_do_not() {
    let mut c = Conv::referenced();
    c.expect_after("@0A1000,4000,2000,4000,0,100,0,100", "0", MINUTE);
    c.expect("@0n1", "0");
    c.expect_after("@0M500,4000,500,4000,300,4000,0,100", "0", MINUTE);
    // `@0P` reports machine coordinates from the reference point.
    assert_eq!(c.position(), [1500, 500, 300]);
    c.expect("@0M0,4000,0,4000,0,100,7,100", "1");
    c.expect_after("@0M0,4000,0,4000,0,4000,0,100", "0", MINUTE);
    assert_eq!(c.position(), [1000, 0, 0]);
    assert_eq!(c.physical()[0], 1000.0);
}

#[test]
fn the_manuals_circle_runs_its_arc() {
    let mut c = Conv::referenced();
    c.expect_after("@0A4000,4000,4000,4000,0,100,0,100", "0", MINUTE);
    c.expect("@0f-1", "0");
    c.send("@0y400,1500,119,-141,141,-1,-1");
    let arc = profile(400, 1500.0);
    // 135 to 225 degrees around (4141, 3859): halfway is 180 degrees.
    c.run_until(c.sent_at + arc / 2);
    let p = c.physical();
    assert!(
        (p[0] - 3941.0).abs() < 3.0 && (p[1] - 3859.0).abs() < 3.0,
        "{p:?}"
    );
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "0");
    assert_close(took, arc, "B = 400 steps at 1500 Hz");
    assert_eq!(c.position(), [4000, 3718, 0]);
}

#[test]
fn a_helix_moves_the_third_axis_along() {
    let mut c = Conv::referenced();
    c.expect_after("@0A4000,4000,4000,4000,0,100,0,100", "0", MINUTE);
    c.expect("@0f-1", "0");
    c.expect_after("@0w400,1500,119,-141,141,-1,-1,600", "0", MINUTE);
    assert_eq!(c.position(), [4000, 3718, 600]);
    // In the XZ plane Y is the helix axis.
    c.expect("@0e1", "0");
    c.expect_after("@0w400,1500,119,-141,141,-1,-1,100", "0", MINUTE);
    assert_eq!(c.position(), [4000, 3818, 318]);
}

#[test]
fn a_circle_needs_the_axes_of_its_plane() {
    let mut c = Conv::new();
    c.expect("@03", "0");
    c.expect("@0N3", "0");
    c.expect("@0e2", "0");
    c.expect("@0y400,1500,119,-141,141,-1,-1", "3");
    c.expect("@0w400,1500,119,-141,141,-1,-1,5", "3");
}

#[test]
fn a_move_until_a_port_event_ramps_down_when_it_comes() {
    let mut c = Conv::referenced();
    // Port 0, mask 4, value 4: until user input 2 is on (manual 2.2.30).
    c.send("@0Z0,4,4,600,0,0,3000");
    c.wait(Duration::from_secs(1));
    let at = c.physical()[2];
    c.set("in0.2", true);
    let (reply, _) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "0");
    let z = c.position()[2];
    assert!(
        f64::from(z) > at && z < 3000,
        "stopped at {z}, event at {at}"
    );
    // Already true at the start: no motion at all.
    c.expect("@0Z0,4,4,600,0,0,3000", "0");
    assert_eq!(c.position()[2], z);
    // Without the event the steps are done.
    c.set("in0.2", false);
    let took = c.expect_after("@0Z0,4,4,600,0,0,-1000", "0", MINUTE);
    assert_close(took, profile(1000, 600.0), "1000 steps at 600 Hz");
    assert_eq!(c.position()[2], z - 1000);
}

#[test]
fn bytes_that_arrive_during_a_move_are_dropped() {
    let mut c = Conv::referenced();
    c.send("@0A2000,2000,0,100,0,100,0,100");
    c.wait(Duration::from_millis(100));
    c.send("@0P");
    let (reply, took) = c.next_reply(MINUTE).expect("reply");
    assert_eq!(reply, "0");
    assert!(took > Duration::ZERO);
    c.silent_for(Duration::from_millis(100));
    assert_eq!(c.position(), [2000, 0, 0]);
}

#[test]
fn a_clockwise_quarter_circle_from_the_cores_parameters() {
    use crate::proto::isel::{CircleDirection, Frame, circle};
    let mut c = Conv::referenced();
    c.expect_after("@0A20000,8000,20000,8000,0,100,0,100", "0", MINUTE);
    // From the top of a circle of R = 1000 clockwise to its right side.
    let arc = circle(1000, 90.0, 0.0, CircleDirection::Cw, 2000).expect("arc");
    let [f, y] = arc
        .commands()
        .map(|cmd| Frame::default_device(cmd).to_string());
    c.expect(&f, "0");
    c.send(&y);
    let took = profile(u64::from(arc.params.arc_length), 2000.0);
    c.run_until(c.sent_at + took / 2);
    let p = c.physical();
    // Halfway is 45 degrees: (707, 707) from the centre at (20000, 19000).
    assert!(
        (p[0] - 20_707.0).abs() < 3.0 && (p[1] - 19_707.0).abs() < 3.0,
        "{p:?}"
    );
    assert_eq!(c.next_reply(MINUTE).expect("reply").0, "0");
    assert_eq!(c.position(), [21_000, 19_000, 0]);
}
