//! Issue 37: what a session is allowed on a line and how long it may wait,
//! against the real `jogterm sim --pty`: sessions that only read send
//! reads alone (isel, EMCU, EMP, byte by byte as the controller received
//! them); a baud rate no line runs at is refused where it is written; an
//! isel that never answers is given up after the profile's bound, and
//! Ctrl-C ends the wait at once; a line that streams bytes ends `send` with
//! a clear error on every family.

use std::io::Write;
use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::faults_support::wire;
use crate::quiet_sessions::spawn;
use crate::sim_process::{SimProcess, contains_panic, text, wait_child};
use crate::stops_support::{assert_exit, session_traffic, signal};

/// Write the profile `name` (on top of the family's shipped one) with the
/// lines `body` into the simulator's configuration directory; its path.
fn write_profile(sim: &SimProcess, name: &str, body: &str) -> String {
    let dir = sim.dir.path().join("profiles");
    std::fs::create_dir_all(&dir).expect("profiles dir");
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, format!("base = \"{}\"\n{body}", sim.family)).expect("profile");
    path.display().to_string()
}

/// Item 8: `[connection] baud = 0` is refused at its line (file:line, status
/// 2) and `--baud 1` with what is expected, before a port is opened; the
/// controller received nothing. Before: both were taken, and `send` waited
/// for ever (here: killed after `sim_process::WAIT`).
#[test]
fn a_baud_rate_no_line_runs_at_is_refused_where_it_is_written() {
    let mut sim = SimProcess::start("isel");
    let before = sim.received();
    let path = write_profile(&sim, "still", "\n[connection]\nbaud = 0\n");
    let out = wait_child(
        spawn(&sim, &["send", "--profile", "still", "@0P"]),
        "send with baud = 0",
    );
    assert_exit(&out, 2, "send with baud = 0");
    let err = text(&out.stderr);
    assert!(err.contains(&format!("{path}:4")), "file and line: {err}");
    assert!(
        err.contains("expected 300 to 4000000 baud"),
        "what is expected: {err}"
    );
    for args in [
        &["send", "--baud", "1", "@0P"][..],
        &["poll", "--baud", "0", "--count", "1"][..],
    ] {
        let out = wait_child(spawn(&sim, args), &format!("{args:?}"));
        assert_exit(&out, 2, &format!("{args:?}"));
        let err = text(&out.stderr);
        assert!(
            err.contains(&format!(
                "jogterm {}: --baud {}: expected 300 to 4000000 baud",
                args[0], args[2]
            )),
            "{args:?}: {err}"
        );
    }
    assert_eq!(sim.received(), before, "nothing reached the controller");
    sim.assert_alive();
}

/// The reads each family's sessions may send of their own: isel `@0P` and
/// the input ports `@0b0`-`@0b3` (manual 2.2.21, 2.2.3); EMCU `@X`, `@LX`,
/// `@LY`, `@LZ` (manual 1.5.3); EMP `0A` (last error), `2C` (position),
/// `40` (inputs). Everything else the controller received from `session`.
fn not_reads(family: &str, session: &str) -> Vec<String> {
    let messages = match family {
        "emp" => wire::emp_frames(session),
        _ => wire::isel_messages(session),
    };
    messages
        .into_iter()
        .filter(|m| match family {
            "isel" => !matches!(m.as_str(), "@0P" | "@0b0" | "@0b1" | "@0b2" | "@0b3"),
            "emcu" => !matches!(m.as_str(), "@X" | "@LX" | "@LY" | "@LZ"),
            _ => !["0A", "2C", "40"].iter().any(|c| m.starts_with(c)),
        })
        .collect()
}

/// Wait until the controller received `n` more messages after `from`.
fn wait_messages(sim: &mut SimProcess, from: usize, n: usize) {
    let end = if sim.family == "emp" { "<EOF>" } else { "<CR>" };
    sim.wait_received("the session's reads", |r| {
        r.get(from..).is_some_and(|t| t.matches(end).count() >= n)
    });
}

/// `watch`, `poll`, `send` of a read and `commission` (ended with `q`)
/// against a controller `prepare` set up: each sent nothing but reads.
fn sessions_send_only_reads(family: &'static str, prepare: &[&str], read: &str) {
    let mut sim = SimProcess::start(family);
    if !prepare.is_empty() {
        let mut args = vec!["send"];
        args.extend_from_slice(prepare);
        let out = sim.run(&args);
        assert_exit(&out, 0, &format!("{args:?}"));
    }
    let report = sim.dir.path().join("report").display().to_string();
    let sessions: [&[&str]; 4] = [
        &["watch"],
        &["poll", "--count", "3"],
        &["send", read],
        &["commission", "--report", &report],
    ];
    for args in sessions {
        let from = sim.received().len();
        match args[0] {
            "watch" => {
                let child = spawn(&sim, args);
                wait_messages(&mut sim, from, 12);
                signal(child.id(), libc::SIGINT);
                assert_exit(&wait_child(child, "watch"), 0, "watch interrupted");
            }
            "commission" => {
                let mut child = sim
                    .configured(args)
                    .stdin(Stdio::piped())
                    .stdout(Stdio::piped())
                    .stderr(Stdio::piped())
                    .spawn()
                    .expect("run jogterm");
                // The read-back at least (EMP: three frames).
                wait_messages(&mut sim, from, 3);
                let mut stdin = child.stdin.take().expect("stdin");
                // A walk-test with nothing to walk may have ended already.
                let _ = stdin.write_all(b"q\n");
                drop(stdin);
                let out = wait_child(child, "commission");
                assert!(!contains_panic(&out.stderr), "{}", text(&out.stderr));
            }
            _ => assert_exit(&wait_child(spawn(&sim, args), args[0]), 0, args[0]),
        }
        let session = session_traffic(&mut sim, from);
        assert!(!session.is_empty(), "{args:?} read nothing");
        assert_eq!(
            not_reads(family, &session),
            Vec::<String>::new(),
            "{args:?} sent more than reads:\n{session}"
        );
    }
    sim.assert_alive();
}

