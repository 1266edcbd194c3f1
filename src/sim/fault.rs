//! Faults the simulator shell injects into a device's output, and exactly how
//! each one changes a message (`docs/simulator.md`, "Faults").
//!
//! Message faults are one-shot and apply to the *next message the device
//! hands to the shell* after they were armed (not to one already queued for
//! the wire). Several different faults may be armed at once; they all hit the
//! same message. Arming a fault that is already armed replaces it.

use std::fmt;
use std::time::Duration;

/// A fault as the operator asks for it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Fault {
    /// Leave one byte of the next message out; the other bytes keep their
    /// times on the wire (the line is silent where the byte would have been).
    DropByte(ByteIndex),
    /// Flip bit 7 of one byte of the next message (`b ^ 0x80`). All three
    /// protocols are 7-bit ASCII (plus EOF 0x1A), so a corrupted byte is never
    /// a valid one: not even a different hex digit or letter case.
    CorruptByte(ByteIndex),
    /// Do not send the next message at all (the device believes it did).
    Withhold,
    /// Put these bytes on the wire as soon as the line is free, unasked.
    Garbage(Vec<u8>),
    /// Start the next message this much later than it would have started.
    Delay(Duration),
    /// Instead of the next message, this many bytes of [`STREAM_BYTE`] at
    /// line speed, without a pause: a line that streams and answers nothing
    /// (a wrong baud rate, a babbling device; issue 37).
    Stream(usize),
    /// Close the line. For a pseudo-terminal, `reopen_after` brings up a new
    /// one (same stable link path) after that time.
    Close { reopen_after: Option<Duration> },
    /// A device fault, not a message fault: the next long action the device
    /// starts (EMP positioning or homing) answers busy and then neither
    /// moves nor reports ready, until a request ends it (a stop). Only
    /// simulators with such actions model it (`SimDevice::stall_next`).
    Stall,
}

/// What `fault stream` sends: `U` (0x55), no reply of any family (not an
/// isel reply code, not a hex digit, no CR or EOF that would end a message).
pub const STREAM_BYTE: u8 = b'U';

/// The longest stream: 10 MB, more than an hour at 19200 baud.
pub const MAX_STREAM: usize = 10_000_000;

/// Which byte of a message a fault hits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ByteIndex {
    /// The byte at index `len / 2` (0-based): the middle of the message, so
    /// both a reply's start and its terminator survive and a decoder sees a
    /// wrong-length or garbled frame, not a missing one. For a 1-byte message
    /// that is the only byte.
    #[default]
    Middle,
    /// The byte at this 0-based index; past the end, the last byte.
    At(usize),
}

impl ByteIndex {
    /// The index hit in a message of `len` bytes (`len > 0`).
    pub fn resolve(self, len: usize) -> usize {
        let last = len.saturating_sub(1);
        match self {
            ByteIndex::Middle => len / 2,
            ByteIndex::At(i) => i.min(last),
        }
    }
}

impl fmt::Display for ByteIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ByteIndex::Middle => f.write_str("middle byte"),
            ByteIndex::At(i) => write!(f, "byte {i}"),
        }
    }
}

/// The message faults armed for the next message.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ArmedFaults {
    pub drop: Option<ByteIndex>,
    pub corrupt: Option<ByteIndex>,
    pub withhold: bool,
    pub delay: Option<Duration>,
    pub stream: Option<usize>,
}

impl ArmedFaults {
    pub fn is_empty(&self) -> bool {
        *self == ArmedFaults::default()
    }

    /// Take everything armed, leaving nothing armed.
    pub fn take(&mut self) -> ArmedFaults {
        std::mem::take(self)
    }

    /// Apply drop and corrupt to a message whose bytes carry their due times.
    /// Withhold and delay are the caller's (they concern the schedule).
    /// If both hit the same byte, it is dropped.
    pub fn apply_to_bytes<T>(&self, bytes: &mut Vec<(u8, T)>) {
        if bytes.is_empty() {
            return;
        }
        let len = bytes.len();
        if let Some(which) = self.corrupt
            && let Some(entry) = bytes.get_mut(which.resolve(len))
        {
            entry.0 ^= 0x80;
        }
        if let Some(which) = self.drop {
            let i = which.resolve(len);
            if i < bytes.len() {
                bytes.remove(i);
            }
        }
    }
}

impl fmt::Display for ArmedFaults {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if self.withhold {
            parts.push("withhold".to_owned());
        }
        if let Some(d) = self.delay {
            parts.push(format!("delay {} ms", d.as_millis()));
        }
        if let Some(n) = self.stream {
            parts.push(format!("stream {n} bytes"));
        }
        if let Some(i) = self.drop {
            parts.push(format!("drop {i}"));
        }
        if let Some(i) = self.corrupt {
            parts.push(format!("corrupt {i}"));
        }
        if parts.is_empty() {
            f.write_str("none")
        } else {
            f.write_str(&parts.join(", "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timed(bytes: &[u8]) -> Vec<(u8, usize)> {
        bytes.iter().copied().zip(0..).collect()
    }

    #[test]
    fn middle_is_len_over_two() {
        assert_eq!(ByteIndex::Middle.resolve(1), 0);
        assert_eq!(ByteIndex::Middle.resolve(2), 1);
        assert_eq!(ByteIndex::Middle.resolve(19), 9);
        assert_eq!(ByteIndex::At(3).resolve(19), 3);
        assert_eq!(ByteIndex::At(99).resolve(19), 18);
    }

    #[test]
    fn drop_removes_the_byte_and_keeps_the_others_slots() {
        let mut m = timed(b"0ABCD\r");
        ArmedFaults {
            drop: Some(ByteIndex::Middle),
            ..Default::default()
        }
        .apply_to_bytes(&mut m);
        assert_eq!(
            m,
            vec![(b'0', 0), (b'A', 1), (b'B', 2), (b'D', 4), (b'\r', 5)]
        );
    }

    #[test]
    fn corrupt_sets_bit_seven() {
        let mut m = timed(b"0ABCD\r");
        ArmedFaults {
            corrupt: Some(ByteIndex::At(5)),
            ..Default::default()
        }
        .apply_to_bytes(&mut m);
        assert_eq!(m.last(), Some(&(b'\r' | 0x80, 5)));
    }

    #[test]
    fn drop_wins_over_corrupt_on_the_same_byte() {
        let mut m = timed(b"0");
        ArmedFaults {
            drop: Some(ByteIndex::Middle),
            corrupt: Some(ByteIndex::Middle),
            ..Default::default()
        }
        .apply_to_bytes(&mut m);
        assert!(m.is_empty());
    }
}
