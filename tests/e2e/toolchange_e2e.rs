//! End to end: a job with two tools (`M6 T1`, `M6 T2`) run by the real
//! `jogterm run` against `jogterm sim --pty` with a probe surface, the
//! tool sensor on it (`docs/gcode.md`, "Tool changes"). Stored (three
//! pieces: the change before T1, T1's cut, T2's cut) and streamed: at each
//! change the job waits at the change position with the spindle off until
//! a line comes on standard input (`--yes` skips no wait), the new tool is
//! measured, and after the simulator's tool was made 1 mm longer (`value
//! tool 400`) every cut after the change runs 1 mm higher in machine Z.

use std::io::Write as _;
use std::process::Stdio;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use crate::gcode_e2e::wait_run;
use crate::sim_process::{SimProcess, contains_panic, spawn_with_lines, text};

/// 400 steps/mm; G54's zero at machine X50 Y50 Z60 mm.
pub(crate) const WORK_ZERO: &str = "X50 Y50 Z60";

/// A faster machine, the tool sensor under X25 Y0 (the point above it at
/// Z27.5 mm), the change position X25 Y0 Z40 (machine mm).
const MACHINE: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n\
     [probe]\ntool_sensor = \"X25 Y0 Z27.5\"\n[tools]\nchange_at = \"X25 Y0 Z40\"\n",
);

/// The work piece and the sensor: a flat plane at Z 8000 steps (20 mm).
const SURFACE: &str = "--probe-surface=8000";

/// T1 cuts along Y10 from X10 to X20 at Z-1 (lines 7-8), T2 from X30 to
/// X40 (lines 14-15).
pub(crate) const JOB: &str = "(T1 D=6 CR=0 - ZMIN=-1 - flat end mill)\n\
(T2 D=3.175 CR=0 - ZMIN=-1 - ball end mill)\n\
G21 G90 G17\n\
M6 T1\n\
M3 S10000\n\
G0 Z5\n\
G0 X10 Y10\nG1 Z-1 F300\nG1 X20 F600\nG0 Z5\n\
M5\n\
M6 T2\n\
M3 S12000\n\
G0 X30 Y10\nG1 Z-1 F300\nG1 X40 F600\nG0 Z5\n\
M30\n";

const SCALE: f64 = 20.0;

fn sim() -> SimProcess {
    let sim = SimProcess::options("isel")
        .files(&[MACHINE])
        .args(&[SURFACE])
        .time_scale(SCALE)
        .start();
    let reference = sim.run(&["send", "@07", "@0R7"]);
    assert!(reference.status.success(), "{}", text(&reference.stderr));
    sim
}

fn job_file(sim: &SimProcess) -> String {
    let path = sim.dir.path().join("two-tools.nc");
    std::fs::write(&path, JOB).expect("write the job");
    path.display().to_string()
}

/// The next JSON event on `lines` for which `pick` holds, within 60 s.
fn event(lines: &Receiver<String>, pick: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
    let end = Instant::now() + Duration::from_secs(60);
    loop {
        let left = end.saturating_duration_since(Instant::now());
        let line = lines
            .recv_timeout(left)
            .unwrap_or_else(|e| panic!("no such event within 60 s: {e}"));
        let Ok(value) = serde_json::from_str::<serde_json::Value>(&line) else {
            continue;
        };
        if pick(&value) {
            return value;
        }
    }
}

fn is(kind: &'static str) -> impl Fn(&serde_json::Value) -> bool {
    move |v| v["event"] == kind
}

/// The X, Y and Z steps of every absolute move the controller received,
/// stored (`m…`) or sent (`@0M…`), in order.
pub(crate) fn moves(received: &str) -> Vec<[i64; 3]> {
    received
        .split("<CR>")
        .filter_map(|c| {
            let c = c.trim_start_matches("@0i");
            let rest = c.strip_prefix("@0M").or_else(|| c.strip_prefix('m'))?;
            let n: Vec<i64> = rest.split(',').filter_map(|v| v.parse().ok()).collect();
            Some([*n.first()?, *n.get(2)?, *n.get(4)?])
        })
        .collect()
}

