//! The console's ways out stop the machine on every family
//! (`docs/safety-tests.md`): quit while a continuous jog runs (asks, then
//! stops first), a hang-up (the pty master closed: SIGHUP) during a
//! continuous jog, SIGTERM during a go-to move, on the EMCU and EMP
//! consoles against the real `jogterm sim --pty` (isel has these in
//! `tests/e2e/jog_terminal.rs` and `tests/e2e/faults.rs`); and a program the isel
//! simulator's start key runs, stopped with Space. Each test shows the stop
//! reached the controller (its own record), the axis stands (read twice,
//! unchanged) within the overrun bound, nothing resumes, and the exit.

use crate::faults_support;
use crate::sim_process::{self, SimProcess, WAIT};
use crate::stops_support;
use faults_support::console::Console;
use faults_support::wire::{emcu_motion, isel_messages, isel_motion};
use stops_support::{
    assert_a_new_connection_moves_nothing, assert_stands, emp_frames, isel_store_long_program,
    moving, signal, wait_moving, write_profile, x_steps,
};

/// The console on `family`'s simulator with the stop tests' profile
/// (`stops_support::write_profile`), initialised and referenced: READY, so
/// jogs and go-to are allowed.
fn ready(family: &'static str) -> (SimProcess, Console) {
    let sim = simulator(family);
    let profile = write_profile(&sim, "stoptest", "");
    let mut console = Console::start_with(&sim, &["--profile", profile]);
    console.initialise_and_reference();
    (sim, console)
}

/// `family`'s simulator for these tests. The axes stand near the
/// reference point at power-up (`sim_process::near_reference`), not 40 mm
/// from it: the reference run is only the way to READY here.
fn simulator(family: &'static str) -> SimProcess {
    SimProcess::start_with_files(family, &[sim_process::near_reference(family)])
}

/// The jog's overrun bound in steps (`jog.max_overrun` = 3 units, the
/// shipped profiles' steps per unit) and a margin for the stop's ramp.
fn overrun_bound(family: &str) -> i64 {
    let steps_per_unit = match family {
        "emcu" => 200,
        _ => 11_200,
    };
    3 * steps_per_unit + steps_per_unit / 2
}

const RIGHT: &[u8] = b"\x1b[C";

/// Switch to continuous jogging and hold X+ (Right) as a terminal repeats
/// it, until the console says JOGGING and the simulator's axis moves; a
/// few repeats more. The state line then.
fn hold_a_continuous_jog(sim: &mut SimProcess, console: &mut Console) -> String {
    console.keys(b"c");
    console.wait_for("HOLD");
    console.hold_until_jogging(RIGHT, 5);
    let state = wait_moving(sim, "jogging");
    console.keys(RIGHT);
    state
}

/// The stop went out after the motion that started: EMCU `@B` after the
/// last motion line, EMP the stop frame `08` after the last motion frame.
fn assert_stop_after_motion(family: &str, received: &str) {
    match family {
        "emcu" => {
            let motion = emcu_motion(received);
            let last = motion
                .last()
                .unwrap_or_else(|| panic!("no motion:\n{received}"));
            let after = received
                .rsplit_once(last.as_str())
                .map(|(_, rest)| rest)
                .unwrap_or_default();
            assert!(after.contains("@B<CR>"), "no @B after {last}:\n{received}");
        }
        _ => {
            let frames = emp_frames(received);
            let last = frames
                .iter()
                .rposition(|f| f.starts_with("2A") && f.get(4..6) != Some("03"))
                .unwrap_or_else(|| panic!("no motion:\n{received}"));
            assert!(
                frames[last + 1..].iter().any(|f| f.starts_with("0811")),
                "no stop frame after the motion:\n{received}"
            );
        }
    }
}

/// After the way out: the stop reached the controller, the axis stands
/// within the overrun bound of where it was when the way out was taken, and
/// a new connection moves nothing.
fn assert_stopped(sim: &mut SimProcess, at_exit: &str) {
    let family = sim.family;
    let received = sim.received();
    assert_stop_after_motion(family, &received);
    let state = assert_stands(sim);
    let (from, to) = (x_steps(family, at_exit), x_steps(family, &state));
    assert!(
        (to - from).abs() <= overrun_bound(family),
        "ran on from {from} to {to}: the stop did not go out at once\n{state}"
    );
    assert_a_new_connection_moves_nothing(sim, to);
    sim.assert_alive();
}

