//! End to end: the console's `P` (Z touch-off, `docs/probing.md`) in a
//! pseudo-terminal against `jogterm sim --pty` with a probe surface.

use crate::console_pty::{quit, spawn, wait_for};
use crate::sim_process::{ISEL_NEAR_REFERENCE, SimProcess};

#[test]
fn p_touches_off_z_and_refuses_with_a_jog_speed_override() {
    // The surface at Z 4000 steps (10 mm).
    let mut sim = SimProcess::options("isel")
        .files(&[ISEL_NEAR_REFERENCE])
        .args(&["--probe-surface=4000"])
        .time_scale(crate::sim_process::LOGIC_SCALE)
        .start();
    // Referenced, Z up at 20 mm, before the console opens.
    let out = sim.run(&["send", "@07", "@0R7", "@0A0,4000,0,4000,8000,4000,0,4000"]);
    assert!(out.status.success());
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    wait_for(&run, "READY");
    // An override left on: refused, nothing moves.
    run.type_keys(&[b")"]);
    wait_for(&run, "110 %");
    run.type_keys(&[b"P"]);
    wait_for(&run, "the jog speed override is 110 %");
    assert!(!sim.received().contains("@0Z"));
    run.type_keys(&[b"%"]);
    run.type_keys(&[b"P"]);
    wait_for(&run, "Touch off Z");
    run.type_keys(&[b"y"]);
    let screen = wait_for(&run, "G54 Z 0 set to machine Z 10.0000 mm");
    assert!(screen.contains("touched at Z 10.0000 mm"), "{screen}");
    assert!(sim.received().contains("@0Z1,32,32,2000,0,0,-4000"));
    // Saved where `s` saves: the offsets file has G54's Z.
    let offsets = std::fs::read_dir(state.path().join("offsets"))
        .expect("offsets dir")
        .filter_map(Result::ok)
        .map(|e| std::fs::read_to_string(e.path()).unwrap_or_default())
        .collect::<String>();
    assert!(offsets.contains("G54"), "{offsets}");
    quit(&mut run);
}
