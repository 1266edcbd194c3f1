//! End to end: `jogterm send --protocol emcu` and `jogterm poll --protocol
//! emcu` against the real `jogterm sim --protocol emcu --pty`, operated on
//! its stdin: reset, initialise, home, move, positions during the move, the
//! `@X` flags, stop, and a port that vanishes mid-move.

use std::process::Stdio;
use std::thread;
use std::time::{Duration, Instant};

use crate::sim_process;
use sim_process::{EMCU_NEAR_REFERENCE, SimProcess, text};

/// `<< @LX1234: X = 1234 steps` -> 1234.
fn x_steps(line: &str) -> Option<i64> {
    line.strip_prefix("<< @LX")?.split(':').next()?.parse().ok()
}

/// Reset, start speed and ramp, a fast reference run.
const READY: [&str; 4] = ["@R", "#S2000", "#R200\\x01", "$HZYX\\x01"];

/// The simulator of a test that references first: 5 mm from the
/// reference point, not 40 (`EMCU_NEAR_REFERENCE`); what the tests check
/// happens after the reference run, or during its first axis.
fn near_reference() -> SimProcess {
    SimProcess::start_with_files("emcu", &[EMCU_NEAR_REFERENCE])
}

#[test]
fn send_resets_homes_moves_reads_during_the_move_and_stops() {
    let sim = near_reference();
    let mut args = vec!["send"];
    args.extend(READY);
    args.extend([
        "@X",
        "#E1,2000",
        "L1,x40000\\x01",
        "@LX",
        "@LX",
        "@X",
        "@B",
        "@X",
    ]);
    let started = Instant::now();
    let out = sim.run(&args);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains(">> @R\n<< @R sent"), "{stdout}");
    // Queries go at once, also during the reference run.
    assert!(
        stdout.contains(">> $HZYX<01>\n<< CR: running\n>> @X\n<< @X100110: moving, position unknown, referencing"),
        "{stdout}"
    );
    assert!(
        stdout.contains(">> L1,x40000<01>\n<< CR: running\n"),
        "{stdout}"
    );
    // Read during the move: between 0 and the target, rising.
    let xs: Vec<i64> = stdout.lines().filter_map(x_steps).collect();
    assert_eq!(xs.len(), 2, "{stdout}");
    assert!(xs[0] < xs[1] && xs[1] < 40_000, "{xs:?}");
    assert!(
        stdout.contains("<< @X100001: moving, job running"),
        "{stdout}"
    );
    assert!(stdout.contains(">> @B\n<< @B sent"), "{stdout}");
    // The move was halted: 40 000 steps at 2 kHz would take 20 s.
    assert!(started.elapsed() < Duration::from_secs(15), "{stdout}");
}

#[test]
fn a_batch_runs_to_its_end_before_the_command_ends() {
    let sim = near_reference();
    let mut args = vec!["send"];
    args.extend(READY);
    args.extend(["#E1,2000", "L1,x1000,y500\\x01", "@LX", "L1,x-200\\x01"]);
    let out = sim.run(&args);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let out = sim.run(&["send", "@LX", "@LY", "@X"]);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(stdout.contains("<< @LX800: X = 800 steps"), "{stdout}");
    assert!(stdout.contains("<< @LY500: Y = 500 steps"), "{stdout}");
    assert!(stdout.contains("<< @X000000: idle"), "{stdout}");
}

#[test]
fn outputs_and_the_job_store() {
    let mut sim = near_reference();
    let mut args = vec!["send"];
    args.extend(READY);
    args.extend(["@F", "#E1,2000", "L1,x300\\x01", "@J", "@LX", "A1,1\\x01"]);
    let out = sim.run(&args);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(
        stdout.contains(">> L1,x300<01>\n<< CR: the job is stored (2 lines; @J runs it)"),
        "{stdout}"
    );
    let described = sim.device_state();
    assert!(described.contains("X 300"), "{described}");
    assert!(described.contains("A1 on"), "{described}");
}

#[test]
fn poll_prints_measured_positions_and_the_status() {
    let sim = SimProcess::start("emcu");
    let lines = sim.poll_json("5", "0");
    assert_eq!(lines.len(), 5);
    for l in &lines {
        assert_eq!(l["pos"].as_array().map(Vec::len), Some(3), "{l}");
        assert_eq!(l["source"], "measured");
        // Power-up: position unknown.
        assert_eq!(l["ports"]["status"], 8, "{l}");
    }
}

#[test]
fn bad_lines_are_refused_before_anything_is_sent() {
    let sim = SimProcess::start("emcu");
    let out = sim.run(&["send", "@X", "L1,q5\\x01"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("command 2 `L1,q5\\x01`"),
        "{}",
        text(&out.stderr)
    );
    assert!(out.stdout.is_empty(), "nothing sent");
}

#[test]
fn a_port_that_vanishes_mid_move_exits_3() {
    let mut sim = near_reference();
    let mut args = vec!["send"];
    args.extend(READY);
    args.extend(["#E1,1000", "L1,x40000\\x01"]);
    let child = sim
        .jogterm(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("send");
    // Wait until the move runs.
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let d = sim.device_state();
        if d.contains("moving") && !d.contains("referencing") && !d.contains("position unknown") {
            break;
        }
        assert!(Instant::now() < deadline, "no move: {d}");
        thread::sleep(Duration::from_millis(100));
    }
    sim.control("fault close 500");
    let out = child.wait_with_output().expect("send ends");
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("link failure"));
    // The line is back; the operator's `@B` halts the move (a read would
    // stop nothing, docs/device.md, "Sessions that do not move").
    thread::sleep(Duration::from_millis(800));
    let out = sim.run(&["send", "@B"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    thread::sleep(Duration::from_millis(1_500));
    let d = sim.device_state();
    assert!(!d.contains("moving"), "{d}");
}
