//! The simulator's end of the line: a socket (in-process), a pty master or
//! a TCP listener (`jogterm sim --tcp`, a serial port server in raw mode),
//! whether a client is there, and closing and reopening it on request.
//!
//! A pty master reads `EIO` and polls as hung up while no process has the
//! slave open. That is the normal "no client" state: the shell keeps the
//! device running, discards what it transmits (a real line carries it into
//! nothing) and looks every few milliseconds for a client to appear.
//!
//! A TCP line has one client at a time, as ser2net's raw accepter: a second
//! connection is told `Port already in use` and closed; a client that
//! leaves makes room for the next. While the line is closed (`fault
//! close`), every connection is closed at once, as a server whose serial
//! device has gone does.

use std::io::{self, Write};
use std::net::TcpListener;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use rustix::event::PollFlags;

use super::pty::{self, StableLink};
use crate::transport::fd::{self, FdKind};

/// How often a pty without a client is checked for one. Bytes a new client
/// writes wait at most this long before they are read.
const CLIENT_CHECK_INTERVAL: Duration = Duration::from_millis(2);

/// What the outside world can see of a pty line while the shell runs.
#[derive(Debug)]
pub(crate) struct PtyShared {
    pub slave: Mutex<Option<PathBuf>>,
    pub link: Option<StableLink>,
}

impl PtyShared {
    pub fn slave(&self) -> Option<PathBuf> {
        self.slave.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    fn set_slave(&self, path: Option<PathBuf>) {
        *self.slave.lock().unwrap_or_else(|p| p.into_inner()) = path;
    }
}

#[derive(Debug)]
enum Kind {
    Socket,
    Pty(Arc<PtyShared>),
    Tcp(TcpListener),
}

/// What ser2net says to a connection when another client has the port.
pub(crate) const TCP_IN_USE: &[u8] = b"Port already in use\r\n";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Connected,
    /// pty only: no process has the slave open.
    NoClient {
        check_at: Instant,
    },
    Closed {
        reopen_at: Option<Instant>,
    },
}

/// What a read found.
pub(crate) enum ReadOutcome {
    Data(usize),
    /// Nothing more to read now.
    Empty,
}

#[derive(Debug)]
pub(crate) struct Line {
    fd: Option<OwnedFd>,
    kind: Kind,
    state: State,
    /// Bytes that came due while no client was there (or the line was closed).
    pub lost_bytes: u64,
    /// Bytes the client's buffer did not take (it was not reading).
    pub overrun_bytes: u64,
}

impl Line {
    pub fn socket(fd: OwnedFd) -> Self {
        Self {
            fd: Some(fd),
            kind: Kind::Socket,
            state: State::Connected,
            lost_bytes: 0,
            overrun_bytes: 0,
        }
    }

    pub fn pty(master: OwnedFd, shared: Arc<PtyShared>, now: Instant) -> Self {
        Self {
            fd: Some(master),
            kind: Kind::Pty(shared),
            state: State::NoClient { check_at: now },
            lost_bytes: 0,
            overrun_bytes: 0,
        }
    }

    /// Serve on a TCP listener (non-blocking); clients connect to it.
    pub fn tcp(listener: TcpListener) -> Self {
        Self {
            fd: None,
            kind: Kind::Tcp(listener),
            state: State::NoClient {
                check_at: far_future(),
            },
            lost_bytes: 0,
            overrun_bytes: 0,
        }
    }

