//! The command line on a closed stdout or stderr (`src/cli/out.rs`): the
//! real binary with its output's reader gone, as `jogterm poll | head -1`
//! leaves it. No panic (status 101) in any command; the ones that hold a
//! port close with their stop (the controller's own record), and every
//! exit status is the one the command's `--help` gives.

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::sim_process;
use crate::stops_support;
use sim_process::{JOGTERM, SimProcess, contains_panic, text, wait_child};
use stops_support::{assert_exit, session_traffic, stops_and_motion};

use crate::faults_support::wire;
use wire::isel_messages;

/// Read the first line of the child's stdout, then drop the reader, as
/// `| head -1` does. The line.
fn take_first_line_and_close(child: &mut Child) -> String {
    take_lines_and_close(child, 1)
}

/// Read `n` lines of the child's stdout, then drop the reader. The lines.
fn take_lines_and_close(child: &mut Child, n: usize) -> String {
    let stdout = child.stdout.take().expect("stdout piped");
    let mut reader = BufReader::new(stdout);
    let mut lines = String::new();
    for _ in 0..n {
        reader.read_line(&mut lines).expect("a line");
    }
    lines
}

/// A pipe whose reader is gone before the process starts: its first write
/// fails with EPIPE (for output too short to be cut after a first line).
fn closed_pipe() -> std::io::PipeWriter {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    writer
}

/// `jogterm poll` with its stdout closed after the first sample: it ends at
/// once, status 0 as for `| head`, no panic, and it sends no stop (a
/// session that moves nothing, `docs/device.md`): the controller received
/// its polls, whole, and nothing else that stops or moves.
fn poll_with_stdout_closed(family: &'static str, args: &[&str], poll: &str) {
    let mut sim = SimProcess::start(family);
    let before = sim.received();
    let mut command = vec!["poll", "--interval-ms", "0"];
    command.extend(args);
    let mut child = sim
        .jogterm(&command)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm poll");
    let first = take_first_line_and_close(&mut child);
    assert!(
        first.contains("X=") || first.contains("\"pos\":["),
        "a sample first: {first}"
    );
    let out = wait_child(child, "jogterm poll with its stdout closed");
    assert_exit(&out, 0, "poll with its stdout closed");
    let polled = session_traffic(&mut sim, before.len());
    assert!(polled.matches(poll).count() >= 1, "it polled:\n{polled}");
    assert_eq!(
        stops_and_motion(family, &polled),
        Vec::<String>::new(),
        "poll stopped or moved:\n{polled}"
    );
    sim.assert_alive();
}

#[test]
fn isel_poll_closes_without_a_stop_when_its_reader_goes_away() {
    poll_with_stdout_closed("isel", &[], "@0P<CR>");
}

#[test]
fn emcu_poll_json_closes_without_a_stop_when_its_reader_goes_away() {
    poll_with_stdout_closed("emcu", &["--json", "--ports"], "@LX<CR>");
}

