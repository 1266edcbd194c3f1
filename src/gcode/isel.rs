//! The isel output: a CNC program as `jogterm upload` stores it (`@0i` …
//! `9`, manual chapter 3), from a checked toolpath (`docs/gcode.md`,
//! "isel").
//!
//! - The program begins with a reference run of its axes (`7`, 3.2.8)
//!   unless the profile says `reference_first = false`: `m` counts from the
//!   reference point (or a zero `n` set), and only the reference run makes
//!   that the machine coordinates the toolpath was checked in.
//! - 3D interpolation (`z1`, 2.2.29, 3.2.24) right after it: in the
//!   default 2.5D mode X/Y run first and Z after, so a plunge or retract
//!   combined with X/Y would be a staircase into the part. A reference run
//!   ends 3D mode (2.2.22), so `z1` follows every `7`.
//! - Straight moves as `m` (absolute, 3.2.16) at the path speed in steps/s
//!   (in 3D the x speed is the path speed), capped by every moving axis'
//!   `max_speed` and the manual's 1-40000 Hz, a capped speed is a warning at
//!   its line; G0 at the profile's rapid speed.
//! - Arcs and helices as the controller's circle interpolation (`e` plane,
//!   `f` direction, `y`/`w`, manual 2.3, the same code as `jogterm arc`),
//!   each followed by an `m` to its exact end as 2.3 advises; arcs in a
//!   plane whose axes have different steps per mm become chords (the
//!   controller's circle is round in steps), arcs too short for one step
//!   become a line.
//! - Dwells as `5` (tenths of a second), outputs as `p`, pauses (M0, M1,
//!   M6) as a wait for the machine's start key: `o<port>,<bit>,<released>,0`
//!   (3.2.19) branches to itself while the key reads released, so the
//!   program stands until the operator presses it at the machine. Not the
//!   sync character `2` (3.2.4): any byte on the line ends that wait, and a
//!   console polling the position would end it at once.

use crate::axis::Axis;
use crate::config::profile::{AxisProfile, Profile};
use crate::program::ISEL_CAPACITY;
use crate::proto::isel::{
    CircleDirection, CircleError, CircleParams, CncCommand, Plane as IselPlane, circle, helix,
};
use crate::proto::typed::isel_config;
use crate::wiring::{BitKind, Level, Role};

use super::interp::{end_angles, get, plane_axes, radius, sweep_between};
use super::num::round;
use super::output::{Header, MAX_COMMANDS, Program, chords, merged_ops, path_speed, too_many};
use super::toolpath::{Arc, Diagnostic, Op, Origin, Pause, Plane, Point, Severity, Toolpath};

const HZ_MIN: f64 = 1.0;
const HZ_MAX: f64 = 40_000.0;

#[derive(Clone)]
struct Axes {
    x: AxisProfile,
    y: AxisProfile,
    z: AxisProfile,
    /// Pairs per `m`: XYZ has x, y, z1, z2 (the z2 of `m` is ignored, 3.2.16).
    pairs: usize,
    /// X, Y and Z's `max_speed` in steps/s, and as the whole Hz an `m`
    /// pair may carry: taken once, not for every move of the file.
    limits_hz: [f64; 3],
    caps_hz: [u32; 3],
}

impl Axes {
    fn new(x: AxisProfile, y: AxisProfile, z: AxisProfile, pairs: usize) -> Axes {
        let limits_hz = [&x, &y, &z].map(|p| p.speed_hz(p.max_speed));
        let caps_hz = limits_hz.map(|hz| hz.round().max(HZ_MIN) as u32);
        Axes {
            x,
            y,
            z,
            pairs,
            limits_hz,
            caps_hz,
        }
    }

    fn of(&self, axis: Axis) -> &AxisProfile {
        match axis {
            Axis::X => &self.x,
            Axis::Y => &self.y,
            _ => &self.z,
        }
    }

    fn exact_steps(&self, p: Point) -> [f64; 3] {
        [
            p.x * self.x.steps_per_unit,
            p.y * self.y.steps_per_unit,
            p.z * self.z.steps_per_unit,
        ]
    }

    /// `AxisProfile::to_steps` of each axis, its rounding inlined (every
    /// move of the file is rounded to steps here).
    fn steps(&self, p: Point) -> [i64; 3] {
        [
            round(p.x * self.x.steps_per_unit) as i64,
            round(p.y * self.y.steps_per_unit) as i64,
            round(p.z * self.z.steps_per_unit) as i64,
        ]
    }
}

fn error(origin: Origin, message: impl Into<String>) -> Diagnostic {
    Diagnostic::error(origin, message)
}

