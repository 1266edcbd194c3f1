//! Controllers on the network, end to end with the real binaries
//! (`docs/network.md`): `jogterm send`, `poll --json`, `upload` and a
//! stopped move over `tcp://` against `jogterm sim --tcp`, and through the
//! real ser2net (raw and `telnet(rfc2217)` accepters) in front of `jogterm
//! sim --pty`; Ctrl-C of a running move reaches the serial line (the
//! simulator's own record, with the time of each read) as stop bytes within
//! 100 ms; the RFC 2217 negotiation sets the remote port's baud rate and
//! 0xFF travels as IAC IAC; one owner per machine (a second jogterm is
//! refused with who holds the port, a server's refusal is passed on); a
//! server that falls silent is a lost link; a console on `tcp://` hung up
//! while jogging stops the machine.

use std::net::TcpStream;
use std::process::{Child, Output, Stdio};
use std::thread;
use std::time::{Duration, Instant, SystemTime};

use crate::faults_support;
use crate::ser2net_support;
use crate::sim_process::{
    self, ISEL_NEAR_REFERENCE, SimOptions, SimProcess, WAIT, text, wait_child,
};
use crate::stops_support;
use crate::timing::serial;
use faults_support::console::Console;
use faults_support::wire::{isel_messages, isel_motion};
use ser2net_support::Ser2net;
use stops_support::{assert_exit, assert_stands, signal, wait_moving, write_profile, x_steps};

/// isel: the axes and the reference where they stand, then a long X move
/// (15 s at 4000 Hz) for a signal to interrupt.
const READY: [&str; 2] = ["@07", "@0N7"];
const LONG_MOVE: &str = "@0M60000,4000,0,4000,0,4000,0,4000";

/// The bound the issue sets: from Ctrl-C to the stop bytes on the line.
const STOP_WITHIN: Duration = Duration::from_millis(100);

fn run(sim: &SimProcess, port: &str, args: &[&str]) -> Output {
    command(sim, port, args)
        .stdin(Stdio::null())
        .output()
        .expect("run jogterm")
}

/// `jogterm <args[0]> --port <port> --protocol isel <args[1..]>`, with the
/// simulator's configuration directory.
fn command(sim: &SimProcess, port: &str, args: &[&str]) -> std::process::Command {
    let mut c = sim_process::jogterm(std::path::Path::new(port), sim.family, args);
    c.env("JOGTERM_CONFIG_DIR", sim.dir.path());
    c
}

/// The isel simulator with its axes 1 mm from the reference point
/// (`ISEL_NEAR_REFERENCE`), for the tests whose reference runs are only the
/// way to a referenced machine.
fn near_reference() -> SimOptions<'static> {
    SimProcess::options("isel").files(&[ISEL_NEAR_REFERENCE])
}

