//! The writing end of a port as the paced writer and the emergency handle
//! see it: an fd plus what the link in between does to the bytes. One
//! place knows that a Telnet stream doubles 0xFF, that a TCP socket can
//! hold bytes the server has not acknowledged, and that an RFC 2217 server
//! can discard what it still holds for the serial line.
//!
//! Capabilities, so that the writer stays the same for every link:
//! - [`Sink::write_some`] counts *serial* bytes taken, whatever went on the
//!   socket; an escape pair cut by a full buffer is completed before
//!   anything else is written (a lone IAC would turn the next byte into a
//!   Telnet command);
//! - on TCP, writes wait (`WouldBlock`) while the bytes not yet
//!   acknowledged by the server exceed [`LinkInfo::queue_limit`]: a stalled
//!   network does not pile up a second of commands in front of the next
//!   stop (`docs/network.md`, "What can sit between jogterm and the line");
//! - [`Sink::discard_queued`]: RFC 2217 PURGE-DATA (the server's transmit
//!   buffer); `false` where the link cannot (raw TCP, a socket pair). A tty
//!   could `tcflush(TCOFLUSH)` here; the writer decides when it may;
//! - dropping a TCP sink waits (bounded) until the server has acknowledged
//!   every byte, and the writer's sink closes gracefully: `shutdown(SHUT_WR)`
//!   (a FIN behind the last stop), then what the server still sends is
//!   read and dropped until it closes too. Linux resets a socket that is
//!   closed with unread input, and a reset makes the server drop what it
//!   has received and not yet read: the close's stop, seen lost through
//!   ser2net before this.

use std::borrow::Cow;
use std::io;
use std::os::fd::{AsFd, AsRawFd, BorrowedFd, OwnedFd};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use super::fd::{self, FdKind};
use super::lock::OwnerLock;
use super::rfc2217;
use super::telnet;

/// How serial bytes are put on the link.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Framing {
    /// As they are.
    Raw,
    /// In a Telnet stream; `binary` when the server agreed to receive
    /// binary (else CR goes as CR NUL); `purge` when PURGE-DATA may be sent.
    Telnet { binary: bool, purge: bool },
}

/// What a port's link is, for its sink.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct LinkInfo {
    pub kind: FdKind,
    /// A TCP connection: unacknowledged bytes can be counted (`SIOCOUTQ`).
    pub tcp: bool,
    pub framing: Framing,
    /// TCP: most bytes written and not yet acknowledged before paced writes
    /// wait. Stops never wait for it.
    pub queue_limit: Option<usize>,
}

impl LinkInfo {
    /// A link that passes bytes as they are (a tty, a socket pair).
    pub fn plain(kind: FdKind) -> Self {
        Self {
            kind,
            tcp: false,
            framing: Framing::Raw,
            queue_limit: None,
        }
    }
}

/// How long a closing TCP sink waits for the server's acknowledgement.
pub(crate) const CLOSE_LINGER: Duration = Duration::from_millis(250);

/// How long the writer's sink keeps a connection after the server has
/// acknowledged the last bytes, before it closes its side: a stop's wire
/// time (1 ms at 19200 baud), a USB adapter's latency timer (16 ms) and the
/// server's scheduling. Seen without it: ser2net let go of the port with
/// the close's stop still unread by the controller on the other end.
pub(crate) const CLOSE_SETTLE: Duration = Duration::from_millis(50);

/// The writing end of a port.
#[derive(Debug)]
pub(crate) struct Sink {
    fd: OwnedFd,
    info: LinkInfo,
    /// Encoded bytes that must go before anything else (the rest of an
    /// escaped chunk the socket did not take whole).
    owed: Vec<u8>,
    /// Keeps the port's ownership lock while the sink lives.
    _owner: Option<Arc<OwnerLock>>,
    /// Close the connection gracefully when dropped (the writer's sink,
    /// which writes the last bytes of a session).
    graceful: bool,
}

