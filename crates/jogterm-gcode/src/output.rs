//! What both controller outputs share: the converted program with the
//! G-code line of every command, the header that says what it was made
//! for, chords of arcs and the merging of near-collinear cuts.

use std::borrow::Cow;
use std::f64::consts::PI;
use std::fmt::Write as _;

use super::interp::{arc_point, radius, sweep};
use super::toolpath::{Arc, Diagnostic, Line, Op, Origin, Point};

/// A converted program: controller lines (comments included), and for
/// each its G-code origin.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Program {
    pub lines: Vec<ProgramLine>,
    pub warnings: Vec<Diagnostic>,
    /// Commands the controller stores (comment lines not counted).
    pub commands: usize,
    /// Its program memory in commands (the profile's `[gcode] memory`, the
    /// one setting `check`, `upload`, `run` and the console use too).
    pub capacity: usize,
    /// The closing command takes no memory (isel: the controller stores
    /// its capacity in commands before the `9`, as the program check
    /// counts).
    pub end_is_free: bool,
    /// Where the program stops for the operator (M0, M1, M6) and what it
    /// waits for, to be said before it starts.
    pub pauses: Vec<(Origin, String)>,
    /// Indices into `lines` of the commands after which the tool stands at
    /// the job's safe height (a rapid up to the highest Z the file's rapids
    /// reach): the only places a job too big for the memory is cut.
    pub retracted: Vec<usize>,
}

/// One part of a program cut to fit the controller's memory: a range of
/// its lines.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Part {
    pub lines: std::ops::Range<usize>,
    /// Commands in it, with what the part adds (see [`Program::part`]).
    pub commands: usize,
}

/// Commands a part after the first adds (`z1`: a new program starts in
/// the controller's 2.5D mode) and every part may need (the closing `9`).
pub const PART_OVERHEAD: usize = 2;

#[derive(Debug, Clone, PartialEq)]
pub struct ProgramLine {
    /// The command (empty for a comment-only line).
    pub command: String,
    pub comment: Option<String>,
    pub origin: Option<Origin>,
}

impl Program {
    pub fn fits(&self) -> bool {
        self.stored() <= self.capacity
    }

    /// The commands that take memory: all, less an isel program's closing
    /// `9`.
    pub fn stored(&self) -> usize {
        let last = self.lines.iter().rev().find(|l| !l.command.is_empty());
        let free = self.end_is_free && last.is_some_and(|l| l.command == "9");
        self.commands - usize::from(free)
    }

    /// The program as a file: the command, and `; FILE:LINE` after it.
    ///
    /// Comments carry text from outside (the file's and the profile's
    /// names, output and key names): its control characters are written
    /// escaped ([`one_line`]), so that a comment stays on its line and no
    /// text becomes a line of the program (issue 37).
    pub fn text(&self, file: &str) -> String {
        let file = one_line(file);
        let mut out = String::new();
        for line in &self.lines {
            let mut comment = line.comment.as_deref().map(one_line);
            if let Some(o) = line.origin {
                let at = format!("{file}:{}", o.line);
                comment = Some(match comment {
                    Some(c) => format!("{at} {c}"),
                    None => at,
                });
            }
            match (line.command.is_empty(), comment) {
                (true, Some(c)) => out.push_str(&format!("; {c}\n")),
                (true, None) => out.push('\n'),
                (false, Some(c)) => out.push_str(&format!("{:<40} ; {c}\n", line.command)),
                (false, None) => out.push_str(&format!("{}\n", line.command)),
            }
        }
        out
    }

    /// The program of the ops after this one's (a conversion in two
    /// parts) appended: its lines, commands, warnings and pauses after
    /// these.
    pub fn append(&mut self, rest: Program) {
        let offset = self.lines.len();
        self.lines.extend(rest.lines);
        self.warnings.extend(rest.warnings);
        self.commands += rest.commands;
        self.pauses.extend(rest.pauses);
        self.retracted
            .extend(rest.retracted.into_iter().map(|at| at + offset));
    }