fn spawn(sim: &SimProcess, port: &str, args: &[&str]) -> Child {
    command(sim, port, args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run jogterm")
}

fn assert_ok(out: &Output, what: &str) {
    assert_exit(out, 0, what);
}

/// `send` and `poll --json` through `port`: replies decoded, samples as
/// JSON with a position per axis.
fn send_and_poll(sim: &SimProcess, port: &str) {
    let out = run(
        sim,
        port,
        &[
            "send",
            "@07",
            "@0R7",
            "@0A 400,900,0,900,0,900,0,900",
            "@0P",
        ],
    );
    assert_ok(&out, "send");
    let stdout = text(&out.stdout);
    assert!(stdout.contains(">> @0R7\n<< 0 ok\n"), "{stdout}");
    assert!(stdout.contains("<< 0 X=400 Y=0 Z=0 (steps)"), "{stdout}");
    let out = run(
        sim,
        port,
        &[
            "poll",
            "--json",
            "--count",
            "3",
            "--ports",
            "--interval-ms",
            "50",
        ],
    );
    assert_ok(&out, "poll");
    let samples = sim_process::json_lines(&out.stdout);
    assert_eq!(samples.len(), 3, "{}", text(&out.stdout));
    for s in &samples {
        assert_eq!(s["pos"][0], 400, "{s}");
        assert_eq!(s["source"], "measured", "{s}");
        assert!(s["ports"].is_object(), "{s}");
    }
}

/// `send` of the long move through `port`, Ctrl-C while it runs: the
/// command says it stopped the machine and ends with 1, the axis stands
/// mid-move, the controller received 0xFD 0xFF right after the move, and
/// the first of them arrived within [`STOP_WITHIN`] of the signal. The
/// time it took.
fn ctrl_c_of_a_move(sim: &mut SimProcess, port: &str, extra: &[&str]) -> Duration {
    // A timing promise: measured one at a time (`timing.rs`).
    let _serial = serial();
    let moves = |r: &str| isel_motion(r).iter().filter(|m| *m == LONG_MOVE).count();
    let before = moves(&sim.received());
    let mut args = vec!["send"];
    args.extend_from_slice(extra);
    args.extend(READY);
    args.push(LONG_MOVE);
    let child = spawn(sim, port, &args);
    sim.wait_received("the move", |r| moves(r) > before);
    wait_moving(sim, "moving");
    let signalled = SystemTime::now();
    signal(child.id(), libc::SIGINT);
    let out = wait_child(child, "jogterm send");
    assert_exit(&out, 1, "send interrupted");
    assert!(
        text(&out.stderr).contains("interrupted: the machine was stopped"),
        "{}",
        text(&out.stderr)
    );
    let state = assert_stands(sim);
    let x = x_steps("isel", &state);
    assert!(x > 0 && x < 60_000, "stopped mid-move: {state}");
    let received = sim.received();
    let messages = isel_messages(&received);
    let last_move = messages
        .iter()
        .rposition(|m| m == LONG_MOVE)
        .unwrap_or_else(|| panic!("no move:\n{received}"));
    let after = messages.get(last_move + 1..).unwrap_or_default();
    assert_eq!(
        after.get(..2),
        Some(&["<FD>".to_string(), "<FF>".to_string()][..]),
        "the stop right after the move (0xFF as one byte, not an IAC pair):\n{received}"
    );
    let motion = isel_motion(&received);
    assert_eq!(moves(&received), before + 1, "the move once:\n{received}");
    assert_eq!(
        motion.last().map(String::as_str),
        Some(LONG_MOVE),
        "nothing moved after the stop:\n{received}"
    );
    // When the first stop byte after the move was read from the line: the
    // reads put together (a byte's readable form is never split between
    // two), the move found in them, the read that holds the next <FD>.
    let reads = sim.received_times();
    let joined: String = reads.iter().map(|(_, b)| b.as_str()).collect();
    let move_at = joined
        .rfind(&format!("{LONG_MOVE}<CR>"))
        .unwrap_or_else(|| panic!("the move is not in the reads: {reads:?}"));
    let stop_at = move_at
        + joined[move_at..]
            .find("<FD>")
            .unwrap_or_else(|| panic!("no stop after the move: {reads:?}"));
    let took = crate::sim_process::read_time_at(&reads, stop_at)
        .duration_since(signalled)
        .unwrap_or_default();
    assert!(
        took <= STOP_WITHIN,
        "the stop reached the line {took:?} after Ctrl-C (bound {STOP_WITHIN:?}): {reads:?}"
    );
    took
}

#[test]
fn over_raw_tcp_send_poll_upload_and_ctrl_c_of_a_move_work_as_on_a_tty() {
    let mut sim = near_reference().tcp().start();
    let port = sim.link.display().to_string();
    send_and_poll(&sim, &port);

    let program = sim.dir.path().join("square.isel");
    std::fs::write(
        &program,
        "0 800,4000,0,4000,0,4000,0,4000\n0 0,4000,800,4000,0,4000,0,4000\n9\n",
    )
    .expect("program");
    let out = run(
        &sim,
        &port,
        &[
            "upload",
            &program.display().to_string(),
            "--erase",
            "--start",
        ],
    );
    let said = text(&out.stderr);
    assert_ok(&out, "upload");
    assert!(said.contains("3 commands stored"), "{said}");
    assert!(said.contains("position (steps): X 1200, Y 800"), "{said}");

    let took = ctrl_c_of_a_move(&mut sim, &port, &[]);
    eprintln!("tcp:// (jogterm sim --tcp): stop on the line {took:?} after Ctrl-C");
    sim.assert_alive();
}

#[test]
fn through_ser2net_raw_send_poll_and_ctrl_c_of_a_move_reach_the_serial_line() {
    let mut sim = near_reference().start();
    let ser2net = Ser2net::start(&sim.link, 19200);
    send_and_poll(&sim, &ser2net.raw);
    let took = ctrl_c_of_a_move(&mut sim, &ser2net.raw, &[]);
    eprintln!("ser2net raw: stop on the serial line {took:?} after Ctrl-C");
    sim.assert_alive();
}

/// The pty's output speed as ser2net set it (termios of the slave).
fn pty_speed(link: &std::path::Path) -> libc::speed_t {
    use std::os::fd::AsRawFd;
    use std::os::unix::fs::OpenOptionsExt;
    let f = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NOCTTY | libc::O_NONBLOCK)
        .open(link)
        .expect("open the pty to read its settings");
    // SAFETY: termios is plain data that tcgetattr fills on success.
    let mut t: libc::termios = unsafe { std::mem::zeroed() };
    // SAFETY: a valid fd and a pointer to a termios.
    assert_eq!(unsafe { libc::tcgetattr(f.as_raw_fd(), &mut t) }, 0);
    // SAFETY: reads a field of the termios filled above.
    unsafe { libc::cfgetospeed(&t) }
}