impl Sink {
    pub fn new(fd: OwnedFd, info: LinkInfo, owner: Option<Arc<OwnerLock>>) -> Self {
        Self {
            fd,
            info,
            owed: Vec::new(),
            _owner: owner,
            graceful: false,
        }
    }

    /// Close a TCP connection gracefully on drop (see the module).
    pub fn closing_gracefully(mut self) -> Self {
        self.graceful = true;
        self
    }

    /// A second sink on a dup of the fd (nothing owed).
    pub fn try_clone(&self) -> io::Result<Sink> {
        Ok(Sink {
            fd: self.fd.try_clone()?,
            info: self.info,
            owed: Vec::new(),
            _owner: self._owner.clone(),
            graceful: false,
        })
    }

    pub fn fd(&self) -> BorrowedFd<'_> {
        self.fd.as_fd()
    }

    pub fn is_tty(&self) -> bool {
        self.info.kind == FdKind::Tty
    }

    pub fn info(&self) -> LinkInfo {
        self.info
    }

    /// Whether [`Sink::discard_queued`] does anything on this link.
    pub fn can_discard(&self) -> bool {
        matches!(self.info.framing, Framing::Telnet { purge: true, .. })
    }

    /// Serial bytes as they go on the link.
    pub fn encode<'a>(&self, data: &'a [u8]) -> Cow<'a, [u8]> {
        match self.info.framing {
            Framing::Raw => Cow::Borrowed(data),
            Framing::Telnet { binary, .. } => Cow::Owned(telnet::escape(data, binary)),
        }
    }

    /// Hand over what the link takes now. Returns how many serial bytes of
    /// `data` were taken (then they are on their way, whole); `WouldBlock`
    /// when nothing could be, so the caller retries later.
    pub fn write_some(&mut self, data: &[u8]) -> io::Result<usize> {
        if !self.flush_owed()? {
            return Err(io::Error::from(io::ErrorKind::WouldBlock));
        }
        if let (true, Some(limit)) = (self.info.tcp, self.info.queue_limit)
            && unacknowledged(self.fd()).is_some_and(|n| n >= limit)
        {
            return Err(io::Error::from(io::ErrorKind::WouldBlock));
        }
        match self.info.framing {
            Framing::Raw => fd::write_some(self.fd.as_fd(), self.info.kind, data),
            Framing::Telnet { binary, .. } => {
                let encoded = telnet::escape(data, binary);
                let n = fd::write_some(self.fd.as_fd(), self.info.kind, &encoded)?;
                if n == 0 {
                    return Ok(0);
                }
                self.owed
                    .extend_from_slice(encoded.get(n..).unwrap_or_default());
                Ok(data.len())
            }
        }
    }

    /// Every serial byte of `data` before `deadline`, past the queue limit
    /// (for stops and the rest of a frame ahead of a stop).
    pub fn write_all_until(&mut self, data: &[u8], deadline: Instant) -> io::Result<()> {
        if !self.owed.is_empty() {
            let owed = std::mem::take(&mut self.owed);
            fd::write_all_until(self.fd.as_fd(), self.info.kind, &owed, deadline)?;
        }
        let encoded = self.encode(data);
        fd::write_all_until(self.fd.as_fd(), self.info.kind, &encoded, deadline)
    }

    /// Ask the far end to drop what it holds for the serial line and has not
    /// sent yet (RFC 2217 PURGE-DATA, transmit buffer). `Ok(false)` when the
    /// link cannot. The request travels behind the bytes already written,
    /// so it drops those the server has not yet put on the line.
    pub fn discard_queued(&mut self, deadline: Instant) -> io::Result<bool> {
        if !self.can_discard() {
            return Ok(false);
        }
        if !self.owed.is_empty() {
            let owed = std::mem::take(&mut self.owed);
            fd::write_all_until(self.fd.as_fd(), self.info.kind, &owed, deadline)?;
        }
        fd::write_all_until(
            self.fd.as_fd(),
            self.info.kind,
            &rfc2217::purge_transmit(),
            deadline,
        )?;
        Ok(true)
    }

    /// TCP: wait until the server has acknowledged every byte written, at
    /// most `timeout`. `Ok(true)` when it has (or the link is no TCP).
    pub fn wait_acknowledged(&self, timeout: Duration) -> io::Result<bool> {
        if !self.info.tcp {
            return Ok(true);
        }
        wait_acknowledged(self.fd(), timeout)
    }

    /// Write the owed bytes that fit now; true when none are left.
    fn flush_owed(&mut self) -> io::Result<bool> {
        while !self.owed.is_empty() {
            match fd::write_some(self.fd.as_fd(), self.info.kind, &self.owed) {
                Ok(0) => return Ok(false),
                Ok(n) => {
                    self.owed.drain(..n.min(self.owed.len()));
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(false),
                Err(e) => return Err(e),
            }
        }
        Ok(true)
    }
}

