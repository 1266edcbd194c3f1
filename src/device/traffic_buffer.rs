//! Traffic records as an operator wants to read them: the paced writer
//! hands a command to the line a byte or two at a time, and the reader gets
//! replies in whatever pieces the kernel delivers. Here a sent message
//! becomes one record when it is complete, and received bytes one record per
//! burst (until the line was quiet for a moment or something was sent).

use std::collections::HashMap;
use std::time::{Duration, Instant, SystemTime};

use crate::traffic::{Direction, TrafficRecord};
use crate::transport::{MessageId, ReadChunk, WrittenChunk};

/// Received bytes become a record after this much quiet.
pub const QUIET: Duration = Duration::from_millis(5);
/// A burst longer than this becomes several records.
const MAX_RECORD: usize = 256;

#[derive(Debug, Default)]
pub struct TrafficBuffer {
    sending: HashMap<MessageId, (SystemTime, Vec<u8>)>,
    received: Option<(SystemTime, Vec<u8>)>,
    last_read: Option<Instant>,
}

impl TrafficBuffer {
    /// A chunk the writer reports; returns the records that are complete.
    pub fn written(&mut self, chunk: &WrittenChunk) -> Vec<TrafficRecord> {
        let mut out = self.flush_received();
        let entry = self
            .sending
            .entry(chunk.id)
            .or_insert_with(|| (chunk.wall, Vec::new()));
        entry.1.extend_from_slice(&chunk.bytes);
        if chunk.done
            && let Some((at, bytes)) = self.sending.remove(&chunk.id)
            && !bytes.is_empty()
        {
            out.push(TrafficRecord {
                at,
                direction: Direction::Sent,
                bytes,
            });
        }
        out
    }

    pub fn read(&mut self, chunk: &ReadChunk) -> Vec<TrafficRecord> {
        self.last_read = Some(chunk.at);
        let (_, bytes) = self
            .received
            .get_or_insert_with(|| (chunk.wall, Vec::new()));
        bytes.extend_from_slice(&chunk.bytes);
        if bytes.len() >= MAX_RECORD {
            return self.flush_received();
        }
        Vec::new()
    }

    /// When received bytes are due as a record.
    pub fn due(&self) -> Option<Instant> {
        self.received
            .as_ref()
            .and(self.last_read)
            .map(|t| t + QUIET)
    }

    pub fn on_time(&mut self, now: Instant) -> Vec<TrafficRecord> {
        match self.due() {
            Some(t) if t <= now => self.flush_received(),
            _ => Vec::new(),
        }
    }

    /// Everything held, received bytes first (they came before).
    pub fn flush(&mut self) -> Vec<TrafficRecord> {
        let mut out = self.flush_received();
        let mut pending: Vec<_> = self.sending.drain().collect();
        pending.sort_by_key(|(id, _)| *id);
        out.extend(pending.into_iter().filter(|(_, (_, b))| !b.is_empty()).map(
            |(_, (at, bytes))| TrafficRecord {
                at,
                direction: Direction::Sent,
                bytes,
            },
        ));
        out
    }

    fn flush_received(&mut self) -> Vec<TrafficRecord> {
        self.received
            .take()
            .map(|(at, bytes)| TrafficRecord {
                at,
                direction: Direction::Received,
                bytes,
            })
            .into_iter()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::Lane;

    fn chunk(id: u64, bytes: &[u8], done: bool) -> WrittenChunk {
        let now = Instant::now();
        WrittenChunk {
            id: MessageId(id),
            lane: Lane::Normal,
            bytes: bytes.to_vec(),
            at: now,
            wall: SystemTime::now(),
            wire_start: now,
            wire_end: now,
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

    #[test]
    fn a_message_written_in_pieces_is_one_record() {
        let mut t = TrafficBuffer::default();
        assert!(t.written(&chunk(1, b"@0", false)).is_empty());
        let r = t.written(&chunk(1, b"P\r", true));
        assert_eq!(r.len(), 1);
        assert_eq!(r[0].readable(), ">> @0P<CR>");
    }

    #[test]
    fn a_burst_of_replies_is_one_record_after_quiet_or_before_the_next_send() {
        let mut t = TrafficBuffer::default();
        let t0 = Instant::now();
        assert!(t.read(&read(b"00", t0)).is_empty());
        assert!(
            t.read(&read(b"03", t0 + Duration::from_millis(1)))
                .is_empty()
        );
        assert_eq!(t.due(), Some(t0 + Duration::from_millis(6)));
        assert!(t.on_time(t0 + Duration::from_millis(5)).is_empty());
        let r = t.on_time(t0 + Duration::from_millis(6));
        assert_eq!(r[0].readable(), "<< 0003");
        t.read(&read(b"0", t0));
        let r = t.written(&chunk(2, b"@0P\r", true));
        assert_eq!(
            r.iter().map(|r| r.readable()).collect::<Vec<_>>(),
            ["<< 0", ">> @0P<CR>"]
        );
    }
}
