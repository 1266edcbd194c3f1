//! The incremental reply decoder.
//!
//! The controller answers one command at a time, and the shape of the
//! answer depends on the command, so the decoder is told what to expect
//! ([`Expect::for_command`]). [`decode`] is a pure function over the bytes
//! received so far; [`ReplyDecoder`] keeps the buffer and the outstanding
//! expectation for a caller that is fed bytes in arbitrary chunks.
//!
//! Rules (`docs/protocols.md`, isel):
//! - A reply code where data was expected (`R` to `@0P`) is a normal
//!   [`Reply::Code`], not an error.
//! - A byte that cannot continue the expected reply is a [`DecodeError`]. The
//!   bytes up to and including it are dropped, and the expectation ends: the
//!   answer to that command is lost, so its outcome is unknown and the caller
//!   must treat the machine state as unknown. What follows is decoded afresh
//!   (as unsolicited bytes until the next command).
//! - No reply is longer than [`Expect::max_len`]; a text reply that has not
//!   ended within [`MAX_TEXT_REPLY`] bytes is an error, so a full buffer never
//!   means "need more" forever.
//! - `@0V`/`@0U` end only on silence: the caller, which owns the clock, calls
//!   [`ReplyDecoder::silence`] (or passes `silence = true`) after 50 ms
//!   without a byte (`docs/decisions.md` isel 8).

use std::fmt;

use thiserror::Error;

use crate::traffic::readable;

use super::axes::AxisConfig;
use super::cnc::SyncChar;
use super::command::Command;
use super::reply::{Positions, Reply, ReplyCode, TextEnd};

/// Longest text reply (`@0H`, `@0h`, `@0V`, `@0U`) the decoder collects.
pub const MAX_TEXT_REPLY: usize = 4096;

/// Silence that ends a `@0V`/`@0U` reply (`docs/decisions.md` isel 8).
pub const TEXT_SILENCE: std::time::Duration = std::time::Duration::from_millis(50);

/// The kind of reply a command gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Expect {
    /// One reply code: `0` or an error. Every command not listed below, and
    /// every stored CNC line.
    Handshake,
    /// `@0P`: `0` and 6 hex digits per axis; 3 axes unless A is on.
    Positions { with_a: bool },
    /// `@0b`, `@0D`: `0` and 2 hex digits.
    Byte,
    /// `@0H`, `@0h`: text lines, then a digit reply code (normally `0`).
    TextThenCode,
    /// `@0V`, `@0?`, `@0U`: text lines, ended by silence.
    TextUntilSilence,
    /// `@0S`: sync characters from stored `1` commands, then a reply code.
    ProgramRun,
}

impl Expect {
    /// The reply `command` gets from a controller with `config` (`None`
    /// before the axes are set: `@0P` then reports 3 axes).
    pub fn for_command(command: &Command, config: Option<AxisConfig>) -> Expect {
        match command {
            Command::ReadPosition => Expect::Positions {
                with_a: config.is_some_and(|c| c.position_axes() == 4),
            },
            Command::ReadPort(_) | Command::Diagnose(_) => Expect::Byte,
            Command::Status | Command::LimitSwitchStatus => Expect::TextThenCode,
            Command::ReadVersion | Command::ReadUserInfo => Expect::TextUntilSilence,
            Command::Start => Expect::ProgramRun,
            _ => Expect::Handshake,
        }
    }

    /// Longest reply of this kind in bytes (for a program run: per item).
    pub fn max_len(self) -> usize {
        match self {
            Expect::Handshake | Expect::ProgramRun => 1,
            Expect::Byte => 3,
            Expect::Positions { with_a } => 1 + 6 * if with_a { 4 } else { 3 },
            Expect::TextThenCode | Expect::TextUntilSilence => MAX_TEXT_REPLY,
        }
    }

    fn describe(self) -> &'static str {
        match self {
            Expect::Handshake => "a reply code",
            Expect::Positions { with_a: false } => "a position reply (`0` and 18 hex digits)",
            Expect::Positions { with_a: true } => "a position reply (`0` and 24 hex digits)",
            Expect::Byte => "a byte reply (`0` and 2 hex digits)",
            Expect::TextThenCode => "text lines and a closing reply code",
            Expect::TextUntilSilence => "text lines",
            Expect::ProgramRun => "sync characters or a reply code",
        }
    }
}

impl fmt::Display for Expect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.describe())
    }
}