struct Writer<'a> {
    axes: Axes,
    program: Program,
    profile: &'a Profile,
    /// Steps where the tool stands (after the last command).
    at: [i64; 3],
    plane: IselPlane,
    capped: usize,
    first_capped: Option<Origin>,
    spindle_speeds: Option<Origin>,
    /// The start key a pause waits for: input port, bit, the level it
    /// reads released, and its name.
    start_key: Option<(u32, u32, u8, String)>,
    /// The job's safe height: the highest Z its rapids reach (machine mm).
    safe_z: f64,
}

/// Converts a checked toolpath into an isel CNC program.
pub fn convert(
    path: &Toolpath,
    profile: &Profile,
    header: &Header,
) -> Result<Program, Vec<Diagnostic>> {
    convert_with(path, profile, header, &super::Options::default())
}

/// [`convert`] as `options` say: a piece of a job after its first (no
/// reference run), the job's own safe height.
pub fn convert_with(
    path: &Toolpath,
    profile: &Profile,
    header: &Header,
    options: &super::Options,
) -> Result<Program, Vec<Diagnostic>> {
    convert_ops(|| path.ops.iter(), profile, header, options)
}

/// [`convert_with`] of ops given one at a time (the import's whole job,
/// the slices of `Plan::expanded_slices`, is not collected into a toolpath): `ops` gives
/// them from the start on every call (the start point and, without
/// `options.safe_z`, the safe height are looked up first).
pub fn convert_ops<'a, I>(
    ops: impl Fn() -> I + Sync,
    profile: &Profile,
    header: &Header,
    options: &super::Options,
) -> Result<Program, Vec<Diagnostic>>
where
    I: Iterator<Item = &'a Op>,
{
    convert_ops_from(ops, profile, header, options, SPLIT_MIN_OPS, None)
}

/// Work to do beside a conversion (the import's machine check), and its
/// time as a share of the conversion's: a conversion cut in two does it on
/// this thread and gives the other thread that much more of the ops.
pub struct Beside<'b> {
    pub work: &'b mut (dyn FnMut() + Send),
    pub share: f64,
}

/// [`convert_ops`], with `beside` done on this thread (on a long job while
/// the second thread converts, else after the conversion; not at all when
/// the profile cannot be converted for).
pub fn convert_ops_beside<'a, I>(
    ops: impl Fn() -> I + Sync,
    profile: &Profile,
    header: &Header,
    options: &super::Options,
    beside: Beside<'_>,
) -> Result<Program, Vec<Diagnostic>>
where
    I: Iterator<Item = &'a Op>,
{
    convert_ops_from(ops, profile, header, options, SPLIT_MIN_OPS, Some(beside))
}

