//! Byte transports between jogterm and a controller: a real serial port, a
//! pseudo-terminal, a serial port server on the network (raw TCP or RFC
//! 2217, `docs/network.md`), or an in-process socket pair to a built-in
//! simulator. The protocol code above never knows which one it talks through.
//!
//! All of them are file descriptors, so there is one code path: [`open`] gives
//! a [`Port`], and [`Port::split`] turns it into
//! - a [`PortReader`] (async, tokio `AsyncFd`): a vanished port is
//!   [`TransportError::LinkLost`], never data, never a panic;
//! - a [`PacedWriter`] (std thread, own dup of the fd): writes at line speed
//!   in few writes (an EMCU line or EMP frame whole, isel commands with at
//!   most 1.6 ms in the OS buffer, the first write from the caller's thread
//!   when the line is idle), a stop lane that overtakes the queue, and
//!   reports of every chunk written ([`WriterEvent`]);
//! - an [`EmergencyStop`] (own dup of the fd): synchronous, bounded
//!   `write_now` for the panic hook and the hang-up path; it completes an
//!   EMCU line or EMP frame the writer has begun before its stop bytes.
//!
//! What a link does to the bytes (Telnet's IAC doubling, a TCP socket's
//! unacknowledged bytes, RFC 2217's PURGE-DATA) is the writing side's
//! `sink` and the reader's Telnet decoder; the writer paces serial bytes
//! whatever the link. One owner per port: `lock`.
//!
//! Linux/unix only.

mod address;
mod emergency;
mod error;
pub(crate) mod fd;
mod identity;
mod list;
pub mod lock;
mod pacing;
mod reader;
pub mod rfc2217;
mod sink;
mod tcp;
pub mod telnet;
mod writer;

use std::os::fd::{AsFd, FromRawFd, IntoRawFd, OwnedFd};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

pub use address::{AddressError, NetMode, NetTarget, PortAddress};
pub use emergency::EmergencyStop;
pub use error::TransportError;
pub use identity::{PortIdentity, identify, still_the_same};
pub use list::{PortInfo, PortUse, list_ports};
pub use pacing::{Pace, Pacer};
pub use reader::{PortReader, ReadChunk};
pub use tcp::NetOptions;
pub use writer::{
    Interleave, Lane, MessageId, PacedWriter, WriterConfig, WriterEvent, WrittenChunk,
};

use crate::wire::LineSettings;

/// Where to find the controller.
#[derive(Debug)]
pub enum PortSpec {
    /// A serial device (or a simulator's pseudo-terminal) by path, 8N1, no
    /// flow control, opened exclusively.
    Serial { path: PathBuf, line: LineSettings },
    /// One end of a socket pair whose other end a built-in simulator serves
    /// (`sim::shell::serve_socket`). `name` labels it in messages.
    InProcess {
        stream: UnixStream,
        line: LineSettings,
        name: String,
    },
    /// A serial port server (`tcp://`, `rfc2217://`), reconnected by address.
    Network {
        target: NetTarget,
        line: LineSettings,
        options: NetOptions,
    },
}

impl PortSpec {
    /// The port an address names (`--port`, a profile's `connection.port`).
    pub fn from_address(address: &str, line: LineSettings) -> Result<PortSpec, AddressError> {
        Ok(match PortAddress::parse(address)? {
            PortAddress::Device(path) => PortSpec::Serial { path, line },
            PortAddress::Network(target) => PortSpec::Network {
                target,
                line,
                options: NetOptions::default(),
            },
        })
    }
}

/// An open port, not yet split into its reading and writing parts.
#[derive(Debug)]
pub struct Port {
    fd: OwnedFd,
    name: String,
    line: LineSettings,
    link: sink::LinkInfo,
    decoder: Option<telnet::Decoder>,
    owner: Option<Arc<lock::OwnerLock>>,
}

/// The parts of an open port. Each owns its own dup of the fd: the port stays
/// open until all of them are dropped.
#[derive(Debug)]
pub struct PortParts {
    pub reader: PortReader,
    pub writer: PacedWriter,
    pub events: tokio::sync::mpsc::UnboundedReceiver<WriterEvent>,
    pub emergency: EmergencyStop,
}

