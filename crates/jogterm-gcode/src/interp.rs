//! The interpreter: blocks to a [`Toolpath`] of machine moves, with one
//! modal state grouped as RS-274/NGC groups it (`docs/gcode.md`, "The
//! supported subset").
//!
//! Within a block the order is RS-274/NGC's (3.8): feed, spindle speed,
//! tool, tool change, spindle, coolant, outputs, dwell, plane, units,
//! distance modes, coordinate system, motion, stops. Everything jogterm
//! cannot do faithfully is an error at the word that asks for it, never a
//! guess: the diagnostics say what the code is and why it is refused.

use std::f64::consts::PI;

#[cfg(test)]
#[path = "interp_tests.rs"]
mod tests;

use crate::offsets::System;
use jogterm_proto::axis::Axis;

use super::modal::{Modal, Spindle};
use super::reader::{Block, Word};
use super::setup::{CodeRule, Setup, Units};
use super::toolpath::{
    Arc, Diagnostic, Dwell, Line, Op, Origin, OutputSwitch, Pause, Plane, Point, Rapid, Severity,
    Toolpath,
};

/// LinuxCNC's rule for an arc's end on its circle: the radii to start and
/// to end may differ by at most 2 x 0.01 x sqrt 2 mm, or 2 x 0.001 x sqrt 2
/// in in G20 (CENTER_ARC_RADIUS_TOLERANCE_MM/_INCH, rs274ngc).
const ARC_RADIUS_TOLERANCE_MM: f64 = 0.028_284_271;
const ARC_RADIUS_TOLERANCE_INCH: f64 = 0.002_828_427;

/// G83's retract clearance above the last depth (LinuxCNC: 0.010 in).
const PECK_CLEARANCE_MM: f64 = 0.254;

/// The most errors one file reports; the rest are counted.
pub const ERROR_LIMIT: usize = 50;

/// Bounds on the work one line may ask for, checked before any of it is
/// done (issue 37: `P100000000` turns or a dwell of 400 nines grew past
/// 13 GB). A helix of 1000 turns is 2000 isel commands, a whole program
/// memory; a day of dwell is longer than any job waits; 1000 pecks of one
/// hole is more than any drill takes.
pub const MAX_TURNS: f64 = 1000.0;
pub const MAX_DWELL_S: f64 = 86_400.0;
pub const MAX_PECKS: f64 = 1000.0;
/// The most toolpath moves a file makes (a 16 MiB CAM file of half a
/// million lines makes about as many).
pub const MAX_OPS: usize = 2_000_000;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Motion {
    Rapid,
    Feed,
    ArcCw,
    ArcCcw,
    Drill,      // G81
    DrillDwell, // G82
    Peck,       // G83
    None,       // G80
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Retract {
    Initial, // G98
    RPlane,  // G99
}

/// The modal state between blocks.
#[derive(Debug, Clone)]
struct State {
    motion: Motion,
    plane: Plane,
    units: Option<Units>,
    absolute: bool,
    arc_absolute: bool,
    system: System,
    retract: Retract,
    /// The Z the cycle started from (G98 returns there).
    cycle_initial_z: Option<f64>,
    cycle_r: Option<f64>,
    cycle_z: Option<f64>,
    cycle_q: Option<f64>,
    cycle_p: Option<f64>,
    feed: Option<f64>,
    tool: Option<u32>,
    /// What M3-M5, S and M7-M9 left, for a restart's confirmation
    /// (`modal_before`): the ops say only which outputs switched.
    spindle: Spindle,
    speed: Option<f64>,
    mist: bool,
    flood: bool,
    /// Machine mm.
    position: Point,
    ended: bool,
    /// The G80 that cancelled the motion mode, if one did.
    cancelled_by: Option<Origin>,
}

/// What an earlier line that failed may have changed unseen (issue 37:
/// one error cascaded into false ones). A line that could not be read may
/// have held any word; a G word refused may have been a mode; a move that
/// failed left the position where it was. While a fact is in doubt, the
/// errors that depend on it are not reported (the file has an error
/// already, so nothing runs); the line that sets the fact again clears it.
#[derive(Debug, Clone, Copy, Default)]
struct Doubt {
    feed: bool,
    motion: bool,
    units: bool,
    plane: bool,
    distance: bool,
    /// X, Y, Z positions.
    axes: [bool; 3],
}

impl Doubt {
    fn everything() -> Doubt {
        Doubt {
            feed: true,
            motion: true,
            units: true,
            plane: true,
            distance: true,
            axes: [true; 3],
        }
    }

    fn modes(&mut self) {
        self.motion = true;
        self.units = true;
        self.plane = true;
        self.distance = true;
    }
}

/// G and M codes as tenths (G90.1 is 901), so that equality is exact.
fn code_of(word: &Word) -> Option<u32> {
    let tenths = super::num::round(word.value * 10.0);
    if (tenths - word.value * 10.0).abs() > 1e-6 || !(0.0..=99_999.0).contains(&tenths) {
        return None;
    }
    Some(tenths as u32)
}

fn code_name(letter: char, code: u32) -> String {
    if code.is_multiple_of(10) {
        format!("{letter}{}", code / 10)
    } else {
        format!("{letter}{}.{}", code / 10, code % 10)
    }
}

/// The `[gcode]` table's key of a code (`g28`, `m7`, `g38.2`: the name in
/// lower case) written into `buf`; `None` if it did not fit (codes go up
/// to 9999.9, which always fits).
fn code_key(letter: char, code: u32, buf: &mut [u8; 16]) -> Option<&str> {
    use std::io::Write as _;
    let letter = letter.to_ascii_lowercase();
    let mut cursor = std::io::Cursor::new(&mut buf[..]);
    let written = if code.is_multiple_of(10) {
        write!(cursor, "{letter}{}", code / 10)
    } else {
        write!(cursor, "{letter}{}.{}", code / 10, code % 10)
    };
    written.ok()?;
    let len = usize::try_from(cursor.position()).ok()?;
    std::str::from_utf8(buf.get(..len)?).ok()
}

/// RS-274/NGC's modal groups of the G codes jogterm knows (refused ones
/// included, so that a conflict is named before the refusal).
fn g_group(code: u32) -> Option<u8> {
    Some(match code {
        0 | 10 | 20 | 30 | 800 | 810 | 820 | 830 | 382..=385 => 1,
        40 | 280 | 300 | 530 | 100 | 920 | 921 | 922 | 923 => 0,
        170 | 180 | 190 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 | 410 | 420 | 411 | 421 => 7,
        430 | 431 | 490 => 8,
        980 | 990 => 10,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => 12,
        610 | 611 | 640 => 13,
        _ => return None,
    })
}

fn m_group(code: u32) -> Option<u8> {
    Some(match code {
        0 | 10 | 20 | 300 | 600 => 4,
        60 => 6,
        30 | 40 | 50 => 7,
        70 | 80 | 90 => 8,
        620 | 630 | 640 | 650 => 5,
        _ => return None,
    })
}

/// Why jogterm refuses a G code it knows.
fn refused_g(code: u32) -> Option<&'static str> {
    Some(match code {
        410 | 420 | 411 | 421 => {
            "cutter radius compensation is refused: jogterm has no tool table; let the CAM post compensate (\"in computer\")"
        }
        430 | 431 => {
            "tool length offsets are refused: jogterm has no tool table; set the tool's Z zero with the work offset"
        }
        930 => "inverse time feed is refused: jogterm runs feeds in units per minute (G94)",
        950 => "feed per revolution is refused: the controller does not know the spindle speed",
        280 | 300 => {
            "G28/G30 go to a position this profile does not name: map the code in the profile's [gcode] table (\"ignore\") or let the CAM post leave it out"
        }
        100 => "G10 writes offsets and tools: jogterm's work offsets are set in the console (O, s)",
        920..=923 => "G92 offsets are refused: use jogterm's work offsets G54-G59",
        382..=385 => "probing is refused: jogterm runs no probe moves from G-code",
        591..=593 => "G59.1-G59.3 are refused: jogterm has the work offsets G54-G59",
        _ => return None,
    })
}

