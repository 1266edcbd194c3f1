//! The tool's path through a program: one segment per motion, with the
//! source line that caused it, for the toolpath preview and the predicted end
//! position.
//!
//! Positions are the controller's counters in steps (what `@0P` and `@LX`
//! report), X Y Z A. The path follows one run: conditional branches (isel
//! `2`, `o`) are not taken, a port condition (`6`) does not end its move
//! early, loops are unrolled, and a run that goes on for ever is cut after a
//! bound of executed commands ([`Path::finish`] says so). Semantics:
//! `docs/programs.md` and `docs/protocols.md` (isel "Running stored
//! programs").

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{ArcGeometry, AxisConfig, CircleDirection, Plane};

use super::model::{Language, Program};
use super::run::value::Val;
use super::run::{self, Finish, Mode, Motion, MotionKind, Observer};

/// Counters of X, Y, Z, A in steps.
pub type Position = [i64; 4];

/// Commands a path runs at most before it is cut.
pub const PATH_BOUND: usize = 100_000;

/// Where and with what a program starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Start {
    /// The axes the controller is initialised with. isel: X, XY, XYZ or
    /// XYZA (they decide how move parameters are read, manual 3.2.2); any
    /// other set is read as the smallest of these that holds it.
    pub axes: AxisSet,
    /// The counters when the program starts.
    pub position: Position,
    /// The counter values of the virtual zero point (isel `@0n`, manual
    /// 2.2.19) in force when the program starts: absolute moves `m` count
    /// from it. 0 after a reference run.
    pub zero: Position,
}

impl Start {
    pub fn new(axes: AxisSet, position: Position) -> Start {
        Start {
            axes,
            position,
            zero: [0; 4],
        }
    }

    /// The same start with the virtual zero point at `zero` (isel).
    pub fn with_zero(mut self, zero: Position) -> Start {
        self.zero = zero;
        self
    }

    /// All counters at 0 (machine zero after a reference run).
    pub fn at_zero(axes: AxisSet) -> Start {
        Start::new(axes, [0; 4])
    }
}

/// One motion of the tool.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// The source line of the command.
    pub line: usize,
    /// The command index.
    pub index: usize,
    pub from: Position,
    pub to: Position,
    pub kind: SegmentKind,
    /// An isel port condition (`6`, manual 3.2.7) may end this move early;
    /// the path assumes it runs to its end.
    pub until_port: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub enum SegmentKind {
    /// A straight, interpolated move.
    Line,
    /// isel `y` (manual 3.2.23).
    Arc(Arc),
    /// isel `w` (manual 3.2.22): the arc, and the third axis of the plane
    /// moving `steps` along it.
    Helix { arc: Arc, axis: Axis, steps: i32 },
    /// A reference run of one axis to its switch; the counter becomes 0.
    Reference(Axis),
    /// isel `N` (manual 3.2.18): nothing moves, the counters of these axes
    /// become 0. A preview does not draw it.
    SimulatedReference(AxisSet),
}

/// A circular arc in a plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    pub plane: Plane,
    pub direction: CircleDirection,
    /// No `f` set the direction before this arc; the path assumed CW
    /// (`docs/programs.md`).
    pub direction_assumed: bool,
    /// The centre, in counters of the plane's two axes.
    pub centre: (i64, i64),
    /// The arc around the centre: start, radius, start angle, sweep
    /// ([`ArcGeometry::point_at`] gives points along it).
    pub geometry: ArcGeometry,
}

impl Segment {
    /// The lowest and highest counter of `axis` along the segment.
    pub fn extent(&self, axis: Axis) -> (i64, i64) {
        let i = axis.index();
        let (a, b) = (self.from[i], self.to[i]);
        let line = (a.min(b), a.max(b));
        let arc = match &self.kind {
            SegmentKind::Arc(arc) | SegmentKind::Helix { arc, .. } => arc,
            _ => return line,
        };
        let (a1, a2) = arc.plane.axes();
        let ((lo1, hi1), (lo2, hi2)) = run::isel::extents(&arc.geometry);
        let around = |c: i64, lo: i64, hi: i64| (c.saturating_add(lo), c.saturating_add(hi));
        if axis == a1 {
            around(arc.centre.0, lo1, hi1)
        } else if axis == a2 {
            around(arc.centre.1, lo2, hi2)
        } else {
            line
        }
    }
}

