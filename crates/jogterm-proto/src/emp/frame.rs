//! The EMP frame: eight bytes CMD DS PROP INFO D3 D2 D1 D0, written as 16
//! upper-case hex characters and ended by EOF 0x1A (EMP manual, "Easy Motion
//! Protocol", "Aufbau der Datenstrings").

use std::fmt;
use std::str::FromStr;

use super::error::FrameError;

/// The end-of-frame byte, CHR(26).
pub const EOF: u8 = 0x1A;

/// Hex characters in a frame before its EOF.
pub const FRAME_HEX_LEN: usize = 16;

/// Bytes a frame occupies on the wire: 16 hex characters and the EOF.
pub const FRAME_WIRE_LEN: usize = FRAME_HEX_LEN + 1;

const HEX_DIGITS: &[u8; 16] = b"0123456789ABCDEF";

/// One frame as its eight raw bytes. Requests have an even CMD, replies CMD+1.
///
/// `data` holds D3, D2, D1, D0 in wire order (D3 first), so a 32-bit value such
/// as a position reads big-endian from it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Frame {
    pub cmd: u8,
    pub ds: u8,
    pub prop: u8,
    pub info: u8,
    pub data: [u8; 4],
}

impl Frame {
    pub const fn new(cmd: u8, ds: u8, prop: u8, info: u8, data: [u8; 4]) -> Frame {
        Frame {
            cmd,
            ds,
            prop,
            info,
            data,
        }
    }

    pub const fn from_bytes(b: [u8; 8]) -> Frame {
        Frame::new(b[0], b[1], b[2], b[3], [b[4], b[5], b[6], b[7]])
    }

    pub const fn to_bytes(&self) -> [u8; 8] {
        let d = self.data;
        [
            self.cmd, self.ds, self.prop, self.info, d[0], d[1], d[2], d[3],
        ]
    }

    pub const fn d3(&self) -> u8 {
        self.data[0]
    }

    pub const fn d2(&self) -> u8 {
        self.data[1]
    }

    pub const fn d1(&self) -> u8 {
        self.data[2]
    }

    pub const fn d0(&self) -> u8 {
        self.data[3]
    }

    /// D3..D0 as one big-endian word.
    pub const fn data_word(&self) -> u32 {
        u32::from_be_bytes(self.data)
    }

    /// Odd CMD bytes are replies of the drive, even ones requests of the host
    /// (manual: "Gerade Zahlen sind die Kommandos des PC's/SPS, ungerade Zahlen
    /// sind Antworten des Systems").
    pub const fn is_reply(&self) -> bool {
        self.cmd & 1 == 1
    }

    /// The 16 upper-case hex characters, without EOF.
    pub fn hex(&self) -> [u8; FRAME_HEX_LEN] {
        let mut out = [0u8; FRAME_HEX_LEN];
        for (i, b) in self.to_bytes().into_iter().enumerate() {
            out[2 * i] = HEX_DIGITS[usize::from(b >> 4)];
            out[2 * i + 1] = HEX_DIGITS[usize::from(b & 0x0F)];
        }
        out
    }

    /// The frame as it goes on the wire: 16 hex characters and EOF.
    pub fn encode(&self) -> [u8; FRAME_WIRE_LEN] {
        let mut out = [EOF; FRAME_WIRE_LEN];
        out[..FRAME_HEX_LEN].copy_from_slice(&self.hex());
        out
    }

    /// Parse exactly 16 upper-case hex characters (no EOF). This is the
    /// decoder's check for one run of characters between two EOFs.
    pub fn from_hex(hex: &[u8]) -> Result<Frame, FrameError> {
        check_hex_run(hex)?;
        let mut bytes = [0u8; 8];
        for (byte, pair) in bytes.iter_mut().zip(hex.chunks_exact(2)) {
            // check_hex_run has proved every character a digit, so these are
            // `Some`; the fallback keeps this free of panics all the same.
            if let [hi, lo] = *pair {
                *byte = hex_value(hi).unwrap_or(0) << 4 | hex_value(lo).unwrap_or(0);
            }
        }
        Ok(Frame::from_bytes(bytes))
    }
}

