//! jogterm and its terminal, end to end: the real `jogterm` in a
//! pseudo-terminal, on a pty served by the isel simulator in this process
//! (with the arrival time of every byte recorded), jogging with a profile
//! whose lease is a full second, so only the path under test can stop the
//! axis within 50 ms:
//!
//! - the terminal goes away (the master closes, the kernel sends SIGHUP) or
//!   SIGTERM arrives during a held jog: the stop bytes reach the controller
//!   at once, the axis stands, and a later `@0S` does not move it;
//! - a terminal with the kitty keyboard protocol (the test answers the
//!   query as one would): a key release stops the jog at once, and the
//!   protocol's flags are popped on the way out;
//! - in step jogging (issue 13): a bracketed paste of ten `6` moves
//!   nothing, ten jog keys written at once (a burst) move at most
//!   `1 + step_queue` steps, and Space in the program editor types a blank
//!   while the machine stands but stops a step that runs.

use crate::jog_support;
use crate::timing::serial;
use crate::ui_pty;

use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use jog_support::{BREAK, DISCARD, Probe, first_break, moves, ms, profile};
use jogterm::sim::SimDevice;
use jogterm::sim::isel::IselSim;
use jogterm::sim::shell::{PtyOptions, serve_pty};
use ui_pty::PtyRun;

const JOGTERM: &str = env!("CARGO_BIN_EXE_jogterm");
const WAIT: Duration = Duration::from_secs(20);
/// The requirement is 50 ms; on a loaded 2-core machine a little more is
/// tolerated, still far below the one-second lease.
const BOUND: Duration = Duration::from_millis(150);

fn lock(p: &Arc<Mutex<Probe>>) -> std::sync::MutexGuard<'_, Probe> {
    p.lock().unwrap_or_else(|e| e.into_inner())
}

fn wait_for(run: &PtyRun, needle: &str) -> String {
    run.wait_for(needle, WAIT)
        .unwrap_or_else(|screen| panic!("`{needle}` never appeared:\n{screen}"))
}

fn counter_x(probe: &Arc<Mutex<Probe>>) -> f64 {
    lock(probe).sim.counters_at(Instant::now())[0]
}

/// How the console is ended during the jog.
#[derive(Clone, Copy)]
enum End {
    /// The terminal's master side closes: SIGHUP, POLLHUP/EOF on stdin.
    HangUp,
    /// SIGTERM, as a service manager or `kill` sends it.
    Terminate,
}

#[test]
fn a_hang_up_during_a_jog_writes_the_stop_at_once_and_nothing_resumes_it() {
    jog_then(End::HangUp);
}

#[test]
fn a_terminate_signal_during_a_jog_writes_the_stop_at_once() {
    jog_then(End::Terminate);
}

/// jogterm in a pty on the recorded simulator, initialised, referenced,
/// the keypad focused in continuous (hold) jogging, or in step jogging.
struct Session {
    _config: tempfile::TempDir,
    probe: Arc<Mutex<Probe>>,
    shell: jogterm::sim::shell::Shell,
    run: PtyRun,
}

/// The isel simulator recording every byte's arrival, served on a pty
/// linked at `dir/isel-link`.
fn recorded_simulator(
    dir: &Path,
) -> (
    Arc<Mutex<Probe>>,
    jogterm::sim::shell::Shell,
    std::path::PathBuf,
) {
    let sim = IselSim::from_profile(&profile()).expect("simulator");
    let probe = Arc::new(Mutex::new(Probe {
        sim,
        arrivals: Vec::new(),
    }));
    let link = dir.join("isel-link");
    let shell = serve_pty(
        Box::new(jog_support::Recorder(probe.clone())) as Box<dyn SimDevice>,
        PtyOptions {
            link: Some(link.clone()),
        },
    )
    .expect("serve the simulator");
    (probe, shell, link)
}

/// `kitty`: answer the keyboard protocol query as a kitty-protocol terminal
/// would, so jogterm turns key release reports on.
fn session(kitty: bool) -> Session {
    session_in(kitty, true)
}

