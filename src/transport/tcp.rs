//! Opening a serial port server: resolve, lock, connect with a timeout,
//! set the socket up for a control line, and for `rfc2217://` run the
//! negotiation ([`super::rfc2217`]) until the remote port is set.
//!
//! Socket settings (`docs/network.md`):
//! - `TCP_NODELAY`: a stop byte goes at once, not after Nagle's wait for an
//!   acknowledgement of the bytes before it;
//! - a small send buffer (`SO_SNDBUF`) and, in the sink, a bound on bytes
//!   not yet acknowledged: what waits in front of a stop stays small;
//! - keep-alive after 1 s idle, every 1 s, 3 probes, and `TCP_USER_TIMEOUT`
//!   3 s: a network that died is a lost link within seconds even when
//!   nothing is being polled (while polling, the driver's own deadline
//!   notices first, as on a tty whose controller fell silent).
//!
//! Blocking: the device task runs it on a blocking thread.

use std::io;
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::address::{NetMode, NetTarget};
use super::error::TransportError;
use super::fd::{self, FdKind};
use super::lock::{self, OwnerLock};
use super::rfc2217::{Negotiation, Progress};
use super::sink::{Framing, LinkInfo};
use super::telnet;
use crate::wire::LineSettings;

/// Tuning of a network port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NetOptions {
    /// Bound on one TCP connect.
    pub connect_timeout: Duration,
    /// Bound on the RFC 2217 negotiation.
    pub negotiation_timeout: Duration,
    /// A server that closes the connection within this time of accepting
    /// it has refused it (ser2net: "Port already in use").
    pub refusal_window: Duration,
    pub keepalive_idle: Duration,
    pub keepalive_interval: Duration,
    pub keepalive_count: u32,
    /// Written bytes unacknowledged for this long end the connection.
    pub user_timeout: Duration,
    /// `SO_SNDBUF` asked for (Linux doubles it and keeps a minimum).
    pub send_buffer: usize,
    /// Paced writes wait while more than this much wire time is written and
    /// not yet acknowledged by the server (at least [`MIN_QUEUE_BYTES`]).
    pub unacknowledged: Duration,
    /// RFC 2217: send PURGE-DATA (the server's transmit buffer) right before
    /// a stop where it cannot cut a command (`PacedWriter`). Off: ser2net
    /// 4.3 applied the purge after the stop bytes that followed it and
    /// dropped them, in 2 of 6 runs of `tests/e2e/network.rs` under load (none
    /// of 9 without; `docs/network.md`). Only for a server known to apply
    /// it in order.
    pub purge_before_stop: bool,
}

/// The unacknowledged bound never goes below this: a server acknowledges
/// small segments late (delayed ACK, 40 ms on Linux), and a bound below
/// what one delayed acknowledgement covers would halve the throughput.
pub const MIN_QUEUE_BYTES: usize = 64;

impl Default for NetOptions {
    fn default() -> Self {
        Self {
            connect_timeout: Duration::from_secs(3),
            negotiation_timeout: Duration::from_secs(3),
            refusal_window: Duration::from_millis(100),
            keepalive_idle: Duration::from_secs(1),
            keepalive_interval: Duration::from_secs(1),
            keepalive_count: 3,
            user_timeout: Duration::from_secs(3),
            send_buffer: 4096,
            unacknowledged: Duration::from_millis(60),
            purge_before_stop: false,
        }
    }
}

impl NetOptions {
    /// The unacknowledged bound in bytes for a line.
    pub fn queue_limit(&self, line: LineSettings) -> usize {
        let bytes = line.bytes_per_second() * self.unacknowledged.as_secs_f64();
        (bytes.ceil() as usize).max(MIN_QUEUE_BYTES)
    }
}

/// A connected, set-up serial port server.
#[derive(Debug)]
pub(crate) struct Connected {
    pub fd: OwnedFd,
    pub link: LinkInfo,
    /// The decoder of the incoming Telnet stream (rfc2217), in the state
    /// the negotiation left it.
    pub decoder: Option<telnet::Decoder>,
    pub owner: Arc<OwnerLock>,
}

