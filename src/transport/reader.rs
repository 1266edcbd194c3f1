//! Async reading from a port: tokio's `AsyncFd` on the port's own fd (a
//! serial device, a pseudo-terminal or a socket, all the same here). On an
//! RFC 2217 link the Telnet stream is decoded on the way: the caller sees
//! the serial bytes only, never the server's notifications.

use std::os::fd::{AsFd, OwnedFd};
use std::time::{Instant, SystemTime};

use tokio::io::Interest;
use tokio::io::unix::AsyncFd;

use super::error::TransportError;
use super::fd;
use super::telnet;
use crate::traffic::{Direction, TrafficRecord};

/// Bytes as they were read, with the moment they were read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadChunk {
    pub bytes: Vec<u8>,
    pub at: Instant,
    pub wall: SystemTime,
}

impl ReadChunk {
    pub fn traffic(&self) -> TrafficRecord {
        TrafficRecord {
            at: self.wall,
            direction: Direction::Received,
            bytes: self.bytes.clone(),
            messages: Vec::new(),
        }
    }
}

/// The reading half of a port. Reads never return `Ok(0)` for a non-empty
/// buffer: the end of the stream is [`TransportError::LinkLost`], and so is
/// every error that means the port has gone away. Once lost, every further
/// read says so again at once.
#[derive(Debug)]
pub struct PortReader {
    port: String,
    state: State,
    /// The Telnet decoder of an RFC 2217 link.
    telnet: Option<Telnet>,
}

/// Decoding state and scratch space, kept across reads (a command may be
/// cut between two).
#[derive(Debug)]
struct Telnet {
    decoder: telnet::Decoder,
    raw: Vec<u8>,
    data: Vec<u8>,
    commands: Vec<telnet::Command>,
}

#[derive(Debug)]
enum State {
    /// Not yet registered with the runtime (registration needs one; the port
    /// may be opened outside it).
    Unregistered(OwnedFd),
    Registered(AsyncFd<OwnedFd>),
    Lost(String),
    /// Only while registering.
    Empty,
}

impl PortReader {
    /// `fd` must be in non-blocking mode. `decoder`: the link is Telnet.
    pub(crate) fn new(fd: OwnedFd, port: String, decoder: Option<telnet::Decoder>) -> Self {
        Self {
            port,
            state: State::Unregistered(fd),
            telnet: decoder.map(|decoder| Telnet {
                decoder,
                raw: Vec::new(),
                data: Vec::new(),
                commands: Vec::new(),
            }),
        }
    }

    pub fn port(&self) -> &str {
        &self.port
    }

    /// Read at least one byte into `buf` and return how many.
    ///
    /// Cancel safe: dropping the future before it completes loses no data.
    /// The first call must happen inside a tokio runtime with I/O enabled.
    pub async fn read(&mut self, buf: &mut [u8]) -> Result<usize, TransportError> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.ensure_registered()?;
        loop {
            let attempt = {
                let State::Registered(afd) = &self.state else {
                    return Err(self.lost_again());
                };
                let mut guard = afd
                    .readable()
                    .await
                    .map_err(|e| TransportError::from_io(&self.port, "waiting for input", e))?;
                // Telnet: read into scratch space no larger than `buf`;
                // decoding never makes bytes more.
                let target: &mut [u8] = match &mut self.telnet {
                    Some(t) => {
                        t.raw.resize(buf.len(), 0);
                        &mut t.raw
                    }
                    None => &mut *buf,
                };
                // Err: spurious readiness, cleared by try_io; wait again.
                guard
                    .try_io(|inner| fd::read_some(inner.get_ref().as_fd(), target))
                    .ok()
            };
            match attempt {
                None => continue,
                Some(Ok(0)) => return Err(self.lose(TransportError::end_of_stream(&self.port))),
                Some(Ok(n)) => match self.decode(n, buf) {
                    // Only Telnet commands came: wait for serial bytes.
                    0 => continue,
                    n => return Ok(n),
                },
                Some(Err(e)) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Some(Err(e)) => {
                    let err = TransportError::from_io(&self.port, "read", e);
                    return Err(self.lose(err));
                }
            }
        }
    }

    /// The `n` bytes just read: as they are, or decoded from Telnet into
    /// `buf`. Returns the serial bytes now in `buf`.
    fn decode(&mut self, n: usize, buf: &mut [u8]) -> usize {
        let Some(t) = &mut self.telnet else {
            return n;
        };
        t.data.clear();
        t.commands.clear();
        let raw = t.raw.get(..n).unwrap_or_default();
        t.decoder.feed(raw, &mut t.data, &mut t.commands);
        for command in &t.commands {
            // Line and modem state notifications were masked off in the
            // negotiation; whatever still comes is of no use to a driver.
            tracing::debug!(port = %self.port, ?command, "telnet command from the server");
        }
        let len = t.data.len().min(buf.len());
        if let (Some(dst), Some(src)) = (buf.get_mut(..len), t.data.get(..len)) {
            dst.copy_from_slice(src);
        }
        len
    }

    /// Read whatever is available (at least one byte), timestamped.
    pub async fn read_chunk(&mut self) -> Result<ReadChunk, TransportError> {
        let mut buf = [0u8; 512];
        let n = self.read(&mut buf).await?;
        Ok(ReadChunk {
            bytes: buf.get(..n).unwrap_or_default().to_vec(),
            at: Instant::now(),
            wall: SystemTime::now(),
        })
    }

    fn ensure_registered(&mut self) -> Result<(), TransportError> {
        match self.state {
            State::Registered(_) => return Ok(()),
            State::Lost(_) | State::Empty => return Err(self.lost_again()),
            State::Unregistered(_) => {}
        }
        if tokio::runtime::Handle::try_current().is_err() {
            return Err(TransportError::NoRuntime {
                port: self.port.clone(),
            });
        }
        let State::Unregistered(owned) = std::mem::replace(&mut self.state, State::Empty) else {
            return Err(self.lost_again());
        };
        // SAFETY: the AsyncFd owns `owned`, so the descriptor stays open and
        // refers to the same file description for the AsyncFd's whole life.
        match unsafe { AsyncFd::register_with_interest(owned, Interest::READABLE) } {
            Ok(afd) => {
                self.state = State::Registered(afd);
                Ok(())
            }
            Err(e) => {
                let (owned, source) = e.into_parts();
                self.state = State::Unregistered(owned);
                Err(TransportError::Io {
                    port: self.port.clone(),
                    action: "registering with the runtime",
                    source,
                })
            }
        }
    }

    fn lost_again(&self) -> TransportError {
        let reason = match &self.state {
            State::Lost(reason) => reason.clone(),
            _ => "the reader is closed".to_owned(),
        };
        TransportError::LinkLost {
            port: self.port.clone(),
            reason,
        }
    }

    fn lose(&mut self, err: TransportError) -> TransportError {
        if let TransportError::LinkLost { reason, .. } = &err {
            // Dropping the AsyncFd deregisters and closes this dup; a hung-up
            // fd would otherwise report readiness for ever.
            self.state = State::Lost(reason.clone());
        }
        err
    }
}
