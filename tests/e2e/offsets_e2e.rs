//! Work offsets, the typed step, the speed override and go-to with the real
//! `jogterm` binary in a pseudo-terminal against `jogterm sim --pty`
//! (issue 16): G55 set to X = 10 here comes back after a restart and the
//! position panel shows it; a file of other steps per unit, or a broken
//! one, is refused and says so; `z` sends `@0n`, `X10` here does not; go-to
//! in machine coordinates and at a typed feed; a typed step moves exactly
//! that; the override shows in the speed on the wire.

use crate::console_pty;
use crate::sim_process;
use crate::ui_pty;

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use console_pty::{quit, spawn, wait_for};
use sim_process::{SimProcess, WAIT};
use ui_pty::PtyRun;

/// The default profile with a short reference run (it is only the way to
/// READY and to a referenced machine after the restart), for the simulator
/// and the console alike: the axes 1 mm from the reference point at
/// power-up (5 mm before), reference runs at 12 000 Hz (4000) into
/// switches 0.5 mm below the soft minimum (2 mm). At real time: a console
/// test (`docs/testing.md`, "The time scale").
const PROFILE: (&str, &str) = (
    "profiles/default.toml",
    "base = \"default\"\n[isel]\nreference_speed_hz = 12000\n[sim]\nstart_position = 1.0\nlimit_margin = 0.5\n",
);

/// The X line of the position panel: (work, steps).
fn x_line(run: &PtyRun) -> (String, String) {
    let screen = run.screen().screen().contents();
    let line = screen
        .lines()
        .find(|l| l.starts_with('X'))
        .unwrap_or_default()
        .to_string();
    let mut words = line.split_whitespace();
    let work = words.nth(1).unwrap_or_default().to_string();
    let steps = words.nth(2).unwrap_or_default().to_string();
    (work, steps)
}

