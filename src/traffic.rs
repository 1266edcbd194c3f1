//! Bytes as they crossed the line, for the traffic console, the `--log` file and
//! error messages. Readable form: printable ASCII as itself, everything else as
//! `<CR>`, `<LF>`, `<EOF>` or a hex byte such as `<FD>`, so a control byte is
//! never mistaken for text and never garbles a terminal.

use std::fmt::Write as _;
use std::time::SystemTime;

use serde::Serialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Direction {
    /// From jogterm to the controller.
    Sent,
    /// From the controller to jogterm.
    Received,
}

impl Direction {
    pub fn arrow(self) -> &'static str {
        match self {
            Direction::Sent => ">>",
            Direction::Received => "<<",
        }
    }
}

/// One chunk of bytes as it was written to or read from the port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TrafficRecord {
    pub at: SystemTime,
    pub direction: Direction,
    pub bytes: Vec<u8>,
}

impl TrafficRecord {
    pub fn new(direction: Direction, bytes: impl Into<Vec<u8>>) -> Self {
        Self {
            at: SystemTime::now(),
            direction,
            bytes: bytes.into(),
        }
    }

    /// `>> @0P<CR>` style, without a timestamp.
    pub fn readable(&self) -> String {
        format!("{} {}", self.direction.arrow(), readable(&self.bytes))
    }
}

/// Render bytes so that every byte is visible and none acts on a terminal.
pub fn readable(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len() + 8);
    for &b in bytes {
        match b {
            b'\r' => out.push_str("<CR>"),
            b'\n' => out.push_str("<LF>"),
            0x1A => out.push_str("<EOF>"),
            b'<' => out.push_str("<3C>"),
            0x20..=0x7E => out.push(b as char),
            _ => {
                let _ = write!(out, "<{b:02X}>");
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_bytes_show_as_hex_and_text_as_text() {
        assert_eq!(readable(b"@0P\r"), "@0P<CR>");
        assert_eq!(readable(&[0xFD, 0xFF]), "<FD><FF>");
        assert_eq!(readable(b"0211110000000000\x1a"), "0211110000000000<EOF>");
        assert_eq!(readable(b"\x02\r"), "<02><CR>");
        // A literal `<` must not be confused with the start of a hex escape.
        assert_eq!(readable(b"a<b"), "a<3C>b");
    }
}
