//! The real `jogterm` binary in an 80x24 pseudo-terminal, driven as an
//! operator would: against `jogterm sim --pty` (a limit switch flipped on the
//! simulator's stdin lights up on screen) and on the built-in simulator; the
//! terminal is given back after `q`, a terminating signal and a hang-up; a
//! broken configuration exits with status 2 before the terminal is touched.

use crate::sim_process;
use crate::ui_pty;

use std::path::Path;
use std::time::{Duration, Instant};

use sim_process::{JOGTERM, SimProcess, WAIT};
use ui_pty::{PtyRun, contains, rfind};

const LEAVE_ALTERNATE: &[u8] = b"\x1b[?1049l";

/// The environment every run gets: no keyboard protocol query (the test
/// terminal does not answer it), no user configuration.
fn env(config: &Path) -> Vec<(&'static str, String)> {
    vec![
        ("JOGTERM_NO_KEYBOARD_QUERY", "1".into()),
        ("JOGTERM_CONFIG_DIR", config.display().to_string()),
        (
            "JOGTERM_STATE_DIR",
            config.join("state").display().to_string(),
        ),
        ("RUST_BACKTRACE", "0".into()),
    ]
}

fn spawn(args: &[&str], config: &Path) -> PtyRun {
    let env = env(config);
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    PtyRun::spawn(Path::new(JOGTERM), args, &env)
}

fn wait_for(run: &PtyRun, needle: &str) -> String {
    run.wait_for(needle, WAIT)
        .unwrap_or_else(|screen| panic!("`{needle}` never appeared:\n{screen}"))
}

/// The screen row that holds `needle`.
fn row_with(screen: &str, needle: &str) -> Option<String> {
    screen
        .lines()
        .find(|l| l.contains(needle))
        .map(str::to_string)
}

/// Quit with `q` and check the terminal is back: main screen, cursor shown.
fn quit_and_check(run: &mut PtyRun) {
    run.type_keys(&[b"q"]);
    let code = run.wait_exit(WAIT);
    run.drain(Duration::from_secs(5));
    let screen = run.screen();
    assert_eq!(code, Some(0), "{}", screen.screen().contents());
    assert!(
        !screen.screen().alternate_screen(),
        "still on the alternate screen"
    );
    assert!(!screen.screen().hide_cursor(), "cursor still hidden");
    assert!(rfind(&run.output(), LEAVE_ALTERNATE).is_some());
}

#[test]
fn a_limit_switch_flipped_on_the_simulator_lights_up() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut sim = SimProcess::start("isel");
    let mut run = spawn(&["--port", &sim.link.display().to_string()], config.path());
    let screen = wait_for(&run, "connected");
    assert!(screen.contains("isel"), "{screen}");
    // Port 3 is read with the positions; X1 is unlit.
    let screen = wait_for(&run, "○X1");
    let row = row_with(&screen, "○X1").expect("the limit switch row");
    assert!(row.contains("in 3"), "{row}");

    sim.control("set limit-x1 on");
    let screen = wait_for(&run, "●X1");
    let row = row_with(&screen, "●X1").expect("the limit switch row");
    assert!(row.contains("in 3"), "{row}");
    assert!(
        screen.contains("LIMIT"),
        "the state word says so:\n{screen}"
    );
    sim.control("set limit-x1 off");
    wait_for(&run, "○X1");
    quit_and_check(&mut run);
}

/// The port timeline (`w`) of the running console shows a pulse of limit X1
/// with its times, as the device task's recorder saw it, and `--log` has
/// the change decoded.
#[test]
fn the_port_timeline_shows_a_pulse_and_the_log_decodes_it() {
    let config = tempfile::tempdir().expect("tempdir");
    let log = config.path().join("traffic.log");
    let mut sim = SimProcess::start("isel");
    let mut run = spawn(
        &[
            "--port",
            &sim.link.display().to_string(),
            "--log",
            &log.display().to_string(),
        ],
        config.path(),
    );
    wait_for(&run, "○X1");
    run.type_keys(&[b"w"]);
    wait_for(&run, "Port timeline");
    wait_for(&run, "no input has changed since the link came up");
    sim.control("pulse limit-x1 500");
    let screen = wait_for(&run, "limit X1 (in3.0) 0 free");
    assert!(
        screen.contains("limit X1 (in3.0) 1 hit"),
        "both edges listed:\n{screen}"
    );
    let lane = row_with(&screen, "limit X1  ").expect("the limit X1 lane");
    assert!(
        lane.matches('│').count() >= 1,
        "an edge in the lane: {lane}"
    );
    run.type_keys(&[b"w"]);
    wait_for(&run, "○X1");
    quit_and_check(&mut run);
    let text = std::fs::read_to_string(&log).expect("the log");
    let lines: Vec<&str> = text.lines().filter(|l| l.contains(" # input ")).collect();
    assert_eq!(lines.len(), 2, "{text}");
    assert!(
        lines[0].ends_with("ms") && lines[0].contains("limit X1 (in3.0) 1 hit, t "),
        "{}",
        lines[0]
    );
    assert!(
        lines[1].contains("limit X1 (in3.0) 0 free, t "),
        "{}",
        lines[1]
    );
}

