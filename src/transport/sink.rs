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
//!   buffer); `false` where the link cannot (raw TCP, a socket pair, and a
//!   tty, on purpose: see the method); the writer decides when it may;
//! - the writer's sink and the emergency handle's share what is owed and
//!   the rest of a frame that must not be cut ([`Sink::write_part`],
//!   [`Sink::write_stop_now`]): an emergency stop from another thread goes
//!   behind the rest of the EMCU line or EMP frame on its way, never into
//!   it (issue 20, the hang-up stop seen as `@` CR `@B` CR `X` CR);
//! - dropping a TCP sink waits (bounded) until the server has acknowledged
//!   every byte, and the writer's sink closes gracefully: `shutdown(SHUT_WR)`
//!   (a FIN behind the last stop), then what the server still sends is
//!   read and dropped until it closes too. Linux resets a socket that is
//!   closed with unread input, and a reset makes the server drop what it
//!   has received and not yet read: the close's stop, seen lost through
//!   ser2net before this.

use std::borrow::Cow;
use std::io;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::sync::{Arc, Mutex, MutexGuard, TryLockError};
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

/// What the sinks on dups of one fd share: the paced writer's and the
/// emergency handle's write from two threads onto one line, and neither may
/// cut what the other has begun.
#[derive(Debug, Default)]
struct Shared {
    /// Encoded bytes that must go before anything else (the rest of an
    /// escaped chunk the socket did not take whole).
    owed: Vec<u8>,
    /// A frame that must not be cut ([`Sink::write_part`] with `whole`),
    /// partly handed over: its tag and the serial bytes still to come.
    unfinished: Option<(u64, Vec<u8>)>,
    /// The tag of an unfinished frame another sink has completed, for the
    /// one that began it to learn.
    completed: Option<u64>,
}

/// How much of a message [`Sink::write_part`] took.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Taken {
    /// This many serial bytes (0: none fit now).
    Bytes(usize),
    /// None: another sink (the emergency handle) has already written the
    /// whole rest of this frame, ahead of its stop.
    CompletedElsewhere,
}