pub struct Interpreter<'a> {
    setup: &'a Setup,
    state: State,
    ops: Vec<Op>,
    errors: Vec<Diagnostic>,
    warnings: Vec<Diagnostic>,
    more_errors: usize,
    warned_block_delete: bool,
    warned_ignored: Vec<u32>,
    /// The file has said G20 or G21: a number read before that takes the
    /// profile's unit, which the summary must say (issue 40).
    units_from_file: bool,
    warned_profile_unit: bool,
    /// `Toolpath::named_from` as it grows.
    named_from: [Option<usize>; 3],
    /// The last block's `Words`, emptied and filled again by the next
    /// block: one set of vectors for the file instead of new ones a block.
    spare: Words,
    /// The modal groups of a block's G and M codes, reused from block to
    /// block as `spare` is (no allocation a line).
    groups: (Groups, Groups),
    doubt: Doubt,
    /// The `[gcode]` table's rule of each G and M code met so far: a file
    /// names a few dozen codes, on a hundred thousand lines.
    code_rules: Vec<(char, u32, Option<&'a CodeRule>)>,
    /// A work offset op has been made (the first move makes one if not).
    offset_made: bool,
}

/// The most codes whose rule `Interpreter::code_rule` keeps; any other is
/// looked up every time.
const CODE_RULES_KEPT: usize = 64;

/// A block's G or M codes by modal group, to find two of one group.
type Groups = Vec<(u8, Word)>;

/// Interprets a read file (the reader's errors first).
pub fn interpret(text: &str, setup: &Setup) -> Result<Toolpath, Vec<Diagnostic>> {
    // The blocks as the reader makes them, one at a time (a long file's
    // read ahead on another thread).
    crate::ahead::with_blocks(text, |blocks| interpret_blocks(text, blocks, setup))
}

/// [`interpret`] with the blocks always read ahead in chunks of
/// `chunk_blocks`, however short the text: what `interpret` does for long
/// files, for the tests.
#[cfg(test)]
pub(crate) fn interpret_ahead(
    text: &str,
    setup: &Setup,
    chunk_blocks: usize,
) -> Result<Toolpath, Vec<Diagnostic>> {
    crate::ahead::with_blocks_ahead(text, chunk_blocks, |blocks| {
        interpret_blocks(text, blocks, setup)
    })
}

fn interpret_blocks(
    text: &str,
    blocks: &mut dyn crate::ahead::Source,
    setup: &Setup,
) -> Result<Toolpath, Vec<Diagnostic>> {
    let mut it = Interpreter::new(setup);
    // About an op a line in CAM files: the ops' vector sized once, not
    // grown by doubling through copies of half a million ops.
    let newlines = memchr::memchr_iter(b'\n', text.as_bytes()).count();
    it.ops.reserve((newlines + newlines / 16 + 16).min(MAX_OPS));
    let mut anything = false;
    // The reader's errors in line order among the interpreter's: a line
    // that could not be read may have held any word.
    let mut unread = Vec::new();
    while let Some(item) = blocks.next() {
        anything = true;
        let block = match item {
            Ok(block) => block,
            Err(e) => {
                unread.push(e);
                continue;
            }
        };
        for e in unread.drain(..) {
            it.error_diag(e);
            it.doubt = Doubt::everything();
        }
        if it.ops.len() > MAX_OPS {
            it.error(
                block.origin(),
                format!(
                    "the toolpath has more than {MAX_OPS} moves by this line: split the job in the CAM"
                ),
            );
            break;
        }
        if it.state.ended {
            if !block.words.is_empty() {
                it.warn(
                    block.origin(),
                    "after M2/M30: this line and the rest of the file are not run",
                );
                break;
            }
            blocks.recycle(block);
            continue;
        }
        it.block(&block);
        blocks.recycle(block);
    }
    // The errors of lines after the last block run, and of the lines not
    // run (read to the end for them and for the count of lines).
    for e in unread {
        it.error_diag(e);
    }
    for item in &mut *blocks {
        anything = true;
        if let Err(e) = item {
            it.error_diag(e);
        }
    }
    if !anything {
        it.error(
            Origin { line: 1, col: 1 },
            "the file holds no G-code: nothing to run",
        );
    }
    it.finish(blocks.lines())
}

/// The modal state the lines before `line` (1-based) leave in force: the
/// interpreter run over them alone. For a file that imports (its errors
/// were reported there); a line beyond the file gives the state at its end.
pub fn modal_before(text: &str, setup: &Setup, line: u32) -> Modal {
    let read = super::reader::read(text);
    let mut it = Interpreter::new(setup);
    for block in read.blocks.iter().take_while(|b| b.line < line) {
        if it.state.ended {
            break;
        }
        it.block(block);
    }
    it.modal()
}

