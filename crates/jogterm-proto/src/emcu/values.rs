//! Validated parameter values of EMCU commands. The manual gives placeholders
//! (`#Saaaa`, `L1,abbbbbb`, `Waaaa`) but no ranges; the ranges below are
//! jogterm's reading of them (`docs/protocols.md`, EMCU). Every value type can
//! only hold a value the interface accepts, so an encoded command is always
//! well formed.

use std::fmt;

use thiserror::Error;

use crate::axis::Axis;

/// A parameter that breaks one of the EMCU rules.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ValueError {
    #[error("{what} {value} is out of range {min}..={max}")]
    OutOfRange {
        what: &'static str,
        value: i64,
        min: i64,
        max: i64,
    },
    #[error("axis {0} does not exist on the EMCU (X, Y and Z only)")]
    NotEmcuAxis(Axis),
    #[error("axis {0} is given more than once")]
    RepeatedAxis(Axis),
    #[error("no axis given: at least one of X, Y, Z is needed")]
    NoAxes,
}

fn check_range(what: &'static str, value: i64, min: i64, max: i64) -> Result<(), ValueError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(ValueError::OutOfRange {
            what,
            value,
            min,
            max,
        })
    }
}

/// One of the three EMCU axes. Wraps the shared [`Axis`] and refuses `A`,
/// which the SMC3000 interface does not have (manual 1.5.4, 1.5.9, 1.5.10).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct EmcuAxis(Axis);

impl EmcuAxis {
    pub const X: EmcuAxis = EmcuAxis(Axis::X);
    pub const Y: EmcuAxis = EmcuAxis(Axis::Y);
    pub const Z: EmcuAxis = EmcuAxis(Axis::Z);
    pub const ALL: [EmcuAxis; 3] = [EmcuAxis::X, EmcuAxis::Y, EmcuAxis::Z];

    pub fn new(axis: Axis) -> Result<EmcuAxis, ValueError> {
        match axis {
            Axis::X | Axis::Y | Axis::Z => Ok(EmcuAxis(axis)),
            Axis::A => Err(ValueError::NotEmcuAxis(axis)),
        }
    }

    pub fn axis(self) -> Axis {
        self.0
    }

    /// 0, 1, 2 for X, Y, Z.
    pub fn index(self) -> usize {
        self.0.index()
    }

    /// The upper-case letter (`X`), as queries, reference runs and absolute
    /// moves write it.
    pub fn upper(self) -> u8 {
        match self.0 {
            Axis::X => b'X',
            Axis::Y => b'Y',
            // `new` refuses A, so only Z is left.
            _ => b'Z',
        }
    }

    /// The lower-case letter (`x`), as relative moves write it (manual 1.5.10).
    pub fn lower(self) -> u8 {
        self.upper().to_ascii_lowercase()
    }

    /// The axis for an upper-case letter; lower case is not an axis name
    /// here (it only marks relative moves).
    pub fn from_upper(letter: u8) -> Option<EmcuAxis> {
        match letter {
            b'X' => Some(EmcuAxis::X),
            b'Y' => Some(EmcuAxis::Y),
            b'Z' => Some(EmcuAxis::Z),
            _ => None,
        }
    }
}

impl TryFrom<Axis> for EmcuAxis {
    type Error = ValueError;

    fn try_from(axis: Axis) -> Result<Self, Self::Error> {
        EmcuAxis::new(axis)
    }
}

impl From<EmcuAxis> for Axis {
    fn from(axis: EmcuAxis) -> Axis {
        axis.0
    }
}

impl fmt::Display for EmcuAxis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// An unsigned command parameter with a range and a digit width, so that the
/// parser can read every one of them the same way.
pub trait Bounded: Sized {
    /// What the value is called in error messages.
    const WHAT: &'static str;
    /// Most digits the parser accepts (leading zeros included).
    const DIGITS: usize;
    fn new(value: u16) -> Result<Self, ValueError>;
}