/// Runs the job (`way`: extra options of `run`) to its end, confirming each
/// wait with a line on stdin, the tool 1 mm longer from the second change
/// on; the events, and the moves the controller received.
fn two_tools(extra: &[&str]) -> (Vec<serde_json::Value>, Vec<[i64; 3]>, String) {
    let mut sim = sim();
    let file = job_file(&sim);
    let state = tempfile::tempdir().expect("state dir");
    let mut args = vec!["run", &file, "--work-zero", WORK_ZERO, "--yes", "--json"];
    args.extend_from_slice(extra);
    let before = sim.received().len();
    let mut command = sim.configured(&args);
    command
        .env("JOGTERM_STATE_DIR", state.path())
        .stderr(Stdio::piped());
    let (child, mut stdin, lines) = spawn_with_lines(&mut command);
    let mut events = Vec::new();
    // T1: the first change, before any move. Waiting, nothing goes on
    // until the line: two seconds later it still waits at the change
    // position (X25 Y0 Z40: 10000, 0, 16000 steps).
    let wait = event(&lines, is("wait"));
    assert_eq!(wait["line"], 4, "{wait}");
    assert_eq!(wait["tool"], "T1", "{wait}");
    assert!(
        wait["what"]
            .as_str()
            .is_some_and(|w| w.contains("flat end mill, D=6")),
        "{wait}"
    );
    std::thread::sleep(Duration::from_secs(2));
    let state_line = sim.device_state();
    assert!(
        state_line.starts_with("device: X 10000 Y 0 Z 16000 "),
        "waits at the change position: {state_line}"
    );
    events.push(wait);
    writeln!(stdin).expect("confirm T1");
    events.push(event(&lines, is("wait_ended")));
    events.push(event(&lines, is("tool_measured")));
    // T2: the operator puts in a tool 1 mm (400 steps) longer.
    let wait = event(&lines, is("wait"));
    assert_eq!(wait["line"], 12, "{wait}");
    events.push(wait);
    sim.control("value tool 400");
    writeln!(stdin).expect("confirm T2");
    events.push(event(&lines, is("wait_ended")));
    events.push(event(&lines, is("tool_measured")));
    let out = wait_run(child, "run");
    let said = text(&out.stderr);
    assert!(!contains_panic(&out.stderr), "{said}");
    assert_eq!(out.status.code(), Some(0), "{said}");
    // The job log followed the pieces: done, its last line after T2's.
    let log = sim
        .configured(&["log", "--json"])
        .env("JOGTERM_STATE_DIR", state.path())
        .output()
        .expect("jogterm log");
    let log: serde_json::Value = serde_json::from_slice(&log.stdout).expect("the log as JSON");
    let run = &log["runs"][0];
    assert_eq!(run["how"], "done", "{log:#}");
    assert!(
        run["last_line"].as_u64().is_some_and(|l| l > 12),
        "the last line after the second change: {log:#}"
    );
    let received = sim.received();
    let moves = moves(received.get(before..).unwrap_or_default());
    (events, moves, said)
}

fn check_cuts(events: &[serde_json::Value], moves: &[[i64; 3]], said: &str) {
    let offsets: Vec<f64> = events
        .iter()
        .filter(|e| e["event"] == "tool_measured")
        .map(|e| e["offset_mm"].as_f64().expect("offset"))
        .collect();
    assert_eq!(offsets.len(), 2, "{events:?}");
    assert!(offsets[0].abs() < 1e-9, "T1 is the reference: {events:?}");
    assert!(
        (offsets[1] - 1.0).abs() <= 0.0025 + 1e-9,
        "T2 one millimetre longer, within a step: {events:?}"
    );
    assert!(
        events
            .iter()
            .filter(|e| e["event"] == "wait_ended")
            .all(|e| e["by"] == "operator"),
        "{events:?}"
    );
    // T1's cut ends at X20 Y10 Z-1: machine 70, 60, 59 mm.
    assert!(
        moves.contains(&[28_000, 24_000, 23_600]),
        "T1 cuts at Z 59 mm: {moves:?}\n{said}"
    );
    // T2's, measured 1 mm longer (within a step), 1 mm higher: X90 Y60 Z60.
    let t2 = moves
        .iter()
        .find(|m| m[0] == 36_000 && m[1] == 24_000)
        .unwrap_or_else(|| panic!("no cut to X40: {moves:?}\n{said}"));
    assert!(
        (t2[2] - 24_000).abs() <= 1,
        "T2 cuts 1 mm higher, at Z 60 mm: {t2:?}\n{said}"
    );
    // Nothing of T2's cut at T1's depth.
    assert!(!moves.contains(&[36_000, 24_000, 23_600]), "{moves:?}");
}

#[test]
fn a_two_tool_job_stored_waits_at_each_change_and_cuts_the_longer_tool_higher() {
    let (events, moves, said) = two_tools(&[]);
    check_cuts(&events, &moves, &said);
    assert!(
        said.contains("piece 3/3"),
        "three pieces, one per tool: {said}"
    );
    // Each piece says the model's time left and the waits to come, which
    // it does not guess.
    for (piece, waits) in [
        ("piece 1/3", " and 2 waits"),
        ("piece 2/3", " and 1 wait"),
        ("piece 3/3", " left"),
    ] {
        assert!(
            said.lines()
                .any(|l| l.starts_with(piece) && l.contains(", about ") && l.ends_with(waits)),
            "{piece} with the time left: {said}"
        );
    }
    // The summary before the start lists the changes with their lines.
    assert!(
        said.contains("two-tools.nc:line 4: M6: change to tool T1 flat end mill, D=6"),
        "{said}"
    );
    assert!(
        said.contains("two-tools.nc:line 12: M6: change to tool T2 ball end mill, D=3.175"),
        "{said}"
    );
}