impl<'a> Interpreter<'a> {
    fn new(setup: &'a Setup) -> Interpreter<'a> {
        Interpreter {
            setup,
            state: State {
                motion: Motion::None,
                plane: Plane::Xy,
                units: setup.default_units,
                absolute: true,
                arc_absolute: false,
                system: setup.active,
                retract: Retract::Initial,
                cycle_initial_z: None,
                cycle_r: None,
                cycle_z: None,
                cycle_q: None,
                cycle_p: None,
                feed: None,
                tool: None,
                spindle: Spindle::Off,
                speed: None,
                mist: false,
                flood: false,
                position: setup.start,
                ended: false,
                cancelled_by: None,
            },
            ops: Vec::new(),
            errors: Vec::new(),
            warnings: Vec::new(),
            more_errors: 0,
            warned_block_delete: false,
            warned_ignored: Vec::new(),
            named_from: [None; 3],
            spare: Words::default(),
            groups: (Vec::new(), Vec::new()),
            doubt: Doubt::default(),
            code_rules: Vec::new(),
            offset_made: false,
            units_from_file: false,
            warned_profile_unit: false,
        }
    }

    fn finish(mut self, lines: u32) -> Result<Toolpath, Vec<Diagnostic>> {
        // In line order (a block's own errors are found in the order of
        // its checks, not of its columns).
        self.errors.sort_by_key(|e| e.origin);
        if self.more_errors > 0 {
            let last = self.errors.last().map(|e| e.origin).unwrap_or_default();
            self.errors.push(Diagnostic {
                severity: Severity::Error,
                origin: last,
                message: format!("{} more errors not shown", self.more_errors),
            });
        }
        if !self.errors.is_empty() {
            return Err(self.errors);
        }
        if !self.state.ended {
            self.ops.push(Op::End {
                origin: Origin {
                    line: lines.max(1),
                    col: 1,
                },
            });
        }
        let never = self.ops.len();
        Ok(Toolpath {
            named_from: self.named_from.map(|n| n.unwrap_or(never)),
            ops: self.ops,
            lines,
            warnings: self.warnings,
        })
    }

    fn error_diag(&mut self, d: Diagnostic) {
        if self.errors.len() >= ERROR_LIMIT {
            self.more_errors += 1;
        } else {
            self.errors.push(d);
        }
    }

    fn error(&mut self, origin: Origin, message: impl Into<String>) {
        self.error_diag(Diagnostic::error(origin, message));
    }

    fn warn(&mut self, origin: Origin, message: impl Into<String>) {
        self.warnings.push(Diagnostic::warning(origin, message));
    }

    fn block(&mut self, block: &Block) {
        if block.deleted && !self.warned_block_delete {
            self.warned_block_delete = true;
            self.warn(
                block.origin(),
                "`/` block delete: jogterm runs the block (the block delete switch is off, RS-274/NGC's default)",
            );
        }
        // The words that are valid take effect even when others on the
        // line are refused, so that one error does not make more.
        let errors_before = self.errors.len() + self.more_errors;
        let words = self.sort(block);
        let position = self.state.position;
        self.execute(block, &words);
        let failed = self.errors.len() + self.more_errors > errors_before;
        if failed && words.any_axis() && self.state.position == position {
            // The line's move was not made: where the tool stands is unsure.
            self.doubt.axes = [true; 3];
        }
        self.spare = words;
    }

    /// Splits a block's words into codes and values, with the checks that
    /// need the whole block: one word of each letter, one code per group.
    fn sort(&mut self, block: &Block) -> Words {
        let mut w = std::mem::take(&mut self.spare);
        w.clear();
        let (mut g_groups, mut m_groups) = std::mem::take(&mut self.groups);
        g_groups.clear();
        m_groups.clear();
        for word in &block.words {
            match word.letter {
                'G' | 'M' => {
                    let Some(code) = code_of(word) else {
                        self.error(
                            word.origin,
                            format!("`{}{}` is no code", word.letter, word.value),
                        );
                        self.doubt.modes();
                        continue;
                    };
                    // The code's name is built only where a message or a
                    // mapping needs it, and the table's key on the stack:
                    // this runs for every G and M word of the file.
                    let name = || code_name(word.letter, code);
                    if let Some(rule) = self.code_rule(word.letter, code) {
                        match rule {
                            CodeRule::Ignore => {
                                if !self.warned_ignored.contains(&code) {
                                    self.warned_ignored.push(code);
                                    self.warn(
                                        word.origin,
                                        format!("{} is ignored, as the profile's [gcode] table says (first at this line)", name()),
                                    );
                                }
                                continue;
                            }
                            CodeRule::Output(target) => {
                                w.mapped.push((*word, name(), target.clone()));
                                continue;
                            }
                        }
                    }
                    let group = if word.letter == 'G' {
                        g_group(code)
                    } else {
                        m_group(code)
                    };
                    let Some(group) = group else {
                        self.doubt.modes();
                        self.error(
                            word.origin,
                            format!(
                                "{} is not supported by jogterm's G-code import (docs/gcode.md lists what is)",
                                name()
                            ),
                        );
                        continue;
                    };
                    let groups = if word.letter == 'G' {
                        &mut g_groups
                    } else {
                        &mut m_groups
                    };
                    // Group 0 (non-modal) codes may share a line unless equal;
                    // M7 and M8 may too (both coolants on).
                    let conflict = groups.iter().find(|(g, other)| {
                        *g == group
                            && (group != 0 || code_of(other) == Some(code))
                            && !(word.letter == 'M'
                                && group == 8
                                && matches!(
                                    (code_of(other), code),
                                    (Some(70), 80) | (Some(80), 70)
                                ))
                    });
                    if let Some((_, other)) = conflict {
                        let other_name =
                            code_of(other).map_or_else(String::new, |c| code_name(other.letter, c));
                        self.error(
                            word.origin,
                            format!(
                                "{} and {other_name} (column {}) are of one modal group: a line may hold only one of them",
                                name(),
                                other.origin.col
                            ),
                        );
                        continue;
                    }
                    groups.push((group, *word));
                    if word.letter == 'G' {
                        w.g.push((code, *word));
                    } else {
                        w.m.push((code, *word));
                    }
                }
                'N' => {}
                letter => {
                    if let Some(first) = w.values.iter().find(|v| v.letter == letter) {
                        self.error(
                            word.origin,
                            format!(
                                "`{letter}` twice on one line (first at column {})",
                                first.origin.col
                            ),
                        );
                        continue;
                    }
                    match letter {
                        'X' | 'Y' | 'Z' | 'I' | 'J' | 'K' | 'R' | 'F' | 'S' | 'T' | 'P' | 'Q'
                        | 'L' => w.values.push(*word),
                        'A' | 'B' | 'C' | 'U' | 'V' | 'W' => self.error(
                            word.origin,
                            format!(
                                "axis {letter} is refused: jogterm's G-code import moves X, Y and Z"
                            ),
                        ),
                        'D' | 'H' => self.error(
                            word.origin,
                            format!(
                                "`{letter}` selects a tool offset: jogterm has no tool table (no G41/G42/G43)"
                            ),
                        ),
                        _ => self.error(
                            word.origin,
                            format!("`{letter}` is not a word jogterm's G-code import reads"),
                        ),
                    }
                }
            }
        }
        // A refused code stays out of the block's codes: nothing it would
        // do is done, and what it might have changed is in doubt.
        // (Most lines hold no G code, and hardly any a refused one.)
        if w.g.iter().any(|(code, _)| refused_g(*code).is_some()) {
            let refused: Vec<(u32, Word)> =
                w.g.iter()
                    .filter(|(code, _)| refused_g(*code).is_some())
                    .copied()
                    .collect();
            for (code, word) in &refused {
                if let Some(why) = refused_g(*code) {
                    let name = code_name('G', *code);
                    self.error(word.origin, format!("{name}: {why}"));
                    self.doubt.modes();
                    self.doubt.axes = [true; 3];
                }
            }
            w.g.retain(|(code, _)| refused_g(*code).is_none());
        }
        self.groups = (g_groups, m_groups);
        w
    }

    fn execute(&mut self, block: &Block, w: &Words) {
        let origin = block.origin();
        // Feed (G94 is the only feed mode).
        // A refused F, S or T is left out; the rest of the line runs.
        if let Some(f) = w.value('F') {
            if f.value <= 0.0 {
                self.error(f.origin, "F must be a feed above 0");
            } else {
                let scale = self.units_at(f.origin);
                self.state.feed = Some(f.value * scale);
                self.doubt.feed = false;
            }
        }
        if let Some(s) = w.value('S') {
            if s.value < 0.0 {
                self.error(s.origin, "S must not be negative");
            } else {
                self.state.speed = Some(s.value);
                self.ops.push(Op::SpindleSpeed {
                    rpm: s.value,
                    origin: s.origin,
                });
            }
        }
        if let Some(t) = w.value('T') {
            if t.value < 0.0 || t.value.fract() != 0.0 {
                self.error(t.origin, "T must be a tool number");
            } else {
                self.state.tool = Some(t.value as u32);
            }
        }
        if let Some(m6) = w.m_code(60) {
            self.ops.push(Op::Pause(Pause::ToolChange {
                tool: self.state.tool,
                origin: m6.origin,
            }));
        }
        for (code, word) in &w.m {
            self.note_m(*code);
            match code {
                30 | 40 => self.switch("spindle", true, *code, word),
                50 => self.switch("spindle", false, *code, word),
                70 | 80 => self.switch("coolant", true, *code, word),
                90 => self.switch("coolant", false, *code, word),
                620..=650 => self.numbered_output(*code, word, w),
                _ => {}
            }
        }
        for (word, name, target) in &w.mapped {
            if let Some(code) = code_of(word) {
                self.note_m(code);
            }
            let on = !matches!(
                name.to_ascii_uppercase().as_str(),
                "M5" | "M9" | "M63" | "M65"
            );
            self.output_op(target, on, *word);
        }
        // Dwell.
        if let Some(g4) = w.g_code(40) {
            match w.value('P') {
                Some(p) if (0.0..=MAX_DWELL_S).contains(&p.value) => {
                    self.ops.push(Op::Dwell(Dwell {
                        seconds: p.value,
                        origin: g4.origin,
                    }))
                }
                Some(p) => self.error(
                    p.origin,
                    format!("G4 P must be a time in seconds, 0 to {MAX_DWELL_S} (a day)"),
                ),
                None => self.error(g4.origin, "G4 needs P: the dwell in seconds"),
            }
        }
        for (code, word) in &w.g {
            match code {
                170 | 180 | 190 => {
                    self.state.plane = match code {
                        170 => Plane::Xy,
                        180 => Plane::Zx,
                        _ => Plane::Yz,
                    };
                    self.doubt.plane = false;
                }
                200 | 210 => {
                    self.state.units = Some(if *code == 200 {
                        Units::Inch
                    } else {
                        Units::Mm
                    });
                    self.doubt.units = false;
                    self.units_from_file = true;
                }
                900 | 910 => {
                    self.state.absolute = *code == 900;
                    self.doubt.distance = false;
                }
                901 => self.state.arc_absolute = true,
                911 => self.state.arc_absolute = false,
                980 => self.state.retract = Retract::Initial,
                990 => self.state.retract = Retract::RPlane,
                540..=590 => {
                    if let Some(system) = System::from_index(((code - 540) / 10) as usize)
                        && (system != self.state.system || self.ops.is_empty())
                    {
                        self.state.system = system;
                        self.push_offset(word.origin);
                    }
                }
                640 => self.warn(
                    word.origin,
                    "G64 path blending: the controller ramps down at the end of every command; jogterm merges near-collinear cuts instead (gcode.merge_tolerance)",
                ),
                _ => {}
            }
        }
        let machine = w.g_code(530).is_some();
        // Motion.
        let mut motion = self.state.motion;
        let mut motion_word = None;
        for (code, word) in &w.g {
            let m = match code {
                0 => Motion::Rapid,
                10 => Motion::Feed,
                20 => Motion::ArcCw,
                30 => Motion::ArcCcw,
                800 => Motion::None,
                810 => Motion::Drill,
                820 => Motion::DrillDwell,
                830 => Motion::Peck,
                _ => continue,
            };
            motion = m;
            motion_word = Some(*word);
        }
        if let Some(word) = motion_word {
            let was_cycle = is_cycle(self.state.motion);
            self.state.motion = motion;
            self.doubt.motion = false;
            self.state.cancelled_by = (motion == Motion::None).then_some(word.origin);
            if !is_cycle(motion) || !was_cycle {
                self.state.cycle_initial_z = None;
            }
            if !is_cycle(motion) {
                self.state.cycle_r = None;
                self.state.cycle_z = None;
                self.state.cycle_q = None;
                self.state.cycle_p = None;
            }
        }
        let has_axes = w.any_axis();
        if machine && (!matches!(motion, Motion::Rapid | Motion::Feed) || !has_axes) {
            let at = w.g_code(530).map_or(origin, |g| g.origin);
            self.error(
                at,
                "G53 moves in machine coordinates with G0 or G1 and axis words only",
            );
            return;
        }
        if has_axes || (motion_word.is_some() && matches!(motion, Motion::ArcCw | Motion::ArcCcw)) {
            let at = motion_word
                .map_or_else(|| w.first_axis().map_or(origin, |a| a.origin), |m| m.origin);
            match motion {
                Motion::None => {
                    if has_axes && !self.doubt.motion {
                        let why = match self.state.cancelled_by {
                            Some(g80) => format!(" (G80 at line {} cancelled it)", g80.line),
                            None => " (the file has given none yet)".to_owned(),
                        };
                        self.error(
                            at,
                            format!("axis words with no motion mode in force{why}: give G0 or G1"),
                        );
                    }
                    if has_axes {
                        self.doubt.axes = [true; 3];
                    }
                }
                Motion::Rapid | Motion::Feed => self.straight(motion, w, at, machine),
                Motion::ArcCw | Motion::ArcCcw => self.arc(motion == Motion::ArcCw, w, at),
                Motion::Drill | Motion::DrillDwell | Motion::Peck => self.cycle(motion, w, at),
            }
        } else if w.has_any(&['I', 'J', 'K', 'R']) && !is_cycle(motion) {
            let at = w
                .values
                .iter()
                .find(|v| matches!(v.letter, 'I' | 'J' | 'K' | 'R'))
                .map_or(origin, |v| v.origin);
            self.error(
                at,
                "arc words (I J K R) with no end point: an arc needs X, Y or Z",
            );
        }
        // Stops last.
        for (code, word) in &w.m {
            match code {
                0 => self.ops.push(Op::Pause(Pause::Program {
                    origin: word.origin,
                })),
                10 => self.ops.push(Op::Pause(Pause::Optional {
                    origin: word.origin,
                })),
                20 | 300 => {
                    self.ops.push(Op::End {
                        origin: word.origin,
                    });
                    self.state.ended = true;
                }
                600 => self.error(
                    word.origin,
                    "M60 (pallet change) is refused: the machine has no pallet changer jogterm knows",
                ),
                _ => {}
            }
        }
    }

    /// mm per file unit; when the file never said, an error (once) and
    /// millimetres from here on, so that the lines after it are read as
    /// they would be with G21 and report only their own errors.
    fn units_at(&mut self, at: Origin) -> f64 {
        match self.state.units {
            Some(u) => {
                if !self.units_from_file && !self.warned_profile_unit {
                    self.warned_profile_unit = true;
                    let name = match u {
                        Units::Mm => "millimetres",
                        Units::Inch => "inches",
                    };
                    self.warn(
                        at,
                        format!(
                            "the file sets no unit (G20 or G21): its numbers are read in {name}, the profile's [gcode] unit"
                        ),
                    );
                }
                u.mm()
            }
            None => {
                if !self.doubt.units {
                    self.error(
                        at,
                        "the file sets no unit (G20 inch or G21 mm) before its first number with a unit, and the profile names none ([gcode] unit = \"mm\")",
                    );
                }
                self.state.units = Some(Units::Mm);
                Units::Mm.mm()
            }
        }
    }

    fn zero(&self) -> Point {
        self.setup.zero(self.state.system)
    }

    fn push_offset(&mut self, origin: Origin) {
        self.ops.push(Op::WorkOffset {
            system: self.state.system,
            zero: self.zero(),
            origin,
        });
        self.offset_made = true;
    }

    fn ensure_offset(&mut self, origin: Origin) {
        if !self.offset_made {
            self.push_offset(origin);
        }
    }

    /// The `[gcode]` table's rule of a G or M code, if it maps it: looked
    /// up by the code's name once a code (this runs for every G and M word
    /// of the file).
    fn code_rule(&mut self, letter: char, code: u32) -> Option<&'a CodeRule> {
        if let Some(&(.., rule)) = self
            .code_rules
            .iter()
            .find(|(l, c, _)| *l == letter && *c == code)
        {
            return rule;
        }
        let setup: &'a Setup = self.setup;
        let mut key = [0u8; 16];
        let rule = code_key(letter, code, &mut key).and_then(|key| setup.codes.get(key));
        if self.code_rules.len() < CODE_RULES_KEPT {
            self.code_rules.push((letter, code, rule));
        }
        rule
    }

