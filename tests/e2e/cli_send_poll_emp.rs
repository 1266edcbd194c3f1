//! End to end for EMP: `jogterm send` and `jogterm poll --protocol emp`
//! against the real `jogterm sim --protocol emp --pty`: switch on, home,
//! move, read the position during a move, read I/O, stop.

use std::process::Stdio;
use std::thread;
use std::time::Duration;

use crate::sim_process;
use sim_process::{SimProcess, text};

#[test]
fn send_switches_on_homes_moves_and_reads_back() {
    let sim = SimProcess::start("emp");
    let out = sim.run(&[
        "send",
        "02 11 11 00 00000000",
        "22 11 07 00 00000000",
        "20 11 19 00 000030D4",
        // Homing out at 127 counts/ms, back off the switch at 32.
        "26 11 00 00 007F2000",
        "2A 11 01 7F 000186A0",
        "2C 11 00 00 00000000",
        "40 11 01 00 00000000",
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(
        stdout.contains(">> 26110000007F2000\n<< started: 11: busy, homing"),
        "{stdout}"
    );
    assert!(stdout.contains("<< completed: "), "{stdout}");
    assert!(
        stdout.contains(">> 2C11000000000000\n<< 11: position 100000"),
        "{stdout}"
    );
}

#[test]
fn positions_are_read_during_a_velocity_move_and_a_stop_holds() {
    let sim = SimProcess::start("emp");
    let out = sim.run(&[
        "send",
        "--drive",
        "11",
        "02 11 00 00000000",
        "22 03 00 00000000",
        "2A 00 40 00000000",
        "2C 00 00 00000000",
        "2C 00 00 00000000",
        "08 00 00 00000000",
    ]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let positions: Vec<&str> = stdout
        .lines()
        .filter(|l| l.starts_with("<< 11: position"))
        .collect();
    assert_eq!(positions.len(), 2, "{stdout}");
    assert_ne!(positions[0], positions[1], "moving: {stdout}");
    assert!(stdout.contains(">> 0811000000000000\n<< 11: "), "{stdout}");
}

#[test]
fn a_rejected_frame_exits_1_with_the_error_meaning() {
    let sim = SimProcess::start("emp");
    // Not switched on yet: the drive answers EE, 0A says why.
    let out = sim.run(&["send", "2A 11 00 05 00000000"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));
    let stderr = text(&out.stderr);
    assert!(stderr.contains("not switched on"), "{stderr}");
}

/// The bug of docs/faults.md: a raw positioning whose drive answers busy
/// and never ready used to wait until Ctrl-C. Now it ends at the deadline of
/// its travel and speed (112 000 counts at 100 counts/ms: 1.1 s, deadline
/// 2.4 s) with the drive stopped and exit status 1.
#[test]
fn a_raw_move_that_stays_busy_ends_at_its_deadline_with_the_drive_stopped() {
    let mut sim = SimProcess::start("emp");
    sim.control("fault stall");
    let started = std::time::Instant::now();
    let out = sim.run(&[
        "send",
        "02 11 11 00 00000000",
        "22 11 07 00 00000000",
        "20 11 19 00 000030D4",
        "2A 11 01 64 0001B580",
        "2C 11 00 00 00000000",
    ]);
    let stdout = text(&out.stdout);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(started.elapsed() < Duration::from_secs(15), "{stderr}");
    assert!(
        stdout.contains(">> 2A1101640001B580\n<< started: 11: busy"),
        "{stdout}"
    );
    assert!(
        stderr.contains("the controller answered `55`: drive 11 (X) stayed busy (55)")
            && stderr.contains("stopped with 08")
            && stderr.contains("initialise (i) and reference (h)"),
        "{stderr}"
    );
    // Nothing after the move was sent but the stop.
    assert!(!stdout.contains(">> 2C11"), "{stdout}");
    let received = sim.received();
    let after = received
        .split("2A1101640001B580<EOF>")
        .nth(1)
        .unwrap_or_default();
    assert!(after.starts_with("0811000000000000<EOF>"), "{received}");
}

#[test]
fn bad_frames_are_refused_before_anything_is_sent() {
    let sim = SimProcess::start("emp");
    let out = sim.run(&["send", "2C 11 00 00 00000000", "2c11000000000000"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("command 2 `2c11000000000000`"),
        "{}",
        text(&out.stderr)
    );
    assert!(out.stdout.is_empty(), "nothing sent");
}

#[test]
fn poll_prints_one_position_per_drive_as_json() {
    let sim = SimProcess::start("emp");
    let on = sim.run(&["send", "02 11 11 00 00000000"]);
    assert!(on.status.success(), "{}", text(&on.stderr));
    let lines = sim.poll_json("20", "0");
    assert_eq!(lines.len(), 20);
    for l in &lines {
        assert_eq!(l["pos"].as_array().map(Vec::len), Some(1), "{l}");
        assert_eq!(l["source"], "measured");
        assert_eq!(l["ports"]["drive11"], 0, "{l}");
    }
    // At line speed (two round trips of 10.45 ms per cycle with --ports):
    // far faster than the 100 ms default interval would give.
    let first = lines[0]["t"].as_f64().unwrap_or(0.0);
    let last = lines[19]["t"].as_f64().unwrap_or(0.0);
    assert!(last - first < 1.5, "{first} .. {last}");
}

#[test]
fn inputs_show_in_poll_and_a_vanished_port_exits_3() {
    let mut sim = SimProcess::start("emp");
    let on = sim.run(&["send", "02 11 11 00 00000000"]);
    assert!(on.status.success(), "{}", text(&on.stderr));
    sim.control("set i2 on");
    let out = sim.run(&["poll", "--count", "3", "--ports"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The raw inputs, then the active ones by the profile's names.
    assert!(
        stdout
            .lines()
            .all(|l| l.ends_with(" drive11=02 active: I2")),
        "{stdout}"
    );
    let child = sim
        .jogterm(&["poll", "--interval-ms", "0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("poll");
    thread::sleep(Duration::from_millis(1000));
    sim.control("fault close");
    let out = child.wait_with_output().expect("poll ends");
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("link failure"));
}

#[test]
fn poll_of_a_drive_that_is_off_gives_up_with_a_hint() {
    let sim = SimProcess::start("emp");
    let started = std::time::Instant::now();
    let out = sim.run(&["poll", "--count", "3", "--interval-ms", "0"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));
    assert!(
        text(&out.stderr).contains("02 11 11 00 00000000"),
        "{}",
        text(&out.stderr)
    );
    assert!(started.elapsed() < Duration::from_secs(10));
}
