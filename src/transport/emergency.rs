//! The emergency stop handle: a reserved dup of the port's fd that writes stop
//! bytes synchronously, past the paced writer's queue.
//!
//! It is meant for the panic hook and the hang-up path, where the async
//! machinery and the writer thread may already be gone
//! (`docs/field-notes.md`, "Serial ports" and "Order on hang-up").
//! So it never panics and never blocks longer than its bound.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::error::TransportError;
use super::fd;
use super::sink::Sink;
use crate::wire::LineSettings;

/// `Send + Sync + Clone`; every clone writes through the same reserved fd.
#[derive(Debug, Clone)]
pub struct EmergencyStop {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    /// Writes through the escaping of the link (an RFC 2217 link doubles
    /// isel's 0xFF break byte), never through the writer's queue.
    sink: Sink,
    port: String,
    line: LineSettings,
    timeout: Duration,
}

impl EmergencyStop {
    /// Default bound on one `write_now`, on top of the bytes' own wire time.
    pub const DEFAULT_TIMEOUT: Duration = Duration::from_millis(200);

    pub(crate) fn new(sink: Sink, port: String, line: LineSettings) -> Self {
        Self {
            inner: Arc::new(Inner {
                sink,
                port,
                line,
                timeout: Self::DEFAULT_TIMEOUT,
            }),
        }
    }

    /// A handle with a different bound (shares nothing with `self` but the port).
    pub fn with_timeout(&self, timeout: Duration) -> Result<Self, TransportError> {
        let sink = self
            .inner
            .sink
            .try_clone()
            .map_err(|source| TransportError::Io {
                port: self.inner.port.clone(),
                action: "duplicating the emergency handle",
                source,
            })?;
        Ok(Self {
            inner: Arc::new(Inner {
                sink,
                port: self.inner.port.clone(),
                line: self.inner.line,
                timeout,
            }),
        })
    }

    pub fn port(&self) -> &str {
        &self.inner.port
    }

    /// Write `bytes` now (`write_all`), then wait until a terminal has sent
    /// them (`tcdrain`), or a serial port server has acknowledged them (the
    /// process may end next, and closing a socket with unread input resets
    /// it, which drops what is not yet acknowledged). Gives up after the
    /// handle's timeout plus the bytes' wire time; bytes may then still be
    /// in flight.
    ///
    /// The bytes go between whatever the paced writer has already handed to
    /// the OS and what it writes next, as one write (two emergency writers
    /// never mix their bytes). A frame that must not be cut (an EMCU line,
    /// an EMP frame: [`super::Interleave::WholeMessage`]) and that the
    /// writer has begun is completed first, in the same write: the stop
    /// waits for at most the rest of one line, and the line reaches the
    /// controller whole (issue 20; a cut `@X` with the stop's CR `@B` CR in
    /// it set the EMCU's error flag). isel's messages may be cut: its
    /// control bytes act between any two bytes of a command. This handle is
    /// for when the writer can no longer be relied on, not for normal stops.
    pub fn write_now(&self, bytes: &[u8]) -> Result<(), TransportError> {
        let inner = &*self.inner;
        let deadline = Instant::now() + inner.timeout + inner.line.transfer_time(bytes.len());
        inner.sink.write_stop_now(bytes, deadline).map_err(|e| {
            if e.kind() == std::io::ErrorKind::TimedOut {
                TransportError::DrainTimeout {
                    port: inner.port.clone(),
                    waited: inner.timeout,
                }
            } else {
                TransportError::from_io(&inner.port, "emergency write", e)
            }
        })?;
        let left = deadline.saturating_duration_since(Instant::now());
        if !inner.sink.is_tty() {
            return match inner.sink.wait_acknowledged(left) {
                Ok(true) => {
                    if inner.sink.info().tcp {
                        // The process may end next: input left unread would
                        // make its close a reset, and the server would drop
                        // the stop it has not read yet (`sink.rs`).
                        super::sink::discard_arrived(inner.sink.fd());
                    }
                    Ok(())
                }
                Ok(false) => Err(TransportError::DrainTimeout {
                    port: inner.port.clone(),
                    waited: inner.timeout,
                }),
                Err(e) => Err(TransportError::from_io(
                    &inner.port,
                    "waiting for the server",
                    e,
                )),
            };
        }
        match fd::drain_bounded(inner.sink.fd(), left) {
            Ok(true) => Ok(()),
            Ok(false) => Err(TransportError::DrainTimeout {
                port: inner.port.clone(),
                waited: inner.timeout,
            }),
            Err(e) => Err(TransportError::from_io(&inner.port, "tcdrain", e)),
        }
    }
}
