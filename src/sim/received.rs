//! What the simulated controller received, for `show received`: the
//! controller's own view of the line, so that a test (or an operator) can
//! check what a client really sent, e.g. that no motion command went out
//! twice after a fault. Bounded: the newest [`RECEIVED_KEPT`] bytes are kept,
//! the total is always counted.

use std::collections::VecDeque;
use std::fmt;

use crate::traffic;

/// Bytes kept at most. A client polling an isel controller at line speed
/// sends about 330 bytes a second, so this holds minutes of traffic, plenty
/// for a scripted scenario, without growing for ever in a long session.
pub const RECEIVED_KEPT: usize = 256 * 1024;

/// The bytes read from the line, oldest first.
#[derive(Debug, Clone)]
pub struct ReceivedLog {
    kept: VecDeque<u8>,
    capacity: usize,
    total: u64,
}

impl Default for ReceivedLog {
    fn default() -> Self {
        Self::with_capacity(RECEIVED_KEPT)
    }
}

impl ReceivedLog {
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            kept: VecDeque::new(),
            capacity,
            total: 0,
        }
    }

    /// Bytes read from the line.
    pub fn record(&mut self, bytes: &[u8]) {
        self.total += bytes.len() as u64;
        self.kept.extend(bytes);
        let excess = self.kept.len().saturating_sub(self.capacity);
        self.kept.drain(..excess);
    }

    /// A copy of what is kept now.
    pub fn snapshot(&self) -> Received {
        Received {
            total: self.total,
            bytes: self.kept.iter().copied().collect(),
        }
    }
}

/// What `show received` reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Received {
    /// Every byte received since the simulator started.
    pub total: u64,
    /// The newest of them (all of them unless more than the capacity came).
    pub bytes: Vec<u8>,
}

impl Received {
    /// Bytes received that are no longer kept.
    pub fn not_kept(&self) -> u64 {
        self.total.saturating_sub(self.bytes.len() as u64)
    }
}

/// One line: `received N bytes: @0P<CR>…` in `traffic::readable` form, with
/// how many of the oldest bytes are no longer kept when some are not.
impl fmt::Display for Received {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "received {} bytes", self.total)?;
        if self.not_kept() > 0 {
            write!(f, " (the first {} not kept)", self.not_kept())?;
        }
        write!(f, ": {}", traffic::readable(&self.bytes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn everything_is_kept_below_the_capacity() {
        let mut log = ReceivedLog::default();
        log.record(b"@0P\r");
        log.record(&[0xFD, 0xFF]);
        let r = log.snapshot();
        assert_eq!(r.total, 6);
        assert_eq!(r.bytes, b"@0P\r\xFD\xFF");
        assert_eq!(r.to_string(), "received 6 bytes: @0P<CR><FD><FF>");
    }

    #[test]
    fn the_newest_bytes_are_kept_and_the_total_counts_all() {
        let mut log = ReceivedLog::with_capacity(4);
        log.record(b"@07\r");
        log.record(b"@0P\r");
        let r = log.snapshot();
        assert_eq!(r.total, 8);
        assert_eq!(r.bytes, b"@0P\r");
        assert_eq!(r.not_kept(), 4);
        assert_eq!(
            r.to_string(),
            "received 8 bytes (the first 4 not kept): @0P<CR>"
        );
    }

    #[test]
    fn nothing_received_is_an_empty_record() {
        let r = ReceivedLog::default().snapshot();
        assert_eq!(r.to_string(), "received 0 bytes: ");
    }

    proptest::proptest! {
        #[test]
        fn the_kept_bytes_are_the_tail_of_everything(
            chunks in proptest::collection::vec(proptest::collection::vec(proptest::num::u8::ANY, 0..20), 0..20),
            capacity in 0usize..50,
        ) {
            let mut log = ReceivedLog::with_capacity(capacity);
            let mut all = Vec::new();
            for c in &chunks {
                log.record(c);
                all.extend_from_slice(c);
            }
            let r = log.snapshot();
            proptest::prop_assert_eq!(r.total, all.len() as u64);
            let tail = all.get(all.len().saturating_sub(capacity)..).unwrap_or_default();
            proptest::prop_assert_eq!(r.bytes.as_slice(), tail);
        }
    }
}
