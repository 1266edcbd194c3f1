//! Typed replies of the interface and their encoder (for the simulator) and
//! line parser (for the decoder). Every command is acknowledged by CR; query
//! replies repeat the command and end with CR (manual 1.4.2, 1.5.2-1.5.4); 0x02
//! CR and 0x03 CR are the ready and memory-full lines of decision 1.

use std::fmt;

use thiserror::Error;

use crate::text::readable;

use super::command::CR;
use super::status::Status;
use super::values::EmcuAxis;

/// First byte of the unsolicited ready line (manual 1.4.2).
pub const READY: u8 = 0x02;
/// First byte of the memory-full acknowledgement (manual 1.4.2).
pub const MEMORY_FULL: u8 = 0x03;
/// Longest reply line jogterm accepts, CR not counted. The longest reply the
/// manual shows is `@V SMC3000i 1.00` (16); a position is at most 14
/// (`@LX-2147483648`). Room is left for a longer version text.
pub const MAX_REPLY_LINE: usize = 64;

/// The text of a version reply after `@V ` (`SMC3000i 1.00`): one or more
/// printable ASCII characters, so that it always encodes to one line.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct VersionText(String);

impl VersionText {
    /// Most characters: the line limit less `@V `.
    pub const MAX_LEN: usize = MAX_REPLY_LINE - 3;

    /// Whether `text` makes a version text: at compile time, for a text
    /// jogterm itself sends (the simulator's `VERSION`).
    pub const fn is_valid(text: &str) -> bool {
        let bytes = text.as_bytes();
        if bytes.is_empty() || bytes.len() > Self::MAX_LEN {
            return false;
        }
        let mut i = 0;
        while i < bytes.len() {
            if bytes[i] < 0x20 || bytes[i] > 0x7E {
                return false;
            }
            i += 1;
        }
        true
    }

    pub fn new(text: &str) -> Result<VersionText, ReplyError> {
        if text.is_empty() {
            return Err(ReplyError::VersionEmpty);
        }
        if text.len() > Self::MAX_LEN {
            return Err(ReplyError::VersionTooLong { max: Self::MAX_LEN });
        }
        if let Some(bad) = text.bytes().find(|b| !(0x20..=0x7E).contains(b)) {
            return Err(ReplyError::VersionByte(bad));
        }
        Ok(VersionText(text.to_owned()))
    }

    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for VersionText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// One line from the interface.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Reply {
    /// A bare CR: the acknowledgement of any non-query command.
    Ack,
    /// 0x03 CR: the acknowledgement of a buffered command that filled the data
    /// memory; the buffer starts running, and buffered commands must wait for
    /// [`Reply::Ready`] (decision 1).
    MemoryFull,
    /// 0x02 CR, unsolicited: the buffer or job has finished, or the memory has
    /// room again. Never the answer to a command (manual 1.4.2).
    Ready,
    /// `@V SMC3000i 1.00`: the answer to `@V`.
    Version(VersionText),
    /// `@X100110`: the answer to `@X`.
    Status(Status),
    /// `@LX1234`, `@LY-1234`: the answer to `@LX`/`@LY`/`@LZ`, in steps.
    Position { axis: EmcuAxis, steps: i32 },
}

/// Why a CR-terminated line is not a reply.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ReplyError {
    #[error("not an EMCU reply (a reply is CR, 0x02 CR, 0x03 CR or starts with `@V`, `@X`, `@L`)")]
    Unknown,
    #[error("bytes after {0:#04x}: the ready and memory-full lines are that byte and CR only")]
    AfterControl(u8),
    #[error("status reply needs six characters 0 or 1 after `@X`")]
    Status,
    #[error("position reply needs an axis X, Y or Z after `@L`")]
    PositionAxis,
    #[error(
        "position reply needs a whole number of steps (-2147483648..=2147483647) after the axis"
    )]
    PositionNumber,
    #[error("version reply has no text after `@V`")]
    VersionEmpty,
    #[error("version text is longer than {max} characters")]
    VersionTooLong { max: usize },
    #[error("version text contains the byte {}", readable(&[*.0]))]
    VersionByte(u8),
}

impl Reply {
    /// The bytes of the reply line, CR included.
    pub fn encode(&self) -> Vec<u8> {
        let mut line = match self {
            Reply::Ack => Vec::new(),
            Reply::MemoryFull => vec![MEMORY_FULL],
            Reply::Ready => vec![READY],
            Reply::Version(text) => format!("@V {text}").into_bytes(),
            Reply::Status(status) => {
                let mut line = b"@X".to_vec();
                line.extend_from_slice(&status.digits());
                line
            }
            Reply::Position { axis, steps } => {
                format!("@L{}{steps}", char::from(axis.upper())).into_bytes()
            }
        };
        line.push(CR);
        line
    }

