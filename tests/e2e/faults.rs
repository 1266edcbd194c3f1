//! The fault-injection suite (`docs/faults.md`): scripted scenarios against
//! `jogterm sim --pty`, each asserting what the operator sees (the message
//! line names what happened and what to do), what the controller received
//! (no motion command repeated), and that nothing panicked or hung (every
//! wait is bounded). Its own runner prints the totals.

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod faults_runner;
mod faults_steps;

// The harness this crate shares with the e2e crate (`main.rs`) beside it:
// the scenarios use part of it, the e2e tests the rest.
#[allow(dead_code)]
mod faults_support;
#[allow(dead_code)]
mod sim_process;
#[allow(dead_code)]
mod ui_pty;

use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use faults_runner::{self as runner, Scenario, Tally};
use faults_steps::assert_isel_motion;
use faults_support::console::Console;
use faults_support::wire::{emcu_motion, emp_after, emp_motion, isel_messages, isel_motion};
use sim_process::{JOGTERM, WAIT, contains_panic};
use sim_process::{SimProcess, wait_child};

/// A long X move (15 s at 4000 Hz) for a fault to interrupt.
const LONG_MOVE: &str = "@0M60000,4000,0,4000,0,4000,0,4000";
/// A short X move (about 1 s) to try after a fault.
const SHORT_MOVE: &str = "@0M4000,4000,0,4000,0,4000,0,4000";
/// An X move of about 2 s: long enough to arm a fault for its answer
/// under load, short enough that its deadline (the move plus a quarter
/// plus 1 s, docs/protocols.md) keeps the scenario brief.
const MEDIUM_MOVE: &str = "@0M8000,4000,0,4000,0,4000,0,4000";

/// The console connected to a fresh isel simulator, initialised and
/// referenced (`@0N7`), so moves are allowed.
fn ready_isel() -> (SimProcess, Console) {
    let sim = SimProcess::start("isel");
    let mut console = Console::start(&sim);
    console.make_ready();
    (sim, console)
}

/// Go to `target` with the keypad's go-to prompt (`g`, the target, Enter);
/// waits until the controller has the move and the console says MOVING.
/// The motion command the controller received.
fn start_go_to(sim: &mut SimProcess, console: &mut Console, target: &str) -> String {
    console.keys(b"g");
    console.keys(target.as_bytes());
    console.wait_for(target);
    console.keys(b"\r");
    let received = sim.wait_received("the go-to move", |r| !isel_motion(r).is_empty());
    console.wait_until("MOVING in the status bar", |s| {
        s.lines().next().is_some_and(|l| l.contains("MOVING"))
    });
    isel_motion(&received).remove(0)
}

/// Wait until the controller has received the whole `command`.
fn wait_received_command(sim: &mut SimProcess, command: &str) {
    sim.wait_received(command, |r| isel_messages(r).iter().any(|m| m == command));
}

/// Start a move from the console and wait until it runs (the controller
/// has the whole command and the console says MOVING).
fn start_move(sim: &mut SimProcess, console: &mut Console, command: &str) {
    console.command(command);
    wait_received_command(sim, command);
    console.wait_until("MOVING in the status bar", |s| {
        s.lines().next().is_some_and(|l| l.contains("MOVING"))
    });
}

/// The X position the console shows (the steps column of the X row:
/// `X⌂   10.000 mm   10.000    4000 …`).
fn x_steps(screen: &str) -> Option<i64> {
    let row = screen.lines().find(|l| l.starts_with('X'))?;
    row.split_whitespace().nth(4)?.parse().ok()
}

/// A move typed now is refused with its reason (by the command line's
/// check, or by the device task) and never sent.
fn assert_move_refused(console: &mut Console) {
    console.command(SHORT_MOVE);
    let screen = console.wait_until("the typed move refused", |s| {
        s.lines()
            .any(|l| l.starts_with("^ ") || l.contains("refused"))
    });
    let reason = screen
        .lines()
        .find(|l| l.starts_with("^ ") || l.contains("refused"))
        .unwrap_or_default();
    assert!(
        reason.contains(": ") || reason.contains("first"),
        "the refusal says what to do: {reason}"
    );
}