#[test]
fn through_ser2net_rfc2217_the_remote_baud_is_set_0xff_is_escaped_and_ctrl_c_stops() {
    let mut sim = near_reference().start();
    // ser2net opens the port at 19200 as configured; jogterm asks for 38400
    // (SET-BAUDRATE), and the port must run that while jogterm has it.
    let ser2net = Ser2net::start(&sim.link, 19200);
    send_and_poll(&sim, &ser2net.rfc2217);
    let mut args = vec!["send", "--baud", "38400"];
    args.extend(READY);
    args.push(LONG_MOVE);
    let child = spawn(&sim, &ser2net.rfc2217, &args);
    wait_moving(&mut sim, "moving");
    assert_eq!(
        pty_speed(&sim.link),
        libc::B38400,
        "SET-BAUDRATE reached the serial port; ser2net:\n{}",
        ser2net.stderr_text()
    );
    signal(child.id(), libc::SIGINT);
    assert_exit(&wait_child(child, "send"), 1, "send interrupted");
    assert_stands(&mut sim);

    // The stops (0xFD 0xFF) and 0xFF typed as a raw command arrive as
    // single bytes: escaped as IAC IAC on the way, undone by the server.
    let out = run(&sim, &ser2net.rfc2217, &["send", "\\xFF", "@0P"]);
    assert_ok(&out, "send of 0xFF");
    let received = sim.received();
    let (_, after) = received
        .rsplit_once(&format!("{LONG_MOVE}<CR>"))
        .unwrap_or_else(|| panic!("no move:\n{received}"));
    // Ctrl-C's stop and the close's of the session that moved, then the
    // 0xFF sent: three, each one byte. The `send` of a raw byte and a read
    // was not asked to move, so it neither opens nor closes with a stop
    // (docs/device.md, "Sessions that do not move").
    assert!(after.starts_with("<FD><FF><FD><FF><FF>@0"), "{after}");
    assert_eq!(after.matches("<FF>").count(), 3, "{after}");
    assert!(after.ends_with("@0P<CR>"), "{after}");

    let took = ctrl_c_of_a_move(&mut sim, &ser2net.rfc2217, &[]);
    eprintln!("ser2net rfc2217: stop on the serial line {took:?} after Ctrl-C");
    sim.assert_alive();
}

/// Wait until `child` (a `send` of the long move) holds the port and the
/// axis moves.
fn holding(sim: &mut SimProcess) {
    wait_moving(sim, "the first jogterm's move");
}

fn assert_refused(out: &Output, needles: &[&str]) {
    assert_exit(out, 3, "the second jogterm");
    let said = text(&out.stderr);
    for n in needles {
        assert!(said.contains(n), "`{n}` in: {said}");
    }
}

#[test]
fn a_second_jogterm_is_refused_with_who_holds_the_port() {
    // A tty: the lock file names the first jogterm.
    let mut sim = SimProcess::start("isel");
    let port = sim.link.display().to_string();
    let mut args = vec!["send"];
    args.extend(READY);
    args.push(LONG_MOVE);
    let first = spawn(&sim, &port, &args);
    holding(&mut sim);
    let out = run(&sim, &port, &["send", "@0P"]);
    assert_refused(
        &out,
        &[
            "busy: held by jogterm",
            &format!("pid {}", first.id()),
            "one console per machine",
        ],
    );
    signal(first.id(), libc::SIGINT);
    assert_exit(&wait_child(first, "send"), 1, "the first send");

    // A serial port server: this machine's lock names it too.
    let mut sim = SimProcess::start_tcp("isel");
    let port = sim.link.display().to_string();
    let first = spawn(&sim, &port, &args);
    holding(&mut sim);
    let out = run(&sim, &port, &["send", "@0P"]);
    assert_refused(
        &out,
        &["busy: held by jogterm", &format!("pid {}", first.id())],
    );
    signal(first.id(), libc::SIGINT);
    assert_exit(&wait_child(first, "send"), 1, "the first send");

    // Another client of the server (not a jogterm): the server refuses.
    let other = TcpStream::connect(port.trim_start_matches("tcp://")).expect("connect");
    thread::sleep(Duration::from_millis(100));
    let out = run(&sim, &port, &["send", "@0P"]);
    assert_refused(&out, &["refused by the server", "Port already in use"]);
    drop(other);
}

