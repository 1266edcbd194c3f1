//! Thin, panic-free wrappers around the unix calls the transport and the
//! simulator shell share: non-blocking reads and writes on a borrowed fd,
//! waits with sub-millisecond deadlines, a bounded `tcdrain`, and the one
//! place that decides which errors mean "the link is gone".
//!
//! The calls themselves are rustix's (safe, and the same system calls);
//! what is here is the policy around them: deadlines, retries, draining on
//! a thread of its own.

use std::io::{self, IsTerminal};
use std::os::fd::{BorrowedFd, OwnedFd};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

use rustix::event::{PollFd, PollFlags, Timespec};
use rustix::fs::{FileType, OFlags};
use rustix::io::Errno;
use rustix::net::SendFlags;

/// What kind of file an fd refers to; decides how it is written and drained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FdKind {
    /// A terminal: a real serial port or a pseudo-terminal. Has a line to drain.
    Tty,
    /// A socket (an in-process socket pair to a built-in simulator).
    Socket,
    /// Anything else (a pipe, in tests).
    Other,
}

pub(crate) fn kind_of(fd: BorrowedFd<'_>) -> FdKind {
    if fd.is_terminal() {
        return FdKind::Tty;
    }
    match rustix::fs::fstat(fd) {
        Ok(st) if FileType::from_raw_mode(st.st_mode) == FileType::Socket => FdKind::Socket,
        _ => FdKind::Other,
    }
}

pub(crate) fn set_nonblocking(fd: BorrowedFd<'_>) -> io::Result<()> {
    let flags = rustix::fs::fcntl_getfl(fd)?;
    rustix::fs::fcntl_setfl(fd, flags | OFlags::NONBLOCK)?;
    Ok(())
}

/// One `read(2)`. `Ok(0)` means end of stream; `WouldBlock` means no data now.
pub(crate) fn read_some(fd: BorrowedFd<'_>, buf: &mut [u8]) -> io::Result<usize> {
    Ok(rustix::io::read(fd, buf)?)
}

/// One `write(2)`, or `send(2)` with `MSG_NOSIGNAL` on a socket so that a
/// vanished peer is an `EPIPE` error and not a process-killing SIGPIPE.
pub(crate) fn write_some(fd: BorrowedFd<'_>, kind: FdKind, bytes: &[u8]) -> io::Result<usize> {
    Ok(match kind {
        FdKind::Socket => rustix::net::send(fd, bytes, SendFlags::NOSIGNAL)?,
        FdKind::Tty | FdKind::Other => rustix::io::write(fd, bytes)?,
    })
}