/// Bytes that cannot be the expected reply.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("expected {expected}, got {got}; dropped {bytes}")]
pub struct DecodeError {
    /// What the decoder was waiting for.
    pub expected: String,
    /// What came instead.
    pub got: String,
    /// The dropped bytes in [`traffic::readable`](crate::traffic::readable) form.
    pub bytes: String,
    /// How many bytes were dropped from the front of the buffer.
    pub consumed: usize,
}

/// The result of one [`decode`] call.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decode {
    /// The bytes so far are the beginning of a valid reply.
    NeedMore,
    /// A complete reply in the first `consumed` bytes.
    Reply { reply: Reply, consumed: usize },
    /// During a program run: a sync character from a stored `1` command.
    /// The run goes on; the expectation stays.
    Sync { sync: SyncChar, consumed: usize },
    /// The first [`DecodeError::consumed`] bytes are not the expected reply.
    Error(DecodeError),
}

fn describe_byte(byte: u8) -> String {
    format!("`{}`", readable(&[byte]))
}

fn error(expected: impl Into<String>, got: String, buf: &[u8], consumed: usize) -> Decode {
    let consumed = consumed.min(buf.len());
    Decode::Error(DecodeError {
        expected: expected.into(),
        got,
        bytes: readable(buf.get(..consumed).unwrap_or_default()),
        consumed,
    })
}

fn truncated(expect: Expect, buf: &[u8]) -> Decode {
    error(
        expect.describe(),
        format!(
            "silence after {} byte{}",
            buf.len(),
            if buf.len() == 1 { "" } else { "s" }
        ),
        buf,
        buf.len(),
    )
}

/// Decode the reply at the front of `buf`. `silence` says that the line has
/// been quiet since the last byte of `buf` (for `@0V`/`@0U`, after
/// [`TEXT_SILENCE`]); with it a partial reply is an error instead of
/// [`Decode::NeedMore`]. An empty buffer is never an error: the controller
/// may be busy (a move answers when it is done).
pub fn decode(expect: Expect, buf: &[u8], silence: bool) -> Decode {
    match expect {
        Expect::Handshake => decode_code(buf),
        Expect::Positions { with_a } => {
            decode_hex(expect, buf, silence, if with_a { 4 } else { 3 })
        }
        Expect::Byte => decode_hex(expect, buf, silence, 0),
        Expect::TextThenCode => decode_text_then_code(buf, silence),
        Expect::TextUntilSilence => decode_text_until_silence(buf, silence),
        Expect::ProgramRun => decode_program_run(buf),
    }
}

fn decode_code(buf: &[u8]) -> Decode {
    let Some(&b) = buf.first() else {
        return Decode::NeedMore;
    };
    match ReplyCode::from_byte(b) {
        Some(code) => Decode::Reply {
            reply: Reply::Code(code),
            consumed: 1,
        },
        None => error(Expect::Handshake.describe(), describe_byte(b), buf, 1),
    }
}

/// `0` and hex digits: 6 per axis for positions, or 2 for a byte (`axes` 0).
fn decode_hex(expect: Expect, buf: &[u8], silence: bool, axes: usize) -> Decode {
    let Some(&first) = buf.first() else {
        return Decode::NeedMore;
    };
    if first != b'0' {
        return match ReplyCode::from_byte(first) {
            // An error where data was expected is a normal reply.
            Some(code) => Decode::Reply {
                reply: Reply::Code(code),
                consumed: 1,
            },
            None => error(expect.describe(), describe_byte(first), buf, 1),
        };
    }
    let len = expect.max_len();
    for (i, &b) in buf.iter().enumerate().take(len).skip(1) {
        if !b.is_ascii_hexdigit() {
            return error(
                format!("{} (hex digit {} of {})", expect.describe(), i, len - 1),
                describe_byte(b),
                buf,
                i + 1,
            );
        }
    }
    if buf.len() < len {
        return if silence {
            truncated(expect, buf)
        } else {
            Decode::NeedMore
        };
    }
    let digits = &buf[1..len];
    let reply = if axes == 0 {
        Reply::Byte(hex_value(digits) as u8)
    } else {
        let mut values = digits.chunks(6).map(|c| sign_extend_24(hex_value(c)));
        let mut next = || values.next().unwrap_or_default();
        let (x, y, z) = (next(), next(), next());
        let a = (axes == 4).then(next);
        Reply::Positions(Positions { x, y, z, a })
    };
    Decode::Reply {
        reply,
        consumed: len,
    }
}