/// [`convert_ops_beside`], on two threads from `split_min_ops` ops on (the
/// tests convert short jobs both ways).
fn convert_ops_from<'a, I>(
    ops: impl Fn() -> I + Sync,
    profile: &Profile,
    header: &Header,
    options: &super::Options,
    split_min_ops: usize,
    mut beside: Option<Beside<'_>>,
) -> Result<Program, Vec<Diagnostic>>
where
    I: Iterator<Item = &'a Op>,
{
    let set = profile.axis_set();
    let config = isel_config(set);
    let axis = |a: Axis| profile.axis(a).cloned();
    let (Some(x), Some(y), Some(z), Some(config)) =
        (axis(Axis::X), axis(Axis::Y), axis(Axis::Z), config)
    else {
        return Err(vec![error(
            Origin { line: 1, col: 1 },
            format!(
                "the isel output needs a machine with axes X, Y and Z (this profile has {set}): the G-code import moves all three"
            ),
        )]);
    };
    let pairs = config.axes().len() + usize::from(set.len() == 3);
    let count = ops().count();
    let mut w = Writer {
        axes: Axes::new(x, y, z, pairs),
        program: Program {
            // Sized once, not grown by doubling through copies: a command
            // an op or less, but for arcs (two and their end), merged
            // moves and the few header lines.
            lines: Vec::with_capacity(count + 16),
            capacity: profile.gcode.memory.unwrap_or(ISEL_CAPACITY),
            end_is_free: true,
            ..Program::default()
        },
        profile,
        at: [0; 3],
        plane: IselPlane::XY,
        capped: 0,
        first_capped: None,
        spindle_speeds: None,
        start_key: start_key(profile),
        safe_z: options
            .safe_z
            .or_else(|| {
                ops()
                    .filter_map(|op| match op {
                        Op::Rapid(m) => Some(m.to.z),
                        _ => None,
                    })
                    .reduce(f64::max)
            })
            .unwrap_or(f64::INFINITY),
    };
    for line in header.lines() {
        w.program.comment(line);
    }
    let start = ops().find_map(|op| match op {
        Op::Rapid(m) => Some(m.from),
        Op::Line(m) => Some(m.from),
        Op::Arc(a) => Some(a.from),
        _ => None,
    });
    w.at = w.axes.steps(start.unwrap_or_default());
    if options.continued {
        w.program.comment(
            "a piece of the job after a wait: the axes were referenced by its first piece",
        );
    } else if profile.gcode.reference_first {
        w.program.command_noted(
            "77",
            "reference run of X, Y and Z: m counts from the reference point",
            None,
        );
        w.at = [0; 3];
    } else {
        w.program.comment(
            "no reference run (gcode.reference_first = false): m counts from the controller's zero point, which must be the reference point",
        );
    }
    w.program
        .command_noted("z1", "3D interpolation: X, Y and Z on one line", None);
    // A short job is never cut: no walk for a cut either.
    let cut = (count >= split_min_ops)
        .then(|| cut_of(&ops, beside.as_ref().map_or(0.0, |b| b.share)))
        .flatten();
    let errors = match cut {
        Some(cut) => w.convert_in_two(&ops, &cut, beside.take()),
        None => w.convert(ops()).errors,
    };
    if let Some(beside) = beside {
        (beside.work)();
    }
    if !errors.is_empty() {
        return Err(errors);
    }
    if w.capped > 0 {
        let origin = w.first_capped.unwrap_or_default();
        w.program.warnings.push(Diagnostic {
            severity: Severity::Warning,
            origin,
            message: format!(
                "{} moves asked for more speed than the machine gives (max_speed of an axis, or 40000 Hz): they run slower, the first at this line",
                w.capped
            ),
        });
    }
    if let Some(origin) = w.spindle_speeds {
        w.program.warnings.push(Diagnostic {
            severity: Severity::Warning,
            origin,
            message: "the isel controller cannot set a spindle speed: S words (the first here) go into the program as comments only".into(),
        });
    }
    Ok(w.program)
}

/// Ops converted on two threads from this many on (a long CAM file's): a
/// thread's start costs tens of microseconds, a short job's conversion not
/// much more.
const SPLIT_MIN_OPS: usize = 50_000;

/// Where a conversion can be cut in two, and the writer's state there as
/// the ops alone say it.
///
/// After every move the writer stands at the steps of the move's end (an
/// arc's circles end with a move to its exact end, its chords at it, a
/// move too short to make is already there), so where the tool stands
/// before any op is known from the last move before it. A rapid begins no
/// merged run of lines and ends any. The circle plane is the last arc's,
/// unless that arc was made as chords or a line; the conversion checks
/// the plane (and where the tool stands) when the first part is done.
#[derive(Debug, Clone, Copy)]
struct Cut {
    /// The index of the op (a rapid) the second part starts with.
    index: usize,
    /// The end of the last move before it.
    at: Point,
    /// The plane of the last arc before it.
    plane: Option<Plane>,
}

/// How much longer an arc takes to convert than a line: its circle's
/// parameters and the controller's step walk (measured on the bench file,
/// `cargo bench --bench gcode`: about 51 000 arcs take as long as 250 000
/// lines).
const ARC_WORK: usize = 5;

fn work(op: &Op) -> usize {
    match op {
        Op::Arc(_) => ARC_WORK,
        _ => 1,
    }
}

/// The first rapid that has a move before it and half the conversion's
/// work (by [`work`]) or more before it; `beside`, the share of that work
/// done beside it on the first part's thread, less.
fn cut_of<'a, I: Iterator<Item = &'a Op>>(ops: &impl Fn() -> I, beside: f64) -> Option<Cut> {
    let total = ops().map(work).sum::<usize>() as f64;
    // Truncation wanted: an op more or less on either side is the same.
    let half = (total * (1.0 - beside.clamp(0.0, 1.0)) / 2.0) as usize;
    let mut done = 0;
    let mut at = None;
    let mut plane = None;
    for (index, op) in ops().enumerate() {
        match op {
            Op::Rapid(m) => {
                if let (true, Some(at)) = (done >= half, at) {
                    return Some(Cut { index, at, plane });
                }
                at = Some(m.to);
            }
            Op::Line(m) => at = Some(m.to),
            Op::Arc(a) => {
                at = Some(a.to);
                plane = Some(a.plane);
            }
            _ => {}
        }
        done += work(op);
    }
    None
}

/// What a run of the writer over ops ended with.
struct Converted {
    /// Every op's error, in order.
    errors: Vec<Diagnostic>,
    /// It stopped early: the program grew beyond [`MAX_COMMANDS`].
    stopped: bool,
}

