//! Restart a job from a G-code line, after a broken tool or a power cut
//! (issue 27; `docs/gcode.md`, "Restart from a line").
//!
//! The restart is a toolpath of its own, converted by the same writers as
//! the import: an entry (retract to the job's safe height, rapid above the
//! line's start, the skipped lines' outputs, descend at feed), then the
//! job's ops from the line on. So the result is an [`output::Program`]
//! like any import's, with the G-code origin of every command, and stream,
//! chunked and stored runs take it unchanged.
//!
//! Sans-IO: the G-code text, the profile and the import in, values out.

use std::fmt;

use crate::config::profile::Profile;
use crate::offsets::WorkOffsets;

use super::check::check_limits;
use super::import::Import;
use super::interp::modal_before;
use super::modal::{Modal, number};
use super::output::{Header, Program};
use super::profile::{machine_of, setup_of};
use super::setup::Units;
use super::target::Target;
use super::toolchange::end_of;
use super::toolpath::{Diagnostic, Line, Op, Origin, OutputSwitch, Pause, Point, Rapid, Toolpath};

#[cfg(test)]
#[path = "restart_tests.rs"]
mod tests;

/// The column of the entry's ops: G-code columns count from 1, so 0 tells
/// the entry's commands from the line's own while both name the line.
pub const ENTRY_COL: u32 = 0;

/// A job cut at a G-code line, with the way back into it.
#[derive(Debug, Clone, PartialEq)]
pub struct Restart {
    /// The line asked for.
    pub requested: u32,
    /// The line the restart begins at: the first at or after `requested`
    /// that converted to anything.
    pub line: u32,
    /// What the skipped lines left in force.
    pub modal: Modal,
    /// Where line `line` begins (the end of the last skipped move), machine mm.
    pub start: Point,
    /// The job's safe height: the highest Z its rapids reach, machine mm.
    pub safe_z: f64,
    /// The work zero in force at the line, machine mm (for saying points in
    /// the file's coordinates).
    pub zero: Point,
    /// The entry, in the order it runs: the toolpath ops before line `line`'s own.
    pub entry: Vec<Op>,
    /// The whole restart converted: header, entry, line `line` to the end.
    pub program: Program,
    /// Index into `program.lines` of the first command of line `line` itself.
    pub cut: usize,
    /// G-code lines skipped (before `line`) and left to run (from it).
    pub skipped_lines: u32,
    pub remaining_lines: u32,
    /// What the operator should know: the line moved on, an arc run whole.
    pub notes: Vec<String>,
    /// The restart's motion time, as the import estimates a job's.
    pub estimated_s: f64,
    /// The descent's feed, mm/min: the file's last plunge before the line
    /// (a feed move of Z alone, downwards), else the profile's
    /// `gcode.plunge_feed`.
    pub descent_feed: f64,
    /// The line of that plunge; `None`: the profile's feed.
    pub plunge_line: Option<u32>,
    /// The program begins with a reference run (`gcode.reference_first`).
    pub reference_first: bool,
    pub target: Target,
}

/// Why a job cannot be restarted at a line.
#[derive(Debug, Clone, PartialEq)]
pub enum RestartError {
    /// Line 0 or beyond the file.
    BeyondFile { line: u32, lines: u32 },
    /// At or before the first move: there is nothing to skip and no point
    /// to go back to.
    BeforeFirstMove { line: u32, first: u32 },
    /// No move left from the line on (after M2/M30, or the last move).
    NothingLeft { line: u32 },
    /// The line is a pause (M0, M1, M6): it waits for the operator, who is
    /// at the machine already.
    Pause { line: u32, what: String },
    /// The restart's toolpath failed the check or the conversion.
    Convert(Vec<Diagnostic>),
}

impl fmt::Display for RestartError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RestartError::BeyondFile { line, lines } => write!(
                f,
                "line {line} is not in the file: it has lines 1 to {lines}"
            ),
            RestartError::BeforeFirstMove { line, first } => write!(
                f,
                "line {line} is at or before the job's first move (line {first}): nothing to skip, run the whole job"
            ),
            RestartError::NothingLeft { line } => write!(
                f,
                "no move from line {line} on (the job ends before it): nothing left to run"
            ),
            RestartError::Pause { line, what } => write!(
                f,
                "line {line} is a pause ({what}): restart from the line after it once the tool is ready, or from a line before it"
            ),
            RestartError::Convert(errors) => {
                let first = errors.first().map_or_else(String::new, |d| {
                    format!(" at line {}: {}", d.origin.line, d.message)
                });
                write!(f, "the restart does not convert{first}")
            }
        }
    }
}