/// A byte missing from a poll's reply: the console says the reply was
/// garbled (information: polling reads it again), keeps the link, and a move
/// afterwards is sent exactly once and ends where it should.
fn dropped_byte_in_a_reply(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    sim.control("fault drop-byte");
    t.fault();
    // The next reply is a poll's (the position or a port), or, right after
    // a reconnect, the read-back's, which then starts again.
    let screen = console.wait_until("the garbled reply named", |s| {
        s.lines().any(|l| {
            l.contains("the reply to @0") && l.contains("was garbled")
                || l.contains("reply could not be read")
        })
    });
    let line = screen
        .lines()
        .map(str::trim)
        .find(|l| l.contains("garbled") || l.contains("could not be read"))
        .unwrap_or_default();
    assert!(line.starts_with("·"), "information, nothing to do: {line}");
    console.command(SHORT_MOVE);
    wait_received_command(&mut sim, SHORT_MOVE);
    console.wait_until("READY after the move", |s| {
        s.lines().next().is_some_and(|l| l.contains("READY")) && x_steps(s) == Some(4000)
    });
    assert!(console.status_bar().contains("connected"));
    assert_isel_motion(&sim.received(), &[SHORT_MOVE]);
    sim.assert_alive();
    console.quit();
}

/// A corrupted byte in the answer to a move: the outcome is unknown, so
/// the console says so and what to check, reads the state back, and does
/// not send the move again.
fn corrupted_byte(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    console.command(MEDIUM_MOVE);
    wait_received_command(&mut sim, MEDIUM_MOVE);
    // The next message the controller produces is the move's answer `0`.
    sim.control("fault corrupt-byte");
    t.fault();
    let line = console.wait_message(&[
        "the outcome of the command is unknown",
        "check the cable",
        MEDIUM_MOVE,
    ]);
    assert!(line.starts_with("!!"), "{line}");
    console.wait_until("READY with the position read back", |s| {
        s.lines().next().is_some_and(|l| l.contains("READY"))
            && x_steps(s) == Some(8000)
            && s.contains("the reply to @0M")
    });
    assert_isel_motion(&sim.received(), &[MEDIUM_MOVE]);
    sim.assert_alive();
    console.quit();
}

/// The answer to a move withheld: after the move's deadline the console
/// reports the timeout and the lost link with what to check, reconnects,
/// stops and reads back; the move is not sent again.
fn withheld_reply(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    console.command(MEDIUM_MOVE);
    wait_received_command(&mut sim, MEDIUM_MOVE);
    sim.control("fault withhold");
    t.fault();
    let line = console.wait_message(&[
        "No reply within",
        "check the cable, the baud rate and the controller type",
        MEDIUM_MOVE,
    ]);
    assert!(line.starts_with("!!"), "{line}");
    console.wait_message(&[
        &format!("link lost: no reply to {MEDIUM_MOVE}"),
        "motion state unknown until the controller is read again",
    ]);
    console.wait_until("connected and READY again", |s| {
        let bar = s.lines().next().unwrap_or_default();
        bar.contains("connected") && bar.contains("READY")
    });
    let received = sim.received();
    assert_isel_motion(&received, &[MEDIUM_MOVE]);
    let after: Vec<String> = isel_messages(&received)
        .into_iter()
        .skip_while(|m| m != MEDIUM_MOVE)
        .skip(1)
        .collect();
    assert_eq!(
        after.first().map(String::as_str),
        Some("<FD>"),
        "the reconnect stops first: {after:?}"
    );
    sim.assert_alive();
    console.quit();
}

/// The line closed under a go-to move (`g X150`, 6 s) and reopened 500 ms
/// later: the console says the link is lost and the motion state unknown,
/// reconnects, stops the move first and reads the state back; the move is
/// not sent again.
fn port_closed_mid_move_and_reopened(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    let go_to = start_go_to(&mut sim, &mut console, "X150");
    sim.control("fault close 500");
    t.fault();
    console.wait_for("motion state unknown until the controller is read again");
    console.wait_for("reconnecting");
    let screen = console.wait_until("the state read back after the reconnect", |s| {
        s.lines()
            .nth(1)
            .is_some_and(|l| l.contains("state read back"))
            && s.lines().next().is_some_and(|l| l.contains("READY"))
    });
    let x = x_steps(&screen).expect("the X position");
    assert!(x > 0 && x < 60_000, "the move was stopped: X {x}\n{screen}");
    let received = sim.received();
    assert_isel_motion(&received, &[&go_to]);
    let after: Vec<String> = isel_messages(&received)
        .into_iter()
        .skip_while(|m| *m != go_to)
        .skip(1)
        .collect();
    assert_eq!(
        after.first().map(String::as_str),
        Some("<FD>"),
        "the reopened line is stopped first: {after:?}"
    );
    sim.assert_alive();
    console.quit();
}

