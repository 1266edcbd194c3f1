//! End to end: the console runs a job with two tools (`M6 T1`, `M6 T2`)
//! itself (issue 40, 3; `docs/editor.md`, "Tool changes and pauses"): the
//! real binary in a pseudo-terminal against `jogterm sim --pty`. F6 asks
//! with every wait; each piece is stored and run; at each change the
//! stored piece is erased (`@0k`) and the console waits at the change
//! position, saying what for, until F6; then the new tool is measured on
//! the simulator's tool sensor (`--probe-surface`), as `jogterm run` does
//! (`toolchange_e2e`): T2, made 1 mm longer on the simulator (`value tool
//! 400`), cuts 1 mm higher in machine Z, and the tool table in the state
//! directory keeps both. Run at 40x200, 80x24 and 160x48: each wait's
//! words and key are waited for whole on the screen at every size.

use crate::console_pty::{self, wait_for};
use crate::editor_e2e;
use crate::sim_process::SimProcess;
// The two-tool job `jogterm run` runs: T1 cuts along Y10 from X10 to X20 at
// Z-1, T2 from X30 to X40; G54's zero at machine X50 Y50 Z60 mm.
use crate::toolchange_e2e::{JOB, WORK_ZERO, moves};

use std::time::{Duration, Instant};

/// A faster machine, the change position X25 Y0 Z40 (machine mm), the
/// tool sensor under X25 Y0 (the point above it at Z27.5 mm).
const MACHINE: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n\
     [isel]\nreference_speed_hz = 12000\n\
     [probe]\ntool_sensor = \"X25 Y0 Z27.5\"\n[tools]\nchange_at = \"X25 Y0 Z40\"\n",
);