/// Wait until the position panel's X line satisfies `ok`.
fn wait_x(run: &PtyRun, what: &str, ok: impl Fn(&str, &str) -> bool) {
    let end = Instant::now() + WAIT;
    loop {
        let (work, steps) = x_line(run);
        if ok(&work, &steps) {
            return;
        }
        assert!(
            Instant::now() < end,
            "X never {what}:\n{}",
            run.screen().screen().contents()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Initialise and reference; the axes stand at machine 0.
fn reference(run: &mut PtyRun) {
    console_pty::reference(run);
    wait_x(run, "at 0", |_, steps| steps == "0");
}

/// The offsets files in the state directory, without the hidden temporary
/// file of a write under way (`.<name>.jogterm-save-…`, renamed over the
/// file once it is on the disk): found with the whole text in it while the
/// disk was slow, it was taken for the file and was gone a moment later.
fn offsets_files(state: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = fs::read_dir(state.join("offsets"))
        .map(|d| {
            d.flatten()
                .filter(|e| !e.file_name().to_string_lossy().starts_with('.'))
                .map(|e| e.path())
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

fn wait_file(state: &Path, what: &str, ok: impl Fn(&str) -> bool) -> PathBuf {
    let end = Instant::now() + WAIT;
    loop {
        for f in offsets_files(state) {
            if fs::read_to_string(&f).is_ok_and(|t| ok(&t)) {
                return f;
            }
        }
        assert!(Instant::now() < end, "the offsets file never {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn g55_set_here_survives_a_restart_and_only_a_zero_moves_the_isel_zero() {
    let mut sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    reference(&mut run);
    // z: G54's zero here, and the controller's (`@0n7`).
    run.type_keys(&[b"z"]);
    wait_for(&run, "G54: work zero of XYZ set to the current position");
    sim.wait_received("@0n7", |r| r.contains("@0n7<CR>"));
    // One 1 mm step on, G55, and X = 10 here.
    run.type_keys(&[b"\x1b[C"]);
    wait_x(&run, "at 400 steps", |_, steps| steps == "400");
    run.type_keys(&[b"O"]);
    wait_for(&run, "Work offsets: zeros in machine coordinates");
    run.type_keys(&[b"2"]);
    wait_for(&run, "Position G55");
    run.type_keys(&[b"s"]);
    wait_for(&run, "Set the work position here (G55)");
    run.type_text("X10");
    run.type_keys(&[b"\r"]);
    wait_for(&run, "G55: X = 10 (zero at machine -9.000) here");
    wait_x(&run, "at work 10", |work, _| work == "10.000");
    // isel's zero stays where `z` put it: stored programs count from there.
    wait_for(&run, "programs ≠ G55");
    let received = sim.received();
    assert_eq!(received.matches("@0n").count(), 1, "{received}");
    let file = wait_file(state.path(), "held G55", |t| {
        t.contains("active = \"G55\"") && t.contains("G55 = { X = -3600, Y = 0, Z = 0 }")
    });
    quit(&mut run);

    // Restart: G55 and its zero are back, the position panel counts from it.
    let mut run = spawn(&sim, state.path());
    wait_for(&run, "Position G55");
    wait_x(&run, "at work 10 again", |work, _| work == "10.000");
    // Go to in machine coordinates (after a reference run: the controller's
    // zero is unknown to a new connection until then; the controller kept
    // its axes and reference, the state read back says so).
    wait_for(&run, "READY");
    run.type_keys(&[b"h"]);
    wait_for(&run, "Reference run");
    run.type_keys(&[b"y"]);
    wait_x(&run, "referenced", |work, steps| {
        steps == "0" && work == "9.000"
    });
    run.type_keys(&[b"g", b"\t"]);
    wait_for(&run, "Go to (machine coordinates)");
    // Short moves at real time (a console test): 2 mm at the jog speed of
    // 2 mm/s, then 1 mm at F120 (12 mm and 1 mm before, 6.5 s of motion).
    run.type_text("X2");
    // Enter once the target shows (typed right behind it, a busy console
    // reads it with the text: a burst, which sends nothing).
    wait_for(&run, "> X2");
    run.type_keys(&[b"\r"]);
    wait_for(&run, "go to X2 (machine coordinates) at 2 per second");
    wait_x(&run, "at machine 2", |work, steps| {
        steps == "800" && work == "11.000"
    });
    wait_for(&run, "READY");
    // G55 X12 at F120 (2 mm/s = 800 Hz): machine 3 mm, 1200 steps.
    run.type_keys(&[b"g"]);
    wait_for(&run, "Go to (G55 work coordinates)");
    run.type_text("X12F120");
    wait_for(&run, "> X12F120");
    run.type_keys(&[b"\r"]);
    sim.wait_received("the move at 800 Hz", |r| r.contains("@0M1200,800,"));
    wait_x(&run, "at work 12", |work, steps| {
        work == "12.000" && steps == "1200"
    });
    quit(&mut run);
    assert!(file.exists());
    sim.assert_alive();
}

#[test]
fn a_typed_step_moves_exactly_that_and_the_override_shows_on_the_wire() {
    let mut sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    reference(&mut run);
    // A step of 0.25 mm: 100 steps at 400 steps/mm.
    run.type_keys(&[b"J"]);
    wait_for(&run, "Jog step and speed");
    run.type_text("0.25");
    run.type_keys(&[b"\r"]);
    wait_for(&run, "STEP 0.25 mm");
    run.type_keys(&[b"\x1b[C"]);
    wait_x(&run, "at 100 steps", |_, steps| steps == "100");
    sim.wait_received("a 100-step move at 800 Hz", |r| r.contains("@0A100,800,0,"));
    wait_for(&run, "READY");
    // 150 %: 3 mm/s, 1200 Hz on the wire.
    run.type_keys(&[b")", b")", b")", b")", b")"]);
    wait_for(&run, "3 mm/s  150%");
    run.type_keys(&[b"\x1b[C"]);
    wait_x(&run, "at 200 steps", |_, steps| steps == "200");
    sim.wait_received("a 100-step move at 1200 Hz", |r| {
        r.contains("@0A100,1200,0,")
    });
    // A typed value out of the axes' limits: refused, nothing changes.
    run.type_keys(&[b"J"]);
    run.type_text("500");
    run.type_keys(&[b"\r"]);
    wait_for(&run, "a step of 500 is more than the travel of Z (80 mm)");
    run.type_keys(&[b"\x1b"]);
    wait_for(&run, "STEP 0.25 mm");
    quit(&mut run);
    sim.assert_alive();
}

#[test]
fn a_file_of_other_steps_per_unit_or_a_broken_one_is_refused() {
    let mut sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    reference(&mut run);
    run.type_keys(&[b"\x1b[C"]);
    wait_x(&run, "at 400 steps", |_, steps| steps == "400");
    wait_for(&run, "READY");
    run.type_keys(&[b"z"]);
    let file = wait_file(state.path(), "held the zero", |t| {
        t.contains("G54 = { X = 400,")
    });
    quit(&mut run);

    // The profile now says 800 steps/mm on X: the file is not this machine's.
    let profile = sim.dir.path().join(PROFILE.0);
    fs::write(
        &profile,
        format!("{}[axes.X]\nsteps_per_unit = 800.0\n", PROFILE.1),
    )
    .expect("write the profile");
    let mut run = spawn(&sim, state.path());
    let screen = wait_for(
        &run,
        "work offsets refused, not applied: saved for another machine",
    );
    assert!(
        screen.contains("X at 400 steps per mm, the profile 800 steps per mm"),
        "{screen}"
    );
    wait_for(&run, "Position G54!");
    // Machine coordinates, not the refused zero.
    wait_x(&run, "in machine coordinates", |work, steps| {
        steps == "400" && work == "0.500"
    });
    quit(&mut run);
    assert!(file.exists(), "the refused file is kept");

    // Back to 400 steps/mm, the file broken: refused with its line.
    fs::write(&profile, PROFILE.1).expect("write the profile");
    fs::write(&file, "format = 1\nactive = \"G5\n").expect("break the file");
    let mut run = spawn(&sim, state.path());
    let screen = wait_for(&run, "work offsets refused, not applied: /");
    assert!(screen.contains("toml:2:"), "{screen}");
    wait_for(&run, "Position G54!");
    // Setting an offset puts the broken file aside and writes a new one.
    run.type_keys(&[b"O", b"3"]);
    wait_for(&run, "Position G56");
    wait_file(state.path(), "was written again", |t| {
        t.contains("active = \"G56\"")
    });
    let names: Vec<String> = offsets_files(state.path())
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    assert!(names.iter().any(|n| n.contains(".refused-")), "{names:?}");
    quit(&mut run);
    sim.assert_alive();
}
