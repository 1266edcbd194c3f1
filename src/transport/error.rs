//! Errors of the transport layer. Every one names the port, so a message on
//! the screen says which line failed and how.

use std::io;
use std::time::Duration;

/// What went wrong with a port. A vanished port is [`TransportError::LinkLost`],
/// distinct from everything else so the device task can show "link lost" and
/// stop trusting the machine state.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("{port}: no such port")]
    NotFound { port: String },

    /// Another process owns the port (a tty's lock, or this machine's lock
    /// of a serial port server); `holder` says who, as far as it can be told.
    #[error("{port}: busy: {holder}; one console per machine")]
    Busy { port: String, holder: String },

    /// A serial port server turned the connection away (ser2net: "Port
    /// already in use" when another client has the port).
    #[error("{port}: refused by the server: {message}")]
    Refused { port: String, message: String },

    #[error("{port}: permission denied (is the user in the `dialout` group?)")]
    PermissionDenied { port: String },

    /// The other end went away: a USB adapter was unplugged, a simulator's
    /// pseudo-terminal was closed, a socket peer hung up.
    #[error("{port}: link lost ({reason})")]
    LinkLost { port: String, reason: String },

    #[error("{port}: cannot open: {message}")]
    Open { port: String, message: String },

    #[error("{port}: {action} failed: {source}")]
    Io {
        port: String,
        action: &'static str,
        #[source]
        source: io::Error,
    },

    /// Stop bytes were handed to the port but did not drain within the bound;
    /// whether they reached the controller is unknown.
    #[error("{port}: stop bytes not confirmed on the wire within {waited:?}")]
    DrainTimeout { port: String, waited: Duration },

    /// The paced writer's thread has ended (after a link loss or a close).
    #[error("{port}: the writer has stopped")]
    WriterStopped { port: String },

    /// Async reads need a tokio runtime with I/O enabled.
    #[error("{port}: reading needs a tokio runtime (none is running on this thread)")]
    NoRuntime { port: String },

    #[error("listing serial ports failed: {message}")]
    List { message: String },
}

impl TransportError {
    /// True when the port has gone away (as opposed to a refused open or an
    /// unexpected system error).
    pub fn is_link_lost(&self) -> bool {
        matches!(self, TransportError::LinkLost { .. })
    }

    /// Turn an I/O error on an open port into `LinkLost` when it means the
    /// other end is gone, and into `Io` otherwise.
    pub(crate) fn from_io(port: &str, action: &'static str, source: io::Error) -> Self {
        if super::fd::is_link_gone(&source) {
            TransportError::LinkLost {
                port: port.to_owned(),
                reason: format!("{action}: {source}"),
            }
        } else {
            TransportError::Io {
                port: port.to_owned(),
                action,
                source,
            }
        }
    }

    pub(crate) fn end_of_stream(port: &str) -> Self {
        TransportError::LinkLost {
            port: port.to_owned(),
            reason: "the other end closed the line".to_owned(),
        }
    }
}