/// As [`session`]; `continuous`: switched to continuous jogging (`c`), else
/// left in step jogging (1 mm steps at 2 mm/s, the profile's defaults).
fn session_in(kitty: bool, continuous: bool) -> Session {
    let config = tempfile::tempdir().expect("tempdir");
    let profiles = config.path().join("profiles");
    std::fs::create_dir_all(&profiles).expect("profiles dir");
    // A long lease: only the path under test can stop the jog within 50 ms.
    std::fs::write(
        profiles.join("longlease.toml"),
        "[jog]\nrepeat_timeout_ms = 1000\nfirst_repeat_grace_ms = 2000\n",
    )
    .expect("profile");

    let (probe, shell, link) = recorded_simulator(config.path());

    let config_dir = config.path().to_str().expect("utf-8 path").to_string();
    // Recovery files of the editor stay in this test's own directory.
    let state_dir = config.path().join("state").display().to_string();
    let mut env = vec![
        ("JOGTERM_CONFIG_DIR", config_dir.as_str()),
        ("JOGTERM_STATE_DIR", state_dir.as_str()),
        ("RUST_BACKTRACE", "0"),
    ];
    if !kitty {
        env.push(("JOGTERM_NO_KEYBOARD_QUERY", "1"));
    }
    let link_arg = link.display().to_string();
    let mut run = PtyRun::spawn(
        Path::new(JOGTERM),
        &["--profile", "longlease", "--port", &link_arg],
        &env,
    );
    if kitty {
        // crossterm asks `CSI ? u` (the flags) then `CSI c` (device
        // attributes); a kitty-protocol terminal answers both.
        let deadline = Instant::now() + WAIT;
        while !ui_pty::contains(&run.output(), b"\x1b[?u") {
            assert!(
                Instant::now() < deadline,
                "jogterm never asked for the keyboard protocol"
            );
            std::thread::sleep(Duration::from_millis(10));
        }
        run.send(b"\x1b[?0u\x1b[?62;22c");
    }
    wait_for(&run, "connected");
    // Initialise, and reference without travel (`@0N7`) from the console,
    // typed key by key: keys written together are a burst, and a burst's
    // Enter sends nothing.
    run.type_keys(&[b"i"]);
    std::thread::sleep(Duration::from_millis(500));
    run.type_keys(&[b":"]);
    run.type_text("@0N7");
    wait_for(&run, "> @0N7");
    run.type_keys(&[b"\r"]);
    wait_for(&run, ">> @0N7");
    // Back to the keypad (Tab leaves the command line).
    run.type_keys(&[b"\t"]);
    std::thread::sleep(Duration::from_millis(300));
    if continuous {
        run.type_keys(&[b"c"]);
        wait_for(&run, "HOLD");
    } else {
        wait_for(&run, "READY");
    }
    Session {
        _config: config,
        probe,
        shell,
        run,
    }
}

