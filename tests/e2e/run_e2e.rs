//! `jogterm run` (issue 27): the real binary against `jogterm sim --pty`.
//! The way chosen by the estimate, parts cut only at retracts, and the
//! operator's keys on a terminal (pause, resume, stop) and its hang-up, each
//! checked on the wire.

use std::path::Path;
use std::time::Duration;

use crate::sim_process::{JOGTERM, SimProcess};
use crate::ui_pty::PtyRun;

const WORK_ZERO: &str = "X50 Y50 Z60";

/// A faster machine than the default (X and Y 60 mm/s, Z 30 mm/s) with a
/// program memory of 30 commands, as its simulator.
const SMALL_MEMORY: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n[gcode]\nmemory = 30\n",
);

fn small_controller() -> SimProcess {
    SimProcess::start_variant("isel", &[SMALL_MEMORY], &["memory=30"])
}

/// Machine steps of a point in the job's work coordinates (400 steps/mm).
fn steps(work_mm: [f64; 3]) -> [i64; 3] {
    let zero = [50.0, 50.0, 60.0];
    [0, 1, 2].map(|i| ((work_mm[i] + zero[i]) * 400.0).round() as i64)
}

fn stands_at(sim: &mut SimProcess, work_mm: [f64; 3]) {
    let [x, y, z] = steps(work_mm);
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    assert!(
        state.starts_with(&format!("device: X {x} Y {y} Z {z} ")),
        "not at {work_mm:?}: {state}"
    );
}

/// `n` square pockets, each entered from and left to Z5 (7 commands each).
fn pockets(n: usize) -> String {
    pockets_at(n, 10, (5, -1))
}

/// `n` square pockets from X and Y `corner` in 12 mm steps, each entered
/// from and left to the safe height `z.0`, cut at `z.1` (7 commands each).
pub(crate) fn pockets_at(n: usize, corner: usize, z: (i32, i32)) -> String {
    let (safe, cut) = z;
    let mut text = format!("%\n(pockets)\nG21 G90 G17\nG0 Z{safe}\n");
    for i in 0..n {
        let (x, y) = (corner + (i % 4) * 12, corner + (i / 4) * 12);
        text.push_str(&format!(
            "G0 X{x} Y{y}\nG1 Z{cut} F600\nG1 X{} F1500\nG1 Y{}\nG1 X{x}\nG1 Y{y}\nG0 Z{safe}\n",
            x + 5,
            y + 5
        ));
    }
    text.push_str("M30\n%\n");
    text
}

/// The programs stored after `received` (the simulator's record) began:
/// `@0i` also opens the driver's look at what is stored (answered `6`
/// while a program is there, then `@0k`), and those hold no commands.
pub(crate) fn stored_programs(received: &str) -> Vec<Vec<&str>> {
    received
        .split("@0i<CR>")
        .skip(1)
        .map(|program| program.split("<CR>").collect::<Vec<_>>())
        .filter(|commands| commands.first().is_some_and(|c| !c.starts_with('@')))
        .collect()
}

/// Every stored part ends, before its `9`, with a move of Z to
/// `safe_steps`: the rapid up to the safe height; none holds more than
/// `memory` commands.
pub(crate) fn assert_parts_end_retracted(parts: &[Vec<&str>], safe_steps: &str, memory: usize) {
    for (k, part) in parts.iter().enumerate() {
        let end = part.iter().position(|c| *c == "9").expect("a 9");
        assert!(end <= memory, "part {} holds {end} commands", k + 1);
        let last = part[end - 1];
        let fields: Vec<&str> = last.trim_start_matches('m').split(',').collect();
        assert!(
            last.starts_with('m') && fields.get(4) == Some(&safe_steps),
            "part {} ends with `{last}`, not at the safe height",
            k + 1
        );
    }
}

/// One slow cut (30 mm at 5 mm/s), long enough to pause in the middle.
const SLOW_CUT: &str =
    "%\nG21 G90 G17\nG0 Z5\nG0 X10 Y10\nG1 Z-1 F600\nG1 X40 F300\nG1 Y20 F1500\nG0 Z5\nM30\n%\n";

