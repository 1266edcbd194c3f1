//! The EMCU output: a job for the ROM job store (`@F`, manual 1.5.17),
//! from a checked toolpath (`docs/gcode.md`, "EMCU").
//!
//! - `$HZXY` first (reference run, Z first so the tool leaves the part)
//!   unless the profile says `reference_first = false`, so that absolute
//!   moves (`L` with upper-case axes) count from the reference point.
//! - Every move is an absolute vector move `L<slot>,X…,Y…,Z…` (1.5.10) at
//!   the path speed of end-speed slot [`SLOT`], set with `#E` whenever the
//!   speed changes (1-9999 Hz, capped by every moving axis' `max_speed`).
//! - Arcs become chords within `gcode.chord_tolerance` (the EMCU has no
//!   circle interpolation).
//! - Dwells are `W` (ms, at most 9999 each), outputs `A1`/`A2`; a pause
//!   (M0, M1, M6) makes the next move wait for input E1 (`&V1` … `&V0`,
//!   1.5.19), the start key on the machines we know.

use std::fmt::Write as _;

use crate::axis::Axis;
use crate::config::profile::{AxisProfile, Profile};
use crate::proto::emcu::job::JOB_CAPACITY;

use super::output::{Header, MAX_COMMANDS, Program, chords, merged_ops, path_speed, too_many};
use super::toolpath::{Diagnostic, Op, Origin, Pause, Point, Severity, Toolpath};

/// The end-speed slot of the import's moves (jogterm's own moves use
/// `emcu.move_slot`, the teach-in slot 8).
pub const SLOT: u8 = 7;

const HZ_MIN: f64 = 1.0;
const HZ_MAX: f64 = 9999.0;

fn error(origin: Origin, message: impl Into<String>) -> Diagnostic {
    Diagnostic::error(origin, message)
}

struct Writer<'a> {
    axes: Vec<(Axis, AxisProfile)>,
    program: Program,
    profile: &'a Profile,
    speed: Option<u32>,
    at: Vec<i64>,
    capped: usize,
    first_capped: Option<Origin>,
    wait_e1: bool,
}

pub fn convert(
    path: &Toolpath,
    profile: &Profile,
    header: &Header,
) -> Result<Program, Vec<Diagnostic>> {
    convert_with(path, profile, header, &super::Options::default())
}

/// [`convert`] as `options` say: a piece of a job after its first has no
/// reference run.
pub fn convert_with(
    path: &Toolpath,
    profile: &Profile,
    header: &Header,
    options: &super::Options,
) -> Result<Program, Vec<Diagnostic>> {
    convert_ops(path.ops.iter(), profile, header, options)
}

/// [`convert_with`] of ops given one at a time (the import's whole job,
/// the slices of `Plan::expanded_slices`, is not collected into a toolpath).
pub fn convert_ops<'a>(
    ops: impl Iterator<Item = &'a Op>,
    profile: &Profile,
    header: &Header,
    options: &super::Options,
) -> Result<Program, Vec<Diagnostic>> {
    let axes: Vec<(Axis, AxisProfile)> = [Axis::X, Axis::Y, Axis::Z]
        .into_iter()
        .filter_map(|a| profile.axis(a).map(|p| (a, p.clone())))
        .collect();
    if axes.is_empty() {
        return Err(vec![error(
            Origin { line: 1, col: 1 },
            "the profile has no X, Y or Z axis",
        )]);
    }
    let mut w = Writer {
        at: vec![i64::MIN; axes.len()],
        axes,
        program: Program {
            capacity: profile.gcode.memory.unwrap_or(JOB_CAPACITY),
            ..Program::default()
        },
        profile,
        speed: None,
        capped: 0,
        first_capped: None,
        wait_e1: false,
    };
    for line in header.lines() {
        w.program.comment(line);
    }
    if profile.gcode.reference_first && !options.continued {
        let order: String = [Axis::Z, Axis::X, Axis::Y]
            .into_iter()
            .filter(|a| w.axes.iter().any(|(b, _)| b == a))
            .map(|a| a.letter())
            .collect();
        w.program.command_noted(
            format!("$H{order}"),
            "reference run: absolute moves count from it",
            None,
        );
    }
    let mut errors = Vec::new();
    for op in merged_ops(ops, profile.gcode.merge_tolerance) {
        if let Err(e) = w.op(&op) {
            errors.push(e);
        }
        if w.program.commands > MAX_COMMANDS {
            errors.push(too_many(op.origin(), "by this line the program has"));
            break;
        }
    }
    if !errors.is_empty() {
        return Err(errors);
    }
    if w.capped > 0 {
        w.program.warnings.push(Diagnostic {
            severity: Severity::Warning,
            origin: w.first_capped.unwrap_or_default(),
            message: format!(
                "{} moves asked for more speed than the machine gives (max_speed of an axis, or 9999 Hz): they run slower, the first at this line",
                w.capped
            ),
        });
    }
    Ok(w.program)
}