/// Resolve, lock, connect, set up.
pub(crate) fn connect(
    target: &NetTarget,
    line: LineSettings,
    options: &NetOptions,
) -> Result<Connected, TransportError> {
    let port = target.to_string();
    let addrs: Vec<SocketAddr> = target
        .host_port()
        .to_socket_addrs()
        .map_err(|e| TransportError::NotFound {
            port: format!("{port} (cannot resolve {}: {e})", target.host),
        })?
        .collect();
    let mut last: Option<io::Error> = None;
    for addr in &addrs {
        let owner = lock::lock_network(addr).map_err(|holder| TransportError::Busy {
            port: port.clone(),
            holder: holder.to_string(),
        })?;
        match TcpStream::connect_timeout(addr, options.connect_timeout) {
            Ok(stream) => return set_up(stream, target, line, options, owner),
            Err(e) => last = Some(e),
        }
    }
    let message = match last {
        Some(e) if e.kind() == io::ErrorKind::TimedOut => format!(
            "no answer within {} ms (is the server on and the address right?)",
            options.connect_timeout.as_millis()
        ),
        Some(e) if e.kind() == io::ErrorKind::ConnectionRefused => {
            "connection refused (nothing listens on that port: is ser2net running, \
             and its accepter on this port?)"
                .to_owned()
        }
        Some(e) => e.to_string(),
        None => "the name resolves to no address".to_owned(),
    };
    Err(TransportError::Open { port, message })
}

fn set_up(
    stream: TcpStream,
    target: &NetTarget,
    line: LineSettings,
    options: &NetOptions,
    owner: Arc<OwnerLock>,
) -> Result<Connected, TransportError> {
    let port = target.to_string();
    let io_err = |action: &'static str| {
        let port = port.clone();
        move |source: io::Error| TransportError::Io {
            port: port.clone(),
            action,
            source,
        }
    };
    stream
        .set_nodelay(true)
        .map_err(io_err("setting TCP_NODELAY"))?;
    let fd = OwnedFd::from(stream);
    socket_options(fd.as_fd(), options).map_err(io_err("setting the socket options"))?;
    fd::set_nonblocking(fd.as_fd()).map_err(io_err("setting non-blocking mode"))?;
    let queue_limit = Some(options.queue_limit(line));
    match target.mode {
        NetMode::Raw => {
            refused_at_once(fd.as_fd(), &port, options.refusal_window)?;
            Ok(Connected {
                fd,
                link: LinkInfo {
                    kind: FdKind::Socket,
                    tcp: true,
                    framing: Framing::Raw,
                    queue_limit,
                },
                decoder: None,
                owner,
            })
        }
        NetMode::Rfc2217 => {
            let (decoder, binary) = negotiate(fd.as_fd(), &port, line, options)?;
            Ok(Connected {
                fd,
                link: LinkInfo {
                    kind: FdKind::Socket,
                    tcp: true,
                    framing: Framing::Telnet {
                        binary,
                        purge: options.purge_before_stop,
                    },
                    queue_limit,
                },
                decoder: Some(decoder),
                owner,
            })
        }
    }
}

/// A count for an `int` socket option: larger values are clamped to
/// `INT_MAX`, where the kernel would refuse them.
fn clamp_int(n: u128) -> u32 {
    u32::try_from(n.min(i32::MAX as u128)).unwrap_or(i32::MAX as u32)
}

fn socket_options(fd: BorrowedFd<'_>, o: &NetOptions) -> io::Result<()> {
    use rustix::net::sockopt;
    sockopt::set_socket_keepalive(fd, true)?;
    sockopt::set_socket_send_buffer_size(fd, clamp_int(o.send_buffer as u128) as usize)?;
    #[cfg(any(target_os = "linux", target_os = "android"))]
    {
        // Whole seconds, at least 1 (tcp(7)); truncated here, so that
        // rustix's rounding up of a fraction never applies.
        let secs =
            |d: Duration| Duration::from_secs(clamp_int(u128::from(d.as_secs().max(1))).into());
        sockopt::set_tcp_keepidle(fd, secs(o.keepalive_idle))?;
        sockopt::set_tcp_keepintvl(fd, secs(o.keepalive_interval))?;
        sockopt::set_tcp_keepcnt(fd, clamp_int(u128::from(o.keepalive_count.max(1))))?;
        sockopt::set_tcp_user_timeout(fd, clamp_int(o.user_timeout.as_millis()))?;
    }
    Ok(())
}

