//! Bytes as they crossed the line, for the traffic console, the `--log` file and
//! error messages. Readable form: printable ASCII as itself, everything else as
//! `<CR>`, `<LF>`, `<EOF>` or a hex byte such as `<FD>`, so a control byte is
//! never mistaken for text and never garbles a terminal.

use std::time::SystemTime;

use serde::Serialize;

pub use jogterm_proto::text::readable;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Direction {
    /// From jogterm to the controller.
    Sent,
    /// From the controller to jogterm.
    Received,
}

impl Direction {
    pub fn arrow(self) -> &'static str {
        match self {
            Direction::Sent => ">>",
            Direction::Received => "<<",
        }
    }
}

/// Whose a message on the line is: the driver that sent it, or awaited it,
/// knows (`docs/device.md`, "Traffic").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Owner {
    /// The reads a driver repeats on its own (positions, ports, status),
    /// and their answers.
    Poll,
    /// A line the operator typed (a raw command), and its answer.
    User,
    /// A jog, step or go-to jogterm planned.
    Motion,
    /// A program being stored.
    Upload,
    /// A stored program or job being run.
    Program,
    /// Stops (the stop key, a jog's release or dead-man, every connect's
    /// first bytes) and resets, and their answers.
    Stop,
    /// jogterm's own work: the state read back, initialising, reference
    /// runs, zero, outputs, error reads.
    Setup,
    /// Something the controller sent that no command awaited (EMCU 0x02,
    /// an EMP completion nobody waits for, stray bytes).
    Controller,
}

/// Where a message ends in a record's bytes, and whose it is. A record's
/// bytes after its last end belong to a message that goes on in a later
/// record (or that nothing ended: a reply cut short).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct MessageEnd {
    /// Offset just past the message's last byte.
    pub end: usize,
    pub owner: Owner,
    /// The controller refused the command this answers (EMP INFO `EE`).
    pub rejected: bool,
}

impl MessageEnd {
    pub fn new(end: usize, owner: Owner) -> MessageEnd {
        MessageEnd {
            end,
            owner,
            rejected: false,
        }
    }

    /// The same message `by` bytes further on (records put together).
    pub fn shifted(self, by: usize) -> MessageEnd {
        MessageEnd {
            end: self.end + by,
            ..self
        }
    }
}

/// One chunk of bytes as it was written to or read from the port, with the
/// messages that end in it as the driver knows them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TrafficRecord {
    pub at: SystemTime,
    pub direction: Direction,
    pub bytes: Vec<u8>,
    /// In order, each `end` within `bytes`.
    pub messages: Vec<MessageEnd>,
}

impl TrafficRecord {
    /// Bytes without known message boundaries (as the transport sees them).
    pub fn new(direction: Direction, bytes: impl Into<Vec<u8>>) -> Self {
        Self {
            at: SystemTime::now(),
            direction,
            bytes: bytes.into(),
            messages: Vec::new(),
        }
    }

    /// Bytes that are whole messages of `owner`, ending at `ends`.
    pub fn messages(
        direction: Direction,
        bytes: impl Into<Vec<u8>>,
        owner: Owner,
        ends: &[usize],
    ) -> Self {
        Self {
            messages: ends.iter().map(|e| MessageEnd::new(*e, owner)).collect(),
            ..Self::new(direction, bytes)
        }
    }

    /// The record's bytes cut into messages: each with its end's facts,
    /// and the bytes after the last end, whose message goes on (`None`).
    pub fn parts(&self) -> impl Iterator<Item = (&[u8], Option<MessageEnd>)> {
        let mut start = 0;
        let ended = self.messages.iter().filter_map(move |m| {
            let part = self.bytes.get(start..m.end)?;
            start = m.end;
            Some((part, Some(*m)))
        });
        let last = self.messages.last().map_or(0, |m| m.end);
        let rest = self.bytes.get(last..).filter(|r| !r.is_empty());
        ended.chain(rest.map(|r| (r, None)))
    }

    /// `>> @0P<CR>` style, without a timestamp.
    pub fn readable(&self) -> String {
        format!("{} {}", self.direction.arrow(), readable(&self.bytes))
    }
}
