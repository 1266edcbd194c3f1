//! What the simulated controller received, for `show received`: the
//! controller's own view of the line, so that a test (or an operator) can
//! check what a client really sent, e.g. that no motion command went out
//! twice after a fault. Bounded: the newest [`RECEIVED_KEPT`] bytes are kept,
//! the total is always counted. Each read is kept with the wall-clock time
//! it was taken from the line (`show received times`): when a stop byte
//! reached the controller, to compare with when a test asked for it.

use std::collections::VecDeque;
use std::fmt;
use std::time::{SystemTime, UNIX_EPOCH};

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
    /// Each read whose first byte is still kept: its offset in everything
    /// received, and when it was read.
    reads: VecDeque<(u64, SystemTime)>,
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
            reads: VecDeque::new(),
        }
    }

    /// Bytes read from the line.
    pub fn record(&mut self, bytes: &[u8]) {
        self.record_at(bytes, SystemTime::now());
    }

    /// Bytes read from the line at `at`.
    pub fn record_at(&mut self, bytes: &[u8], at: SystemTime) {
        if !bytes.is_empty() {
            self.reads.push_back((self.total, at));
        }
        self.total += bytes.len() as u64;
        self.kept.extend(bytes);
        let excess = self.kept.len().saturating_sub(self.capacity);
        self.kept.drain(..excess);
        let first_kept = self.total - self.kept.len() as u64;
        while self.reads.front().is_some_and(|(o, _)| *o < first_kept) {
            self.reads.pop_front();
        }
    }

    /// A copy of what is kept now.
    pub fn snapshot(&self) -> Received {
        Received {
            total: self.total,
            bytes: self.kept.iter().copied().collect(),
            reads: self.reads.iter().copied().collect(),
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
    /// The reads that brought the kept bytes: offset of the first byte in
    /// everything received, and when.
    pub reads: Vec<(u64, SystemTime)>,
}

impl Received {
    /// Bytes received that are no longer kept.
    pub fn not_kept(&self) -> u64 {
        self.total.saturating_sub(self.bytes.len() as u64)
    }

    /// `show received times`: a head line `received N bytes in K reads:`,
    /// then one line per read, `<seconds since 1970, µs> <bytes readable>`.
    pub fn timed(&self) -> String {
        let first_kept = self.not_kept();
        let mut text = format!(
            "received {} bytes in {} reads:",
            self.total,
            self.reads.len()
        );
        for (i, (offset, at)) in self.reads.iter().enumerate() {
            let end = self.reads.get(i + 1).map_or(self.total, |(next, _)| *next);
            let range = (offset - first_kept) as usize..(end - first_kept) as usize;
            let bytes = self.bytes.get(range).unwrap_or_default();
            let t = at.duration_since(UNIX_EPOCH).unwrap_or_default();
            text.push_str(&format!(
                "\n{}.{:06} {}",
                t.as_secs(),
                t.subsec_micros(),
                traffic::readable(bytes)
            ));
        }
        text
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
    fn reads_are_kept_with_their_times_while_their_bytes_are() {
        let mut log = ReceivedLog::with_capacity(6);
        let t = |s| UNIX_EPOCH + std::time::Duration::from_micros(s);
        log.record_at(b"@0P\r", t(1_000_001));
        log.record_at(&[0xFD, 0xFF], t(2_500_000));
        assert_eq!(
            log.snapshot().timed(),
            "received 6 bytes in 2 reads:\n1.000001 @0P<CR>\n2.500000 <FD><FF>"
        );
        log.record_at(b"@07\r", t(3_000_000));
        // The first read's bytes are gone: so is its time.
        assert_eq!(
            log.snapshot().timed(),
            "received 10 bytes in 2 reads:\n2.500000 <FD><FF>\n3.000000 @07<CR>"
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