impl<'p> Writer<'p> {
    /// Converts `ops` one after the other, each op's error kept; stops
    /// where the program grows beyond [`MAX_COMMANDS`].
    fn convert<'o>(&mut self, ops: impl Iterator<Item = &'o Op>) -> Converted {
        let mut errors = Vec::new();
        for op in merged_ops(ops, self.profile.gcode.merge_tolerance) {
            if let Err(e) = self.op(&op) {
                errors.push(e);
            }
            if self.program.commands > MAX_COMMANDS {
                errors.push(too_many(op.origin(), "by this line the program has"));
                return Converted {
                    errors,
                    stopped: true,
                };
            }
        }
        Converted {
            errors,
            stopped: false,
        }
    }

    /// [`Writer::convert`] of a long job on two threads, cut at `cut`: the
    /// ops after the cut converted by a second writer that starts as the
    /// cut says this one will stand, its program appended. The program is
    /// the one one thread makes, line for line: when this writer ends the
    /// first part elsewhere (another plane), or the two parts together
    /// pass [`MAX_COMMANDS`] (the arcs' chords and the limit count the
    /// whole program), the second part is converted again, here, from
    /// where the first ended.
    fn convert_in_two<'o, I>(
        &mut self,
        ops: &(impl Fn() -> I + Sync),
        cut: &Cut,
        beside: Option<Beside<'_>>,
    ) -> Vec<Diagnostic>
    where
        I: Iterator<Item = &'o Op>,
    {
        let mut rest = self.fork(cut);
        let (start_at, start_plane) = (rest.at, rest.plane);
        let (first, second) = std::thread::scope(|scope| {
            let second = std::thread::Builder::new()
                .name("isel-convert".into())
                .spawn_scoped(scope, || rest.convert(ops().skip(cut.index)));
            if let Some(beside) = beside {
                (beside.work)();
            }
            let first = self.convert(ops().take(cut.index));
            // `None`: a thread the system would not start (its limit
            // reached); the second part is converted here, below.
            let second = second.ok().map(|second| {
                second
                    .join()
                    .unwrap_or_else(|payload| std::panic::resume_unwind(payload))
            });
            (first, second)
        });
        let mut errors = first.errors;
        if first.stopped {
            return errors;
        }
        let joins = (self.at, self.plane) == (start_at, start_plane)
            && self.program.commands + rest.program.commands <= MAX_COMMANDS;
        if let (true, Some(second)) = (joins, second) {
            errors.extend(second.errors);
            self.append(rest);
        } else {
            errors.extend(self.convert(ops().skip(cut.index)).errors);
        }
        errors
    }

    /// A writer for the ops after `cut`: this one's settings, an empty
    /// program, standing where the cut says.
    fn fork(&self, cut: &Cut) -> Writer<'p> {
        // No arc before the cut: the plane this writer starts in.
        let plane = match cut.plane {
            None => self.plane,
            Some(Plane::Xy) => IselPlane::XY,
            Some(Plane::Zx) => IselPlane::XZ,
            Some(Plane::Yz) => IselPlane::YZ,
        };
        Writer {
            axes: self.axes.clone(),
            program: Program {
                lines: Vec::with_capacity(self.program.lines.capacity() / 2),
                capacity: self.program.capacity,
                end_is_free: self.program.end_is_free,
                ..Program::default()
            },
            profile: self.profile,
            at: self.axes.steps(cut.at),
            plane,
            capped: 0,
            first_capped: None,
            spindle_speeds: None,
            start_key: self.start_key.clone(),
            safe_z: self.safe_z,
        }
    }

    /// The writer of the ops after this one's, appended: its program and
    /// what it counted.
    fn append(&mut self, rest: Writer<'_>) {
        self.program.append(rest.program);
        self.at = rest.at;
        self.plane = rest.plane;
        self.capped += rest.capped;
        self.first_capped = self.first_capped.or(rest.first_capped);
        self.spindle_speeds = self.spindle_speeds.or(rest.spindle_speeds);
    }
}