/// F6 at the wait until the job goes on: once the erase has answered
/// and the position at the wait is read the console takes it, and the
/// wait's words (`waiting`) leave the status line. One F6 at a time, each
/// after the last was seen to do nothing: a second one would answer the
/// next wait.
fn confirm(run: &mut crate::ui_pty::PtyRun, waiting: &str) {
    let end = Instant::now() + Duration::from_secs(30);
    loop {
        std::thread::sleep(Duration::from_millis(700));
        run.type_keys(&[b"\x1b[17~"]);
        let gone = Instant::now() + Duration::from_secs(2);
        while Instant::now() < gone {
            if !run.screen().screen().contents().contains(waiting) {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        assert!(
            Instant::now() < end,
            "F6 never went on:\n{}",
            run.screen().screen().contents()
        );
    }
}

#[test]
fn the_console_waits_at_each_tool_change_until_f6_and_runs_the_pieces() {
    two_tools_at((40, 200), Way::Stored);
}

/// The same at 80x24: the wait and its key read whole on the status line.
#[test]
fn at_80x24_every_wait_reads_whole_with_its_key() {
    two_tools_at((24, 80), Way::Stored);
}

/// The same at 160x48.
#[test]
fn at_160x48_every_wait_reads_whole_with_its_key() {
    two_tools_at((48, 160), Way::Stored);
}

/// On a controller that stores 3 commands no piece fits or can be cut:
/// each streams, and waits, measures and cuts as when stored.
#[test]
fn on_a_controller_too_small_for_a_piece_each_piece_streams() {
    two_tools_at((24, 80), Way::Streamed);
}

/// How the pieces run.
#[derive(Clone, Copy, PartialEq)]
enum Way {
    Stored,
    Streamed,
}

/// The two-tool job run from the console in a terminal of `size` (rows,
/// columns): each wait shown whole with the key that ends it, F6 going on,
/// the job ending done in the log.
fn two_tools_at(size: (u16, u16), way: Way) {
    let profile = match way {
        Way::Stored => MACHINE.1.to_owned(),
        Way::Streamed => format!("{}[gcode]\nmemory = 3\n", MACHINE.1),
    };
    let files = [(MACHINE.0, profile.as_str())];
    // The work piece and the sensor: a flat plane at Z 8000 steps (20 mm).
    let mut sim = SimProcess::options("isel")
        .files(&files)
        .args(&["--probe-surface=8000"])
        .time_scale(20.0)
        .start();
    let state = tempfile::tempdir().expect("state dir");
    let job = sim.dir.path().join("two-tools.nc");
    std::fs::write(&job, JOB).expect("write the job");
    let link = sim.link.display().to_string();
    let job_arg = job.display().to_string();
    let mut run = editor_e2e::spawn_sized(
        &[
            "--port",
            &link,
            "--work-zero",
            WORK_ZERO,
            "--program",
            &job_arg,
        ],
        sim.dir.path(),
        state.path(),
        size,
    );
    wait_for(&run, "Job two-tools.nc");
    run.type_keys(&[b"\x1bOS"]);
    wait_for(&run, "Position");
    console_pty::reference(&mut run);
    run.type_keys(&[b"e"]);
    wait_for(&run, "two-tools.isel");
    let before = sim.received().len();
    run.type_keys(&[b"\x1b[17~"]);
    let screen = wait_for(&run, "Run two-tools.nc");
    assert!(screen.contains("2 tool changes and pauses"), "{screen}");
    if way == Way::Streamed {
        for piece in [
            "piece 1: streamed",
            "piece 2: streamed",
            "piece 3: streamed",
        ] {
            assert!(screen.contains(piece), "{piece}:\n{screen}");
        }
    }
    run.type_keys(&[b"y"]);
    // T1: the first change, before any move; the piece before it
    // references and goes to the change position (X25 Y0 Z40: 10000, 0,
    // 16000 steps), erased there.
    let t1 = "WAIT T1 flat end mill, D=6: F6 goes on, Space ends";
    let screen = wait_for(&run, t1);
    assert!(!screen.contains("piece 2/3"), "{screen}");
    std::thread::sleep(Duration::from_secs(1));
    let at = sim.device_state();
    assert!(
        at.starts_with("device: X 10000 Y 0 Z 16000 "),
        "waits at the change position: {at}"
    );
    confirm(&mut run, t1);
    let t2 = "WAIT T2 ball end mill, D=3.175: F6 goes on, Space ends";
    wait_for(&run, t2);
    let at = sim.device_state();
    assert!(
        at.starts_with("device: X 10000 Y 0 Z 16000 "),
        "waits at the change position: {at}"
    );
    // The operator puts in a tool 1 mm (400 steps) longer.
    sim.control("value tool 400");
    confirm(&mut run, t2);
    // The job's end from the controller, then from the console's message
    // history: on the message line the note of the job checked again for
    // the new tool (T2 now in the spindle) follows it at once.
    sim.wait_device("the job's end", |s| {
        s.starts_with("device: X 36000 Y 24000 Z 26400 ") && !s.contains("moving")
    });
    run.type_keys(&[b"\x1bOS"]);
    wait_for(&run, "Position");
    run.type_keys(&[b"M"]);
    wait_for(&run, "the job ended: 3 pieces");
    run.type_keys(&[b"\x1b"]);
    let received = sim.received();
    let received = received.get(before..).unwrap_or_default();
    assert!(
        received.matches("@0k").count() >= 2,
        "each wait erases the piece before it: {received}"
    );
    match way {
        Way::Stored => assert!(received.contains("@0i"), "{received}"),
        Way::Streamed => assert!(!received.contains("@0i"), "nothing stored: {received}"),
    }
    let moves = moves(received);
    // T1's cut ends at X20 Y10 Z-1 (machine 70, 60, 59 mm); T2's at X40,
    // measured 1 mm longer (within a step), 1 mm higher: Z 60 mm.
    assert!(moves.contains(&[28_000, 24_000, 23_600]), "{moves:?}");
    let t2 = moves
        .iter()
        .find(|m| m[0] == 36_000 && m[1] == 24_000)
        .unwrap_or_else(|| panic!("no cut to X40: {moves:?}"));
    assert!((t2[2] - 24_000).abs() <= 1, "T2 cuts 1 mm higher: {t2:?}");
    assert!(!moves.contains(&[36_000, 24_000, 23_600]), "{moves:?}");
    // Each tool probed on the sensor, and the tool table beside the work
    // offsets keeps both: T1 the reference, T2 touching 1 mm higher.
    // Not the hidden temporary file of a write under way.
    let tables: Vec<_> = std::fs::read_dir(state.path().join("tools"))
        .expect("the tool table's folder")
        .filter_map(|e| e.ok())
        .filter(|e| !e.file_name().to_string_lossy().starts_with('.'))
        .collect();
    assert_eq!(tables.len(), 1, "{tables:?}");
    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(tables[0].path()).expect("the tool table"))
            .expect("JSON");
    assert_eq!(table["reference"], "T1", "{table}");
    assert_eq!(table["active"], "T2", "{table}");
    let touched = |t: &str| table["touched"][t].as_f64().expect("touched");
    assert!(
        (touched("T2") - touched("T1") - 1.0).abs() <= 0.0025 + 1e-9,
        "{table}"
    );
    editor_e2e::quit_discarding_the_edits(&mut run);
    // The job log followed the pieces: done, its last line after T2's
    // change.
    let log = sim
        .configured(&["log", "--json"])
        .env("JOGTERM_STATE_DIR", state.path())
        .output()
        .expect("jogterm log");
    let log: serde_json::Value = serde_json::from_slice(&log.stdout).expect("the log as JSON");
    let job = &log["runs"][0];
    assert_eq!(job["how"], "done", "{log:#}");
    assert!(
        job["last_line"].as_u64().is_some_and(|l| l > 12),
        "the last line after the second change: {log:#}"
    );
}
