//! `jogterm run` (issue 27): the real binary against `jogterm sim --pty`.
//! The way chosen by the estimate, parts cut only at retracts, and the
//! operator's keys on a terminal (pause, resume, stop) and its hang-up, each
//! checked on the wire.

use std::path::Path;
use std::time::Duration;

use crate::sim_process::{JOGTERM, SimProcess};
use crate::ui_pty::PtyRun;

pub(crate) const WORK_ZERO: &str = "X50 Y50 Z60";

/// A faster machine than the default (X and Y 60 mm/s, Z 30 mm/s) with a
/// program memory of 30 commands, as its simulator; the simulated axes
/// stand 1 mm from their reference point, so a job's own reference run
/// (`77`) takes a moment (what is tested comes after it).
const SMALL_MEMORY: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n[gcode]\nmemory = 30\n[sim]\nstart_position = 1.0\n",
);

fn small_controller() -> SimProcess {
    SimProcess::start_variant("isel", &[SMALL_MEMORY], &["memory=30"])
}

/// [`SMALL_MEMORY`]'s machine with a short reference run and short ramps,
/// for the tests of [`SLOW_CUT`] at real time: reference runs at 12 000 Hz
/// (the default 4000) into switches 0.5 mm below the soft minimum (the
/// default 2 mm), about 1 s for the three axes instead of 2 s, and ramps of
/// 500 Hz/ms (the default 100: a quarter of a second to a rapid's speed).
/// The job's reference run and rapids are only its way to the cut; what
/// the tests check happens in the cut, at its programmed feed. One file:
/// two files of one name do not merge.
const CUT_MACHINE: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n[gcode]\nmemory = 30\n[isel]\nreference_speed_hz = 12000\naccel_hz_per_ms = 500\n[sim]\nstart_position = 1.0\nlimit_margin = 0.5\n",
);

/// The simulator of [`CUT_MACHINE`], at real time: a key, a hang-up or a
/// lost line must land inside the cut (`docs/testing.md`, "The time scale").
pub(crate) fn cut_controller() -> SimProcess {
    SimProcess::start_variant("isel", &[CUT_MACHINE], &["memory=30"])
}

/// [`small_controller`] fifty times as fast, for the tests that check where
/// a job ends and what went on the wire, not when (`docs/simulator.md`,
/// "Time scale"): nothing in them is timed against the machine. At 50 (10
/// before) the 88-command job's motion takes about 0.5 s; what is left is
/// jogterm storing its parts at 19200 baud, which the estimate they check
/// counts (the way chosen), so the baud stays.
fn small_controller_scaled() -> SimProcess {
    SimProcess::options("isel")
        .files(&[SMALL_MEMORY])
        .variants(&["memory=30"])
        .time_scale(50.0)
        .start()
}

/// Machine steps of a point in the job's work coordinates (400 steps/mm).
fn steps(work_mm: [f64; 3]) -> [i64; 3] {
    let zero = [50.0, 50.0, 60.0];
    [0, 1, 2].map(|i| ((work_mm[i] + zero[i]) * 400.0).round() as i64)
}

pub(crate) fn stands_at(sim: &mut SimProcess, work_mm: [f64; 3]) {
    stands_at_steps(sim, steps(work_mm));
}