    /// The file names `axis` from the next op on.
    fn name_axis(&mut self, axis: Axis) {
        let index = self.ops.len();
        if let Some(slot) = self.named_from.get_mut(axis_index(axis)) {
            slot.get_or_insert(index);
        }
    }

    /// The target of the block's axis words in machine mm.
    fn target(&mut self, w: &Words, machine: bool) -> Option<Point> {
        let scale = self.units_at(w.first_axis()?.origin);
        let mut p = self.state.position;
        let zero = if machine {
            Point::default()
        } else {
            self.zero()
        };
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            let Some(word) = w.value(axis.letter()) else {
                continue;
            };
            if !self.setup.axes.contains(&axis) {
                self.error(word.origin, format!("this machine has no {axis} axis"));
                return None;
            }
            self.name_axis(axis);
            let v = word.value * scale;
            if (machine || (self.state.absolute && !self.doubt.distance))
                && let Some(d) = self.doubt.axes.get_mut(axis_index(axis))
            {
                *d = false;
            }
            let c = if self.state.absolute || machine {
                v + get(zero, axis)
            } else {
                get(p, axis) + v
            };
            set(&mut p, axis, c);
        }
        Some(p)
    }

    /// The feed in force; before any F an error (once), and the move is
    /// made all the same so that the lines after it start where it ends.
    fn feed_at(&mut self, at: Origin) -> f64 {
        if let Some(feed) = self.state.feed {
            return feed;
        }
        if !self.doubt.feed {
            self.error(
                at,
                "a feed move before any F: give the feed (F, units per minute)",
            );
        }
        self.doubt.feed = true;
        self.state.feed = Some(1.0);
        1.0
    }

    fn straight(&mut self, motion: Motion, w: &Words, at: Origin, machine: bool) {
        let Some(to) = self.target(w, machine) else {
            return;
        };
        self.ensure_offset(at);
        let from = self.state.position;
        if motion == Motion::Rapid {
            self.ops.push(Op::Rapid(Rapid {
                from,
                to,
                origin: at,
            }));
        } else {
            let feed = self.feed_at(at);
            self.ops.push(Op::Line(Line {
                from,
                to,
                feed,
                origin: at,
            }));
        }
        self.state.position = to;
    }

    fn arc(&mut self, clockwise: bool, w: &Words, at: Origin) {
        let plane = self.state.plane;
        let (u_axis, v_axis, n_axis) = plane_axes(plane);
        let offset_letters = offset_letters(plane);
        // Where the arc starts, its plane or its unit may be what a failed
        // line left unsure: then its geometry is not checked (the file has
        // an error already) and the tool goes on from its end.
        let d = self.doubt;
        let unsure = d.plane
            || d.units
            || d.distance
            || d.axes[axis_index(u_axis)]
            || d.axes[axis_index(v_axis)];
        let scale = self.units_at(at);
        let to = if w.any_axis() {
            match self.target(w, false) {
                Some(p) => p,
                None => return,
            }
        } else {
            self.state.position
        };
        let feed = self.feed_at(at);
        let from = self.state.position;
        let fail = |it: &mut Interpreter, origin: Origin, why: String| {
            if !unsure {
                it.error(origin, why);
            }
            // The end is the file's, arc or not.
            it.state.position = to;
        };
        let (su, sv) = (get(from, u_axis), get(from, v_axis));
        let (eu, ev) = (get(to, u_axis), get(to, v_axis));
        let radius_word = w.value('R');
        let no_offsets = offset_letters.iter().all(|l| w.value(*l).is_none());
        let wrong_plane: Option<&Word> = w
            .values
            .iter()
            .find(|v| matches!(v.letter, 'I' | 'J' | 'K') && !offset_letters.contains(&v.letter));
        if let Some(bad) = wrong_plane {
            let why = format!(
                "`{}` is not a centre offset of the plane in force ({}): it takes {} and {}",
                bad.letter,
                plane_name(plane),
                offset_letters[0],
                offset_letters[1]
            );
            fail(self, bad.origin, why);
            return;
        }
        let tolerance = if scale > 1.0 {
            ARC_RADIUS_TOLERANCE_INCH * scale
        } else {
            ARC_RADIUS_TOLERANCE_MM
        };
        let (cu, cv) = match (radius_word, no_offsets) {
            (Some(r), true) => {
                match r_centre(su, sv, eu, ev, r.value * scale, clockwise, tolerance) {
                    Ok(c) => c,
                    Err(why) => {
                        fail(self, r.origin, why);
                        return;
                    }
                }
            }
            (Some(r), false) => {
                self.error(
                    r.origin,
                    "an arc takes R or centre offsets (I J K), not both",
                );
                self.state.position = to;
                return;
            }
            (None, true) => {
                self.error(
                    at,
                    format!(
                        "an arc needs its centre ({} {}) or its radius (R)",
                        offset_letters[0], offset_letters[1]
                    ),
                );
                self.state.position = to;
                return;
            }
            (None, false) => {
                let off = |l: char| w.value(l).map_or(0.0, |v| v.value * scale);
                let (ou, ov) = (off(offset_letters[0]), off(offset_letters[1]));
                if self.state.arc_absolute {
                    let zero = self.zero();
                    (ou + get(zero, u_axis), ov + get(zero, v_axis))
                } else {
                    (su + ou, sv + ov)
                }
            }
        };
        if !plainly_on_circle((su, sv), (eu, ev), (cu, cv), tolerance) {
            let r0 = (su - cu).hypot(sv - cv);
            let r1 = (eu - cu).hypot(ev - cv);
            if r0 < 1e-9 {
                fail(
                    self,
                    at,
                    "the arc's centre is its start point: radius 0".into(),
                );
                return;
            }
            if (r0 - r1).abs() > tolerance {
                let unit = if scale > 1.0 { 25.4 } else { 1.0 };
                let name = if unit > 1.0 { "in" } else { "mm" };
                let why = format!(
                    "the arc's end is not on its circle: radius {:.4} {name} to the start, {:.4} {name} to the end (they may differ by {:.4} {name})",
                    r0 / unit,
                    r1 / unit,
                    tolerance / unit
                );
                fail(self, at, why);
                return;
            }
        }
        let turns = match w.value('P') {
            None => 1,
            Some(p) if (1.0..=MAX_TURNS).contains(&p.value) && p.value.fract() == 0.0 => {
                p.value as u32
            }
            Some(p) => {
                self.error(
                    p.origin,
                    format!("P of an arc is its number of turns: 1 to {MAX_TURNS}"),
                );
                self.state.position = to;
                return;
            }
        };
        let mut centre = from;
        set(&mut centre, u_axis, cu);
        set(&mut centre, v_axis, cv);
        set(&mut centre, n_axis, get(from, n_axis));
        self.ensure_offset(at);
        self.name_axis(u_axis);
        self.name_axis(v_axis);
        self.ops.push(Op::Arc(Box::new(Arc {
            from,
            to,
            centre,
            plane,
            clockwise,
            extra_turns: turns - 1,
            feed,
            origin: at,
        })));
        self.state.position = to;
    }

    fn cycle(&mut self, motion: Motion, w: &Words, at: Origin) {
        if self.state.plane != Plane::Xy {
            if !self.doubt.plane {
                self.error(at, "drilling cycles run in G17 (XY) only");
            }
            return;
        }
        if !self.state.absolute {
            if self.doubt.distance {
                return;
            }
            self.error(
                at,
                "drilling cycles in G91 (incremental) are refused: CAM posts write them in G90",
            );
            return;
        }
        if let Some(l) = w.value('L') {
            self.error(
                l.origin,
                "L (repeats of a cycle) is refused: write the holes out",
            );
            return;
        }
        let scale = self.units_at(at);
        let zero = self.zero();
        if let Some(r) = w.value('R') {
            self.state.cycle_r = Some(r.value * scale + zero.z);
        }
        if let Some(z) = w.value('Z') {
            self.state.cycle_z = Some(z.value * scale + zero.z);
        }
        if let Some(q) = w.value('Q') {
            if q.value <= 0.0 {
                self.error(q.origin, "G83's Q (peck depth) must be above 0");
                return;
            }
            self.state.cycle_q = Some(q.value * scale);
        }
        if let Some(p) = w.value('P') {
            if !(0.0..=MAX_DWELL_S).contains(&p.value) {
                self.error(
                    p.origin,
                    format!("P (dwell seconds) must be 0 to {MAX_DWELL_S} (a day)"),
                );
                return;
            }
            self.state.cycle_p = Some(p.value);
        }
        let (Some(r), Some(bottom)) = (self.state.cycle_r, self.state.cycle_z) else {
            self.error(at, "a drilling cycle needs R (retract plane) and Z (depth)");
            return;
        };
        if bottom > r {
            self.error(at, "the cycle's depth Z lies above its retract plane R");
            return;
        }
        if motion == Motion::Peck {
            let Some(q) = self.state.cycle_q else {
                self.error(at, "G83 needs Q (peck depth)");
                return;
            };
            if (r - bottom) / q > MAX_PECKS {
                let at = w.value('Q').map_or(at, |q| q.origin);
                self.error(
                    at,
                    format!(
                        "G83's Q makes more than {MAX_PECKS} pecks for this hole: give a deeper peck"
                    ),
                );
                return;
            }
        }
        let feed = self.feed_at(at);
        self.ensure_offset(at);
        let initial = *self
            .state
            .cycle_initial_z
            .get_or_insert(self.state.position.z);
        // The hole's XY: the block's (work coordinates), else where it stands.
        let mut hole = self.state.position;
        self.name_axis(Axis::Z);
        for axis in [Axis::X, Axis::Y] {
            if let Some(v) = w.value(axis.letter()) {
                self.name_axis(axis);
                set(&mut hole, axis, v.value * scale + get(zero, axis));
            }
        }
        let rapid = |it: &mut Interpreter, to: Point| {
            let from = it.state.position;
            it.ops.push(Op::Rapid(Rapid {
                from,
                to,
                origin: at,
            }));
            it.state.position = to;
        };
        if self.state.position.z < r {
            let p = Point {
                z: r,
                ..self.state.position
            };
            rapid(self, p);
        }
        rapid(
            self,
            Point {
                z: self.state.position.z,
                ..hole
            },
        );
        rapid(self, Point { z: r, ..hole });
        let feed_to = |it: &mut Interpreter, z: f64| {
            let from = it.state.position;
            let to = Point { z, ..from };
            it.ops.push(Op::Line(Line {
                from,
                to,
                feed,
                origin: at,
            }));
            it.state.position = to;
        };
        if motion == Motion::Peck {
            let q = self.state.cycle_q.unwrap_or(1.0);
            let mut depth = r;
            while depth > bottom + 1e-9 {
                let next = (depth - q).max(bottom);
                if depth < r {
                    let above = Point {
                        z: (depth + PECK_CLEARANCE_MM).min(r),
                        ..hole
                    };
                    rapid(self, above);
                }
                feed_to(self, next);
                depth = next;
                if depth > bottom + 1e-9 {
                    rapid(self, Point { z: r, ..hole });
                }
            }
        } else {
            feed_to(self, bottom);
        }
        if motion == Motion::DrillDwell {
            let seconds = self.state.cycle_p.unwrap_or(0.0);
            self.ops.push(Op::Dwell(Dwell {
                seconds,
                origin: at,
            }));
        }
        let back = match self.state.retract {
            Retract::RPlane => r,
            Retract::Initial => initial.max(r),
        };
        rapid(self, Point { z: back, ..hole });
    }

    /// Spindle and coolant as the M code leaves them.
    fn note_m(&mut self, code: u32) {
        let s = &mut self.state;
        match code {
            30 => s.spindle = Spindle::Clockwise,
            40 => s.spindle = Spindle::CounterClockwise,
            50 => s.spindle = Spindle::Off,
            70 => s.mist = true,
            80 => s.flood = true,
            90 => (s.mist, s.flood) = (false, false),
            _ => {}
        }
    }

    fn modal(&self) -> Modal {
        let s = &self.state;
        Modal {
            units: s.units,
            plane: s.plane,
            absolute: s.absolute,
            arc_absolute: s.arc_absolute,
            system: s.system,
            feed: s.feed,
            spindle: s.spindle,
            speed: s.speed,
            mist: s.mist,
            flood: s.flood,
            tool: s.tool,
        }
    }

    fn switch(&mut self, role: &str, on: bool, code: u32, word: &Word) {
        let name = code_name('M', code);
        let Some(output) = self.setup.output(role).cloned() else {
            self.error(
                word.origin,
                format!(
                    "{name} switches the {role}, and this profile has no output with that role (outputs: {}); give one the role in [io], or map {name} in [gcode]",
                    self.setup.output_names()
                ),
            );
            return;
        };
        if code == 40 {
            self.warn(
                word.origin,
                "M4 (spindle counter-clockwise) switches the same spindle output as M3: the controller has no direction output",
            );
        }
        self.ops.push(Op::Output(OutputSwitch {
            address: output.address,
            name: output.name,
            role: output.role,
            on,
            origin: word.origin,
        }));
    }

    fn output_op(&mut self, target: &str, on: bool, word: Word) {
        if let Some(output) = self.setup.output(target).cloned() {
            self.ops.push(Op::Output(OutputSwitch {
                address: output.address,
                name: output.name,
                role: output.role,
                on,
                origin: word.origin,
            }));
        }
    }

    fn numbered_output(&mut self, code: u32, word: &Word, w: &Words) {
        let name = code_name('M', code);
        let Some(p) = w.value('P') else {
            self.error(word.origin, format!("{name} needs P: the output's number"));
            return;
        };
        let n = p.value;
        let output = if n >= 0.0 && n.fract() == 0.0 {
            self.setup
                .outputs
                .iter()
                .find(|o| f64::from(o.number) == n)
                .cloned()
        } else {
            None
        };
        let Some(output) = output else {
            self.error(
                p.origin,
                format!(
                    "{name} P{n}: no output {n} on this machine (outputs 0-{}: {})",
                    self.setup.outputs.len().saturating_sub(1),
                    self.setup.output_names()
                ),
            );
            return;
        };
        let on = matches!(code, 620 | 640);
        self.ops.push(Op::Output(OutputSwitch {
            address: output.address,
            name: output.name,
            role: output.role,
            on,
            origin: word.origin,
        }));
    }
}