/// An E-stop circuit opened during a move: the controller answers `9`; the
/// console shows E-STOP and tells the operator to release it, then
/// initialise and reference; a move typed now is refused, not sent.
fn estop_during_a_move(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    start_move(&mut sim, &mut console, LONG_MOVE);
    sim.control("set estop1 open");
    t.fault();
    let line = console.wait_message(&[
        "release the emergency stop, then initialise (i) and reference (h)",
        "answer 9",
    ]);
    assert!(line.starts_with("!!"), "{line}");
    console.wait_until("E-STOP in the status bar", |s| {
        s.lines().next().is_some_and(|l| l.contains("E-STOP"))
    });
    assert_move_refused(&mut console);
    sim.control("set estop1 closed");
    assert_isel_motion(&sim.received(), &[LONG_MOVE]);
    sim.assert_alive();
    console.quit();
}

/// A limit switch during a move: the controller answers `2`; the console
/// shows LIMIT and says to initialise and reference.
fn limit_switch_during_a_move(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    start_move(&mut sim, &mut console, LONG_MOVE);
    sim.control("set limit-x2 on");
    t.fault();
    let line = console.wait_message(&["initialise (i) and reference (h)", "answer 2"]);
    assert!(line.starts_with("!!"), "{line}");
    console.wait_until("LIMIT in the status bar", |s| {
        s.lines().next().is_some_and(|l| l.contains("LIMIT"))
    });
    assert_move_refused(&mut console);
    sim.control("set limit-x2 off");
    assert_isel_motion(&sim.received(), &[LONG_MOVE]);
    sim.assert_alive();
    console.quit();
}

/// The stop key on the controller during a move (typed as a raw command):
/// it answers `F`; the console says the move was stopped and that start
/// resumes it or stop discards it. Nothing is sent again.
fn stop_button_on_the_controller(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    start_move(&mut sim, &mut console, LONG_MOVE);
    sim.control("press stop");
    t.fault();
    let line = console.wait_message(&[
        "stopped by the stop key",
        "start to resume the move, or stop to discard it",
        "answer F",
    ]);
    assert!(line.starts_with("!!"), "{line}");
    assert_isel_motion(&sim.received(), &[LONG_MOVE]);
    sim.assert_alive();
    console.quit();
}

/// Small deterministic pseudo-random numbers (xorshift64*), so a failing
/// fuzz run can be repeated.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n.max(1)
    }
}

/// Bursts of garbage fuzzed during the garbage scenario.
const GARBAGE_BURSTS: u32 = 40;

/// Unsolicited garbage while polling: the console names the bytes, keeps
/// the link; then random bursts at random moments (seeded): no panic, no
/// motion, and the console still answers a typed command afterwards.
fn unsolicited_garbage(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    sim.control("fault garbage ?!xyz");
    t.fault();
    // Bytes that arrive while a poll's reply is awaited garble that reply;
    // the others are named as unexpected.
    console.wait_until("the garbage named", |s| {
        s.contains("unexpected bytes from the controller") || s.contains("was garbled")
    });
    let seed = 0x5EED_F00D_u64;
    let mut rng = Rng(seed);
    for _ in 0..GARBAGE_BURSTS {
        let len = 1 + rng.below(12);
        let hex: Vec<String> = (0..len)
            .map(|_| format!("{:02x}", rng.below(256)))
            .collect();
        sim.control(&format!("fault garbage hex:{}", hex.join("")));
        t.fuzzed += 1;
        std::thread::sleep(Duration::from_millis(rng.below(60)));
    }
    t.fault();
    console.wait_until("connected again after the garbage", |s| {
        s.lines().next().is_some_and(|l| l.contains("connected"))
    });
    // Still operable: once the garbage is behind it (polls go on past the
    // last burst), a typed query is answered, the first time it is typed.
    let polls = |r: &str| isel_messages(r).iter().filter(|m| *m == "@0P").count();
    let before = polls(&sim.received());
    sim.wait_received("polls after the last burst", |r| polls(r) >= before + 3);
    console.command("@0V");
    console.wait_for("@0V = isel");
    assert_isel_motion(&sim.received(), &[]);
    sim.assert_alive();
    console.quit();
}

/// A hang-up (the terminal goes away: SIGHUP) during a move: jogterm stops
/// the machine (the stop bytes reach the controller, which comes to rest
/// long before the move's end) and ends without a panic.
fn sighup_during_a_move(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    start_move(&mut sim, &mut console, LONG_MOVE);
    console.run.close_master();
    t.fault();
    console.assert_exits(None);
    let received = sim.wait_received("the stop after the hang-up", |r| {
        isel_messages(r)
            .iter()
            .skip_while(|m| *m != LONG_MOVE)
            .any(|m| m == "<FD>")
    });
    assert_isel_motion(&received, &[LONG_MOVE]);
    // Stopped with a ramp, well before the move's end (15 s away).
    let state = sim.wait_device("idle", |d| d.ends_with("| idle"));
    assert!(
        !state.contains("X 60000"),
        "the move ran to its end: {state}"
    );
    sim.assert_alive();
}

