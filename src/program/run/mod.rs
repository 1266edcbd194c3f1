//! Runs a program without a machine: what the controller would do with each
//! stored command, as a stream of [`Motion`]s. Two modes share the same
//! semantics:
//! - [`Mode::Path`] follows one run from a known start (branches not taken),
//!   for the toolpath preview and the predicted end position;
//! - [`Mode::Explore`] follows every outcome of the conditional branches and
//!   of an unknown circle direction, from a start that may be unknown, with
//!   positions as ranges, for the soft-limit check.
//!
//! Both stop after a budget of executed commands, so endless programs end.

pub(crate) mod emcu;
pub(crate) mod isel;
pub(crate) mod value;

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{ArcGeometry, CircleDirection, Plane};

use value::{Reach, Val};

/// One motion of the tool: positions in the controller's coordinates (what
/// `@0P` / `@LX` report), reach in machine coordinates.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Motion {
    /// Command index.
    pub index: usize,
    pub kind: MotionKind,
    pub from: [Val; 4],
    pub to: [Val; 4],
    /// The extremes each moving axis reaches; `None` for axes that stand,
    /// whose position is unknown, or whose motion is a reference run (which
    /// goes to the switches by design).
    pub reach: [Option<Reach>; 4],
    /// A port condition (`6`) may end this move early.
    pub until_port: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum MotionKind {
    Line,
    Arc(ArcMotion),
    Reference(AxisSet),
    /// isel `N`: nothing moves; the counters of the axes become 0.
    SimulatedReference(AxisSet),
}

#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ArcMotion {
    pub plane: Plane,
    pub direction: CircleDirection,
    /// No `f` has set the direction; the runner assumed it.
    pub assumed: bool,
    pub geometry: ArcGeometry,
    /// The centre in the controller's coordinates of the plane's two axes.
    pub centre: (Val, Val),
    /// A helix: the third axis and its steps.
    pub helix: Option<(Axis, i32)>,
}

/// Receives the motions of a run.
pub(crate) trait Observer {
    fn motion(&mut self, motion: &Motion);
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Mode {
    Path,
    Explore,
}

/// Why a run (or, exploring, the last path) ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Finish {
    /// At the end command `9` with this index.
    End(usize),
    /// Past the last command.
    RanOff,
    /// A jump at this index leads back into a state already seen: the
    /// program repeats for ever.
    Endless(usize),
    /// The budget ran out before this index.
    Bound(usize),
    /// The jump at this index leads out of the program.
    OutOfProgram(usize),
    /// The loop at this index would need more loop counters than exist.
    LoopStack(usize),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Outcome {
    pub executed: usize,
    pub finish: Finish,
    /// Exploring: the index where the budget ran out, if it did.
    pub bound: Option<usize>,
}