fn is_cycle(m: Motion) -> bool {
    matches!(m, Motion::Drill | Motion::DrillDwell | Motion::Peck)
}

/// The block's words, sorted.
#[derive(Debug, Default)]
struct Words {
    g: Vec<(u32, Word)>,
    m: Vec<(u32, Word)>,
    values: Vec<Word>,
    /// Codes the profile maps to an output.
    mapped: Vec<(Word, String, String)>,
}

impl Words {
    /// Empty, its capacity kept.
    fn clear(&mut self) {
        self.g.clear();
        self.m.clear();
        self.values.clear();
        self.mapped.clear();
    }

    fn value(&self, letter: char) -> Option<&Word> {
        self.values.iter().find(|w| w.letter == letter)
    }

    fn g_code(&self, code: u32) -> Option<&Word> {
        self.g.iter().find(|(c, _)| *c == code).map(|(_, w)| w)
    }

    fn m_code(&self, code: u32) -> Option<&Word> {
        self.m.iter().find(|(c, _)| *c == code).map(|(_, w)| w)
    }

    fn any_axis(&self) -> bool {
        self.has_any(&['X', 'Y', 'Z'])
    }

    fn first_axis(&self) -> Option<&Word> {
        self.values
            .iter()
            .find(|w| matches!(w.letter, 'X' | 'Y' | 'Z'))
    }

