//! The text a drive sends instead of a hex frame when asked `00` (program
//! version and device number).
//!
//! EMP manual "00 : Programm-Version und Gerätenummer" shows the reply as the
//! eight character pairs `DR S- 50 0- EC _V xx .x`: 16 ASCII characters, not
//! hex, then EOF like every frame. They carry no CMD and no DS.

use std::fmt;

use super::error::ValueError;
use super::frame::{EOF, FRAME_HEX_LEN, FRAME_WIRE_LEN};

/// Every identity text starts with the device family. `R`, `S` and `-` are no
/// hex digits, so no hex frame can start like this and the decoder can tell the
/// two apart without knowing what was asked.
pub const IDENT_PREFIX: &[u8; 4] = b"DRS-";

/// The fixed part of the drive's identity texts (docs/protocols.md, EMP).
pub const IDENT_MODEL: &str = "DRS-500-EC_";

/// 16 printable ASCII characters starting with `DRS-`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct IdentText([u8; FRAME_HEX_LEN]);

impl IdentText {
    pub fn new(text: &[u8]) -> Result<IdentText, ValueError> {
        let bytes: [u8; FRAME_HEX_LEN] = text
            .try_into()
            .map_err(|_| ValueError::IdentText(text.to_vec()))?;
        if !text.starts_with(IDENT_PREFIX) || !text.iter().all(|b| (0x20..=0x7E).contains(b)) {
            return Err(ValueError::IdentText(text.to_vec()));
        }
        Ok(IdentText(bytes))
    }

    /// The version text a drive answers to `00 DS 00`: `DRS-500-EC_V08.2` for
    /// version 8.2 (manual: "DRS-500-ECS_V8.2"). `major` 0-99, `minor` 0-9.
    pub fn version(major: u8, minor: u8) -> Result<IdentText, ValueError> {
        if major > 99 || minor > 9 {
            return Err(ValueError::OutOfRange {
                field: "version",
                value: i64::from(major) * 10 + i64::from(minor),
                expected: "0.0 to 99.9",
            });
        }
        IdentText::new(format!("{IDENT_MODEL}V{major:02}.{minor}").as_bytes())
    }

    /// The text a drive answers to `00 DS 01`: `DRS-500-EC_N0650` for device
    /// number 650 (docs/protocols.md, EMP: the manual prints the version template
    /// for both queries).
    pub fn device_number(number: u16) -> Result<IdentText, ValueError> {
        if number > 9999 {
            return Err(ValueError::OutOfRange {
                field: "device number",
                value: i64::from(number),
                expected: "0..=9999",
            });
        }
        IdentText::new(format!("{IDENT_MODEL}N{number:04}").as_bytes())
    }

    pub fn as_bytes(&self) -> &[u8; FRAME_HEX_LEN] {
        &self.0
    }

    pub fn as_str(&self) -> &str {
        // Only printable ASCII is ever stored.
        std::str::from_utf8(&self.0).unwrap_or("")
    }

    /// The version after `_V` (`08.2`), if the text has that form.
    pub fn version_text(&self) -> Option<&str> {
        self.field_after('V')
    }

    /// The device number after `_N`, if the text has that form.
    pub fn device_number_value(&self) -> Option<u16> {
        self.field_after('N').and_then(|n| n.parse().ok())
    }

    fn field_after(&self, tag: char) -> Option<&str> {
        let s = self.as_str();
        let at = s.rfind('_')?;
        s.get(at + 1..)?.strip_prefix(tag)
    }

    /// The text and EOF as they go on the wire.
    pub fn encode(&self) -> [u8; FRAME_WIRE_LEN] {
        let mut out = [EOF; FRAME_WIRE_LEN];
        out[..FRAME_HEX_LEN].copy_from_slice(&self.0);
        out
    }
}

impl fmt::Display for IdentText {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn version_and_device_number_fill_the_manual_template() {
        let v = IdentText::version(8, 2).unwrap();
        assert_eq!(v.as_str(), "DRS-500-EC_V08.2");
        assert_eq!(v.version_text(), Some("08.2"));
        assert_eq!(v.device_number_value(), None);
        let n = IdentText::device_number(650).unwrap();
        assert_eq!(&n.encode(), b"DRS-500-EC_N0650\x1a");
        assert_eq!(n.device_number_value(), Some(650));
        assert!(IdentText::version(100, 0).is_err());
        assert!(IdentText::device_number(10_000).is_err());
    }

    #[test]
    fn only_sixteen_printable_characters_after_the_prefix_are_text() {
        assert!(IdentText::new(b"DRS-500-EC_V08.").is_err());
        assert!(IdentText::new(b"DRS-500-EC_V08.22").is_err());
        assert!(IdentText::new(b"XRS-500-EC_V08.2").is_err());
        assert!(IdentText::new(b"DRS-500-EC_V08\x002").is_err());
        assert!(IdentText::new(b"DRS-anything-ok!").is_ok());
    }
}
