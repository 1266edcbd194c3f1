//! End to end: the simulators' probe surface (`jogterm sim --probe-surface`,
//! `docs/simulator.md`, "Probe surface") seen through the real `jogterm
//! send`: a probing cycle of `@0Z` moves on the probe input in1.5 (isel
//! manual 2.2.30) and the positions the controller reports after each.

use std::process::Stdio;

use crate::sim_process;
use sim_process::{ISEL_NEAR_REFERENCE, JOGTERM, SimProcess, text};

/// The Z of every `@0P` answer in `send`'s output (`<< 0 X=… Y=… Z=… (steps)`).
fn reported_z(stdout: &str) -> Vec<i64> {
    stdout
        .lines()
        .filter_map(|l| l.split_once(" Z=")?.1.split_once(' ')?.0.parse().ok())
        .collect()
}

/// Logic only (where each move ends is the model's, whatever the wall
/// clock), so on a simulator ten times faster than real time.
#[test]
fn a_probing_cycle_stops_past_the_surface_then_on_it() {
    let sim = SimProcess::options("isel")
        .files(&[ISEL_NEAR_REFERENCE])
        .args(&["--probe-surface", "8000,0.01,-0.005"])
        .time_scale(sim_process::LOGIC_SCALE)
        .start();
    // Over X 10000, Y 0 the plane is at 8000 + 0.01 * 10000 = 8100.
    let out = sim.run(&[
        "send",
        "@07",
        "@0R7",
        "@0M10000,4000,0,4000,12000,4000,0,4000",
        // Fast approach: 4000 Hz down until touched (port 1, bit 5 = 1).
        "@0Z1,32,32,4000,0,0,-8000",
        "@0P",
        // Back off at the start-stop frequency until released.
        "@0Z1,32,0,300,0,0,1000",
        "@0P",
        // Slow pass down at the start-stop frequency.
        "@0Z1,32,32,300,0,0,-1000",
        "@0P",
        "@0b1",
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let z = reported_z(&stdout);
    assert_eq!(z.len(), 3, "{stdout}");
    // The fast pass ramps down from 4000 Hz to the start-stop frequency
    // (300 Hz) at 100 Hz/ms after the trip (manual 2.2.15, 2.2.16):
    // (4000² - 300²) / (2 * 100000) = 79.55 steps below the surface.
    let overshoot = (4000.0_f64.powi(2) - 300.0_f64.powi(2)) / 200_000.0;
    assert!(
        (z[0] as f64 - (8100.0 - overshoot)).abs() <= 2.0,
        "fast pass ended at Z {}: {stdout}",
        z[0]
    );
    assert_eq!(z[1], 8101, "released one step above the surface: {stdout}");
    assert_eq!(z[2], 8100, "the slow pass touches on the surface: {stdout}");
    assert!(stdout.contains("X=10000 Y=0 Z=8100"), "{stdout}");
    assert!(stdout.contains("tool-length probe"), "{stdout}");
}

#[test]
fn the_emcu_simulator_refuses_a_probe_surface_with_the_reason() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = std::process::Command::new(JOGTERM)
        .args([
            "sim",
            "--pty",
            "--protocol",
            "emcu",
            "--probe-surface",
            "8000",
        ])
        .env("JOGTERM_CONFIG_DIR", dir.path())
        .stdin(Stdio::null())
        .output()
        .expect("run jogterm");
    assert_eq!(out.status.code(), Some(1));
    let err = text(&out.stderr);
    assert!(err.contains("cannot read its input E1"), "{err}");
    let bad = std::process::Command::new(JOGTERM)
        .args(["sim", "--pty", "--probe-surface", "8000,1"])
        .env("JOGTERM_CONFIG_DIR", dir.path())
        .stdin(Stdio::null())
        .output()
        .expect("run jogterm");
    assert_eq!(bad.status.code(), Some(2), "{}", text(&bad.stderr));
    assert!(text(&bad.stderr).contains("Z0,GX,GY"));
    // A block whose X range runs backwards: its own form in the error.
    let bad = std::process::Command::new(JOGTERM)
        .args(["sim", "--pty", "--probe-surface", "block:2,1,0,1,0"])
        .env("JOGTERM_CONFIG_DIR", dir.path())
        .stdin(Stdio::null())
        .output()
        .expect("run jogterm");
    assert_eq!(bad.status.code(), Some(2), "{}", text(&bad.stderr));
    assert!(
        text(&bad.stderr).contains("block:X0,X1,Y0,Y1,TOP"),
        "{}",
        text(&bad.stderr)
    );
}