    /// The listener to wait on for connections (a TCP line).
    pub fn listener_fd(&self) -> Option<BorrowedFd<'_>> {
        match &self.kind {
            Kind::Tcp(listener) => Some(listener.as_fd()),
            _ => None,
        }
    }

    /// Take the connections waiting on a TCP line: the first becomes the
    /// client when there is none; every other is refused and closed.
    pub fn accept(&mut self) {
        let Kind::Tcp(listener) = &self.kind else {
            return;
        };
        while let Ok((mut stream, _)) = listener.accept() {
            let free = matches!(self.state, State::NoClient { .. });
            if !free {
                let refusal = match self.state {
                    State::Closed { .. } => &b""[..],
                    _ => TCP_IN_USE,
                };
                let _ = stream.write_all(refusal);
                continue;
            }
            if stream.set_nonblocking(true).is_err() {
                continue;
            }
            // Replies go out as the wire model releases them, byte by byte:
            // no Nagle wait between them.
            let _ = stream.set_nodelay(true);
            self.fd = Some(OwnedFd::from(stream));
            self.state = State::Connected;
        }
    }

    /// The fd to wait on for input, while a client is connected.
    pub fn readable_fd(&self) -> Option<BorrowedFd<'_>> {
        match self.state {
            State::Connected => self.fd.as_ref().map(|fd| fd.as_fd()),
            _ => None,
        }
    }

    /// When `tick` next has something to do.
    pub fn timer(&self) -> Option<Instant> {
        if let (Kind::Tcp(_), State::NoClient { .. }) = (&self.kind, self.state) {
            // A TCP line learns of clients from its listener, not by looking.
            return None;
        }
        match self.state {
            State::Connected => None,
            State::NoClient { check_at } => Some(check_at),
            State::Closed { reopen_at } => reopen_at,
        }
    }

    /// Look for a client, or reopen a closed pty, when it is time.
    /// An error means a reopen failed; the line then stays closed.
    pub fn tick(&mut self, now: Instant) -> io::Result<()> {
        match self.state {
            State::Connected => {}
            State::NoClient { check_at } if now >= check_at => {
                // A client that opened, wrote and closed again between two
                // checks (`jogterm send break` takes about a millisecond)
                // left its bytes behind: on a real line they went out, so
                // they are read now, not handed to the next client.
                let hung_up = match &self.fd {
                    Some(fd) => {
                        let mut fds = [fd::pollfd(fd.as_fd(), PollFlags::IN)];
                        fd::poll_until(&mut fds, Some(now))?;
                        fds[0].revents().contains(PollFlags::HUP) && !self.bytes_waiting()
                    }
                    None => true,
                };
                self.state = if hung_up {
                    State::NoClient {
                        check_at: now + CLIENT_CHECK_INTERVAL,
                    }
                } else {
                    State::Connected
                };
            }
            State::NoClient { .. } => {}
            State::Closed {
                reopen_at: Some(at),
            } if now >= at => {
                self.state = State::Closed { reopen_at: None };
                self.reopen(now)?;
            }
            State::Closed { .. } => {}
        }
        Ok(())
    }

    /// Read what is there. A client that went away puts a pty into the
    /// no-client state and closes a socket line for good.
    pub fn read(&mut self, buf: &mut [u8], now: Instant) -> ReadOutcome {
        let Some(fd) = &self.fd else {
            return ReadOutcome::Empty;
        };
        if self.state != State::Connected {
            return ReadOutcome::Empty;
        }
        match fd::read_some(fd.as_fd(), buf) {
            Ok(0) => {
                self.client_gone(now);
                ReadOutcome::Empty
            }
            Ok(n) => ReadOutcome::Data(n),
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => ReadOutcome::Empty,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => ReadOutcome::Empty,
            Err(_) => {
                // EIO on a pty master: the slave was closed. Anything else
                // on a socket: the peer is gone.
                self.client_gone(now);
                ReadOutcome::Empty
            }
        }
    }

    /// Hand bytes to the client. What it does not take is lost, as on a real
    /// line whose receiver is not listening.
    pub fn write(&mut self, bytes: &[u8], now: Instant) {
        let (Some(fd), State::Connected) = (&self.fd, self.state) else {
            self.lost_bytes += bytes.len() as u64;
            return;
        };
        let kind = match self.kind {
            Kind::Socket | Kind::Tcp(_) => FdKind::Socket,
            Kind::Pty(_) => FdKind::Tty,
        };
        let mut rest = bytes;
        while !rest.is_empty() {
            match fd::write_some(fd.as_fd(), kind, rest) {
                Ok(0) => break,
                Ok(n) => rest = rest.get(n..).unwrap_or_default(),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(_) => {
                    self.lost_bytes += rest.len() as u64;
                    self.client_gone(now);
                    return;
                }
            }
        }
        self.overrun_bytes += rest.len() as u64;
    }

    /// Close the line; a pty may come back after `reopen_after`.
    pub fn close(&mut self, reopen_after: Option<Duration>, now: Instant) -> Result<(), String> {
        if reopen_after.is_some() && matches!(self.kind, Kind::Socket) {
            return Err(
                "reopening needs a pseudo-terminal or TCP line; this one is a socket pair"
                    .to_owned(),
            );
        }
        let fd = self.fd.take();
        if let (Some(fd), Kind::Socket | Kind::Tcp(_)) = (&fd, &self.kind) {
            // The peer reads EOF even if another copy of the fd were still
            // open somewhere.
            let _ = rustix::net::shutdown(fd, rustix::net::Shutdown::Both);
        }
        // Closing a pty master hangs the slave up: the client's reads end.
        drop(fd);
        if let Kind::Pty(shared) = &self.kind {
            // Like an unplugged USB adapter: the device node and its link vanish.
            if let (Some(link), Some(slave)) = (&shared.link, shared.slave()) {
                link.remove_if_pointing_to(&slave);
            }
            shared.set_slave(None);
        }
        self.state = State::Closed {
            reopen_at: reopen_after.map(|d| now + d),
        };
        Ok(())
    }

    pub fn status(&self, now: Instant) -> String {
        let kind = match &self.kind {
            Kind::Socket => "socket".to_owned(),
            Kind::Pty(shared) => {
                let slave = shared
                    .slave()
                    .map_or_else(|| "no device".to_owned(), |p| p.display().to_string());
                match &shared.link {
                    Some(link) => format!("pty {slave} (link {})", link.path().display()),
                    None => format!("pty {slave}"),
                }
            }
            Kind::Tcp(listener) => match listener.local_addr() {
                Ok(addr) => format!("tcp {addr}"),
                Err(_) => "tcp".to_owned(),
            },
        };
        let state = match self.state {
            State::Connected => "client connected".to_owned(),
            State::NoClient { .. } => "waiting for a client".to_owned(),
            State::Closed { reopen_at: None } => "closed".to_owned(),
            State::Closed {
                reopen_at: Some(at),
            } => format!(
                "closed, reopens in {} ms",
                at.saturating_duration_since(now).as_millis()
            ),
        };
        format!("{kind}, {state}")
    }

    /// Whether bytes a client wrote wait in the pty to be read.
    fn bytes_waiting(&self) -> bool {
        let Some(fd) = &self.fd else {
            return false;
        };
        rustix::io::ioctl_fionread(fd).is_ok_and(|waiting| waiting > 0)
    }

    fn client_gone(&mut self, now: Instant) {
        match &self.kind {
            Kind::Socket => {
                self.fd = None;
                self.state = State::Closed { reopen_at: None };
            }
            Kind::Tcp(_) => {
                // The next client may connect; nothing is kept for it.
                self.fd = None;
                self.state = State::NoClient {
                    check_at: far_future(),
                };
            }
            Kind::Pty(_) => {
                if let Some(fd) = &self.fd {
                    // Bytes written in the moment the client left would be
                    // read by the next client; a line keeps nothing.
                    let _ = rustix::termios::tcflush(fd, rustix::termios::QueueSelector::IOFlush);
                }
                self.state = State::NoClient {
                    check_at: now + CLIENT_CHECK_INTERVAL,
                };
            }
        }
    }

    fn reopen(&mut self, now: Instant) -> io::Result<()> {
        if let Kind::Tcp(_) = self.kind {
            self.state = State::NoClient {
                check_at: far_future(),
            };
            return Ok(());
        }
        let Kind::Pty(shared) = &self.kind else {
            return Ok(());
        };
        let master = pty::open_master()?;
        if let Some(link) = &shared.link {
            link.point_to(&master.slave_path)?;
        }
        shared.set_slave(Some(master.slave_path));
        self.fd = Some(master.fd);
        self.state = State::NoClient { check_at: now };
        Ok(())
    }
}

/// A time that never comes within a session (a TCP line's "no client"
/// state has nothing to look at on a timer).
fn far_future() -> Instant {
    let now = Instant::now();
    now.checked_add(Duration::from_secs(86_400 * 365))
        .unwrap_or(now)
}