/// `q` while a continuous jog runs asks first; `y` stops, then quits
/// (status 0, the terminal given back).
fn quit_while_jogging(family: &'static str) {
    let (mut sim, mut console) = ready(family);
    hold_a_continuous_jog(&mut sim, &mut console);
    console.keys(b"q");
    // The question wraps in its popup: its first line.
    console.wait_for("The machine is jogging. Stop all motion");
    assert!(
        moving(family, &sim.device_state()),
        "still jogging while asked"
    );
    console.keys(b"y");
    let at_exit = sim.device_state();
    console.assert_exits(Some(0));
    console.assert_terminal_restored();
    assert_stopped(&mut sim, &at_exit);
}

#[test]
fn emcu_quit_while_a_continuous_jog_runs_asks_then_stops() {
    quit_while_jogging("emcu");
}

#[test]
fn emp_quit_while_a_continuous_jog_runs_asks_then_stops() {
    quit_while_jogging("emp");
}

/// The terminal goes away (the pty master closed: SIGHUP) during a
/// continuous jog: the stop goes out at once and the console ends.
fn hang_up_while_jogging(family: &'static str) {
    let (mut sim, mut console) = ready(family);
    hold_a_continuous_jog(&mut sim, &mut console);
    let at_exit = sim.device_state();
    console.run.close_master();
    // 0, or 1 when a frame failed on the dead terminal before the hang-up
    // was seen (`the console failed: drawing the screen failed`); never a
    // panic's 101 (`ui::terminal::Tui`, `main`).
    let code = console.run.wait_exit(WAIT);
    assert!(
        matches!(code, Some(0 | 1)),
        "exit {code:?} after the hang-up"
    );
    assert_stopped(&mut sim, &at_exit);
}

#[test]
fn emcu_hang_up_during_a_continuous_jog_stops() {
    hang_up_while_jogging("emcu");
}

#[test]
fn emp_hang_up_during_a_continuous_jog_stops() {
    hang_up_while_jogging("emp");
}

/// SIGTERM during a go-to move (`g X150`, far at the jog speed): the stop
/// goes out, the console ends with 0 and gives the terminal back.
fn terminate_during_a_go_to(family: &'static str) {
    let (mut sim, mut console) = ready(family);
    console.keys(b"g");
    console.keys(b"X150");
    console.wait_for("X150");
    console.keys(b"\r");
    console.wait_until("MOVING in the status bar", |s| {
        s.lines().next().is_some_and(|l| l.contains("MOVING"))
    });
    wait_moving(&mut sim, "the go-to move");
    let pid = console.run.child.process_id().expect("pid");
    signal(pid, libc::SIGTERM);
    let at_exit = sim.device_state();
    console.assert_exits(Some(0));
    console.assert_terminal_restored();
    assert_stopped(&mut sim, &at_exit);
}

#[test]
fn emcu_terminate_signal_during_a_go_to_stops() {
    terminate_during_a_go_to("emcu");
}

#[test]
fn emp_terminate_signal_during_a_go_to_stops() {
    terminate_during_a_go_to("emp");
}