impl Writer<'_> {
    /// `m` to `target` steps at `hz`.
    fn move_to(&mut self, target: [i64; 3], hz: u32, origin: Origin, note: Option<&str>) {
        // The pairs of X Y Z, then `0,hz` for the z2 pair. In 3D mode the
        // x pair's speed is the path speed and the others are ignored
        // (2.2.29); they carry what their axis allows, so that a reader
        // (and `jogterm check`) sees no speed above an axis' max.
        let mut values = [0i64; COMMAND_NUMBERS];
        let pairs = self.axes.pairs.min(COMMAND_NUMBERS / 2);
        for k in 0..pairs {
            let speed = match self.axes.caps_hz.get(k) {
                Some(&cap) => hz.min(cap),
                None => hz,
            };
            values[2 * k] = target.get(k).copied().unwrap_or(0);
            values[2 * k + 1] = i64::from(speed);
        }
        let command = command_text(b'm', &values[..2 * pairs]);
        match note {
            Some(n) => self.program.command_noted(command, n, Some(origin)),
            None => self.program.command(command, Some(origin)),
        }
        self.at = target;
    }

    /// The path speed in steps/s for a move of `from` → `to` (mm) at
    /// `mm_per_s`, capped by every moving axis' `max_speed`.
    fn path_hz(&mut self, from: Point, to: Point, mm_per_s: f64, origin: Origin) -> u32 {
        let limits = self.axes.limits_hz;
        // The path speed is given as the x pair's (2.2.29): never above
        // X's own max_speed, whatever the direction.
        let ceiling = limits[0].min(HZ_MAX);
        let steps = (
            &self.axes.exact_steps(from)[..],
            &self.axes.exact_steps(to)[..],
        );
        let Some((hz, held)) = path_speed(from, to, steps, mm_per_s, &limits, ceiling) else {
            return HZ_MIN as u32;
        };
        if held {
            self.capped += 1;
            self.first_capped.get_or_insert(origin);
        }
        round(hz).clamp(HZ_MIN, HZ_MAX) as u32
    }

    fn rapid_mm_s(&self, from: Point, to: Point) -> f64 {
        match self.profile.gcode.rapid_speed {
            Some(s) => s,
            // As fast as the slowest moving axis allows on the path: the
            // cap in `path_hz` then holds every axis to its max_speed.
            None => f64::INFINITY.min(
                [Axis::X, Axis::Y, Axis::Z]
                    .into_iter()
                    .filter(|a| (get(to, *a) - get(from, *a)).abs() > 1e-12)
                    .map(|a| self.axes.of(a).max_speed)
                    .fold(f64::INFINITY, f64::max),
            ),
        }
    }

    fn op(&mut self, op: &Op) -> Result<(), Diagnostic> {
        match op {
            Op::Rapid(m) => {
                let speed = self.rapid_mm_s(m.from, m.to);
                let capped_before = (self.capped, self.first_capped);
                let hz = self.path_hz(m.from, m.to, speed, m.origin);
                // A rapid is meant to be as fast as allowed: no warning.
                if self.profile.gcode.rapid_speed.is_none() {
                    (self.capped, self.first_capped) = capped_before;
                }
                let target = self.axes.steps(m.to);
                if target != self.at {
                    self.move_to(target, hz, m.origin, None);
                    if m.to.z >= self.safe_z - 1e-9 {
                        self.program.retracted.push(self.program.lines.len() - 1);
                    }
                }
            }
            Op::Line(m) => {
                let hz = self.path_hz(m.from, m.to, m.feed / 60.0, m.origin);
                let target = self.axes.steps(m.to);
                if target != self.at {
                    self.move_to(target, hz, m.origin, None);
                }
            }
            Op::Arc(a) => self.arc(a)?,
            Op::Dwell(d) => {
                let mut tenths = (d.seconds * 10.0).round() as u64;
                if d.seconds > 0.0 && tenths == 0 {
                    tenths = 1;
                }
                while tenths > 0 {
                    let part = tenths.min(u64::from(u16::MAX));
                    self.program.command(format!("5{part}"), Some(d.origin));
                    tenths -= part;
                }
            }
            Op::Output(o) => {
                let (port, bit) = isel_output(&o.address).ok_or_else(|| {
                    error(
                        o.origin,
                        format!("output {} ({}) is no isel output port", o.name, o.address),
                    )
                })?;
                let v = u8::from(o.on);
                self.program.command_noted(
                    format!("p{port},{bit},{v}"),
                    &format!("{} {}", o.name, if o.on { "on" } else { "off" }),
                    Some(o.origin),
                );
            }
            Op::SpindleSpeed { rpm, origin } => {
                self.spindle_speeds.get_or_insert(*origin);
                self.program.lines.push(super::output::ProgramLine {
                    command: String::new(),
                    comment: Some(format!("S{rpm}: the controller sets no spindle speed")),
                    origin: Some(*origin),
                });
            }
            Op::Pause(p) => {
                let (origin, why) = match p {
                    Pause::Program { origin } => (*origin, "M0: program pause".to_owned()),
                    Pause::Optional { origin } => (
                        *origin,
                        "M1: optional pause (jogterm always pauses)".to_owned(),
                    ),
                    Pause::ToolChange { tool, origin } => (
                        *origin,
                        match tool {
                            Some(t) => format!("M6: change to tool T{t}"),
                            None => "M6: tool change (no T given)".to_owned(),
                        },
                    ),
                };
                let Some((port, bit, released, name)) = self.start_key.clone() else {
                    return Err(error(
                        origin,
                        format!(
                            "{why}: a pause waits for the machine's start key, and this profile wires none (an input with role \"start\" in [io])"
                        ),
                    ));
                };
                self.program.pauses.push((
                    origin,
                    format!("{why}: press the start key ({name}) at the machine to go on"),
                ));
                self.program.command_noted(
                    format!("o{port},{bit},{released},0"),
                    &format!("{why}; waits for the start key ({name})"),
                    Some(origin),
                );
            }
            Op::WorkOffset { .. } => {}
            Op::End { origin } => {
                self.program.command("9", Some(*origin));
            }
        }
        Ok(())
    }

    fn arc(&mut self, arc: &Arc) -> Result<(), Diagnostic> {
        let (u, v, n) = plane_axes(arc.plane);
        let (pu, pv) = (self.axes.of(u), self.axes.of(v));
        let round = (pu.steps_per_unit - pv.steps_per_unit).abs() < 1e-9;
        let isel_plane = match arc.plane {
            Plane::Xy => IselPlane::XY,
            Plane::Zx => IselPlane::XZ,
            Plane::Yz => IselPlane::YZ,
        };
        if !round {
            return self.arc_as_chords(arc, "the plane's axes have different steps per unit");
        }
        let spu = pu.steps_per_unit;
        // isel's angles: counter-clockwise from axis 1 of its plane; G18's
        // (Z, X) order is the other way round from isel's XZ.
        let (a1, a2, flip) = match arc.plane {
            Plane::Zx => (v, u, true),
            _ => (u, v, false),
        };
        let angle = |p: Point| {
            (get(p, a2) - get(arc.centre, a2))
                .atan2(get(p, a1) - get(arc.centre, a1))
                .to_degrees()
        };
        let cw = arc.clockwise != flip;
        let direction = if cw {
            CircleDirection::Cw
        } else {
            CircleDirection::Ccw
        };
        let r_steps = (radius(arc) * spu).round();
        // In a plane whose axes isel orders as RS-274/NGC does, its angles
        // are the ones the sweep is taken from (libm's atan2 once each).
        let (from_rad, to_rad) = end_angles(arc);
        let (start, end) = if flip {
            (angle(arc.from), angle(arc.to))
        } else {
            (from_rad.to_degrees(), to_rad.to_degrees())
        };
        let total = sweep_between(arc, from_rad, to_rad);
        let pieces = 1 + arc.extra_turns;
        let mm_per_s = arc.feed / 60.0;
        let mut hz = mm_per_s * spu;
        let max_hz = pu.speed_hz(pu.max_speed).min(pv.speed_hz(pv.max_speed));
        let capped = hz > max_hz + 0.5 || hz > HZ_MAX;
        hz = hz.min(max_hz).clamp(HZ_MIN, HZ_MAX);
        if capped {
            self.capped += 1;
            self.first_capped.get_or_insert(arc.origin);
        }
        let hz = hz.round() as u32;
        let n_profile = self.axes.of(n).clone();
        let rise_steps = n_profile.to_steps(get(arc.to, n)) - n_profile.to_steps(get(arc.from, n));
        if r_steps < 1.0 {
            self.line_instead(arc, hz);
            return Ok(());
        }
        if self.plane != isel_plane {
            self.program.command_noted(
                format!("e{}", isel_plane.value()),
                "circle plane",
                Some(arc.origin),
            );
            self.plane = isel_plane;
        }
        // The first piece sweeps what is beyond whole turns, then whole turns.
        let first = total - 2.0 * std::f64::consts::PI * f64::from(arc.extra_turns);
        let mut done_rise = 0i64;
        let mut swept = 0.0;
        for k in 0..pieces {
            let piece = if k == 0 {
                first
            } else {
                2.0 * std::f64::consts::PI
            };
            swept += piece;
            let (s_deg, e_deg) = if k == 0 { (start, end) } else { (end, end) };
            let rise_here = if rise_steps == 0 {
                0
            } else {
                let target = (rise_steps as f64 * swept / total).round() as i64;
                let r = target - done_rise;
                done_rise = target;
                r
            };
            let lines = if rise_steps == 0 {
                circle(r_steps as u32, s_deg, e_deg, direction, hz).map(|c| c.cnc_lines())
            } else {
                let s3 = i32::try_from(rise_here).unwrap_or(i32::MAX);
                helix(r_steps as u32, s_deg, e_deg, direction, hz, s3).map(|h| h.cnc_lines())
            };
            match lines {
                Ok([f, y]) => {
                    self.program.command(cnc_text(&f), Some(arc.origin));
                    self.program.command(cnc_text(&y), Some(arc.origin));
                }
                Err(CircleError::ArcTooShort) => {
                    self.line_instead(arc, hz);
                    return Ok(());
                }
                Err(e) => {
                    return self.arc_as_chords(arc, &e.to_string());
                }
            }
        }
        // The controller's step walk ends near, not always on, the end.
        let target = self.axes.steps(arc.to);
        self.move_to(target, hz, arc.origin, Some("to the arc's exact end"));
        Ok(())
    }

    fn line_instead(&mut self, arc: &Arc, hz: u32) {
        let target = self.axes.steps(arc.to);
        if target != self.at {
            self.move_to(
                target,
                hz,
                arc.origin,
                Some("an arc shorter than a step: a line"),
            );
        }
    }

    fn arc_as_chords(&mut self, arc: &Arc, why: &str) -> Result<(), Diagnostic> {
        let room = MAX_COMMANDS.saturating_sub(self.program.commands);
        let points = chords(arc, self.profile.gcode.chord_tolerance, room)
            .map_err(|_| too_many(arc.origin, "the arc's chords make the program"))?;
        self.program.warnings.push(Diagnostic {
            severity: Severity::Warning,
            origin: arc.origin,
            message: format!(
                "arc as chords ({} mm): {why}",
                self.profile.gcode.chord_tolerance
            ),
        });
        let mut from = arc.from;
        for p in points {
            let hz = self.path_hz(from, p, arc.feed / 60.0, arc.origin);
            let target = self.axes.steps(p);
            if target != self.at {
                self.move_to(target, hz, arc.origin, None);
            }
            from = p;
        }
        Ok(())
    }
}