#[test]
fn the_built_in_simulator_runs_by_default_and_its_inputs_can_be_flipped() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut run = spawn(&[], config.path());
    wait_for(&run, "connected");
    let screen = wait_for(&run, "Simulator inputs");
    assert!(
        screen.contains("limit-x1=0") && screen.contains("estop1=1"),
        "the simulator's levels are shown from the start:\n{screen}"
    );
    // Tab to the simulator panel (past the port bits; the jog keypad has
    // focus at start, the command line is not in the ring), walk to
    // limit-x1 and set it, key by key (keys written together are a burst).
    run.type_keys(&[b"\t", b"\t"]);
    wait_for(&run, "flip");
    let names = screen
        .lines()
        .skip_while(|l| !l.contains("Simulator inputs"))
        .skip(1)
        .take_while(|l| !l.contains("──"))
        .flat_map(|l| {
            l.split_whitespace()
                .filter_map(|w| w.split_once('=').map(|(n, _)| n.to_string()))
                .collect::<Vec<_>>()
        })
        .collect::<Vec<_>>();
    let steps = names
        .iter()
        .position(|n| n == "limit-x1")
        .expect("limit-x1 is listed");
    for _ in 0..steps {
        run.type_keys(&[b"\x1b[B"]);
    }
    run.type_keys(&[b"1"]);
    wait_for(&run, "limit-x1=1");
    wait_for(&run, "●X1");
    // Enter flips it back.
    run.type_keys(&[b"\r"]);
    wait_for(&run, "limit-x1=0");
    wait_for(&run, "○X1");
    quit_and_check(&mut run);
}

/// Issue 20, finding 2: a drive that rejects every request before `02`,
/// `0A` included, got `2C` and `0A` alternately at line speed (about 90
/// frames/s) and the message line repeated "the error code cannot be read".
/// The console must poll it slowly and say once what to do.
#[test]
fn an_emp_console_on_a_drive_that_is_switched_off_sends_at_most_2_frames_a_second() {
    const FRAME: u64 = jogterm::proto::emp::FRAME_WIRE_LEN as u64;
    let config = tempfile::tempdir().expect("tempdir");
    let mut sim = SimProcess::start_variant("emp", &[], &["emp-rejects-0a-before-on"]);
    let link = sim.link.display().to_string();
    let mut run = spawn(&["--protocol", "emp", "--port", &link], config.path());
    // Start-up is over once the state is read back.
    wait_for(&run, "state read back");
    let (start, before) = (Instant::now(), sim.received_total());
    std::thread::sleep(Duration::from_secs(4));
    let after = sim.received_total();
    let seconds = start.elapsed().as_secs_f64();
    let frames = (after - before) / FRAME;
    assert!(
        frames as f64 <= 2.0 * seconds,
        "{frames} frames in {seconds:.1} s"
    );
    // Told once what to do (the traffic console keeps the notices).
    let screen = wait_for(&run, "drive 11 is switched off: switch it on (i)");
    assert_eq!(screen.matches("is switched off").count(), 1, "{screen}");
    assert!(!screen.contains("cannot be read"), "{screen}");
    quit_and_check(&mut run);
}

#[test]
fn a_typed_command_is_refused_with_its_reason_then_sent() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut run = spawn(&[], config.path());
    wait_for(&run, "connected");
    // Initialised, the controller's axes are known to the check.
    run.type_keys(&[b"i"]);
    wait_for(&run, "NOT REF");
    run.type_keys(&[b":"]);
    run.type_text("@0A5000,900");
    wait_for(&run, "> @0A5000,900");
    run.type_keys(&[b"\r"]);
    let screen = wait_for(&run, "^ ");
    assert!(screen.contains("pairs"), "{screen}");
    // Ctrl-U clears; the version query goes out and its answer is shown.
    run.type_keys(&[b"\x15"]);
    run.type_text("@0V");
    run.type_keys(&[b"\r"]);
    // The answer is in the message line (the console may have scrolled on).
    wait_for(&run, "@0V = isel");
    run.type_keys(&[b"\t"]);
    quit_and_check(&mut run);
}

