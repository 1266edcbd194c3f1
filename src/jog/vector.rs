//! A jog direction: for each axis plus, minus or not at all. One key names
//! one vector (X+, or X+Y- for a diagonal); keys held together (where the
//! terminal reports releases) add up to one.

use std::fmt;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Dir, PerAxis};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Vector(PerAxis<Dir>);

impl Default for Vector {
    fn default() -> Vector {
        Vector(PerAxis::new())
    }
}

impl Vector {
    pub fn new(pairs: &[(Axis, Dir)]) -> Vector {
        Vector(pairs.iter().copied().collect())
    }

    pub fn single(axis: Axis, dir: Dir) -> Vector {
        Vector(PerAxis::new().with(axis, dir))
    }

    pub fn get(&self, axis: Axis) -> Option<Dir> {
        self.0.get(axis)
    }

    pub fn axes(&self) -> AxisSet {
        self.0.axes()
    }

    pub fn is_empty(&self) -> bool {
        self.axes().is_empty()
    }

    /// `self` with `other` on top: an axis both name goes `other`'s way
    /// (the key pressed last wins).
    pub fn combine(&self, other: &Vector) -> Vector {
        let mut out = *self;
        for (axis, dir) in other.0.iter() {
            out.0.set(axis, dir);
        }
        out
    }

    /// The axes and directions in X, Y, Z, A order, as requests take them.
    pub fn pairs(&self) -> Vec<(Axis, Dir)> {
        self.0.iter().collect()
    }
}

impl fmt::Display for Vector {
    /// `X+Y-`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (axis, dir) in self.0.iter() {
            let sign = match dir {
                Dir::Plus => '+',
                Dir::Minus => '-',
            };
            write!(f, "{axis}{sign}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_key_pressed_last_wins_an_axis() {
        let right = Vector::single(Axis::X, Dir::Plus);
        let up = Vector::single(Axis::Y, Dir::Plus);
        let left = Vector::single(Axis::X, Dir::Minus);
        let diagonal = right.combine(&up);
        assert_eq!(diagonal.to_string(), "X+Y+");
        assert_eq!(
            diagonal.pairs(),
            [(Axis::X, Dir::Plus), (Axis::Y, Dir::Plus)]
        );
        assert_eq!(diagonal.combine(&left).to_string(), "X-Y+");
        assert!(Vector::default().is_empty());
    }
}