impl std::error::Error for RestartError {}

fn origin_of(op: &Op) -> Origin {
    op.origin()
}

fn pause_name(p: &Pause) -> String {
    match p {
        Pause::Program { .. } => "M0".into(),
        Pause::Optional { .. } => "M1".into(),
        Pause::ToolChange { tool: Some(t), .. } => format!("M6 T{t}"),
        Pause::ToolChange { tool: None, .. } => "M6".into(),
    }
}

/// The job's safe height; a job without rapids has its highest point.
fn safe_height(path: &Toolpath) -> Option<f64> {
    path.safe_height().or_else(|| {
        path.ops
            .iter()
            .filter_map(end_of)
            .map(|p| p.z)
            .reduce(f64::max)
    })
}

/// The job `imported` (from `text`, named `file`, for `profile` and
/// `offsets`) restarted at G-code line `line` (1-based).
pub fn restart(
    text: &str,
    file: &str,
    profile: &Profile,
    offsets: &WorkOffsets,
    imported: &Import,
    line: u32,
) -> Result<Restart, RestartError> {
    let path = &imported.toolpath;
    let ops = &path.ops;
    if line == 0 || line > path.lines {
        return Err(RestartError::BeyondFile {
            line,
            lines: path.lines,
        });
    }
    let first_move = ops.iter().position(|op| end_of(op).is_some());
    let Some(cut) = ops.iter().position(|op| origin_of(op).line >= line) else {
        return Err(RestartError::NothingLeft { line });
    };
    if !ops[cut..].iter().any(|op| end_of(op).is_some()) {
        return Err(RestartError::NothingLeft { line });
    }
    let first_move = first_move.unwrap_or(cut);
    if cut <= first_move {
        return Err(RestartError::BeforeFirstMove {
            line,
            first: origin_of(&ops[first_move]).line,
        });
    }
    let at = origin_of(&ops[cut]).line;
    if let Op::Pause(p) = &ops[cut] {
        return Err(RestartError::Pause {
            line: at,
            what: pause_name(p),
        });
    }
    let mut notes = Vec::new();
    if at != line {
        notes.push(format!(
            "line {line} converts to no command (a comment, or modal words only): the restart begins at line {at}, the first converted command after it, with line {line}'s modal words applied"
        ));
    }
    if matches!(ops[cut], Op::Arc(_)) {
        notes.push(format!(
            "line {at} is an arc: it runs whole, from its start (a line is never entered midway)"
        ));
    }
    let skipped = &ops[..cut];
    // The operator put a tool in after a broken one: the job's, not any.
    if let Some((tool, origin)) = skipped.iter().rev().find_map(|op| match op {
        Op::Pause(Pause::ToolChange { tool, origin }) => Some((*tool, *origin)),
        _ => None,
    }) {
        let which = tool.map_or_else(|| "the tool".to_owned(), |t| format!("tool T{t}"));
        notes.push(format!(
            "the skipped lines change to {which} (line {}): that tool must be in the spindle",
            origin.line
        ));
    }
    let start = skipped.iter().rev().find_map(end_of).unwrap_or_default();
    let safe_z = safe_height(path).unwrap_or(start.z);
    let setup = setup_of(profile, offsets).map_err(|errors| {
        RestartError::Convert(
            errors
                .into_iter()
                .map(|e| {
                    Diagnostic::error(
                        Origin { line: 1, col: 1 },
                        format!("profile: {}: {}", e.key, e.message),
                    )
                })
                .collect(),
        )
    })?;
    let modal = modal_before(text, &setup, at);
    // The descent goes into material the job may have cut, as the file's
    // own plunges do: at their feed, not at the feed of the cut in force.
    let plunge = skipped.iter().rev().find_map(|op| match op {
        Op::Line(m) if m.to.z < m.from.z && m.to.x == m.from.x && m.to.y == m.from.y => {
            Some((m.feed, m.origin.line))
        }
        _ => None,
    });
    let (feed, plunge_line) = match plunge {
        Some((feed, line)) => (feed, Some(line)),
        None => (profile.gcode.plunge_feed, None),
    };
    let deepest = ops
        .iter()
        .filter_map(end_of)
        .map(|p| p.z)
        .fold(start.z, f64::min);
    let entry = entry(
        skipped,
        Entry {
            start,
            safe_z,
            deepest,
            feed,
            reference_first: profile.gcode.reference_first,
            origin: Origin {
                line: at,
                col: ENTRY_COL,
            },
        },
    );
    let zero = entry
        .iter()
        .find_map(|op| match op {
            Op::WorkOffset { zero, .. } => Some(*zero),
            _ => None,
        })
        .unwrap_or(imported.summary.zero);
    let mut restarted = Toolpath {
        ops: entry.clone(),
        lines: path.lines,
        warnings: Vec::new(),
        named_from: [0; 3],
    };
    restarted.ops.extend(ops[cut..].iter().cloned());
    let machine = machine_of(profile, imported.target);
    check_limits(&restarted, &machine).map_err(|e| RestartError::Convert(vec![e]))?;
    let estimated_s = super::check::summarise(&restarted, &machine).estimated_s;
    let header = Header {
        file: file.to_owned(),
        profile: profile.name.clone(),
        system: imported.summary.system.to_string(),
        zero: imported.summary.zero,
    };
    let mut program = match imported.target {
        Target::Isel => super::isel::convert(&restarted, profile, &header),
        Target::Emcu => super::emcu::convert(&restarted, profile, &header),
    }
    .map_err(RestartError::Convert)?;
    let mark = header.lines().len();
    program.lines.insert(
        mark,
        super::output::ProgramLine {
            command: String::new(),
            comment: Some(format!("{} restart=line {at}", Header::PREFIX)),
            origin: None,
        },
    );
    for r in &mut program.retracted {
        if *r >= mark {
            *r += 1;
        }
    }
    let first_own = program
        .lines
        .iter()
        .position(|l| {
            !l.command.is_empty() && l.origin.is_some_and(|o| o.col != ENTRY_COL && o.line >= at)
        })
        .unwrap_or(program.lines.len());
    Ok(Restart {
        requested: line,
        line: at,
        modal,
        start,
        safe_z,
        zero,
        entry,
        program,
        cut: first_own,
        skipped_lines: at - 1,
        remaining_lines: path.lines + 1 - at,
        notes,
        estimated_s,
        descent_feed: feed,
        plunge_line,
        reference_first: profile.gcode.reference_first,
        target: imported.target,
    })
}

