//! The interpreted job: the contract between the interpreter and the
//! per-family outputs, the machine check, the preview and the runs.
//!
//! Everything here is resolved: units are millimetres (G20 files are
//! converted on reading), coordinates are the **machine** coordinates of the
//! profile's axes (work offset and G53 applied), incremental words are
//! absolute, arcs carry their centre, every output is a bit of the
//! profile's wiring, and every op knows the G-code line it came from. What
//! is left to the outputs is only how their controller says it.

use crate::offsets::System;
use jogterm_proto::wiring::Role;

/// Where a thing came from in the G-code file: 1-based line and column (in
/// characters) of the word that made it; the block's first word for what a
/// whole block made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct Origin {
    pub line: u32,
    pub col: u32,
}

/// A point in machine coordinates, mm, X Y Z.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// A straight move at the rapid speed of the machine (G0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rapid {
    pub from: Point,
    pub to: Point,
    pub origin: Origin,
}

/// A straight move at a feed (G1, and the moves of the drilling cycles).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    pub from: Point,
    pub to: Point,
    /// mm per minute, as the file's F said it (converted from inches).
    pub feed: f64,
    pub origin: Origin,
}

/// The plane of an arc (G17 XY, G18 ZX, G19 YZ). Not isel's `proto::isel::Plane`:
/// RS-274/NGC orders G18 as Z then X, which decides what clockwise means,
/// and the IR serves the EMCU output too; the isel output maps between them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Plane {
    #[default]
    Xy,
    Zx,
    Yz,
}

/// A circular or helical arc (G2 clockwise, G3 counter-clockwise, seen
/// from the positive end of the plane's normal, as RS-274/NGC says).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arc {
    pub from: Point,
    pub to: Point,
    /// In the plane; its coordinate along the plane's normal is `from`'s.
    pub centre: Point,
    pub plane: Plane,
    pub clockwise: bool,
    /// Full turns beyond the first (P of G2/G3 minus one); 0 for an arc of
    /// at most one turn. A full circle has `from` and `to` equal in the plane.
    pub extra_turns: u32,
    /// mm per minute.
    pub feed: f64,
    pub origin: Origin,
}

/// A dwell (G4 P seconds, and G82's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dwell {
    pub seconds: f64,
    pub origin: Origin,
}

/// An output of the profile's wiring switched on or off: M3/M4/M5 (spindle),
/// M7/M8/M9 (coolant), M62-M65 (by number), each as the profile's `[gcode]`
/// table maps it.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSwitch {
    /// The wiring's address of the bit (`out0.3`, `11.O1`): one the profile
    /// declares.
    pub address: String,
    /// What the profile calls it, for messages and headers.
    pub name: String,
    pub role: Option<Role>,
    pub on: bool,
    pub origin: Origin,
}

/// A stop that waits for the operator.
#[derive(Debug, Clone, PartialEq)]
pub enum Pause {
    /// M0.
    Program { origin: Origin },
    /// M1 (optional stop; jogterm always stops).
    Optional { origin: Origin },
    /// M6 with the tool the file names (`T` on its line or before).
    ToolChange { tool: Option<u32>, origin: Origin },
}

/// One step of the job, in file order.
#[derive(Debug, Clone, PartialEq)]
pub enum Op {
    Rapid(Rapid),
    Line(Line),
    /// Boxed: an arc is half as large again as a line, and every op of a
    /// file takes the size of the largest; one arc in ten (in CAM files)
    /// would make a 500 000-line toolpath 12 MB larger, pages the import
    /// faults in and every walk over the ops reads.
    Arc(Box<Arc>),
    Dwell(Dwell),
    Output(OutputSwitch),
    /// Spindle speed (S), rpm, for headers and for machines that set it.
    SpindleSpeed {
        rpm: f64,
        origin: Origin,
    },
    Pause(Pause),
    /// The work coordinate system in force from here on, with its zero in
    /// machine mm as the interpreter took it from jogterm's work offsets:
    /// first before any move, again where the file selects another. The
    /// work coordinates of a point are its machine coordinates minus the
    /// zero in force (G53 moves are machine coordinates and change nothing).
    WorkOffset {
        system: System,
        zero: Point,
        origin: Origin,
    },
    /// M2 or M30, or the end of the file.
    End {
        origin: Origin,
    },
}

impl Op {
    /// The G-code line and column the step came from.
    pub fn origin(&self) -> Origin {
        match self {
            Op::Rapid(m) => m.origin,
            Op::Line(m) => m.origin,
            Op::Arc(a) => a.origin,
            Op::Dwell(d) => d.origin,
            Op::Output(o) => o.origin,
            Op::SpindleSpeed { origin, .. }
            | Op::WorkOffset { origin, .. }
            | Op::End { origin } => *origin,
            Op::Pause(
                Pause::Program { origin }
                | Pause::Optional { origin }
                | Pause::ToolChange { origin, .. },
            ) => *origin,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Severity {
    Warning,
    Error,
}

/// A message about the G-code at its line and column
/// (`FILE:LINE:COL: error: …` when printed with the file's name).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    pub severity: Severity,
    pub origin: Origin,
    pub message: String,
}

impl Diagnostic {
    pub fn error(origin: Origin, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            origin,
            message: message.into(),
        }
    }

    pub fn warning(origin: Origin, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Warning,
            origin,
            message: message.into(),
        }
    }
}

/// What the interpreter made of a file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Toolpath {
    pub ops: Vec<Op>,
    /// Lines read (a final line without newline counts).
    pub lines: u32,
    /// Warnings (errors make no toolpath).
    pub warnings: Vec<Diagnostic>,
    /// For X, Y and Z: the index of the first op from which the file has
    /// named that axis (`ops.len()` if never). Before it the axis stands
    /// where the job started, which is the machine's, not the file's: the
    /// file's extents leave it out (a first `G0 Z5` says nothing of X).
    pub named_from: [usize; 3],
}

impl Toolpath {
    /// Whether the file had named `axis` (0 X, 1 Y, 2 Z) by op `index`.
    pub fn named(&self, axis: usize, index: usize) -> bool {
        self.named_from.get(axis).is_some_and(|&from| index >= from)
    }

    /// The job's safe height: the highest Z its rapids reach (machine mm),
    /// where parts are cut and restarts enter; `None` without rapids.
    pub fn safe_height(&self) -> Option<f64> {
        self.ops
            .iter()
            .filter_map(|op| match op {
                Op::Rapid(m) => Some(m.to.z),
                _ => None,
            })
            .reduce(f64::max)
    }
}