    fn has_any(&self, letters: &[char]) -> bool {
        self.values.iter().any(|w| letters.contains(&w.letter))
    }
}

/// Whether an arc from `s` to `e` around `c` passes the interpreter's
/// radius checks (a radius of at least 1e-9, the radii to its ends within
/// `tolerance`) by a margin no rounding crosses, told by square roots of
/// sums of squares instead of `hypot` (a libm call, two an arc). A root is
/// within a few units in the last place of the `hypot` of the same sides:
/// below a radius of 1e6 that is under 1e-9 mm, so a radius above 2e-9
/// and radii within half the tolerance (at least 1e-6) decide as the
/// `hypot`s would. `false` says nothing: the `hypot`s decide.
fn plainly_on_circle(s: (f64, f64), e: (f64, f64), c: (f64, f64), tolerance: f64) -> bool {
    let radius = |(u, v): (f64, f64)| ((u - c.0).powi(2) + (v - c.1).powi(2)).sqrt();
    let (r0, r1) = (radius(s), radius(e));
    r0 > 2e-9 && r0 < 1e6 && r1 < 1e6 && (r0 - r1).abs() < 0.5 * tolerance
}

/// X 0, Y 1, Z 2 (the IR's axes).
pub fn axis_index(axis: Axis) -> usize {
    match axis {
        Axis::X => 0,
        Axis::Y => 1,
        _ => 2,
    }
}