/// Declares a validated unsigned value: its range, its digit width (the
/// manual's placeholder) and what it is called in error messages.
macro_rules! bounded {
    ($(#[$doc:meta])* $name:ident, $what:literal, $min:literal ..= $max:literal, digits $digits:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(u16);

        impl $name {
            pub const MIN: u16 = $min;
            pub const MAX: u16 = $max;

            pub fn new(value: u16) -> Result<$name, ValueError> {
                check_range($what, i64::from(value), i64::from($min), i64::from($max))?;
                Ok($name(value))
            }

            pub fn get(self) -> u16 {
                self.0
            }
        }

        impl Bounded for $name {
            const WHAT: &'static str = $what;
            const DIGITS: usize = $digits;

            fn new(value: u16) -> Result<$name, ValueError> {
                $name::new(value)
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                self.0.fmt(f)
            }
        }
    };
}

bounded!(
    /// A step frequency in Hz for `#S` and `#E` (manual 1.5.5/1.5.6,
    /// placeholder `aaaa`). Zero is refused: a motor started at 0 Hz never
    /// moves and the ramp arithmetic would divide by it.
    Speed, "speed (Hz)", 1..=9999, digits 4
);
bounded!(
    /// Ramp length in ms for `#R` (manual 1.5.7, placeholder `aaaa`). Zero
    /// is refused: the acceleration follows from speed change / ramp length.
    RampMillis, "ramp length (ms)", 1..=9999, digits 4
);
bounded!(
    /// Wait time in ms for `W` (manual 1.5.16, placeholder `aaaa`). Zero is
    /// refused: it waits for nothing and is most likely a typing slip.
    WaitMillis, "wait time (ms)", 1..=9999, digits 4
);
bounded!(
    /// An end-speed slot, `#E<slot>,…` and `L<slot>,…` (decision 3: 1-9).
    Slot, "speed slot", 1..=9, digits 1
);
bounded!(
    /// A switched output, `A<n>,…` (manual 1.5.15: two outputs, K1 and K2).
    Output, "output", 1..=2, digits 1
);

impl Speed {
    /// Start speed after power-up (manual 1.4.2, 1.5.5).
    pub const DEFAULT_START: Speed = Speed(200);
    /// End speed of every slot after power-up (manual 1.4.2, 1.5.6).
    pub const DEFAULT_END: Speed = Speed(600);
}

impl RampMillis {
    /// Ramp length after power-up (manual 1.4.2, 1.5.7).
    pub const DEFAULT: RampMillis = RampMillis(500);
}

impl Slot {
    /// Slot 1, the one every example of the manual uses.
    pub const FIRST: Slot = Slot(1);
}

/// A step count or absolute step position of one axis in `L` (manual
/// 1.5.10, placeholder `bbbbbb`: six digits and a sign).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Steps(i32);

impl Steps {
    pub const MIN: i32 = -999_999;
    pub const MAX: i32 = 999_999;
    pub const DIGITS: usize = 6;
    pub const WHAT: &'static str = "steps";

    pub fn new(value: i32) -> Result<Steps, ValueError> {
        check_range(
            Self::WHAT,
            i64::from(value),
            i64::from(Self::MIN),
            i64::from(Self::MAX),
        )?;
        Ok(Steps(value))
    }

    pub fn get(self) -> i32 {
        self.0
    }
}

impl fmt::Display for Steps {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_hold_at_their_edges() {
        assert!(Speed::new(0).is_err());
        assert_eq!(Speed::new(1).map(Speed::get), Ok(1));
        assert_eq!(Speed::new(9999).map(Speed::get), Ok(9999));
        assert!(Speed::new(10000).is_err());
        assert!(RampMillis::new(0).is_err());
        assert!(WaitMillis::new(10000).is_err());
        assert!(Slot::new(0).is_err());
        assert!(Slot::new(10).is_err());
        assert!(Output::new(3).is_err());
        assert!(Steps::new(1_000_000).is_err());
        assert!(Steps::new(-1_000_000).is_err());
        assert_eq!(Steps::new(-999_999).map(Steps::get), Ok(-999_999));
    }

    #[test]
    fn the_a_axis_is_refused() {
        assert_eq!(
            EmcuAxis::new(Axis::A),
            Err(ValueError::NotEmcuAxis(Axis::A))
        );
        assert_eq!(EmcuAxis::new(Axis::Z).map(EmcuAxis::upper), Ok(b'Z'));
        assert_eq!(EmcuAxis::Y.lower(), b'y');
        assert_eq!(EmcuAxis::from_upper(b'x'), None);
    }
}
