//! The program check-out (issue 15, `docs/editor.md`, "Check-out") with the
//! real `jogterm` binary in a pseudo-terminal against `jogterm sim --pty`:
//! F10 held as a terminal repeats it (one key every 30 ms), the lines in
//! DNC form on the wire, a hold let go in the middle of a line pauses it
//! (0xFD alone) and the next hold finishes that line with `@0S` to the
//! exact step, single step, the speed factor on the wire, run from a line.

use crate::sim_process;
use crate::ui_pty;

use std::fs;
use std::path::Path;
use std::thread;
use std::time::{Duration, Instant};

use sim_process::{ISEL_NEAR_REFERENCE, JOGTERM, SimProcess, WAIT};
use ui_pty::PtyRun;

const F4: &[u8] = b"\x1bOS";
const F10: &[u8] = b"\x1b[21~";
const SHIFT_F10: &[u8] = b"\x1b[21;2~";
const DOWN: &[u8] = b"\x1b[B";

/// Two moves: X 20 mm, then Y 2 mm (400 steps/mm), at 2000 Hz.
const PROGRAM: &str = "; check-out\n\
    0 8000,2000,0,2000,0,2000,0,2000\n\
    0 0,2000,800,2000,0,2000,0,2000\n\
    9\n";

fn wait_for(run: &PtyRun, needle: &str) -> String {
    run.wait_for(needle, WAIT)
        .unwrap_or_else(|screen| panic!("`{needle}` never appeared:\n{screen}"))
}

/// The console on the simulator with `program` in the editor, the axes
/// initialised and referenced, the program screen shown.
fn ready(sim: &SimProcess, dir: &Path, program: &str) -> PtyRun {
    let file = dir.join("part.isel");
    fs::write(&file, program).unwrap();
    let config = dir.join("config");
    fs::create_dir_all(&config).unwrap();
    let env = [
        ("JOGTERM_NO_KEYBOARD_QUERY", "1".to_string()),
        ("JOGTERM_CONFIG_DIR", config.display().to_string()),
        ("JOGTERM_STATE_DIR", dir.join("state").display().to_string()),
        ("RUST_BACKTRACE", "0".into()),
    ];
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let link = sim.link.display().to_string();
    let file = file.display().to_string();
    let mut run = PtyRun::spawn_sized(
        Path::new(JOGTERM),
        &["--port", &link, "--protocol", "isel", "--program", &file],
        &env,
        48,
        160,
    );
    wait_for(&run, "connected");
    run.type_keys(&[F4]);
    wait_for(&run, "Position");
    run.type_keys(&[b"i"]);
    wait_for(&run, "NOT REF");
    run.type_keys(&[b"h"]);
    wait_for(&run, "Reference run");
    run.type_keys(&[b"y"]);
    wait_for(&run, "READY");
    run.type_keys(&[F4]);
    wait_for(&run, "part.isel");
    run
}

/// F10 as a held key repeats it: every 30 ms (far beyond the 5 ms burst
/// gap), until `done` or `most` has passed.
fn hold(run: &mut PtyRun, most: Duration, mut done: impl FnMut(&mut PtyRun) -> bool) {
    let end = Instant::now() + most;
    while Instant::now() < end {
        run.send(F10);
        thread::sleep(Duration::from_millis(30));
        if done(run) {
            return;
        }
    }
}

/// The check-out has ended: its state leaves the program panel's title.
/// (Its "check-out ended" message may already be gone by the time a loaded
/// machine reads the screen: what follows the 0xFF of `x` says more.)
fn wait_ended(run: &PtyRun) {
    let end = Instant::now() + WAIT;
    loop {
        let now = screen(run);
        if now.contains("check-out ended") || !now.contains("CHECK-OUT") {
            return;
        }
        assert!(Instant::now() < end, "the check-out never ended:\n{now}");
        thread::sleep(Duration::from_millis(20));
    }
}

/// The check-out is done: its transient message, or the title's ENDED (the
/// message may already have given way to the next one when the screen is
/// read, and a hold that waited for it would go on to its bound).
fn checkout_done(run: &PtyRun) -> bool {
    let s = screen(run);
    s.contains("check-out done") || s.contains("CHECK-OUT ENDED")
}

fn screen(run: &PtyRun) -> String {
    run.screen().screen().contents()
}