/// The axes stand at `[x, y, z]` machine steps.
pub(crate) fn stands_at_steps(sim: &mut SimProcess, [x, y, z]: [i64; 3]) {
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    assert!(
        state.starts_with(&format!("device: X {x} Y {y} Z {z} ")),
        "not at {x} {y} {z}: {state}"
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

/// One slow cut, `G1 X22.5 F300` (12.5 mm at 5 mm/s: 2.5 s), long enough for a
/// key, a hang-up or a lost line to land in the middle of it
/// ([`wait_in_the_slow_cut`] waits until X has left the cut's start, so
/// the key comes early in the cut, not after a fixed sleep). Run from
/// [`CUT_ZERO`].
pub(crate) const SLOW_CUT: &str =
    "%\nG21 G90 G17\nG0 Z5\nG0 X10 Y10\nG1 Z-1 F600\nG1 X22.5 F300\nG1 Y20 F1500\nG0 Z5\nM30\n%\n";

/// Where [`SLOW_CUT`]'s cut starts and ends in X (work mm).
const CUT_START_X: f64 = 10.0;
pub(crate) const CUT_END_X: f64 = 22.5;

/// The slow cut's work zero: next to the reference point (machine 0), so
/// the way from the job's reference run to the cut is short (10 mm up,
/// 10 mm over, 6 mm down, about a second) and the test's time goes to the
/// cut that its key, hang-up or lost line must land in.
pub(crate) const CUT_ZERO: &str = "X0 Y0 Z5";

/// Machine steps of a point in [`SLOW_CUT`]'s work coordinates
/// ([`CUT_ZERO`]) at `per_mm` steps a millimetre.
fn cut_steps_at(per_mm: f64, work_mm: [f64; 3]) -> [i64; 3] {
    let zero = [0.0, 0.0, 5.0];
    [0, 1, 2].map(|i| ((work_mm[i] + zero[i]) * per_mm).round() as i64)
}

/// [`cut_steps_at`] on the isel machine (400 steps/mm).
pub(crate) fn cut_steps(work_mm: [f64; 3]) -> [i64; 3] {
    cut_steps_at(400.0, work_mm)
}

pub(crate) fn write(sim: &SimProcess, name: &str, text: &str) -> String {
    let file = sim.dir.path().join(name);
    std::fs::write(&file, text).expect("write the job");
    file.display().to_string()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn a_job_bigger_than_the_memory_is_run_in_parts_cut_at_retracts_as_the_estimate_chose() {
    let mut sim = small_controller_scaled();
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
    assert!(said.contains("motion by the controller's ramps"), "{said}");
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
    let mut sim = small_controller_scaled();
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

/// `jogterm run FILE --stream` of [`SLOW_CUT`] from [`CUT_ZERO`] on a
/// terminal of its own, confirmed with `y`.
fn run_on_a_terminal(sim: &SimProcess, file: &str) -> PtyRun {
    run_on_a_terminal_as(sim, file, "stream", CUT_ZERO)
}

/// [`run_on_a_terminal`] the way `way` (`stream`, `chunked`) from the work
/// zero `zero`.
fn run_on_a_terminal_as(sim: &SimProcess, file: &str, way: &str, zero: &str) -> PtyRun {
    let mut run = spawn_on_a_terminal(sim, file, way, zero);
    run.wait_for(
        &format!("start the job ({way})? [y/N]"),
        Duration::from_secs(10),
    )
    .expect("the confirmation");
    run.type_text("y\r");
    run
}

/// `jogterm run FILE --work-zero ZERO --WAY` on a terminal of its own (50
/// by 200), configured and with the state directory of `sim`; nothing
/// answered yet.
pub(crate) fn spawn_on_a_terminal(sim: &SimProcess, file: &str, way: &str, zero: &str) -> PtyRun {
    let way_arg = format!("--{way}");
    let link = sim.link.display().to_string();
    let config = sim.dir.path().display().to_string();
    let state = sim.state_dir().display().to_string();
    PtyRun::spawn_sized(
        Path::new(JOGTERM),
        &[
            "run",
            "--port",
            &link,
            "--protocol",
            sim.family,
            file,
            "--work-zero",
            zero,
            &way_arg,
        ],
        &[
            ("JOGTERM_CONFIG_DIR", &config),
            ("JOGTERM_STATE_DIR", &state),
        ],
        50,
        200,
    )
}

/// The X counter of the simulator's `show` line.
fn x_of(state: &str) -> i64 {
    state
        .trim_start_matches("device: X ")
        .split(' ')
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no X in {state}"))
}

/// The slow cut `G1 X22.5 F300` has gone out and runs: on the wire, and the
/// axes moving with X past the cut's start and short of its end (waited
/// for, where a fixed 800 ms sleep was: what follows lands early in the
/// cut, whatever the load).
pub(crate) fn wait_in_the_slow_cut(sim: &mut SimProcess) {
    let [start, ..] = cut_steps([CUT_START_X, 0.0, 0.0]);
    let [end, ..] = cut_steps([CUT_END_X, 0.0, 0.0]);
    let target = format!("@0M{end},");
    sim.wait_received("the slow cut", |r| r.contains(&target));
    let state = sim.wait_device("in the cut", |s| s.contains("moving") && x_of(s) > start);
    assert!(x_of(&state) < end, "the cut runs: {state}");
}

/// [`SLOW_CUT`] streamed on a terminal of its own (`run_on_a_terminal`)
/// from [`cut_controller`], waited for until it is inside its slow cut.
fn streaming_in_the_slow_cut() -> (SimProcess, PtyRun) {
    let mut sim = cut_controller();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    let run = run_on_a_terminal(&sim, &file);
    wait_in_the_slow_cut(&mut sim);
    (sim, run)
}

#[test]
fn p_pauses_a_stream_without_a_stop_and_r_finishes_the_move_with_0s() {
    let (mut sim, mut run) = streaming_in_the_slow_cut();
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
    // Standing where it paused, inside the cut (past its start, short of
    // its end); nothing goes out meanwhile.
    let [start, ..] = cut_steps([CUT_START_X, 0.0, 0.0]);
    let [end, ..] = cut_steps([CUT_END_X, 0.0, 0.0]);
    let x = x_of(&state);
    assert!(start < x && x < end, "paused inside the cut: {state}");
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
    stands_at_steps(&mut sim, cut_steps([CUT_END_X, 20.0, 5.0]));
}

#[test]
fn space_stops_a_stream_and_nothing_goes_out_after_the_stop() {
    let (mut sim, mut run) = streaming_in_the_slow_cut();
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
    let (mut sim, mut run) = streaming_in_the_slow_cut();
    run.close_master();
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    let received = sim.received();
    let stop = received.rfind("<FD><FF>").expect("the stop");
    assert!(
        !received[stop..].contains("@0M"),
        "no move after the stop: {received}"
    );
    let [end, ..] = cut_steps([CUT_END_X, 0.0, 0.0]);
    assert!(
        !state.starts_with(&format!("device: X {end} ")),
        "stopped short of the cut's end: {state}"
    );
    assert!(run.wait_exit(Duration::from_secs(10)).is_some());
}

#[test]
fn a_line_lost_mid_stream_ends_the_run_and_nothing_resumes_after_it_comes_back() {
    let mut sim = cut_controller();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    let child = sim
        .configured(&["run", &file, "--work-zero", CUT_ZERO, "--stream", "--yes"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn jogterm run");
    wait_in_the_slow_cut(&mut sim);
    sim.control("fault close 500");
    let out = child.wait_with_output().expect("jogterm run ends");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "a link failure: {said}");
    // The line is back; the run has ended and sends nothing more.
    std::thread::sleep(Duration::from_millis(1500));
    let received = sim.received();
    let [end, ..] = cut_steps([CUT_END_X, 0.0, 0.0]);
    let last_move = received.rfind("@0M").expect("moves");
    assert!(
        received[last_move..].starts_with(&format!("@0M{end},")),
        "no move after the slow cut's: {received}"
    );
}

#[test]
fn over_tcp_ctrl_c_of_a_stream_reaches_the_line_within_the_network_bound() {
    // A timing promise (docs/network.md: Ctrl-C to the stop on the line
    // within 100 ms): measured one at a time, the lock held from before
    // the cut so that the cut is still running when the signal goes.
    let _serial = crate::timing::serial();
    let mut sim = SimProcess::options("isel")
        .files(&[CUT_MACHINE])
        .tcp()
        .start();
    let file = write(&sim, "slow.nc", SLOW_CUT);
    let port = sim.link.display().to_string();
    let mut command = std::process::Command::new(JOGTERM);
    command
        .args(["run", "--port", &port, "--protocol", "isel", &file])
        .args(["--work-zero", CUT_ZERO, "--stream", "--yes"])
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .stdin(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped());
    let child = command.spawn().expect("spawn jogterm run");
    wait_in_the_slow_cut(&mut sim);
    let signalled = std::time::SystemTime::now();
    let pid = libc::pid_t::try_from(child.id()).expect("pid");
    // SAFETY: a plain signal to the child this test started.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    let out = child.wait_with_output().expect("jogterm run ends");
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    sim.wait_device("standing", |s| !s.contains("moving"));
    let reads = sim.received_times();
    let joined: String = reads.iter().map(|(_, b)| b.as_str()).collect();
    let stop_at = joined.rfind("<FD><FF>").expect("the stop");
    assert!(
        !joined[stop_at..].contains("@0M"),
        "nothing after the stop: {joined}"
    );
    let took = crate::sim_process::read_time_at(&reads, stop_at)
        .duration_since(signalled)
        .unwrap_or_default();
    assert!(
        took <= Duration::from_millis(100),
        "the stop reached the line {took:?} after Ctrl-C"
    );
}

/// `@0M` moves on the wire after `from`, as (x, y, z, z speed, x speed,
/// y speed).
fn moves_after(received: &str, from: usize) -> Vec<(i64, i64, i64, i64, i64, i64)> {
    received[from..]
        .split("<CR>")
        .filter_map(|c| c.strip_prefix("@0M"))
        .map(|fields| {
            let f: Vec<i64> = fields
                .split(',')
                .map(|v| v.parse().expect("a number"))
                .collect();
            (f[0], f[2], f[4], f[5], f[1], f[3])
        })
        .collect()
}

#[test]
fn a_restart_from_a_line_retracts_goes_above_its_start_descends_at_feed_and_ends_at_the_jobs_end() {
    let mut sim = small_controller_scaled();
    let file = write(&sim, "pockets.nc", &pockets(12));
    // Line 42: the first cut of the sixth pocket (X22 Y22), after its
    // plunge `G1 Z-1 F600` on line 41.
    let out = sim
        .configured(&[
            "run",
            &file,
            "--work-zero",
            WORK_ZERO,
            "--stream",
            "--yes",
            "--from-line",
            "42",
        ])
        .output()
        .expect("run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    // The confirmation: the skipped lines' modal state and the entry.
    assert!(said.contains("restart from line 42"), "{said}");
    assert!(
        said.contains("modal state applied: G21 mm, G17 XY, G90, G54, F600"),
        "{said}"
    );
    assert!(
        said.contains("1. retract: Z alone up to Z5.000 (the job's safe height)"),
        "{said}"
    );
    assert!(
        said.contains("2. reference run of Z, then Y, then X"),
        "{said}"
    );
    assert!(said.contains("descend: G1 Z-1.000 F600"), "{said}");
    stands_at(&mut sim, [46.0, 34.0, 5.0]);
    let received = sim.received();
    let three_d = received.find("@0z1<CR>").expect("3D mode");
    let moves = moves_after(&received, three_d);
    let [x, y, z] = steps([22.0, 22.0, -1.0]);
    let safe = steps([0.0, 0.0, 5.0])[2];
    // First the retract (Z only up to the safe height), then above the
    // start at the safe height, then down at F600 (10 mm/s: 4000 Hz), then
    // the line's own cut to X27.
    assert_eq!(moves[0].2, safe, "{moves:?}");
    assert_eq!(
        (moves[1].0, moves[1].1, moves[1].2),
        (x, y, safe),
        "{moves:?}"
    );
    assert_eq!(
        (moves[2].0, moves[2].1, moves[2].2, moves[2].3),
        (x, y, z, 4000),
        "{moves:?}"
    );
    assert_eq!(
        (moves[3].0, moves[3].2),
        (steps([27.0, 0.0, 0.0])[0], z),
        "{moves:?}"
    );
    // Nothing of the five pockets before: no move to their first corner.
    let first_pocket = steps([10.0, 10.0, 0.0]);
    assert!(
        !moves
            .iter()
            .any(|m| (m.0, m.1) == (first_pocket[0], first_pocket[1])),
        "{moves:?}"
    );
}

/// A CAM-style finish of `passes` passes of 200 short cuts (0.25 mm in X
/// over a rough surface, so the import merges none), each entered from and
/// left to the safe height Z5: 203 moves a pass.
pub(crate) fn finish(passes: usize) -> String {
    let mut text = String::from("%\n(finish)\nG21 G90 G17\nG0 Z5\n");
    for pass in 0..passes {
        let y = 5.0 + pass as f64 * 0.4;
        text.push_str(&format!("G0 X5 Y{y:.3}\nG1 Z-0.5 F600\n"));
        for k in 1..=200 {
            let x = 5.0 + k as f64 * 0.25;
            let z = -0.5 + 0.2 * (k as f64 * 1.3).sin();
            text.push_str(&format!("G1 X{x:.3} Z{z:.3} F3000\n"));
        }
        text.push_str("G0 Z5\n");
    }
    text.push_str("M30\n%\n");
    text
}

/// The finish's last point: the end of its last pass, retracted.
pub(crate) fn finish_end(passes: usize) -> [f64; 3] {
    [55.0, 5.0 + (passes - 1) as f64 * 0.4, 5.0]
}

/// The simulator runs 500 times as fast as the controller (motion, wire,
/// erases), and jogterm paces the line as for 921600 baud, so jogterm's own
/// round trip per command is most of what is left: these runs check where
/// 20 000 moves end and where the parts are cut, not how long they take
/// (`benches/jobs.rs` measures that at the controller's speed). Nothing in
/// jogterm's deadlines gets shorter with the scale: every reply only comes
/// sooner than the controller's would.
pub(crate) const JOB_SCALE: f64 = 500.0;
const JOB_BAUD: &str = "921600";

/// The faster machine with the controller's own memory (2000 commands).
const FAST_MACHINE: (&str, &str) = (
    "profiles/default.toml",
    "[axes.X]\nmax_speed = 60.0\n[axes.Y]\nmax_speed = 60.0\n[axes.Z]\nmax_speed = 30.0\n",
);

/// The faster machine's simulator at [`JOB_SCALE`].
fn job_simulator() -> SimProcess {
    SimProcess::options("isel")
        .files(&[FAST_MACHINE])
        .time_scale(JOB_SCALE)
        .start()
}

/// `jogterm run` of the 20k-move finish on a scaled simulator, its traffic
/// logged: what it said, and the log.
fn run_finish(sim: &SimProcess, passes: usize, way: &str) -> (String, String) {
    let file = write(sim, "finish.nc", &finish(passes));
    let log = sim.dir.path().join("traffic.log");
    let log_arg = log.display().to_string();
    let mut command = sim.configured(&[
        "run",
        &file,
        "--work-zero",
        WORK_ZERO,
        way,
        "--yes",
        "--baud",
        JOB_BAUD,
    ]);
    let out = command.arg("--log").arg(&log_arg).output().expect("run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{said}");
    (
        said,
        std::fs::read_to_string(&log).expect("the traffic log"),
    )
}

/// The moves (`m`) of the finish converted as `jogterm import -o` writes
/// it: the import merges the few cuts that lie on one line.
fn converted_moves(sim: &SimProcess) -> usize {
    let file = sim.dir.path().join("finish.nc").display().to_string();
    let program = sim.dir.path().join("finish.isel");
    let out = sim
        .configured(&["import", &file, "--work-zero", WORK_ZERO, "-o"])
        .arg(&program)
        .output()
        .expect("import");
    assert!(out.status.success(), "{}", text(&out.stderr));
    std::fs::read_to_string(&program)
        .expect("the program")
        .lines()
        .filter(|l| l.starts_with('m'))
        .count()
}

/// Lines the traffic log says were sent.
fn sent(log: &str) -> impl Iterator<Item = &str> {
    log.lines()
        .filter_map(|l| l.split_once(" >> ").map(|(_, t)| t))
}

#[test]
fn a_20k_move_job_streamed_ends_exactly_at_its_last_point() {
    let mut sim = job_simulator();
    let passes = 102;
    let (said, log) = run_finish(&sim, passes, "--stream");
    assert!(said.contains("the stream ended"), "{said}");
    stands_at(&mut sim, finish_end(passes));
    assert_eq!(
        sent(&log).filter(|l| l.starts_with("@0i")).count(),
        0,
        "nothing stored"
    );
    // Every move of the converted job went out once.
    let moves = sent(&log).filter(|l| l.starts_with("@0M")).count();
    assert_eq!(moves, converted_moves(&sim));
    assert!(moves > 20_000, "{moves}");
}

#[test]
fn a_20k_move_job_in_parts_ends_exactly_at_its_last_point_every_part_cut_at_a_retract() {
    let mut sim = job_simulator();
    let passes = 102;
    let (said, log) = run_finish(&sim, passes, "--chunked");
    assert!(said.contains("chosen: chunked"), "{said}");
    stands_at(&mut sim, finish_end(passes));
    // The stored parts, from the log: what follows each `@0i` up to `9`.
    let lines: Vec<&str> = sent(&log).map(|l| l.trim_end_matches("<CR>")).collect();
    let mut parts: Vec<Vec<&str>> = Vec::new();
    let mut storing: Option<Vec<&str>> = None;
    for line in lines {
        match (&mut storing, line) {
            (None, "@0i") => storing = Some(Vec::new()),
            (Some(part), "9") => {
                part.push("9");
                parts.extend(storing.take());
            }
            (Some(part), l) if !l.starts_with('@') => part.push(l),
            _ => {}
        }
    }
    assert!(parts.len() >= 10, "{} parts", parts.len());
    let safe = steps([0.0, 0.0, 5.0])[2].to_string();
    let mut moves = 0;
    for (k, part) in parts.iter().enumerate() {
        moves += part.iter().filter(|c| c.starts_with('m')).count();
        assert!(
            part.len() <= 2000,
            "part {} holds {} commands",
            k + 1,
            part.len()
        );
        if k + 1 < parts.len() {
            let last = part[part.len() - 2];
            let fields: Vec<&str> = last.trim_start_matches('m').split(',').collect();
            assert!(
                last.starts_with('m') && fields.get(4) == Some(&safe.as_str()),
                "part {} ends with `{last}`, not at the safe height",
                k + 1
            );
        }
    }
    assert_eq!(moves, converted_moves(&sim), "every move stored once");
    assert!(moves > 20_000, "{moves}");
}

/// The EMCU machine of the G-code tests: faster axes, the spindle relay on
/// A1; and for this test at real time shorter still: the reference point
/// 0.2 mm away (the interface homes at its start speed, 200 Hz: 1 mm took
/// a second an axis) and 100 ms ramps (500 ms on every move of the shipped
/// profile). Neither is what the test checks: the pause inside the cut,
/// the rest of the cut, the end point.
const FAST_EMCU: (&str, &str) = (
    "profiles/emcu.toml",
    "base = \"emcu\"\n[axes.X]\nmax_speed = 40.0\n[axes.Y]\nmax_speed = 40.0\n[axes.Z]\nmax_speed = 20.0\n[emcu]\nramp_ms = 100\n[sim]\nstart_position = 0.2\n[gcode]\nm3 = \"output:A1\"\nm5 = \"output:A1\"\n",
);

/// EMCU steps of a point in the slow cut's work coordinates (200 steps/mm).
fn emcu_steps(work_mm: [f64; 3]) -> [i64; 3] {
    cut_steps_at(200.0, work_mm)
}

#[test]
fn an_emcu_stream_pauses_with_b_resumes_with_the_rest_and_ends_at_its_last_point() {
    let mut sim = SimProcess::start_with_files("emcu", &[FAST_EMCU]);
    let file = write(&sim, "slow.nc", SLOW_CUT);
    let mut run = run_on_a_terminal(&sim, &file);
    let [start, ..] = emcu_steps([CUT_START_X, 0.0, 0.0]);
    let [end, ..] = emcu_steps([CUT_END_X, 0.0, 0.0]);
    let cut = format!("X{end},");
    sim.wait_received("the slow cut", |r| r.contains(&cut));
    // In the cut: X moving past its start (waited for, not slept).
    let state = sim.wait_device("in the cut", |s| s.contains("moving") && x_of(s) > start);
    assert!(x_of(&state) < end, "the cut runs: {state}");
    run.type_text("p");
    run.wait_for("paused at", Duration::from_secs(10))
        .expect("the pause is said");
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    let received = sim.received();
    let paused_at = received.len();
    assert!(
        received[received.rfind(&cut).expect("the cut")..].contains("@B"),
        "the pause halts with @B: {received}"
    );
    let x = x_of(&state);
    assert!(start < x && x < end, "paused inside the cut: {state}");
    std::thread::sleep(Duration::from_millis(1000));
    assert!(
        !sim.received()[paused_at..].contains('L'),
        "nothing moves on its own while paused: {}",
        &sim.received()[paused_at..]
    );
    run.type_text("r");
    assert_eq!(run.wait_exit(Duration::from_secs(60)), Some(0));
    // The rest of the cut went out from where the axes stood, to X22.5.
    assert!(
        sim.received()[paused_at..].contains(&cut),
        "{}",
        sim.received()
    );
    let [x, y, z] = emcu_steps([CUT_END_X, 20.0, 5.0]);
    let state = sim.wait_device("standing", |s| !s.contains("moving"));
    // The EMCU line: counters, then the machine position in brackets.
    for (axis, v) in [("X", x), ("Y", y), ("Z", z)] {
        assert!(state.contains(&format!(" {axis} {v} [")), "{state}");
    }
    assert!(!sim.received().contains("@F"), "nothing stored");
}

#[test]
fn the_speed_factor_sets_the_speed_of_the_moves_not_yet_sent() {
    let (mut sim, mut run) = streaming_in_the_slow_cut();
    // One step slower while the cut runs: the cut keeps its speed (it is
    // on its way), the moves after it go out at 90 %.
    run.type_text("-");
    run.wait_for("speed 90 % of the program's", Duration::from_secs(10))
        .expect("the factor is said");
    assert_eq!(run.wait_exit(Duration::from_secs(60)), Some(0));
    stands_at_steps(&mut sim, cut_steps([CUT_END_X, 20.0, 5.0]));
    let received = sim.received();
    let [x_end, y20, _] = cut_steps([CUT_END_X, 20.0, 0.0]);
    let moves = moves_after(&received, 0);
    // G1 X22.5 F300: 5 mm/s, 2000 Hz at 400 steps/mm, as programmed.
    let cut = moves.iter().position(|m| m.0 == x_end).expect("the cut");
    assert_eq!(moves[cut].4, 2000, "{moves:?}");
    // G1 Y20 F1500: 25 mm/s, 10000 Hz; at 90 % 9000 Hz.
    assert_eq!(
        (moves[cut + 1].1, moves[cut + 1].5),
        (y20, 9000),
        "{moves:?}"
    );
}

#[test]
fn space_stops_a_job_in_parts_and_no_further_part_is_stored() {
    let mut sim = small_controller();
    let file = write(&sim, "pockets.nc", &pockets(12));
    let mut run = run_on_a_terminal_as(&sim, &file, "chunked", WORK_ZERO);
    // Inside the first part: its program started and the axes move.
    sim.wait_received("the first part's start", |r| r.contains("@0S<CR>"));
    sim.wait_device("moving", |s| s.contains("moving"));
    run.type_text(" ");
    assert_eq!(run.wait_exit(Duration::from_secs(10)), Some(1));
    run.drain(Duration::from_secs(2));
    assert!(text(&run.output()).contains("stopped; nothing resumes"));
    let received = sim.received();
    let stop = received.rfind("<FD><FF>").expect("the stop");
    assert!(
        received.find("@0S<CR>").is_some_and(|start| start < stop),
        "{received}"
    );
    assert!(
        !received[stop..].contains("@0i") && !received[stop..].contains("@0S"),
        "no part after the stop: {received}"
    );
    sim.wait_device("standing", |s| !s.contains("moving"));
    std::thread::sleep(Duration::from_millis(800));
    assert!(!sim.device_state().contains("moving"), "nothing resumes");
}

/// The link lost in a job in parts (issue 37): exit 3, and the message
/// names the part it was lost in and the G-code line to restart from: the
/// part's first line, which follows a rapid at the safe height (parts are
/// cut only where the tool stands retracted).
#[test]
fn a_link_lost_in_a_job_in_parts_names_the_part_and_the_line_to_restart_from() {
    let mut sim = small_controller();
    let job = pockets(12);
    let file = write(&sim, "pockets.nc", &job);
    let child = sim
        .configured(&["run", &file, "--work-zero", WORK_ZERO, "--chunked", "--yes"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn jogterm run");
    sim.wait_received("the second part's start", |r| {
        r.matches("@0S<CR>").count() >= 2
    });
    sim.control("fault close 500");
    let out = crate::sim_process::wait_child(child, "jogterm run");
    let said = text(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "a link failure: {said}");
    let (part, line) = said
        .lines()
        .find_map(|l| {
            let rest = l.strip_prefix("jogterm run: the link was lost in part ")?;
            let (part, rest) = rest.split_once("/4, which begins at G-code line ")?;
            let line: String = rest.chars().take_while(char::is_ascii_digit).collect();
            Some((part.parse::<usize>().ok()?, line.parse::<usize>().ok()?))
        })
        .unwrap_or_else(|| panic!("no part and line in:\n{said}"));
    assert!(part >= 2, "{said}");
    assert!(
        said.contains(&format!("--from-line {line}")),
        "the restart is named: {said}"
    );
    let lines: Vec<&str> = job.lines().collect();
    assert!(
        lines[line - 2].starts_with("G0 "),
        "line {line} follows a rapid at the safe height: `{}`",
        lines[line - 2]
    );
}
