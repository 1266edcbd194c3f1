//! The traffic console's log: the chunks the device task reports
//! (`Event::Traffic`, cut wherever the writer paced or the reader woke) put
//! back together into whole messages per protocol, each shown readable
//! (`traffic::readable`), and the routine polls kept apart so that the
//! console does not scroll eighty times a second while the DRO runs.
//!
//! Framing per family (messages end after):
//! - isel: commands after CR (or LF); the control bytes 0xFD/0xFE/0xFF are
//!   messages of their own even between two bytes of a command (isel manual
//!   2.2.31). Text replies after each CR LF line; the other replies have no
//!   terminator (`0`, `0` + hex digits): a reply ends when the next command
//!   goes out or the line is quiet (`flush_idle`).
//! - EMCU: CR, or 0x01 for a command that runs the buffer (manual 1.3).
//! - EMP: EOF 0x1A (EMP document, frame format).
//!
//! Routine polls are the reads a driver repeats: isel `P`, `b`, `D`; EMCU
//! `@X`, `@L…`; EMP `2C`, `40`, and their answers. Lines the operator typed
//! are never routine.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::proto::Protocol;
use crate::proto::{emcu, emp, isel};
use crate::traffic::{Direction, TrafficRecord, readable};

/// Lines kept for scrolling back; polls kept apart, fewer.
pub const MAX_LINES: usize = 500;
pub const MAX_POLL_LINES: usize = 100;
/// A message without a terminator is complete after this much quiet.
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

#[derive(Debug, Clone)]
pub struct TrafficLog {
    protocol: Protocol,
    lines: VecDeque<ConsoleLine>,
    polls: VecDeque<ConsoleLine>,
    next_seq: u64,
    sent: Pending,
    received: Pending,
    /// Whether the last complete command sent was a routine poll.
    last_sent_routine: bool,
    /// The last rejection of a routine poll (EMP INFO `EE`), shown once: the
    /// same rejection again is counted with the polls, so a drive that is
    /// switched off and rejects every poll does not flood the console.
    last_rejection: Option<Vec<u8>>,
    /// Typed lines sent and not yet seen on the wire (whitespace removed,
    /// upper case), so they show even when they read like polls.
    typed: VecDeque<Vec<u8>>,
    /// Routine polls sent (shown or not).
    pub poll_count: u64,
    pub show_polls: bool,
}

impl TrafficLog {
    pub fn new(protocol: Protocol) -> Self {
        Self {
            protocol,
            lines: VecDeque::new(),
            polls: VecDeque::new(),
            next_seq: 0,
            sent: Pending::default(),
            received: Pending::default(),
            last_sent_routine: false,
            last_rejection: None,
            typed: VecDeque::new(),
            poll_count: 0,
            show_polls: false,
        }
    }