pub fn get(p: Point, axis: Axis) -> f64 {
    match axis {
        Axis::X => p.x,
        Axis::Y => p.y,
        _ => p.z,
    }
}

pub fn set(p: &mut Point, axis: Axis, v: f64) {
    match axis {
        Axis::X => p.x = v,
        Axis::Y => p.y = v,
        _ => p.z = v,
    }
}

/// The plane's two axes in RS-274/NGC's order and its normal.
pub fn plane_axes(plane: Plane) -> (Axis, Axis, Axis) {
    match plane {
        Plane::Xy => (Axis::X, Axis::Y, Axis::Z),
        Plane::Zx => (Axis::Z, Axis::X, Axis::Y),
        Plane::Yz => (Axis::Y, Axis::Z, Axis::X),
    }
}

fn offset_letters(plane: Plane) -> [char; 2] {
    match plane {
        Plane::Xy => ['I', 'J'],
        Plane::Zx => ['K', 'I'],
        Plane::Yz => ['J', 'K'],
    }
}

fn plane_name(plane: Plane) -> &'static str {
    match plane {
        Plane::Xy => "G17 XY",
        Plane::Zx => "G18 ZX",
        Plane::Yz => "G19 YZ",
    }
}

/// The centre of an R arc: the short way for R > 0, the long way for R < 0.
fn r_centre(
    su: f64,
    sv: f64,
    eu: f64,
    ev: f64,
    r: f64,
    clockwise: bool,
    tolerance: f64,
) -> Result<(f64, f64), String> {
    let (du, dv) = (eu - su, ev - sv);
    let chord = du.hypot(dv);
    if chord < 1e-9 {
        return Err("an R arc must end elsewhere than it starts: a full circle takes I J K".into());
    }
    let half = chord / 2.0;
    let radius = r.abs();
    if radius < 1e-9 {
        return Err("R must not be 0".into());
    }
    let h2 = radius * radius - half * half;
    if h2 < 0.0 && half - radius > tolerance {
        return Err(format!(
            "R {radius:.4} is too small for an arc between points {chord:.4} apart"
        ));
    }
    let h = h2.max(0.0).sqrt();
    let (mu, mv) = (su + du / 2.0, sv + dv / 2.0);
    // Unit normal to the left of the chord.
    let (lu, lv) = (-dv / chord, du / chord);
    // The short CCW arc has its centre on the left; CW on the right; R < 0
    // takes the other side (the long way).
    let left = clockwise != (r > 0.0);
    let sign = if left { 1.0 } else { -1.0 };
    Ok((mu + sign * h * lu, mv + sign * h * lv))
}