/// The most numbers a command holds: an `m`'s four pairs, a `w`'s eight.
const COMMAND_NUMBERS: usize = 8;

/// `code` and the first [`COMMAND_NUMBERS`] of `values` in decimal,
/// comma-separated, as `Display` writes them: the digits are written
/// backwards into a buffer on the stack and the text copied once into a
/// `String` of its exact size. This runs for every move of the file; a
/// `String` appended to number by number (itoa's digits) was a copy call a
/// number and the formatting machinery before it more. Hand-written for
/// that: itoa into the same stack buffer measured 89-100 ms for the isel
/// conversion of the 500 000-line bench file, this 78-81 ms
/// (`cargo bench --bench gcode -- --no-node`); the test below holds it to
/// `Display` at the extremes.
fn command_text(code: u8, values: &[i64]) -> String {
    // A number is at most 20 bytes with its sign, and a comma before it.
    let mut buf = [0u8; 1 + COMMAND_NUMBERS * 21];
    let mut at = buf.len();
    let values = values.get(..COMMAND_NUMBERS).unwrap_or(values);
    for (k, &v) in values.iter().enumerate().rev() {
        // Two digits a division, as itoa does.
        let mut n = v.unsigned_abs();
        while n >= 100 {
            let pair = 2 * (n % 100) as usize;
            n /= 100;
            at -= 2;
            buf[at..at + 2].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
        }
        if n >= 10 {
            let pair = 2 * n as usize;
            at -= 2;
            buf[at..at + 2].copy_from_slice(&DIGIT_PAIRS[pair..pair + 2]);
        } else {
            at -= 1;
            buf[at] = b'0' + n as u8;
        }
        if v < 0 {
            at -= 1;
            buf[at] = b'-';
        }
        if k > 0 {
            at -= 1;
            buf[at] = b',';
        }
    }
    at -= 1;
    buf[at] = code;
    // ASCII throughout, so never the empty fallback.
    std::str::from_utf8(&buf[at..]).map_or_else(|_| String::new(), str::to_owned)
}

