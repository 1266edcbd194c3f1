//! Thin, panic-free wrappers around the unix calls the transport and the
//! simulator shell share: non-blocking reads and writes on a borrowed fd,
//! waits with sub-millisecond deadlines, a bounded `tcdrain`, and the one
//! place that decides which errors mean "the link is gone".

use std::io;
use std::os::fd::{AsRawFd, BorrowedFd, OwnedFd};
use std::sync::mpsc;
use std::thread;
use std::time::{Duration, Instant};

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
    // SAFETY: `fd` is a valid open descriptor for the duration of the borrow.
    if unsafe { libc::isatty(fd.as_raw_fd()) } == 1 {
        return FdKind::Tty;
    }
    // SAFETY: `stat` is plain data; fstat writes it completely on success.
    let mut st: libc::stat = unsafe { std::mem::zeroed() };
    // SAFETY: valid fd, valid pointer to a stat buffer.
    if unsafe { libc::fstat(fd.as_raw_fd(), &mut st) } == 0
        && (st.st_mode & libc::S_IFMT) == libc::S_IFSOCK
    {
        return FdKind::Socket;
    }
    FdKind::Other
}

pub(crate) fn set_nonblocking(fd: BorrowedFd<'_>) -> io::Result<()> {
    // SAFETY: fcntl on a valid fd with integer arguments.
    let flags = unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_GETFL) };
    if flags < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: as above.
    if unsafe { libc::fcntl(fd.as_raw_fd(), libc::F_SETFL, flags | libc::O_NONBLOCK) } < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// One `read(2)`. `Ok(0)` means end of stream; `WouldBlock` means no data now.
pub(crate) fn read_some(fd: BorrowedFd<'_>, buf: &mut [u8]) -> io::Result<usize> {
    // SAFETY: the buffer is valid for `buf.len()` bytes of writes.
    let n = unsafe { libc::read(fd.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
    if n < 0 {
        Err(io::Error::last_os_error())
    } else {
        Ok(n as usize)
    }
}

/// One `write(2)`, or `send(2)` with `MSG_NOSIGNAL` on a socket so that a
/// vanished peer is an `EPIPE` error and not a process-killing SIGPIPE.
pub(crate) fn write_some(fd: BorrowedFd<'_>, kind: FdKind, bytes: &[u8]) -> io::Result<usize> {
    let n = match kind {
        // SAFETY: the buffer is valid for `bytes.len()` bytes of reads.
        FdKind::Socket => unsafe {
            libc::send(
                fd.as_raw_fd(),
                bytes.as_ptr().cast(),
                bytes.len(),
                libc::MSG_NOSIGNAL,
            )
        },
        // SAFETY: as above.
        FdKind::Tty | FdKind::Other => unsafe {
            libc::write(fd.as_raw_fd(), bytes.as_ptr().cast(), bytes.len())
        },
    };
    if n < 0 {
        Err(io::Error::last_os_error())
    } else {
        Ok(n as usize)
    }
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
                let mut fds = [pollfd(fd, libc::POLLOUT)];
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
        err.raw_os_error(),
        Some(
            libc::EIO
                | libc::ENXIO
                | libc::ENODEV
                | libc::EPIPE
                | libc::ECONNRESET
                | libc::ENOTCONN
                | libc::ESHUTDOWN
                | libc::ETIMEDOUT
                | libc::EHOSTUNREACH
                | libc::ENETUNREACH
                | libc::ENETDOWN
                | libc::EHOSTDOWN
                | libc::ECONNABORTED
        )
    ) || matches!(
        err.kind(),
        io::ErrorKind::BrokenPipe | io::ErrorKind::ConnectionReset | io::ErrorKind::NotConnected
    )
}

pub(crate) fn pollfd(fd: BorrowedFd<'_>, events: libc::c_short) -> libc::pollfd {
    libc::pollfd {
        fd: fd.as_raw_fd(),
        events,
        revents: 0,
    }
}

/// Wait until one of `fds` is ready or `deadline` has passed (`None`: no
/// deadline). Returns how many fds are ready; 0 means the deadline passed.
/// Never returns before the deadline unless an fd is ready or a signal came.
///
/// Linux's `ppoll` takes a nanosecond timeout; plain `poll` counts whole
/// milliseconds, which is two byte times at 38400 baud.
pub(crate) fn poll_until(fds: &mut [libc::pollfd], deadline: Option<Instant>) -> io::Result<usize> {
    let timeout = deadline.map(|d| d.saturating_duration_since(Instant::now()));
    let n = sys_poll(fds, timeout);
    if n < 0 {
        let e = io::Error::last_os_error();
        if e.kind() == io::ErrorKind::Interrupted {
            return Ok(0);
        }
        return Err(e);
    }
    Ok(n as usize)
}

#[cfg(any(target_os = "linux", target_os = "android"))]
fn sys_poll(fds: &mut [libc::pollfd], timeout: Option<Duration>) -> libc::c_int {
    let ts = timeout.map(|t| libc::timespec {
        tv_sec: t.as_secs().min(i32::MAX as u64) as libc::time_t,
        tv_nsec: t.subsec_nanos() as libc::c_long,
    });
    let ts_ptr = ts
        .as_ref()
        .map_or(std::ptr::null(), |t| t as *const libc::timespec);
    // SAFETY: `fds` is a valid slice of pollfd; `ts_ptr` is null or points at a
    // timespec that lives until the call returns; a null sigmask keeps the mask.
    unsafe {
        libc::ppoll(
            fds.as_mut_ptr(),
            fds.len() as libc::nfds_t,
            ts_ptr,
            std::ptr::null(),
        )
    }
}

#[cfg(not(any(target_os = "linux", target_os = "android")))]
fn sys_poll(fds: &mut [libc::pollfd], timeout: Option<Duration>) -> libc::c_int {
    // Rounded up so that a wait is never shorter than asked: late, never early.
    let ms = timeout.map_or(-1, |t| {
        let ms = t.as_nanos().div_ceil(1_000_000);
        ms.min(i32::MAX as u128) as libc::c_int
    });
    // SAFETY: `fds` is a valid slice of pollfd.
    unsafe { libc::poll(fds.as_mut_ptr(), fds.len() as libc::nfds_t, ms) }
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
            // SAFETY: tcdrain on an fd this thread owns.
            let r = unsafe { libc::tcdrain(own.as_raw_fd()) };
            let res = if r == 0 {
                Ok(())
            } else {
                Err(io::Error::last_os_error())
            };
            let _ = tx.send(res);
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
    // SAFETY: PR_SET_TIMERSLACK takes one integer argument (nanoseconds) and
    // only affects the calling thread.
    unsafe {
        libc::prctl(libc::PR_SET_TIMERSLACK, 1 as libc::c_ulong, 0, 0, 0);
    }
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
        let mut fds = [pollfd(a.as_fd(), libc::POLLIN)];
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