    pub fn comment(&mut self, text: impl Into<String>) {
        self.lines.push(ProgramLine {
            command: String::new(),
            comment: Some(text.into()),
            origin: None,
        });
    }

    pub fn command(&mut self, command: impl Into<String>, origin: Option<Origin>) {
        self.commands += 1;
        self.lines.push(ProgramLine {
            command: command.into(),
            comment: None,
            origin,
        });
    }

    pub fn command_noted(
        &mut self,
        command: impl Into<String>,
        note: &str,
        origin: Option<Origin>,
    ) {
        self.commands += 1;
        self.lines.push(ProgramLine {
            command: command.into(),
            comment: Some(note.to_owned()),
            origin,
        });
    }

    /// The program cut into parts of at most `capacity` commands, each
    /// ending where the tool stands at the safe height (issue 27, "chunked
    /// store-and-run"); why it cannot be cut otherwise.
    pub fn parts(&self, capacity: usize) -> Result<Vec<Part>, String> {
        let budget = capacity.saturating_sub(PART_OVERHEAD).max(1);
        let mut parts = Vec::new();
        let mut start = 0;
        let mut count = 0;
        let mut cut: Option<(usize, usize)> = None;
        let mut retracted = self.retracted.iter().peekable();
        for (index, line) in self.lines.iter().enumerate() {
            if line.command.is_empty() {
                continue;
            }
            count += 1;
            if count > budget {
                let Some((at, commands)) = cut.take() else {
                    let origin = line
                        .origin
                        .map_or_else(String::new, |o| format!(" (G-code line {})", o.line));
                    return Err(format!(
                        "no retract to the safe height within {budget} commands before command {}{origin}: the job cannot be cut where the tool stands clear of the part",
                        index + 1
                    ));
                };
                parts.push(Part {
                    lines: start..at + 1,
                    commands: commands + PART_OVERHEAD,
                });
                start = at + 1;
                count -= commands;
            }
            while retracted.next_if(|&&r| r < index).is_some() {}
            if retracted.peek() == Some(&&index) {
                cut = Some((index, count));
            }
        }
        if count > 0 || parts.is_empty() {
            parts.push(Part {
                lines: start..self.lines.len(),
                commands: count + PART_OVERHEAD,
            });
        }
        Ok(parts)
    }

    /// Part `k` (0-based) of `parts` as a program of its own: the header,
    /// which part it is, `z1` again for every part after the first (each
    /// stored program starts in 2.5D), its lines with their origins, and
    /// `9` where a part ends before the job does.
    pub fn part(&self, parts: &[Part], k: usize) -> Program {
        let mut head = Program::default();
        let header_len = self
            .lines
            .iter()
            .take_while(|l| l.command.is_empty() && l.origin.is_none())
            .count();
        head.lines.extend(self.lines[..header_len].iter().cloned());
        head.comment(format!("{} part={}/{}", Header::PREFIX, k + 1, parts.len()));
        head.capacity = self.capacity;
        head.end_is_free = self.end_is_free;
        let Some(part) = parts.get(k) else {
            return head;
        };
        if k > 0 {
            head.command_noted("z1", "3D interpolation again: a new program", None);
        }
        let from = part.lines.start.max(header_len);
        for line in &self.lines[from..part.lines.end.max(from)] {
            if !line.command.is_empty() {
                head.commands += 1;
            }
            if let Some(pause) = self.pauses.iter().find(|(o, _)| Some(*o) == line.origin)
                && !head.pauses.contains(pause)
            {
                head.pauses.push(pause.clone());
            }
            head.lines.push(line.clone());
        }
        if k + 1 < parts.len() {
            head.command_noted("9", "end of this part: the tool stands retracted", None);
        }
        head
    }