/// Read what the server sent (at most `max` bytes) until `deadline`, or
/// until it closed the connection. Returns the bytes and whether it closed.
fn read_until(
    fd: BorrowedFd<'_>,
    deadline: Instant,
    stop_early: impl Fn(&[u8]) -> bool,
) -> io::Result<(Vec<u8>, bool)> {
    let mut got = Vec::new();
    let mut buf = [0u8; 512];
    loop {
        if stop_early(&got) {
            return Ok((got, false));
        }
        match fd::read_some(fd, &mut buf) {
            Ok(0) => return Ok((got, true)),
            Ok(n) => got.extend_from_slice(buf.get(..n).unwrap_or_default()),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                if Instant::now() >= deadline {
                    return Ok((got, false));
                }
                let mut fds = [fd::pollfd(fd, rustix::event::PollFlags::IN)];
                fd::poll_until(&mut fds, Some(deadline))?;
            }
            Err(e) if fd::is_link_gone(&e) => return Ok((got, true)),
            Err(e) => return Err(e),
        }
    }
}

/// A raw server that closes a new connection at once refuses it; what it
/// said is the reason. Bytes that came and no close are dropped: they
/// arrived before the port was ours (as a tty's input is flushed on open).
fn refused_at_once(fd: BorrowedFd<'_>, port: &str, window: Duration) -> Result<(), TransportError> {
    let (text, closed) = read_until(fd, Instant::now() + window, |_| false)
        .map_err(|e| TransportError::from_io(port, "reading the server's greeting", e))?;
    if closed {
        return Err(refusal(port, &text));
    }
    if !text.is_empty() {
        tracing::debug!(%port, bytes = text.len(), "dropped bytes that came before the port was ours");
    }
    Ok(())
}

fn refusal(port: &str, text: &[u8]) -> TransportError {
    let said = String::from_utf8_lossy(text).trim().to_owned();
    let message = if said.is_empty() {
        "the server closed the connection at once".to_owned()
    } else {
        format!("the server closed the connection: \"{said}\"")
    };
    TransportError::Refused {
        port: port.to_owned(),
        message,
    }
}

