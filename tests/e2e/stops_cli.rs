//! Every way the command-line tools start motion has a tested way to stop it
//! (`docs/safety-tests.md`): `jogterm send`, `poll` and `upload --start`
//! against the real `jogterm sim --pty`, interrupted by a signal (SIGINT,
//! SIGTERM, SIGHUP: `src/cli/session.rs::interrupted`), and a program the
//! isel simulator's start key runs, stopped from jogterm. Each test shows
//! the stop bytes reached the controller (its own record), the axis stands
//! (read twice, unchanged), nothing resumes, no panic, and the exit status.

use std::process::{Child, Stdio};

use crate::sim_process;
use crate::stops_support;
use sim_process::{
    EMCU_NEAR_REFERENCE, EMP_NEAR_REFERENCE, ISEL_NEAR_REFERENCE, SimProcess, text, wait_child,
};
use stops_support::{
    LONG_PROGRAM_SCALE, assert_a_new_connection_moves_nothing, assert_exit, assert_stands,
    emp_frames, interrupt, isel_store_long_program, moving, session_traffic, signal,
    stops_and_motion, wait_moving, x_steps,
};

use crate::faults_support::wire;
use wire::{emcu_motion, isel_messages, isel_motion};

/// isel: a long X move (15 s at 4000 Hz) for a signal to interrupt.
const ISEL_LONG_MOVE: &str = "@0M60000,4000,0,4000,0,4000,0,4000";
/// isel: the axes and the reference where they stand, so moves are allowed.
const ISEL_READY: [&str; 2] = ["@07", "@0N7"];

/// EMCU: reset, start speed and ramp, a fast reference run (as
/// `tests/e2e/cli_send_poll_emcu.rs`), then a move of 20 s at 2 kHz.
const EMCU_LONG_MOVE: [&str; 6] = [
    "@R",
    "#S2000",
    "#R200\\x01",
    "$HZYX\\x01",
    "#E1,2000",
    "L1,x40000\\x01",
];

/// EMP drive 11: switch on, enable in TP mode, home, then position far away
/// slowly (`send` waits for the positioning's completion).
const EMP_LONG_MOVE: [&str; 4] = [
    "02 11 00 00000000",
    "22 07 00 00000000",
    "26 00 00 007F2000",
    "2A 01 10 00400000",
];