    /// Parses one reply line without its CR.
    pub fn parse_line(line: &[u8]) -> Result<Reply, ReplyError> {
        match line {
            [] => Ok(Reply::Ack),
            [READY] => Ok(Reply::Ready),
            [MEMORY_FULL] => Ok(Reply::MemoryFull),
            [first @ (READY | MEMORY_FULL), ..] => Err(ReplyError::AfterControl(*first)),
            [b'@', b'X', digits @ ..] => Status::from_digits(digits)
                .map(Reply::Status)
                .ok_or(ReplyError::Status),
            [b'@', b'L', rest @ ..] => parse_position(rest),
            [b'@', b'V', rest @ ..] => {
                // The manual writes one space between `@V` and the text.
                let text = rest.strip_prefix(b" ").unwrap_or(rest);
                let text = std::str::from_utf8(text)
                    .map_err(|_| ReplyError::VersionByte(first_non_ascii(text)))?;
                VersionText::new(text).map(Reply::Version)
            }
            _ => Err(ReplyError::Unknown),
        }
    }

    /// Whether the interface sends this line on its own, not as an answer.
    pub fn is_unsolicited(&self) -> bool {
        matches!(self, Reply::Ready)
    }
}

fn first_non_ascii(bytes: &[u8]) -> u8 {
    bytes.iter().copied().find(|b| !b.is_ascii()).unwrap_or(0)
}

fn parse_position(rest: &[u8]) -> Result<Reply, ReplyError> {
    let (letter, number) = rest.split_first().ok_or(ReplyError::PositionAxis)?;
    let axis = EmcuAxis::from_upper(*letter).ok_or(ReplyError::PositionAxis)?;
    let digits = number.strip_prefix(b"-").unwrap_or(number);
    // Only digits after an optional minus: `str::parse` alone would take `+`.
    if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
        return Err(ReplyError::PositionNumber);
    }
    let steps = std::str::from_utf8(number)
        .ok()
        .and_then(|s| s.parse::<i32>().ok())
        .ok_or(ReplyError::PositionNumber)?;
    Ok(Reply::Position { axis, steps })
}

impl fmt::Display for Reply {
    /// The line as it crossed the wire, in `traffic::readable` form.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&readable(&self.encode()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn version_text_is_one_printable_line() {
        assert!(VersionText::new("SMC3000i 1.00").is_ok());
        for text in [
            "SMC3000i 1.00",
            "",
            "a\rb",
            "ä",
            &"v".repeat(VersionText::MAX_LEN + 1),
        ] {
            assert_eq!(
                VersionText::is_valid(text),
                VersionText::new(text).is_ok(),
                "{text:?}"
            );
        }
        assert_eq!(VersionText::new(""), Err(ReplyError::VersionEmpty));
        assert_eq!(
            VersionText::new("a\rb"),
            Err(ReplyError::VersionByte(b'\r'))
        );
        assert_eq!(VersionText::new("ä"), Err(ReplyError::VersionByte(0xC3)));
        assert!(VersionText::new(&"v".repeat(VersionText::MAX_LEN)).is_ok());
        assert!(VersionText::new(&"v".repeat(VersionText::MAX_LEN + 1)).is_err());
    }

    #[test]
    fn positions_take_an_optional_minus_only() {
        assert_eq!(
            Reply::parse_line(b"@LZ-0"),
            Ok(Reply::Position {
                axis: EmcuAxis::Z,
                steps: 0
            })
        );
        for bad in [
            &b"@LX+5"[..],
            b"@LX",
            b"@LX-",
            b"@Lx5",
            b"@LA5",
            b"@LX5 ",
            b"@LX99999999999",
            b"@L",
        ] {
            assert!(Reply::parse_line(bad).is_err(), "{}", readable(bad));
        }
        assert_eq!(
            Reply::parse_line(b"@LX-2147483648"),
            Ok(Reply::Position {
                axis: EmcuAxis::X,
                steps: i32::MIN
            })
        );
    }

    #[test]
    fn control_lines_are_one_byte() {
        assert_eq!(
            Reply::parse_line(&[READY, b'x']),
            Err(ReplyError::AfterControl(READY))
        );
        assert_eq!(Reply::parse_line(b"OK"), Err(ReplyError::Unknown));
        assert_eq!(Reply::parse_line(b"@Q"), Err(ReplyError::Unknown));
        assert_eq!(Reply::Ready.to_string(), "<02><CR>");
    }
}
