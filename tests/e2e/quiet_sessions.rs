//! Sessions that were not asked to move send no stop (`docs/device.md`,
//! "Sessions that do not move"; issue 24): `watch`, `poll` and `send` of a
//! read against the real `jogterm sim --pty`, on isel, EMCU and EMP. What the
//! controller received from each session is counted for stop and control
//! bytes: none at connect, none while it runs, none at its exit (a signal
//! included). And a stored program the isel start key runs goes on to its
//! end while `watch` connects.

use std::process::{Child, Stdio};

use crate::sim_process;
use crate::stops_support;
use sim_process::{
    EMCU_NEAR_REFERENCE, ISEL_NEAR_REFERENCE, LOGIC_SCALE, SimProcess, text, wait_child,
};
use stops_support::{
    LONG_PROGRAM_SCALE, assert_exit, isel_store_long_program, moving, session_traffic, signal,
    stops_and_motion, wait_moving, x_steps,
};

/// `args` configured from the simulator's directory, stdout and stderr
/// piped (also `read_sessions`).
pub fn spawn(sim: &SimProcess, args: &[&str]) -> Child {
    sim.configured(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm")
}

/// The read each family's `poll` repeats, as the controller receives it.
fn poll_read(family: &str) -> &'static str {
    match family {
        "isel" => "@0P<CR>",
        "emcu" => "@LX<CR>",
        _ => "2C11000000000000<EOF>",
    }
}

/// `args` runs until it has sent `reads` of its read, then gets SIGINT: it
/// ends with 0, and the controller received no stop, control byte or motion
/// from it.
fn interrupted_session_sends_no_stop(
    family: &'static str,
    args: &[&str],
    read: &str,
    reads: usize,
) {
    let mut sim = SimProcess::start(family);
    let before = sim.received();
    let child = spawn(&sim, args);
    sim.wait_received("a few reads", |r| {
        r.len() > before.len() && r[before.len()..].matches(read).count() >= reads
    });
    signal(child.id(), libc::SIGINT);
    let out = wait_child(child, args[0]);
    assert_exit(&out, 0, &format!("{args:?} interrupted"));
    assert!(
        !text(&out.stderr).contains("stopped"),
        "nothing was stopped: {}",
        text(&out.stderr)
    );
    let session = session_traffic(&mut sim, before.len());
    let session = session.as_str();
    assert_eq!(
        stops_and_motion(family, session),
        Vec::<String>::new(),
        "{args:?} sent stops or motion:\n{session}"
    );
    sim.assert_alive();
}

/// `send` of a read: answered, status 0, and the controller received the
/// read alone (whole, nothing cut into it), no stop at connect or exit.
fn send_of_a_read_sends_no_stop(family: &'static str, args: &[&str]) {
    let mut sim = SimProcess::start(family);
    let before = sim.received();
    let out = sim.run(args);
    assert_exit(&out, 0, &format!("{args:?}"));
    let session = session_traffic(&mut sim, before.len());
    let session = session.as_str();
    assert_eq!(
        stops_and_motion(family, session),
        Vec::<String>::new(),
        "{args:?} sent stops or motion:\n{session}"
    );
    assert!(
        session.contains(poll_read(family)),
        "the read whole:\n{session}"
    );
    sim.assert_alive();
}

#[test]
fn isel_watch_poll_and_send_of_a_read_send_no_stop() {
    interrupted_session_sends_no_stop("isel", &["watch"], "<CR>", 10);
    interrupted_session_sends_no_stop("isel", &["poll", "--interval-ms", "0"], "@0P<CR>", 5);
    send_of_a_read_sends_no_stop("isel", &["send", "@0P"]);
}

#[test]
fn emcu_watch_poll_and_send_of_a_read_send_no_stop() {
    interrupted_session_sends_no_stop("emcu", &["watch"], "<CR>", 10);
    interrupted_session_sends_no_stop("emcu", &["poll", "--interval-ms", "0"], "@LX<CR>", 5);
    send_of_a_read_sends_no_stop("emcu", &["send", "@LX"]);
}

#[test]
fn emp_watch_poll_and_send_of_a_read_send_no_stop() {
    interrupted_session_sends_no_stop("emp", &["watch"], "<EOF>", 6);
    interrupted_session_sends_no_stop("emp", &["poll", "--interval-ms", "0"], poll_read("emp"), 3);
    send_of_a_read_sends_no_stop("emp", &["send", "2C 11 00 00 00000000"]);
}

