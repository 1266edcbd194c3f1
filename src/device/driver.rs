//! The sans-IO heart of the device layer: one `Driver` per controller family
//! turns requests into bytes and bytes into events and machine state. The
//! device task (`task.rs`) is the only thing that does I/O; it feeds a driver
//! with what happens and carries out what the driver asks for.
//!
//! Every method takes the current time, so a driver can be tested against a
//! simulator model in memory with synthetic time: bytes from
//! `poll_transmit` go to `SimDevice::on_byte`, bytes from
//! `SimDevice::poll_output` go to `received`.

use std::time::Instant;

use super::api::{Event, Request};
use crate::traffic::{MessageEnd, Owner};

/// Bytes for the paced writer: one message of the protocol, or several
/// back to back (a stop sequence), and whose they are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Outgoing {
    pub bytes: Vec<u8>,
    /// Whether a stop may be written between two bytes of this message (isel:
    /// the controller reads 0xFD/0xFE/0xFF in its receive routine, manual
    /// 2.2.31). EMCU lines and EMP frames cannot be interleaved.
    pub interruptible: bool,
    /// Where each message in `bytes` ends, and whose it is: the traffic
    /// records say so (`TrafficRecord::messages`).
    pub messages: Vec<MessageEnd>,
}

impl Outgoing {
    /// One message of `owner`.
    pub fn message(bytes: Vec<u8>, interruptible: bool, owner: Owner) -> Outgoing {
        let end = bytes.len();
        Outgoing {
            bytes,
            interruptible,
            messages: vec![MessageEnd::new(end, owner)],
        }
    }

    /// Messages of `owner` that end at `ends` (in order, the last at the
    /// end of `bytes`).
    pub fn messages(bytes: Vec<u8>, interruptible: bool, owner: Owner, ends: &[usize]) -> Outgoing {
        Outgoing {
            bytes,
            interruptible,
            messages: ends.iter().map(|e| MessageEnd::new(*e, owner)).collect(),
        }
    }
}

pub trait Driver: Send {
    /// The link is up (first open or after a reconnect): read the controller's
    /// state back before anything else. Never resend a motion command.
    fn connected(&mut self, now: Instant);

    /// Whether a connect opens with the family's stop sequence (the
    /// default). Off while the session has not been asked to move: what a
    /// controller runs, a stored program started from its own start key,
    /// goes on (`docs/device.md`, "Sessions that do not move"). The state
    /// is read back either way.
    fn set_connect_halt(&mut self, on: bool);

    /// A session that only reads (`SessionMoves::No`: `watch`, `poll`,
    /// `commission`, `send` of lines that move nothing): what the driver
    /// sends of its own accord is reads, nothing that sets something in the
    /// controller (`docs/device.md`, "Sessions that only read"). What the
    /// client asks for still goes out. The default: a family whose read-back
    /// only reads anyway.
    fn set_reads_only(&mut self, _on: bool) {}

    /// Whether `request` may set an axis in motion as this family reads it:
    /// what makes a console a session that moves (`SessionMoves::OnceAsked`).
    /// A raw line is parsed, so a typed read is no motion; a line that does
    /// not parse counts as motion (the safe side).
    fn may_move(&self, request: &Request) -> bool {
        request.may_move()
    }

    /// The link is gone: whatever was in flight is lost; motion state becomes
    /// unknown until the controller has been read again.
    fn disconnected(&mut self, reason: &str, now: Instant);

    /// A client request. Refusals come back as `Event::Refused`.
    fn request(&mut self, request: Request, now: Instant);

    /// Stop all motion, now. Returns the bytes that go on the wire ahead of
    /// everything queued; the driver drops its queued work (never resumes a
    /// jog, never continues an upload) and expects the replies the stop causes.
    fn stop(&mut self, now: Instant) -> Outgoing;

    /// The stop sequence for the emergency handle (panic hook, hang-up path),
    /// written without the driver's involvement. Harmless when nothing moves.
    fn emergency_stop(&self) -> Outgoing;

    /// Bytes read from the port. Returns where messages ended in them and
    /// whose they were (the answer to a poll, to a typed line, something
    /// the controller sent on its own), for the traffic records; bytes after
    /// the last end belong to a message that is not complete yet, or that
    /// only silence ends.
    fn received(&mut self, bytes: &[u8], now: Instant) -> Vec<MessageEnd>;

    /// The writer has handed the last byte of the current message to the line
    /// (reply timeouts are measured from here).
    fn transmitted(&mut self, now: Instant);

    /// The next message to write, if the protocol allows one now (isel: one
    /// command at a time, after the previous reply).
    fn poll_transmit(&mut self, now: Instant) -> Option<Outgoing>;

    /// The next event for the clients. A driver that finds the link dead (a
    /// reply did not come within its deadline) reports
    /// `Event::Link(LinkState::Lost)` and sends nothing more; the device task
    /// treats that like a vanished port (stop bytes, close, reconnect).
    fn poll_event(&mut self) -> Option<Event>;

    /// When `handle_timeout` must be called: a reply deadline, the next poll, a
    /// jog lease running out.
    fn next_timeout(&self) -> Option<Instant>;

    fn handle_timeout(&mut self, now: Instant);
}