impl Drop for Sink {
    fn drop(&mut self) {
        if self.info.tcp {
            // Bounded; an error means the link is gone and nothing can be
            // waited for.
            let deadline = Instant::now() + CLOSE_LINGER;
            if !self.owed.is_empty() {
                let _ = fd::write_all_until(self.fd.as_fd(), self.info.kind, &self.owed, deadline);
            }
            let _ = wait_acknowledged(self.fd(), CLOSE_LINGER);
            if self.graceful {
                // The server has the last bytes; give it time to put them on
                // the serial line before it learns the client is gone: a
                // server may close (and flush) its device at once then.
                thread::sleep(CLOSE_SETTLE);
                // SAFETY: shutdown on a socket fd we own.
                unsafe {
                    libc::shutdown(self.fd.as_raw_fd(), libc::SHUT_WR);
                }
                drain_input(self.fd(), Instant::now() + CLOSE_LINGER);
            }
        }
    }
}

/// Read and drop what the peer sends until it closes or `deadline`.
pub(crate) fn drain_input(fd: BorrowedFd<'_>, deadline: Instant) {
    let mut buf = [0u8; 512];
    loop {
        match fd::read_some(fd, &mut buf) {
            Ok(0) => return,
            Ok(_) => {}
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if Instant::now() >= deadline {
                    return;
                }
                let mut fds = [fd::pollfd(fd, libc::POLLIN)];
                if fd::poll_until(&mut fds, Some(deadline)).is_err() {
                    return;
                }
            }
            Err(_) => return,
        }
    }
}

/// Read and drop what has arrived, without waiting.
pub(crate) fn discard_arrived(fd: BorrowedFd<'_>) {
    drain_input(fd, Instant::now());
}

/// Bytes written to a TCP socket and not yet acknowledged by the peer
/// (`SIOCOUTQ`, Linux `tcp(7)`); `None` where the system cannot tell.
pub(crate) fn unacknowledged(fd: BorrowedFd<'_>) -> Option<usize> {
    #[cfg(any(target_os = "linux", target_os = "android"))]
    {
        let mut n: libc::c_int = 0;
        // SAFETY: SIOCOUTQ (= TIOCOUTQ) writes one c_int through the pointer
        // we pass, on an fd valid for the borrow.
        let ok = unsafe { libc::ioctl(fd.as_raw_fd(), libc::TIOCOUTQ, &mut n) };
        (ok == 0).then(|| usize::try_from(n).unwrap_or(0))
    }
    #[cfg(not(any(target_os = "linux", target_os = "android")))]
    {
        let _ = fd;
        None
    }
}