#[test]
fn a_two_tool_job_streamed_waits_in_place_and_cuts_the_longer_tool_higher() {
    let (events, moves, said) = two_tools(&["--stream"]);
    check_cuts(&events, &moves, &said);
    // Three streams, one per piece, the host waiting between them.
    assert_eq!(said.matches("the stream ended").count(), 3, "{said}");
    // Each piece's progress says the model's time left (`gcode::eta`).
    assert!(said.contains("left at speed 100 %"), "{said}");
}

/// `--yes` starts without asking, but skips no wait: with no line to come
/// on standard input the run stops at the first tool change, exit 1,
/// with the spindle off and nothing of the cut sent.
#[test]
fn yes_skips_no_wait_and_a_closed_input_stops_at_the_change() {
    let mut sim = sim();
    let file = job_file(&sim);
    let state = tempfile::tempdir().expect("state dir");
    let before = sim.received().len();
    // Bounded: a run that waited for the start key instead would never end.
    let mut command = sim.configured(&["run", &file, "--work-zero", WORK_ZERO, "--yes"]);
    let child = command
        .env("JOGTERM_STATE_DIR", state.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run");
    let out = wait_run(child, "run at a closed input");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(
        said.contains("two-tools.nc:4: waiting: M6: change to tool T1"),
        "{said}"
    );
    assert!(said.contains("stopped at the wait of line 4"), "{said}");
    let received = sim.received();
    let moves = moves(received.get(before..).unwrap_or_default());
    assert!(
        !moves.iter().any(|m| m[2] == 23_600),
        "nothing of the cut: {moves:?}"
    );
}

#[test]
fn the_import_summary_lists_every_tool_change_and_pause_with_its_line() {
    let sim = SimProcess::options("isel").files(&[MACHINE]).start();
    let file = job_file(&sim);
    let path = sim.dir.path().join("with-pause.nc");
    std::fs::write(&path, JOB.replace("M5\n", "M5\nM0\n")).expect("write");
    for (file, pauses) in [(file, 2), (path.display().to_string(), 3)] {
        let out = sim
            .configured(&["import", &file, "--work-zero", WORK_ZERO])
            .output()
            .expect("import");
        let summary = text(&out.stdout);
        assert!(out.status.success(), "{summary}{}", text(&out.stderr));
        assert!(
            summary.contains(&format!("tool changes and pauses: {pauses}")),
            "{summary}"
        );
        assert!(
            summary.contains(
                "line 4: M6: change to tool T1 flat end mill, D=6 (the spindle off, waits at machine X 25.000 Y 0.000 Z 40.000)"
            ),
            "{summary}"
        );
        if pauses == 3 {
            assert!(summary.contains("line 12: M0: program pause"), "{summary}");
        }
    }
}

/// Issue 39 (4): the offset `jogterm probe tool` measured for the tool in
/// the spindle shifts every Z of a job. T1 measured (the reference), then
/// a tool 1 mm longer in the spindle measured as T2: the import says the
/// offset and `run` of a job without a tool change cuts 1 mm higher.
#[test]
fn the_measured_offset_of_the_tool_in_the_spindle_shifts_every_z_of_a_job() {
    let mut sim = sim();
    let state = tempfile::tempdir().expect("state dir");
    let measure = |sim: &SimProcess, tool: &str| {
        let out = sim
            .configured(&["probe", "tool", "--tool", tool, "--json"])
            .env("JOGTERM_STATE_DIR", state.path())
            .output()
            .expect("probe tool");
        assert!(out.status.success(), "{}", text(&out.stderr));
    };
    measure(&sim, "T1");
    sim.control("value tool 400");
    measure(&sim, "T2");
    let path = sim.dir.path().join("one-tool.nc");
    std::fs::write(
        &path,
        "G21 G90\nG0 Z5\nG0 X10 Y10\nG1 Z-1 F300\nG1 X20 F600\nG0 Z5\nM30\n",
    )
    .expect("write");
    let file = path.display().to_string();
    let out = sim
        .configured(&["import", &file, "--work-zero", WORK_ZERO, "--json"])
        .env("JOGTERM_STATE_DIR", state.path())
        .output()
        .expect("import");
    let summary: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("the summary as JSON");
    assert_eq!(summary["tool_offset"]["tool"], "T2", "{summary}");
    let offset = summary["tool_offset"]["offset_mm"]
        .as_f64()
        .expect("offset");
    assert!((offset - 1.0).abs() <= 0.0025 + 1e-9, "{summary}");
    let before = sim.received().len();
    let mut command = sim.configured(&["run", &file, "--work-zero", WORK_ZERO, "--yes"]);
    let child = command
        .env("JOGTERM_STATE_DIR", state.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run");
    let out = wait_run(child, "run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("tool offset T2 +1.0"), "{said}");
    let received = sim.received();
    let moves = moves(received.get(before..).unwrap_or_default());
    // The cut to X20 Y10 Z-1: machine 70, 60 and 59 + 1 mm.
    let cut = moves
        .iter()
        .find(|m| m[0] == 28_000 && m[1] == 24_000 && m[2] < 25_000)
        .unwrap_or_else(|| panic!("no cut to X20: {moves:?}\n{said}"));
    assert!((cut[2] - 24_000).abs() <= 1, "1 mm higher: {cut:?}\n{said}");
}