    /// The G-code origin of the `index`th stored command (0-based), for a
    /// controller error that names a command.
    pub fn origin_of_command(&self, index: usize) -> Option<Origin> {
        self.lines
            .iter()
            .filter(|l| !l.command.is_empty())
            .nth(index)
            .and_then(|l| l.origin)
    }
}

/// `text` on one line: every control character (line ends, NUL, escape
/// sequences) written as `\u{..}`; the rest as it is, so that a name with
/// none (every profile name, `Profile::validate`) reads back unchanged.
pub fn one_line(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            c if c.is_control() => {
                let _ = write!(out, "\\u{{{:x}}}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out
}

/// What a program was made for: it goes at the top of the program as
/// comments, one `key=value` per line, so that a run can check it.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    pub file: String,
    pub profile: String,
    pub system: String,
    /// Machine mm of the work zero the file was mapped through.
    pub zero: Point,
}

impl Header {
    pub const PREFIX: &'static str = "jogterm-gcode";

    pub fn lines(&self) -> Vec<String> {
        vec![
            format!("{} file={}", Header::PREFIX, self.file),
            format!("{} profile={}", Header::PREFIX, self.profile),
            format!(
                "{} offset={} zero={:.4},{:.4},{:.4}",
                Header::PREFIX,
                self.system,
                self.zero.x,
                self.zero.y,
                self.zero.z
            ),
        ]
    }

    /// The header of a converted program's text, if it has one whole.
    pub fn of(text: &str) -> Option<Header> {
        let value = |key: &str| {
            let marker = format!("{} {key}=", Header::PREFIX);
            text.lines().take(16).find_map(|l| {
                let l = l.trim_start_matches(';').trim();
                l.strip_prefix(&marker).map(str::to_owned)
            })
        };
        let offset = value("offset")?;
        let (system, zero) = offset.split_once(" zero=")?;
        let mut it = zero.split(',').map(|v| v.trim().parse::<f64>());
        let (Some(Ok(x)), Some(Ok(y)), Some(Ok(z))) = (it.next(), it.next(), it.next()) else {
            return None;
        };
        Some(Header {
            file: value("file")?,
            profile: value("profile")?,
            system: system.to_owned(),
            zero: Point { x, y, z },
        })
    }
}

/// The most commands a converted program may hold: a thousand times an
/// isel program memory, and more than a DNC stream of a day; the work is
/// bounded before it is done (issue 37).
pub const MAX_COMMANDS: usize = 2_000_000;

/// Why an arc or a program was not converted: it would exceed
/// [`MAX_COMMANDS`].
pub fn too_many(origin: Origin, what: &str) -> Diagnostic {
    Diagnostic::error(
        origin,
        format!(
            "{what} more than {MAX_COMMANDS} commands: split the job in the CAM, or give the arc fewer turns or a larger gcode.chord_tolerance"
        ),
    )
}

/// Points along an arc (its end included, its start not) so that no chord
/// strays more than `tolerance` from it; `Err` with the number of chords
/// when that is more than `limit` (nothing is made then).
pub fn chords(arc: &Arc, tolerance: f64, limit: usize) -> Result<Vec<Point>, f64> {
    let r = radius(arc).max(1e-9);
    let total = sweep(arc);
    let tol = tolerance.clamp(1e-6, r);
    // A chord of angle a strays r (1 - cos(a/2)) from its arc.
    let max_angle = 2.0 * (1.0 - tol / r).clamp(-1.0, 1.0).acos();
    let max_angle = if max_angle.is_finite() && max_angle > 0.0 {
        max_angle.min(PI / 2.0)
    } else {
        PI / 2.0
    };
    let n = (total / max_angle).ceil().max(1.0);
    // NaN (no sweep) is refused too.
    if n.is_nan() || n > limit as f64 {
        return Err(n);
    }
    let n = n as usize;
    Ok((1..=n)
        .map(|k| arc_point(arc, k as f64 / n as f64))
        .collect())
}

/// A segment from `a` to `b` as the distance of points from it is taken:
/// its direction and squared length computed once for all the points of a
/// run checked against it.
struct Segment {
    a: Point,
    d: Point,
    len2: f64,
}

impl Segment {
    fn new(a: Point, b: Point) -> Segment {
        let (dx, dy, dz) = (b.x - a.x, b.y - a.y, b.z - a.z);
        Segment {
            a,
            d: Point {
                x: dx,
                y: dy,
                z: dz,
            },
            len2: dx * dx + dy * dy + dz * dz,
        }
    }

    /// The squared distance of `p` from the segment.
    #[inline]
    fn square(&self, p: Point) -> f64 {
        let (a, d) = (self.a, self.d);
        let t = if self.len2 < 1e-18 {
            0.0
        } else {
            (((p.x - a.x) * d.x + (p.y - a.y) * d.y + (p.z - a.z) * d.z) / self.len2)
                .clamp(0.0, 1.0)
        };
        let (qx, qy, qz) = (a.x + t * d.x, a.y + t * d.y, a.z + t * d.z);
        (p.x - qx).powi(2) + (p.y - qy).powi(2) + (p.z - qz).powi(2)
    }
}

#[cfg(test)]
fn distance_to_segment(p: Point, a: Point, b: Point) -> f64 {
    Segment::new(a, b).square(p).sqrt()
}

/// The largest square whose root is within `tolerance`: `s.sqrt() <=
/// tolerance` is `s <= square_limit(tolerance)` for every square `s` (no
/// number below zero; NaN and infinity too), since the root is correctly rounded and so never
/// falls as its argument grows. The merge compares squares with it and
/// takes no root: a run of moves checks every inner point against every
/// new end, and the root was half of that work.
fn square_limit(tolerance: f64) -> f64 {
    if tolerance.is_nan() || tolerance == f64::INFINITY {
        return tolerance;
    }
    if tolerance < 0.0 {
        return f64::NEG_INFINITY;
    }
    // Within a few units in the last place of the square: stepped there.
    let mut limit = tolerance * tolerance;
    while limit > 0.0 && limit.sqrt() > tolerance {
        limit = limit.next_down();
    }
    while limit < f64::MAX && limit.next_up().sqrt() <= tolerance {
        limit = limit.next_up();
    }
    limit
}

/// A straight move's path speed in steps/s on the wire, as both outputs
/// give it: `mm_per_s` along the move from `s0` to `s1` (its axes' exact,
/// unrounded steps, so that equal feeds give equal speeds chord after
/// chord), held so that no axis runs above its `limits_hz` and the path
/// never above `ceiling_hz`. `None` for a move shorter than half a step;
/// else the speed and whether a finite speed asked for had to be held.
pub fn path_speed(
    from: Point,
    to: Point,
    (s0, s1): (&[f64], &[f64]),
    mm_per_s: f64,
    limits_hz: &[f64],
    ceiling_hz: f64,
) -> Option<(f64, bool)> {
    let d_mm = ((to.x - from.x).powi(2) + (to.y - from.y).powi(2) + (to.z - from.z).powi(2)).sqrt();
    let d_steps = s0
        .iter()
        .zip(s1)
        .map(|(a, b)| (b - a).powi(2))
        .sum::<f64>()
        .sqrt();
    if d_mm < 1e-12 || d_steps < 0.5 {
        return None;
    }
    let mut hz = if mm_per_s.is_finite() {
        mm_per_s * d_steps / d_mm
    } else {
        ceiling_hz
    };
    let mut held = false;
    for ((a, b), limit) in s0.iter().zip(s1).zip(limits_hz) {
        let share = (b - a).abs() / d_steps;
        if share > 0.0 && hz > limit / share + 0.5 {
            hz = limit / share;
            held = true;
        }
    }
    if hz > ceiling_hz + 0.5 {
        hz = ceiling_hz;
        held = true;
    }
    Some((hz, held && mm_per_s.is_finite()))
}

/// The most lines merged into one move, so that a merge stays cheap.
const MERGE_RUN: usize = 64;

/// Consecutive feed moves at one feed whose inner points all lie within
/// `tolerance` of the merged line become one move (the first's origin):
/// every isel command ramps down to the start-stop speed, so CAM's short
/// collinear segments cost time and marks at the part.
pub fn merge_lines(ops: &[Op], tolerance: f64) -> Vec<Op> {
    merged(ops, tolerance).map(Cow::into_owned).collect()
}

/// [`merge_lines`] one op at a time, the ops it does not merge borrowed:
/// the conversions walk it once, so a file of half a million moves is not
/// copied whole (it was the largest copy at the conversion's memory peak).
pub fn merged(ops: &[Op], tolerance: f64) -> Merged<'_, std::slice::Iter<'_, Op>> {
    merged_ops(ops.iter(), tolerance)
}

/// [`merged`] of ops given one at a time (the import's whole job, the
/// slices of `Plan::expanded_slices`, is not collected into a toolpath).
pub fn merged_ops<'a, I: Iterator<Item = &'a Op>>(ops: I, tolerance: f64) -> Merged<'a, I> {
    Merged {
        ops,
        tolerance,
        square_limit: square_limit(tolerance),
        run: Vec::new(),
        pending: None,
    }
}