/// Item 5, isel: on a controller initialised and referenced (`@07`,
/// `@0N7`), the read sessions send `@0P` and `@0b<n>` and nothing else.
/// Before: each sent `@0T0`, the zero-step probe `@0A0,300,0,300,…` and the
/// profile's `@0j300`, `@0J100`, `@0d4000,4000,4000`.
#[test]
fn isel_sessions_that_read_send_only_reads() {
    sessions_send_only_reads("isel", &["@07", "@0N7"], "@0P");
}

/// Item 5, EMCU: the read-back was reads already (`@X`, `@LX`, `@LY`,
/// `@LZ`); this keeps it so.
#[test]
fn emcu_sessions_that_read_send_only_reads() {
    sessions_send_only_reads("emcu", &[], "@LX");
}

/// Item 5, EMP: on a drive switched on (`02`), the read sessions send `0A`,
/// `2C` and `40` frames alone (reads already before; this keeps it so).
#[test]
fn emp_sessions_that_read_send_only_reads() {
    sessions_send_only_reads("emp", &["02 11 11 00 00000000"], "2C 11 00 00 00000000");
}

/// Item 9: an isel that answers nothing (its replies held back 10 minutes,
/// `fault delay`): `send @0P` and `poll` say that the controller is busy and
/// how long they have waited, and give up after the profile's
/// `isel.busy_wait_s` (3 s here) with a link failure, status 3. Before:
/// both waited for ever (killed after `sim_process::WAIT`).
#[test]
fn an_isel_that_never_answers_is_given_up_after_the_profiles_bound() {
    let mut sim = SimProcess::start("isel");
    write_profile(&sim, "patient", "\n[isel]\nbusy_wait_s = 3\n");
    sim.control("fault delay 600000");
    for args in [
        &["send", "--profile", "patient", "@0P"][..],
        &["poll", "--profile", "patient"][..],
    ] {
        let started = Instant::now();
        let out = wait_child(spawn(&sim, args), &format!("{args:?}"));
        let took = started.elapsed();
        assert_exit(&out, 3, &format!("{args:?}"));
        let err = text(&out.stderr);
        assert!(
            err.contains("the controller is busy: a program runs; waiting (no reply to @0P"),
            "{args:?}: {err}"
        );
        assert!(
            err.contains("s so far, giving up after 3 s (isel.busy_wait_s)"),
            "how long it waited: {err}"
        );
        assert!(
            err.contains(&format!(
                "jogterm {}: link failure: no reply to @0P for 3.",
                args[0]
            )),
            "{err}"
        );
        assert!(
            took >= Duration::from_secs(3) && took < Duration::from_secs(10),
            "{args:?} took {took:?}"
        );
    }
    sim.assert_alive();
}

/// Item 9: Ctrl-C ends the wait for a silent isel at once, with the
/// default bound (10 minutes): `poll` with status 0, `send` with 1.
#[test]
fn ctrl_c_ends_the_wait_for_a_silent_isel_at_once() {
    let mut sim = SimProcess::start("isel");
    sim.control("fault delay 600000");
    for (args, code) in [(&["poll"][..], 0), (&["send", "@0P"][..], 1)] {
        let from = sim.received().len();
        let child = spawn(&sim, args);
        // The first read and its repeat: the session waits.
        wait_messages(&mut sim, from, 2);
        let signalled = Instant::now();
        signal(child.id(), libc::SIGINT);
        let out = wait_child(child, args[0]);
        let took = signalled.elapsed();
        assert_exit(&out, code, &format!("{args:?} interrupted"));
        assert!(
            text(&out.stderr).contains("the controller is busy"),
            "{}",
            text(&out.stderr)
        );
        assert!(
            took < Duration::from_secs(1),
            "{args:?} ended {took:?} after Ctrl-C"
        );
    }
    sim.assert_alive();
}

/// Item 9: the controller's first reply replaced by 8 s of bytes at line
/// speed that answer nothing (`fault stream`): `send` of a read ends with a
/// link failure that says so, status 3, on every family. Before: it waited
/// without a word until the stream ended.
#[test]
fn a_line_that_streams_bytes_ends_send_with_a_clear_error() {
    for (family, read, stream) in [
        ("isel", "@0P", 16_000),
        ("emcu", "@LX", 16_000),
        ("emp", "2C 11 00 00 00000000", 32_000),
    ] {
        let mut sim = SimProcess::start(family);
        sim.control(&format!("fault stream {stream}"));
        let started = Instant::now();
        let out = wait_child(spawn(&sim, &["send", read]), family);
        let took = started.elapsed();
        assert_exit(&out, 3, family);
        let err = text(&out.stderr);
        assert!(
            err.contains("jogterm send: link failure: the line streams bytes that answer nothing"),
            "{family}: {err}"
        );
        assert!(took < Duration::from_secs(6), "{family}: took {took:?}");
        sim.assert_alive();
    }
}
