//! Streaming decoder of the interface's replies: CR-terminated lines in any
//! split, bounded memory, resynchronisation on garbage. Sans-IO: bytes in,
//! events out, one byte never yields more than one event, so the events do not
//! depend on how the bytes were split.
//!
//! Resynchronisation (`docs/protocols.md`, EMCU):
//! - a line ends at CR; a line that is no reply is reported as garbage;
//! - 0x02 and 0x03 never occur inside a reply, so they start a new line and
//!   the bytes before them are garbage (a ready line survives line noise);
//! - `@` starts a new line unless the current one began with `@` (a version
//!   text may contain `@`);
//! - an LF where a line would start is dropped and reported on its own, so a
//!   CR LF line end cannot swallow the next bare-CR acknowledgement;
//! - a line longer than [`MAX_REPLY_LINE`] is reported in chunks and skipped
//!   up to the next CR (or 0x02/0x03).

use std::fmt;

use thiserror::Error;

use crate::text::readable;

use super::command::CR;
use super::reply::{MAX_REPLY_LINE, MEMORY_FULL, READY, Reply, ReplyError};

/// Why bytes were dropped.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum GarbageReason {
    #[error("{0}")]
    NotAReply(ReplyError),
    #[error("line longer than {MAX_REPLY_LINE} bytes")]
    TooLong,
    #[error("incomplete line cut off by the start of a new one")]
    Cut,
    #[error("stray LF (EMCU lines end with CR only)")]
    StrayLineFeed,
}

/// Bytes that were not a reply, kept for the traffic log and the error
/// message (at most [`MAX_REPLY_LINE`] + 1 bytes each).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Garbage {
    pub bytes: Vec<u8>,
    pub reason: GarbageReason,
}

impl Garbage {
    /// The dropped bytes in `traffic::readable` form.
    pub fn readable(&self) -> String {
        readable(&self.bytes)
    }
}

impl fmt::Display for Garbage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "dropped `{}`: {}", self.readable(), self.reason)
    }
}

/// What the decoder made of the bytes so far.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ReplyEvent {
    Reply(Reply),
    Garbage(Garbage),
}

/// Incremental reply decoder; feed it the bytes as they arrive.
#[derive(Debug, Clone, Default)]
pub struct ReplyDecoder {
    /// Bytes of the current line not yet reported.
    line: Vec<u8>,
    /// First byte of the current line, kept while an over-long line is skipped.
    line_start: Option<u8>,
    /// The current line overflowed and is being skipped.
    skipping: bool,
}

impl ReplyDecoder {
    pub fn new() -> ReplyDecoder {
        ReplyDecoder::default()
    }

