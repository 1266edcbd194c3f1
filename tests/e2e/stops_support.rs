//! What the stop tests (`tests/e2e/stops_cli.rs`, `tests/e2e/stops_console.rs`)
//! share: signals to a child, bounded waits for it, and the simulator's
//! state line read per family (moving or not, the X position), so "the axis
//! stands" is the same check everywhere.

use std::process::{Child, Output};
use std::thread;
use std::time::Duration;

use crate::faults_support::wire;
use crate::sim_process::{SimProcess, contains_panic, text, wait_child};

/// A profile `name` on top of `sim`'s family's shipped one, in the
/// simulator's configuration directory (which the console shares): the
/// longest dead-man lease a profile may give (1 s once repeats flow, 2 s
/// before), so only the stop under test ends a jog within the time the
/// tests allow; EMCU and EMP home fast, so the reference run takes seconds,
/// not half a minute; `jog` adds lines to its `[jog]` table. Its name, for
/// `--profile`.
pub fn write_profile(sim: &SimProcess, name: &'static str, jog: &str) -> &'static str {
    let dir = sim.dir.path().join("profiles");
    std::fs::create_dir_all(&dir).expect("profiles dir");
    let family = match sim.family {
        "emcu" => "[emcu]\nstart_speed_hz = 2000\nramp_ms = 200\n",
        "emp" => "[emp]\nhome_fast = 127\nhome_slow = 32\n",
        _ => "",
    };
    let text = format!(
        "base = \"{}\"\nname = \"{name}\"\n\n[jog]\nrepeat_timeout_ms = 1000\nfirst_repeat_grace_ms = 2000\n{jog}\n{family}",
        sim.family
    );
    std::fs::write(dir.join(format!("{name}.toml")), text).expect("profile");
    name
}

/// How long an axis that stands is watched for motion.
pub const STANDS_FOR: Duration = Duration::from_millis(600);

/// Send `signal` to the process `pid` (a child this test started).
pub fn signal(pid: u32, signal: libc::c_int) {
    let pid = libc::pid_t::try_from(pid).expect("a pid");
    // SAFETY: a signal to a child this test started and has not reaped.
    assert_eq!(unsafe { libc::kill(pid, signal) }, 0, "kill({pid})");
}

/// The command ended with `code`, without a panic.
pub fn assert_exit(out: &Output, code: i32, what: &str) {
    assert!(
        !contains_panic(&out.stderr),
        "{what} panicked:\n{}",
        text(&out.stderr)
    );
    assert_eq!(
        out.status.code(),
        Some(code),
        "{what}:\n{}\n{}",
        text(&out.stdout),
        text(&out.stderr)
    );
}

/// `jogterm <command>` (the `child`) interrupted by `sig`: it ends with
/// status 1, without a panic, saying it stopped the machine.
pub fn interrupt(child: Child, sig: libc::c_int, command: &str) {
    signal(child.id(), sig);
    let out = wait_child(child, &format!("jogterm {command}"));
    assert_exit(&out, 1, &format!("{command} interrupted"));
    assert!(
        text(&out.stderr).contains("interrupted: the machine was stopped"),
        "{}",
        text(&out.stderr)
    );
}

/// isel: `jogterm send` of the axes, the reference where they stand, and a
/// stored program of one long X move (15 s at 4000 Hz) for the machine's
/// start key to run (isel manual 2.2.13 `@0i`, 3.1); its output.
pub fn isel_store_long_program(sim: &SimProcess) -> Output {
    sim.run(&[
        "send",
        "@07",
        "@0N7",
        "@0i",
        "060000,4000,0,4000,0,4000,0,4000",
        "9",
    ])
}

/// The time scale of a test that lets [`isel_store_long_program`]'s
/// program run to its end while a session connects: 5 s of wall time, still
/// ample for a `jogterm` to start and talk to it (`docs/testing.md`, "The
/// time scale").
pub const LONG_PROGRAM_SCALE: f64 = 3.0;

/// Whether the simulator's state line says an axis moves.
pub fn moving(family: &str, state: &str) -> bool {
    match family {
        // isel: `| moving`, or `| program: moving` while a program runs.
        "isel" => state.ends_with("moving"),
        "emcu" => state.contains("moving"),
        // EMP: a running drive shows its speed (`-112000/s homing`).
        _ => state.contains("/s"),
    }
}

/// Wait until the simulator's axes move.
pub fn wait_moving(sim: &mut SimProcess, what: &str) -> String {
    let family = sim.family;
    sim.wait_device(what, |d| moving(family, d))
}

/// The axes stand: the state (positions included) is the same twice, read
/// [`STANDS_FOR`] apart, once the ramp down has ended. The state line.
pub fn assert_stands(sim: &mut SimProcess) -> String {
    let family = sim.family;
    let first = sim.wait_device("at rest", |d| !moving(family, d));
    thread::sleep(STANDS_FOR);
    let second = sim.device_state();
    // The EMP simulator's counters of dropped frames are no motion: the
    // emergency stop's leading EOF is one when nothing was cut
    // (docs/protocols.md, EMP), and was once counted after the drive stood
    // (seen under load: `dropped: 2 framing` then `3`).
    assert_eq!(
        without_counters(&first),
        without_counters(&second),
        "the axes moved on after the stop"
    );
    second
}

fn without_counters(state: &str) -> &str {
    state.split(" | dropped:").next().unwrap_or(state)
}

/// The X (or EMP: the drive's) position in steps of a state line: isel
/// `device: X 6896 Y 0 …`, EMCU `device: X 1234 [machine …] …`, EMP
/// `device: 11 X TP pos 3360 …`.
pub fn x_steps(family: &str, state: &str) -> i64 {
    let number = match family {
        "emp" => state.split_once(" pos ").map(|(_, r)| r),
        _ => state.strip_prefix("device: X "),
    };
    number
        .and_then(|r| r.split_whitespace().next())
        .and_then(|x| x.parse().ok())
        .unwrap_or_else(|| panic!("no X position in {state}"))
}

/// EMP: the frames received (`traffic::readable` ends each with `<EOF>`).
pub fn emp_frames(received: &str) -> Vec<&str> {
    received.split("<EOF>").filter(|f| !f.is_empty()).collect()
}

/// A later connection moves nothing: `jogterm send` of a position query
/// (isel `@0P`, EMCU `@LX`, EMP `2C`; each connection opens with the
/// family's stop) ends with 0 and the axis still stands at `x`. (EMCU: not
/// `@X`, which answers the error flag that a line cut by an emergency stop
/// leaves set, `docs/protocols.md`.)
pub fn assert_a_new_connection_moves_nothing(sim: &mut SimProcess, x: i64) {
    let query: &[&str] = match sim.family {
        "isel" => &["send", "@0P"],
        "emcu" => &["send", "@LX"],
        _ => &["send", "--drive", "11", "2C 00 00 00000000"],
    };
    let out = sim.run(query);
    let received = sim.received();
    let tail = &received[received.len().saturating_sub(600)..];
    let what = format!("a query on a new connection; the controller received last:\n…{tail}");
    assert_exit(&out, 0, &what);
    let family = sim.family;
    let state = assert_stands(sim);
    assert_eq!(x_steps(family, &state), x, "moved on: {state}");
}

/// The stops, control bytes and motion in `traffic` (what the controller
/// received from one session), in readable form; empty when it had none.
pub fn stops_and_motion(family: &str, traffic: &str) -> Vec<String> {
    match family {
        "isel" => wire::isel_messages(traffic)
            .into_iter()
            .filter(|m| matches!(m.as_str(), "<FD>" | "<FE>" | "<FF>") || m.contains("<F"))
            .chain(wire::isel_motion(traffic))
            .collect(),
        "emcu" => {
            let mut found: Vec<String> = traffic
                .split("<CR>")
                .filter(|l| matches!(*l, "@B" | "@S" | "@R" | "@A"))
                .map(str::to_owned)
                .collect();
            found.extend(wire::emcu_motion(traffic));
            found
        }
        // EMP: 08 (hold), 2A (positioning, 2A 03 fast stop), 26 (homing),
        // 02/22 (switch, enable): every frame that can change motion.
        _ => wire::emp_frames(traffic)
            .into_iter()
            .filter(|f| {
                ["08", "2A", "26", "02", "22"]
                    .iter()
                    .any(|c| f.starts_with(c))
            })
            .collect(),
    }
}

/// What the controller received from a session that has ended, from
/// `from` on: once it ends with a whole message (a session's bytes are all
/// in the line before its process exits; the simulator reads them in order).
pub fn session_traffic(sim: &mut SimProcess, from: usize) -> String {
    let received = sim.wait_received("the session's last message whole", |r| {
        let tail = r.get(from..).unwrap_or_default();
        tail.is_empty() || tail.ends_with("<CR>") || tail.ends_with("<EOF>")
    });
    received.get(from..).unwrap_or_default().to_owned()
}