impl Writer<'_> {
    fn exact_steps(&self, p: Point) -> Vec<f64> {
        self.axes
            .iter()
            .map(|(a, prof)| super::interp::get(p, *a) * prof.steps_per_unit)
            .collect()
    }

    fn steps(&self, p: Point) -> Vec<i64> {
        self.axes
            .iter()
            .map(|(a, prof)| prof.to_steps(super::interp::get(p, *a)))
            .collect()
    }

    fn move_to(&mut self, from: Point, to: Point, mm_per_s: f64, origin: Origin) {
        let target = self.steps(to);
        if target == self.at {
            return;
        }
        let hz = self.path_hz(from, to, mm_per_s, origin);
        if self.speed != Some(hz) {
            self.program.command(format!("#E{SLOT},{hz}"), Some(origin));
            self.speed = Some(hz);
        }
        // Written in place, one String a move (this runs for every move
        // and chord of the file).
        let mut command = String::with_capacity(40);
        let _ = write!(command, "L{SLOT}");
        for ((a, _), s) in self.axes.iter().zip(&target) {
            let _ = write!(command, ",{}{s}", a.letter());
        }
        self.program.command(command, Some(origin));
        if self.wait_e1 {
            self.program
                .command_noted("&V0", "later moves start at once again", Some(origin));
            self.wait_e1 = false;
        }
        self.at = target;
    }

    fn path_hz(&mut self, from: Point, to: Point, mm_per_s: f64, origin: Origin) -> u32 {
        let limits: Vec<f64> = self
            .axes
            .iter()
            .map(|(_, p)| p.speed_hz(p.max_speed))
            .collect();
        let steps = (&self.exact_steps(from)[..], &self.exact_steps(to)[..]);
        let Some((hz, held)) = path_speed(from, to, steps, mm_per_s, &limits, HZ_MAX) else {
            return HZ_MIN as u32;
        };
        if held {
            self.capped += 1;
            self.first_capped.get_or_insert(origin);
        }
        hz.round().clamp(HZ_MIN, HZ_MAX) as u32
    }

    fn op(&mut self, op: &Op) -> Result<(), Diagnostic> {
        match op {
            Op::Rapid(m) => {
                let speed = self.profile.gcode.rapid_speed.unwrap_or(f64::INFINITY);
                self.move_to(m.from, m.to, speed, m.origin);
            }
            Op::Line(m) => self.move_to(m.from, m.to, m.feed / 60.0, m.origin),
            Op::Arc(a) => {
                let mut from = a.from;
                let room = MAX_COMMANDS.saturating_sub(self.program.commands);
                let points = chords(a, self.profile.gcode.chord_tolerance, room)
                    .map_err(|_| too_many(a.origin, "the arc's chords make the program"))?;
                for p in points {
                    self.move_to(from, p, a.feed / 60.0, a.origin);
                    from = p;
                }
            }
            Op::Dwell(d) => {
                let mut ms = (d.seconds * 1000.0).round() as u64;
                while ms > 0 {
                    let part = ms.min(9999);
                    self.program.command(format!("W{part}"), Some(d.origin));
                    ms -= part;
                }
            }
            Op::Output(o) => {
                let n = o
                    .address
                    .strip_prefix('A')
                    .and_then(|n| n.parse::<u8>().ok())
                    .filter(|n| (1..=2).contains(n))
                    .ok_or_else(|| {
                        error(
                            o.origin,
                            format!(
                                "output {} ({}) is no EMCU output (A1, A2)",
                                o.name, o.address
                            ),
                        )
                    })?;
                self.program.command_noted(
                    format!("A{n},{}", u8::from(o.on)),
                    &format!("{} {}", o.name, if o.on { "on" } else { "off" }),
                    Some(o.origin),
                );
            }
            Op::SpindleSpeed { rpm, origin } => {
                self.program.lines.push(super::output::ProgramLine {
                    command: String::new(),
                    comment: Some(format!("S{rpm}: the controller sets no spindle speed")),
                    origin: Some(*origin),
                });
            }
            Op::Pause(p) => {
                let origin = match p {
                    Pause::Program { origin }
                    | Pause::Optional { origin }
                    | Pause::ToolChange { origin, .. } => *origin,
                };
                let why = match p {
                    Pause::ToolChange { tool: Some(t), .. } => {
                        format!("M6 T{t}: change the tool, then press start (E1)")
                    }
                    _ => "pause: press start (E1) to go on".to_owned(),
                };
                if !start_key_is_e1(self.profile) {
                    return Err(error(
                        origin,
                        format!(
                            "{why}: an EMCU pause waits for input E1 (`&V1`, manual 1.5.19), and this profile does not wire E1 as the start key (role \"start\" in [io])"
                        ),
                    ));
                }
                self.program
                    .pauses
                    .push((origin, format!("{why} at the machine")));
                if !self.wait_e1 {
                    self.program.command_noted("&V1", &why, Some(origin));
                    self.wait_e1 = true;
                }
            }
            Op::WorkOffset { .. } | Op::End { .. } => {}
        }
        Ok(())
    }
}

/// Whether the profile wires E1, the input `&V1` waits for, as the start key.
fn start_key_is_e1(profile: &Profile) -> bool {
    profile.wiring().is_ok_and(|w| {
        w.bit("E1")
            .is_some_and(|b| b.wired && b.role == crate::wiring::Role::Start)
    })
}