/// The angle swept by an arc, radians, always positive, in (0, 2π] for a
/// single turn (a full circle when start and end meet).
pub fn sweep(arc: &Arc) -> f64 {
    let (a0, a1) = end_angles(arc);
    sweep_between(arc, a0, a1)
}

/// The angles of an arc's start and end about its centre, radians, from
/// the plane's first axis towards its second: what [`sweep`] is taken
/// from, for the callers that need them too (each is a call into libm,
/// for every arc of a file).
pub fn end_angles(arc: &Arc) -> (f64, f64) {
    let (u, v, _) = plane_axes(arc.plane);
    let a0 = (get(arc.from, v) - get(arc.centre, v)).atan2(get(arc.from, u) - get(arc.centre, u));
    let a1 = (get(arc.to, v) - get(arc.centre, v)).atan2(get(arc.to, u) - get(arc.centre, u));
    (a0, a1)
}

/// [`sweep`] of the angles [`end_angles`] gives.
pub fn sweep_between(arc: &Arc, a0: f64, a1: f64) -> f64 {
    let raw = if arc.clockwise { a0 - a1 } else { a1 - a0 };
    let mut s = raw.rem_euclid(2.0 * PI);
    if s < 1e-9 {
        s = 2.0 * PI;
    }
    s + 2.0 * PI * f64::from(arc.extra_turns)
}

/// The radius of an arc (to its start).
pub fn radius(arc: &Arc) -> f64 {
    let (u, v, _) = plane_axes(arc.plane);
    (get(arc.from, u) - get(arc.centre, u)).hypot(get(arc.from, v) - get(arc.centre, v))
}

/// The point at `t` in [0, 1] along an arc (helix included).
pub fn arc_point(arc: &Arc, t: f64) -> Point {
    let (u, v, n) = plane_axes(arc.plane);
    let a0 = (get(arc.from, v) - get(arc.centre, v)).atan2(get(arc.from, u) - get(arc.centre, u));
    let s = sweep(arc) * if arc.clockwise { -1.0 } else { 1.0 };
    let r0 = radius(arc);
    let r1 = (get(arc.to, u) - get(arc.centre, u)).hypot(get(arc.to, v) - get(arc.centre, v));
    let r = r0 + (r1 - r0) * t;
    let a = a0 + s * t;
    let mut p = arc.from;
    set(&mut p, u, get(arc.centre, u) + r * a.cos());
    set(&mut p, v, get(arc.centre, v) + r * a.sin());
    set(
        &mut p,
        n,
        get(arc.from, n) + (get(arc.to, n) - get(arc.from, n)) * t,
    );
    if t >= 1.0 {
        return arc.to;
    }
    p
}
