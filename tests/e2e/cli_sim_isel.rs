//! End to end: the real `jogterm sim --protocol isel --pty`, driven over its
//! pseudo-terminal through jogterm's own transport, and operated on its
//! stdin, byte for byte.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::Receiver;
use std::thread;
use std::time::{Duration, Instant};

use jogterm::transport::{self, PortParts, PortSpec, WriterConfig};
use jogterm::wire::LineSettings;

use crate::sim_process;
use sim_process::{JOGTERM, spawn_with_lines};

/// A simulator process; killed if the test fails half-way.
struct Sim {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
}

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Sim {
    fn start(args: &[&str], config_dir: &std::path::Path) -> Sim {
        let (child, stdin, lines) = spawn_with_lines(
            Command::new(JOGTERM)
                .args(args)
                .env("JOGTERM_CONFIG_DIR", config_dir)
                .stderr(Stdio::inherit()),
        );
        Sim {
            child,
            stdin: Some(stdin),
            lines,
        }
    }

    fn line(&self) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(10))
            .expect("a line from the simulator")
    }

    fn operate(&mut self, command: &str) {
        let stdin = self.stdin.as_mut().expect("stdin open");
        writeln!(stdin, "{command}").expect("write stdin");
        stdin.flush().expect("flush");
        assert_eq!(self.line(), "ok", "{command}");
    }

    /// Close stdin: the simulator ends; its exit status.
    fn finish(mut self) -> std::process::ExitStatus {
        drop(self.stdin.take());
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(status) = self.child.try_wait().expect("wait") {
                return status;
            }
            assert!(Instant::now() < deadline, "the simulator did not end");
            thread::sleep(Duration::from_millis(10));
        }
    }
}

/// Send `request` and read exactly `reply.len()` bytes within `limit`.
async fn cycle(parts: &mut PortParts, request: &[u8], reply: &[u8], limit: Duration) {
    parts
        .writer
        .send(request.to_vec(), transport::Interleave::BetweenBytes)
        .expect("send");
    let mut got = Vec::new();
    let deadline = tokio::time::Instant::now() + limit;
    while got.len() < reply.len() {
        let chunk = tokio::time::timeout_at(deadline, parts.reader.read_chunk())
            .await
            .unwrap_or_else(|_| {
                panic!(
                    "{:?}: got {:?} before the timeout",
                    String::from_utf8_lossy(request),
                    String::from_utf8_lossy(&got)
                )
            })
            .expect("read");
        got.extend(chunk.bytes);
    }
    assert_eq!(
        String::from_utf8_lossy(&got),
        String::from_utf8_lossy(reply),
        "reply to {:?}",
        String::from_utf8_lossy(request)
    );
}

#[test]
fn a_conversation_with_the_isel_simulator_over_its_pty() {
    let dir = tempfile::tempdir().expect("tempdir");
    // The default machine, its axes 1 mm from machine 0: a short reference run.
    let profile: PathBuf = dir.path().join("near.toml");
    std::fs::write(
        &profile,
        "name = \"near\"\ndescription = \"test\"\n[sim]\nstart_position = 1.0\n",
    )
    .expect("write profile");
    let profile = profile.to_string_lossy().into_owned();
    let mut sim = Sim::start(
        &["sim", "--protocol", "isel", "--pty", "--profile", &profile],
        dir.path(),
    );
    let path = sim.line();
    assert!(path.starts_with("/dev/"), "{path}");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    runtime.block_on(async {
        let port = transport::open(PortSpec::Serial {
            path: PathBuf::from(&path),
            line: LineSettings::new(19200),
        })
        .expect("open the simulator's pty");
        let mut parts = port.split(WriterConfig::default()).expect("split");
        let quick = Duration::from_secs(2);
        cycle(&mut parts, b"@07\r", b"0", quick).await;
        cycle(&mut parts, b"@0A100,900,0,900,0,900,0,900\r", b"R", quick).await;
        cycle(&mut parts, b"@0d10000,10000,10000\r", b"0", quick).await;
        cycle(&mut parts, b"@0R7\r", b"0", Duration::from_secs(20)).await;
        cycle(&mut parts, b"@0P\r", b"0000000000000000000", quick).await;
        cycle(
            &mut parts,
            b"@0A4000,8000,2000,8000,400,4000,-400,4000\r",
            b"0",
            Duration::from_secs(10),
        )
        .await;
        cycle(&mut parts, b"@0P\r", b"0000FA00007D0000000", quick).await;
        sim.operate("set limit-x1 on");
        cycle(&mut parts, b"@0b3\r", b"001", quick).await;
        cycle(&mut parts, b"@0A1,100,0,100,0,100,0,100\r", b"2", quick).await;
        sim.operate("set limit-x1 off");
        cycle(&mut parts, b"@0b3\r", b"000", quick).await;
    });
    assert!(sim.finish().success());
}

#[test]
fn usage_errors_exit_2_and_failures_exit_1() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = |args: &[&str]| {
        Command::new(JOGTERM)
            .args(args)
            .env("JOGTERM_CONFIG_DIR", dir.path())
            .stdin(Stdio::null())
            .output()
            .expect("run jogterm")
    };
    assert_eq!(run(&["sim"]).status.code(), Some(2));
    assert_eq!(
        run(&["sim", "--pty", "--protocol", "plc"]).status.code(),
        Some(2)
    );
    let missing = run(&["sim", "--pty", "--profile", "no-such-profile"]);
    assert_eq!(missing.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("no-such-profile"));
    let port = run(&["sim", "--pty", "--port", "/dev/ttyUSB0"]);
    assert_eq!(port.status.code(), Some(1));
    // A variant of another family's simulator is refused, not ignored.
    let variant = run(&["sim", "--pty", "--variant", "emp-rejects-0a-before-on"]);
    assert_eq!(variant.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&variant.stderr).contains("the isel simulator has no such variant")
    );
    let help = run(&["--help"]);
    assert_eq!(help.status.code(), Some(0));
    let text = String::from_utf8_lossy(&help.stdout);
    for word in [
        "sim",
        "--profile",
        "--port",
        "--protocol",
        "--sim",
        "--theme",
        "--log",
    ] {
        assert!(text.contains(word), "--help lacks {word}");
    }
}