/// The value of validated hex digits (at most 8 of them).
fn hex_value(digits: &[u8]) -> u32 {
    digits.iter().fold(0u32, |acc, d| {
        let v = char::from(*d).to_digit(16).unwrap_or_default();
        (acc << 4) | v
    })
}

/// A 24-bit two's complement field (`docs/decisions.md` isel 2).
fn sign_extend_24(raw: u32) -> i32 {
    ((raw << 8) as i32) >> 8
}

/// Lines end with CR LF; a lone CR or LF is accepted as a line end too.
/// Returns the line and where the next one starts, or `None` when the end
/// of the buffer leaves it open (a CR as the last byte may still get its LF).
fn next_line(buf: &[u8], start: usize) -> Option<(&[u8], usize)> {
    let rest = buf.get(start..)?;
    let at = rest.iter().position(|b| *b == b'\r' || *b == b'\n')?;
    let line = &rest[..at];
    match (rest[at], rest.get(at + 1)) {
        (b'\r', Some(b'\n')) => Some((line, start + at + 2)),
        (b'\r', None) => None,
        _ => Some((line, start + at + 1)),
    }
}

fn latin1(bytes: &[u8]) -> String {
    bytes.iter().map(|b| char::from(*b)).collect()
}

/// `@0H`/`@0h`: a digit at the start of a line closes the reply; a text line
/// cannot start with one (`docs/protocols.md`, isel).
fn decode_text_then_code(buf: &[u8], silence: bool) -> Decode {
    let window = &buf[..buf.len().min(MAX_TEXT_REPLY)];
    let mut lines = Vec::new();
    let mut pos = 0;
    loop {
        if let Some(&b) = window.get(pos)
            && b.is_ascii_digit()
        {
            // Every digit is a reply code.
            let code = ReplyCode::from_byte(b).unwrap_or(ReplyCode::Syntax);
            let reply = if lines.is_empty() && !code.is_ok() {
                Reply::Code(code)
            } else {
                Reply::Text {
                    lines,
                    end: TextEnd::Code(code),
                }
            };
            return Decode::Reply {
                reply,
                consumed: pos + 1,
            };
        }
        match next_line(window, pos) {
            Some((line, next)) => {
                lines.push(latin1(line));
                pos = next;
            }
            None => break,
        }
    }
    if window.len() >= MAX_TEXT_REPLY {
        return error(
            format!("text lines and a closing reply code within {MAX_TEXT_REPLY} bytes"),
            "more text".into(),
            buf,
            MAX_TEXT_REPLY,
        );
    }
    if !silence || buf.is_empty() {
        return Decode::NeedMore;
    }
    // A lone letter code followed by silence is an error reply, such as `H`.
    if let [b] = buf
        && lines.is_empty()
        && let Some(code) = ReplyCode::from_byte(*b)
    {
        return Decode::Reply {
            reply: Reply::Code(code),
            consumed: 1,
        };
    }
    truncated(Expect::TextThenCode, buf)
}

/// `@0V`/`@0U`: everything up to the silence, split into lines.
fn decode_text_until_silence(buf: &[u8], silence: bool) -> Decode {
    if buf.len() >= MAX_TEXT_REPLY {
        return error(
            format!("text lines followed by silence within {MAX_TEXT_REPLY} bytes"),
            "more text".into(),
            buf,
            MAX_TEXT_REPLY,
        );
    }
    if !silence {
        return Decode::NeedMore;
    }
    if let [b] = buf
        && let Some(code) = ReplyCode::from_byte(*b)
    {
        return Decode::Reply {
            reply: Reply::Code(code),
            consumed: 1,
        };
    }
    let mut lines = Vec::new();
    let mut pos = 0;
    while pos < buf.len() {
        match next_line(buf, pos) {
            Some((line, next)) => {
                lines.push(latin1(line));
                pos = next;
            }
            None => {
                // The last line without its end (or a CR without LF): keep it.
                let rest = &buf[pos..];
                lines.push(latin1(rest.strip_suffix(b"\r").unwrap_or(rest)));
                pos = buf.len();
            }
        }
    }
    Decode::Reply {
        reply: Reply::Text {
            lines,
            end: TextEnd::Silence,
        },
        consumed: buf.len(),
    }
}

