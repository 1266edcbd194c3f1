//! Tool changes and program pauses (`M6`, `M0`, `M1`) as moves and waits
//! (`docs/gcode.md`, "Tool changes"), sans-IO: a toolpath in, the job cut
//! at its waits out, and the sequence a host runs between the pieces.
//!
//! A tool change is, in the order it runs:
//!
//! 1. **exit** (the piece before): Z alone up to the job's safe height,
//!    the outputs that are on (spindle, coolant) off, then the change
//!    position (`[tools] change_at`, machine coordinates; an axis it does
//!    not name stays where it is, Z at the safe height);
//! 2. **the wait** (the host's, [`Sequence`]): the operator is told which
//!    tool to put in (from the file's own tool table, [`crate::tools`]) and
//!    confirms; with a tool sensor the new tool is measured and every later
//!    Z shifts by its length against the reference tool;
//! 3. **entry** (the piece after): Z up to the safe height (shifted), over
//!    the job's next point, the spindle speed and the outputs as they were,
//!    down to the safe height and at the file's plunge feed onto the point.
//!
//! `M0` and `M1` wait in place: no exit and no entry, the outputs as they
//! are. A host that cannot take over (a program stored whole, `jogterm
//! upload`) runs [`Plan::expanded`]: the same moves with the wait as the
//! program's own pause (the machine's start key).

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::ops::Range;

use super::toolpath::{Line, Op, Origin, OutputSwitch, Pause, Point, Rapid, Toolpath};
use super::tools::ToolInfo;

/// The change position, machine mm per axis; `None`: that axis stays where
/// it is (Z: at the safe height).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChangeAt {
    pub x: Option<f64>,
    pub y: Option<f64>,
    pub z: Option<f64>,
}

/// What a wait is for.
#[derive(Debug, Clone, PartialEq)]
pub enum WaitKind {
    /// M6: the tool the file names (`T` on its line or before), and how its
    /// tool table describes it.
    ToolChange {
        tool: Option<u32>,
        info: Option<ToolInfo>,
    },
    /// M0.
    Program,
    /// M1 (jogterm always stops).
    Optional,
}

/// One wait of the job, with what the moves around it need.
#[derive(Debug, Clone, PartialEq)]
pub struct Wait {
    pub kind: WaitKind,
    /// The pause as the interpreter made it.
    pub pause: Pause,
    pub origin: Origin,
    /// Where the tool stands when the wait comes (machine mm, unshifted).
    pub at: Point,
    /// The outputs on when the wait comes: a tool change switches them off
    /// and on again after.
    pub outputs: Vec<OutputSwitch>,
    pub spindle_rpm: Option<f64>,
    /// The start of the job's next move (machine mm, unshifted); `None`:
    /// no move follows.
    pub next: Option<Point>,
    /// mm/min of the descent onto `next`: the file's last plunge before the
    /// wait, else the plan's default.
    pub descent_feed: f64,
}

impl Wait {
    pub fn is_tool_change(&self) -> bool {
        matches!(self.kind, WaitKind::ToolChange { .. })
    }

    /// The tool's name as `jogterm probe tool --tool` and the tool table
    /// keep it (`T2`); `None` for a pause or an M6 without T.
    pub fn tool_name(&self) -> Option<String> {
        match &self.kind {
            WaitKind::ToolChange { tool: Some(t), .. } => Some(format!("T{t}")),
            _ => None,
        }
    }

    /// `M6: change to tool T2 flat end mill, D=3.175`, `M0: program pause`.
    pub fn what(&self) -> String {
        match &self.kind {
            WaitKind::ToolChange {
                info: Some(info), ..
            } => format!("M6: change to tool {}", info.label()),
            WaitKind::ToolChange { tool: Some(t), .. } => format!("M6: change to tool T{t}"),
            WaitKind::ToolChange { tool: None, .. } => "M6: tool change (no T given)".to_owned(),
            WaitKind::Program => "M0: program pause".to_owned(),
            WaitKind::Optional => "M1: optional pause (jogterm always pauses)".to_owned(),
        }
    }
}