/// A hang-up (SIGHUP) during a continuous jog held with key repeats: jogterm
/// stops the machine and ends; the jog's one move was sent once and the
/// machine comes to rest.
fn sighup_during_a_continuous_jog(t: &mut Tally) {
    let (mut sim, mut console) = ready_isel();
    // Continuous jogging, then hold X+ (Right) as a terminal repeats it.
    console.keys(b"c");
    console.wait_for("continuous");
    // Then the terminal goes away between two repeats.
    console.hold_until_jogging(b"\x1b[C", 5);
    console.run.close_master();
    t.fault();
    console.assert_exits(None);
    let received = sim.wait_received("the stop after the hang-up", |r| {
        isel_messages(r)
            .iter()
            .skip_while(|m| !faults_support::wire::isel_moves(m))
            .any(|m| m == "<FD>")
    });
    let motion = isel_motion(&received);
    assert_eq!(motion.len(), 1, "one move for the jog: {motion:?}");
    sim.wait_device("idle", |d| d.ends_with("| idle"));
    sim.assert_alive();
}

/// `jogterm send` whose reply is withheld: it ends with status 3 and says
/// the link failed and what to check, within its deadline.
fn withheld_reply_to_send(t: &mut Tally) {
    let mut sim = SimProcess::start("isel");
    let child = Command::new(JOGTERM)
        .args(["send", "--protocol", "isel", "--port"])
        .arg(&sim.link)
        .args(["@07", "@0N7", MEDIUM_MOVE, "@0P"])
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run jogterm send");
    sim.wait_received("the move", |r| {
        isel_messages(r).iter().any(|m| m == MEDIUM_MOVE)
    });
    sim.control("fault withhold");
    t.fault();
    let out = wait_child(child, "jogterm send");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(!contains_panic(&out.stderr), "{stderr}");
    assert!(stderr.contains("link failure"), "{stderr}");
    assert!(
        stderr.contains(&format!("timeout to {MEDIUM_MOVE}")),
        "{stderr}"
    );
    assert!(
        stderr.contains("check the cable, the baud rate and the controller type"),
        "{stderr}"
    );
    assert_isel_motion(&sim.received(), &[MEDIUM_MOVE]);
    sim.assert_alive();
}