/// The frame's 16 hex characters.
impl fmt::Display for Frame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let hex = self.hex();
        // Hex digits are ASCII, so this cannot fail; `map_err` avoids a panic path.
        f.write_str(std::str::from_utf8(&hex).map_err(|_| fmt::Error)?)
    }
}

/// Typed text for the `send` command line: 16 upper-case hex characters, with
/// optional whitespace anywhere (`2A 11 01 01 00 01 86 A0`) and an optional
/// trailing EOF. Lower case is rejected as on the wire.
impl FromStr for Frame {
    type Err = FrameError;

    fn from_str(s: &str) -> Result<Frame, FrameError> {
        let mut hex: Vec<u8> = s.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
        if hex.last() == Some(&EOF) {
            hex.pop();
        }
        Frame::from_hex(&hex)
    }
}

/// The value of one upper-case hex digit; lower case is not a digit here
/// (manual: "Gültige Zeichen ... Ziffern von 0-9 und Großbuchstaben von A-F").
pub(crate) fn hex_value(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'A'..=b'F' => Some(c - b'A' + 10),
        _ => None,
    }
}

/// Check one run of characters (without EOF) for being a frame: every
/// character an upper-case hex digit, and exactly 16 of them. Character faults
/// are reported before the length, so `021111000000000g` says "lower case".
pub(crate) fn check_hex_run(run: &[u8]) -> Result<(), FrameError> {
    use super::error::FrameFault;
    if let Some((at, &byte)) = run
        .iter()
        .enumerate()
        .find(|(_, b)| hex_value(**b).is_none())
    {
        let fault = if matches!(byte, b'a'..=b'f') {
            FrameFault::LowerCase { at }
        } else {
            FrameFault::NotHex { at, byte }
        };
        return Err(FrameError::new(fault, run));
    }
    if run.len() != FRAME_HEX_LEN {
        return Err(FrameError::new(
            FrameFault::WrongLength { chars: run.len() },
            run,
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::error::FrameFault;
    use super::*;

    #[test]
    fn encodes_sixteen_upper_case_digits_and_eof() {
        let f = Frame::new(0x2A, 0x11, 0x00, 0x01, [0x00, 0x01, 0x86, 0xA0]);
        assert_eq!(&f.encode(), b"2A110001000186A0\x1a");
        assert_eq!(f.to_string(), "2A110001000186A0");
        assert_eq!(f.data_word(), 100_000);
        assert!(!f.is_reply());
    }

    #[test]
    fn parses_typed_text_with_spaces_and_optional_eof() {
        let f: Frame = "2A 11 00 01 00 01 86 A0".parse().unwrap();
        assert_eq!(f.to_bytes(), [0x2A, 0x11, 0, 1, 0, 1, 0x86, 0xA0]);
        let g: Frame = "2C11000000000000\x1a".parse().unwrap();
        assert_eq!(g.cmd, 0x2C);
    }

    #[test]
    fn rejects_lower_case_non_hex_and_wrong_lengths() {
        let e = "2a11000000000000".parse::<Frame>().unwrap_err();
        assert_eq!(e.fault, FrameFault::LowerCase { at: 1 });
        let e = "2C1100000000000G".parse::<Frame>().unwrap_err();
        assert_eq!(e.fault, FrameFault::NotHex { at: 15, byte: b'G' });
        let e = "2C1100000000000".parse::<Frame>().unwrap_err();
        assert_eq!(e.fault, FrameFault::WrongLength { chars: 15 });
        let e = "2C110000000000000".parse::<Frame>().unwrap_err();
        assert_eq!(e.fault, FrameFault::WrongLength { chars: 17 });
    }
}
