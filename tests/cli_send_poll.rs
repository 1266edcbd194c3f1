//! End to end: `jogterm send` and `jogterm poll` against the real
//! `jogterm sim --protocol isel --pty`, operated on its stdin.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Output, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::thread;
use std::time::Duration;

/// A simulator process; killed when dropped.
struct Sim {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<String>,
    link: PathBuf,
    _dir: tempfile::TempDir,
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Sim {
    fn start() -> Sim {
        let dir = tempfile::tempdir().expect("temp dir");
        let link = dir.path().join("isel");
        let mut child = Command::new(env!("CARGO_BIN_EXE_jogterm"))
            .args(["sim", "--protocol", "isel", "--pty", "--link"])
            .arg(&link)
            .env("JOGTERM_CONFIG_DIR", dir.path())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn the simulator");
        let stdout = child.stdout.take().expect("stdout");
        let (tx, lines) = mpsc::channel();
        thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let stdin = child.stdin.take().expect("stdin");
        let sim = Sim {
            child,
            stdin,
            lines,
            link,
            _dir: dir,
        };
        let first = sim.line();
        assert_eq!(PathBuf::from(first), sim.link);
        sim
    }

    fn line(&self) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(10))
            .expect("a line from the simulator")
    }

    fn operate(&mut self, command: &str) {
        writeln!(self.stdin, "{command}").expect("write stdin");
        self.stdin.flush().expect("flush");
        assert_eq!(self.line(), "ok", "{command}");
    }
}

fn jogterm(port: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_jogterm"));
    c.args(args[..1].iter())
        .arg("--port")
        .arg(port)
        .arg("--protocol")
        .arg("isel")
        .args(&args[1..])
        .env("JOGTERM_CONFIG_DIR", "/nonexistent-jogterm-config");
    c
}

fn run(port: &Path, args: &[&str]) -> Output {
    jogterm(port, args).output().expect("run jogterm")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn send_initialises_references_moves_and_reads_back() {
    let sim = Sim::start();
    let out = run(
        &sim.link,
        &[
            "send",
            "@07",
            "@0d10000,10000,10000",
            "@0R7",
            "@0A 4000,5000,-400,900,0,900,0,900",
            "@0P",
            "@0b1",
            "@0b3",
        ],
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(stdout.contains(">> @0R7\n<< 0 ok\n"), "{stdout}");
    assert!(
        stdout.contains("<< 0 X=4000 Y=-400 Z=0 (steps)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("<< 0 0x03 (00000011): E-stop circuit 1, E-stop circuit 2"),
        "{stdout}"
    );
    assert!(
        stdout.contains(">> @0b3\n<< 0 0x00 (00000000): no input set"),
        "{stdout}"
    );
}

#[test]
fn a_limit_switch_during_a_move_answers_2_and_exits_1() {
    let mut sim = Sim::start();
    let child = jogterm(
        &sim.link,
        &[
            "send",
            "@07",
            "@0N7",
            "@0A 100000,4000,0,900,0,900,0,900",
            "@0P",
        ],
    )
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .spawn()
    .expect("send");
    thread::sleep(Duration::from_millis(1500));
    sim.operate("set limit-x2 on");
    let out = child.wait_with_output().expect("send ends");
    let stdout = text(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{stdout}\n{}",
        text(&out.stderr)
    );
    assert!(stdout.ends_with("<< 2\n"), "{stdout}");
    assert!(
        text(&out.stderr).contains("initialise the axes again and run a reference"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_move_stopped_with_a_soft_stop_answers_f() {
    let sim = Sim::start();
    let out = run(
        &sim.link,
        &[
            "send",
            "@07",
            "@0N7",
            "@0A 100000,4000,0,900,0,900,0,900",
            "0xFD",
        ],
    );
    let stdout = text(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains(">> <FD>\n<< F\n"), "{stdout}");
}

#[test]
fn a_stored_program_is_run() {
    let sim = Sim::start();
    let out = run(
        &sim.link,
        &[
            "send",
            "@07",
            "@0N7",
            "@0k",
            "@0i",
            "0400,2000,0,900,0,900,0,900",
            "133",
            "0-400,2000,0,900,0,900,0,900",
            "9",
            "@0S",
            "@0P",
        ],
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    assert!(
        stdout.contains(">> @0S\n<< 0 ok (sync characters: !)\n"),
        "{stdout}"
    );
    assert!(stdout.ends_with("<< 0 X=0 Y=0 Z=0 (steps)\n"), "{stdout}");
}

#[test]
fn poll_prints_json_samples() {
    let sim = Sim::start();
    let out = run(
        &sim.link,
        &[
            "poll",
            "--json",
            "--count",
            "5",
            "--ports",
            "--interval-ms",
            "20",
        ],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    let lines: Vec<serde_json::Value> = text(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON object per line"))
        .collect();
    assert_eq!(lines.len(), 5);
    for l in &lines {
        assert_eq!(l["pos"].as_array().map(Vec::len), Some(3), "{l}");
        assert_eq!(l["source"], "measured");
        assert_eq!(l["ports"]["1"], 3, "{l}");
        assert!(l["t"].as_f64().is_some());
    }
}

#[test]
fn a_vanished_port_exits_3() {
    let out = run(Path::new("/dev/jogterm-no-such-port"), &["send", "@0P"]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("no such port"));
    let mut sim = Sim::start();
    let child = jogterm(
        &sim.link,
        &["send", "@07", "@0N7", "@0A 100000,4000,0,900,0,900,0,900"],
    )
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .spawn()
    .expect("send");
    thread::sleep(Duration::from_millis(1500));
    sim.operate("fault close");
    let out = child.wait_with_output().expect("send ends");
    assert_eq!(out.status.code(), Some(3), "{}", text(&out.stderr));
    assert!(text(&out.stderr).contains("link failure"));
}

#[test]
fn bad_commands_are_refused_before_anything_is_sent() {
    let dir = tempfile::tempdir().expect("dir");
    let log = dir.path().join("traffic.log");
    let sim = Sim::start();
    let out = jogterm(&sim.link, &["send", "@0P", "@07", "@0A1,2"])
        .arg("--log")
        .arg(&log)
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("command 3 `@0A1,2`: `A` with XYZ takes 4"),
        "{}",
        text(&out.stderr)
    );
    assert!(out.stdout.is_empty(), "nothing sent");
    assert!(!log.exists() || std::fs::read_to_string(&log).unwrap_or_default().is_empty());
}

#[test]
fn the_log_holds_every_byte_with_a_timestamp() {
    let dir = tempfile::tempdir().expect("dir");
    let log = dir.path().join("traffic.log");
    let sim = Sim::start();
    let out = jogterm(&sim.link, &["send", "@0b1"])
        .arg("--log")
        .arg(&log)
        .output()
        .expect("run");
    assert!(out.status.success());
    let logged = std::fs::read_to_string(&log).expect("log");
    let traffic: Vec<&str> = logged
        .lines()
        .filter(|l| l.contains(" >> ") || l.contains(" << "))
        .collect();
    assert!(
        traffic.iter().any(|l| l.ends_with(">> <FD><FF>")),
        "{logged}"
    );
    assert!(
        traffic.iter().any(|l| l.ends_with(">> @0b1<CR>")),
        "{logged}"
    );
    assert!(traffic.iter().any(|l| l.ends_with("<< 003")), "{logged}");
    assert!(
        traffic
            .iter()
            .all(|l| l.len() > 28 && l.as_bytes()[4] == b'-' && l.as_bytes()[26] == b'Z'),
        "{logged}"
    );
}