/// "00" to "99", the two digits of each.
const DIGIT_PAIRS: &[u8; 200] = b"\
0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// A circle's stored line (`f`, `y`, `w`: two of every arc) as its
/// `Display` writes it, by [`command_text`] rather than through the
/// formatting machinery; any other command through `Display`.
fn cnc_text(command: &CncCommand) -> String {
    let circle = |c: &CircleParams| {
        [
            i64::from(c.arc_length),
            i64::from(c.speed),
            i64::from(c.d),
            i64::from(c.xs),
            i64::from(c.ys),
            i64::from(c.rx.value()),
            i64::from(c.ry.value()),
        ]
    };
    let mut values = [0i64; COMMAND_NUMBERS];
    let (code, n) = match command {
        CncCommand::SetCircleDirection(d) => {
            values[0] = i64::from(d.value());
            (b'f', 1)
        }
        CncCommand::Circle(c) => {
            values[..7].copy_from_slice(&circle(c));
            (b'y', 7)
        }
        CncCommand::Helix(h) => {
            values[..7].copy_from_slice(&circle(&h.circle));
            values[7] = i64::from(h.s3);
            (b'w', 8)
        }
        other => return other.to_string(),
    };
    command_text(code, &values[..n])
}

/// The wired start key of the profile: `in1.3` → port 1, bit 3, and the
/// level it reads while released.
fn start_key(profile: &Profile) -> Option<(u32, u32, u8, String)> {
    let wiring = profile.wiring().ok()?;
    let key = wiring
        .bits()
        .iter()
        .find(|b| b.role == Role::Start && b.kind == BitKind::Input && b.wired)?;
    let (port, bit) = key.address.strip_prefix("in")?.split_once('.')?;
    let released = match key.active {
        Level::High => 0,
        Level::Low => 1,
    };
    Some((
        port.parse().ok()?,
        bit.parse().ok()?,
        released,
        key.name.clone(),
    ))
}

