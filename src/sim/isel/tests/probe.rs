//! The probe surface (variant `probe-surface`, `docs/simulator.md`): port 1
//! bit 5 (the tool-length probe, manual 2.2.3) follows a plane as the
//! carriage crosses it, so a `@0Z` on it (manual 2.2.30) ends where a real
//! one would: ramped down from the speed it had at the trip (2.2.15,
//! 2.2.16), past the trip by the ramp-down distance.

use std::time::Duration;

use super::{Conv, default_config};
use crate::config::{ProbeSurface, SimVariant};
use crate::sim::{InputControl, SimDevice};

const MINUTE: Duration = Duration::from_secs(60);

/// The manual's defaults: start-stop frequency 300 Hz (`@0j`, 2.2.15) and
/// acceleration 100 Hz/ms (`@0J`, 2.2.16).
const START_STOP_HZ: f64 = 300.0;
const ACCEL_HZ_PER_S: f64 = 100.0 * 1000.0;

/// Steps a ramp from `hz` down to the start-stop frequency covers at
/// constant deceleration: v² - f0² = 2 a s. Written from the manual's
/// figures, not from the simulator's motion code.
fn ramp_down_steps(hz: f64) -> f64 {
    (hz * hz - START_STOP_HZ * START_STOP_HZ) / (2.0 * ACCEL_HZ_PER_S)
}

/// XYZ referenced (every axis at machine 0) with a work piece at `z0`
/// sloping `gx`, `gy`.
fn referenced_over(z0: f64, gx: f64, gy: f64) -> Conv {
    let surface = ProbeSurface::new(z0, gx, gy).expect("a plane");
    let mut c = Conv::with(default_config().with_variant(SimVariant::ProbeSurface(surface)));
    c.expect("@07", "0");
    c.expect_after("@0R7", "0", MINUTE);
    c
}

/// Port 1 bit 5 as `@0b1` reads it.
fn probe_touched(c: &mut Conv) -> bool {
    let reply = c.ask("@0b1");
    let byte = u8::from_str_radix(reply.get(1..3).expect("two hex digits"), 16).expect("hex");
    byte & 0x20 != 0
}

/// To X, Y, Z (absolute, every axis at 4000 Hz).
fn go_to(c: &mut Conv, x: i32, y: i32, z: i32) {
    c.expect_after(
        &format!("@0M{x},4000,{y},4000,{z},4000,0,4000"),
        "0",
        MINUTE,
    );
    assert_eq!(c.position(), [x, y, z]);
}

/// `@0Z` on port 1 bit 5 (mask 32): until touched (`value` 32) or released
/// (0), Z by `steps` at `hz`.
fn port_move(c: &mut Conv, value: u8, hz: u32, steps: i32) {
    c.expect_after(&format!("@0Z1,32,{value},{hz},0,0,{steps}"), "0", MINUTE);
}

#[test]
fn a_fast_port_move_stops_past_the_surface_by_its_ramp_down() {
    let mut c = referenced_over(8000.0, 0.0, 0.0);
    // At machine 0 the probe stands below the work piece's top: touched.
    assert!(probe_touched(&mut c));
    go_to(&mut c, 0, 0, 12_000);
    assert!(!probe_touched(&mut c));
    // 4000 Hz: the move cruises when it reaches the surface (4000 steps
    // of travel, 80 of ramp), brakes there and comes to rest 79.55 steps
    // further down, well short of the 8000 steps asked for.
    port_move(&mut c, 32, 4000, -8000);
    let z = f64::from(c.position()[2]);
    let expected = 8000.0 - ramp_down_steps(4000.0);
    assert!(
        (z - expected).abs() <= 2.0,
        "stopped at {z}, the ramp-down from the surface ends at {expected}"
    );
    assert!(probe_touched(&mut c));
}

#[test]
fn a_port_move_at_the_start_stop_frequency_stops_on_the_surface() {
    let mut c = referenced_over(8000.0, 0.0, 0.0);
    go_to(&mut c, 0, 0, 8400);
    // No ramp below the start-stop frequency: it stops at the step that
    // touches.
    port_move(&mut c, 32, 300, -4000);
    let z = c.position()[2];
    assert!((z - 8000).abs() <= 1, "stopped at {z}");
    assert!(probe_touched(&mut c));
    // Manual 2.2.30: true at the start, the move ends at once.
    port_move(&mut c, 32, 300, -4000);
    assert_eq!(c.position()[2], z);
}

#[test]
fn a_tilted_surface_trips_at_its_height_over_x_and_y() {
    // z = 8000 + 0.01 x - 0.005 y.
    let mut c = referenced_over(8000.0, 0.01, -0.005);
    for (x, y) in [(10_050, 0), (30_000, 6_000)] {
        let height = 8000.0 + 0.01 * f64::from(x) - 0.005 * f64::from(y);
        go_to(&mut c, x, y, 9000);
        port_move(&mut c, 32, 300, -2000);
        let z = f64::from(c.position()[2]);
        assert!(
            z <= height && height - z < 1.0,
            "over X {x} Y {y}: stopped at {z}, the surface is at {height}"
        );
    }
}

#[test]
fn a_reverse_port_move_stops_just_above_the_surface() {
    let mut c = referenced_over(8000.0, 0.0, 0.0);
    go_to(&mut c, 0, 0, 8400);
    port_move(&mut c, 32, 4000, -1000);
    let down = c.position()[2];
    assert!(down < 7950, "{down}");
    // Up until released (bit 5 == 0): the first step above the surface.
    port_move(&mut c, 0, 300, 1000);
    assert_eq!(c.position()[2], 8001);
    assert!(!probe_touched(&mut c));
    // The slow pass down again touches one step lower, on the surface.
    port_move(&mut c, 32, 300, -1000);
    assert_eq!(c.position()[2], 8000);
}

#[test]
fn a_plain_move_through_the_surface_is_not_stopped_by_it() {
    let mut c = referenced_over(8000.0, 0.0, 0.0);
    go_to(&mut c, 0, 0, 12_000);
    go_to(&mut c, 0, 0, 4000);
    assert!(probe_touched(&mut c));
}

#[test]
fn the_surface_wins_over_the_probe_control() {
    let mut c = referenced_over(8000.0, 0.0, 0.0);
    go_to(&mut c, 0, 0, 12_000);
    let err = c
        .sim
        .control(
            &InputControl::Set {
                name: "probe".into(),
                level: true,
            },
            c.now,
        )
        .unwrap_err();
    assert!(err.contains("probe surface 8000"), "{err}");
    assert!(!c.sim.input_names().contains(&"probe"));
    assert!(!probe_touched(&mut c));
    assert!(c.sim.describe(c.now).contains("probe surface 8000 (clear)"));
    // Without a surface the control sets the bit as before.
    let mut plain = Conv::referenced();
    plain.set("probe", true);
    assert!(probe_touched(&mut plain));
}

#[test]
fn a_stored_port_condition_ends_a_program_move_on_the_surface() {
    let mut c = referenced_over(8000.0, 0.0, 0.0);
    go_to(&mut c, 0, 0, 8400);
    // CNC `6` numbers the bits 1-8 (manual 3.2.7): bit 6 is port 1 bit 5.
    c.expect("@0i", "0");
    for line in ["61,6,1", "00,300,0,300,-4000,300,0,300", "9"] {
        c.expect(line, "0");
    }
    c.expect_after("@0S", "0", MINUTE);
    assert_eq!(c.position()[2], 8000);
}