/// `jogterm poll` whose `@0P` reply is withheld: poll moves nothing, so a
/// silent isel is a busy controller to it (a stored program runs, manual
/// 3.1; `docs/device.md`, "A controller that is busy"): it says so and what
/// to check, repeats the read, goes on once it is answered and ends with 0
/// on Ctrl-C; every sample is a whole line; nothing moved. (Before issue 24
/// it ended with status 3, a link failure.)
fn withheld_reply_to_poll(t: &mut Tally) {
    let mut sim = SimProcess::start("isel");
    let child = Command::new(JOGTERM)
        .args([
            "poll",
            "--protocol",
            "isel",
            "--json",
            "--interval-ms",
            "20",
            "--port",
        ])
        .arg(&sim.link)
        .env("JOGTERM_CONFIG_DIR", sim.dir.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run jogterm poll");
    sim.wait_received("a few polls", |r| {
        isel_messages(r).iter().filter(|m| *m == "@0P").count() >= 5
    });
    let before = sim.received().len();
    sim.control("fault withhold");
    t.fault();
    // Polled on after the repeat: more reads than the withheld one.
    sim.wait_received("polls after the withheld reply", |r| {
        isel_messages(&r[before..])
            .iter()
            .filter(|m| *m == "@0P")
            .count()
            >= 10
    });
    // SAFETY: a plain kill(2) of the child this scenario started.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let out = wait_child(child, "jogterm poll");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(!contains_panic(&out.stderr), "{stderr}");
    assert!(
        stderr.contains("the controller is busy: a program runs; waiting (no reply to @0"),
        "{stderr}"
    );
    assert!(stderr.contains("check the line"), "{stderr}");
    assert!(stderr.contains("the controller answers again"), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.lines().count() >= 1, "samples before the fault");
    for line in stdout.lines() {
        assert!(
            line.starts_with('{') && line.ends_with('}'),
            "a whole JSON sample per line: {line}"
        );
    }
    assert_isel_motion(&sim.received(), &[]);
    sim.assert_alive();
}

/// EMCU: a poll's answer withheld: the console says the link is lost and
/// what to check, reconnects and reads the state back; nothing moved.
fn withheld_reply_emcu(t: &mut Tally) {
    let mut sim = SimProcess::start("emcu");
    let console = Console::start(&sim);
    sim.control("fault withhold");
    t.fault();
    console.wait_message(&[
        "No reply within",
        "check the cable, the baud rate and the controller type",
    ]);
    console.wait_message(&["link lost: no reply to", "motion state unknown"]);
    console.wait_until("connected again", |s| {
        s.lines().next().is_some_and(|l| l.contains("connected"))
    });
    let motion = emcu_motion(&sim.received());
    assert!(motion.is_empty(), "nothing was to move: {motion:?}");
    sim.assert_alive();
    console.quit();
}

/// The recovery files in a console's state directory.
fn recoveries(sim: &SimProcess) -> Vec<String> {
    ui_pty::recoveries(&sim.dir.path().join("state"))
}

/// SIGKILL of jogterm while a program is being edited: the file on disk is
/// untouched, the next start offers the edits back and restores them, and
/// nothing moved on either start.
fn sigkill_mid_edit(t: &mut Tally) {
    const PROGRAM: &str = "; drill\n7 7\nm8000,8000,8000,8000\n9\n";
    let mut sim = SimProcess::start("isel");
    let file = sim.dir.path().join("drill.isel");
    std::fs::write(&file, PROGRAM).expect("write the program");
    let file_arg = file.display().to_string();
    let mut console = Console::start_with(&sim, &["--program", &file_arg]);
    console.wait_for("drill.isel");
    // A new comment on the first line (Tab types the blank whatever moves).
    // Typed key by key (a burst would type too, but is no person typing):
    // the recovery file may be written after the first key already, so wait
    // until it holds the whole line.
    console.keys(b";\tkept-after-kill\r");
    console.wait_for("kept-after-kill");
    let end = Instant::now() + WAIT;
    let state = sim.dir.path().join("state").join("recovery");
    let kept = || {
        recoveries(&sim).iter().any(|name| {
            std::fs::read_to_string(state.join(name)).is_ok_and(|t| t.contains("kept-after-kill"))
        })
    };
    while !kept() {
        assert!(Instant::now() < end, "no recovery file holds the edit");
        std::thread::sleep(Duration::from_millis(50));
    }
    let pid = console.run.child.process_id().expect("pid");
    // SAFETY: a signal to our own child.
    assert_eq!(unsafe { libc::kill(pid as i32, libc::SIGKILL) }, 0);
    t.fault();
    assert!(
        console.run.wait_exit(WAIT).is_some(),
        "not ended by SIGKILL"
    );
    drop(console);
    assert_eq!(
        std::fs::read_to_string(&file).expect("read"),
        PROGRAM,
        "the file is untouched"
    );

    let mut console = Console::start(&sim);
    // Everything a step looks for in one wait: a screen read in the middle
    // of a redraw shows the new frame's first rows over the old one's.
    console.wait_until("the recovered edits of drill.isel offered", |s| {
        s.contains("Recovered edits") && s.contains("drill.isel")
    });
    console.keys(b"y");
    console.wait_until("the recovered program in the editor", |s| {
        s.contains("kept-after-kill") && s.contains("m8000,8000,8000,8000")
    });
    assert_isel_motion(&sim.received(), &[]);
    sim.assert_alive();
    console.assert_no_panic();
}

/// The EMP machine of the scenarios: the shipped `emp` profile with the axis
/// at 1 mm at power-up, so that a reference run takes under a second.
const EMP_PROFILE: &str = "base = \"emp\"\n\n[sim]\nstart_position = 1.0\n";

/// The reference run of the shipped profile (`emp.home_fast` 20,
/// `emp.home_slow` 4, counts per ms at 1 kHz).
const EMP_HOME: &str = "2611000000140400";

/// The stop frame of the shipped profile (`emp.stop = "hold"`: `08`).
const EMP_STOP: &str = "0811000000000000";

/// The first line of the screen holds `word`.
fn status_has(screen: &str, word: &str) -> bool {
    screen.lines().next().is_some_and(|l| l.contains(word))
}

/// Initialise (`i`) and reference (`h`, confirmed with `y`) until READY.
fn emp_initialise_and_reference(console: &mut Console) {
    console.keys(b"i");
    // Fresh: NOT REF. After a long action was given up: still ERROR; the
    // message line says it is initialised, and once no message is shown,
    // the detail there asks only for the reference run.
    console.wait_until("initialised: the reference run left", |s| {
        status_has(s, "NOT REF")
            || s.lines().nth(1).is_some_and(|l| {
                l.contains("initialised: drives") || l.contains(": reference the axes (h)")
            })
    });
    console.keys(b"h");
    console.wait_for("Start the reference run?");
    console.keys(b"y");
    console.wait_until("READY after the reference run", |s| status_has(s, "READY"));
}

/// The console against a fresh EMP simulator, initialised and referenced.
fn ready_emp() -> (SimProcess, Console) {
    let sim = SimProcess::start_with_files("emp", &[("profiles/emp.toml", EMP_PROFILE)]);
    let mut console = Console::start(&sim);
    emp_initialise_and_reference(&mut console);
    (sim, console)
}

/// [`ready_emp`] with the drive made to stay busy and not move (`fault
/// stall`), counted as the scenario's fault.
fn stalled_emp(t: &mut Tally) -> (SimProcess, Console) {
    let (mut sim, console) = ready_emp();
    sim.control("fault stall");
    t.fault();
    (sim, console)
}

/// A reference run (`26`) begun at `started` on a stalled drive: given up
/// by the stall watchdog (well before the reference deadline), the drive
/// stopped and the operator told what to check, the run sent once (`once`
/// says which), moves refused; the console quits.
fn assert_homing_stalled(mut sim: SimProcess, mut console: Console, started: Instant, once: &str) {
    assert_given_up(
        &mut sim,
        &console,
        EMP_HOME,
        &["homing stalled", "Check the axis for a blockage"],
    );
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "the watchdog, not the deadline: {:?}",
        started.elapsed()
    );
    let motion = emp_motion(&sim.received());
    assert_eq!(motion, [EMP_HOME, EMP_HOME], "{once}");
    assert_emp_motion_refused(&mut sim, &mut console);
    sim.assert_alive();
    console.quit();
}

