//! End to end: `jogterm send` and `jogterm poll` against the real
//! `jogterm sim --protocol isel --pty`, operated on its stdin.

use std::path::Path;
use std::process::Stdio;
use std::thread;
use std::time::Duration;

use crate::sim_process;
use sim_process::{SimProcess, jogterm, text};

/// On a simulator ten times faster than real time: the replies and the
/// position read back are the same at any speed.
#[test]
fn send_initialises_references_moves_and_reads_back() {
    let sim = SimProcess::options("isel")
        .time_scale(sim_process::LOGIC_SCALE)
        .start();
    let out = sim.run(&[
        "send",
        "@07",
        "@0d10000,10000,10000",
        "@0R7",
        "@0A 4000,5000,-400,900,0,900,0,900",
        "@0P",
        "@0b1",
        "@0b3",
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains(">> @0R7\n<< 0 ok\n"), "{stdout}");
    assert!(
        stdout.contains("<< 0 X=4000 Y=-400 Z=0 (steps)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("<< 0 0x03 (00000011): E-stop circuit 1, E-stop circuit 2"),
        "{stdout}"
    );
    assert!(
        stdout.contains(">> @0b3\n<< 0 0x00 (00000000): no input set"),
        "{stdout}"
    );
}

#[test]
fn a_limit_switch_during_a_move_answers_2_and_exits_1() {
    let mut sim = SimProcess::start("isel");
    let child = sim
        .jogterm(&[
            "send",
            "@07",
            "@0N7",
            "@0A 100000,4000,0,900,0,900,0,900",
            "@0P",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("send");
    thread::sleep(Duration::from_millis(1500));
    sim.control("set limit-x2 on");
    let out = child.wait_with_output().expect("send ends");
    let stdout = text(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{stdout}\n{}",
        text(&out.stderr)
    );
    assert!(stdout.ends_with("<< 2\n"), "{stdout}");
    assert!(
        text(&out.stderr).contains("initialise the axes again and run a reference"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_move_stopped_with_a_soft_stop_answers_f() {
    let sim = SimProcess::start("isel");
    let out = sim.run(&[
        "send",
        "@07",
        "@0N7",
        "@0A 100000,4000,0,900,0,900,0,900",
        "0xFD",
    ]);
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains(">> <FD>\n<< F\n"), "{stdout}");
}

#[test]
fn a_stored_program_is_run() {
    let sim = SimProcess::start("isel");
    let out = sim.run(&[
        "send",
        "@07",
        "@0N7",
        "@0k",
        "@0i",
        "0400,2000,0,900,0,900,0,900",
        "133",
        "0-400,2000,0,900,0,900,0,900",
        "9",
        "@0S",
        "@0P",
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(
        stdout.contains(">> @0S\n<< 0 ok (sync characters: !)\n"),
        "{stdout}"
    );
    assert!(stdout.ends_with("<< 0 X=0 Y=0 Z=0 (steps)\n"), "{stdout}");
}

#[test]
fn poll_prints_json_samples() {
    let sim = SimProcess::start("isel");
    let lines = sim.poll_json("5", "20");
    assert_eq!(lines.len(), 5);
    for l in &lines {
        assert_eq!(l["pos"].as_array().map(Vec::len), Some(3), "{l}");
        assert_eq!(l["source"], "measured");
        assert_eq!(l["ports"]["1"], 3, "{l}");
        assert!(l["t"].as_f64().is_some());
    }
}

#[test]
fn a_vanished_port_exits_3() {
    let out = jogterm(
        Path::new("/dev/jogterm-no-such-port"),
        "isel",
        &["send", "@0P"],
    )
    .output()
    .expect("run jogterm");
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("no such port"));
    let mut sim = SimProcess::start("isel");
    let child = sim
        .jogterm(&["send", "@07", "@0N7", "@0A 100000,4000,0,900,0,900,0,900"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("send");
    thread::sleep(Duration::from_millis(1500));
    sim.control("fault close");
    let out = child.wait_with_output().expect("send ends");
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("link failure"));
}

#[test]
fn bad_commands_are_refused_before_anything_is_sent() {
    let dir = tempfile::tempdir().expect("dir");
    let log = dir.path().join("traffic.log");
    let sim = SimProcess::start("isel");
    let out = sim
        .jogterm(&["send", "@0P", "@07", "@0A1,2"])
        .arg("--log")
        .arg(&log)
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("command 3 `@0A1,2`: `A` with XYZ takes 4"),
        "{}",
        text(&out.stderr)
    );
    assert!(out.stdout.is_empty(), "nothing sent");
    assert!(!log.exists() || std::fs::read_to_string(&log).unwrap_or_default().is_empty());
}

#[test]
fn the_log_holds_every_byte_with_a_timestamp() {
    let dir = tempfile::tempdir().expect("dir");
    let log = dir.path().join("traffic.log");
    let sim = SimProcess::start("isel");
    let out = sim
        .jogterm(&["send", "@0b1"])
        .arg("--log")
        .arg(&log)
        .output()
        .expect("run");
    assert!(out.status.success());
    let logged = std::fs::read_to_string(&log).expect("log");
    let traffic: Vec<&str> = logged
        .lines()
        .filter(|l| l.contains(" >> ") || l.contains(" << "))
        .collect();
    // A read moves nothing: no stop at connect or exit (docs/device.md).
    assert!(
        !traffic
            .iter()
            .any(|l| l.contains("<FD>") || l.contains("<FF>")),
        "{logged}"
    );
    assert!(
        traffic.iter().any(|l| l.ends_with(">> @0b1<CR>")),
        "{logged}"
    );
    assert!(traffic.iter().any(|l| l.ends_with("<< 003")), "{logged}");
    assert!(
        traffic
            .iter()
            .all(|l| l.len() > 28 && l.as_bytes()[4] == b'-' && l.as_bytes()[26] == b'Z'),
        "{logged}"
    );
}