/// `@0S`: a code the controller uses ends the run; any other printable
/// character (33-126, the unused codes `A B C E =` included) is a sync
/// character (`docs/protocols.md`, isel).
fn decode_program_run(buf: &[u8]) -> Decode {
    let Some(&b) = buf.first() else {
        return Decode::NeedMore;
    };
    if let Some(code) = ReplyCode::from_byte(b).filter(|c| c.is_used()) {
        return Decode::Reply {
            reply: Reply::Code(code),
            consumed: 1,
        };
    }
    match SyncChar::new(b) {
        Some(sync) => Decode::Sync { sync, consumed: 1 },
        None => error(Expect::ProgramRun.describe(), describe_byte(b), buf, 1),
    }
}

/// What the decoder reports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// The reply to the outstanding command; nothing is outstanding now.
    Reply(Reply),
    /// A sync character during a program run; the run is still outstanding.
    Sync(SyncChar),
    /// A byte that arrived while no reply was expected: line noise, or the
    /// sync characters (`1` commands) of a CNC program started with the start
    /// key, which answers nothing else, not even its end (`docs/protocols.md`,
    /// isel, "Start key").
    Unsolicited(u8),
    /// The outstanding reply was garbled; its bytes were dropped and nothing
    /// is outstanding now.
    Error(DecodeError),
}

/// `expect` was called while a reply is still outstanding: the isel
/// protocol allows one command at a time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("still waiting for {0}: the controller takes one command at a time")]
pub struct Outstanding(pub Expect);

/// Buffer and expectation for a byte stream from one controller.
///
/// ```
/// use jogterm::proto::isel::{Event, Expect, Positions, Reply, ReplyDecoder};
///
/// let mut decoder = ReplyDecoder::new();
/// decoder.expect(Expect::Positions { with_a: false }).unwrap();
/// // `0`, then 6 hex digits per axis, in any split.
/// assert!(decoder.feed(b"0000100").is_empty());
/// let events = decoder.feed(b"02000FFFFFFE");
/// assert_eq!(
///     events,
///     [Event::Reply(Reply::Positions(Positions { x: 256, y: 131087, z: -2, a: None }))]
/// );
/// ```
#[derive(Debug, Clone, Default)]
pub struct ReplyDecoder {
    outstanding: Option<Expect>,
    buf: Vec<u8>,
}

impl ReplyDecoder {
    pub fn new() -> ReplyDecoder {
        ReplyDecoder::default()
    }

    /// A command has been sent; its reply is `expect`.
    pub fn expect(&mut self, expect: Expect) -> Result<(), Outstanding> {
        if let Some(current) = self.outstanding {
            return Err(Outstanding(current));
        }
        self.outstanding = Some(expect);
        Ok(())
    }

    /// The reply being waited for.
    pub fn outstanding(&self) -> Option<Expect> {
        self.outstanding
    }

    /// Bytes of the outstanding reply received so far.
    pub fn pending(&self) -> &[u8] {
        &self.buf
    }

    /// Bytes have arrived.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Event> {
        let mut events = Vec::new();
        if self.outstanding.is_some() {
            self.buf.extend_from_slice(bytes);
            self.run(false, &mut events);
        } else {
            events.extend(bytes.iter().map(|b| Event::Unsolicited(*b)));
        }
        events
    }

    /// The line has been quiet since the last byte: ends `@0V`/`@0U`, and
    /// turns a partial reply of any other kind into an error.
    pub fn silence(&mut self) -> Vec<Event> {
        let mut events = Vec::new();
        self.run(true, &mut events);
        events
    }

    /// Stop waiting (a timeout, or 0xFE reset, which answers nothing and
    /// drops what the controller was doing). Returns the partial reply.
    pub fn abandon(&mut self) -> Vec<u8> {
        self.outstanding = None;
        std::mem::take(&mut self.buf)
    }

    fn run(&mut self, silence: bool, events: &mut Vec<Event>) {
        while let Some(expect) = self.outstanding {
            let consumed = match decode(expect, &self.buf, silence) {
                Decode::NeedMore => return,
                Decode::Reply { reply, consumed } => {
                    self.outstanding = None;
                    events.push(Event::Reply(reply));
                    consumed
                }
                Decode::Sync { sync, consumed } => {
                    events.push(Event::Sync(sync));
                    consumed
                }
                Decode::Error(e) => {
                    self.outstanding = None;
                    let consumed = e.consumed;
                    events.push(Event::Error(e));
                    consumed
                }
            };
            // The loop goes on only after a sync character, which consumed
            // one byte, so it always ends.
            self.buf.drain(..consumed.min(self.buf.len()));
        }
        events.extend(self.buf.drain(..).map(Event::Unsolicited));
    }
}
