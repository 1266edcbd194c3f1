//! Macros of the profile with the real `jogterm` binary in a
//! pseudo-terminal against `jogterm sim --pty` (issue 16): a macro bound to
//! F8 asks first (it moves), then its lines go out on the wire one after
//! the other; a macro stopped by Space sends the stop bytes and none of
//! its lines after the one that ran.

use crate::console_pty;
use crate::sim_process;

use std::thread;
use std::time::{Duration, Instant};

use console_pty::{quit, reference, spawn, wait_for};
use sim_process::SimProcess;

/// F8 runs `park` (a short move and a read-back), F9 `long` (a 100 mm
/// move at 900 Hz, some 45 s, then a move to a place nothing else uses).
/// A third test: a macro refused before anything is sent (no axes yet,
/// and after an E-stop), as a typed command would be (the device task's
/// own refusals: `tests/operator_ui.rs`).
const PROFILE: (&str, &str) = (
    "profiles/default.toml",
    "base = \"default\"\n\
     [sim]\nstart_position = 5.0\n\
     [macros.park]\n\
     description = \"to X 10 mm\"\n\
     lines = [\"@0M 4000,2000,0,900,0,900,0,900\", \"@0P\"]\n\
     [macros.long]\n\
     lines = [\"@0M 40000,900,0,900,0,900,0,900\", \"@0M 1234,900,0,900,0,900,0,900\"]\n\
     [macros.nudge]\n\
     lines = [\"@0A 40,900,0,900,0,900,0,900\"]\n\
     confirm = false\n\
     [keys.main]\n\
     \"f8\" = \"macro:park\"\n\
     \"f9\" = \"macro:long\"\n\
     \"f11\" = \"macro:nudge\"\n",
);

const F8: &[u8] = b"\x1b[19~";
const F9: &[u8] = b"\x1b[20~";
const F11: &[u8] = b"\x1b[23~";

#[test]
fn a_macro_asks_first_and_its_lines_go_out_one_after_the_other() {
    let mut sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    reference(&mut run);
    let before = sim.received().len();
    run.type_keys(&[F8]);
    wait_for(&run, "Run macro park");
    // Nothing before the answer.
    assert!(!sim.received()[before..].contains("@0M4000"));
    run.type_keys(&[b"y"]);
    wait_for(&run, "macro park done (2 lines)");
    let received = sim.wait_received("the macro's lines", |r| {
        r.get(before..).is_some_and(|r| r.contains("@0M"))
    });
    let tail = &received[before..];
    let moved = tail.find("@0M").expect("the move");
    assert!(
        tail[moved..].starts_with("@0M4000,2000,0,900,0,900,0,900<CR>")
            || tail[moved..].starts_with("@0M 4000,2000,0,900,0,900,0,900<CR>"),
        "{tail}"
    );
    // `@0P` after the move's answer: polls are `@0P` too, so the position
    // shown says the move ran to its end.
    wait_for(&run, "4000");
    quit(&mut run);
}

#[test]
fn space_stops_a_macro_and_its_next_line_never_goes_out() {
    let mut sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    reference(&mut run);
    let before = sim.received().len();
    run.type_keys(&[F9]);
    wait_for(&run, "Run macro long");
    run.type_keys(&[b"y"]);
    sim.wait_received("the long move", |r| {
        r.get(before..).is_some_and(|r| r.contains("40000,900"))
    });
    wait_for(&run, "macro long, line 1 of 2");
    run.type_keys(&[b" "]);
    wait_for(&run, "stopped by the operator; 1 more not sent");
    // The stop bytes after the move, then the machine at rest and polled.
    let received = sim.wait_received("the stop", |r| {
        r.get(before..).is_some_and(|r| {
            r.find("40000,900")
                .is_some_and(|at| r[at..].contains("<FD>") && r[at..].matches("@0P").count() >= 3)
        })
    });
    let received = sim.wait_received("polls after the stop", |r| {
        r.len() > received.len() && r[received.len()..].matches("@0P").count() >= 3
    });
    assert!(
        !received[before..].contains("1234,900"),
        "the line after the stopped one went out:\n{}",
        &received[before..]
    );
    quit(&mut run);
}

#[test]
fn a_macro_meets_the_refusals_of_a_typed_command() {
    let mut sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    // Connected, no axes initialised: the command line's own check refuses
    // the move before anything is asked or sent.
    wait_for(&run, "connected");
    run.type_keys(&[F9]);
    let screen = wait_for(&run, "macro long not started: line 1");
    assert!(screen.contains("no axes are initialised"), "{screen}");
    // Ready, then the emergency stop trips: the controller forgets its
    // axes, and the macro is refused as a typed move would be, saying why.
    reference(&mut run);
    sim.control("set estop1 open; set estop2 open");
    wait_for(&run, "E-STOP");
    run.type_keys(&[F8]);
    let screen = wait_for(&run, "macro park not started: line 1");
    assert!(!screen.contains("Run macro park"), "{screen}");
    let received = sim.received();
    assert!(
        !received.contains("40000,900")
            && !received.contains("1234,900")
            && !received.contains("4000,2000"),
        "a refused macro line went out:\n{received}"
    );
    quit(&mut run);
}

/// Issue 24: without the kitty keyboard protocol (the console here is told
/// not to ask for it) a held key's repeats arrive as presses. F11 held as a
/// terminal repeats it (the first repeat after 500 ms, then every 33 ms for
/// 2 s) runs `nudge` (0.1 mm, no question) once, though it ends within the
/// first repeat delay; pressed again after a pause, it runs again.
#[test]
fn a_held_macro_key_on_a_terminal_that_repeats_with_presses_runs_it_once() {
    let mut sim = SimProcess::start_with_files("isel", &[PROFILE]);
    let state = tempfile::tempdir().expect("state dir");
    let mut run = spawn(&sim, state.path());
    reference(&mut run);
    let before = sim.received().len();
    let nudges = |sim: &mut SimProcess| {
        let r = sim.received();
        let tail = r.get(before..).unwrap_or_default();
        tail.matches("@0A40,900,").count() + tail.matches("@0A 40,900,").count()
    };
    run.send(F11);
    wait_for(&run, "macro nudge done (1 lines)");
    thread::sleep(Duration::from_millis(500));
    let end = Instant::now() + Duration::from_secs(2);
    while Instant::now() < end {
        run.send(F11);
        thread::sleep(Duration::from_millis(33));
    }
    thread::sleep(Duration::from_millis(500));
    assert_eq!(nudges(&mut sim), 1, "the held key ran the macro again");
    // Let go, then a deliberate press: it runs again.
    run.send(F11);
    sim.wait_received("the second nudge", |r| {
        let tail = r.get(before..).unwrap_or_default();
        tail.matches("@0A40,900,").count() + tail.matches("@0A 40,900,").count() >= 2
    });
    // Quit once the console has its end (the isel answers a move when it
    // has ended): `q` while it moves asks first (CI, under load).
    let end = Instant::now() + Duration::from_secs(20);
    while run
        .screen()
        .screen()
        .contents()
        .matches("macro nudge done (1 lines)")
        .count()
        < 2
    {
        assert!(Instant::now() < end, "the second nudge never ended");
        thread::sleep(Duration::from_millis(50));
    }
    quit(&mut run);
}