/// isel: the machine's start key runs the stored program while the console
/// is connected and has not moved. The controller answers nothing while a
/// program runs (manual 3.1), so the console's next poll goes unanswered: a
/// console that was not asked to move sends no stop of its own (issue 24,
/// `docs/device.md`, "Sessions that do not move"); it says the controller is
/// busy and waits. Space, the operator's stop, then halts the program: 0xFD
/// then 0xFF reach the controller, the axis stands short of the program's
/// end, and a later connection moves nothing (a later `@0S` would run the
/// stored program anew, manual 2.2.23: a new start, not a resume).
#[test]
fn isel_a_program_run_by_the_start_key_runs_until_space_stops_it() {
    let mut sim = SimProcess::start("isel");
    let out = isel_store_long_program(&sim);
    assert!(out.status.success(), "{}", sim_process::text(&out.stderr));
    let mut console = Console::start(&sim);
    console.wait_until("READY", |s| {
        s.lines().next().is_some_and(|l| l.contains("READY"))
    });
    let before = sim.received();
    sim.control("press start");
    wait_moving(&mut sim, "the program started by the key");
    console.wait_for("the controller is busy: a program runs; waiting");
    assert!(
        moving("isel", &sim.device_state()),
        "the program runs on while the console waits"
    );
    let quiet = sim.received();
    assert!(
        !isel_messages(&quiet[before.len()..])
            .iter()
            .any(|m| m.starts_with("<F")),
        "no stop of the console's own:\n{}",
        &quiet[before.len()..]
    );
    console.keys(b" ");
    let received = sim.wait_received("Space's stop", |r| {
        isel_messages(&r[before.len()..])
            .iter()
            .any(|m| m == "<FD>")
    });
    let after = isel_messages(&received[before.len()..]);
    let stop = after.iter().position(|m| m == "<FD>").unwrap_or_default();
    assert_eq!(
        after.get(stop + 1).map(String::as_str),
        Some("<FF>"),
        "0xFD then 0xFF: {after:?}"
    );
    let state = assert_stands(&mut sim);
    let x = x_steps("isel", &state);
    assert!(x < 60_000, "the program ran to its end: {state}");
    console.wait_for("the controller answers again");
    assert!(
        isel_motion(&sim.received()).is_empty(),
        "jogterm started nothing"
    );
    console.quit();
    assert_a_new_connection_moves_nothing(&mut sim, x);
    sim.assert_alive();
}

/// The console's read-back is done: the status bar says what the machine
/// needs next (or READY).
fn wait_read_back(console: &Console) {
    console.wait_until("the state read back", |s| {
        s.lines().next().is_some_and(|l| {
            ["READY", "NOT INIT", "NOT REF"]
                .iter()
                .any(|w| l.contains(w))
        })
    });
}

/// Whether `traffic` holds the family's stop: isel 0xFD then 0xFF, EMCU
/// `@B`, EMP the stop frame `08` (the shipped profile's `emp.stop = hold`).
fn has_stop(family: &str, traffic: &str) -> bool {
    match family {
        "isel" => {
            let m = isel_messages(traffic);
            m.windows(2).any(|w| w[0] == "<FD>" && w[1] == "<FF>")
        }
        "emcu" => traffic.split("<CR>").any(|l| l == "@B"),
        _ => emp_frames(traffic).iter().any(|f| f.starts_with("0811")),
    }
}

/// Issue 24: the console sends no stop at connect, nor at a quit when it
/// never moved (a session that was not asked to move never stops what the
/// machine runs, `docs/device.md`, "Sessions that do not move"). A console
/// that has moved (a reference run and a continuous jog, ended by its
/// dead man) sends the family's stop when it quits. Before: every console
/// connection opened with the stop sequence.
fn console_stops_only_once_it_has_moved(family: &'static str) {
    let mut sim = simulator(family);
    let profile = write_profile(&sim, "stoptest", "");
    let before = sim.received().len();
    let console = Console::start_with(&sim, &["--profile", profile]);
    wait_read_back(&console);
    std::thread::sleep(std::time::Duration::from_millis(500));
    console.quit();
    let quiet = stops_support::session_traffic(&mut sim, before);
    assert_eq!(
        stops_support::stops_and_motion(family, &quiet),
        Vec::<String>::new(),
        "a console that never moved sent stops or motion:\n{quiet}"
    );
    assert!(!quiet.is_empty(), "the console read the state back");

    let mut console = Console::start_with(&sim, &["--profile", profile]);
    wait_read_back(&console);
    console.initialise_and_reference();
    hold_a_continuous_jog(&mut sim, &mut console);
    // Keys no more: the dead man ends the jog.
    console.wait_until("the jog ended", |s| {
        s.lines().next().is_some_and(|l| l.contains("READY"))
    });
    assert_stands(&mut sim);
    let mark = sim.received().len();
    console.quit();
    sim.wait_received("a console that moved quits with the stop", |r| {
        has_stop(family, &r[mark..])
    });
    sim.assert_alive();
}

#[test]
fn isel_console_connect_sends_no_stop_and_its_quit_after_a_jog_does() {
    console_stops_only_once_it_has_moved("isel");
}

#[test]
fn emcu_console_connect_sends_no_stop_and_its_quit_after_a_jog_does() {
    console_stops_only_once_it_has_moved("emcu");
}

#[test]
fn emp_console_connect_sends_no_stop_and_its_quit_after_a_jog_does() {
    console_stops_only_once_it_has_moved("emp");
}
