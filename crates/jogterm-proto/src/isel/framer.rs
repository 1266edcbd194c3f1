//! The controller's side of the line: cutting received bytes into command
//! lines and control bytes, for a simulator (or a test controller) that then
//! hands each line to [`parse_frame`](super::parse_frame) or
//! [`parse_cnc`](super::parse_cnc).
//!
//! Rules (`docs/protocols.md`, isel):
//! - A line ends with CR; an LF right after a CR is dropped (isel 1).
//! - 0xFD, 0xFE and 0xFF act at once, even between the bytes of a line
//!   (manual 2.2.31). 0xFD and 0xFF leave a partial line alone; 0xFE resets
//!   the controller, so the partial line is gone.
//! - A line longer than [`MAX_LINE`] bytes is reported as
//!   [`Received::Overlong`] when its CR arrives, so the controller answers
//!   once, at the same point it would answer any line.

use super::command::ControlByte;

/// Longest command line kept, without its CR. The longest valid command
/// (`@0w` with eight 8-digit numbers) has fewer than 90 bytes.
pub const MAX_LINE: usize = 256;

/// What the controller has received.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Received {
    /// A control byte, to be acted on at once.
    Control(ControlByte),
    /// A complete line without its CR.
    Line(Vec<u8>),
    /// A line longer than [`MAX_LINE`] ended; `len` bytes were dropped.
    Overlong { len: usize },
}

/// Splits the received byte stream into lines and control bytes.
#[derive(Debug, Clone, Default)]
pub struct RequestFramer {
    line: Vec<u8>,
    dropped: usize,
    after_cr: bool,
}

impl RequestFramer {
    pub fn new() -> RequestFramer {
        RequestFramer::default()
    }

    /// One byte has arrived.
    pub fn push(&mut self, byte: u8) -> Option<Received> {
        let after_cr = std::mem::take(&mut self.after_cr);
        if let Some(control) = ControlByte::from_byte(byte) {
            if control == ControlByte::Reset {
                self.line.clear();
                self.dropped = 0;
            } else {
                // The LF that may follow the CR is still to come.
                self.after_cr = after_cr;
            }
            return Some(Received::Control(control));
        }
        match byte {
            b'\n' if after_cr => None,
            b'\r' => {
                self.after_cr = true;
                let line = std::mem::take(&mut self.line);
                let dropped = std::mem::take(&mut self.dropped);
                Some(if dropped > 0 {
                    Received::Overlong {
                        len: dropped + line.len(),
                    }
                } else {
                    Received::Line(line)
                })
            }
            _ => {
                if self.line.len() >= MAX_LINE {
                    self.dropped += self.line.len();
                    self.line.clear();
                }
                self.line.push(byte);
                None
            }
        }
    }

    /// Several bytes have arrived.
    pub fn push_all(&mut self, bytes: &[u8]) -> Vec<Received> {
        bytes.iter().filter_map(|b| self.push(*b)).collect()
    }

    /// The bytes of the line received so far.
    pub fn partial(&self) -> &[u8] {
        &self.line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_end_with_cr_and_an_lf_after_it_is_dropped() {
        let mut f = RequestFramer::new();
        let got = f.push_all(b"@07\r\n@0P\r\n\n@0R7\r");
        assert_eq!(
            got,
            [
                Received::Line(b"@07".to_vec()),
                Received::Line(b"@0P".to_vec()),
                Received::Line(b"\n@0R7".to_vec()),
            ]
        );
    }

    #[test]
    fn control_bytes_act_between_the_bytes_of_a_line() {
        let mut f = RequestFramer::new();
        let got = f.push_all(b"@0A5\xfd000,900\r\xff\n@0P\xfe@0P\r");
        assert_eq!(
            got,
            [
                Received::Control(ControlByte::SoftStop),
                Received::Line(b"@0A5000,900".to_vec()),
                Received::Control(ControlByte::Break),
                Received::Control(ControlByte::Reset),
                Received::Line(b"@0P".to_vec()),
            ]
        );
    }

    #[test]
    fn overlong_lines_are_reported_once_at_their_cr() {
        let mut f = RequestFramer::new();
        let mut bytes = vec![b'1'; 600];
        bytes.push(b'\r');
        bytes.extend_from_slice(b"@0P\r");
        assert_eq!(
            f.push_all(&bytes),
            [
                Received::Overlong { len: 600 },
                Received::Line(b"@0P".to_vec())
            ]
        );
        assert!(f.partial().is_empty());
    }
}