/// A job cut at its waits.
///
/// The plan keeps where its pieces lie in the toolpath it was made of, not
/// copies of their ops (half a million ops are some 60 MB): the methods
/// that need the ops ([`Plan::segment`], [`Plan::expanded`],
/// [`Plan::first_line`]) take that toolpath (`Import::toolpath`) again.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The job's ops between the waits, as ranges of the toolpath's ops
    /// (the pauses between them left out): one more than waits.
    pieces: Vec<Range<usize>>,
    pub waits: Vec<Wait>,
    /// The job's safe height (machine mm, unshifted): the highest Z its
    /// rapids reach, else its highest point.
    pub safe_z: f64,
    change_at: ChangeAt,
    lines: u32,
}

/// Where a move ends; `None` for an op that is no move.
pub fn end_of(op: &Op) -> Option<Point> {
    match op {
        Op::Rapid(m) => Some(m.to),
        Op::Line(m) => Some(m.to),
        Op::Arc(a) => Some(a.to),
        _ => None,
    }
}

/// Where a move starts; `None` for an op that is no move.
pub fn start_of(op: &Op) -> Option<Point> {
    match op {
        Op::Rapid(m) => Some(m.from),
        Op::Line(m) => Some(m.from),
        Op::Arc(a) => Some(a.from),
        _ => None,
    }
}

/// A rapid from `here` to `to`, and `here` there.
fn rapid(ops: &mut Vec<Op>, here: &mut Point, to: Point, origin: Origin) {
    ops.push(Op::Rapid(Rapid {
        from: *here,
        to,
        origin,
    }));
    *here = to;
}

fn up(p: Point, dz: f64) -> Point {
    Point { z: p.z + dz, ..p }
}

/// `op` with every Z `dz` higher (a tool `dz` longer cuts the same part
/// from `dz` higher).
pub fn shifted(op: &Op, dz: f64) -> Op {
    let mut op = op.clone();
    match &mut op {
        Op::Rapid(m) => {
            m.from.z += dz;
            m.to.z += dz;
        }
        Op::Line(m) => {
            m.from.z += dz;
            m.to.z += dz;
        }
        Op::Arc(a) => {
            a.from.z += dz;
            a.to.z += dz;
            a.centre.z += dz;
        }
        _ => {}
    }
    op
}

/// Every Z of `path` `dz` higher: the tool-length offset of the tool in
/// the spindle, applied like a height map's correction.
pub fn shift_toolpath(path: &Toolpath, dz: f64) -> Toolpath {
    Toolpath {
        ops: path.ops.iter().map(|op| shifted(op, dz)).collect(),
        ..path.clone()
    }
}

impl Plan {
    /// `path` cut at its pauses. `tools`: the file's tool table; `plunge`:
    /// the descent's feed where the file plunges nowhere before a wait.
    pub fn of(
        path: &Toolpath,
        tools: &BTreeMap<u32, ToolInfo>,
        change_at: ChangeAt,
        plunge: f64,
    ) -> Plan {
        let start = path.ops.iter().find_map(start_of).unwrap_or_default();
        // The safe height (`Toolpath::safe_height`, else the highest end of
        // any move) found in the walk below, not in walks of its own over
        // the half million ops of a CAM file.
        let mut rapids_top: Option<f64> = None;
        let mut ends_top: Option<f64> = None;
        let mut pieces = Vec::new();
        let mut first = 0;
        let mut waits = Vec::new();
        let mut at = start;
        let mut outputs: Vec<OutputSwitch> = Vec::new();
        let mut rpm = None;
        let mut feed = plunge;
        for (index, op) in path.ops.iter().enumerate() {
            if let Op::Rapid(m) = op {
                rapids_top = Some(rapids_top.map_or(m.to.z, |z| z.max(m.to.z)));
            }
            if let Some(end) = end_of(op) {
                ends_top = Some(ends_top.map_or(end.z, |z| z.max(end.z)));
            }
            match op {
                Op::Pause(pause) => {
                    let kind = match pause {
                        Pause::ToolChange { tool, .. } => WaitKind::ToolChange {
                            tool: *tool,
                            info: tool.and_then(|t| tools.get(&t).cloned()),
                        },
                        Pause::Program { .. } => WaitKind::Program,
                        Pause::Optional { .. } => WaitKind::Optional,
                    };
                    // The next move's start, where the file has named every
                    // axis by then: before that it is the machine's start,
                    // not a point of the job to go back to (an `M6` before
                    // the first move), and the file's own first moves lead
                    // from the change position.
                    let next = path
                        .ops
                        .iter()
                        .enumerate()
                        .skip(index + 1)
                        .take_while(|(_, op)| !matches!(op, Op::Pause(_)))
                        .find_map(|(k, op)| start_of(op).map(|p| (k, p)))
                        .filter(|(k, _)| (0..3).all(|axis| path.named(axis, *k)))
                        .map(|(_, p)| p);
                    waits.push(Wait {
                        kind,
                        pause: pause.clone(),
                        origin: op.origin(),
                        at,
                        outputs: outputs.iter().filter(|o| o.on).cloned().collect(),
                        spindle_rpm: rpm,
                        next,
                        descent_feed: feed,
                    });
                    pieces.push(first..index);
                    first = index + 1;
                    continue;
                }
                Op::Output(o) => match outputs.iter_mut().find(|x| x.address == o.address) {
                    Some(x) => x.on = o.on,
                    None => outputs.push(o.clone()),
                },
                Op::SpindleSpeed { rpm: r, .. } => rpm = Some(*r),
                Op::Line(m) if m.to.z < m.from.z && m.to.x == m.from.x && m.to.y == m.from.y => {
                    feed = m.feed;
                }
                _ => {}
            }
            if let Some(end) = end_of(op) {
                at = end;
            }
        }
        pieces.push(first..path.ops.len());
        Plan {
            pieces,
            waits,
            safe_z: rapids_top.or(ends_top).unwrap_or(start.z),
            change_at,
            lines: path.lines,
        }
    }