/// The writing end of a port.
#[derive(Debug)]
pub(crate) struct Sink {
    fd: OwnedFd,
    info: LinkInfo,
    /// Shared by every sink cloned from this one ([`Sink::try_clone`]).
    shared: Arc<Mutex<Shared>>,
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
            shared: Arc::default(),
            _owner: owner,
            graceful: false,
        }
    }

    /// Close a TCP connection gracefully on drop (see the module).
    pub fn closing_gracefully(mut self) -> Self {
        self.graceful = true;
        self
    }

    /// A second sink on a dup of the fd. It shares what is owed and what is
    /// unfinished with this one: writes through either never cut a frame
    /// or an escape pair the other has begun.
    pub fn try_clone(&self) -> io::Result<Sink> {
        Ok(Sink {
            fd: self.fd.try_clone()?,
            info: self.info,
            shared: self.shared.clone(),
            _owner: self._owner.clone(),
            graceful: false,
        })
    }

    /// The shared state, held for one write. A thread that panicked while
    /// holding it left it consistent between two writes: still usable.
    fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared.lock().unwrap_or_else(|p| p.into_inner())
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

    /// Hand over what the link takes now (tests; the writer uses
    /// [`Sink::write_part`]).
    #[cfg(test)]
    pub fn write_some(&mut self, data: &[u8]) -> io::Result<usize> {
        match self.write_part(None, data, data.len())? {
            Taken::Bytes(n) => Ok(n),
            Taken::CompletedElsewhere => Ok(0),
        }
    }

    /// Hand over up to `n` serial bytes of `rest`, what the link takes now.
    /// [`Taken::Bytes`] counts serial bytes taken (then they are on their
    /// way, whole); `WouldBlock` when nothing could be, so the caller
    /// retries later.
    ///
    /// `frame`: `rest` is (the rest of) a frame that must not be cut, tagged
    /// so; while part of it is still to come, an emergency write on a clone
    /// of this sink writes that part ahead of its stop, and this sink then
    /// answers [`Taken::CompletedElsewhere`] for the tag.
    pub fn write_part(&self, frame: Option<u64>, rest: &[u8], n: usize) -> io::Result<Taken> {
        let mut shared = self.lock();
        if let Some(tag) = frame
            && shared.completed == Some(tag)
        {
            shared.completed = None;
            return Ok(Taken::CompletedElsewhere);
        }
        if !flush_owed(self.fd(), self.info.kind, &mut shared.owed)? {
            return Err(io::Error::from(io::ErrorKind::WouldBlock));
        }
        if let (true, Some(limit)) = (self.info.tcp, self.info.queue_limit)
            && unacknowledged(self.fd()).is_some_and(|n| n >= limit)
        {
            return Err(io::Error::from(io::ErrorKind::WouldBlock));
        }
        let data = rest.get(..n.min(rest.len())).unwrap_or_default();
        let taken = match self.info.framing {
            Framing::Raw => fd::write_some(self.fd(), self.info.kind, data)?,
            Framing::Telnet { binary, .. } => {
                let encoded = telnet::escape(data, binary);
                let w = fd::write_some(self.fd(), self.info.kind, &encoded)?;
                if w == 0 {
                    0
                } else {
                    shared
                        .owed
                        .extend_from_slice(encoded.get(w..).unwrap_or_default());
                    data.len()
                }
            }
        };
        if let Some(tag) = frame
            && taken > 0
        {
            shared.unfinished = rest
                .get(taken..)
                .filter(|left| !left.is_empty())
                .map(|left| (tag, left.to_vec()));
        }
        Ok(Taken::Bytes(taken))
    }

    /// Every serial byte of `data` before `deadline`, past the queue limit
    /// (tests; the writer uses [`Sink::write_rest_until`]).
    #[cfg(test)]
    pub fn write_all_until(&mut self, data: &[u8], deadline: Instant) -> io::Result<()> {
        self.write_rest_until(None, data, deadline).map(|_| ())
    }

    /// The whole rest of a message before `deadline`, past the queue limit
    /// (a frame ahead of a stop, a message on the line at close). `frame`
    /// as for [`Sink::write_part`].
    pub fn write_rest_until(
        &self,
        frame: Option<u64>,
        rest: &[u8],
        deadline: Instant,
    ) -> io::Result<Taken> {
        let mut shared = self.lock();
        if let Some(tag) = frame {
            if shared.completed == Some(tag) {
                shared.completed = None;
                return Ok(Taken::CompletedElsewhere);
            }
            shared.unfinished = None;
        }
        let owed = std::mem::take(&mut shared.owed);
        fd::write_all_until(self.fd(), self.info.kind, &owed, deadline)?;
        let encoded = self.encode(rest);
        fd::write_all_until(self.fd(), self.info.kind, &encoded, deadline)?;
        Ok(Taken::Bytes(rest.len()))
    }

    /// An emergency stop: `stop` as one write, behind the rest of a frame a
    /// clone of this sink has begun (at most one line or frame: an EMCU
    /// line or an EMP frame cut by stop bytes is a malformed command, or
    /// swallows the stop), or right away when none is. The shared state is
    /// waited for until `deadline` only (the other writer holds it for one
    /// write); past it the stop goes without, as a stop that may cut beats
    /// no stop.
    pub fn write_stop_now(&self, stop: &[u8], deadline: Instant) -> io::Result<()> {
        let mut out = Vec::new();
        let shared = lock_until(&self.shared, deadline);
        if let Some(mut shared) = shared {
            out.append(&mut shared.owed);
            if let Some((tag, rest)) = shared.unfinished.take() {
                out.extend_from_slice(&self.encode(&rest));
                shared.completed = Some(tag);
            }
            out.extend_from_slice(&self.encode(stop));
            return fd::write_all_until(self.fd(), self.info.kind, &out, deadline);
        }
        out.extend_from_slice(&self.encode(stop));
        fd::write_all_until(self.fd(), self.info.kind, &out, deadline)
    }

    /// Ask the far end to drop what it holds for the serial line and has not
    /// sent yet (RFC 2217 PURGE-DATA, transmit buffer). `Ok(false)` when the
    /// link cannot. The request travels behind the bytes already written,
    /// so it drops those the server has not yet put on the line.
    ///
    /// A tty has no arm here on purpose (`docs/performance.md`, "Whole
    /// commands"): `tcflush(TCOFLUSH)` reaches neither a UART's FIFO nor a
    /// USB transfer already submitted, which is where a short command is
    /// once written, and what it does drop cannot be counted exactly (a
    /// byte may leave between `TIOCOUTQ` and the flush), so the cut line
    /// could not be repaired exactly.
    pub fn discard_queued(&mut self, deadline: Instant) -> io::Result<bool> {
        if !self.can_discard() {
            return Ok(false);
        }
        let mut shared = self.lock();
        let owed = std::mem::take(&mut shared.owed);
        fd::write_all_until(self.fd(), self.info.kind, &owed, deadline)?;
        fd::write_all_until(
            self.fd(),
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
}

/// Write the owed bytes that fit now; true when none are left.
fn flush_owed(fd: BorrowedFd<'_>, kind: FdKind, owed: &mut Vec<u8>) -> io::Result<bool> {
    while !owed.is_empty() {
        match fd::write_some(fd, kind, owed) {
            Ok(0) => return Ok(false),
            Ok(n) => {
                owed.drain(..n.min(owed.len()));
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(false),
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

/// Take the lock if it comes free before `deadline`; past it, go on without.
/// A poisoned lock is still a lock.
fn lock_until<T>(lock: &Mutex<T>, deadline: Instant) -> Option<MutexGuard<'_, T>> {
    loop {
        match lock.try_lock() {
            Ok(guard) => return Some(guard),
            Err(TryLockError::Poisoned(p)) => return Some(p.into_inner()),
            Err(TryLockError::WouldBlock) => {
                if Instant::now() >= deadline {
                    return None;
                }
                thread::sleep(Duration::from_micros(50));
            }
        }
    }
}

impl Drop for Sink {
    fn drop(&mut self) {
        if self.info.tcp {
            // Bounded; an error means the link is gone and nothing can be
            // waited for.
            let deadline = Instant::now() + CLOSE_LINGER;
            let owed = std::mem::take(&mut self.lock().owed);
            let _ = fd::write_all_until(self.fd(), self.info.kind, &owed, deadline);
            let _ = wait_acknowledged(self.fd(), CLOSE_LINGER);
            if self.graceful {
                // The server has the last bytes; give it time to put them on
                // the serial line before it learns the client is gone: a
                // server may close (and flush) its device at once then.
                thread::sleep(CLOSE_SETTLE);
                let _ = rustix::net::shutdown(&self.fd, rustix::net::Shutdown::Write);
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
                let mut fds = [fd::pollfd(fd, rustix::event::PollFlags::IN)];
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
        // Hand-written: rustix wraps `FIONREAD` but not `TIOCOUTQ`, and its
        // generic ioctl is as unsafe as this call and still needs libc's
        // number for it (which differs between architectures).
        use std::os::fd::AsRawFd;
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

    #[test]
    fn an_emergency_stop_completes_the_frame_another_sink_has_begun() {
        let (client, mut server) = tcp_pair();
        let fd = OwnedFd::from(client);
        fd::set_nonblocking(fd.as_fd()).expect("nonblocking");
        let writer = Sink::new(fd, LinkInfo::plain(FdKind::Socket), None);
        let emergency = writer.try_clone().expect("clone");
        let deadline = Instant::now() + Duration::from_secs(1);
        // The writer has handed over the head of a line that must not be cut.
        let line = b"@LX\r";
        assert_eq!(
            writer.write_part(Some(7), line, 1).expect("head"),
            Taken::Bytes(1)
        );
        emergency.write_stop_now(b"\r@B\r", deadline).expect("stop");
        // The line's rest went first; the writer learns it has nothing left.
        assert_eq!(read_exactly(&mut server, 8), *b"@LX\r\r@B\r");
        let rest = line.get(1..).unwrap_or_default();
        assert_eq!(
            writer.write_part(Some(7), rest, rest.len()).expect("rest"),
            Taken::CompletedElsewhere
        );
        // A message that may be cut (isel) is not completed: the stop goes
        // at once, and the writer writes its own rest.
        assert_eq!(
            writer.write_part(None, b"@0P\r", 2).expect("head"),
            Taken::Bytes(2)
        );
        emergency.write_stop_now(&[0xFD], deadline).expect("stop");
        assert_eq!(
            writer.write_part(None, b"P\r", 2).expect("rest"),
            Taken::Bytes(2)
        );
        assert_eq!(
            read_exactly(&mut server, 5),
            [b'@', b'0', 0xFD, b'P', b'\r']
        );
        // A frame written whole leaves nothing for a stop to complete.
        assert_eq!(
            writer.write_part(Some(8), line, 4).expect("whole"),
            Taken::Bytes(4)
        );
        emergency.write_stop_now(b"\r@B\r", deadline).expect("stop");
        assert_eq!(read_exactly(&mut server, 8), *b"@LX\r\r@B\r");
    }
}
