//! The frame's legs as the question offers them and its answer carries
//! them (`outcome::Then::Frame`): data only, so that the outcome of a
//! question needs nothing of the frame's logic.

use crate::device::api::{PerAxis, Request};
use crate::gcode::frame::LegKind;
use crate::gcode::toolpath::Point;

/// One leg as it goes out: what it is, where it ends (machine units), and
/// its go-to.
#[derive(Debug, Clone, PartialEq)]
pub struct Leg {
    pub kind: LegKind,
    pub to: Point,
    pub target: PerAxis<i64>,
    pub request: Request,
}

/// The frame the question offers, carried by its answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    pub legs: Vec<Leg>,
    /// Where X, Y and Z stood (machine steps) when the question was asked:
    /// the first leg (Z alone up) keeps X and Y there, so the answer starts
    /// nothing once the axes have moved since.
    pub from: PerAxis<i64>,
}