/// `out0.3` → port 0 bit 3; `out2` → port 2, bit 128 (the whole on/off port).
fn isel_output(address: &str) -> Option<(u32, u32)> {
    let rest = address.strip_prefix("out")?;
    match rest.split_once('.') {
        Some((port, bit)) => Some((port.parse().ok()?, bit.parse().ok()?)),
        None => Some((rest.parse().ok()?, 128)),
    }
}

#[cfg(test)]
#[path = "isel_split_tests.rs"]
mod split_tests;

#[cfg(test)]
mod tests {
    use super::{cnc_text, command_text};
    use crate::proto::isel::{
        CircleDirection, CircleParams, CncCommand, HelixParams, Sign, circle, helix,
    };

    #[test]
    fn circle_lines_are_written_as_display_writes_them() {
        let mut commands = vec![
            CncCommand::SetCircleDirection(CircleDirection::Cw),
            CncCommand::SetCircleDirection(CircleDirection::Ccw),
            CncCommand::SetStartStop(3),
        ];
        for (r, a, e, dir) in [
            (200, 135.0, 225.0, CircleDirection::Ccw),
            (3, 10.0, 350.0, CircleDirection::Cw),
            (40_000, 0.0, 0.0, CircleDirection::Ccw),
            (8_388_607, 30.0, 200.0, CircleDirection::Ccw),
        ] {
            if let Ok(c) = circle(r, a, e, dir, 1500) {
                commands.extend(c.cnc_lines());
            }
            if let Ok(h) = helix(r, a, e, dir, 40_000, -8_388_607) {
                commands.extend(h.cnc_lines());
            }
        }
        let extreme = CircleParams {
            arc_length: u32::MAX,
            speed: 0,
            d: i32::MIN,
            xs: i32::MAX,
            ys: -1,
            rx: Sign::Minus,
            ry: Sign::Plus,
        };
        commands.push(CncCommand::Circle(extreme));
        commands.push(CncCommand::Helix(HelixParams {
            circle: extreme,
            s3: i32::MIN,
        }));
        assert!(commands.len() > 12);
        for c in &commands {
            let text = cnc_text(c);
            assert_eq!(text, c.to_string());
            if matches!(
                c,
                CncCommand::Circle(_) | CncCommand::Helix(_) | CncCommand::SetCircleDirection(_)
            ) {
                assert_eq!(text.capacity(), text.len(), "{text}");
            }
        }
    }

    #[test]
    fn command_text_writes_what_display_writes() {
        let cases: [&[i64]; 6] = [
            &[],
            &[0],
            &[1, -1, 9, 10, -10, 99, 40_000, -123_456_789],
            &[
                i64::MAX,
                i64::MIN,
                i64::MIN,
                i64::MIN,
                i64::MIN,
                i64::MIN,
                i64::MIN,
                i64::MIN,
            ],
            &[i64::MIN; 8],
            &[100, 1000, 10_000, 100_000, 1_000_000, -999_999, 7],
        ];
        for values in cases {
            let shown: Vec<String> = values.iter().map(i64::to_string).collect();
            let text = command_text(b'm', values);
            assert_eq!(text, format!("m{}", shown.join(",")));
            assert_eq!(text.capacity(), text.len(), "{text}");
        }
    }
}