/// Open a port. No runtime needed; see [`Port::split`]. Blocks while a
/// network port connects (bounded by its [`NetOptions`]).
pub fn open(spec: PortSpec) -> Result<Port, TransportError> {
    match spec {
        PortSpec::Serial { path, line } => open_serial(&path, line),
        PortSpec::InProcess { stream, line, name } => {
            let fd = OwnedFd::from(stream);
            fd::set_nonblocking(fd.as_fd()).map_err(|source| TransportError::Io {
                port: name.clone(),
                action: "setting non-blocking mode",
                source,
            })?;
            Ok(Port {
                link: sink::LinkInfo::plain(fd::kind_of(fd.as_fd())),
                fd,
                name,
                line,
                decoder: None,
                owner: None,
            })
        }
        PortSpec::Network {
            target,
            line,
            options,
        } => {
            let c = tcp::connect(&target, line, &options)?;
            Ok(Port {
                fd: c.fd,
                name: target.to_string(),
                line,
                link: c.link,
                decoder: c.decoder,
                owner: Some(c.owner),
            })
        }
    }
}

impl Port {
    pub fn name(&self) -> &str {
        &self.name
    }

    pub fn line(&self) -> LineSettings {
        self.line
    }

    /// Start the writer thread and hand out the parts.
    pub fn split(self, config: WriterConfig) -> Result<PortParts, TransportError> {
        let reader_fd = self.dup("duplicating the fd for reading")?;
        let emergency_fd = self.dup("duplicating the fd for emergency stops")?;
        let emergency = sink::Sink::new(emergency_fd, self.link, self.owner.clone());
        let sink = sink::Sink::new(self.fd, self.link, self.owner).closing_gracefully();
        let (writer, events) = PacedWriter::spawn(sink, self.name.clone(), self.line, config)?;
        Ok(PortParts {
            reader: PortReader::new(reader_fd, self.name.clone(), self.decoder),
            writer,
            events,
            emergency: EmergencyStop::new(emergency, self.name, self.line),
        })
    }

    fn dup(&self, action: &'static str) -> Result<OwnedFd, TransportError> {
        self.fd.try_clone().map_err(|source| TransportError::Io {
            port: self.name.clone(),
            action,
            source,
        })
    }
}

fn open_serial(path: &Path, line: LineSettings) -> Result<Port, TransportError> {
    let port = path.display().to_string();
    let Some(path_str) = path.to_str() else {
        return Err(TransportError::Open {
            port,
            message: "the path is not valid UTF-8".to_owned(),
        });
    };
    // The lock file first: it names an owner that the device's own flock
    // (taken by the open below) cannot.
    let owner = lock::lock_tty(path).map_err(|holder| TransportError::Busy {
        port: port.clone(),
        holder: holder.to_string(),
    })?;
    let tty = serialport::new(path_str, line.baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(Duration::ZERO)
        .open_native()
        .map_err(|e| open_error(&port, path, e))?;
    // serialport's TTYPort closes its fd on drop; from here the fd is ours.
    // (TTYPort has no `Into<OwnedFd>`, only `IntoRawFd`: hence the raw step.)
    // SAFETY: into_raw_fd hands over sole ownership of an open descriptor.
    let fd = unsafe { OwnedFd::from_raw_fd(tty.into_raw_fd()) };
    // Bytes that arrived before the port was ours (or were garbled while its
    // settings changed) belong to nobody: drop them.
    let _ = rustix::termios::tcflush(&fd, rustix::termios::QueueSelector::IFlush);
    fd::set_nonblocking(fd.as_fd()).map_err(|source| TransportError::Io {
        port: port.clone(),
        action: "setting non-blocking mode",
        source,
    })?;
    Ok(Port {
        link: sink::LinkInfo::plain(fd::kind_of(fd.as_fd())),
        fd,
        name: port,
        line,
        decoder: None,
        owner,
    })
}

fn open_error(port: &str, path: &Path, e: serialport::Error) -> TransportError {
    use serialport::ErrorKind as K;
    let port = port.to_owned();
    match e.kind() {
        // serialport reports EBUSY (TIOCEXCL) and a held flock as NoDevice.
        K::NoDevice => TransportError::Busy {
            holder: busy_holder(path),
            port,
        },
        K::Io(std::io::ErrorKind::NotFound) => TransportError::NotFound { port },
        K::Io(std::io::ErrorKind::PermissionDenied) => TransportError::PermissionDenied { port },
        _ if !path.exists() => TransportError::NotFound { port },
        _ => TransportError::Open {
            port,
            message: e.to_string(),
        },
    }
}

/// Who has a busy tty: the `flock` holder, else a process that has it open.
fn busy_holder(path: &Path) -> String {
    let real = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if let Some(holder) = lock::flock_holder(&real) {
        return holder.to_string();
    }
    match lock::openers(&real).first() {
        Some((pid, name)) => format!(
            "held by {} (pid {pid}, /proc/{pid}/fd)",
            name.as_deref().unwrap_or("a process")
        ),
        None => "another process has the port open or locked".to_owned(),
    }
}