/// The first non-query frame the drive received after `frame`: polls
/// (`2C`, `40`) and error reads (`0A`) go on while a long action runs.
fn emp_first_command_after(received: &str, frame: &str) -> Option<String> {
    emp_after(received, frame)
        .into_iter()
        .find(|f| !(f.starts_with("2C") || f.starts_with("40") || f.starts_with("0A")))
}

/// After a long action was given up: the operator is told, in the message
/// line, that the drive stayed busy, what `needles` say, and to initialise
/// and reference; the state is ERROR; the stop frame was the first command
/// the drive received after `frame`.
fn assert_given_up(sim: &mut SimProcess, console: &Console, frame: &str, needles: &[&str]) {
    let mut all = vec![
        "drive 11 (X) stayed busy (55)",
        "initialise (i) and reference (h)",
        frame,
    ];
    all.extend_from_slice(needles);
    // The fault as a danger message (`!!`) in the traffic console; the line
    // under the status bar shows the same as the state's detail.
    console.wait_until(&format!("a danger message with {all:?}"), |s| {
        s.lines()
            .any(|l| l.trim_start().starts_with("!!") && all.iter().all(|n| l.contains(n)))
    });
    console.wait_until("ERROR in the status bar", |s| status_has(s, "ERROR"));
    let received = sim.wait_received("the stop after the deadline", |r| {
        emp_after(r, frame).iter().any(|f| f == EMP_STOP)
    });
    assert_eq!(
        emp_first_command_after(&received, frame).as_deref(),
        Some(EMP_STOP),
        "the drive is stopped before anything else: {:?}",
        emp_after(&received, frame)
    );
}

/// How many lines of the screen say that something was refused.
fn refusals_shown(console: &Console) -> usize {
    console
        .screen()
        .lines()
        .filter(|l| l.contains("refused"))
        .count()
}

/// Moves asked for now are refused and never sent: a step of the jog
/// keypad (Right) and a raw positioning typed on the command line, which
/// the driver refuses with the recovery.
fn assert_emp_motion_refused(sim: &mut SimProcess, console: &mut Console) {
    let before = emp_motion(&sim.received());
    let shown = refusals_shown(console);
    console.keys(b"\x1b[C");
    console.wait_until("the step refused", |s| {
        s.lines().filter(|l| l.contains("refused")).count() > shown
    });
    console.command("2A1101640000EA60");
    console.wait_until("the raw move refused with what to do", |s| {
        s.lines().any(|l| {
            l.contains("refused")
                && l.contains("2A1101640000EA60")
                && l.contains("controller error: initialise (i) and reference (h)")
        })
    });
    // Give a wrongly sent frame time to arrive before looking.
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(emp_motion(&sim.received()), before, "nothing more moved");
}