    /// Pieces the job runs in: one more than its waits.
    pub fn segments(&self) -> usize {
        self.pieces.len()
    }

    /// Where the tool waits at wait `k` when the job's Z is shifted by
    /// `dz`: the change position (an axis it does not name where the tool
    /// stood, Z at the safe height); for a pause where it stands.
    pub fn waits_at(&self, k: usize, dz: f64) -> Option<Point> {
        let w = self.waits.get(k)?;
        let at = up(w.at, dz);
        if !w.is_tool_change() {
            return Some(at);
        }
        let travel = (self.safe_z + dz).max(at.z);
        Some(Point {
            x: self.change_at.x.unwrap_or(at.x),
            y: self.change_at.y.unwrap_or(at.y),
            z: self.change_at.z.unwrap_or(travel),
        })
    }

    /// The travel height of a change with the job shifted by `dz`: the
    /// safe height, or the change position's Z where that is higher.
    fn travel(&self, dz: f64, also: f64) -> f64 {
        (self.safe_z + dz).max(also)
    }

    /// Piece `k`'s own ops in `path`, the toolpath the plan was made of
    /// (none where `path` is another, shorter one).
    fn own<'a>(&self, path: &'a Toolpath, k: usize) -> &'a [Op] {
        self.pieces
            .get(k)
            .and_then(|r| path.ops.get(r.clone()))
            .unwrap_or_default()
    }

    /// Piece `k` as a toolpath of its own, every Z of the job `dz` higher:
    /// the entry of the wait before it (the tool at the change position
    /// where the piece before, shifted by `dz_before`, left it), the job's
    /// ops (of `path`, the toolpath the plan was made of), and the exit of
    /// the wait after it with an end. Empty beyond the last piece.
    pub fn segment(&self, path: &Toolpath, k: usize, dz_before: f64, dz: f64) -> Toolpath {
        let mut ops = Vec::with_capacity(self.own(path, k).len() + 16);
        self.push_segment(path, k, (dz_before, dz), &mut ops);
        if k < self.waits.len()
            && let Some(w) = self.waits.get(k)
        {
            ops.push(Op::End { origin: w.origin });
        }
        Toolpath {
            ops,
            lines: self.lines,
            warnings: Vec::new(),
            named_from: [0; 3],
        }
    }

    /// Piece `k`'s entry, own ops and exit onto `ops` (see
    /// [`Plan::segment`]), without the end.
    fn push_segment(
        &self,
        path: &Toolpath,
        k: usize,
        (dz_before, dz): (f64, f64),
        ops: &mut Vec<Op>,
    ) {
        if let Some(before) = k.checked_sub(1) {
            ops.extend(self.entry(before, dz_before, dz));
        }
        ops.extend(self.own(path, k).iter().map(|op| shifted(op, dz)));
        if k < self.waits.len() {
            ops.extend(self.exit(k, dz));
        }
    }

    /// The whole job with its moves around every wait and the waits as the
    /// program's own pauses, every Z `dz` higher: what a program stored
    /// whole runs (the start key ends each wait).
    pub fn expanded(&self, path: &Toolpath, dz: f64) -> Toolpath {
        // Sized for the job's ops and a few moves around each wait, so
        // that a file of half a million moves is not copied as it grows.
        let mut ops = Vec::with_capacity(self.ops() + 8 * self.waits.len() + 1);
        for k in 0..self.segments() {
            // Each piece as `segment` has it, its end replaced by the wait.
            self.push_segment(path, k, (dz, dz), &mut ops);
            if let Some(w) = self.waits.get(k) {
                ops.push(Op::Pause(w.pause.clone()));
            }
        }
        // The path's other fields, not `..path.clone()`: that would copy
        // all its ops only to drop them.
        Toolpath {
            ops,
            lines: path.lines,
            warnings: path.warnings.clone(),
            named_from: path.named_from,
        }
    }

    /// [`Plan::expanded`] of the unshifted job (`dz` 0) as a list of
    /// slices, in order: the job's own ops borrowed from `path`, only the
    /// moves around the waits and the pauses made. The import checks and
    /// converts the whole job through them (`iter().flat_map(|s|
    /// s.iter())`), so that a file of half a million moves is not copied
    /// (the copy was the largest share of the import's heap peak).
    pub fn expanded_slices<'a>(&self, path: &'a Toolpath) -> Vec<Cow<'a, [Op]>> {
        let mut slices = Vec::with_capacity(4 * self.segments());
        for k in 0..self.segments() {
            if let Some(before) = k.checked_sub(1) {
                slices.push(Cow::Owned(self.entry(before, 0.0, 0.0)));
            }
            slices.push(Cow::Borrowed(self.own(path, k)));
            if k < self.waits.len() {
                slices.push(Cow::Owned(self.exit(k, 0.0)));
            }
            if let Some(w) = self.waits.get(k) {
                slices.push(Cow::Owned(vec![Op::Pause(w.pause.clone())]));
            }
        }
        slices
    }

    /// The job's own ops in all its pieces.
    fn ops(&self) -> usize {
        self.pieces.iter().map(ExactSizeIterator::len).sum()
    }

    /// The first G-code line of piece `k`'s own ops in `path`, the toolpath
    /// the plan was made of (where a restart would pick the job up after
    /// wait `k - 1`).
    pub fn first_line(&self, path: &Toolpath, k: usize) -> Option<u32> {
        self.own(path, k)
            .iter()
            .find(|op| end_of(op).is_some())
            .map(|op| op.origin().line)
    }

    /// Up, outputs off, to the change position (tool changes only).
    fn exit(&self, k: usize, dz: f64) -> Vec<Op> {
        let (Some(w), Some(change)) = (self.waits.get(k), self.waits_at(k, dz)) else {
            return Vec::new();
        };
        if !w.is_tool_change() {
            return Vec::new();
        }
        let origin = w.origin;
        let mut ops = Vec::new();
        let mut here = up(w.at, dz);
        let travel = self.travel(dz, here.z.max(change.z));
        let to = Point { z: travel, ..here };
        rapid(&mut ops, &mut here, to, origin);
        for o in &w.outputs {
            ops.push(Op::Output(OutputSwitch {
                on: false,
                origin,
                ..o.clone()
            }));
        }
        let to = Point {
            z: travel,
            ..change
        };
        rapid(&mut ops, &mut here, to, origin);
        let to = change;
        rapid(&mut ops, &mut here, to, origin);
        ops
    }

    /// From the change position up, over the next point, the outputs as
    /// they were, down onto it (tool changes only).
    fn entry(&self, k: usize, dz_before: f64, dz: f64) -> Vec<Op> {
        let (Some(w), Some(change)) = (self.waits.get(k), self.waits_at(k, dz_before)) else {
            return Vec::new();
        };
        if !w.is_tool_change() {
            return Vec::new();
        }
        let origin = w.origin;
        let mut ops = Vec::new();
        let mut here = change;
        let travel = self.travel(dz, change.z);
        let to = Point { z: travel, ..here };
        rapid(&mut ops, &mut here, to, origin);
        let next = w.next.map(|n| up(n, dz));
        if let Some(n) = next {
            let to = Point { z: travel, ..n };
            rapid(&mut ops, &mut here, to, origin);
        }
        if let Some(rpm) = w.spindle_rpm {
            ops.push(Op::SpindleSpeed { rpm, origin });
        }
        for o in &w.outputs {
            ops.push(Op::Output(OutputSwitch {
                origin,
                ..o.clone()
            }));
        }
        if let Some(n) = next {
            let safe = Point {
                z: (self.safe_z + dz).max(n.z),
                ..n
            };
            if safe.z < here.z {
                let to = safe;
                rapid(&mut ops, &mut here, to, origin);
            }
            if n.z < here.z {
                ops.push(Op::Line(Line {
                    from: here,
                    to: n,
                    feed: w.descent_feed,
                    origin,
                }));
            }
        }
        ops
    }
}

