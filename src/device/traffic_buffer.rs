//! Traffic records as an operator wants to read them: the paced writer
//! hands a command to the line a byte or two at a time, and the reader gets
//! replies in whatever pieces the kernel delivers. Here a sent message
//! becomes one record when it is complete, and received bytes one record per
//! burst (until the line was quiet for a moment or something was sent).
//!
//! The writer's reports may be taken after bytes that were read later (the
//! task does not wake for every report), so received bytes are split by
//! time: those read before a message's first byte was written come before
//! its record, those read after it stay for the next.

use std::collections::HashMap;
use std::time::{Duration, Instant, SystemTime};

use crate::traffic::{Direction, TrafficRecord};
use crate::transport::{MessageId, ReadChunk, WrittenChunk};

/// Received bytes become a record after this much quiet. A burst is also
/// closed by the next message sent, which is what closes it while polling;
/// the quiet time only has to catch a reply nothing follows, so it is long
/// enough not to cost a wakeup per poll cycle at 10 Hz.
pub const QUIET: Duration = Duration::from_millis(100);
/// A burst longer than this becomes several records.
const MAX_RECORD: usize = 256;

#[derive(Debug)]
struct Sending {
    first: Instant,
    wall: SystemTime,
    bytes: Vec<u8>,
}

#[derive(Debug, Default)]
pub struct TrafficBuffer {
    sending: HashMap<MessageId, Sending>,
    /// Reads not yet in a record: when, wall time, bytes.
    received: Vec<(Instant, SystemTime, Vec<u8>)>,
}

impl TrafficBuffer {
    /// A chunk the writer reports; returns the records that are complete.
    pub fn written(&mut self, chunk: &WrittenChunk) -> Vec<TrafficRecord> {
        let entry = self.sending.entry(chunk.id).or_insert_with(|| Sending {
            first: chunk.at,
            wall: chunk.wall,
            bytes: Vec::new(),
        });
        entry.bytes.extend_from_slice(&chunk.bytes);
        let first = entry.first;
        let mut out = Vec::new();
        if chunk.done
            && let Some(sent) = self.sending.remove(&chunk.id)
        {
            out.extend(self.take_received(|at| at <= first));
            if !sent.bytes.is_empty() {
                out.push(TrafficRecord {
                    at: sent.wall,
                    direction: Direction::Sent,
                    bytes: sent.bytes,
                });
            }
        }
        out
    }

    pub fn read(&mut self, chunk: &ReadChunk) -> Vec<TrafficRecord> {
        self.received
            .push((chunk.at, chunk.wall, chunk.bytes.clone()));
        let held: usize = self.received.iter().map(|(_, _, b)| b.len()).sum();
        if held >= MAX_RECORD {
            return self.take_received(|_| true);
        }
        Vec::new()
    }

    /// When received bytes are due as a record.
    pub fn due(&self) -> Option<Instant> {
        self.received.last().map(|(at, _, _)| *at + QUIET)
    }

    pub fn on_time(&mut self, now: Instant) -> Vec<TrafficRecord> {
        match self.due() {
            Some(t) if t <= now => self.take_received(|_| true),
            _ => Vec::new(),
        }
    }

    /// Everything held, in the order it happened.
    pub fn flush(&mut self) -> Vec<TrafficRecord> {
        let mut pending: Vec<_> = self.sending.drain().map(|(_, s)| s).collect();
        pending.sort_by_key(|s| s.first);
        let mut out = Vec::new();
        for sent in pending {
            out.extend(self.take_received(|at| at <= sent.first));
            if !sent.bytes.is_empty() {
                out.push(TrafficRecord {
                    at: sent.wall,
                    direction: Direction::Sent,
                    bytes: sent.bytes,
                });
            }
        }
        out.extend(self.take_received(|_| true));
        out
    }

    /// The received bytes read at times `which` accepts, as one record.
    fn take_received(&mut self, which: impl Fn(Instant) -> bool) -> Vec<TrafficRecord> {
        let split = self
            .received
            .iter()
            .position(|(at, _, _)| !which(*at))
            .unwrap_or(self.received.len());
        if split == 0 {
            return Vec::new();
        }
        let taken: Vec<_> = self.received.drain(..split).collect();
        let wall = taken.first().map_or(SystemTime::now(), |(_, w, _)| *w);
        let bytes = taken.into_iter().flat_map(|(_, _, b)| b).collect();
        vec![TrafficRecord {
            at: wall,
            direction: Direction::Received,
            bytes,
        }]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::Lane;

    fn chunk(id: u64, bytes: &[u8], at: Instant, done: bool) -> WrittenChunk {
        WrittenChunk {
            id: MessageId(id),
            lane: Lane::Normal,
            bytes: bytes.to_vec(),
            at,
            wall: SystemTime::now(),
            wire_start: at,
            wire_end: at,
            done,
        }
    }

    fn read(bytes: &[u8], at: Instant) -> ReadChunk {
        ReadChunk {
            bytes: bytes.to_vec(),
            at,
            wall: SystemTime::now(),
        }
    }

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn a_message_written_in_pieces_is_one_record() {
        let t0 = Instant::now();
        let mut t = TrafficBuffer::default();
        assert!(t.written(&chunk(1, b"@0", t0, false)).is_empty());
        let r = t.written(&chunk(1, b"P\r", t0 + ms(1), true));
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].readable(), ">> @0P<CR>");
    }

    #[test]
    fn a_burst_of_replies_is_one_record_after_quiet_or_before_the_next_send() {
        let mut t = TrafficBuffer::default();
        let t0 = Instant::now();
        assert!(t.read(&read(b"00", t0)).is_empty());
        assert!(t.read(&read(b"03", t0 + ms(1))).is_empty());
        assert_eq!(t.due(), Some(t0 + ms(1) + QUIET));
        assert!(t.on_time(t0 + QUIET).is_empty());
        let r = t.on_time(t0 + ms(1) + QUIET);
        assert_eq!(r[0].readable(), "<< 0003");
        let later = t0 + ms(2) + QUIET;
        t.read(&read(b"0", later));
        let r = t.written(&chunk(2, b"@0P\r", later + ms(1), true));
        assert_eq!(
            r.iter().map(|r| r.readable()).collect::<Vec<_>>(),
            ["<< 0", ">> @0P<CR>"]
        );
    }

    #[test]
    fn a_report_taken_late_does_not_pull_later_replies_before_its_message() {
        let mut t = TrafficBuffer::default();
        let t0 = Instant::now();
        // The reply to an earlier command, then `@0b1` is written, then its
        // reply starts arriving; the writer's report is taken only now.
        t.read(&read(b"0", t0));
        t.read(&read(b"0", t0 + ms(3)));
        let r = t.written(&chunk(3, b"@0b1\r", t0 + ms(1), true));
        assert_eq!(
            r.iter().map(|r| r.readable()).collect::<Vec<_>>(),
            ["<< 0", ">> @0b1<CR>"]
        );
        t.read(&read(b"3", t0 + ms(4)));
        let r = t.on_time(t0 + ms(4) + QUIET);
        assert_eq!(r[0].readable(), "<< 03");
    }
}