fn wait_acknowledged(fd: BorrowedFd<'_>, timeout: Duration) -> io::Result<bool> {
    let deadline = Instant::now() + timeout;
    loop {
        match unacknowledged(fd) {
            None | Some(0) => return Ok(true),
            Some(_) if Instant::now() >= deadline => return Ok(false),
            // An acknowledgement takes a round trip (a LAN: well under a
            // millisecond); polling every 200 µs costs nothing in the few
            // places that wait (a close, an emergency stop).
            Some(_) => thread::sleep(Duration::from_micros(200)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;
    use std::net::{TcpListener, TcpStream};

    fn tcp_pair() -> (TcpStream, TcpStream) {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let client = TcpStream::connect(listener.local_addr().expect("addr")).expect("connect");
        let (server, _) = listener.accept().expect("accept");
        (client, server)
    }

    fn telnet_sink(stream: TcpStream, binary: bool) -> Sink {
        let fd = OwnedFd::from(stream);
        fd::set_nonblocking(fd.as_fd()).expect("nonblocking");
        Sink::new(
            fd,
            LinkInfo {
                kind: FdKind::Socket,
                tcp: true,
                framing: Framing::Telnet {
                    binary,
                    purge: true,
                },
                queue_limit: Some(64),
            },
            None,
        )
    }

    fn read_exactly(server: &mut TcpStream, n: usize) -> Vec<u8> {
        server
            .set_read_timeout(Some(Duration::from_secs(5)))
            .expect("timeout");
        let mut buf = vec![0u8; n];
        server.read_exact(&mut buf).expect("read");
        buf
    }

    #[test]
    fn telnet_sinks_escape_every_write_and_count_serial_bytes() {
        let (client, mut server) = tcp_pair();
        let mut sink = telnet_sink(client, false);
        assert_eq!(sink.write_some(&[0xFD, 0xFF, b'\r']).expect("write"), 3);
        let deadline = Instant::now() + Duration::from_secs(1);
        sink.write_all_until(&[0xFF], deadline).expect("stop");
        assert!(sink.discard_queued(deadline).expect("purge"));
        assert_eq!(
            read_exactly(&mut server, 5 + 2 + 7),
            [
                0xFD, 0xFF, 0xFF, b'\r', 0, 0xFF, 0xFF, 0xFF, 0xFA, 44, 12, 2, 0xFF, 0xF0
            ]
        );
    }

    #[test]
    fn raw_sinks_pass_bytes_and_cannot_discard() {
        let (client, mut server) = tcp_pair();
        let fd = OwnedFd::from(client);
        fd::set_nonblocking(fd.as_fd()).expect("nonblocking");
        let mut sink = Sink::new(
            fd,
            LinkInfo {
                kind: FdKind::Socket,
                tcp: true,
                framing: Framing::Raw,
                queue_limit: None,
            },
            None,
        );
        assert!(!sink.can_discard());
        assert_eq!(sink.write_some(&[0xFF, 0xFD]).expect("write"), 2);
        assert_eq!(read_exactly(&mut server, 2), [0xFF, 0xFD]);
        assert!(
            sink.wait_acknowledged(Duration::from_secs(1))
                .expect("acked")
        );
    }

    #[test]
    fn paced_writes_wait_while_too_much_is_unacknowledged_and_stops_do_not() {
        let (client, server) = tcp_pair();
        // A server that reads nothing: its receive window fills, nothing
        // written after that is acknowledged.
        let mut sink = telnet_sink(client, true);
        let chunk = [b'x'; 1024];
        let mut taken = 0usize;
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            match sink.write_some(&chunk) {
                Ok(n) => taken += n,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) => panic!("{e}"),
            }
            assert!(Instant::now() < deadline, "never blocked");
        }
        // Loopback acknowledges what fits into the server's buffer; the
        // writes block once 64 bytes stay unacknowledged (or the buffer is
        // full), long before megabytes.
        assert!(taken < 8 << 20, "{taken}");
        let unacked = unacknowledged(sink.fd()).expect("linux");
        assert!(unacked >= 64, "{unacked}");
        // A stop still goes (past the limit), while the socket has room.
        assert_eq!(
            sink.write_some(b"y").map_err(|e| e.kind()),
            Err(io::ErrorKind::WouldBlock)
        );
        sink.write_all_until(&[0xFD], Instant::now() + Duration::from_secs(1))
            .expect("a stop is not held back");
        drop(server);
    }
}