/// How the path ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathEnd {
    /// At the end command `9` in this line.
    End { line: usize },
    /// After the last command.
    Finished,
    /// The jump in this line leads back to where the program was before
    /// with nothing changed: it repeats for ever.
    Endless { line: usize },
    /// The bound of executed commands ran out before this line.
    Cut { line: usize },
    /// The jump in this line leads out of the program.
    OutOfProgram { line: usize },
    /// The loop in this line needs more loop counters than exist.
    TooDeep { line: usize },
}

/// The path of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pub start: Position,
    pub segments: Vec<Segment>,
    /// The predicted counters after the run.
    pub end: Position,
    pub finish: PathEnd,
    /// Commands executed (loops counted each time round).
    pub executed: usize,
}

/// The isel axis configuration that holds `axes`: the one of its highest
/// axis (manual 2.2.1).
pub fn covering_config(axes: AxisSet) -> AxisConfig {
    if axes.contains(Axis::A) {
        AxisConfig::XYZA
    } else if axes.contains(Axis::Z) {
        AxisConfig::XYZ
    } else if axes.contains(Axis::Y) {
        AxisConfig::XY
    } else {
        AxisConfig::X
    }
}

/// The path of `program` from `start`, cut after [`PATH_BOUND`] commands.
pub fn path(program: &Program, start: &Start) -> Path {
    path_with(program, start, PATH_BOUND)
}

/// The path, cut after `max_commands` executed commands.
pub fn path_with(program: &Program, start: &Start, max_commands: usize) -> Path {
    let mut collect = Collect {
        program,
        segments: Vec::new(),
    };
    let outcome = match program.language() {
        Language::Isel => {
            let runner = run::isel::Runner::new(
                program,
                covering_config(start.axes),
                Mode::Path,
                max_commands,
            );
            runner.run(
                run::isel::State::start(Some(start.position)).with_zero(start.zero),
                &mut collect,
            )
        }
        Language::Emcu => run::emcu::run(program, Some(start.position), max_commands, &mut collect),
    };
    let line = |index: usize| program.line_of(index).unwrap_or(0);
    let finish = match outcome.finish {
        Finish::End(i) => PathEnd::End { line: line(i) },
        Finish::RanOff => PathEnd::Finished,
        Finish::Endless(i) => PathEnd::Endless { line: line(i) },
        Finish::Bound(i) => PathEnd::Cut { line: line(i) },
        Finish::OutOfProgram(i) => PathEnd::OutOfProgram { line: line(i) },
        Finish::LoopStack(i) => PathEnd::TooDeep { line: line(i) },
    };
    let segments = collect.segments;
    let end = segments.last().map_or(start.position, |s| s.to);
    Path {
        start: start.position,
        segments,
        end,
        finish,
        executed: outcome.executed,
    }
}

struct Collect<'p> {
    program: &'p Program,
    segments: Vec<Segment>,
}

/// In path mode every position is exact (the start is known and nothing
/// widens a position), so the low end is the value.
fn exact(position: &[Val; 4]) -> Position {
    position.map(|v| v.map_or(0, |iv| iv.lo))
}

impl Observer for Collect<'_> {
    fn motion(&mut self, m: &Motion) {
        let from = exact(&m.from);
        let to = exact(&m.to);
        let kind = match &m.kind {
            MotionKind::Line => SegmentKind::Line,
            MotionKind::Arc(a) => {
                let arc = Arc {
                    plane: a.plane,
                    direction: a.direction,
                    direction_assumed: a.assumed,
                    centre: (
                        a.centre.0.map_or(0, |c| c.lo),
                        a.centre.1.map_or(0, |c| c.lo),
                    ),
                    geometry: a.geometry,
                };
                match a.helix {
                    Some((axis, steps)) => SegmentKind::Helix { arc, axis, steps },
                    None => SegmentKind::Arc(arc),
                }
            }
            MotionKind::Reference(axes) => match axes.iter().next() {
                Some(axis) => SegmentKind::Reference(axis),
                None => return,
            },
            MotionKind::SimulatedReference(axes) => SegmentKind::SimulatedReference(*axes),
        };
        self.segments.push(Segment {
            line: self.program.line_of(m.index).unwrap_or(0),
            index: m.index,
            from,
            to,
            kind,
            until_port: m.until_port,
        });
    }
}