    /// A chunk from the device task, arrived at `now`.
    pub fn record(&mut self, record: &TrafficRecord, now: Instant) {
        match record.direction {
            Direction::Sent => {
                // A new command ends whatever answer was being read.
                self.flush_received();
                for &byte in &record.bytes {
                    if self.protocol == Protocol::Isel && (0xFD..=0xFF).contains(&byte) {
                        self.push_message(Direction::Sent, &[byte]);
                        continue;
                    }
                    self.sent.bytes.push(byte);
                    if self.ends_message(Direction::Sent, byte) {
                        let bytes = std::mem::take(&mut self.sent.bytes);
                        self.push_message(Direction::Sent, &bytes);
                    }
                }
                self.sent.since = (!self.sent.bytes.is_empty()).then_some(now);
            }
            Direction::Received => {
                for &byte in &record.bytes {
                    self.received.bytes.push(byte);
                    if self.ends_message(Direction::Received, byte) {
                        let bytes = std::mem::take(&mut self.received.bytes);
                        self.push_message(Direction::Received, &bytes);
                    }
                }
                self.received.since = (!self.received.bytes.is_empty()).then_some(now);
            }
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
            changed |= self.push_message(Direction::Sent, &bytes);
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
        self.push_message(Direction::Received, &bytes)
    }

    fn ends_message(&self, direction: Direction, byte: u8) -> bool {
        match (self.protocol, direction) {
            (Protocol::Isel, Direction::Sent) => byte == b'\r' || byte == b'\n',
            // Text replies end their lines with CR LF (protocols.md isel 8).
            (Protocol::Isel, Direction::Received) => byte == b'\n',
            (Protocol::Emcu, Direction::Sent) => byte == b'\r' || byte == 0x01,
            (Protocol::Emcu, Direction::Received) => byte == b'\r',
            (Protocol::Emp, _) => byte == emp::EOF,
        }
    }

    /// The operator sent `line` as a raw command: show it whatever it is.
    pub fn typed(&mut self, line: &str) {
        self.typed.push_back(normalise(line.as_bytes()));
        while self.typed.len() > 8 {
            self.typed.pop_front();
        }
    }

    /// A line of jogterm's own (a decoded reply, a refusal, a notice).
    pub fn note(&mut self, kind: LineKind, text: impl Into<String>) {
        let line = self.line(kind, text.into());
        push_capped(&mut self.lines, line, MAX_LINES);
    }

    /// Returns whether a visible line was added.
    fn push_message(&mut self, direction: Direction, bytes: &[u8]) -> bool {
        if bytes.is_empty() {
            return false;
        }
        let routine = match direction {
            Direction::Sent => {
                let typed = self.take_typed(bytes);
                let routine = !typed && is_routine_command(self.protocol, bytes);
                self.last_sent_routine = routine;
                routine
            }
            Direction::Received if self.last_sent_routine => {
                if is_routine_answer(self.protocol, bytes) {
                    self.last_rejection = None;
                    true
                } else if !is_poll_rejection(self.protocol, bytes) {
                    false
                } else if self.last_rejection.as_deref() == Some(bytes) {
                    true
                } else {
                    self.last_rejection = Some(bytes.to_vec());
                    false
                }
            }
            Direction::Received => false,
        };
        let kind = match direction {
            Direction::Sent => LineKind::Sent,
            Direction::Received => LineKind::Received,
        };
        let line = self.line(kind, readable(bytes));
        if routine {
            if direction == Direction::Sent {
                self.poll_count = self.poll_count.saturating_add(1);
            }
            push_capped(&mut self.polls, line, MAX_POLL_LINES);
            self.show_polls
        } else {
            push_capped(&mut self.lines, line, MAX_LINES);
            true
        }
    }

    fn take_typed(&mut self, bytes: &[u8]) -> bool {
        let wire = normalise(bytes);
        match self.typed.iter().position(|t| *t == wire) {
            Some(i) => {
                self.typed.remove(i);
                true
            }
            None => false,
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

/// Bytes as compared with a typed line: no terminators, no blanks, upper case.
fn normalise(bytes: &[u8]) -> Vec<u8> {
    bytes
        .iter()
        .filter(|b| !b.is_ascii_whitespace() && **b != emp::EOF && **b != 0x01)
        .map(u8::to_ascii_uppercase)
        .collect()
}

fn body(bytes: &[u8]) -> &[u8] {
    let end = bytes
        .iter()
        .rposition(|&b| !matches!(b, b'\r' | b'\n' | 0x01 | emp::EOF))
        .map_or(0, |i| i + 1);
    bytes.get(..end).unwrap_or_default()
}

/// Whether a command is one of the reads a driver repeats.
pub fn is_routine_command(protocol: Protocol, bytes: &[u8]) -> bool {
    let body = body(bytes);
    match protocol {
        Protocol::Isel => isel::parse_frame(body).is_ok_and(|p| {
            matches!(
                p.value.command,
                isel::Command::ReadPosition
                    | isel::Command::ReadPort(_)
                    | isel::Command::Diagnose(_)
            )
        }),
        Protocol::Emcu => emcu::parse_bytes(body)
            .is_ok_and(|c| matches!(c, emcu::Command::Status | emcu::Command::Position(_))),
        Protocol::Emp => std::str::from_utf8(body)
            .ok()
            .and_then(|s| s.parse::<emp::Request>().ok())
            .is_some_and(|r| {
                matches!(
                    r.command,
                    emp::Command::ReadPosition | emp::Command::ReadInputs
                )
            }),
    }
}

/// Whether a message read after a routine command is its answer (and not
/// something the controller sent on its own).
pub fn is_routine_answer(protocol: Protocol, bytes: &[u8]) -> bool {
    let body = body(bytes);
    match protocol {
        // One command at a time (protocols.md isel): what follows a poll is its answer.
        Protocol::Isel => true,
        // Query replies repeat the command (EMCU manual 1.5.3, 1.5.4); 0x02 /
        // 0x03 are the buffer's own reports.
        Protocol::Emcu => body.starts_with(b"@X") || body.starts_with(b"@L"),
        // Replies to 2C and 40 (CMD + 1); a rejection (INFO EE) is worth seeing.
        Protocol::Emp => {
            emp::Frame::from_hex(body).is_ok_and(|f| matches!(f.cmd, 0x2D | 0x41) && f.info != 0xEE)
        }
    }
}

/// Whether a message is a controller's refusal of a routine poll (EMP
/// INFO `EE` to `2C` / `40`): shown, but its repeats are not news.
fn is_poll_rejection(protocol: Protocol, bytes: &[u8]) -> bool {
    protocol == Protocol::Emp
        && emp::Frame::from_hex(body(bytes))
            .is_ok_and(|f| matches!(f.cmd, 0x2D | 0x41) && f.info == 0xEE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sent(bytes: &[u8]) -> TrafficRecord {
        TrafficRecord::new(Direction::Sent, bytes)
    }

    fn received(bytes: &[u8]) -> TrafficRecord {
        TrafficRecord::new(Direction::Received, bytes)
    }

    fn texts(log: &TrafficLog) -> Vec<String> {
        log.tail(100).iter().map(|l| l.text.clone()).collect()
    }

    #[test]
    fn paced_chunks_become_whole_messages() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Isel);
        for chunk in [&b"@0A5"[..], b"000,9", b"00\r"] {
            log.record(&sent(chunk), t);
        }
        log.record(&received(b"0"), t);
        log.record(&sent(b"@0M10,9\r"), t);
        log.record(&received(b"F"), t);
        assert!(log.flush_idle(t + IDLE_FLUSH));
        assert_eq!(texts(&log), ["@0A5000,900<CR>", "0", "@0M10,9<CR>", "F"]);
        assert_eq!(log.tail(2).len(), 2);
    }

    #[test]
    fn isel_text_replies_are_one_line_each_with_their_cr_lf() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Isel);
        log.record(&sent(b"@0V\r"), t);
        log.record(&received(b"iMC-S8\r"), t);
        log.record(&received(b"\nV2.0\r\n0"), t);
        log.record(&sent(b"@0P\r"), t);
        assert_eq!(
            texts(&log),
            ["@0V<CR>", "iMC-S8<CR><LF>", "V2.0<CR><LF>", "0"]
        );
    }

    #[test]
    fn isel_stop_bytes_show_at_once_even_inside_a_command() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Isel);
        log.record(&sent(b"@0A50"), t);
        log.record(&sent(&[0xFD]), t);
        log.record(&sent(b"00,900\r"), t);
        assert_eq!(texts(&log), ["<FD>", "@0A5000,900<CR>"]);
    }

    #[test]
    fn polls_are_counted_apart_and_shown_on_request() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Isel);
        log.record(&sent(b"@0P\r"), t);
        log.record(&received(b"0000100000000000000"), t);
        log.record(&sent(b"@0b3\r"), t);
        log.record(&received(b"001"), t);
        log.record(&sent(b"@0R7\r"), t);
        log.record(&received(b"0"), t);
        log.flush_idle(t + IDLE_FLUSH);
        assert_eq!(texts(&log), ["@0R7<CR>", "0"]);
        assert_eq!(log.poll_count, 2);
        log.show_polls = true;
        assert_eq!(texts(&log).len(), 6);
        assert_eq!(texts(&log)[0], "@0P<CR>");
    }

    #[test]
    fn a_typed_poll_is_shown_with_its_answer() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Emcu);
        log.typed("@LX");
        log.record(&sent(b"@LX\r"), t);
        log.record(&received(b"@LX1234\r"), t);
        log.record(&sent(b"@LY\r"), t);
        log.record(&received(b"@LY5\r"), t);
        assert_eq!(texts(&log), ["@LX<CR>", "@LX1234<CR>"]);
    }

    #[test]
    fn emcu_and_emp_unsolicited_messages_are_never_hidden() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Emcu);
        log.record(&sent(b"@X\r"), t);
        log.record(&received(b"@X000000\r\x02\r"), t);
        assert_eq!(texts(&log), ["<02><CR>"]);

        let mut log = TrafficLog::new(Protocol::Emp);
        log.record(&sent(b"2C11000000000000\x1a"), t);
        log.record(&received(b"2D11002200000100\x1a2B11002200000000\x1a"), t);
        assert_eq!(texts(&log), ["2B11002200000000<EOF>"]);
        assert_eq!(log.poll_count, 1);
    }

    #[test]
    fn a_rejected_poll_is_shown_once_until_something_else_is_answered() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Emp);
        for _ in 0..5 {
            log.record(&sent(b"2C11000000000000\x1a"), t);
            log.record(&received(b"2D1100EE00000000\x1a"), t);
        }
        assert_eq!(texts(&log), ["2D1100EE00000000<EOF>"]);
        assert_eq!(log.poll_count, 5);
        // Switched on: positions come; a later rejection is news again.
        log.record(&sent(b"2C11000000000000\x1a"), t);
        log.record(&received(b"2D11002200000100\x1a"), t);
        log.record(&sent(b"2C11000000000000\x1a"), t);
        log.record(&received(b"2D1100EE00000000\x1a"), t);
        assert_eq!(
            texts(&log),
            ["2D1100EE00000000<EOF>", "2D1100EE00000000<EOF>"]
        );
        // Unsolicited frames are never folded, however often they repeat.
        for _ in 0..2 {
            log.record(&sent(b"2C11000000000000\x1a"), t);
            log.record(&received(b"2B11002200000000\x1a"), t);
        }
        assert_eq!(texts(&log).len(), 4);
    }

    #[test]
    fn lists_are_bounded() {
        let t = Instant::now();
        let mut log = TrafficLog::new(Protocol::Isel);
        for _ in 0..(MAX_LINES + 10) {
            log.record(&sent(b"@0R1\r"), t);
            log.record(&sent(b"@0P\r"), t);
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

    proptest! {
        #[test]
        fn any_bytes_in_any_split_are_all_shown_in_order(
            protocol in prop::sample::select(Protocol::ALL.to_vec()),
            chunks in prop::collection::vec(
                (any::<bool>(), prop::collection::vec(any::<u8>(), 0..16)), 0..16),
        ) {
            let t = Instant::now();
            let mut log = TrafficLog::new(protocol);
            log.show_polls = true;
            let is_stop = |b: &u8| protocol == Protocol::Isel && (0xFD..=0xFF).contains(b);
            let (mut sent_in, mut received_in, mut stops_in) = (Vec::new(), Vec::new(), Vec::new());
            for (is_sent, bytes) in &chunks {
                if *is_sent {
                    stops_in.extend(bytes.iter().copied().filter(is_stop));
                    sent_in.extend(bytes.iter().copied().filter(|b| !is_stop(b)));
                    log.record(&sent(bytes), t);
                } else {
                    received_in.extend_from_slice(bytes);
                    log.record(&received(bytes), t);
                }
            }
            log.flush_idle(t + IDLE_FLUSH);
            prop_assume!(log.polls.len() < MAX_POLL_LINES && log.lines.len() < MAX_LINES);
            let (mut sent_out, mut received_out, mut stops_out) = (Vec::new(), Vec::new(), Vec::new());
            for line in log.tail(usize::MAX) {
                let bytes = unreadable(&line.text);
                match line.kind {
                    LineKind::Sent if bytes.len() == 1 && is_stop(&bytes[0]) => stops_out.extend(bytes),
                    LineKind::Sent => sent_out.extend(bytes),
                    LineKind::Received => received_out.extend(bytes),
                    _ => prop_assert!(false, "only traffic lines were recorded"),
                }
            }
            prop_assert_eq!(sent_out, sent_in);
            prop_assert_eq!(received_out, received_in);
            prop_assert_eq!(stops_out, stops_in);
        }
    }
}