fn negotiate(
    fd: BorrowedFd<'_>,
    port: &str,
    line: LineSettings,
    options: &NetOptions,
) -> Result<(telnet::Decoder, bool), TransportError> {
    let deadline = Instant::now() + options.negotiation_timeout;
    let mut n = Negotiation::new(line);
    // The server speaks first (its offers; a refusal and its close): heard
    // before jogterm writes, so that a refusal is a clean close with its
    // words, not a reset that loses them.
    let (greeting, closed) = read_until(fd, Instant::now() + options.refusal_window, |_| false)
        .map_err(|e| TransportError::from_io(port, "RFC 2217 negotiation", e))?;
    n.feed(&greeting);
    if closed {
        let text = n.server_text().unwrap_or_default();
        return Err(refusal(port, text.as_bytes()));
    }
    loop {
        let out = n.take_output();
        if !out.is_empty() {
            fd::write_all_until(fd, FdKind::Socket, &out, deadline).map_err(|e| {
                if fd::is_link_gone(&e) {
                    refusal(port, n.server_text().unwrap_or_default().as_bytes())
                } else {
                    TransportError::from_io(port, "RFC 2217 negotiation", e)
                }
            })?;
        }
        match n.progress() {
            Progress::Ready => break,
            Progress::Failed(why) => {
                return Err(TransportError::Open {
                    port: port.to_owned(),
                    message: why,
                });
            }
            Progress::Pending => {}
        }
        let (bytes, closed) = read_until(fd, deadline, |got| !got.is_empty())
            .map_err(|e| TransportError::from_io(port, "RFC 2217 negotiation", e))?;
        n.feed(&bytes);
        if closed {
            let text = n.server_text().unwrap_or_default();
            return Err(refusal(port, text.as_bytes()));
        }
        if bytes.is_empty() && Instant::now() >= deadline {
            return Err(TransportError::Open {
                port: port.to_owned(),
                message: format!(
                    "no RFC 2217 answer within {} ms: waiting for {} (is it a telnet(rfc2217) \
                     accepter, not a raw one? then use tcp://)",
                    options.negotiation_timeout.as_millis(),
                    n.waiting_for()
                ),
            });
        }
    }
    let (server_binary, client_binary) = n.binary();
    let mut decoder = telnet::Decoder::new();
    decoder.set_binary(server_binary);
    Ok((decoder, client_binary))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;
    use std::io::{Read, Write};
    use std::net::TcpListener;
    use std::os::unix::fs::MetadataExt;
    use std::thread;

    fn target(mode: NetMode, addr: SocketAddr) -> NetTarget {
        NetTarget {
            mode,
            host: addr.ip().to_string(),
            port: addr.port(),
        }
    }

    #[test]
    fn the_queue_limit_is_wire_time_with_a_floor() {
        let o = NetOptions::default();
        assert_eq!(o.queue_limit(LineSettings::new(19200)), 116);
        assert_eq!(o.queue_limit(LineSettings::new(38400)), 231);
        assert_eq!(o.queue_limit(LineSettings::new(1200)), MIN_QUEUE_BYTES);
    }

    #[test]
    fn a_server_that_closes_at_once_refuses_with_its_words() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr");
        let server = thread::spawn(move || {
            let (mut s, _) = listener.accept().expect("accept");
            let _ = s.write_all(b"Port already in use\r\n");
        });
        let err = connect(
            &target(NetMode::Raw, addr),
            LineSettings::new(19200),
            &NetOptions::default(),
        )
        .expect_err("refused");
        server.join().expect("server");
        assert!(err.to_string().contains("\"Port already in use\""), "{err}");
    }

    #[test]
    fn nothing_listening_is_a_clear_refusal() {
        let addr = TcpListener::bind("127.0.0.1:0")
            .expect("bind")
            .local_addr()
            .expect("addr");
        // The listener is gone: nothing listens there now.
        let err = connect(
            &target(NetMode::Raw, addr),
            LineSettings::new(19200),
            &NetOptions::default(),
        )
        .expect_err("refused");
        assert!(err.to_string().contains("connection refused"), "{err}");
    }

    #[test]
    fn a_raw_server_that_is_no_rfc2217_server_times_out_with_a_hint() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr");
        let server = thread::spawn(move || {
            let (mut s, _) = listener.accept().expect("accept");
            let mut buf = [0u8; 64];
            let _ = s.read(&mut buf);
            thread::sleep(Duration::from_millis(400));
        });
        let options = NetOptions {
            negotiation_timeout: Duration::from_millis(200),
            ..NetOptions::default()
        };
        let err = connect(
            &target(NetMode::Rfc2217, addr),
            LineSettings::new(19200),
            &options,
        )
        .expect_err("no answer");
        server.join().expect("server");
        assert!(err.to_string().contains("no RFC 2217 answer"), "{err}");
        assert!(err.to_string().contains("use tcp://"), "{err}");
    }

    #[test]
    fn a_second_connection_from_this_machine_is_refused_by_the_lock() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let addr = listener.local_addr().expect("addr");
        thread::spawn(move || {
            let mut kept = Vec::new();
            for s in listener.incoming().flatten() {
                kept.push(s);
            }
        });
        let options = NetOptions {
            refusal_window: Duration::from_millis(10),
            ..NetOptions::default()
        };
        let line = LineSettings::new(19200);
        let first = connect(&target(NetMode::Raw, addr), line, &options).expect("first");
        assert!(first.owner.path().exists());
        // Another process holds that lock: a child `flock` on the same file.
        let path = first.owner.path().to_path_buf();
        drop(first);
        let mut child = std::process::Command::new("sh")
            // One process that takes the lock and keeps it (same pid
            // through the exec), so that killing it releases it.
            .args(["-c", "exec 9>>\"$0\" && flock -n 9 && exec sleep 30"])
            .arg(&path)
            .spawn()
            .expect("sh and flock(1)");
        let end = Instant::now() + Duration::from_secs(10);
        let held = || {
            let ino = fs::metadata(&path).map(|m| m.ino()).unwrap_or(0);
            ino != 0
                && fs::read_to_string("/proc/locks")
                    .unwrap_or_default()
                    .contains(&format!(":{ino} "))
        };
        while !held() {
            assert!(Instant::now() < end, "the child never held the lock");
            thread::sleep(Duration::from_millis(10));
        }
        let err = connect(&target(NetMode::Raw, addr), line, &options).expect_err("held");
        let _ = child.kill();
        let _ = child.wait();
        assert!(matches!(err, TransportError::Busy { .. }), "{err}");
        assert!(err.to_string().contains("jogterm-net-127.0.0.1_"), "{err}");
    }
}