#[test]
fn the_terminal_is_cooked_again_after_quitting() {
    let config = tempfile::tempdir().expect("tempdir");
    let script = format!("'{JOGTERM}'; stty -a");
    let env = env(config.path());
    let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let mut run = PtyRun::spawn(Path::new("/bin/sh"), &["-c", &script], &env);
    wait_for(&run, "connected");
    run.send(b"q");
    assert_eq!(run.wait_exit(WAIT), Some(0));
    run.drain(Duration::from_secs(5));
    let output = run.output();
    let after = &output[rfind(&output, LEAVE_ALTERNATE).expect("left the TUI")..];
    let stty = String::from_utf8_lossy(after);
    for flag in ["icanon", "echo", "isig"] {
        assert!(
            stty.split_whitespace().any(|w| w == flag),
            "`{flag}` is not set again:\n{stty}"
        );
    }
}

#[test]
fn a_terminate_signal_stops_and_gives_the_terminal_back() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut run = spawn(&[], config.path());
    wait_for(&run, "connected");
    let pid = run.child.process_id().expect("pid");
    // SAFETY: a signal to the child we started.
    unsafe {
        libc::kill(pid as libc::pid_t, libc::SIGTERM);
    }
    let code = run.wait_exit(WAIT);
    run.drain(Duration::from_secs(5));
    assert_eq!(code, Some(0), "{}", run.screen().screen().contents());
    let screen = run.screen();
    assert!(!screen.screen().alternate_screen());
    assert!(!screen.screen().hide_cursor());
    assert!(
        contains(&run.output(), b"\x1b[?2004h"),
        "bracketed paste was never switched on"
    );
    assert!(
        !screen.screen().bracketed_paste(),
        "bracketed paste left on after SIGTERM"
    );
}

#[test]
fn a_hang_up_ends_the_console_promptly() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut run = spawn(&[], config.path());
    wait_for(&run, "connected");
    let started = Instant::now();
    // Closing the master is the terminal going away: the kernel sends SIGHUP.
    run.close_master();
    let code = run.wait_exit(WAIT);
    assert!(
        code.is_some(),
        "still running {:?} after the hang-up",
        started.elapsed()
    );
}

#[test]
fn a_broken_configuration_exits_2_before_touching_the_terminal() {
    let config = tempfile::tempdir().expect("tempdir");
    std::fs::create_dir_all(config.path().join("themes")).expect("themes");
    std::fs::write(
        config.path().join("themes/loud.toml"),
        "name = \"loud\"\n[styles]\nlit = { fg = \"neon\" }\n",
    )
    .expect("theme");
    let mut run = spawn(&["--theme", "loud"], config.path());
    assert_eq!(run.wait_exit(WAIT), Some(2));
    run.drain(Duration::from_secs(5));
    let output = run.output();
    let text = String::from_utf8_lossy(&output);
    assert!(text.contains("loud.toml:3:"), "{text}");
    assert!(text.contains("error:"), "{text}");
    assert!(
        !contains(&output, b"\x1b[?1049h"),
        "the alternate screen was entered"
    );
}

/// Issue 13: the command line takes every printable key, so it is entered
/// only with `:`, never by Tab; while it has the keys the console says so
/// and the terminal's cursor stands where the next character goes; Tab
/// leaves it, the cursor is hidden again, and `i` reaches the main keys.
#[test]
fn the_command_line_is_entered_only_with_colon_and_shows_where_typing_lands() {
    let config = tempfile::tempdir().expect("tempdir");
    let mut run = spawn(&[], config.path());
    wait_for(&run, "connected");
    for _ in 0..4 {
        run.type_keys(&[b"\t"]);
        let screen = run.screen();
        assert!(
            !screen.screen().contents().contains("TYPING"),
            "Tab reached the command line:\n{}",
            screen.screen().contents()
        );
        assert!(
            screen.screen().hide_cursor(),
            "a cursor off the command line"
        );
    }
    run.type_keys(&[b":"]);
    wait_for(&run, "TYPING, Tab leaves");
    run.type_text("@0P");
    let screen = wait_for(&run, "> @0P");
    let row = screen
        .lines()
        .position(|l| l.starts_with("> @0P"))
        .expect("the command line row");
    let parser = run.screen();
    assert!(
        !parser.screen().hide_cursor(),
        "no cursor on the command line"
    );
    assert_eq!(
        parser.screen().cursor_position(),
        (row as u16, 5),
        "the cursor after `@0P`"
    );
    run.type_keys(&[b"\t"]);
    let end = Instant::now() + WAIT;
    while run.screen().screen().contents().contains("TYPING") {
        assert!(Instant::now() < end, "Tab did not leave the command line");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(run.screen().screen().hide_cursor(), "the cursor stayed");
    // `i` is the main key again: the controller is initialised.
    run.type_keys(&[b"i"]);
    wait_for(&run, "NOT REF");
    let screen = run.screen().screen().contents();
    assert!(
        screen.contains("> @0P"),
        "the typed line is kept:\n{screen}"
    );
    quit_and_check(&mut run);
}