/// The simulator's counter of `axis` (`show`: `X 1234 Y …`).
fn counter(sim: &mut SimProcess, axis: &str) -> i64 {
    let state = sim.device_state();
    let after = state
        .split_once(&format!("{axis} "))
        .unwrap_or_else(|| panic!("no {axis} in {state}"))
        .1;
    after
        .split_whitespace()
        .next()
        .and_then(|n| n.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no counter in {state}")) as i64
}

fn wait_counter(sim: &mut SimProcess, axis: &str, ok: impl Fn(i64) -> bool) -> i64 {
    let end = Instant::now() + WAIT;
    loop {
        let v = counter(sim, axis);
        if ok(v) {
            return v;
        }
        assert!(Instant::now() < end, "{axis} never got there: {v}");
        thread::sleep(Duration::from_millis(50));
    }
}

fn start_checkout(run: &mut PtyRun, key: &[u8]) -> String {
    run.type_keys(&[key]);
    let question = wait_for(run, "Check-out");
    run.type_keys(&[b"y"]);
    wait_for(run, "CHECK-OUT READY");
    question
}

/// The isel simulator, its axes 1 mm from the reference point (the reference
/// run is only the way to READY here). At real time: a console polls a
/// scaled simulator as fast as its faster wire answers, several times the
/// usual rate, CPU its neighbours miss (`docs/testing.md`, "The time scale").
fn isel_near_reference() -> SimProcess {
    SimProcess::start_with_files("isel", &[ISEL_NEAR_REFERENCE])
}

/// At real time: the line must still run when the hold is let go.
#[test]
fn a_hold_let_go_mid_line_pauses_and_the_next_hold_finishes_that_line_exactly() {
    let mut sim = isel_near_reference();
    let dir = tempfile::tempdir().unwrap();
    let mut run = ready(&sim, dir.path(), PROGRAM);
    start_checkout(&mut run, F10);
    // Speed factor 50 %: every speed of the line halves on the wire.
    run.type_keys(&[b"-", b"-", b"-", b"-", b"-"]);
    wait_for(&run, "CHECK-OUT READY line 2 50 %");
    // Held for a moment: line 2 (X 20 mm at 2.5 mm/s, 8 s) starts.
    hold(&mut run, Duration::from_millis(1500), |_| false);
    wait_for(&run, "PAUSED at line 2");
    let wire = sim.received();
    let sent = wire
        .find("@0A8000,1000,0,1000,0,1000,0,1000<CR>")
        .unwrap_or_else(|| panic!("the line at 50 % not on the wire: {wire}"));
    let after = &wire[sent..];
    let fd = after.find("<FD>").expect("paused with 0xFD");
    assert!(!after[fd..].contains("<FF>"), "no break: {after}");
    // Stopped in the middle of the line, without a step lost: it stays.
    let paused = wait_counter(&mut sim, "X", |x| x > 0 && x < 8000);
    eprintln!("paused at X {paused} of 8000 steps");
    thread::sleep(Duration::from_millis(300));
    assert_eq!(counter(&mut sim, "X"), paused, "it stands while paused");
    let shown = screen(&run);
    assert!(shown.contains("CHECK-OUT PAUSED line 2"), "{shown}");
    // The next hold resumes the same line with `@0S`, to its exact end, and
    // goes on with line 3 while held.
    thread::sleep(Duration::from_millis(900));
    hold(&mut run, Duration::from_secs(20), |run| {
        screen(run).contains("line 3 50 %")
    });
    let wire = sim.received();
    assert!(wire[sent..].contains("@0S<CR>"), "{wire}");
    assert_eq!(wait_counter(&mut sim, "X", |x| x == 8000), 8000);
    run.type_keys(&[b"x"]);
    wait_ended(&run);
}

#[test]
fn single_step_runs_one_line_per_press() {
    let mut sim = isel_near_reference();
    let dir = tempfile::tempdir().unwrap();
    let program = "0 400,2000,0,2000,0,2000,0,2000\n0 0,2000,400,2000,0,2000,0,2000\n9\n";
    let mut run = ready(&sim, dir.path(), program);
    start_checkout(&mut run, F10);
    run.type_keys(&[b"s"]);
    wait_for(&run, "single step");
    // Held far longer than the line takes (0.2 s): one line only.
    hold(&mut run, Duration::from_millis(1500), |_| false);
    assert_eq!(wait_counter(&mut sim, "X", |x| x == 400), 400);
    thread::sleep(Duration::from_millis(300));
    let wire = sim.received();
    assert!(
        !wire.contains("@0A0,2000,400"),
        "the second line went out in single step: {wire}"
    );
    assert_eq!(counter(&mut sim, "Y"), 0);
    // Let go, pressed again: the next line.
    thread::sleep(Duration::from_millis(900));
    hold(&mut run, Duration::from_millis(1500), |_| false);
    assert_eq!(wait_counter(&mut sim, "Y", |y| y == 400), 400);
}

#[test]
fn run_from_a_line_shows_where_it_starts_and_goes_there_first() {
    let mut sim = isel_near_reference();
    let dir = tempfile::tempdir().unwrap();
    let mut run = ready(&sim, dir.path(), PROGRAM);
    // The cursor to line 3 (the Y move).
    run.type_keys(&[DOWN, DOWN]);
    wait_for(&run, "Ln 3/");
    run.type_keys(&[SHIFT_F10]);
    let question = wait_for(&run, "from line 3");
    assert!(question.contains("1 move before it skipped"), "{question}");
    assert!(question.contains("X20"), "{question}");
    run.type_keys(&[b"y"]);
    wait_for(&run, "CHECK-OUT READY line 3");
    hold(&mut run, Duration::from_secs(20), |run| checkout_done(run));
    let wire = sim.received();
    let go = wire.find("@0M8000,").unwrap_or_else(|| panic!("{wire}"));
    assert!(
        wire[go..].contains("@0A0,2000,800,2000,0,2000,0,2000<CR>"),
        "{wire}"
    );
    assert!(!wire.contains("@0A8000"), "line 2 was skipped: {wire}");
    assert_eq!(wait_counter(&mut sim, "X", |x| x == 8000), 8000);
    assert_eq!(wait_counter(&mut sim, "Y", |y| y == 800), 800);
}

/// The console on the EMCU simulator (axes 1 mm from machine 0 at
/// power-up, so the reference run is short) with `job` in the editor, the
/// axes referenced (X counter 0), the program screen shown.
fn ready_emcu(dir: &Path, job: &str) -> (SimProcess, PtyRun) {
    let near_zero = (
        "profiles/emcu.toml",
        "base = \"emcu\"\n[sim]\nstart_position = 1.0\n",
    );
    let mut sim = SimProcess::start_with_files("emcu", &[near_zero]);
    let config = dir.join("config");
    fs::create_dir_all(config.join("profiles")).unwrap();
    fs::write(config.join(near_zero.0), near_zero.1).unwrap();
    let file = dir.join("job.emcu");
    fs::write(&file, job).unwrap();
    let env = [
        ("JOGTERM_NO_KEYBOARD_QUERY", "1".to_string()),
        ("JOGTERM_CONFIG_DIR", config.display().to_string()),
        ("JOGTERM_STATE_DIR", dir.join("state").display().to_string()),
        ("RUST_BACKTRACE", "0".into()),
    ];
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let link = sim.link.display().to_string();
    let file = file.display().to_string();
    let mut run = PtyRun::spawn_sized(
        Path::new(JOGTERM),
        &["--port", &link, "--protocol", "emcu", "--program", &file],
        &env,
        48,
        160,
    );
    wait_for(&run, "connected");
    run.type_keys(&[F4]);
    wait_for(&run, "Position");
    run.type_keys(&[b"i"]);
    wait_for(&run, "NOT REF");
    run.type_keys(&[b"h"]);
    // The answer only once the question is there: two keys in one read
    // are a burst, which moves nothing by design.
    wait_for(&run, "Reference run");
    run.type_keys(&[b"y"]);
    wait_for(&run, "READY");
    wait_counter(&mut sim, "X", |x| x == 0);
    wait_counter(&mut sim, "Y", |y| y == 0);
    run.type_keys(&[F4]);
    wait_for(&run, "job.emcu");
    (sim, run)
}

/// An EMCU job in the check-out: each line sent as a command with 0x01; a
/// hold let go in the middle of a move halts it (`@B`, manual 1.5.11), and
/// the next hold sends what is left of it, which ends exactly where the
/// line would have. At real time: the line must still run when the hold
/// is let go.
#[test]
fn an_emcu_job_line_let_go_halts_and_the_next_hold_ends_it_exactly() {
    let dir = tempfile::tempdir().unwrap();
    // X 20 mm (200 steps/mm) at 1000 Hz: 4 s.
    let (mut sim, mut run) = ready_emcu(dir.path(), "; check-out\n#E1,1000\nL1,x4000\n");
    let start = 0;
    start_checkout(&mut run, F10);
    // Held: the slot speed, then the move; let go after a moment.
    hold(&mut run, Duration::from_millis(1800), |_| false);
    wait_for(&run, "PAUSED at line 3");
    let paused = wait_counter(&mut sim, "X", |x| x > start && x < 4000);
    eprintln!("EMCU paused at X {paused} of 4000 steps");
    thread::sleep(Duration::from_millis(300));
    assert_eq!(counter(&mut sim, "X"), paused, "it stands while paused");
    let wire = sim.received();
    assert!(wire.contains("#E1,1000"), "{wire}");
    let sent = wire.find("L1,x4000").unwrap_or_else(|| panic!("{wire}"));
    assert!(wire[sent..].contains("@B"), "halted: {wire}");
    thread::sleep(Duration::from_millis(900));
    hold(&mut run, Duration::from_secs(20), |run| checkout_done(run));
    let wire = sim.received();
    let rest = format!("L1,x{}", 4000 - paused);
    assert!(wire[sent..].contains(&rest), "{rest} not sent: {wire}");
    assert_eq!(wait_counter(&mut sim, "X", |x| x == 4000), 4000);
}

/// Run from a line of an EMCU job (issue 24): the question names the move
/// skipped, the start position and the settings sent first; the wire has
/// the settings, the absolute move to the start in slot 1 and then the
/// line, and never the skipped move or the skipped output.
#[test]
fn an_emcu_job_run_from_a_line_goes_to_its_start_and_skips_the_lines_before() {
    let dir = tempfile::tempdir().unwrap();
    let job = "; from a line\n#E1,1000\n#E2,1500\nL1,x4000\nA1,1\nL2,y400\n";
    let (mut sim, mut run) = ready_emcu(dir.path(), job);
    // The cursor to line 6 (the Y move).
    run.type_keys(&[DOWN, DOWN, DOWN, DOWN, DOWN]);
    wait_for(&run, "Ln 6/");
    run.type_keys(&[SHIFT_F10]);
    // The question's last line read: the whole box is drawn (a loaded
    // machine may show its first lines a moment before the rest).
    let question = wait_for(&run, "A1,1 (line 5)");
    assert!(question.contains("from line 6"), "{question}");
    assert!(question.contains("1 move before it skipped"), "{question}");
    assert!(question.contains("X20"), "{question}");
    assert!(question.contains("#E1,1000 (line 2)"), "{question}");
    assert!(question.contains("#E2,1500 (line 3)"), "{question}");
    run.type_keys(&[b"y"]);
    wait_for(&run, "CHECK-OUT READY line 2");
    // Six lines, each a round trip, the move to the start some 5 s: a
    // loaded machine may pause the hold on the way (keys read together);
    // the hold ends as soon as the check-out is done.
    hold(&mut run, Duration::from_secs(60), |run| checkout_done(run));
    assert!(checkout_done(&run), "{}", screen(&run));
    let wire = sim.received();
    assert!(!wire.contains("L1,x4000"), "line 4 was skipped: {wire}");
    assert!(
        !wire.contains("A1,1"),
        "the skipped output is not sent: {wire}"
    );
    let e2 = wire.find("#E2,").unwrap_or_else(|| panic!("{wire}"));
    let go = wire.find("L1,X4000,Y0").unwrap_or_else(|| panic!("{wire}"));
    assert!(e2 < go, "the settings go first: {wire}");
    assert!(
        wire[go..].contains("#E1,1000"),
        "slot 1 as the job set it: {wire}"
    );
    assert!(wire[go..].contains("L2,y400"), "{wire}");
    assert_eq!(wait_counter(&mut sim, "X", |x| x == 4000), 4000);
    assert_eq!(wait_counter(&mut sim, "Y", |y| y == 400), 400);
}

/// A line the controller refuses stops the check-out at that line with
/// the code explained (here `R`: the axes were initialised, not
/// referenced), and holding on moves nothing.
#[test]
fn a_line_the_controller_refuses_stops_the_check_out_there_with_its_code() {
    let mut sim = SimProcess::start("isel");
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("part.isel");
    fs::write(&file, PROGRAM).unwrap();
    let config = dir.path().join("config");
    fs::create_dir_all(&config).unwrap();
    let env = [
        ("JOGTERM_NO_KEYBOARD_QUERY", "1".to_string()),
        ("JOGTERM_CONFIG_DIR", config.display().to_string()),
        (
            "JOGTERM_STATE_DIR",
            dir.path().join("state").display().to_string(),
        ),
        ("RUST_BACKTRACE", "0".into()),
    ];
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let link = sim.link.display().to_string();
    let file = file.display().to_string();
    let mut run = PtyRun::spawn_sized(
        Path::new(JOGTERM),
        &["--port", &link, "--protocol", "isel", "--program", &file],
        &env,
        48,
        160,
    );
    wait_for(&run, "connected");
    run.type_keys(&[F4]);
    wait_for(&run, "Position");
    run.type_keys(&[b"i"]);
    wait_for(&run, "NOT REF");
    run.type_keys(&[F4]);
    wait_for(&run, "part.isel");
    let before = counter(&mut sim, "X");
    start_checkout(&mut run, F10);
    hold(&mut run, Duration::from_millis(1500), |run| {
        screen(run).contains("CHECK-OUT STOPPED")
    });
    let shown = wait_for(&run, "the controller answered R");
    assert!(shown.contains("line 2"), "{shown}");
    assert!(shown.contains("CHECK-OUT STOPPED line 2"), "{shown}");
    // Held on: nothing more goes out, nothing moves.
    let sent = sim.received().matches("@0A").count();
    hold(&mut run, Duration::from_millis(1000), |_| false);
    assert_eq!(sim.received().matches("@0A").count(), sent);
    assert_eq!(counter(&mut sim, "X"), before);
}
