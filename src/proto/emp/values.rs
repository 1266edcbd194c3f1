//! Positions and velocities as EMP frames carry them (EMP manual,
//! "Wertebereiche der Encoder und Geschwindigkeitsangaben").

use std::fmt;

use super::error::ValueError;

/// A position in encoder increments: 25-bit two's complement in D3..D0, D3 bit0
/// being the sign bit (`docs/decisions.md` EMP decision 3: `01FFFFFF` = -1,
/// `000186A0` = 100000). The manual's range table: `00.00.00.01h` …
/// `00.FF.FF.FFh` forward (RL), `01.00.00.00h` … `01.FF.FF.FFh` backward (LL).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Position(i32);

impl Position {
    pub const ZERO: Position = Position(0);
    pub const MIN: Position = Position(-(1 << 24));
    pub const MAX: Position = Position((1 << 24) - 1);

    const MASK: u32 = (1 << 25) - 1;

    pub fn new(increments: i64) -> Result<Position, ValueError> {
        if (i64::from(Self::MIN.0)..=i64::from(Self::MAX.0)).contains(&increments) {
            // In range, so it fits an i32.
            Ok(Position(increments as i32))
        } else {
            Err(ValueError::OutOfRange {
                field: "position",
                value: increments,
                expected: "-16777216..=16777215 (25-bit)",
            })
        }
    }

    pub const fn increments(self) -> i32 {
        self.0
    }

    /// D3..D0 as a big-endian word.
    pub const fn to_word(self) -> u32 {
        (self.0 as u32) & Self::MASK
    }

    pub const fn to_bytes(self) -> [u8; 4] {
        self.to_word().to_be_bytes()
    }

    /// Read D3..D0. Bits above the sign bit must be clear: a drive never sends
    /// them, so a set one means the frame is not what it claims to be.
    pub fn from_word(word: u32) -> Result<Position, ValueError> {
        if word & !Self::MASK != 0 {
            return Err(ValueError::PositionBits(word));
        }
        // Sign-extend bit 24: shift it into bit 31, then arithmetic shift back.
        Ok(Position(((word << 7) as i32) >> 7))
    }

    pub fn from_bytes(bytes: [u8; 4]) -> Result<Position, ValueError> {
        Position::from_word(u32::from_be_bytes(bytes))
    }
}

impl fmt::Display for Position {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// A signed velocity (or torque in PWM modes) byte of `2A`: 8-bit two's
/// complement, `01`-`7F` forward (RL), `80`-`FF` backward (LL), `00` stop.
/// `docs/decisions.md` EMP decision 4 (`FE` = -2); the manual's sentence
/// "vLL = 255 - vRL" contradicts its own examples and is not followed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Velocity(i8);

impl Velocity {
    pub const STOP: Velocity = Velocity(0);

    pub const fn new(value: i8) -> Velocity {
        Velocity(value)
    }

    pub const fn from_byte(byte: u8) -> Velocity {
        Velocity(byte as i8)
    }

    pub const fn byte(self) -> u8 {
        self.0 as u8
    }

    pub const fn value(self) -> i8 {
        self.0
    }

    pub const fn is_stop(self) -> bool {
        self.0 == 0
    }
}

impl fmt::Display for Velocity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:+}", self.0)
    }
}

/// An unsigned speed byte, 1-127: Vmax of `2A 01`, Vfast and Vslow of `26`.
/// The direction of these moves comes from the target or the setup, so only
/// the forward half of the velocity range applies; 0 would never arrive and
/// leave the request busy for ever.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Speed(u8);

impl Speed {
    pub const MIN: Speed = Speed(1);
    pub const MAX: Speed = Speed(0x7F);

    pub fn new(value: u8) -> Result<Speed, ValueError> {
        if (Self::MIN.0..=Self::MAX.0).contains(&value) {
            Ok(Speed(value))
        } else {
            Err(ValueError::OutOfRange {
                field: "speed",
                value: i64::from(value),
                expected: "1..=127 (01-7F)",
            })
        }
    }

    pub const fn value(self) -> u8 {
        self.0
    }
}

impl fmt::Display for Speed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_follow_decision_3() {
        assert_eq!(Position::from_word(0x01FF_FFFF).unwrap().increments(), -1);
        assert_eq!(
            Position::from_word(0x0001_86A0).unwrap().increments(),
            100_000
        );
        assert_eq!(Position::new(-1).unwrap().to_word(), 0x01FF_FFFF);
        assert_eq!(
            Position::new(100_000).unwrap().to_bytes(),
            [0x00, 0x01, 0x86, 0xA0]
        );
        // The manual's range table: the ends of both directions.
        assert_eq!(Position::from_word(0x00FF_FFFF).unwrap(), Position::MAX);
        assert_eq!(Position::from_word(0x0100_0000).unwrap(), Position::MIN);
        assert_eq!(Position::from_word(0x0000_0001).unwrap().increments(), 1);
        // Beispiel 4: 500 mm = 100.000d = 186A0h, 200 mm = 40.000d = 9C40h.
        assert_eq!(Position::new(40_000).unwrap().to_word(), 0x9C40);
    }

    #[test]
    fn positions_outside_25_bits_are_rejected() {
        assert!(Position::new(16_777_216).is_err());
        assert!(Position::new(-16_777_217).is_err());
        assert_eq!(
            Position::from_word(0x0200_0000),
            Err(ValueError::PositionBits(0x0200_0000))
        );
        assert!(Position::from_word(0xFFFF_FFFF).is_err());
    }

    #[test]
    fn velocity_bytes_follow_decision_4() {
        assert_eq!(Velocity::from_byte(0xFE).value(), -2);
        assert_eq!(Velocity::from_byte(0xFB).value(), -5);
        assert_eq!(Velocity::from_byte(0xF0).value(), -16);
        assert_eq!(Velocity::from_byte(0xFF).value(), -1);
        assert_eq!(Velocity::from_byte(0x7F).value(), 127);
        assert_eq!(Velocity::from_byte(0x80).value(), -128);
        assert_eq!(Velocity::new(-2).byte(), 0xFE);
        assert_eq!(Velocity::new(-2).to_string(), "-2");
    }

    #[test]
    fn speeds_are_1_to_127() {
        assert!(Speed::new(0).is_err());
        assert!(Speed::new(0x80).is_err());
        assert_eq!(Speed::new(0x7F).unwrap(), Speed::MAX);
    }
}
