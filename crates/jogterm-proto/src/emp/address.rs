//! The DS byte: which drive on the link a frame is for or from.

use std::fmt;
use std::str::FromStr;

use super::error::RequestError;
use super::frame::hex_value;

/// Module (high nibble, 1-F) and drive on that module (low nibble, 1-6); EMP
/// manual "02 : Mehrere Baugruppen EIN": "D" is the module number 1 to F, "S"
/// the motor 1 to 6 on multi-axis units. A single drive is `11`; a link of
/// single-axis drives is `11`, `21`, … `F1`, up to 15 drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DriveAddress(u8);

impl DriveAddress {
    /// The address of a lone drive (manual: "Bei einer Anlage wird immer 0x11
    /// verwendet").
    pub const SINGLE: DriveAddress = DriveAddress(0x11);

    pub const MAX_MODULE: u8 = 0xF;
    pub const MAX_DRIVE: u8 = 6;

    pub fn new(module: u8, drive: u8) -> Result<DriveAddress, RequestError> {
        if (1..=Self::MAX_MODULE).contains(&module) && (1..=Self::MAX_DRIVE).contains(&drive) {
            Ok(DriveAddress(module << 4 | drive))
        } else {
            Err(RequestError::BadAddress {
                ds: (module & 0x0F) << 4 | (drive & 0x0F),
                reason: "module must be 1-F and drive 1-6",
            })
        }
    }

    /// Drive 1 of module `module` (1-15): the address of the `module`-th
    /// single-axis drive on a link.
    pub fn module(module: u8) -> Result<DriveAddress, RequestError> {
        DriveAddress::new(module, 1)
    }

    pub fn from_byte(ds: u8) -> Result<DriveAddress, RequestError> {
        let (module, drive) = (ds >> 4, ds & 0x0F);
        if module == 0 {
            Err(RequestError::BadAddress {
                ds,
                reason: "module number (high nibble) must be 1-F",
            })
        } else if drive == 0 || drive > Self::MAX_DRIVE {
            Err(RequestError::BadAddress {
                ds,
                reason: "drive number (low nibble) must be 1-6",
            })
        } else {
            Ok(DriveAddress(ds))
        }
    }

    pub const fn byte(self) -> u8 {
        self.0
    }

    pub const fn module_number(self) -> u8 {
        self.0 >> 4
    }

    pub const fn drive_number(self) -> u8 {
        self.0 & 0x0F
    }

    /// The addresses of a link of `count` single-axis drives: `11`, `21`, …
    pub fn link(count: u8) -> impl Iterator<Item = DriveAddress> {
        (1..=count.min(Self::MAX_MODULE)).map(|m| DriveAddress(m << 4 | 1))
    }
}

impl Default for DriveAddress {
    fn default() -> Self {
        DriveAddress::SINGLE
    }
}

impl fmt::Display for DriveAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02X}", self.0)
    }
}

/// Two upper-case hex digits as in the frame (`11`, `A1`).
impl FromStr for DriveAddress {
    type Err = RequestError;

    fn from_str(s: &str) -> Result<DriveAddress, RequestError> {
        let b = s.as_bytes();
        match (
            b.len(),
            b.first().copied().and_then(hex_value),
            b.get(1).copied().and_then(hex_value),
        ) {
            (2, Some(hi), Some(lo)) => DriveAddress::from_byte(hi << 4 | lo),
            _ => Err(RequestError::AddressText(s.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_drive_is_11_and_a_link_counts_modules() {
        assert_eq!(DriveAddress::SINGLE.byte(), 0x11);
        let link: Vec<u8> = DriveAddress::link(15).map(DriveAddress::byte).collect();
        assert_eq!(link.len(), 15);
        assert_eq!(link.first(), Some(&0x11));
        assert_eq!(link.last(), Some(&0xF1));
        assert_eq!(DriveAddress::link(20).count(), 15);
    }

    #[test]
    fn nibble_zero_and_drive_above_six_are_rejected() {
        for bad in [0x00, 0x01, 0x10, 0x17, 0x1F, 0x0F] {
            assert!(DriveAddress::from_byte(bad).is_err(), "{bad:02X}");
        }
        for good in [0x11, 0x16, 0xF1, 0x23] {
            assert_eq!(DriveAddress::from_byte(good).unwrap().byte(), good);
        }
        assert!(DriveAddress::new(16, 1).is_err());
        assert!(DriveAddress::new(2, 7).is_err());
        assert_eq!(DriveAddress::new(2, 3).unwrap().to_string(), "23");
    }

    #[test]
    fn parses_two_upper_case_digits() {
        assert_eq!("F1".parse::<DriveAddress>().unwrap().module_number(), 15);
        assert!("f1".parse::<DriveAddress>().is_err());
        assert!("1".parse::<DriveAddress>().is_err());
        assert!("111".parse::<DriveAddress>().is_err());
        assert!("ü1".parse::<DriveAddress>().is_err());
    }
}