/// The iterator of [`merged`].
pub struct Merged<'a, I> {
    ops: I,
    tolerance: f64,
    /// [`square_limit`] of the tolerance.
    square_limit: f64,
    /// The feed moves merged so far, not yet given out.
    run: Vec<Line>,
    /// The op that ended a run, given out after the run's merged move.
    pending: Option<&'a Op>,
}

impl<I> Merged<'_, I> {
    /// The run as one move (the first's origin), the run emptied.
    fn flush(&mut self) -> Option<Op> {
        let merged = match (self.run.first(), self.run.last()) {
            (Some(first), Some(last)) => Some(Op::Line(Line {
                from: first.from,
                to: last.to,
                feed: first.feed,
                origin: first.origin,
            })),
            _ => None,
        };
        self.run.clear();
        merged
    }
}

impl<'a, I: Iterator<Item = &'a Op>> Iterator for Merged<'a, I> {
    type Item = Cow<'a, Op>;

    fn next(&mut self) -> Option<Cow<'a, Op>> {
        if let Some(op) = self.pending.take() {
            return Some(Cow::Borrowed(op));
        }
        loop {
            match self.ops.next() {
                Some(Op::Line(line)) if self.tolerance > 0.0 => {
                    let fits = match self.run.first() {
                        None => true,
                        Some(first) => {
                            first.feed == line.feed && self.run.len() < MERGE_RUN && {
                                let segment = Segment::new(first.from, line.to);
                                self.run
                                    .iter()
                                    .all(|l| segment.square(l.to) <= self.square_limit)
                            }
                        }
                    };
                    let done = if fits { None } else { self.flush() };
                    self.run.push(*line);
                    if let Some(op) = done {
                        return Some(Cow::Owned(op));
                    }
                }
                Some(other) => {
                    return Some(match self.flush() {
                        Some(op) => {
                            self.pending = Some(other);
                            Cow::Owned(op)
                        }
                        None => Cow::Borrowed(other),
                    });
                }
                None => return self.flush().map(Cow::Owned),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The squared distance against [`square_limit`] decides as the
    /// distance against the tolerance, at the boundary and anywhere.
    fn same_decision(s: f64, tolerance: f64) {
        if s < 0.0 {
            return;
        }
        assert_eq!(
            s.sqrt() <= tolerance,
            s <= square_limit(tolerance),
            "{s:e} against {tolerance:e}"
        );
    }

    #[test]
    fn square_limit_decides_as_the_root() {
        let tolerances = [
            0.0,
            -0.0,
            -1.0,
            1e-300,
            1e-9,
            0.001,
            0.01,
            0.1,
            0.3,
            1.0,
            2.0,
            1e154,
            1e200,
            f64::MAX,
            f64::INFINITY,
            f64::NAN,
        ];
        for t in tolerances {
            let limit = square_limit(t);
            for s in [
                0.0,
                -0.0,
                limit,
                limit.next_up(),
                limit.next_down(),
                t * t,
                (t * t).next_up(),
                (t * t).next_down(),
                1e-20,
                1.0,
                f64::MAX,
                f64::INFINITY,
                f64::NAN,
            ] {
                same_decision(s, t);
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn square_limit_decides_as_the_root_for_any_bits(s_bits in 0u64..0x7ff0_0000_0000_0000, t in 0.0f64..10.0, near in -4i64..=4) {
            let limit = square_limit(t);
            same_decision(f64::from_bits(s_bits), t);
            let nearby = f64::from_bits(limit.to_bits().saturating_add_signed(near));
            same_decision(nearby, t);
        }

        #[test]
        fn a_merge_decides_as_the_distance_does(
            p in proptest::array::uniform3(-100.0f64..100.0),
            a in proptest::array::uniform3(-100.0f64..100.0),
            b in proptest::array::uniform3(-100.0f64..100.0),
            t in 0.0001f64..1.0,
        ) {
            let point = |v: [f64; 3]| Point { x: v[0], y: v[1], z: v[2] };
            let (p, a, b) = (point(p), point(a), point(b));
            let d = distance_to_segment(p, a, b);
            proptest::prop_assert_eq!(d <= t, Segment::new(a, b).square(p) <= square_limit(t));
            proptest::prop_assert_eq!(d <= d, Segment::new(a, b).square(p) <= square_limit(d));
        }
    }

    #[test]
    fn a_header_reads_back_from_the_program_it_heads() {
        let header = Header {
            file: "part.nc".into(),
            profile: "isel simulator".into(),
            system: "G55".into(),
            zero: Point {
                x: 50.0,
                y: -12.5,
                z: 60.0,
            },
        };
        let mut program = Program::default();
        for line in header.lines() {
            program.comment(line);
        }
        program.command("77", None);
        assert_eq!(Header::of(&program.text("part.nc")), Some(header));
        assert_eq!(Header::of("77\n9\n"), None);
    }
}

#[cfg(test)]
mod part_tests {
    use super::*;

    fn program(commands: &[&str], retracted: &[usize]) -> Program {
        let mut p = Program {
            capacity: 6,
            ..Program::default()
        };
        p.comment("jogterm-gcode file=x.nc");
        for c in commands {
            p.command(*c, Some(Origin { line: 1, col: 1 }));
        }
        p.retracted = retracted.to_vec();
        p
    }

    #[test]
    fn parts_end_only_where_the_tool_stands_retracted_and_fit_the_memory() {
        // Lines: 0 the header, 1..=9 the commands; retracted after 3 and 6.
        let p = program(
            &["77", "z1", "mUP", "a", "b", "mUP", "c", "d", "9"],
            &[3, 6],
        );
        let parts = p.parts(6).expect("parts");
        assert_eq!(
            parts.iter().map(|x| x.lines.clone()).collect::<Vec<_>>(),
            vec![0..4, 4..7, 7..10]
        );
        for k in 0..parts.len() {
            let part = p.part(&parts, k);
            assert!(part.commands <= 6, "{part:?}");
            let commands: Vec<&str> = part
                .lines
                .iter()
                .map(|l| l.command.as_str())
                .filter(|c| !c.is_empty())
                .collect();
            assert_eq!(commands.last(), Some(&"9"));
            assert_eq!(commands.first(), Some(if k == 0 { &"77" } else { &"z1" }));
        }
    }

    #[test]
    fn a_job_with_no_retract_within_the_memory_cannot_be_cut() {
        let p = program(&["77", "z1", "a", "b", "c", "d", "e", "9"], &[]);
        let why = p.parts(6).expect_err("no place to cut");
        assert!(
            why.contains("no retract to the safe height within 4 commands"),
            "{why}"
        );
    }
}