/// The isel start key runs the stored program (manual 3.1); `watch`
/// connects while it runs and is interrupted later: the program runs to its
/// end (X at 60 000), and watch sent no stop.
#[test]
fn isel_start_key_program_runs_to_its_end_while_watch_connects() {
    // The program runs 5 s of wall time (`LONG_PROGRAM_SCALE`): watch is on
    // the line within a fraction of that, and the test waits for it there.
    let mut sim = SimProcess::options("isel")
        .time_scale(LONG_PROGRAM_SCALE)
        .start();
    let out = isel_store_long_program(&sim);
    assert_exit(&out, 0, "send (store)");
    sim.control("press start");
    wait_moving(&mut sim, "the program started by the key");
    let before = sim.received();
    let child = spawn(&sim, &["watch"]);
    sim.wait_received("watch on the line", |r| r.len() > before.len());
    let end = sim.wait_device("the program at its end", |d| {
        !moving("isel", d) && x_steps("isel", d) == 60_000
    });
    signal(child.id(), libc::SIGINT);
    let out = wait_child(child, "watch");
    assert!(
        !text(&out.stderr).contains("stopped"),
        "{}",
        text(&out.stderr)
    );
    let session = session_traffic(&mut sim, before.len());
    let session = session.as_str();
    assert_eq!(
        stops_and_motion("isel", session),
        Vec::<String>::new(),
        "watch sent stops or motion:\n{session}"
    );
    assert_eq!(x_steps("isel", &end), 60_000, "{end}");
    sim.assert_alive();
}

/// isel: store a program of one X move of `steps` at 4000 Hz (after the
/// axes and a simulated reference, as `isel_store_long_program`).
fn isel_store_program_of(sim: &SimProcess, steps: u32) {
    let line = format!("0{steps},4000,0,4000,0,4000,0,4000");
    let out = sim.run(&["send", "@07", "@0N7", "@0i", &line, "9"]);
    assert_exit(&out, 0, "send (store)");
}

/// Issue 24: the isel controller answers nothing while a stored program
/// runs (manual 3.1; its bytes are dropped, `docs/protocols.md`). `watch`
/// and then `poll`, each connecting while the start key runs the program,
/// say `the controller is busy: a program runs; waiting`, wait without
/// giving up and without a stop or control byte, the program runs to its
/// end each time, and both end normally on Ctrl-C (poll with its samples
/// once the controller answers again). Before: `watch` gave up with
/// "no reply to @0T0" (status 3), `poll` with "no position for 3 s".
#[test]
fn isel_watch_and_poll_say_the_controller_is_busy_and_wait_for_a_program() {
    let mut sim = SimProcess::start("isel");
    // 10 000 steps at 4000 Hz: 2.5 s of real motion (4 s before), still
    // many times what it takes a session to start and find the controller
    // silent (its first read's deadline, wire time + 100 ms); the test
    // fails if a session connects only after the end, as it must then not
    // say "busy". At real time: the scale would shorten the program as
    // much, and a program of fewer steps says the same.
    let program: u32 = 10_000;
    isel_store_program_of(&sim, program);
    let program = i64::from(program);
    for (run, args) in [
        (1, &["watch"][..]),
        (2, &["poll", "--interval-ms", "200"][..]),
    ] {
        sim.control("press start");
        wait_moving(&mut sim, "the program started by the key");
        let before = sim.received();
        let child = spawn(&sim, args);
        // Each run moves X by the program's 10 000 steps (a new start runs
        // the program from its beginning, manual 2.2.23).
        let end = sim.wait_device("the program at its end", |d| {
            !moving("isel", d) && x_steps("isel", d) == program * run
        });
        // Answered again: a few more reads go out.
        let answered = sim.received().len();
        sim.wait_received("reads after the program", |r| {
            r.len() > answered && r[answered..].matches("<CR>").count() >= 3
        });
        signal(child.id(), libc::SIGINT);
        let out = wait_child(child, args[0]);
        assert_exit(&out, 0, &format!("{args:?} interrupted"));
        let err = text(&out.stderr);
        assert!(
            err.contains("the controller is busy: a program runs; waiting"),
            "{args:?} said:\n{err}"
        );
        assert!(err.contains("the controller answers again"), "{err}");
        if args[0] == "poll" {
            assert!(
                text(&out.stdout).contains(&format!("X={}", program * run)),
                "samples after the program:\n{}",
                text(&out.stdout)
            );
        }
        let session = session_traffic(&mut sim, before.len());
        let session = session.as_str();
        assert_eq!(
            stops_and_motion("isel", session),
            Vec::<String>::new(),
            "{args:?} sent stops or motion:\n{session}"
        );
        assert_eq!(x_steps("isel", &end), program * run, "{end}");
    }
    sim.assert_alive();
}

