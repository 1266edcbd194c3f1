//! Issue 37 (4): a reconnect writes nothing into a port that has become
//! another device. The console runs on a simulator's pty by its own name
//! (`/dev/pts/N`, as an operator types it); the simulator ends, and the
//! kernel hands the same number to another program (here: this test). The
//! console says that the port is another device now and waits; not one byte
//! reaches that program. Before, it reopened `/dev/pts/N` and wrote its
//! connect sequence (a stop, `@0T0`) into it.

use std::io::Read;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::console_pty::{quit, spawn_on, wait_for};
use crate::sim_process::SimProcess;

/// A pty pair from `openpty` and the path of its slave.
fn pty() -> (std::fs::File, OwnedFd, PathBuf) {
    let (mut master, mut slave) = (-1, -1);
    // SAFETY: openpty writes two descriptors we then own; the null pointers
    // ask for no name buffer, termios or window size.
    let rc = unsafe {
        libc::openpty(
            &mut master,
            &mut slave,
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert_eq!(rc, 0, "openpty: {}", std::io::Error::last_os_error());
    // SAFETY: both are open descriptors nobody else owns.
    let (master, slave) = unsafe { (OwnedFd::from_raw_fd(master), OwnedFd::from_raw_fd(slave)) };
    let path = std::fs::read_link(format!("/proc/self/fd/{}", slave.as_raw_fd()))
        .expect("the slave's path");
    (std::fs::File::from(master), slave, path)
}

/// Take `wanted` as soon as the kernel hands it out again. The kernel
/// hands out the lowest free number: the ptys taken meanwhile are held, so
/// that the numbers below `wanted` fill up, and let go once it is ours
/// (other tests open ptys too, and may hold `wanted` for a while).
fn take_pty(wanted: &Path, within: Duration) -> (std::fs::File, OwnedFd) {
    let end = Instant::now() + within;
    let mut held = Vec::new();
    loop {
        let (master, slave, path) = pty();
        if path == wanted {
            return (master, slave);
        }
        held.push((master, slave));
        if held.len() >= 256 {
            held.clear();
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(
            Instant::now() < end,
            "{} was never handed out again",
            wanted.display()
        );
    }
}

/// What arrives on `master` within `window`.
fn read_for(master: &mut std::fs::File, window: Duration) -> Vec<u8> {
    // SAFETY: switching our own descriptor to non-blocking reads.
    unsafe {
        let fd = master.as_raw_fd();
        let flags = libc::fcntl(fd, libc::F_GETFL);
        libc::fcntl(fd, libc::F_SETFL, flags | libc::O_NONBLOCK);
    }
    let end = Instant::now() + window;
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while Instant::now() < end {
        match master.read(&mut buf) {
            Ok(n) if n > 0 => got.extend_from_slice(&buf[..n]),
            _ => std::thread::sleep(Duration::from_millis(20)),
        }
    }
    got
}

#[test]
fn a_reconnect_writes_nothing_into_a_pty_that_went_to_another_program() {
    let sim = SimProcess::start("isel");
    let device = std::fs::canonicalize(&sim.link).expect("the simulator's pty");
    let state = sim.dir.path().join("state");
    let port = device.display().to_string();
    let mut run = spawn_on(&sim, &state, &["--port", &port, "--protocol", "isel"]);
    wait_for(&run, "connected");
    // The controller goes away: its process and with it its pty end (its
    // directory, the console's configuration, stays).
    let pid = libc::pid_t::try_from(sim.pid()).expect("pid");
    // SAFETY: a signal to our own child.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGKILL) }, 0);
    let (mut master, _slave) = take_pty(&device, Duration::from_secs(60));
    // Several reconnect attempts fall in this window (250 ms doubling).
    let got = read_for(&mut master, Duration::from_secs(4));
    assert!(
        got.is_empty(),
        "the console wrote into another program's pty: {:?}",
        String::from_utf8_lossy(&got)
    );
    let screen = wait_for(&run, "another device now");
    assert!(screen.contains(&port), "{screen}");
    quit(&mut run);
    drop(sim);
}
