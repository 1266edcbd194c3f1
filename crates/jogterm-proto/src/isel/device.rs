//! The device number that addresses one controller on the line (`@<GN>`).

use std::fmt;

/// A device number `0`–`9`, the digit after `@` in every DNC frame
/// (isel manual 2.1, 2.2.11). The value is private, so a `DeviceNumber` can
/// never hold anything but a single decimal digit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct DeviceNumber(u8);

impl DeviceNumber {
    /// The factory default, `@0`.
    pub const DEFAULT: DeviceNumber = DeviceNumber(0);

    /// `Some` for 0–9, `None` for anything else.
    pub const fn new(number: u8) -> Option<DeviceNumber> {
        if number <= 9 {
            Some(DeviceNumber(number))
        } else {
            None
        }
    }

    /// The device number an ASCII digit names (`b'0'`–`b'9'`).
    pub fn from_ascii(byte: u8) -> Option<DeviceNumber> {
        if byte.is_ascii_digit() {
            Some(DeviceNumber(byte - b'0'))
        } else {
            None
        }
    }

    pub const fn get(self) -> u8 {
        self.0
    }

    /// The ASCII digit sent on the wire.
    pub const fn ascii(self) -> u8 {
        b'0' + self.0
    }
}

impl TryFrom<u8> for DeviceNumber {
    type Error = u8;

    /// Fails with the rejected number.
    fn try_from(number: u8) -> Result<Self, Self::Error> {
        DeviceNumber::new(number).ok_or(number)
    }
}

impl fmt::Display for DeviceNumber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_single_digits_are_device_numbers() {
        assert_eq!(DeviceNumber::new(9).map(DeviceNumber::ascii), Some(b'9'));
        assert_eq!(DeviceNumber::new(10), None);
        assert_eq!(
            DeviceNumber::from_ascii(b'3').map(DeviceNumber::get),
            Some(3)
        );
        assert_eq!(DeviceNumber::from_ascii(b'a'), None);
        assert_eq!(DeviceNumber::try_from(200), Err(200));
    }
}
