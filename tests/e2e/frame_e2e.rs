//! End to end: `jogterm frame` (`docs/gcode.md`, "Frame the job") against
//! `jogterm sim --pty`: the four corners of the job's extents on the wire at
//! its safe height and back to the first, the refusals (outside the soft
//! limits, axes not referenced) with nothing sent that moves, and Space
//! stopping the trace.

use std::path::Path;
use std::time::Duration;

use crate::sim_process::{self, JOGTERM, SimProcess, text};
use crate::ui_pty::PtyRun;

/// Near the reference point at power-up (a short reference run), and the
/// fastest jog speed of the list (15 mm/s) as the one selected at start:
/// the frame's speed.
const MACHINE: (&str, &str) = (
    "profiles/default.toml",
    "[sim]\nstart_position = 1.0\n[jog]\nspeed = 3\n",
);

/// A pocket from work X10 Y5 to X30 Y15, cut at Z-1, entered from and left
/// to Z5: its highest Z.
const JOB: &str =
    "G21 G90\nG0 Z5\nG0 X10 Y5\nG1 Z-1 F300\nG1 X30\nG1 Y15\nG1 X10\nG1 Y5\nG0 Z5\nM2\n";

/// Work zero: the job's X 60-80, Y 55-65, safe Z 25 machine mm.
const ZERO: &str = "X50 Y50 Z20";

/// The trace from machine X 10, Y 10, Z 5 (steps at 400/mm): Z alone up
/// to 25 mm, the four corners, the first again.
const TRACE: [(i64, i64, i64); 6] = [
    (4000, 4000, 10_000),
    (24_000, 22_000, 10_000),
    (32_000, 22_000, 10_000),
    (32_000, 26_000, 10_000),
    (24_000, 26_000, 10_000),
    (24_000, 22_000, 10_000),
];

fn sim(scale: f64) -> SimProcess {
    SimProcess::options("isel")
        .files(&[MACHINE])
        .time_scale(scale)
        .start()
}

fn write_job(sim: &SimProcess) -> String {
    let file = sim.dir.path().join("pocket.nc");
    std::fs::write(&file, JOB).expect("write the job");
    file.display().to_string()
}