/// What the host does next in a job with waits ([`Sequence`]): the
/// console and `jogterm run` drive the same steps.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// Run piece `index` ([`Plan::segment`] with these shifts): convert,
    /// check and run it as the job's way says.
    Run {
        index: usize,
        dz_before: f64,
        dz: f64,
    },
    /// Wait `index` has come: tell the operator and wait for the
    /// confirmation (Enter, a line on stdin, a key, the start key).
    Confirm {
        index: usize,
    },
    /// Measure the new tool on the sensor; [`Sequence::measured`] takes its
    /// offset against the reference tool.
    Measure {
        index: usize,
        tool: String,
    },
    /// Bring the tool back to the change position ([`Plan::waits_at`] with
    /// the shift before) after the measure, so that the entry starts there.
    Return {
        index: usize,
        to: Point,
    },
    Done,
}

/// The host's side of a job with waits as a state machine: [`Sequence::step`]
/// says what to do, [`Sequence::done`], [`Sequence::confirmed`] and
/// [`Sequence::measured`] say it was done. No I/O: the caller runs the
/// pieces, asks the operator and measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Sequence {
    plan: Plan,
    /// A tool sensor measures new tools (`probe.tool_sensor`).
    sensor: bool,
    /// The shift of the piece that runs (or ran last).
    dz: f64,
    /// The shift the piece before the current entry ran with.
    dz_before: f64,
    state: State,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Run(usize),
    Confirm(usize),
    Measure(usize),
    Return(usize),
    Done,
}

