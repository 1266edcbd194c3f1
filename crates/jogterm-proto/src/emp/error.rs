//! Error types of the EMP core, one per level (docs/architecture.md, "Errors"):
//! framing faults on the byte stream, values out of range, requests that are not
//! valid EMP, and replies that do not fit the request they answer. What a drive
//! *answers* (INFO `EE`, an error code from `0A`) is not an error here but a
//! typed [`Reply`](super::Reply).

use thiserror::Error;

use crate::text::readable;

/// Bytes kept for a framing report; a longer run is reported in pieces so the
/// decoder's memory stays bounded whatever arrives.
pub const MAX_REPORTED_BYTES: usize = 64;

/// What was wrong with a run of characters between two EOFs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FrameFault {
    /// Fewer or more than 16 characters before the EOF. Fewer is the case of an
    /// EOF in the middle of a frame.
    WrongLength { chars: usize },
    /// A lower-case hex digit; the manual allows only `0-9` and `A-F`.
    LowerCase { at: usize },
    /// A character that is no hex digit at all.
    NotHex { at: usize, byte: u8 },
    /// No EOF within [`MAX_REPORTED_BYTES`] bytes, or before the decoder was
    /// reset: these bytes are dropped, and after an overflow everything up to
    /// the next EOF too.
    NoEof { chars: usize },
    /// The EOF that ends a run reported as [`FrameFault::NoEof`], with the
    /// bytes dropped since that report.
    LongRunEnd { chars: usize },
}

impl std::fmt::Display for FrameFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            FrameFault::WrongLength { chars } if chars < super::FRAME_HEX_LEN => {
                write!(f, "EOF after {chars} of 16 characters: frame cut short")
            }
            FrameFault::WrongLength { chars } => {
                write!(f, "{chars} characters before EOF, a frame has 16")
            }
            FrameFault::LowerCase { at } => write!(
                f,
                "lower-case hex digit at character {} (only 0-9 and A-F are valid)",
                at + 1
            ),
            FrameFault::NotHex { at, byte } => write!(
                f,
                "`{}` at character {} is not a hex digit",
                readable(&[byte]),
                at + 1
            ),
            FrameFault::NoEof { chars } => write!(f, "no EOF after {chars} characters"),
            FrameFault::LongRunEnd { chars } => {
                write!(f, "EOF ends an over-long run, {chars} more characters")
            }
        }
    }
}

/// A framing fault with the bytes it concerns (the ones the decoder dropped,
/// including the EOF that ended them), shown with [`readable`].
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("EMP framing: {fault}; dropped `{}`", readable(&self.bytes))]
pub struct FrameError {
    pub fault: FrameFault,
    /// The dropped bytes, at most [`MAX_REPORTED_BYTES`] + 1.
    pub bytes: Vec<u8>,
}

impl FrameError {
    pub(crate) fn new(fault: FrameFault, bytes: &[u8]) -> FrameError {
        FrameError {
            fault,
            bytes: bytes.to_vec(),
        }
    }
}

/// A value that does not fit its field.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ValueError {
    #[error("{field} {value} is out of range: expected {expected}")]
    OutOfRange {
        field: &'static str,
        value: i64,
        expected: &'static str,
    },
    #[error("{field} byte {value:02X} is not valid: expected {expected}")]
    BadByte {
        field: &'static str,
        value: u8,
        expected: &'static str,
    },
    #[error("position bytes {0:08X} set bits above the 25-bit sign bit (D3 may only be 00 or 01)")]
    PositionBits(u32),
    #[error("{field} byte {value:02X} is not a BCD number (two decimal digits)")]
    NotBcd { field: &'static str, value: u8 },
    #[error("day {day} does not exist in month {month} of year {year}")]
    NoSuchDay { year: u16, month: u8, day: u8 },
    #[error("identity text must be 16 printable ASCII characters starting with `DRS-`, got `{}`", readable(.0))]
    IdentText(Vec<u8>),
}

/// A frame that is not a valid EMP request. The `send` command shows these
/// before anything goes on the wire; the simulator answers them with INFO `EE`
/// and the matching [`ErrorCode`](super::ErrorCode).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum RequestError {
    #[error("{cmd:02X} is a reply code (odd), not a request")]
    NotARequest { cmd: u8 },
    #[error("{cmd:02X} is not an EMP command")]
    UnknownCommand { cmd: u8 },
    #[error("{cmd:02X} has no sub-code {prop:02X}")]
    UnknownSubCode { cmd: u8, prop: u8 },
    #[error("DS {ds:02X}: {reason}")]
    BadAddress { ds: u8, reason: &'static str },
    #[error("`{0}` is not a drive address: two upper-case hex digits such as 11 or 21")]
    AddressText(String),
    #[error("{cmd:02X}: {field} must be 00 (unused), got {value:02X}")]
    UnusedNotZero {
        cmd: u8,
        field: &'static str,
        value: u8,
    },
    #[error("{cmd:02X}: {source}")]
    BadValue {
        cmd: u8,
        #[source]
        source: ValueError,
    },
}

/// A reply frame that does not fit the request it is matched with.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ReplyError {
    #[error("reply code {got:02X} does not answer request {request:02X} (expected {:02X})", .request.wrapping_add(1))]
    WrongCode { request: u8, got: u8 },
    #[error("reply from DS {got:02X} does not answer a request to {expected:02X}")]
    WrongDrive { expected: u8, got: u8 },
    #[error("INFO byte {0:02X} is none of 22 (ready), 55 (busy), EE (rejected)")]
    UnknownInfo(u8),
    #[error("identity text answers only `00`, not request {0:02X}")]
    UnexpectedText(u8),
    #[error("`00` is answered by an identity text, got frame {0}")]
    ExpectedText(super::Frame),
    #[error("reply {cmd:02X}: {source}")]
    BadValue {
        cmd: u8,
        #[source]
        source: ValueError,
    },
}

/// A feed rate or sample rate that the drive's 16-bit reload value cannot
/// express, or mechanics that make no sense.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ConversionError {
    #[error("{what} must be a finite number above zero, got {value}")]
    NotPositive { what: &'static str, value: f64 },
    #[error("feed must be finite and not zero (stop with velocity 00), got {0}")]
    ZeroFeed(f64),
    #[error(
        "reload value {value:.1} is outside 1..=65535: {}",
        if *.value < 1.0 { "too fast for the drive" } else { "too slow for a 16-bit reload value" }
    )]
    ReloadRange { value: f64 },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_errors_show_the_dropped_bytes_readably() {
        let e = FrameError::new(FrameFault::WrongLength { chars: 5 }, b"02111\x1a");
        assert_eq!(
            e.to_string(),
            "EMP framing: EOF after 5 of 16 characters: frame cut short; dropped `02111<EOF>`"
        );
        let e = FrameError::new(FrameFault::NotHex { at: 0, byte: 0xFF }, b"\xff\x1a");
        assert!(e.to_string().contains("`<FF>` at character 1"));
        let e = FrameError::new(FrameFault::LongRunEnd { chars: 3 }, b"012\x1a");
        assert!(
            e.to_string()
                .contains("3 more characters; dropped `012<EOF>`")
        );
    }
}