/// EMP: a go-to move (`g X1`, 2 s at the jog speed) whose drive answers busy (`55`) and
/// never ready (`fault stall`): at the move's deadline the console stops the
/// drive (`08` first), says what happened and what to do, and refuses every
/// move until the operator has initialised and referenced again; then a
/// move runs.
fn emp_busy_never_ready_go_to(t: &mut Tally) {
    let (mut sim, mut console) = stalled_emp(t);
    console.keys(b"g");
    console.keys(b"X1");
    console.wait_for("X1");
    console.keys(b"\r");
    let received = sim.wait_received("the go-to move", |r| {
        emp_motion(r).iter().any(|f| f.starts_with("2A1101"))
    });
    let go_to = emp_motion(&received)
        .into_iter()
        .find(|f| f.starts_with("2A1101"))
        .unwrap_or_default();
    console.wait_until("MOVING in the status bar", |s| status_has(s, "MOVING"));
    assert_given_up(
        &mut sim,
        &console,
        &go_to,
        &["did not report in position (22)", "stopped with 08"],
    );
    let state = sim.wait_device("held", |d| !d.contains("stalled"));
    assert!(!state.contains("positioning"), "{state}");
    assert_emp_motion_refused(&mut sim, &mut console);
    // Acknowledged by doing what it said: then a move runs again.
    emp_initialise_and_reference(&mut console);
    console.keys(b"g");
    console.keys(b"X0.5");
    console.wait_for("X0.5");
    console.keys(b"\r");
    let received = sim.wait_received("the move after the recovery", |r| {
        emp_motion(r)
            .iter()
            .filter(|f| f.starts_with("2A1101"))
            .count()
            == 2
    });
    let motion = emp_motion(&received);
    assert_eq!(
        motion.len(),
        4,
        "home, the move, home, the move: {motion:?}"
    );
    assert_eq!(
        (motion[0].as_str(), motion[1].as_str(), motion[2].as_str()),
        (EMP_HOME, go_to.as_str(), EMP_HOME),
        "nothing repeated: {motion:?}"
    );
    // At 0.5 mm (5600 counts) and READY: the move has ended (READY alone
    // may still be the screen from before it started).
    console.wait_until("READY at X 0.5 mm after the move", |s| {
        status_has(s, "READY") && x_steps(s) == Some(5600)
    });
    sim.assert_alive();
    console.quit();
}

/// EMP: a raw TP positioning typed on the command line (`2A 11 01`, Vmax
/// 100 counts/ms, 112 000 counts: 1.1 s) whose drive stays busy: the raw
/// frame gets the deadline a planned move of that travel and speed gets,
/// the drive is stopped, the operator told, and moves are refused.
fn emp_busy_never_ready_raw_move(t: &mut Tally) {
    const RAW_MOVE: &str = "2A1101640001B580";
    let (mut sim, mut console) = ready_emp();
    // TP needs TPWM (manual "2A"); the reference run left the jog mode IV.
    console.command("2211070000000000");
    console.wait_for("2211070000000000 = ");
    sim.control("fault stall");
    t.fault();
    console.command(RAW_MOVE);
    console.wait_for(&format!("{RAW_MOVE} = started"));
    assert_given_up(
        &mut sim,
        &console,
        RAW_MOVE,
        &["did not report in position (22)", "stopped with 08"],
    );
    assert_emp_motion_refused(&mut sim, &mut console);
    let motion = emp_motion(&sim.received());
    assert_eq!(motion, [EMP_HOME, RAW_MOVE], "nothing repeated");
    sim.assert_alive();
    console.quit();
}

/// EMP: a raw reference run (`26`) whose drive stays busy and does not
/// move: the watchdog's position reads stand still, so the run is given up
/// as stalled within about a second, long before its deadline; the drive is
/// stopped and the operator told what to check.
fn emp_raw_homing_stalled(t: &mut Tally) {
    let (sim, mut console) = stalled_emp(t);
    console.command(EMP_HOME);
    let started = Instant::now();
    assert_homing_stalled(sim, console, started, "the typed run once");
}

/// EMP: the console's own reference run (`h`, confirmed with `y`) whose
/// drive stays busy and does not move: the same watchdog as for a raw `26`
/// (fed by the position polls), the same give-up: the drive stopped first,
/// the operator told what to check, moves refused.
fn emp_homing_stalled(t: &mut Tally) {
    let (sim, mut console) = stalled_emp(t);
    console.keys(b"h");
    console.wait_for("Start the reference run?");
    console.keys(b"y");
    let started = Instant::now();
    assert_homing_stalled(sim, console, started, "the run once");
}