/// What the entry needs to know of the job.
struct Entry {
    start: Point,
    safe_z: f64,
    /// The lowest Z the job reaches, machine mm.
    deepest: f64,
    /// mm/min of the descent.
    feed: f64,
    reference_first: bool,
    origin: Origin,
}

/// The entry's ops: the work offset in force, the retract, the rapid
/// above the start, the skipped lines' spindle speed and outputs, the
/// descent. Retract first: after a broken tool the tool may stand in the
/// material, and a move in X or Y there would drag it through the part.
/// Outputs before the descent: the spindle must turn before it cuts.
/// Descend at the plunge feed: the surface below may be one the job has
/// cut.
fn entry(skipped: &[Op], e: Entry) -> Vec<Op> {
    let origin = e.origin;
    let mut out = Vec::new();
    let mut outputs: Vec<OutputSwitch> = Vec::new();
    let mut speed = None;
    let mut offset = None;
    for op in skipped {
        match op {
            Op::Output(o) => match outputs.iter_mut().find(|x| x.address == o.address) {
                Some(x) => x.on = o.on,
                None => outputs.push(o.clone()),
            },
            Op::SpindleSpeed { rpm, .. } => speed = Some(*rpm),
            Op::WorkOffset { system, zero, .. } => offset = Some((*system, *zero)),
            _ => {}
        }
    }
    if let Some((system, zero)) = offset {
        out.push(Op::WorkOffset {
            system,
            zero,
            origin,
        });
    }
    // Where the tool stands is the controller's business: after the
    // program's reference run it is the reference point; without one the
    // program assumes the tool above or in the start point, as deep as the
    // job goes at the worst, so that the writers never leave the retract out.
    let from = if e.reference_first {
        Point::default()
    } else {
        Point {
            z: e.deepest.min(e.safe_z - 1.0),
            ..e.start
        }
    };
    let up = Point {
        z: e.safe_z,
        ..from
    };
    let above = Point {
        z: e.safe_z,
        ..e.start
    };
    out.push(Op::Rapid(Rapid {
        from,
        to: up,
        origin,
    }));
    out.push(Op::Rapid(Rapid {
        from: up,
        to: above,
        origin,
    }));
    if let Some(rpm) = speed {
        out.push(Op::SpindleSpeed { rpm, origin });
    }
    for o in outputs {
        out.push(Op::Output(OutputSwitch { origin, ..o }));
    }
    out.push(Op::Line(Line {
        from: above,
        to: e.start,
        feed: e.feed,
        origin,
    }));
    out
}