/// `jogterm poll` at a long interval notices its reader has gone without
/// waiting for the next sample to fail (`cli::out::stdout_gone`): it ends
/// within moments, not at the next sample 15 s later, and sends no stop.
#[test]
fn poll_at_a_long_interval_ends_at_once_when_its_reader_goes_away() {
    let mut sim = SimProcess::start("isel");
    let before = sim.received();
    let mut child = sim
        .jogterm(&["poll", "--interval-ms", "15000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm poll");
    // The read-back's position and the first poll's come at once, the next
    // 15 s later.
    let first = take_lines_and_close(&mut child, 2);
    assert_eq!(first.matches("X=").count(), 2, "two samples first: {first}");
    let closed = Instant::now();
    let out = wait_child(child, "jogterm poll with its stdout closed");
    let took = closed.elapsed();
    assert_exit(&out, 0, "poll with its stdout closed");
    assert!(
        took < Duration::from_secs(5),
        "ended {took:?} after its reader went away"
    );
    let polled = session_traffic(&mut sim, before.len());
    assert_eq!(
        stops_and_motion("isel", &polled),
        Vec::<String>::new(),
        "{polled}"
    );
    sim.assert_alive();
}

/// `jogterm send` of reads with its stdout closed after the first line:
/// nothing more is sent, status 1 with the reason on stderr (its help:
/// "stdout closed or failed"), no panic, and no stop (its lines move
/// nothing, `docs/device.md`): the last query on the wire is whole.
#[test]
fn send_stops_sending_and_closes_when_its_reader_goes_away() {
    const QUERIES: usize = 300;
    let mut sim = SimProcess::start("isel");
    let before = sim.received();
    let mut args = vec!["send", "@07"];
    args.extend(std::iter::repeat_n("@0P", QUERIES));
    let mut child = sim
        .jogterm(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm send");
    let first = take_first_line_and_close(&mut child);
    assert_eq!(first, ">> @07\n");
    let out = wait_child(child, "jogterm send with its stdout closed");
    assert_exit(&out, 1, "send with its stdout closed");
    assert!(
        text(&out.stderr).contains("stdout was closed by its reader: nothing more is sent"),
        "{}",
        text(&out.stderr)
    );
    let received = session_traffic(&mut sim, before.len());
    assert_eq!(
        stops_and_motion("isel", &received),
        Vec::<String>::new(),
        "{received}"
    );
    let sent = isel_messages(&received);
    let queries = sent.iter().filter(|m| *m == "@0P").count();
    assert!(
        queries < QUERIES,
        "all {QUERIES} queries were sent after the reader had gone: {sent:?}"
    );
    sim.assert_alive();
}

/// `jogterm check` of a program with thousands of warnings, read up to its
/// first diagnostic: the summary still comes and the status is the check's
/// (0: warnings only), not a write error's 1.
#[test]
fn check_keeps_its_verdict_when_its_reader_goes_away() {
    // Within the controller's 2000 commands (an error otherwise), and far more
    // than a pipe buffers (64 KiB).
    const LINES: usize = 1500;
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("many-warnings.isel");
    let mut program = String::from("77\n");
    for _ in 0..LINES {
        program.push_str("M1000,900,1000,900,0,900,0,900\n");
    }
    program.push_str("9\n");
    std::fs::write(&path, program).expect("write the program");
    let mut child = Command::new(JOGTERM)
        .arg("check")
        .arg(&path)
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm check");
    let first = take_first_line_and_close(&mut child);
    assert!(first.contains(":2:1: warning: `M`"), "{first}");
    let out = wait_child(child, "jogterm check with its stdout closed");
    assert_exit(&out, 0, "check with its stdout closed");
    assert!(
        text(&out.stderr).contains(&format!("0 errors, {LINES} warnings")),
        "{}",
        text(&out.stderr)
    );
}

/// `jogterm arc` whose stdout's reader has gone before it writes (its two
/// lines fit any pipe's buffer, so they cannot be cut after the first):
/// status 0, the note on stderr, no panic.
#[test]
fn arc_on_a_closed_stdout_exits_0() {
    let child = Command::new(JOGTERM)
        .args([
            "arc", "--radius", "200", "--start", "135", "--end", "225", "--ccw", "--speed", "1500",
        ])
        .stdout(closed_pipe())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm arc");
    let out = wait_child(child, "jogterm arc on a closed stdout");
    assert_exit(&out, 0, "arc on a closed stdout");
    assert!(
        text(&out.stderr).contains("the arc ends"),
        "{}",
        text(&out.stderr)
    );
}

/// `jogterm upload` with stderr gone (its progress and messages): the
/// upload is not aborted, the controller receives the whole program, status
/// 0.
#[test]
fn upload_goes_on_to_its_end_on_a_closed_stderr() {
    let mut sim = SimProcess::start("isel");
    let path = sim.dir.path().join("square.isel");
    let lines = [
        "0400,2000,0,900,0,900,0,900",
        "0400,2000,0,900,0,900,0,900",
        "0-400,2000,0,900,0,900,0,900",
        "0-400,2000,0,900,0,900,0,900",
    ];
    let mut program = String::from("; a square\n77\n");
    for l in lines {
        program.push_str(l);
        program.push('\n');
    }
    program.push_str("9\n");
    std::fs::write(&path, program).expect("write the program");
    let before = sim.received();
    let path_arg = path.display().to_string();
    let child = sim
        .jogterm(&["upload", &path_arg, "--erase"])
        .stdout(Stdio::piped())
        .stderr(closed_pipe())
        .spawn()
        .expect("run jogterm upload");
    let out = wait_child(child, "jogterm upload on a closed stderr");
    assert_eq!(
        out.status.code(),
        Some(0),
        "upload on a closed stderr: {}",
        text(&out.stdout)
    );
    let received = sim.wait_received("the program's end", |r| {
        isel_messages(r.get(before.len()..).unwrap_or_default()).contains(&"9".to_string())
    });
    let sent = isel_messages(&received[before.len()..]);
    let stored: Vec<&String> = sent
        .iter()
        .skip_while(|m| *m != "@0i")
        .skip(1)
        .take_while(|m| *m != "9")
        .collect();
    assert_eq!(stored.len(), lines.len() + 1, "77 and the moves: {sent:?}");
    sim.assert_alive();
}

/// `jogterm sim` whose stdout's reader took the path and went away: the
/// next answer ends it as a closed stdin does, status 0, no panic.
#[test]
fn sim_ends_cleanly_when_its_reader_goes_away() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut child = Command::new(JOGTERM)
        .args(["sim", "--pty", "--protocol", "isel", "--link"])
        .arg(dir.path().join("tty"))
        .env("JOGTERM_CONFIG_DIR", dir.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm sim");
    let first = take_first_line_and_close(&mut child);
    assert!(first.trim_end().ends_with("tty"), "the link first: {first}");
    let mut stdin = child.stdin.take().expect("stdin piped");
    writeln!(stdin, "show").expect("a control line");
    stdin.flush().expect("flush");
    let out = wait_child(child, "jogterm sim with its stdout closed");
    drop(stdin);
    assert_exit(&out, 0, "sim with its stdout closed");
    assert!(!contains_panic(&out.stderr));
}
