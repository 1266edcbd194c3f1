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
use sim_process::{SimProcess, text, wait_child};
use stops_support::{
    assert_exit, isel_store_long_program, moving, session_traffic, signal, stops_and_motion,
    wait_moving, x_steps,
};

fn spawn(sim: &SimProcess, args: &[&str]) -> Child {
    sim.jogterm(args)
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .stdin(Stdio::null())
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
    let mut sim = SimProcess::start("isel");
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
