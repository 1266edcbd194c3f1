//! The traffic console's log: the records the device task reports
//! (`Event::Traffic`) shown as whole messages, each readable
//! (`traffic::readable`), with the routine polls kept apart so that the
//! console does not scroll eighty times a second while the DRO runs.
//!
//! The driver says where each message ends and whose it is
//! (`TrafficRecord::messages`, `docs/device.md` "Traffic"): a record's
//! bytes after its last end are held until the message goes on in a later
//! record, the next command goes out, or the line is quiet (`flush_idle`:
//! an isel reply that only silence ends). Routine polls are the messages
//! the driver owns as polls, sent and answered; lines the operator typed
//! are the operator's, never routine, whatever they read like.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::traffic::{Direction, MessageEnd, Owner, TrafficRecord, readable};

/// Lines kept for scrolling back; polls kept apart, fewer.
pub const MAX_LINES: usize = 500;
pub const MAX_POLL_LINES: usize = 100;
/// A message without a known end is complete after this much quiet.
pub const IDLE_FLUSH: Duration = Duration::from_millis(100);

/// What a console line shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineKind {
    Sent,
    Received,
    /// The decoded answer to a typed command (`Event::Reply`).
    Reply,
    /// Something jogterm says (refusals, faults, notices).
    Note(NoteLevel),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoteLevel {
    Info,
    Warning,
    Danger,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConsoleLine {
    /// Order over both lists, so shown polls interleave correctly.
    pub seq: u64,
    pub kind: LineKind,
    pub text: String,
}

#[derive(Debug, Clone, Default)]
struct Pending {
    bytes: Vec<u8>,
    since: Option<Instant>,
}

#[derive(Debug, Clone, Default)]
pub struct TrafficLog {
    lines: VecDeque<ConsoleLine>,
    polls: VecDeque<ConsoleLine>,
    next_seq: u64,
    sent: Pending,
    received: Pending,
    /// The last rejection of a routine poll (EMP INFO `EE`), shown once: the
    /// same rejection again is counted with the polls, so a drive that is
    /// switched off and rejects every poll does not flood the console.
    last_rejection: Option<Vec<u8>>,
    /// Routine polls sent (shown or not).
    pub poll_count: u64,
    pub show_polls: bool,
}

impl TrafficLog {
    pub fn new() -> Self {
        Self::default()
    }

    /// A record from the device task, arrived at `now`.
    pub fn record(&mut self, record: &TrafficRecord, now: Instant) {
        let direction = record.direction;
        if direction == Direction::Sent {
            // A new command ends whatever answer was being read.
            self.flush_received();
        }
        for (part, end) in record.parts() {
            let pending = self.pending(direction);
            pending.bytes.extend_from_slice(part);
            if end.is_some() {
                let bytes = std::mem::take(&mut pending.bytes);
                self.push_message(direction, &bytes, end);
            }
        }
        let pending = self.pending(direction);
        pending.since = (!pending.bytes.is_empty()).then_some(now);
    }

    fn pending(&mut self, direction: Direction) -> &mut Pending {
        match direction {
            Direction::Sent => &mut self.sent,
            Direction::Received => &mut self.received,
        }
    }

    /// Complete what has been quiet for [`IDLE_FLUSH`]; true if a line was added.
    pub fn flush_idle(&mut self, now: Instant) -> bool {
        let mut changed = false;
        if self
            .sent
            .since
            .is_some_and(|t| now.saturating_duration_since(t) >= IDLE_FLUSH)
        {
            let bytes = std::mem::take(&mut self.sent.bytes);
            self.sent.since = None;
            changed |= self.push_message(Direction::Sent, &bytes, None);
        }
        if self
            .received
            .since
            .is_some_and(|t| now.saturating_duration_since(t) >= IDLE_FLUSH)
        {
            changed |= self.flush_received();
        }
        changed
    }

    fn flush_received(&mut self) -> bool {
        let bytes = std::mem::take(&mut self.received.bytes);
        self.received.since = None;
        self.push_message(Direction::Received, &bytes, None)
    }

    /// A line of jogterm's own (a decoded reply, a refusal, a notice).
    pub fn note(&mut self, kind: LineKind, text: impl Into<String>) {
        let line = self.line(kind, text.into());
        push_capped(&mut self.lines, line, MAX_LINES);
    }

    /// A whole message (`end`: its end as the driver knows it; `None` for
    /// one that ended by quiet or the next command). Returns whether a
    /// visible line was added.
    fn push_message(
        &mut self,
        direction: Direction,
        bytes: &[u8],
        end: Option<MessageEnd>,
    ) -> bool {
        if bytes.is_empty() {
            return false;
        }
        let poll = end.is_some_and(|e| e.owner == Owner::Poll);
        let rejected = end.is_some_and(|e| e.rejected);
        let routine = if !poll {
            false
        } else if !rejected {
            if direction == Direction::Received {
                self.last_rejection = None;
            }
            true
        } else if self.last_rejection.as_deref() == Some(bytes) {
            true
        } else {
            self.last_rejection = Some(bytes.to_vec());
            false
        };
        let kind = match direction {
            Direction::Sent => LineKind::Sent,
            Direction::Received => LineKind::Received,
        };
        let line = self.line(kind, readable(bytes));
        if direction == Direction::Sent && poll {
            self.poll_count = self.poll_count.saturating_add(1);
        }
        if routine {
            push_capped(&mut self.polls, line, MAX_POLL_LINES);
            self.show_polls
        } else {
            push_capped(&mut self.lines, line, MAX_LINES);
            true
        }
    }

    fn line(&mut self, kind: LineKind, text: String) -> ConsoleLine {
        let seq = self.next_seq;
        self.next_seq = self.next_seq.wrapping_add(1);
        ConsoleLine { seq, kind, text }
    }

    /// The last `n` lines to show, oldest first (polls merged in when shown).
    pub fn tail(&self, n: usize) -> Vec<&ConsoleLine> {
        let mut out: Vec<&ConsoleLine> = if self.show_polls {
            let mut all: Vec<&ConsoleLine> = self.lines.iter().chain(self.polls.iter()).collect();
            all.sort_by_key(|l| l.seq);
            all
        } else {
            self.lines.iter().collect()
        };
        let skip = out.len().saturating_sub(n);
        out.drain(..skip);
        out
    }
}

fn push_capped(list: &mut VecDeque<ConsoleLine>, line: ConsoleLine, cap: usize) {
    list.push_back(line);
    while list.len() > cap {
        list.pop_front();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Whole messages of `owner`, as the device task reports what it sent.
    fn sent(bytes: &[u8], owner: Owner) -> TrafficRecord {
        TrafficRecord::messages(Direction::Sent, bytes, owner, &[bytes.len()])
    }

    /// Part of a message, its end in a later record.
    fn sent_part(bytes: &[u8]) -> TrafficRecord {
        TrafficRecord::new(Direction::Sent, bytes)
    }

    /// Bytes read, with the messages the driver found ending in them.
    fn received(bytes: &[u8], ends: &[(usize, Owner)]) -> TrafficRecord {
        TrafficRecord {
            messages: ends.iter().map(|(e, o)| MessageEnd::new(*e, *o)).collect(),
            ..TrafficRecord::new(Direction::Received, bytes)
        }
    }

    fn rejection(bytes: &[u8]) -> TrafficRecord {
        TrafficRecord {
            messages: vec![MessageEnd {
                rejected: true,
                ..MessageEnd::new(bytes.len(), Owner::Poll)
            }],
            ..TrafficRecord::new(Direction::Received, bytes)
        }
    }

    fn texts(log: &TrafficLog) -> Vec<String> {
        log.tail(100).iter().map(|l| l.text.clone()).collect()
    }

    #[test]
    fn a_message_goes_on_across_records_until_its_end() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        log.record(&sent_part(b"@0A5"), t);
        log.record(&sent_part(b"000,9"), t);
        log.record(&sent(b"00\r", Owner::Motion), t);
        log.record(&received(b"0", &[(1, Owner::Motion)]), t);
        log.record(&sent(b"@0M10,9\r", Owner::User), t);
        // Ended by nothing the driver saw: the quiet completes it.
        log.record(&received(b"F", &[]), t);
        assert!(!log.flush_idle(t + IDLE_FLUSH / 2));
        assert!(log.flush_idle(t + IDLE_FLUSH));
        assert_eq!(texts(&log), ["@0A5000,900<CR>", "0", "@0M10,9<CR>", "F"]);
        assert_eq!(log.tail(2).len(), 2);
    }

    #[test]
    fn a_message_ends_where_the_driver_says_and_the_next_command_ends_the_rest() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        log.record(&sent(b"@0V\r", Owner::User), t);
        log.record(&received(b"iMC-S8\r", &[]), t);
        log.record(
            &received(
                b"\nV2.0\r\n0X",
                &[(1, Owner::User), (7, Owner::User), (8, Owner::User)],
            ),
            t,
        );
        log.record(&sent(b"@0P\r", Owner::Poll), t);
        assert_eq!(
            texts(&log),
            ["@0V<CR>", "iMC-S8<CR><LF>", "V2.0<CR><LF>", "0", "X"]
        );
    }

    #[test]
    fn a_stop_sequence_is_a_line_per_control_byte() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        log.record(
            &TrafficRecord::messages(Direction::Sent, [0xFD, 0xFF], Owner::Stop, &[1, 2]),
            t,
        );
        log.record(&sent(b"@0A5000,900\r", Owner::Motion), t);
        assert_eq!(texts(&log), ["<FD>", "<FF>", "@0A5000,900<CR>"]);
    }

    #[test]
    fn polls_are_counted_apart_and_shown_on_request() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        log.record(&sent(b"@0P\r", Owner::Poll), t);
        log.record(&received(b"0000100000000000000", &[(19, Owner::Poll)]), t);
        log.record(&sent(b"@0b3\r", Owner::Poll), t);
        log.record(&received(b"001", &[(3, Owner::Poll)]), t);
        log.record(&sent(b"@0R7\r", Owner::User), t);
        log.record(&received(b"0", &[]), t);
        log.flush_idle(t + IDLE_FLUSH);
        assert_eq!(texts(&log), ["@0R7<CR>", "0"]);
        assert_eq!(log.poll_count, 2);
        log.show_polls = true;
        assert_eq!(texts(&log).len(), 6);
        assert_eq!(texts(&log)[0], "@0P<CR>");
    }

    #[test]
    fn a_typed_poll_is_the_operators_and_shown_with_its_answer() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        log.record(&sent(b"@LX\r", Owner::User), t);
        log.record(&received(b"@LX1234\r", &[(8, Owner::User)]), t);
        log.record(&sent(b"@LY\r", Owner::Poll), t);
        log.record(&received(b"@LY5\r", &[(5, Owner::Poll)]), t);
        assert_eq!(texts(&log), ["@LX<CR>", "@LX1234<CR>"]);
        assert_eq!(log.poll_count, 1);
    }

    #[test]
    fn what_the_controller_sends_on_its_own_is_never_hidden() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        log.record(&sent(b"@X\r", Owner::Poll), t);
        log.record(
            &received(
                b"@X000000\r\x02\r",
                &[(9, Owner::Poll), (11, Owner::Controller)],
            ),
            t,
        );
        assert_eq!(texts(&log), ["<02><CR>"]);

        let mut log = TrafficLog::new();
        log.record(&sent(b"2C11000000000000\x1a", Owner::Poll), t);
        log.record(
            &received(
                b"2D11002200000100\x1a2B11002200000000\x1a",
                &[(17, Owner::Poll), (34, Owner::Controller)],
            ),
            t,
        );
        assert_eq!(texts(&log), ["2B11002200000000<EOF>"]);
        assert_eq!(log.poll_count, 1);
    }

    #[test]
    fn a_rejected_poll_is_shown_once_until_something_else_is_answered() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        let poll = || sent(b"2C11000000000000\x1a", Owner::Poll);
        for _ in 0..5 {
            log.record(&poll(), t);
            log.record(&rejection(b"2D1100EE00000000\x1a"), t);
        }
        assert_eq!(texts(&log), ["2D1100EE00000000<EOF>"]);
        assert_eq!(log.poll_count, 5);
        // Switched on: positions come; a later rejection is news again.
        log.record(&poll(), t);
        log.record(&received(b"2D11002200000100\x1a", &[(17, Owner::Poll)]), t);
        log.record(&poll(), t);
        log.record(&rejection(b"2D1100EE00000000\x1a"), t);
        assert_eq!(
            texts(&log),
            ["2D1100EE00000000<EOF>", "2D1100EE00000000<EOF>"]
        );
        // Unsolicited frames are never folded, however often they repeat.
        for _ in 0..2 {
            log.record(&poll(), t);
            log.record(
                &received(b"2B11002200000000\x1a", &[(17, Owner::Controller)]),
                t,
            );
        }
        assert_eq!(texts(&log).len(), 4);
    }

    #[test]
    fn lists_are_bounded() {
        let t = Instant::now();
        let mut log = TrafficLog::new();
        for _ in 0..(MAX_LINES + 10) {
            log.record(&sent(b"@0R1\r", Owner::User), t);
            log.record(&sent(b"@0P\r", Owner::Poll), t);
        }
        log.show_polls = true;
        assert_eq!(log.tail(usize::MAX).len(), MAX_LINES + MAX_POLL_LINES);
    }

    /// The inverse of `traffic::readable`, for checking that nothing is lost.
    fn unreadable(text: &str) -> Vec<u8> {
        let mut out = Vec::new();
        let mut rest = text;
        while let Some(c) = rest.chars().next() {
            if c == '<'
                && let Some(end) = rest.find('>')
            {
                let name = &rest[1..end];
                out.push(match name {
                    "CR" => b'\r',
                    "LF" => b'\n',
                    "EOF" => 0x1A,
                    hex => u8::from_str_radix(hex, 16).expect("hex escape"),
                });
                rest = &rest[end + 1..];
            } else {
                out.push(c as u8);
                rest = &rest[c.len_utf8()..];
            }
        }
        out
    }

    const OWNERS: [Owner; 8] = [
        Owner::Poll,
        Owner::User,
        Owner::Motion,
        Owner::Upload,
        Owner::Program,
        Owner::Stop,
        Owner::Setup,
        Owner::Controller,
    ];

    /// A record of `bytes` whose messages end at the `cuts` (offsets, any
    /// order, out of range ones dropped), with owners and rejections.
    fn tagged(sent: bool, bytes: &[u8], cuts: &[(usize, usize, bool)]) -> TrafficRecord {
        let mut ends: Vec<MessageEnd> = cuts
            .iter()
            .filter(|(at, _, _)| (1..=bytes.len()).contains(at))
            .map(|(at, owner, rejected)| MessageEnd {
                rejected: *rejected,
                ..MessageEnd::new(*at, OWNERS[owner % OWNERS.len()])
            })
            .collect();
        ends.sort_by_key(|m| m.end);
        ends.dedup_by_key(|m| m.end);
        let direction = if sent {
            Direction::Sent
        } else {
            Direction::Received
        };
        TrafficRecord {
            messages: ends,
            ..TrafficRecord::new(direction, bytes)
        }
    }

    proptest! {
        #[test]
        fn any_bytes_in_any_messages_are_all_shown_in_order(
            records in prop::collection::vec(
                (
                    any::<bool>(),
                    prop::collection::vec(any::<u8>(), 0..16),
                    prop::collection::vec((0usize..17, 0usize..8, any::<bool>()), 0..4),
                ),
                0..16,
            ),
        ) {
            let t = Instant::now();
            let mut log = TrafficLog::new();
            log.show_polls = true;
            let (mut sent_in, mut received_in) = (Vec::new(), Vec::new());
            for (is_sent, bytes, cuts) in &records {
                let record = tagged(*is_sent, bytes, cuts);
                if *is_sent {
                    sent_in.extend_from_slice(bytes);
                } else {
                    received_in.extend_from_slice(bytes);
                }
                log.record(&record, t);
            }
            log.flush_idle(t + IDLE_FLUSH);
            prop_assume!(log.polls.len() < MAX_POLL_LINES && log.lines.len() < MAX_LINES);
            let (mut sent_out, mut received_out) = (Vec::new(), Vec::new());
            for line in log.tail(usize::MAX) {
                let bytes = unreadable(&line.text);
                match line.kind {
                    LineKind::Sent => sent_out.extend(bytes),
                    LineKind::Received => received_out.extend(bytes),
                    _ => prop_assert!(false, "only traffic lines were recorded"),
                }
            }
            prop_assert_eq!(sent_out, sent_in);
            prop_assert_eq!(received_out, received_in);
        }
    }
}