impl Restart {
    /// mm per unit of the file (G20 or G21 in force at the line).
    fn unit(&self) -> f64 {
        self.modal.units.map_or(1.0, Units::mm)
    }

    /// Decimals a coordinate is said with: a step of 0.001 mm or 0.0001 in.
    pub fn places(&self) -> usize {
        if self.unit() > 1.0 { 4 } else { 3 }
    }

    /// A machine point in the file's work coordinates and unit, as the
    /// file would write it.
    pub fn work(&self, p: Point) -> [f64; 3] {
        let u = self.unit();
        [
            (p.x - self.zero.x) / u,
            (p.y - self.zero.y) / u,
            (p.z - self.zero.z) / u,
        ]
    }

    /// The entry as the confirmation says it, every step in the order it
    /// runs, in the file's work coordinates and unit. `run`: said by
    /// `jogterm run`, which moves the tool up itself before the program
    /// (`cli::run::retract`); else the written program's steps alone.
    pub fn entry_text(&self, run: bool) -> Vec<String> {
        let w = |p: Point| {
            let [x, y, z] = self.work(p);
            Point { x, y, z }
        };
        let places = self.places();
        let safe = w(Point {
            z: self.safe_z,
            ..Point::default()
        })
        .z;
        let mut out = Vec::new();
        if run {
            out.push(format!(
                "retract: Z alone up to Z{safe:.places$} (the job's safe height), from wherever the tool stands, before anything else moves (jogterm, before the program)"
            ));
        }
        if self.reference_first {
            let order = match self.target {
                Target::Isel => "Z, then Y, then X",
                Target::Emcu => "Z, then X, then Y",
            };
            out.push(format!(
                "reference run of {order} (gcode.reference_first): the program's moves count from the reference point"
            ));
        }
        let mut rapids = 0;
        for op in &self.entry {
            match op {
                // The entry's order (`entry`): up, above the start, descend.
                Op::Rapid(m) if rapids == 0 => {
                    rapids += 1;
                    if self.reference_first {
                        out.push(format!(
                            "G0 Z{:.places$} (the job's safe height) from the reference point, Z alone",
                            w(m.to).z
                        ));
                    } else if !run {
                        // Absolute moves name every axis (isel `m`): a
                        // written program cannot know where the tool stands.
                        out.push(format!(
                            "retract: G0 Z{:.places$} (the job's safe height) straight up from X{:.places$} Y{:.places$}, line {}'s start: the program cannot know where the tool stands (`jogterm run --from-line` moves it up, Z alone, from wherever it stands first)",
                            w(m.to).z,
                            w(m.to).x,
                            w(m.to).y,
                            self.line
                        ));
                    }
                }
                Op::Rapid(m) => {
                    rapids += 1;
                    out.push(format!(
                        "G0 X{:.places$} Y{:.places$} at the safe height, above line {}'s start",
                        w(m.to).x,
                        w(m.to).y,
                        self.line
                    ));
                }
                Op::SpindleSpeed { rpm, .. } => out.push(format!("spindle speed S{rpm}")),
                Op::Output(o) => {
                    out.push(format!("{} {}", o.name, if o.on { "on" } else { "off" }))
                }
                Op::Line(m) => out.push(format!(
                    "descend: G1 Z{:.places$} F{} to line {}'s start ({})",
                    w(m.to).z,
                    number(m.feed / self.unit()),
                    self.line,
                    match self.plunge_line {
                        Some(line) => format!("the file's last plunge feed, line {line}"),
                        None => "the profile's plunge feed, gcode.plunge_feed: the file plunges nowhere before the line".to_owned(),
                    }
                )),
                _ => {}
            }
        }
        out
    }
}