/// EMCU memory full (0x03) during an upload from the editor: the interface
/// has less job memory than the linter assumes (`memory 2` on the
/// simulator's stdin), so it answers the third command with 0x03 CR. The
/// upload stops at that line, the editor marks it with the meaning of 0x03
/// and says what to do, the text and the file stay as they were, and
/// nothing was started.
fn emcu_memory_full_during_an_upload(t: &mut Tally) {
    const JOB: &str = "; pallet\n#E2,1500\nL2,X2000,Y1000\nW50\nL2,x-500,z300\nA1,1\n";
    let mut sim = SimProcess::start("emcu");
    let file = sim.dir.path().join("pallet.emcu");
    std::fs::write(&file, JOB).expect("write the job");
    let file_arg = file.display().to_string();
    sim.control("memory 2");
    t.fault();
    let mut console = Console::start_with(&sim, &["--program", &file_arg]);
    console.wait_for("pallet.emcu");
    // F5 uploads.
    console.keys(b"\x1b[15~");
    // The editor's upload line keeps what happened and what to do (the
    // message line may move on to the error flag the interface set).
    console.wait_message(&[
        "upload failed at command 3 (line 4)",
        "memory full",
        "shorten the job or split it",
    ]);
    // The line is marked in the editor with the meaning (not only said).
    let screen = console.wait_until("the refused line marked", |s| {
        s.lines().any(|l| {
            l.contains("3! W50") && l.contains("the controller answered `0x03`: memory full")
        })
    });
    // Untouched: every line still there, the file as it was.
    for line in JOB.lines() {
        assert!(screen.contains(line), "`{line}` is gone:\n{screen}");
    }
    assert_eq!(std::fs::read_to_string(&file).expect("read"), JOB);
    // The controller: the upload stopped at the line (nothing after it
    // was sent, nothing twice), the transfer was ended and the job thrown
    // away, nothing started or moved.
    let received = sim.received();
    assert_eq!(
        received.matches("L2,X2000,Y1000<CR>").count(),
        1,
        "{received}"
    );
    assert_eq!(received.matches("W50<CR>").count(), 1, "{received}");
    assert!(!received.contains("L2,x-500"), "{received}");
    assert!(!received.contains("@J"), "nothing was started: {received}");
    let motion = emcu_motion(&received);
    assert_eq!(
        motion,
        ["L2,X2000,Y1000"],
        "stored in ROM only, once: {received}"
    );
    let state = sim.device_state();
    assert!(
        state.contains("ROM empty"),
        "the job was discarded: {state}"
    );
    assert!(state.starts_with("device: X 0 "), "nothing moved: {state}");
    assert!(!state.contains("moving"), "nothing moves: {state}");
    sim.assert_alive();
    console.assert_no_panic();
    // F4: the machine screen, whose console keeps the whole report, and
    // where q quits.
    console.keys(b"\x1bOS");
    console.wait_for("Position");
    let said = console.wait_message(&[
        "upload failed at command 3 (line 4): the controller answered `0x03`: memory full",
        "the interface discarded the job and stores nothing (it took 2 commands)",
    ]);
    assert!(said.contains("change the job, then upload again"), "{said}");
    console.quit();
}

fn main() -> ExitCode {
    runner::run(&[
        Scenario {
            name: "dropped_byte_in_a_reply",
            run: dropped_byte_in_a_reply,
        },
        Scenario {
            name: "corrupted_byte",
            run: corrupted_byte,
        },
        Scenario {
            name: "withheld_reply",
            run: withheld_reply,
        },
        Scenario {
            name: "withheld_reply_to_send",
            run: withheld_reply_to_send,
        },
        Scenario {
            name: "withheld_reply_to_poll",
            run: withheld_reply_to_poll,
        },
        Scenario {
            name: "port_closed_mid_move_and_reopened",
            run: port_closed_mid_move_and_reopened,
        },
        Scenario {
            name: "estop_during_a_move",
            run: estop_during_a_move,
        },
        Scenario {
            name: "limit_switch_during_a_move",
            run: limit_switch_during_a_move,
        },
        Scenario {
            name: "stop_button_on_the_controller",
            run: stop_button_on_the_controller,
        },
        Scenario {
            name: "withheld_reply_emcu",
            run: withheld_reply_emcu,
        },
        Scenario {
            name: "sigkill_mid_edit",
            run: sigkill_mid_edit,
        },
        Scenario {
            name: "emcu_memory_full_during_an_upload",
            run: emcu_memory_full_during_an_upload,
        },
        Scenario {
            name: "unsolicited_garbage",
            run: unsolicited_garbage,
        },
        Scenario {
            name: "sighup_during_a_move",
            run: sighup_during_a_move,
        },
        Scenario {
            name: "sighup_during_a_continuous_jog",
            run: sighup_during_a_continuous_jog,
        },
        Scenario {
            name: "emp_busy_never_ready_go_to",
            run: emp_busy_never_ready_go_to,
        },
        Scenario {
            name: "emp_busy_never_ready_raw_move",
            run: emp_busy_never_ready_raw_move,
        },
        Scenario {
            name: "emp_raw_homing_stalled",
            run: emp_raw_homing_stalled,
        },
        Scenario {
            name: "emp_homing_stalled",
            run: emp_homing_stalled,
        },
    ])
}