impl Sequence {
    /// The job's pieces from the first, every Z `dz` higher until a tool is
    /// measured (the offset of the tool in the spindle).
    pub fn new(plan: Plan, sensor: bool, dz: f64) -> Sequence {
        Sequence {
            plan,
            sensor,
            dz,
            dz_before: dz,
            state: State::Run(0),
        }
    }

    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The Z shift in force.
    pub fn shift(&self) -> f64 {
        self.dz
    }

    pub fn step(&self) -> Step {
        match self.state {
            State::Run(index) => Step::Run {
                index,
                dz_before: self.dz_before,
                dz: self.dz,
            },
            State::Confirm(index) => Step::Confirm { index },
            State::Measure(index) => Step::Measure {
                index,
                tool: self
                    .plan
                    .waits
                    .get(index)
                    .and_then(Wait::tool_name)
                    .unwrap_or_else(|| format!("M6@{}", index + 1)),
            },
            State::Return(index) => match self.plan.waits_at(index, self.dz_before) {
                Some(to) => Step::Return { index, to },
                None => Step::Done,
            },
            State::Done => Step::Done,
        }
    }

    /// The piece of [`Step::Run`] ran to its end.
    pub fn done(&mut self) {
        if let State::Run(k) = self.state {
            self.dz_before = self.dz;
            self.state = if k < self.plan.waits.len() {
                State::Confirm(k)
            } else {
                State::Done
            };
        }
    }

    /// The operator confirmed wait `k` of [`Step::Confirm`].
    pub fn confirmed(&mut self) {
        if let State::Confirm(k) = self.state {
            let change = self.plan.waits.get(k).is_some_and(Wait::is_tool_change);
            self.state = if change && self.sensor {
                State::Measure(k)
            } else {
                State::Run(k + 1)
            };
        }
    }

    /// The new tool of [`Step::Measure`] measured: `offset` mm longer than
    /// the reference tool. Every later Z shifts by it.
    pub fn measured(&mut self, offset: f64) {
        if let State::Measure(k) = self.state {
            self.dz = offset;
            self.state = State::Return(k);
        }
    }

    /// The tool is back at the change position ([`Step::Return`]).
    pub fn returned(&mut self) {
        if let State::Return(k) = self.state {
            self.state = State::Run(k + 1);
        }
    }
}

#[cfg(test)]
#[path = "toolchange_tests.rs"]
mod tests;
