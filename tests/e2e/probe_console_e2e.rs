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

/// Space while the pass that `pass` begins runs (real time, the back-off
/// at 10 Hz so that it lasts two seconds): the probe ends stopped, and no
/// move follows the stop bytes. The slow pass touches a step or two after
/// it starts (it begins where the input released), so Space there may
/// land on the return that follows it at once: that stops the same way.
fn space_during(pass: &str) {
    let profile = (
        "profiles/default.toml",
        "[sim]\nstart_position = 1.0\n[probe]\nslow_speed = 0.025\n",
    );
    let mut sim = SimProcess::options("isel")
        .files(&[profile])
        .args(&["--probe-surface=4000"])
        .start();
    let out = sim
        .configured(&["send", "@07", "@0R7", "@0A0,4000,0,4000,6000,4000,0,4000"])
        .output()
        .expect("send");
    assert!(out.status.success());
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    wait_for(&run, "READY");
    run.type_keys(&[b"P"]);
    wait_for(&run, "Touch off Z");
    run.type_keys(&[b"y"]);
    sim.wait_received(pass, |r| r.contains(pass));
    run.type_keys(&[b" "]);
    wait_for(&run, "the probe of Z- was stopped; nothing resumes");
    wait_for(&run, "READY");
    let received = sim.received();
    assert!(received.contains(pass), "{received}");
    // The last stop bytes are Space's (the first ones opened the link).
    let after = received.rsplit("<FD><FF>").next().unwrap_or_default();
    assert!(!after.contains("@0Z") && !after.contains("@0A"), "{after}");
    quit(&mut run);
}

#[test]
fn space_during_the_fast_pass_stops_the_probe() {
    space_during("@0Z1,32,32,2000,");
}

#[test]
fn space_during_the_back_off_stops_the_probe() {
    space_during("@0Z1,32,0,10,");
}

#[test]
fn space_during_the_slow_pass_stops_the_probe() {
    space_during("@0Z1,32,32,10,");
}