/// Write `text` as `name` in the simulator's directory; its path.
fn program_file(sim: &SimProcess, name: &str, text: &str) -> String {
    let path = sim.dir.path().join(name);
    std::fs::write(&path, text).expect("write the program");
    path.display().to_string()
}

/// Issue 24, item 1: `jogterm upload --start` of an isel program whose first
/// line is the CNC reference run `7 7` (manual 3.2.8) on a controller that
/// is not referenced starts, references and runs to its end. A program
/// that moves before its reference run is still refused, and the refusal
/// names the command line's remedy, not the console's key. Before: both
/// refused with "reference them (h) first".
#[test]
fn isel_upload_start_of_a_program_that_references_itself_runs_unreferenced() {
    // Not referenced, 1 mm from the reference point, ten times faster than
    // real time: the program's own reference run and move end at the same
    // counts, and the messages are the same.
    let mut sim = SimProcess::options("isel")
        .files(&[ISEL_NEAR_REFERENCE])
        .time_scale(LOGIC_SCALE)
        .start();
    let ok = program_file(
        &sim,
        "references.cnc",
        "; references its axes first\n7 7\n0 4000,3000,0,3000,0,3000,0,3000\n9\n",
    );
    let out = sim.run(&["upload", &ok, "--erase", "--start"]);
    assert_exit(&out, 0, "upload --start of a program beginning with 7 7");
    let err = text(&out.stderr);
    assert!(err.contains("the program ended"), "{err}");
    let state = sim.wait_device("at rest", |d| !moving("isel", d));
    assert_eq!(x_steps("isel", &state), 4000, "{state}");

    // A fresh controller, not referenced: a program that moves first.
    let mut sim = SimProcess::start("isel");
    let moves_first = program_file(
        &sim,
        "moves-first.cnc",
        "0 4000,3000,0,3000,0,3000,0,3000\n7 7\n9\n",
    );
    let out = sim.run(&["upload", &moves_first, "--erase", "--start"]);
    assert_exit(&out, 1, "upload --start of a program that moves first");
    let err = text(&out.stderr);
    let link = sim.link.display().to_string();
    assert!(
        err.contains(&format!(
            "starting the program refused: axes XYZ not referenced: reference them first \
             (jogterm send --port {link} --protocol isel @0R7)"
        )),
        "{err}"
    );
    assert!(!err.contains("(h)"), "the console's key in the CLI:\n{err}");
    let state = sim.device_state();
    assert_eq!(x_steps("isel", &state), 0, "nothing moved: {state}");
    sim.assert_alive();
}

/// The same for an EMCU job that begins with `$H` (manual 1.5.9; `#S`, the
/// reference speed of 1.5.8, may come first): it runs on an interface whose
/// positions are unknown (not referenced).
#[test]
fn emcu_upload_start_of_a_job_that_references_itself_runs_unreferenced() {
    // Not referenced, 5 mm from the reference point, ten times faster than
    // real time: the job's own reference run and move end at the same
    // counts.
    let mut sim = SimProcess::options("emcu")
        .files(&[EMCU_NEAR_REFERENCE])
        .time_scale(LOGIC_SCALE)
        .start();
    let job = program_file(
        &sim,
        "references.emcu",
        "#S2000\n#E1,2000\n$HZYX\nL1,X400\n",
    );
    let out = sim.run(&["upload", &job, "--start"]);
    assert_exit(&out, 0, "upload --start of a job beginning with $HZYX");
    let state = sim.wait_device("at rest", |d| !moving("emcu", d));
    assert_eq!(x_steps("emcu", &state), 400, "{state}");
    let moves_first = program_file(&sim, "moves-first.emcu", "L1,x400\n$HZYX\n");
    let mut fresh = SimProcess::start("emcu");
    let out = fresh.run(&["upload", &moves_first, "--start"]);
    assert_exit(&out, 1, "upload --start of a job that moves first");
    let err = text(&out.stderr);
    assert!(
        err.contains("reference them first (jogterm send --port")
            && err.contains("--protocol emcu '$HZYX\\x01')"),
        "{err}"
    );
    fresh.assert_alive();
    sim.assert_alive();
}
