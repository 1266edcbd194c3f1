//! Machine axes as the controllers name them. isel has up to four (X, Y, Z, A),
//! EMCU three (X, Y, Z); an EMP link has one axis per drive, mapped onto these
//! names by the machine profile.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Serialized as its letter (`"X"`), which is how profiles and JSON output name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    X,
    Y,
    Z,
    A,
}

impl Axis {
    pub const ALL: [Axis; 4] = [Axis::X, Axis::Y, Axis::Z, Axis::A];

    /// Position in the X, Y, Z, A order that every reply and parameter list uses.
    pub fn index(self) -> usize {
        self as usize
    }

    pub fn from_index(index: usize) -> Option<Axis> {
        Self::ALL.get(index).copied()
    }

    /// Bit in an isel axis mask (`@0R`, `@0n`, `@0N`): bit0 X, bit1 Y, bit2 Z, bit3 A.
    pub fn mask_bit(self) -> u8 {
        1 << self.index()
    }

    pub fn letter(self) -> char {
        match self {
            Axis::X => 'X',
            Axis::Y => 'Y',
            Axis::Z => 'Z',
            Axis::A => 'A',
        }
    }

    pub fn from_letter(c: char) -> Option<Axis> {
        match c.to_ascii_uppercase() {
            'X' => Some(Axis::X),
            'Y' => Some(Axis::Y),
            'Z' => Some(Axis::Z),
            'A' => Some(Axis::A),
            _ => None,
        }
    }
}

impl Serialize for Axis {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_char(self.letter())
    }
}

impl<'de> Deserialize<'de> for Axis {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        let mut chars = text.chars();
        match (chars.next(), chars.next()) {
            (Some(c), None) if c.is_ascii_uppercase() => Axis::from_letter(c),
            _ => None,
        }
        .ok_or_else(|| {
            serde::de::Error::custom(format!("`{text}` is not an axis: expected X, Y, Z or A"))
        })
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.letter())
    }
}

/// A set of axes, stored as the isel bit mask (bit0 X … bit3 A).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub struct AxisSet(u8);

impl AxisSet {
    pub const EMPTY: AxisSet = AxisSet(0);
    pub const XYZ: AxisSet = AxisSet(0b0111);
    pub const XYZA: AxisSet = AxisSet(0b1111);

    /// The set for a mask; bits above A are dropped.
    pub fn from_mask(mask: u8) -> AxisSet {
        AxisSet(mask & 0b1111)
    }

    pub fn mask(self) -> u8 {
        self.0
    }

    pub fn with(self, axis: Axis) -> AxisSet {
        AxisSet(self.0 | axis.mask_bit())
    }

    pub fn contains(self, axis: Axis) -> bool {
        self.0 & axis.mask_bit() != 0
    }

    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    pub fn len(self) -> usize {
        self.0.count_ones() as usize
    }

    pub fn iter(self) -> impl Iterator<Item = Axis> {
        Axis::ALL.into_iter().filter(move |a| self.contains(*a))
    }
}

impl FromIterator<Axis> for AxisSet {
    fn from_iter<I: IntoIterator<Item = Axis>>(iter: I) -> Self {
        iter.into_iter().fold(AxisSet::EMPTY, AxisSet::with)
    }
}

impl fmt::Display for AxisSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for axis in self.iter() {
            write!(f, "{axis}")?;
        }
        Ok(())
    }
}

/// A value per axis, in X, Y, Z, A order; `None` where the axis is absent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct PerAxis<T>(pub [Option<T>; 4]);

impl<T: Copy> PerAxis<T> {
    pub fn new() -> Self {
        PerAxis([None; 4])
    }

    pub fn get(&self, axis: Axis) -> Option<T> {
        self.0[axis.index()]
    }

    pub fn set(&mut self, axis: Axis, value: T) {
        self.0[axis.index()] = Some(value);
    }

    pub fn with(mut self, axis: Axis, value: T) -> Self {
        self.set(axis, value);
        self
    }

    pub fn clear(&mut self, axis: Axis) {
        self.0[axis.index()] = None;
    }

    pub fn axes(&self) -> AxisSet {
        self.iter().map(|(a, _)| a).collect()
    }

    pub fn iter(&self) -> impl Iterator<Item = (Axis, T)> + '_ {
        Axis::ALL
            .into_iter()
            .filter_map(|a| self.get(a).map(|v| (a, v)))
    }

    pub fn map<U: Copy>(&self, f: impl Fn(Axis, T) -> U) -> PerAxis<U> {
        let mut out = PerAxis::new();
        for (a, v) in self.iter() {
            out.set(a, f(a, v));
        }
        out
    }
}

impl<T: Copy> FromIterator<(Axis, T)> for PerAxis<T> {
    fn from_iter<I: IntoIterator<Item = (Axis, T)>>(iter: I) -> Self {
        let mut out = PerAxis::new();
        for (a, v) in iter {
            out.set(a, v);
        }
        out
    }
}

/// Direction of travel along an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Dir {
    Minus,
    Plus,
}

impl Dir {
    pub fn sign(self) -> i64 {
        match self {
            Dir::Minus => -1,
            Dir::Plus => 1,
        }
    }

    /// The other way.
    pub fn reverse(self) -> Dir {
        match self {
            Dir::Minus => Dir::Plus,
            Dir::Plus => Dir::Minus,
        }
    }

    /// `+` or `-`, as in `X+`.
    pub fn symbol(self) -> char {
        match self {
            Dir::Minus => '-',
            Dir::Plus => '+',
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_follow_the_isel_bit_order() {
        assert_eq!(AxisSet::from_iter([Axis::X, Axis::Z]).mask(), 5);
        assert_eq!(
            AxisSet::from_mask(8).iter().collect::<Vec<_>>(),
            vec![Axis::A]
        );
        assert_eq!(AxisSet::XYZ.to_string(), "XYZ");
    }
}