fn write(sim: &SimProcess, name: &str, text: &str) -> String {
    let file = sim.dir.path().join(name);
    std::fs::write(&file, text).expect("write the job");
    file.display().to_string()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn a_job_bigger_than_the_memory_is_run_in_parts_cut_at_retracts_as_the_estimate_chose() {
    let mut sim = small_controller();
    let file = write(&sim, "pockets.nc", &pockets(12));
    let reference = sim
        .configured(&["send", "@07", "@0R7"])
        .output()
        .expect("send");
    assert!(reference.status.success(), "{}", text(&reference.stderr));
    let before = sim.received().len();
    let out = sim
        .configured(&["run", &file, "--work-zero", WORK_ZERO, "--yes"])
        .output()
        .expect("run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    // The ways and their estimates before the start; chunked, since the
    // stream would stand in the part at every boundary.
    assert!(
        said.contains("88 commands, the controller stores 30"),
        "{said}"
    );
    assert!(said.contains("stream: "), "{said}");
    assert!(said.contains("with the tool in the part"), "{said}");
    assert!(said.contains("chunked: "), "{said}");
    assert!(said.contains("motion alone (the floor)"), "{said}");
    assert!(said.contains("chosen: chunked ("), "{said}");
    assert!(said.contains("part 4/4"), "{said}");
    stands_at(&mut sim, [46.0, 34.0, 5.0]);
    // Every part but the last ends with the rapid up to the safe height Z5
    // (machine Z65: 26000 steps) before its `9`.
    let received = sim.received();
    let stored = stored_programs(&received[before..]);
    assert_eq!(stored.len(), 4, "{received}");
    assert_parts_end_retracted(&stored, "26000", 30);
}

#[test]
fn a_job_that_fits_is_stored_and_without_a_terminal_nothing_starts_unasked() {
    let mut sim = small_controller();
    let file = write(&sim, "two.nc", &pockets(2));
    // No terminal to confirm on and no --yes: bad usage, nothing sent.
    let out = sim
        .configured(&["run", &file, "--work-zero", WORK_ZERO])
        .output()
        .expect("run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{said}");
    assert!(said.contains("give --yes"), "{said}");
    assert_eq!(sim.received_total(), 0);
    // --chunked where it would fit whole is still one stored program.
    let out = sim
        .configured(&["run", &file, "--work-zero", WORK_ZERO, "--yes"])
        .output()
        .expect("run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    assert!(said.contains("chosen: stored ("), "{said}");
    assert!(!said.contains("chunked:"), "{said}");
    stands_at(&mut sim, [22.0, 10.0, 5.0]);
    assert_eq!(sim.received().matches("@0i<CR>").count(), 1);
}

/// `jogterm run FILE --stream` on a terminal of its own, confirmed with `y`.
fn run_on_a_terminal(sim: &SimProcess, file: &str) -> PtyRun {
    let link = sim.link.display().to_string();
    let config = sim.dir.path().display().to_string();
    let mut run = PtyRun::spawn_sized(
        Path::new(JOGTERM),
        &[
            "run",
            "--port",
            &link,
            "--protocol",
            "isel",
            file,
            "--work-zero",
            WORK_ZERO,
            "--stream",
        ],
        &[("JOGTERM_CONFIG_DIR", &config)],
        50,
        200,
    );
    run.wait_for("start the job (stream)? [y/N]", Duration::from_secs(10))
        .expect("the confirmation");
    run.type_text("y\r");
    run
}

/// The long cut `G1 X40 F300` (machine X 90 mm) has gone out and runs.
fn wait_in_the_slow_cut(sim: &mut SimProcess) {
    let target = format!("@0M{},", steps([40.0, 0.0, 0.0])[0]);
    sim.wait_received("the slow cut", |r| r.contains(&target));
    std::thread::sleep(Duration::from_millis(800));
    let state = sim.device_state();
    assert!(state.contains("moving"), "the cut runs: {state}");
}

#[test]
fn p_pauses_a_stream_without_a_stop_and_r_finishes_the_move_with_0s() {
    let mut sim = small_controller();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    let mut run = run_on_a_terminal(&sim, &file);
    wait_in_the_slow_cut(&mut sim);
    run.type_text("p");
    run.wait_for("paused at", Duration::from_secs(10))
        .expect("the pause is said");
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    let paused_at = sim.received().len();
    // 0xFD alone: the pause without step loss, no 0xFF (which would drop
    // the rest of the move).
    let received = sim.received();
    let pause = received.rfind("<FD>").expect("0xFD");
    assert!(
        !received[pause..].starts_with("<FD><FF>"),
        "a pause is no stop: {received}"
    );
    // Standing where it paused, short of X40; nothing goes out meanwhile.
    let [x40, ..] = steps([40.0, 0.0, 0.0]);
    let x: i64 = state
        .trim_start_matches("device: X ")
        .split(' ')
        .next()
        .and_then(|v| v.parse().ok())
        .expect("X");
    assert!(x < x40, "paused short of the cut's end: {state}");
    std::thread::sleep(Duration::from_millis(1500));
    assert_eq!(
        sim.received().len(),
        paused_at,
        "nothing resumes on its own: {}",
        sim.received()
    );
    run.type_text("r");
    run.wait_for("resumed at", Duration::from_secs(10))
        .expect("the resume is said");
    assert_eq!(run.wait_exit(Duration::from_secs(60)), Some(0));
    let received = sim.received();
    assert!(
        received[paused_at..].starts_with("@0S<CR>"),
        "the rest of the move with @0S: {}",
        &received[paused_at..]
    );
    stands_at(&mut sim, [40.0, 20.0, 5.0]);
}

#[test]
fn space_stops_a_stream_and_nothing_goes_out_after_the_stop() {
    let mut sim = small_controller();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    let mut run = run_on_a_terminal(&sim, &file);
    wait_in_the_slow_cut(&mut sim);
    run.type_text(" ");
    assert_eq!(run.wait_exit(Duration::from_secs(10)), Some(1));
    run.drain(Duration::from_secs(2));
    let said = text(&run.output());
    assert!(said.contains("stopped by the operator"), "{said}");
    let received = sim.received();
    let stop = received.rfind("<FD><FF>").expect("the stop");
    assert!(
        !received[stop..].contains("@0M"),
        "no move after the stop: {received}"
    );
    sim.wait_device("standing", |s| !s.contains("moving"));
}

#[test]
fn a_hang_up_during_a_stream_stops_the_machine() {
    let mut sim = small_controller();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    let mut run = run_on_a_terminal(&sim, &file);
    wait_in_the_slow_cut(&mut sim);
    run.close_master();
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    let received = sim.received();
    let stop = received.rfind("<FD><FF>").expect("the stop");
    assert!(
        !received[stop..].contains("@0M"),
        "no move after the stop: {received}"
    );
    let [x40, ..] = steps([40.0, 0.0, 0.0]);
    assert!(
        !state.starts_with(&format!("device: X {x40} ")),
        "stopped short of the cut's end: {state}"
    );
    assert!(run.wait_exit(Duration::from_secs(10)).is_some());
}