/// Write every byte before `deadline`, waiting for room when the fd is
/// non-blocking and its buffer is full. Never waits past the deadline.
pub(crate) fn write_all_until(
    fd: BorrowedFd<'_>,
    kind: FdKind,
    mut bytes: &[u8],
    deadline: Instant,
) -> io::Result<()> {
    while !bytes.is_empty() {
        match write_some(fd, kind, bytes) {
            Ok(0) => return Err(io::Error::from(io::ErrorKind::WriteZero)),
            Ok(n) => bytes = bytes.get(n..).unwrap_or_default(),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if Instant::now() >= deadline {
                    return Err(io::Error::from(io::ErrorKind::TimedOut));
                }
                let mut fds = [pollfd(fd, PollFlags::OUT)];
                poll_until(&mut fds, Some(deadline))?;
            }
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Errors that mean the other end is gone for good: a USB adapter unplugged
/// (`EIO`, `ENXIO`, `ENODEV`), a pseudo-terminal whose other side closed
/// (`EIO`), a socket whose peer closed (`EPIPE`, `ECONNRESET`, `ENOTCONN`),
/// a TCP connection that keep-alive or `TCP_USER_TIMEOUT` gave up on
/// (`ETIMEDOUT`) or whose network went away (`EHOSTUNREACH`, `ENETUNREACH`,
/// `ENETDOWN`, `EHOSTDOWN`, `ECONNABORTED`).
pub(crate) fn is_link_gone(err: &io::Error) -> bool {
    matches!(
        Errno::from_io_error(err),
        Some(
            Errno::IO
                | Errno::NXIO
                | Errno::NODEV
                | Errno::PIPE
                | Errno::CONNRESET
                | Errno::NOTCONN
                | Errno::SHUTDOWN
                | Errno::TIMEDOUT
                | Errno::HOSTUNREACH
                | Errno::NETUNREACH
                | Errno::NETDOWN
                | Errno::HOSTDOWN
                | Errno::CONNABORTED
        )
    ) || matches!(
        err.kind(),
        io::ErrorKind::BrokenPipe | io::ErrorKind::ConnectionReset | io::ErrorKind::NotConnected
    )
}

pub(crate) fn pollfd(fd: BorrowedFd<'_>, events: PollFlags) -> PollFd<'_> {
    PollFd::from_borrowed_fd(fd, events)
}

/// Wait until one of `fds` is ready or `deadline` has passed (`None`: no
/// deadline). Returns how many fds are ready; 0 means the deadline passed.
/// Never returns before the deadline unless an fd is ready or a signal came.
///
/// rustix's `poll` is Linux's `ppoll`, with a nanosecond timeout: plain
/// `poll` counts whole milliseconds, which is two byte times at 38400 baud.
/// (Where there is no `ppoll`, rustix rounds the timeout up to whole
/// milliseconds: late, never early.)
pub(crate) fn poll_until(fds: &mut [PollFd<'_>], deadline: Option<Instant>) -> io::Result<usize> {
    let timeout = deadline.map(|d| {
        let t = d.saturating_duration_since(Instant::now());
        Timespec {
            tv_sec: t.as_secs().min(i32::MAX as u64) as _,
            tv_nsec: t.subsec_nanos().into(),
        }
    });
    match rustix::event::poll(fds, timeout.as_ref()) {
        Ok(n) => Ok(n),
        Err(Errno::INTR) => Ok(0),
        Err(e) => Err(e.into()),
    }
}

/// Wait until the bytes written to a terminal have left it (`tcdrain`), but no
/// longer than `timeout`. `tcdrain` itself can block without end when a
/// driver or adapter hangs, so it runs on a helper thread with its own dup of
/// the fd; on timeout the helper is left to finish on its own.
/// Returns `Ok(true)` when drained, `Ok(false)` on timeout.
pub(crate) fn drain_bounded(fd: BorrowedFd<'_>, timeout: Duration) -> io::Result<bool> {
    let own: OwnedFd = fd.try_clone_to_owned()?;
    let (tx, rx) = mpsc::channel();
    thread::Builder::new()
        .name("jogterm-tcdrain".into())
        .spawn(move || {
            let _ = tx.send(rustix::termios::tcdrain(&own).map_err(io::Error::from));
        })?;
    match rx.recv_timeout(timeout) {
        Ok(Ok(())) => Ok(true),
        Ok(Err(e)) => Err(e),
        Err(_) => Ok(false),
    }
}

/// Ask the kernel to wake this thread's timed waits within a microsecond of
/// the deadline instead of the default 50 µs slack: the pacing threads wait
/// once per byte (0.26 ms at 38400 baud). Best effort; other unix keep slack.
pub(crate) fn tighten_timer_slack() {
    #[cfg(any(target_os = "linux", target_os = "android"))]
    let _ = rustix::thread::set_current_timer_slack(std::num::NonZeroU64::new(1));
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::fd::AsFd;
    use std::os::unix::net::UnixStream;

    #[test]
    fn socket_peer_gone_is_link_gone_and_no_sigpipe() {
        let (a, b) = UnixStream::pair().expect("socketpair");
        drop(b);
        let err = write_some(a.as_fd(), kind_of(a.as_fd()), b"x").expect_err("peer closed");
        assert!(is_link_gone(&err), "{err:?}");
        assert_eq!(kind_of(a.as_fd()), FdKind::Socket);
    }

    #[test]
    fn poll_until_waits_at_least_until_the_deadline() {
        let (a, _b) = UnixStream::pair().expect("socketpair");
        let start = Instant::now();
        let deadline = start + Duration::from_micros(700);
        let mut fds = [pollfd(a.as_fd(), PollFlags::IN)];
        let n = poll_until(&mut fds, Some(deadline)).expect("poll");
        assert_eq!(n, 0);
        assert!(Instant::now() >= deadline);
    }

    #[test]
    fn write_all_until_gives_up_at_the_deadline_when_nobody_reads() {
        let (a, _b) = UnixStream::pair().expect("socketpair");
        set_nonblocking(a.as_fd()).expect("nonblocking");
        let big = vec![0u8; 8 << 20];
        let deadline = Instant::now() + Duration::from_millis(30);
        let err = write_all_until(a.as_fd(), FdKind::Socket, &big, deadline).expect_err("full");
        assert_eq!(err.kind(), io::ErrorKind::TimedOut);
    }
}
