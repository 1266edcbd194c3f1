//! The real ser2net (Debian's `ser2net` 4.x) in front of a simulator's
//! pseudo-terminal, as it stands in front of a controller in a workshop: a
//! raw accepter (`accepter: tcp,…`) and an RFC 2217 one
//! (`telnet(rfc2217),tcp,…`), both on the simulator's link
//! (`connector: serialdev,<link>,19200n81,local`).
//!
//! ser2net is required, not optional: a machine without it fails these
//! tests with a message that says how to get it (`scripts/test`, the README's test command, installs it).

use std::io::Read;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

/// Where Debian installs it.
const CANDIDATES: [&str; 3] = [
    "/usr/sbin/ser2net",
    "/usr/bin/ser2net",
    "/usr/local/sbin/ser2net",
];

/// The ser2net binary, or a failure that says how to install it.
pub fn ser2net_binary() -> PathBuf {
    if let Some(found) = CANDIDATES.iter().map(PathBuf::from).find(|p| p.exists()) {
        return found;
    }
    if let Ok(out) = Command::new("ser2net").arg("-v").output()
        && out.status.success()
    {
        return PathBuf::from("ser2net");
    }
    panic!(
        "ser2net is required for the network tests and is not installed: \
         `apt-get install -y ser2net` (Debian; scripts/test installs it when it is missing)"
    );
}

/// A running ser2net; killed when dropped.
pub struct Ser2net {
    child: Child,
    stderr: Arc<Mutex<Vec<u8>>>,
    /// `tcp://127.0.0.1:PORT` of the raw accepter.
    pub raw: String,
    /// `rfc2217://127.0.0.1:PORT` of the RFC 2217 accepter.
    pub rfc2217: String,
    _dir: tempfile::TempDir,
}

/// A TCP port nobody listens on now (bound, then let go).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// Whether something listens on 127.0.0.1:`port` (`/proc/net/tcp`, state
/// 0A): asked without connecting, as a connection makes ser2net open the
/// device.
fn listening(port: u16) -> bool {
    let want = format!("0100007F:{port:04X}");
    std::fs::read_to_string("/proc/net/tcp")
        .unwrap_or_default()
        .lines()
        .any(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            f.get(1) == Some(&want.as_str()) && f.get(3) == Some(&"0A")
        })
}

impl Ser2net {
    /// Serve `device` (a pty link) at `baud` on a raw and an RFC 2217
    /// accepter.
    pub fn start(device: &Path, baud: u32) -> Ser2net {
        let binary = ser2net_binary();
        let dir = tempfile::tempdir().expect("dir");
        let (raw, rfc) = (free_port(), free_port());
        let config = format!(
            "%YAML 1.1\n---\n\
             connection: &raw\n  accepter: tcp,127.0.0.1,{raw}\n  \
             connector: serialdev,{dev},{baud}n81,local\n\
             connection: &rfc\n  accepter: telnet(rfc2217),tcp,127.0.0.1,{rfc}\n  \
             connector: serialdev,{dev},{baud}n81,local\n",
            dev = device.display()
        );
        let path = dir.path().join("ser2net.yaml");
        std::fs::write(&path, config).expect("config");
        let mut child = Command::new(&binary)
            // Foreground, messages to stderr, this configuration only, and
            // a pid file of its own (not /run/ser2net.pid).
            .args(["-n", "-d", "-c"])
            .arg(&path)
            .arg("-P")
            .arg(dir.path().join("ser2net.pid"))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", binary.display()));
        // `-d` writes its messages to stdout, errors go to stderr: both kept.
        let stderr = Arc::new(Mutex::new(Vec::new()));
        let outputs: [Box<dyn Read + Send>; 2] = [
            Box::new(child.stdout.take().expect("stdout")),
            Box::new(child.stderr.take().expect("stderr")),
        ];
        for mut output in outputs {
            let sink = stderr.clone();
            thread::spawn(move || {
                let mut buf = [0u8; 1024];
                while let Ok(n) = output.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    sink.lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .extend_from_slice(&buf[..n]);
                }
            });
        }
        let s = Ser2net {
            child,
            stderr,
            raw: format!("tcp://127.0.0.1:{raw}"),
            rfc2217: format!("rfc2217://127.0.0.1:{rfc}"),
            _dir: dir,
        };
        let end = Instant::now() + Duration::from_secs(20);
        while !(listening(raw) && listening(rfc)) {
            assert!(
                Instant::now() < end,
                "ser2net never listened on {raw} and {rfc}:\n{}",
                s.stderr_text()
            );
            thread::sleep(Duration::from_millis(20));
        }
        s
    }

    pub fn stderr_text(&self) -> String {
        String::from_utf8_lossy(&self.stderr.lock().unwrap_or_else(|p| p.into_inner())).into_owned()
    }
}

impl Drop for Ser2net {
    /// SIGTERM first: ser2net then removes the UUCP lock files it holds
    /// for the device (`/run/lock/LCK..…`); killed after a second.
    fn drop(&mut self) {
        if let Ok(pid) = libc::pid_t::try_from(self.child.id()) {
            // SAFETY: a signal to the child this value started.
            unsafe {
                libc::kill(pid, libc::SIGTERM);
            }
        }
        let end = Instant::now() + Duration::from_secs(1);
        while matches!(self.child.try_wait(), Ok(None)) && Instant::now() < end {
            thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