fn spawn(sim: &SimProcess, args: &[&str]) -> Child {
    sim.jogterm(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm")
}

fn isel_x(state: &str) -> i64 {
    x_steps("isel", state)
}

/// isel: the axis stands short of the end of [`ISEL_LONG_PROGRAM`]'s move
/// (60 000 steps) and past its start; where it stands (X steps).
fn isel_stands_mid_program(sim: &mut SimProcess) -> i64 {
    let state = assert_stands(sim);
    let x = isel_x(&state);
    assert!(
        x > 0 && x < 60_000,
        "stopped mid-program: {state}\n{}",
        sim.received()
    );
    x
}

/// isel: what the controller received after `command` (the messages).
fn isel_after(received: &str, command: &str) -> Vec<String> {
    isel_messages(received)
        .into_iter()
        .skip_while(|m| m != command)
        .skip(1)
        .collect()
}

/// isel: the stop after `command` is 0xFD and then 0xFF (docs/protocols.md:
/// every stop is both, the break makes sure nothing is left to resume).
fn assert_isel_stopped_after(received: &str, command: &str) {
    let after = isel_after(received, command);
    assert_eq!(
        after.get(..2),
        Some(&["<FD>".to_string(), "<FF>".to_string()][..]),
        "the stop right after {command}:\n{received}"
    );
}

/// isel: a later `@0S` is answered `G` (nothing to resume) and moves
/// nothing; `state` is where the axes stood before.
fn assert_isel_nothing_resumes(sim: &mut SimProcess, state: &str) {
    let out = sim.run(&["send", "@0S"]);
    assert_exit(&out, 1, "send @0S");
    assert!(text(&out.stdout).contains("<< G"), "{}", text(&out.stdout));
    assert_eq!(isel_x(&assert_stands(sim)), isel_x(state), "resumed");
}

/// `jogterm send` of a long isel move, interrupted by `sig` mid-move: the
/// stop goes out at once (0xFD 0xFF), the command says so and exits 1, the
/// axis stands short of the target and `@0S` does not resume it.
fn isel_send_interrupted_by(sig: libc::c_int) {
    let mut sim = SimProcess::start("isel");
    let mut args = vec!["send"];
    args.extend(ISEL_READY);
    args.push(ISEL_LONG_MOVE);
    let child = spawn(&sim, &args);
    sim.wait_received("the move", |r| {
        isel_messages(r).iter().any(|m| m == ISEL_LONG_MOVE)
    });
    wait_moving(&mut sim, "moving");
    interrupt(child, sig, "send");
    let state = assert_stands(&mut sim);
    let x = isel_x(&state);
    assert!(x > 0 && x < 60_000, "stopped mid-move: {state}");
    let received = sim.received();
    assert_isel_stopped_after(&received, ISEL_LONG_MOVE);
    assert_eq!(isel_motion(&received), [ISEL_LONG_MOVE], "{received}");
    assert_isel_nothing_resumes(&mut sim, &state);
    sim.assert_alive();
}

#[test]
fn isel_send_ctrl_c_mid_move_stops_and_nothing_resumes() {
    isel_send_interrupted_by(libc::SIGINT);
}

#[test]
fn isel_send_sigterm_mid_move_stops_and_nothing_resumes() {
    isel_send_interrupted_by(libc::SIGTERM);
}

#[test]
fn isel_send_sighup_mid_move_stops_and_nothing_resumes() {
    isel_send_interrupted_by(libc::SIGHUP);
}

/// A hang-up of the terminal `send` runs in: SIGHUP, and stderr is gone.
/// The stop goes out, then the orderly close (its stop sequence too), and
/// saying so on the dead stderr does not panic: status 1, not 101.
#[test]
fn isel_send_hang_up_with_its_stderr_gone_stops_closes_and_exits_1() {
    let mut sim = SimProcess::start("isel");
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let mut args = vec!["send"];
    args.extend(ISEL_READY);
    args.push(ISEL_LONG_MOVE);
    let child = sim
        .jogterm(&args)
        .stdout(Stdio::null())
        .stderr(writer)
        .spawn()
        .expect("run jogterm");
    wait_moving(&mut sim, "moving");
    signal(child.id(), libc::SIGHUP);
    let out = wait_child(child, "jogterm send");
    assert_eq!(out.status.code(), Some(1));
    let state = assert_stands(&mut sim);
    let received = sim.received();
    let after = isel_after(&received, ISEL_LONG_MOVE);
    assert_eq!(
        after,
        ["<FD>", "<FF>", "<FD>", "<FF>"],
        "the stop, then the close's stop sequence:\n{received}"
    );
    assert_isel_nothing_resumes(&mut sim, &state);
}

/// EMCU: `send` of a long move interrupted with Ctrl-C: `@B` reaches the
/// interface right after the move, the axis stands short of the target and
/// a later connection does not move it.
#[test]
fn emcu_send_ctrl_c_mid_move_stops_and_nothing_resumes() {
    let mut sim = SimProcess::start_with_files("emcu", &[EMCU_NEAR_REFERENCE]);
    let mut args = vec!["send"];
    args.extend(EMCU_LONG_MOVE);
    let child = spawn(&sim, &args);
    // The move runs once the reference run has ended.
    sim.wait_device("moving after the reference run", |d| {
        d.contains("moving") && !d.contains("referencing") && !d.contains("position unknown")
    });
    interrupt(child, libc::SIGINT, "send");
    let state = assert_stands(&mut sim);
    let x = x_steps("emcu", &state);
    assert!(x > 0 && x < 40_000, "stopped mid-move: {state}");
    let received = sim.received();
    let after = received
        .split_once("L1,x40000<01>")
        .map(|(_, rest)| rest)
        .unwrap_or_else(|| panic!("the move was not received:\n{received}"));
    assert!(
        after.trim_start_matches("@X<CR>").starts_with("@B<CR>"),
        "the stop right after the move (queries aside):\n{received}"
    );
    assert_eq!(
        emcu_motion(&received).last().map(String::as_str),
        Some("L1,x40000")
    );
    assert_a_new_connection_moves_nothing(&mut sim, x);
    sim.assert_alive();
}

/// EMP: `send` of a long positioning (`2A 01`, the command waits for its
/// completion) interrupted with Ctrl-C: the stop frame `08` (the profile's
/// `emp.stop = "hold"`) reaches the drive right after, it stands short of
/// the target, and a later connection does not move it.
#[test]
fn emp_send_ctrl_c_mid_positioning_stops_and_nothing_resumes() {
    let mut sim = SimProcess::start_with_files("emp", &[EMP_NEAR_REFERENCE]);
    let mut args = vec!["send", "--drive", "11"];
    args.extend(EMP_LONG_MOVE);
    let child = spawn(&sim, &args);
    sim.wait_received("the positioning", |r| r.contains("2A11011000400000"));
    wait_moving(&mut sim, "positioning");
    interrupt(child, libc::SIGINT, "send");
    let state = assert_stands(&mut sim);
    assert!(
        x_steps("emp", &state) < 0x40_0000,
        "stopped mid-move: {state}"
    );
    let received = sim.received();
    let frames = emp_frames(&received);
    let after: Vec<&str> = frames
        .iter()
        .skip_while(|f| **f != "2A11011000400000")
        .skip(1)
        .copied()
        .filter(|f| !f.starts_with("2C") && !f.starts_with("0A"))
        .collect();
    assert_eq!(
        after.first().copied(),
        Some("0811000000000000"),
        "the stop right after the positioning (reads aside):\n{received}"
    );
    assert_a_new_connection_moves_nothing(&mut sim, x_steps("emp", &state));
    sim.assert_alive();
}

/// `jogterm poll` never starts motion, and interrupted (Ctrl-C) it closes
/// without a stop (it moved nothing, `docs/device.md`, "Sessions that do
/// not move"): the controller received polls and nothing that stops or
/// moves, the status is 0.
fn poll_interrupted(family: &'static str, prepare: &[&str], poll: &str) {
    let mut sim = SimProcess::start(family);
    if !prepare.is_empty() {
        let mut args = vec!["send"];
        args.extend(prepare);
        let out = sim.run(&args);
        assert_exit(&out, 0, "send (prepare)");
    }
    let before = sim.received();
    let child = spawn(&sim, &["poll", "--interval-ms", "0"]);
    sim.wait_received("a few polls", |r| {
        r.len() > before.len() && r[before.len()..].matches(poll).count() >= 5
    });
    signal(child.id(), libc::SIGINT);
    let out = wait_child(child, "jogterm poll");
    assert_exit(&out, 0, "poll interrupted");
    assert!(text(&out.stdout).lines().count() >= 1, "samples printed");
    let polled = session_traffic(&mut sim, before.len());
    let polled = polled.as_str();
    assert_eq!(
        stops_and_motion(family, polled),
        Vec::<String>::new(),
        "poll sent a stop or motion:\n{polled}"
    );
    assert_stands(&mut sim);
    sim.assert_alive();
}

#[test]
fn isel_poll_ctrl_c_closes_without_a_stop_and_never_moves() {
    poll_interrupted("isel", &ISEL_READY, "@0P<CR>");
}

#[test]
fn emcu_poll_ctrl_c_closes_without_a_stop_and_never_moves() {
    poll_interrupted("emcu", &[], "@LX<CR>");
}

#[test]
fn emp_poll_ctrl_c_closes_without_a_stop_and_never_moves() {
    poll_interrupted(
        "emp",
        &["--drive", "11", "02 11 00 00000000"],
        "2C11000000000000<EOF>",
    );
}

/// A program with one long X move (relative, 15 s at 4000 Hz).
const ISEL_LONG_PROGRAM: &str = "; one long move\n7 7\n060000,4000,0,4000,0,4000,0,4000\n9\n";

/// `jogterm upload FILE --start` interrupted with Ctrl-C while the stored
/// program runs: 0xFD 0xFF right after the start, the axis stands short of
/// the program's end, status 1. A later connection moves nothing (a later
/// `@0S` would be a new run of the stored program from its start, manual
/// 2.2.23, not a resume).
#[test]
fn isel_upload_start_ctrl_c_stops_the_running_program() {
    // 1 mm from the reference point: the program's own `7 7` is only the
    // way to its move.
    let mut sim = SimProcess::start_with_files("isel", &[ISEL_NEAR_REFERENCE]);
    let out = sim.run(&["send", "@07", "@0N7"]);
    assert_exit(&out, 0, "send (reference)");
    let file = sim.dir.path().join("long.isel");
    std::fs::write(&file, ISEL_LONG_PROGRAM).expect("write the program");
    let file_arg = file.display().to_string();
    let child = spawn(&sim, &["upload", &file_arg, "--start"]);
    sim.wait_received("the start", |r| isel_messages(r).iter().any(|m| m == "@0S"));
    wait_moving(&mut sim, "the program running");
    interrupt(child, libc::SIGINT, "upload");
    let x = isel_stands_mid_program(&mut sim);
    let received = sim.received();
    assert_isel_stopped_after(&received, "@0S");
    assert_a_new_connection_moves_nothing(&mut sim, x);
    assert_eq!(isel_motion(&sim.received()), ["@0S"], "one start only");
    sim.assert_alive();
}

/// [`ISEL_LONG_PROGRAM`] with the spindle on (port 2) before its move, as a
/// G-code job's M3 comes out (`p2,128,1`), and off after it.
const ISEL_SPINDLE_PROGRAM: &str = "7 7\np2,128,1 ; job.nc:2 spindle on\n\
    060000,4000,0,4000,0,4000,0,4000\np2,128,0 ; job.nc:4 spindle off\n9\n";

/// Issue 37: `jogterm upload FILE --start` of a job that switched the
/// spindle on, stopped with Ctrl-C mid-move: once the axis stands the
/// spindle is switched off (`@0B2,0` reaches the controller after the
/// stop) and stderr says so. Before, nothing went out after the stop.
#[test]
fn isel_upload_start_ctrl_c_switches_the_spindle_off_once_the_axes_stand() {
    let mut sim = SimProcess::start_with_files("isel", &[ISEL_NEAR_REFERENCE]);
    let out = sim.run(&["send", "@07", "@0N7"]);
    assert_exit(&out, 0, "send (reference)");
    let file = sim.dir.path().join("spindle.isel");
    std::fs::write(&file, ISEL_SPINDLE_PROGRAM).expect("write the program");
    let file_arg = file.display().to_string();
    let child = spawn(&sim, &["upload", &file_arg, "--start"]);
    sim.wait_received("the start", |r| isel_messages(r).iter().any(|m| m == "@0S"));
    wait_moving(&mut sim, "the program running");
    signal(child.id(), libc::SIGINT);
    let out = wait_child(child, "jogterm upload");
    assert_exit(&out, 1, "upload interrupted");
    let stderr = text(&out.stderr);
    assert!(
        stderr.contains("switched off once the axes stood: spindle (out2)"),
        "{stderr}"
    );
    isel_stands_mid_program(&mut sim);
    let received = sim.received();
    assert_isel_stopped_after(&received, "@0S");
    let after = isel_after(&received, "@0S");
    assert!(
        after.iter().any(|m| m == "@0B2,0"),
        "the spindle switched off after the stop:\n{received}"
    );
    sim.assert_alive();
}

/// Store [`ISEL_LONG_PROGRAM`]'s move with `send` and run it with the
/// simulator's start key (isel manual 3.1: the key starts the stored program,
/// the controller sends no answer but the sync character).
fn isel_program_started_by_the_key(sim: &mut SimProcess) {
    let out = isel_store_long_program(sim);
    assert_exit(&out, 0, "send (store)");
    // Storing moves nothing: `send` closed without a stop that could break
    // off the start (docs/device.md, "Sessions that do not move").
    sim.control("press start");
    sim.wait_device("the program started by the key, under way", |d| {
        moving("isel", d) && isel_x(d) > 1000
    });
}

/// The machine's start key runs the stored program; `jogterm send break`
/// stops it: its 0xFF reaches the controller, the program halts mid-move,
/// jogterm starts nothing, and a later connection moves nothing.
#[test]
fn isel_start_key_program_is_stopped_by_send_break() {
    let mut sim = SimProcess::start("isel");
    isel_program_started_by_the_key(&mut sim);
    let before = sim.received();
    let out = sim.run(&["send", "break"]);
    assert_exit(&out, 0, "send break");
    let x = isel_stands_mid_program(&mut sim);
    let received = sim.received();
    let sent = isel_messages(received.get(before.len()..).unwrap_or_default());
    // The operator's break (0xFF, manual 2.2.31) reached the controller and
    // is the one stop of the session: it asked for no motion, so its
    // connect sent none (docs/device.md, "Sessions that do not move").
    assert_eq!(sent, ["<FF>"], "{received}");
    assert!(isel_motion(&received).is_empty(), "jogterm started nothing");
    assert_a_new_connection_moves_nothing(&mut sim, x);
    sim.assert_alive();
}

/// A failure reported to a stderr that is gone (the terminal hung up, its
/// reader ended) still ends with status 1, not a panic's 101: a console
/// whose last frame failed on a dead terminal leaves this way after it has
/// stopped the machine. Here the simulator cannot make its link.
#[test]
fn a_failure_on_a_stderr_that_is_gone_exits_1_not_with_a_panic() {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let dir = tempfile::tempdir().expect("temp dir");
    let out = std::process::Command::new(sim_process::JOGTERM)
        .args(["sim", "--pty", "--protocol", "isel", "--link"])
        .arg(dir.path().join("missing").join("tty"))
        .env("JOGTERM_CONFIG_DIR", dir.path())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(writer)
        .status()
        .expect("run jogterm sim");
    assert_eq!(out.code(), Some(1));
}

/// `poll` while the machine's start key runs the stored program: the
/// controller answers nothing while a program runs (isel manual 3.1); poll
/// says the controller is busy and waits, stops nothing (it moved nothing,
/// `docs/device.md`, "Sessions that do not move"): the program runs to its
/// end, poll samples again and ends with 0 on Ctrl-C. Poll never started
/// it. (Before issue 24 it ended with a link failure, status 3.)
#[test]
fn isel_poll_during_a_start_key_program_stops_nothing_and_the_program_ends() {
    // The program runs 5 s of wall time (`LONG_PROGRAM_SCALE`): the poll
    // before it and the waits on events are the same.
    let mut sim = SimProcess::options("isel")
        .time_scale(LONG_PROGRAM_SCALE)
        .start();
    let out = isel_store_long_program(&sim);
    assert_exit(&out, 0, "send (store)");
    let before = sim.received();
    let child = spawn(&sim, &["poll"]);
    sim.wait_received("a few polls", |r| {
        r.len() > before.len() && r[before.len()..].matches("@0P<CR>").count() >= 5
    });
    sim.control("press start");
    let end = sim.wait_device("the program at its end", |d| {
        !moving("isel", d) && isel_x(d) == 60_000
    });
    let answered = sim.received().len();
    sim.wait_received("polls after the program", |r| {
        r.len() > answered && r[answered..].matches("@0P<CR>").count() >= 3
    });
    signal(child.id(), libc::SIGINT);
    let out = wait_child(child, "jogterm poll");
    assert_exit(&out, 0, "poll during a program, interrupted after it");
    let err = text(&out.stderr);
    assert!(
        err.contains("the controller is busy: a program runs; waiting (no reply to @0P")
            && err.contains("the controller answers again"),
        "{err}"
    );
    let polled = session_traffic(&mut sim, before.len());
    assert_eq!(
        stops_and_motion("isel", &polled),
        Vec::<String>::new(),
        "poll stopped nothing: {polled}"
    );
    assert_eq!(isel_x(&assert_stands(&mut sim)), 60_000, "{end}");
    assert!(
        isel_motion(&sim.received()).is_empty(),
        "poll started nothing"
    );
}

/// EMCU: `jogterm upload JOB --start` interrupted with Ctrl-C while the
/// stored job runs (`@J`): `@B` reaches the interface after the start, the
/// axis stands short of the job's end, status 1, and a later connection
/// moves nothing.
#[test]
fn emcu_upload_start_ctrl_c_stops_the_running_job() {
    let mut sim = SimProcess::start_with_files("emcu", &[EMCU_NEAR_REFERENCE]);
    let mut reference = vec!["send"];
    reference.extend(&EMCU_LONG_MOVE[..4]);
    let out = sim.run(&reference);
    assert_exit(&out, 0, "send (reset, ramp, reference)");
    let file = sim.dir.path().join("long.emcu");
    std::fs::write(&file, "; 20 s at 2 kHz\n#E1,2000\nL1,x40000\n").expect("write the job");
    let file_arg = file.display().to_string();
    let child = spawn(&sim, &["upload", &file_arg, "--start"]);
    sim.wait_received("the start", |r| r.contains("@J"));
    sim.wait_device("the job running", |d| {
        d.contains("moving") && x_steps("emcu", d) > 0
    });
    interrupt(child, libc::SIGINT, "upload");
    let state = assert_stands(&mut sim);
    let x = x_steps("emcu", &state);
    assert!(x > 0 && x < 40_000, "stopped mid-job: {state}");
    let received = sim.received();
    let after = received
        .rsplit_once("@J")
        .map(|(_, rest)| rest)
        .unwrap_or_else(|| panic!("the start was not received:\n{received}"));
    assert!(
        after.contains("@B<CR>"),
        "the stop after the start:\n{received}"
    );
    assert_eq!(
        received.matches("@J").count(),
        1,
        "one start only:\n{received}"
    );
    assert_a_new_connection_moves_nothing(&mut sim, x);
    sim.assert_alive();
}