/// Referenced, standing at machine X 10, Y 10, Z 5.
fn referenced(sim: &SimProcess) {
    let out = sim.run(&[
        "send",
        "@07",
        "@0R7",
        "@0M4000,4000,4000,4000,2000,4000,0,4000",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
}

/// The relative moves (`@0A`) received from `before` on, as the absolute
/// positions they lead to from `start`; a move of no steps (the driver's
/// reference probe) is left out.
fn positions_after(received: &str, start: (i64, i64, i64)) -> Vec<(i64, i64, i64)> {
    let mut at = start;
    let mut out = Vec::new();
    for command in received.split("<CR>") {
        let Some(rest) = command.strip_prefix("@0A") else {
            continue;
        };
        let steps: Vec<i64> = rest
            .split(',')
            .filter_map(|n| n.trim().parse().ok())
            .step_by(2)
            .collect();
        if let [dx, dy, dz, ..] = steps[..]
            && (dx, dy, dz) != (0, 0, 0)
        {
            at = (at.0 + dx, at.1 + dy, at.2 + dz);
            out.push(at);
        }
    }
    out
}

/// Any command that moves: `@0A` of steps, `@0M`, `@0Z`.
fn moves(received: &str) -> Vec<String> {
    received
        .split("<CR>")
        .filter(|c| {
            c.starts_with("@0M")
                || c.starts_with("@0Z")
                || (c.starts_with("@0A")
                    && !positions_after(&format!("{c}<CR>"), (0, 0, 0)).is_empty())
        })
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_frame_traces_the_four_corners_at_the_safe_height_and_back_to_the_first() {
    // The scale changes how long the moves take, not which go out.
    let mut sim = sim(sim_process::LOGIC_SCALE);
    let file = write_job(&sim);
    referenced(&sim);
    let before = sim.received().len();
    let out = sim
        .configured(&["frame", &file, "--work-zero", ZERO, "--yes"])
        .output()
        .expect("frame");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(
        said.contains("frame X 60.000 to 80.000, Y 55.000 to 65.000 (machine) at Z 25.000"),
        "{said}"
    );
    let received = sim.received();
    let trace = positions_after(&received[before..], (4000, 4000, 2000));
    assert_eq!(trace, TRACE, "{}", &received[before..]);
    // At the jog speed: 15 mm/s is 6000 Hz (an axis that stands gets the
    // start-stop frequency).
    assert!(
        received[before..].contains("@0A0,300,0,300,8000,6000,0,6000"),
        "{}",
        &received[before..]
    );
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    assert!(
        state.starts_with("device: X 24000 Y 22000 Z 10000 "),
        "{state}"
    );
    // --z: the height asked for, work Z (2 + 20 machine mm): below where
    // the tool stands now, so it stays at Z 25, never lower.
    let before = sim.received().len();
    let out = sim
        .configured(&["frame", &file, "--work-zero", ZERO, "--z", "2", "--yes"])
        .output()
        .expect("frame");
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let received = sim.received();
    let trace = positions_after(&received[before..], (24_000, 22_000, 10_000));
    // No Z move; the tool stands at the first corner already (a move of
    // nothing is not sent).
    assert_eq!(trace, TRACE[2..], "{}", &received[before..]);
}

#[test]
fn a_frame_outside_the_soft_limits_or_with_axes_unreferenced_is_refused_and_nothing_moves() {
    let mut sim = sim(sim_process::LOGIC_SCALE);
    let file = write_job(&sim);
    // X up to 310 mm: beyond the soft limit of 300; nothing is even sent.
    let out = sim
        .configured(&["frame", &file, "--work-zero", "X280 Y50 Z20", "--yes"])
        .output()
        .expect("frame");
    let said = text(&out.stderr);
    assert_ne!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("X 310.000"), "{said}");
    // A height above Z's soft limit of 80.
    let out = sim
        .configured(&["frame", &file, "--work-zero", ZERO, "--z", "70", "--yes"])
        .output()
        .expect("frame");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(
        said.contains("the safe height Z 90.000 lies outside"),
        "{said}"
    );
    assert_eq!(sim.received_total(), 0);
    // Within the limits, but the axes are not referenced.
    let out = sim
        .configured(&["frame", &file, "--work-zero", ZERO, "--yes"])
        .output()
        .expect("frame");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(said.contains("not referenced"), "{said}");
    let received = sim.received();
    assert!(moves(&received).is_empty(), "{received}");
}

/// `jogterm frame` of [`JOB`] on a terminal of its own, confirmed, stopped
/// by `stop` on its way up to the safe height (real time: 20 mm at
/// 15 mm/s): the machine stands short of it, X and Y unmoved, and nothing
/// that moves went out after the stop byte.
fn stopped_on_the_way_up(stop: impl FnOnce(&mut PtyRun)) -> PtyRun {
    let mut sim = sim(1.0);
    let file = write_job(&sim);
    referenced(&sim);
    let link = sim.link.display().to_string();
    let config = sim.dir.path().display().to_string();
    let mut run = PtyRun::spawn(
        Path::new(JOGTERM),
        &[
            "frame",
            "--port",
            &link,
            "--protocol",
            "isel",
            &file,
            "--work-zero",
            ZERO,
        ],
        &[("JOGTERM_CONFIG_DIR", &config)],
    );
    run.wait_for("trace the frame? [y/N]", Duration::from_secs(10))
        .expect("the confirmation");
    run.type_text("y\r");
    sim.wait_device("moving", |s| s.contains("moving"));
    stop(&mut run);
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    let received = sim.received();
    let stop = received.rfind("<FD>").expect("the stop");
    assert!(
        !received[stop..].contains("@0A") && !received[stop..].contains("@0M"),
        "no move after the stop: {received}"
    );
    let z = z_of(&state);
    assert!(state.starts_with("device: X 4000 Y 4000 "), "{state}");
    assert!(z > 2000 && z < 10_000, "{state}");
    assert!(run.wait_exit(Duration::from_secs(10)).is_some());
    run
}

#[test]
fn space_stops_the_frame_and_nothing_moves_after_the_stop() {
    let mut run = stopped_on_the_way_up(|run| run.type_text(" "));
    assert_eq!(run.wait_exit(Duration::from_secs(10)), Some(1));
    run.drain(Duration::from_secs(2));
    let said = text(&run.output());
    assert!(said.contains("stopped; nothing resumes"), "{said}");
}

#[test]
fn sigterm_and_a_hang_up_stop_the_frame() {
    let mut run = stopped_on_the_way_up(|run| {
        let pid = run.child.process_id().expect("the frame's pid");
        let killed = std::process::Command::new("kill")
            .args(["-TERM", &pid.to_string()])
            .status()
            .expect("kill");
        assert!(killed.success());
    });
    assert_eq!(run.wait_exit(Duration::from_secs(10)), Some(1));
    run.drain(Duration::from_secs(2));
    let said = text(&run.output());
    assert!(
        said.contains("interrupted: the machine was stopped"),
        "{said}"
    );
    stopped_on_the_way_up(PtyRun::close_master);
}

/// The absolute moves (`@0M`, the go-to's) in `received`, as positions.
fn go_tos(received: &str) -> Vec<(i64, i64, i64)> {
    received
        .split("<CR>")
        .filter_map(|c| c.strip_prefix("@0M"))
        .filter_map(|rest| {
            let n: Vec<i64> = rest
                .split(',')
                .filter_map(|n| n.trim().parse().ok())
                .step_by(2)
                .collect();
            match n[..] {
                [x, y, z, ..] => Some((x, y, z)),
                _ => None,
            }
        })
        .collect()
}

/// The console with [`JOB`] opened (`--program`, placed by `--work-zero`)
/// on the machine screen, referenced; the simulator at `scale` (`None`:
/// real time). The state directory lives as long as the third value.
fn console_referenced(scale: Option<f64>) -> (SimProcess, PtyRun, tempfile::TempDir) {
    let mut options = SimProcess::options("isel").files(&[(
        "profiles/default.toml",
        "[sim]\nstart_position = 1.0\n[jog]\nspeed = 3\n[isel]\nreference_speed_hz = 12000\n",
    )]);
    if let Some(scale) = scale {
        options = options.time_scale(scale);
    }
    let sim = options.start();
    let file = write_job(&sim);
    let state = tempfile::tempdir().expect("state dir");
    let link = sim.link.display().to_string();
    let mut run = crate::console_pty::spawn_on(
        &sim,
        state.path(),
        &["--port", &link, "--program", &file, "--work-zero", ZERO],
    );
    crate::console_pty::wait_for(&run, "Job pocket.nc");
    run.type_keys(&[b"\x1bOS"]);
    crate::console_pty::wait_for(&run, "Position");
    crate::console_pty::reference(&mut run);
    (sim, run, state)
}

/// Z in steps of a simulator state line (`device: X … Y … Z … `).
fn z_of(state: &str) -> i64 {
    state
        .split(" Z ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no Z in {state}"))
}

/// `F` in the console frames the job open in it (`--program`, placed by
/// `--work-zero`): asked first, then Z up alone and the four corners at the
/// safe height on the wire, each a go-to sent when the one before ended,
/// the trace said done on the status line's message.
#[test]
fn f_in_the_console_frames_the_open_job_at_the_safe_height() {
    let (mut sim, mut run, _state) = console_referenced(Some(sim_process::LOGIC_SCALE));
    let before = sim.received().len();
    run.type_keys(&[b"F"]);
    // The question's words are the offline tests' (`frame_ui`); here its
    // title, and that nothing went out before the answer.
    crate::console_pty::wait_for(&run, "Frame the job");
    assert!(
        go_tos(&sim.received()[before..]).is_empty(),
        "nothing before the answer"
    );
    run.type_keys(&[b"y"]);
    crate::console_pty::wait_for(&run, "frame traced");
    let received = sim.received();
    let trace = go_tos(&received[before..]);
    let corners = &TRACE[1..];
    assert_eq!(trace.len(), 6, "{}", &received[before..]);
    assert_eq!(trace.get(1..), Some(corners), "{}", &received[before..]);
    let up = trace.first().copied().unwrap_or_default();
    assert_eq!(up.2, 10_000, "Z up alone first: {up:?}");
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    assert!(
        state.starts_with("device: X 24000 Y 22000 Z 10000 "),
        "{state}"
    );
    crate::editor_e2e::quit_discarding_the_edits(&mut run);
}

/// Space during the console's frame, on its way up (real time: 25 mm at
/// 15 mm/s): the machine stops short of the safe height, and no go-to goes
/// out after the stop byte (the next leg is never sent).
#[test]
fn space_stops_the_consoles_frame_and_no_leg_follows() {
    let (mut sim, mut run, _state) = console_referenced(None);
    run.type_keys(&[b"F"]);
    crate::console_pty::wait_for(&run, "Frame the job");
    run.type_keys(&[b"y"]);
    sim.wait_device("moving", |s| s.contains("moving"));
    run.type_keys(&[b" "]);
    crate::console_pty::wait_for(&run, "frame: stopped");
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    std::thread::sleep(Duration::from_millis(500));
    let received = sim.received();
    let stop = received.rfind("<FD>").expect("the stop");
    assert!(
        go_tos(&received[stop..]).is_empty(),
        "no leg after the stop: {received}"
    );
    let z = z_of(&state);
    assert!(z < 10_000, "stopped short of the safe height: {state}");
    crate::editor_e2e::quit_discarding_the_edits(&mut run);
}

/// `f` held in the console traces the frame without a question, and only
/// while its repeats come: on a terminal that reports no key releases (this
/// pty) the repeats stopping is the only sign the key was let go, and the
/// device task's hold (`Request::Hold`, renewed by each repeat) stops the
/// machine itself once they stop (real time: 20 mm up at 15 mm/s take
/// 1.3 s; the key is held for 0.6 s). No go-to goes out after the stop
/// byte.
#[test]
fn f_held_traces_the_frame_only_while_its_repeats_come() {
    let (mut sim, mut run, _state) = console_referenced(None);
    let before = sim.received().len();
    // Held: a press, then a repeat every 33 ms (a 30 Hz terminal).
    let held = std::time::Instant::now();
    while held.elapsed() < Duration::from_millis(600) {
        run.type_keys(&[b"f"]);
        std::thread::sleep(Duration::from_millis(33));
    }
    let let_go = std::time::Instant::now();
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    let stopped_after = let_go.elapsed();
    eprintln!("standing {stopped_after:?} after the last repeat");
    crate::console_pty::wait_for(&run, "frame stopped: the key was let go");
    std::thread::sleep(Duration::from_millis(500));
    let received = sim.received();
    let received = &received[before..];
    let trace = go_tos(received);
    assert_eq!(trace.len(), 1, "only the way up went out: {received}");
    let stop = received.rfind("<FD>").expect("the stop byte");
    assert!(
        go_tos(&received[stop..]).is_empty(),
        "no leg after the stop: {received}"
    );
    let z = z_of(&state);
    assert!(z < 10_000, "stopped short of the safe height: {state}");
    // The hold's lease (the repeat timeout, 150 ms) and the ramp down, with
    // the test's polls of the simulator on a loaded machine.
    assert!(
        stopped_after < Duration::from_secs(3),
        "stopped {stopped_after:?} after the last repeat"
    );
    crate::editor_e2e::quit_discarding_the_edits(&mut run);
}
