//! Digital I/O of a drive: limit and reference switches, inputs I1-I4,
//! outputs O1-O4 (EMP manual "40 : I/O Read", "42 : I/O Write";
//! `docs/decisions.md` EMP decision 5).

use std::fmt;

use super::error::ValueError;

/// The switch bits in PROP of the `41` and `43` replies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Limits {
    pub plus: bool,
    pub minus: bool,
    pub reference: bool,
}

impl Limits {
    pub const fn byte(self) -> u8 {
        self.plus as u8 | (self.minus as u8) << 1 | (self.reference as u8) << 2
    }

    /// Bits above bit 2 carry nothing documented and are ignored.
    pub const fn from_byte(b: u8) -> Limits {
        Limits {
            plus: b & 1 != 0,
            minus: b & 2 != 0,
            reference: b & 4 != 0,
        }
    }
}

impl fmt::Display for Limits {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let on = |b: bool| if b { "on" } else { "off" };
        write!(
            f,
            "limit+ {} limit- {} ref {}",
            on(self.plus),
            on(self.minus),
            on(self.reference)
        )
    }
}

/// Four digital lines, bit 0 = line 1 … bit 3 = line 4; `true` = 24 V.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Lines(u8);

/// Inputs I1-I4 (D0 low nibble of the `41` reply).
pub type Inputs = Lines;
/// Outputs O1-O4 (D1/D0 of `42` and its `43` reply).
pub type Outputs = Lines;

impl Lines {
    pub const NONE: Lines = Lines(0);

    /// Bits 0-3; higher bits are dropped.
    pub const fn from_bits(bits: u8) -> Lines {
        Lines(bits & 0x0F)
    }

    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Line `n` (1-4); any other number reads as off.
    pub fn get(self, n: u8) -> bool {
        (1..=4).contains(&n) && self.0 & (1 << (n - 1)) != 0
    }

    /// Line `n` (1-4) set to `on`; other numbers leave the lines unchanged.
    pub fn with(self, n: u8, on: bool) -> Lines {
        if !(1..=4).contains(&n) {
            return self;
        }
        let bit = 1 << (n - 1);
        Lines(if on { self.0 | bit } else { self.0 & !bit })
    }

    /// D1, D0 of `42 DS 01`: one nibble per output, 0 or 1, D1 = O4 O3 and
    /// D0 = O2 O1 (decision 5).
    pub fn output_bytes(self) -> [u8; 2] {
        let nib = |n| u8::from(self.get(n));
        [nib(4) << 4 | nib(3), nib(2) << 4 | nib(1)]
    }

    /// Read D1, D0 of `42` / `43`. Each nibble must be 0 or 1.
    pub fn from_output_bytes(d1: u8, d0: u8) -> Result<Lines, ValueError> {
        let nibbles = [(d0 & 0x0F, 1), (d0 >> 4, 2), (d1 & 0x0F, 3), (d1 >> 4, 4)];
        let mut lines = Lines::NONE;
        for (value, n) in nibbles {
            match value {
                0 => {}
                1 => lines = lines.with(n, true),
                _ => {
                    return Err(ValueError::BadByte {
                        field: "output",
                        value: if n > 2 { d1 } else { d0 },
                        expected: "one nibble per output, each 0 or 1 (D1 = O4 O3, D0 = O2 O1)",
                    });
                }
            }
        }
        Ok(lines)
    }
}

/// `1010` style, line 4 first as the manual's "I4 I3 I2 I1".
impl fmt::Display for Lines {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04b}", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_are_one_nibble_each_as_decision_5() {
        let o = Lines::NONE.with(1, true).with(4, true);
        assert_eq!(o.output_bytes(), [0x10, 0x01]);
        assert_eq!(Lines::from_bits(0x0F).output_bytes(), [0x11, 0x11]);
        assert_eq!(Lines::from_output_bytes(0x10, 0x01).unwrap(), o);
        assert!(Lines::from_output_bytes(0x02, 0x00).is_err());
        assert!(Lines::from_output_bytes(0x00, 0xF0).is_err());
        assert_eq!(o.to_string(), "1001");
    }

    #[test]
    fn limit_bits_are_plus_minus_reference() {
        let l = Limits::from_byte(0b1111_1101);
        assert!(l.plus && !l.minus && l.reference);
        assert_eq!(l.byte(), 0b101);
    }

    #[test]
    fn line_numbers_outside_1_to_4_are_ignored() {
        assert!(!Lines::from_bits(0x0F).get(0));
        assert!(!Lines::from_bits(0x0F).get(5));
        assert_eq!(Lines::NONE.with(9, true), Lines::NONE);
    }
}