    /// All events the bytes complete, in order.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<ReplyEvent> {
        bytes.iter().filter_map(|b| self.push(*b)).collect()
    }

    /// One byte; at most one event.
    pub fn push(&mut self, byte: u8) -> Option<ReplyEvent> {
        match byte {
            CR => Some(self.end_line()),
            READY | MEMORY_FULL => {
                let cut = self.cut();
                self.start(byte);
                cut
            }
            b'@' if self.line_start.is_some_and(|first| first != b'@') => {
                let cut = self.cut();
                self.start(byte);
                cut
            }
            b'\n' if self.line_start.is_none() => Some(ReplyEvent::Garbage(Garbage {
                bytes: vec![byte],
                reason: GarbageReason::StrayLineFeed,
            })),
            _ => {
                if self.line_start.is_none() {
                    self.line_start = Some(byte);
                }
                self.line.push(byte);
                if self.line.len() > MAX_REPLY_LINE {
                    self.skipping = true;
                    return Some(self.garbage(GarbageReason::TooLong));
                }
                None
            }
        }
    }

    /// Bytes of a line that has not ended yet.
    pub fn pending(&self) -> &[u8] {
        &self.line
    }

    /// Forget a partial line (after the port was reopened).
    pub fn reset(&mut self) {
        *self = ReplyDecoder::default();
    }

    fn start(&mut self, byte: u8) {
        self.line_start = Some(byte);
        self.line.push(byte);
    }

    fn garbage(&mut self, reason: GarbageReason) -> ReplyEvent {
        ReplyEvent::Garbage(Garbage {
            bytes: std::mem::take(&mut self.line),
            reason,
        })
    }

    /// Ends the current line where a new one starts.
    fn cut(&mut self) -> Option<ReplyEvent> {
        let reason = if self.skipping {
            GarbageReason::TooLong
        } else {
            GarbageReason::Cut
        };
        self.line_start = None;
        self.skipping = false;
        if self.line.is_empty() {
            None
        } else {
            Some(self.garbage(reason))
        }
    }

    fn end_line(&mut self) -> ReplyEvent {
        let skipping = std::mem::replace(&mut self.skipping, false);
        self.line_start = None;
        if skipping {
            self.line.push(CR);
            return self.garbage(GarbageReason::TooLong);
        }
        match Reply::parse_line(&self.line) {
            Ok(reply) => {
                self.line.clear();
                ReplyEvent::Reply(reply)
            }
            Err(e) => {
                self.line.push(CR);
                self.garbage(GarbageReason::NotAReply(e))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emcu::status::Status;

    fn replies(events: &[ReplyEvent]) -> Vec<Reply> {
        events
            .iter()
            .filter_map(|e| match e {
                ReplyEvent::Reply(r) => Some(r.clone()),
                ReplyEvent::Garbage(_) => None,
            })
            .collect()
    }

    #[test]
    fn a_ready_between_a_query_and_its_answer_stays_apart() {
        let mut d = ReplyDecoder::new();
        let events = d.feed(b"\x02\r@X000001\r");
        assert_eq!(
            events,
            vec![
                ReplyEvent::Reply(Reply::Ready),
                ReplyEvent::Reply(Reply::Status(Status {
                    job_running: true,
                    ..Status::default()
                })),
            ]
        );
    }

    #[test]
    fn noise_before_a_reply_is_reported_and_the_reply_survives() {
        let mut d = ReplyDecoder::new();
        let events = d.feed(b"\xff\x00@LX12\rzz\x02\r");
        assert_eq!(events.len(), 4);
        assert_eq!(
            events.first(),
            Some(&ReplyEvent::Garbage(Garbage {
                bytes: vec![0xFF, 0x00],
                reason: GarbageReason::Cut
            }))
        );
        assert_eq!(
            replies(&events),
            vec![
                Reply::Position {
                    axis: crate::emcu::EmcuAxis::X,
                    steps: 12
                },
                Reply::Ready
            ]
        );
        match events.get(2) {
            Some(ReplyEvent::Garbage(g)) => assert_eq!(
                g.to_string(),
                "dropped `zz`: incomplete line cut off by the start of a new one"
            ),
            other => panic!("expected garbage, got {other:?}"),
        }
    }

    #[test]
    fn crlf_does_not_swallow_the_next_ack() {
        let mut d = ReplyDecoder::new();
        let events = d.feed(b"@X000000\r\n\r");
        assert_eq!(
            replies(&events),
            vec![Reply::Status(Status::default()), Reply::Ack]
        );
        assert!(events.iter().any(|e| matches!(
            e,
            ReplyEvent::Garbage(Garbage {
                reason: GarbageReason::StrayLineFeed,
                ..
            })
        )));
    }

    #[test]
    fn an_endless_line_is_chunked_and_the_decoder_recovers() {
        let mut d = ReplyDecoder::new();
        let mut input = vec![b'@'; 1000];
        input.extend_from_slice(b"\r@X100000\r");
        let events = d.feed(&input);
        let garbage: Vec<&Garbage> = events
            .iter()
            .filter_map(|e| match e {
                ReplyEvent::Garbage(g) => Some(g),
                ReplyEvent::Reply(_) => None,
            })
            .collect();
        assert!(
            garbage
                .iter()
                .all(|g| g.reason == GarbageReason::TooLong && g.bytes.len() <= MAX_REPLY_LINE + 1)
        );
        let dropped: usize = garbage.iter().map(|g| g.bytes.len()).sum();
        assert_eq!(dropped, 1001, "every byte up to the CR is reported once");
        assert_eq!(
            replies(&events),
            vec![Reply::Status(Status {
                moving: true,
                ..Status::default()
            })]
        );
        assert!(d.pending().is_empty());
    }

    #[test]
    fn a_version_text_may_contain_an_at_sign() {
        let mut d = ReplyDecoder::new();
        let events = d.feed(b"@V SMC@home 2\r");
        assert!(
            matches!(events.as_slice(), [ReplyEvent::Reply(Reply::Version(v))] if v.as_str() == "SMC@home 2")
        );
    }
}
