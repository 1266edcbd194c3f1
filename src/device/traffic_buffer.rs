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
//!
//! Each record carries the messages that end in it as the driver knows
//! them (`TrafficRecord::messages`): a sent message's ends and owner come
//! with it from the driver ([`TrafficBuffer::sending`]), a read's from the
//! driver's decoding of it.

use std::collections::HashMap;
use std::time::{Duration, Instant, SystemTime};

use crate::traffic::{Direction, MessageEnd, TrafficRecord};
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

impl Sending {
    fn record(self, messages: Vec<MessageEnd>) -> TrafficRecord {
        TrafficRecord {
            at: self.wall,
            direction: Direction::Sent,
            bytes: self.bytes,
            messages,
        }
    }
}

/// Bytes read and not yet in a record.
#[derive(Debug)]
struct Read {
    at: Instant,
    wall: SystemTime,
    bytes: Vec<u8>,
    /// The messages that end in `bytes`.
    messages: Vec<MessageEnd>,
}

#[derive(Debug, Default)]
pub struct TrafficBuffer {
    sending: HashMap<MessageId, Sending>,
    /// The messages of what is being sent, from the driver.
    messages: HashMap<MessageId, Vec<MessageEnd>>,
    received: Vec<Read>,
}

impl TrafficBuffer {
    /// The writer took the driver's message `id`, whose messages end at
    /// `messages`.
    pub fn sending(&mut self, id: MessageId, messages: Vec<MessageEnd>) {
        self.messages.insert(id, messages);
    }

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
            let messages = self.messages.remove(&chunk.id).unwrap_or_default();
            if !sent.bytes.is_empty() {
                out.push(sent.record(messages));
            }
        }
        out
    }

    /// Bytes read, in which `messages` end (as the driver decoded them).
    pub fn read(&mut self, chunk: &ReadChunk, messages: Vec<MessageEnd>) -> Vec<TrafficRecord> {
        self.received.push(Read {
            at: chunk.at,
            wall: chunk.wall,
            bytes: chunk.bytes.clone(),
            messages,
        });
        let held: usize = self.received.iter().map(|r| r.bytes.len()).sum();
        if held >= MAX_RECORD {
            return self.take_received(|_| true);
        }
        Vec::new()
    }

    /// When received bytes are due as a record.
    pub fn due(&self) -> Option<Instant> {
        self.received.last().map(|r| r.at + QUIET)
    }

    pub fn on_time(&mut self, now: Instant) -> Vec<TrafficRecord> {
        match self.due() {
            Some(t) if t <= now => self.take_received(|_| true),
            _ => Vec::new(),
        }
    }

    /// Everything held, in the order it happened.
    pub fn flush(&mut self) -> Vec<TrafficRecord> {
        let mut pending: Vec<_> = self.sending.drain().collect();
        pending.sort_by_key(|(_, s)| s.first);
        let mut out = Vec::new();
        for (id, sent) in pending {
            out.extend(self.take_received(|at| at <= sent.first));
            // Cut short: only the messages that were written whole.
            let mut messages = self.messages.remove(&id).unwrap_or_default();
            messages.retain(|m| m.end <= sent.bytes.len());
            if !sent.bytes.is_empty() {
                out.push(sent.record(messages));
            }
        }
        self.messages.clear();
        out.extend(self.take_received(|_| true));
        out
    }

    /// The received bytes read at times `which` accepts, as one record.
    fn take_received(&mut self, which: impl Fn(Instant) -> bool) -> Vec<TrafficRecord> {
        let split = self
            .received
            .iter()
            .position(|r| !which(r.at))
            .unwrap_or(self.received.len());
        if split == 0 {
            return Vec::new();
        }
        let taken: Vec<Read> = self.received.drain(..split).collect();
        let wall = taken.first().map_or(SystemTime::now(), |r| r.wall);
        let mut bytes = Vec::new();
        let mut messages = Vec::new();
        for read in taken {
            let at = bytes.len();
            messages.extend(read.messages.into_iter().map(|m| m.shifted(at)));
            bytes.extend(read.bytes);
        }
        vec![TrafficRecord {
            at: wall,
            direction: Direction::Received,
            bytes,
            messages,
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
        assert!(t.read(&read(b"00", t0), Vec::new()).is_empty());
        assert!(t.read(&read(b"03", t0 + ms(1)), Vec::new()).is_empty());
        assert_eq!(t.due(), Some(t0 + ms(1) + QUIET));
        assert!(t.on_time(t0 + QUIET).is_empty());
        let r = t.on_time(t0 + ms(1) + QUIET);
        assert_eq!(r[0].readable(), "<< 0003");
        let later = t0 + ms(2) + QUIET;
        t.read(&read(b"0", later), Vec::new());
        let r = t.written(&chunk(2, b"@0P\r", later + ms(1), true));
        assert_eq!(
            r.iter().map(|r| r.readable()).collect::<Vec<_>>(),
            ["<< 0", ">> @0P<CR>"]
        );
    }

    #[test]
    fn records_carry_the_drivers_message_ends_and_owners() {
        use crate::traffic::{MessageEnd, Owner};
        let t0 = Instant::now();
        let mut t = TrafficBuffer::default();
        t.sending(
            MessageId(7),
            vec![
                MessageEnd::new(1, Owner::Stop),
                MessageEnd::new(2, Owner::Stop),
            ],
        );
        t.written(&chunk(7, &[0xFD], t0, false));
        let r = t.written(&chunk(7, &[0xFF], t0, true));
        assert_eq!(
            r[0].messages.iter().map(|m| m.end).collect::<Vec<_>>(),
            [1, 2]
        );
        // Two reads in one record: the second's ends move by the first's length.
        t.read(&read(b"@X0", t0 + ms(1)), Vec::new());
        t.read(
            &read(b"00000\r\x02\r", t0 + ms(2)),
            vec![
                MessageEnd::new(6, Owner::Poll),
                MessageEnd::new(8, Owner::Controller),
            ],
        );
        let r = t.on_time(t0 + ms(2) + QUIET);
        let ends: Vec<(usize, Owner)> = r[0].messages.iter().map(|m| (m.end, m.owner)).collect();
        assert_eq!(ends, [(9, Owner::Poll), (11, Owner::Controller)]);
        let parts: Vec<Vec<u8>> = r[0].parts().map(|(b, _)| b.to_vec()).collect();
        assert_eq!(parts, [b"@X000000\r".to_vec(), b"\x02\r".to_vec()]);
    }

    #[test]
    fn a_message_cut_short_by_the_end_of_a_session_keeps_the_ends_it_reached() {
        use crate::traffic::{MessageEnd, Owner};
        let t0 = Instant::now();
        let mut t = TrafficBuffer::default();
        t.sending(
            MessageId(1),
            vec![
                MessageEnd::new(1, Owner::Stop),
                MessageEnd::new(4, Owner::Stop),
            ],
        );
        t.written(&chunk(1, b"\r@", t0, false));
        let r = t.flush();
        assert_eq!(r[0].readable(), ">> <CR>@");
        assert_eq!(r[0].messages.iter().map(|m| m.end).collect::<Vec<_>>(), [1]);
        assert_eq!(
            r[0].parts()
                .map(|(b, end)| (b.to_vec(), end.is_some()))
                .collect::<Vec<_>>(),
            [(b"\r".to_vec(), true), (b"@".to_vec(), false)]
        );
    }

    #[test]
    fn a_report_taken_late_does_not_pull_later_replies_before_its_message() {
        let mut t = TrafficBuffer::default();
        let t0 = Instant::now();
        // The reply to an earlier command, then `@0b1` is written, then its
        // reply starts arriving; the writer's report is taken only now.
        t.read(&read(b"0", t0), Vec::new());
        t.read(&read(b"0", t0 + ms(3)), Vec::new());
        let r = t.written(&chunk(3, b"@0b1\r", t0 + ms(1), true));
        assert_eq!(
            r.iter().map(|r| r.readable()).collect::<Vec<_>>(),
            ["<< 0", ">> @0b1<CR>"]
        );
        t.read(&read(b"3", t0 + ms(4)), Vec::new());
        let r = t.on_time(t0 + ms(4) + QUIET);
        assert_eq!(r[0].readable(), "<< 03");
    }
}