#[test]
fn ser2net_refuses_a_second_client_and_jogterm_says_so() {
    let sim = SimProcess::start("isel");
    let ser2net = Ser2net::start(&sim.link, 19200);
    let other = TcpStream::connect(ser2net.raw.trim_start_matches("tcp://")).expect("connect");
    // ser2net opens the device for the first client.
    thread::sleep(Duration::from_millis(300));
    let out = run(&sim, &ser2net.raw, &["send", "@0P"]);
    assert_refused(&out, &["refused by the server", "Port already in use"]);
    let out = run(&sim, &ser2net.rfc2217, &["send", "@0P"]);
    assert_refused(&out, &["refused by the server", "already in use"]);
    drop(other);
}

/// The network (here: the server) stops answering; the socket stays open,
/// nothing is reset: only the driver's reply deadline can tell. EMCU answers
/// its polls also while it moves (`@LX` is a master command), so silence is
/// a dead link: `poll` exits 3 within the deadline (500 ms, EMCU manual
/// 1.4.2), never the seconds of a TCP timeout.
#[test]
fn a_server_that_falls_silent_is_a_lost_link_within_the_poll_deadline() {
    let sim = SimProcess::start_tcp("emcu");
    let port = sim.link.display().to_string();
    let child = spawn(
        &sim,
        &port,
        &["poll", "--json", "--count", "100000", "--interval-ms", "20"],
    );
    thread::sleep(Duration::from_millis(500));
    signal(sim.pid(), libc::SIGSTOP);
    let stopped = Instant::now();
    let out = wait_child(child, "poll");
    let took = stopped.elapsed();
    signal(sim.pid(), libc::SIGCONT);
    assert_exit(&out, 3, "poll of a silent server");
    assert!(
        text(&out.stderr).contains("link failure"),
        "{}",
        text(&out.stderr)
    );
    assert!(took < Duration::from_secs(2), "{took:?}");
}

/// isel answers nothing while a stored program runs (manual 3.1), so a
/// silent isel line is, for a session that has not moved, a busy controller
/// as much as a dead server (`docs/device.md`, "A controller that is busy"):
/// `poll` says so within the reply deadline, sends nothing that changes
/// motion, waits, and ends normally on Ctrl-C. (Before issue 24 it exited 3.)
#[test]
fn an_isel_server_that_falls_silent_is_said_within_the_poll_deadline_and_waited_for() {
    let sim = SimProcess::start_tcp("isel");
    let port = sim.link.display().to_string();
    let child = spawn(
        &sim,
        &port,
        &["poll", "--json", "--count", "100000", "--interval-ms", "20"],
    );
    thread::sleep(Duration::from_millis(500));
    signal(sim.pid(), libc::SIGSTOP);
    thread::sleep(Duration::from_millis(1500));
    signal(child.id(), libc::SIGINT);
    let out = wait_child(child, "poll");
    signal(sim.pid(), libc::SIGCONT);
    assert_exit(&out, 0, "poll of a silent isel server, interrupted");
    let err = text(&out.stderr);
    assert!(
        err.contains("the controller is busy: a program runs; waiting")
            && err.contains("check the line"),
        "said within 1.5 s:\n{err}"
    );
}

#[test]
fn a_console_on_tcp_hung_up_while_jogging_stops_the_machine() {
    let mut sim = near_reference().tcp().start();
    let profile = write_profile(&sim, "nettest", "");
    let mut console = Console::start_with(&sim, &["--profile", profile]);
    console.initialise_and_reference();
    console.keys(b"c");
    console.wait_for("HOLD");
    console.hold_until_jogging(b"\x1b[C", 5);
    wait_moving(&mut sim, "jogging");
    let at_exit = sim.device_state();
    console.run.close_master();
    let code = console.run.wait_exit(WAIT);
    assert!(
        matches!(code, Some(0 | 1)),
        "exit {code:?} after the hang-up"
    );
    let received = sim.received();
    let motion = isel_motion(&received);
    let last = motion
        .last()
        .unwrap_or_else(|| panic!("no jog:\n{received}"));
    let after: Vec<String> = isel_messages(&received)
        .into_iter()
        .skip_while(|m| m != last)
        .skip(1)
        .collect();
    assert_eq!(
        after.first().map(String::as_str),
        Some("<FD>"),
        "the stop after the jog:\n{received}"
    );
    let state = assert_stands(&mut sim);
    let ran_on = x_steps("isel", &state) - x_steps("isel", &at_exit);
    // jog.max_overrun: 3 mm at 11 200 steps/mm, and the ramp.
    assert!(ran_on.abs() <= 3 * 11_200 + 5_600, "ran on {ran_on} steps");
    sim.assert_alive();
}