fn jog_then(end: End) {
    // A timing promise (the stop within [`BOUND`]): measured one at a time.
    let _serial = serial();
    let Session {
        _config,
        probe,
        shell,
        mut run,
    } = session(false);
    let x0 = counter_x(&probe);
    // Hold Right at 30 Hz for a second.
    let start = Instant::now();
    let mut next = start;
    while next < start + Duration::from_secs(1) {
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        }
        run.send(b"\x1b[C");
        next += Duration::from_millis(33);
    }
    let moving = counter_x(&probe);
    assert!(
        moving > x0 + 100.0,
        "the jog never moved: {x0} -> {moving}\n{}",
        run.screen().screen().contents()
    );
    // The terminal goes away (or a signal comes) while the key is held.
    let before = Instant::now();
    let mut hung_up = before;
    match end {
        End::HangUp => {
            // The harness first stops its reader (up to 50 ms), then closes
            // the master: the hang-up is when that returns.
            run.close_master();
            hung_up = Instant::now();
        }
        End::Terminate => {
            let pid = run.child.process_id().expect("pid");
            // SAFETY: a signal to the child this test started.
            unsafe {
                libc::kill(pid as libc::pid_t, libc::SIGTERM);
            }
        }
    }
    let code = run.wait_exit(WAIT);
    assert!(code.is_some(), "jogterm still runs after the hang-up");

    // The stop's two bytes go out in one write, but the probe's reader
    // may take them in two reads: under load its second read can come
    // after the child's exit, so the discard is waited for a moment.
    let read_by = Instant::now() + Duration::from_secs(1);
    let arrivals: Vec<(Instant, u8)> = loop {
        let arrivals: Vec<(Instant, u8)> = lock(&probe)
            .arrivals
            .iter()
            .filter(|(t, _)| *t >= before)
            .copied()
            .collect();
        if arrivals.iter().any(|(_, b)| *b == DISCARD) || Instant::now() > read_by {
            break arrivals;
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stop = first_break(&arrivals).expect("the stop reached the controller");
    let latency = stop.saturating_duration_since(hung_up);
    let what = match end {
        End::HangUp => "hang-up",
        End::Terminate => "SIGTERM",
    };
    println!("{what} -> break on the wire: {:.2} ms", ms(latency));
    assert!(latency < BOUND, "{latency:?}");
    assert!(
        arrivals.iter().any(|(_, b)| *b == DISCARD),
        "the rest of the move was not discarded: {arrivals:?}"
    );
    assert!(arrivals.iter().any(|(_, b)| *b == BREAK));

    // The axis stands (braking done) ...
    std::thread::sleep(Duration::from_millis(500));
    let stood = counter_x(&probe);
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(counter_x(&probe), stood, "the axis still moves");
    // ... and a start does not resume the broken-off move.
    {
        let mut p = lock(&probe);
        for b in b"@0S\r" {
            let now = Instant::now();
            p.sim.on_byte(*b, now);
        }
        p.sim.advance(Instant::now());
    }
    std::thread::sleep(Duration::from_millis(500));
    lock(&probe).sim.advance(Instant::now());
    assert_eq!(counter_x(&probe), stood, "@0S resumed the jog");
    shell.shutdown();
}

/// A terminal with the kitty keyboard protocol reports key releases: the
/// release stops the jog at once (the lease here would take a second), and
/// the protocol's flags are popped on the way out.
#[test]
fn with_the_kitty_keyboard_protocol_a_release_stops_the_jog_at_once() {
    let _serial = serial();
    let Session {
        _config,
        probe,
        shell,
        mut run,
    } = session(true);
    assert!(
        ui_pty::contains(&run.output(), b"\x1b[>"),
        "the keyboard flags were never pushed"
    );
    let x0 = counter_x(&probe);
    // Right: press, repeats at 30 Hz, release (kitty: CSI 1;1:<event> C).
    run.send(b"\x1b[1;1:1C");
    std::thread::sleep(Duration::from_millis(400));
    for _ in 0..10 {
        run.send(b"\x1b[1;1:2C");
        std::thread::sleep(Duration::from_millis(33));
    }
    let screen = run.screen().screen().contents();
    assert!(screen.contains("release stops"), "{screen}");
    let released = Instant::now();
    run.send(b"\x1b[1;1:3C");
    std::thread::sleep(Duration::from_millis(500));
    let moved = counter_x(&probe);
    assert!(moved > x0 + 100.0, "the jog never moved: {x0} -> {moved}");
    let arrivals: Vec<(Instant, u8)> = lock(&probe)
        .arrivals
        .iter()
        .filter(|(t, _)| *t >= released)
        .copied()
        .collect();
    let stop = first_break(&arrivals).expect("the release stopped the jog");
    let latency = stop.saturating_duration_since(released);
    println!("kitty release -> break on the wire: {:.2} ms", ms(latency));
    assert!(latency < BOUND, "{latency:?}");
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(counter_x(&probe), moved, "the axis still moves");

    run.send(b"q");
    let code = run.wait_exit(WAIT);
    run.drain(Duration::from_secs(5));
    assert_eq!(code, Some(0));
    assert!(
        ui_pty::contains(&run.output(), b"\x1b[<1u"),
        "the keyboard flags were not popped"
    );
    shell.shutdown();
}

/// How many steps of the profile's 1 mm the simulated controller's X
/// counter moved between `x0` and now.
fn mm(probe: &Arc<Mutex<Probe>>, x0: f64) -> f64 {
    let spu = profile()
        .axis(jogterm::axis::Axis::X)
        .map_or(1.0, |a| a.steps_per_unit);
    (counter_x(probe) - x0) / spu
}

/// Bytes that reached the simulated controller at or after `t`.
fn arrivals_since(probe: &Arc<Mutex<Probe>>, t: Instant) -> Vec<(Instant, u8)> {
    lock(probe)
        .arrivals
        .iter()
        .filter(|(at, _)| *at >= t)
        .copied()
        .collect()
}

/// Issue 13: pasting ten `6` into the console (a stray right-click in
/// PuTTY) made ten 1 mm steps. With bracketed paste the paste is text: on
/// the keypad it moves nothing and says so; a `6` typed alone afterwards
/// steps as ever.
#[test]
fn a_bracketed_paste_of_ten_jog_keys_moves_nothing() {
    let Session {
        _config,
        probe,
        shell,
        mut run,
    } = session_in(false, false);
    let x0 = counter_x(&probe);
    // As a terminal pastes: bracketed only when the program asked for it
    // (`CSI ? 2004 h`), else as the bare keys.
    let bracketed = run.screen().screen().bracketed_paste();
    let paste: &[u8] = if bracketed {
        b"\x1b[200~6666666666\x1b[201~"
    } else {
        b"6666666666"
    };
    let pasted = Instant::now();
    run.send(paste);
    std::thread::sleep(Duration::from_millis(2500));
    let moved = moves(&arrivals_since(&probe, pasted));
    println!(
        "bracketed paste of ten `6`: {moved} moves, {:.3} mm",
        mm(&probe, x0)
    );
    assert_eq!(moved, 0, "a paste moved the machine");
    assert_eq!(counter_x(&probe), x0);
    assert!(bracketed, "jogterm did not ask for bracketed paste");
    let screen = wait_for(&run, "paste ignored");
    assert!(
        screen.contains("paste ignored: jogterm moves only on keys"),
        "{screen}"
    );
    // The keypad still steps on a key typed alone.
    run.type_keys(&[b"6"]);
    std::thread::sleep(Duration::from_millis(1500));
    assert!((mm(&probe, x0) - 1.0).abs() < 1e-6, "{} mm", mm(&probe, x0));
    shell.shutdown();
}

/// Issue 13: ten jog keys written at once (tmux `send-keys`, a terminal
/// without bracketed paste) made ten steps. Now at most `1 + step_queue`
/// (3 with the profile's `step_queue = 2`) reach the controller; the
/// console catches the burst and moves none.
#[test]
fn ten_jog_keys_in_one_write_move_at_most_one_plus_the_step_queue() {
    let Session {
        _config,
        probe,
        shell,
        mut run,
    } = session_in(false, false);
    let bound = 1 + profile().jog.step_queue;
    for keys in [b"6".repeat(10), b"\x1b[C".repeat(10)] {
        let x0 = counter_x(&probe);
        let written = Instant::now();
        run.send(&keys);
        std::thread::sleep(Duration::from_millis(2500));
        let moved = moves(&arrivals_since(&probe, written));
        let travel = mm(&probe, x0);
        println!(
            "ten keys in one write ({}): {moved} moves, {travel:.3} mm (bound {bound})",
            String::from_utf8_lossy(&keys[..3]).escape_debug()
        );
        assert!(moved <= bound, "{moved} moves");
        assert!(travel <= bound as f64 + 1e-6, "{travel} mm");
        let screen = wait_for(&run, "burst ignored");
        assert!(screen.contains("10 keys"), "{screen}");
    }
    shell.shutdown();
}

/// The Space rule in the program editor: while the machine stands Space
/// types a blank; while a step runs it stops it (the stop bytes reach the
/// controller at once) and types nothing.
#[test]
fn space_in_the_editor_types_while_the_machine_stands_and_stops_a_step() {
    let Session {
        _config,
        probe,
        shell,
        mut run,
    } = session_in(false, false);
    // More than a second after the last request that could move (`@0N7`).
    std::thread::sleep(Duration::from_millis(1200));
    run.type_keys(&[b"e"]);
    wait_for(&run, "Program");
    run.type_text("7 7");
    let screen = wait_for(&run, "Col 4");
    assert!(screen.contains("7 7"), "{screen}");
    // Back to the keypad: a 1 mm step at 2 mm/s takes half a second.
    run.type_keys(&[b"\x1bOS"]);
    wait_for(&run, " Jog ");
    let x0 = counter_x(&probe);
    run.type_keys(&[b"\x1b[C", b"\x1bOS"]);
    wait_for(&run, "Program");
    let space = Instant::now();
    run.send(b" ");
    let screen = wait_for(&run, "Space stops, not types");
    assert!(screen.contains("Col 4"), "a blank was typed:\n{screen}");
    let stop = first_break(&arrivals_since(&probe, space)).expect("the stop reached the wire");
    let latency = stop.saturating_duration_since(space);
    println!(
        "Space in the editor during a step -> break: {:.2} ms",
        ms(latency)
    );
    assert!(latency < BOUND, "{latency:?}");
    std::thread::sleep(Duration::from_millis(800));
    let travel = mm(&probe, x0);
    assert!(travel < 1.0 - 1e-6, "the step ran to its end: {travel} mm");
    shell.shutdown();
}

/// A real terminal in between: jogterm in tmux (which passes a paste on
/// bracketed only to a program that asked for it: `paste-buffer -p`), on
/// the recorded simulator, in step jogging. A paste of ten `6` and ten `6`
/// sent as one burst (`send-keys -l`) move nothing.
#[test]
fn in_tmux_a_paste_and_a_burst_of_ten_jog_keys_move_nothing() {
    if std::process::Command::new("tmux")
        .arg("-V")
        .output()
        .is_err()
    {
        println!("tmux is not installed: the pty tests above cover the same ground");
        return;
    }
    let config = tempfile::tempdir().expect("tempdir");
    let (probe, shell, link) = recorded_simulator(config.path());
    let tmux = Tmux::start(
        &format!("jogterm-test-{}", std::process::id()),
        &[
            ("JOGTERM_CONFIG_DIR", config.path().display().to_string()),
            (
                "JOGTERM_STATE_DIR",
                config.path().join("state").display().to_string(),
            ),
            ("JOGTERM_NO_KEYBOARD_QUERY", "1".into()),
        ],
        &format!("'{JOGTERM}' --port '{}'", link.display()),
    );
    tmux.wait_for("connected");
    tmux.keys(&["i"]);
    std::thread::sleep(Duration::from_millis(500));
    tmux.keys(&[":", "@", "0", "N", "7"]);
    tmux.wait_for("> @0N7");
    tmux.keys(&["Enter"]);
    tmux.wait_for(">> @0N7");
    tmux.keys(&["Tab"]);
    tmux.wait_for("READY");
    let x0 = counter_x(&probe);

    let pasted = Instant::now();
    tmux.run(&["set-buffer", "-b", "jogterm", "6666666666"]);
    tmux.run(&["paste-buffer", "-p", "-d", "-b", "jogterm"]);
    tmux.wait_for("paste ignored: jogterm moves only on keys");
    std::thread::sleep(Duration::from_millis(2000));
    let moved = moves(&arrivals_since(&probe, pasted));
    println!("tmux paste-buffer -p of ten `6`: {moved} moves");
    assert_eq!(moved, 0);

    std::thread::sleep(Duration::from_millis(300));
    let burst = Instant::now();
    tmux.run(&["send-keys", "-l", "6666666666"]);
    tmux.wait_for("burst ignored");
    std::thread::sleep(Duration::from_millis(2000));
    let moved = moves(&arrivals_since(&probe, burst));
    println!("tmux send-keys -l of ten `6`: {moved} moves");
    assert!(moved <= 1 + profile().jog.step_queue, "{moved} moves");
    assert_eq!(moved, 0, "the console caught the burst");
    assert_eq!(counter_x(&probe), x0, "the axis moved");
    tmux.keys(&["q"]);
    drop(tmux);
    shell.shutdown();
}

/// A tmux server of this test's own (its socket), ended when dropped.
struct Tmux {
    socket: String,
}

impl Tmux {
    fn start(socket: &str, env: &[(&str, String)], command: &str) -> Tmux {
        let tmux = Tmux {
            socket: socket.to_string(),
        };
        let mut args = vec!["new-session", "-d", "-x", "80", "-y", "24"];
        let pairs: Vec<String> = env.iter().map(|(k, v)| format!("{k}={v}")).collect();
        for pair in &pairs {
            args.extend(["-e", pair.as_str()]);
        }
        args.push(command);
        tmux.run(&args);
        tmux
    }

    fn run(&self, args: &[&str]) -> String {
        let out = std::process::Command::new("tmux")
            .args(["-L", &self.socket])
            .args(args)
            .output()
            .expect("run tmux");
        assert!(out.status.success(), "tmux {args:?}: {out:?}");
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// Keys one at a time (tmux key names: `Enter`, `Tab`; `-l` for text).
    fn keys(&self, keys: &[&str]) {
        for key in keys {
            std::thread::sleep(ui_pty::KEY_GAP);
            if key.chars().count() == 1 {
                self.run(&["send-keys", "-l", key]);
            } else {
                self.run(&["send-keys", key]);
            }
        }
        std::thread::sleep(ui_pty::KEY_GAP);
    }

    fn wait_for(&self, needle: &str) -> String {
        let end = Instant::now() + WAIT;
        loop {
            let screen = self.run(&["capture-pane", "-p"]);
            if screen.contains(needle) {
                return screen;
            }
            assert!(Instant::now() < end, "`{needle}` never appeared:\n{screen}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = std::process::Command::new("tmux")
            .args(["-L", &self.socket, "kill-server"])
            .output();
    }
}
