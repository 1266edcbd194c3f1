//! How long a converted job takes on its controller (issue 41): a model of
//! the controller, per family, from the parameters jogterm sets at
//! initialisation, run over the converted program's own commands. Sans-IO:
//! pure functions of the program and the parameters (`docs/gcode.md`, "How
//! long a job takes").
//!
//! - **isel** (manual 2.2.15, 2.2.16): every move ramps from the
//!   start-stop frequency (`@0j`, `isel.start_stop_hz`) up at the
//!   acceleration (`@0J`, `isel.accel_hz_per_ms`) and back down to it at
//!   its end: a trapezoid, or a triangle when the move is too short to reach
//!   its speed, one command after the other. In 3D mode (`z1`, 2.2.29) the
//!   trapezoid runs along the X/Y/Z path at the x pair's speed; in 2.5D X/Y
//!   run first (the longer way leads at its own speed), then Z (2.2.2). A
//!   circle or helix (`y`, `w`, 2.3) is `B` steps at `V`, ramped the same
//!   way; it ends where the controller's walk ends, and the `m` after it
//!   covers the step or two to the exact end. A dwell `5` waits its tenths.
//!   Every stored command that neither moves nor waits takes 1 ms (the
//!   project's decision, `docs/protocols.md`: the manual gives no time).
//! - **EMCU** (manual 1.5.5-1.5.7, 1.5.10): the leading axis of an `L`
//!   ramps from the start speed (`#S`, `emcu.start_speed_hz`) to the slot's
//!   end speed (`#E`) in the ramp length (`#R`, `emcu.ramp_ms`), and down
//!   the same way. The manual does not say what a move too short for both
//!   ramps does: `emcu.short_move_ramp` says what is assumed (a triangle at
//!   the same acceleration by default, as the simulator runs it).
//! - **Reference runs** (isel `7`, EMCU `$H`): each axis from where it
//!   stands to its switch at the reference speed (isel `isel.reference_speed_hz`,
//!   ramped; EMCU the start speed, no ramp, 1.5.8). Where the axes stand
//!   before the program's first reference run is not known before the
//!   start: the model takes the job's first point.
//! - **Pauses and tool changes** wait for the operator: listed, not timed.
//!
//! The ways ([`super::ways`]) add the wire: a stored program's upload (each
//! command and its CR, one byte of answer), a stream's commands in DNC form
//! and each answer, which comes only when the move has ended (isel 2.2;
//! EMCU 1.4.2: the buffer's 0x02 CR): the axes stand meanwhile.

use std::ops::Range;

use crate::config::profile::{Profile, ShortMoveRamp};
use crate::program::Language;
use crate::proto::emcu::{Command as EmcuCommand, MoveMode, ReferenceOrder};
use crate::proto::isel::{
    ArcGeometry, CircleDirection, CircleParams, CncCommand, Command as IselCommand, DeviceNumber,
    Frame, MovePair, Plane, PortBits, parse_cnc,
};

use super::output::Program;

/// How a family's controller ramps a move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ramping {
    /// isel: from `start_hz` at a constant acceleration, Hz/s.
    Accel { start_hz: f64, accel_hz_per_s: f64 },
    /// EMCU: from `start_hz` to the end speed in `ramp_s`, whatever the end
    /// speed (the acceleration follows from both, manual 1.5.7).
    RampTime {
        start_hz: f64,
        ramp_s: f64,
        short: ShortMoveRamp,
    },
}

impl Ramping {
    /// Seconds a move of `steps` on its leading axis (or path) takes at
    /// `hz`.
    pub fn move_s(&self, steps: f64, hz: f64) -> f64 {
        match *self {
            Ramping::Accel {
                start_hz,
                accel_hz_per_s,
            } => trapezoid_s(steps, start_hz, hz, accel_hz_per_s),
            Ramping::RampTime {
                start_hz,
                ramp_s,
                short,
            } => {
                let accel = if hz > start_hz && ramp_s > 0.0 {
                    (hz - start_hz) / ramp_s
                } else {
                    0.0
                };
                let both_ramps = if accel > 0.0 {
                    (hz * hz - start_hz * start_hz) / accel
                } else {
                    0.0
                };
                match short {
                    ShortMoveRamp::StartSpeed if steps < both_ramps => {
                        steps / start_hz.min(hz).max(1.0)
                    }
                    _ => trapezoid_s(steps, start_hz, hz, accel),
                }
            }
        }
    }
}

/// Seconds `steps` take from `start_hz` up to `max_hz` at `accel` Hz/s and
/// back down to `start_hz`: a trapezoid, or a triangle when the move is too
/// short for its cruise. A start speed at or above `max_hz`, or no
/// acceleration, runs the whole move at the lower of the two, unramped.
pub fn trapezoid_s(steps: f64, start_hz: f64, max_hz: f64, accel: f64) -> f64 {
    if steps <= 0.0 {
        return 0.0;
    }
    let max_hz = max_hz.max(1e-9);
    let f0 = start_hz.min(max_hz).max(1e-9);
    if accel <= 0.0 || max_hz <= f0 {
        return steps / f0;
    }
    let ramp_steps = (max_hz * max_hz - f0 * f0) / (2.0 * accel);
    if 2.0 * ramp_steps <= steps {
        2.0 * (max_hz - f0) / accel + (steps - 2.0 * ramp_steps) / max_hz
    } else {
        let peak = (f0 * f0 + accel * steps).sqrt();
        2.0 * (peak - f0) / accel
    }
}

/// One ramped motion: steps of the leading axis (or of the path) at a
/// speed in Hz.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Leg {
    steps: f64,
    hz: f64,
}

/// One command of the program as the model sees it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Entry {
    /// Index into the program's lines.
    line: u32,
    /// Up to two ramped motions (2.5D: X/Y, then Z).
    legs: [Leg; 2],
    /// Time besides the ramped legs, not scaled by a speed factor: dwells,
    /// reference runs.
    fixed_s: f64,
    /// Time a stored program spends on a command that neither moves nor
    /// waits.
    step_s: f64,
    /// Bytes of the command in DNC form with its end (0: a stream sends
    /// nothing for it) and of its answers.
    out: u16,
    back: u16,
    /// Bytes of the stored line with its CR (0: the program's end `9`,
    /// counted by the upload itself).
    upload: u16,
    /// A dwell the stream times on the host (isel `5`, EMCU `W`).
    host_dwell: bool,
    /// Exchanges a stream makes for it: 2 where the driver reads the
    /// position after the move.
    trips: u8,
}

/// What a family's controller is, for the model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controller {
    pub language: Language,
    pub ramping: Ramping,
    /// Reference-run speed, Hz (isel: ramped like a move; EMCU: the start
    /// speed, constant).
    pub reference_hz: f64,
    /// The isel device number of the DNC frames.
    pub device: u8,
}

impl Controller {
    /// A stored command that neither moves nor waits (isel; the EMCU's
    /// buffer is taken as running those at once).
    pub const ISEL_PROGRAM_STEP_S: f64 = 0.001;

    /// The controller `profile` describes, as jogterm sets it up at
    /// initialisation.
    pub fn of(profile: &Profile, language: Language) -> Controller {
        match language {
            Language::Isel => Controller {
                language,
                ramping: Ramping::Accel {
                    start_hz: f64::from(profile.isel.start_stop_hz),
                    accel_hz_per_s: f64::from(profile.isel.accel_hz_per_ms) * 1000.0,
                },
                reference_hz: f64::from(profile.isel.reference_speed_hz),
                device: profile.isel.device,
            },
            Language::Emcu => Controller {
                language,
                ramping: Ramping::RampTime {
                    start_hz: f64::from(profile.emcu.start_speed_hz),
                    ramp_s: f64::from(profile.emcu.ramp_ms) / 1000.0,
                    short: profile.emcu.short_move_ramp,
                },
                reference_hz: f64::from(profile.emcu.start_speed_hz),
                device: 0,
            },
        }
    }
}

/// The model's view of one converted program: every command's motion,
/// its bytes on the wire both ways, and what waits for the operator.
#[derive(Debug, Clone, PartialEq)]
pub struct Timing {
    entries: Vec<Entry>,
    ramping: Ramping,
    /// Pauses and tool changes: they wait for the operator, not timed.
    pub listed: Vec<String>,
}

impl Timing {
    /// The model of `program` on `controller`.
    pub fn of(program: &Program, controller: &Controller) -> Timing {
        let listed = program.pauses.iter().map(|(_, why)| why.clone()).collect();
        let entries = match controller.language {
            Language::Isel => isel_entries(program, controller),
            Language::Emcu => emcu_entries(program, controller),
        };
        Timing {
            entries,
            ramping: controller.ramping,
            listed,
        }
    }

    fn motion_s(&self, e: &Entry, factor: f64) -> f64 {
        let scaled = |hz: f64| (hz * factor).floor().max(1.0);
        e.legs
            .iter()
            .filter(|l| l.steps > 0.0)
            .map(|l| {
                let hz = if factor >= 1.0 { l.hz } else { scaled(l.hz) };
                self.ramping.move_s(l.steps, hz)
            })
            .sum::<f64>()
            + e.fixed_s
    }

    fn within(&self, lines: &Range<usize>) -> impl Iterator<Item = &Entry> + use<'_> {
        let start = self
            .entries
            .partition_point(|e| (e.line as usize) < lines.start);
        let end = lines.end;
        self.entries[start..]
            .iter()
            .take_while(move |e| (e.line as usize) < end)
    }

    /// Commands in `lines`.
    pub fn within_count(&self, lines: Range<usize>) -> usize {
        self.within(&lines).count()
    }

    /// Seconds the controller runs the stored commands of `lines`.
    pub fn stored_run_s(&self, lines: Range<usize>) -> f64 {
        self.within(&lines)
            .map(|e| self.motion_s(e, 1.0) + e.step_s)
            .sum()
    }

    /// Bytes out and back of storing the commands of `lines`.
    pub fn upload_bytes(&self, lines: Range<usize>) -> usize {
        self.within(&lines)
            .map(|e| usize::from(e.upload) + usize::from(e.upload > 0))
            .sum()
    }

    /// The commands a stream sends for `lines`, with each one's motion at
    /// `factor` of the programmed speeds and its bytes both ways: `(line,
    /// motion_s, bytes)`; `bytes` 0 for what is timed on the host.
    pub fn stream(
        &self,
        lines: Range<usize>,
        factor: f64,
    ) -> impl Iterator<Item = StreamStep> + use<'_> {
        self.within(&lines).map(move |e| StreamStep {
            line: e.line as usize,
            motion_s: self.motion_s(e, factor),
            bytes: if e.host_dwell {
                0
            } else {
                usize::from(e.out) + usize::from(e.back)
            },
            trips: if e.host_dwell {
                0
            } else {
                usize::from(e.trips)
            },
        })
    }

    /// Seconds the moves of `lines` take at `factor`, ramps and all,
    /// nothing else (the wire, the upload).
    pub fn motion_only_s(&self, lines: Range<usize>, factor: f64) -> f64 {
        self.within(&lines).map(|e| self.motion_s(e, factor)).sum()
    }
}

/// One command of a stream.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamStep {
    pub line: usize,
    pub motion_s: f64,
    /// Bytes out and back (0: nothing goes to the controller).
    pub bytes: usize,
    /// Exchanges with the controller, each with the host's turnaround.
    pub trips: usize,
}

fn narrow(n: usize) -> u16 {
    u16::try_from(n).unwrap_or(u16::MAX)
}

/// Where the isel model stands between two commands.
struct IselState {
    at: [i64; 3],
    three_d: bool,
    plane: Plane,
    direction: CircleDirection,
    /// Where the axes stand before the first reference run: the job's
    /// first point, as assumed.
    known: bool,
    /// Whether the driver knows the virtual zero (after a reference run):
    /// only then does it know where an absolute move ends, and a stream
    /// skips the position read after it (`device::isel` `RawOp`).
    zero_known: bool,
}

fn isel_entries(program: &Program, c: &Controller) -> Vec<Entry> {
    let (start_hz, accel) = match c.ramping {
        Ramping::Accel {
            start_hz,
            accel_hz_per_s,
        } => (start_hz, accel_hz_per_s),
        Ramping::RampTime { start_hz, .. } => (start_hz, 0.0),
    };
    let device = DeviceNumber::new(c.device).unwrap_or(DeviceNumber::DEFAULT);
    let first_point = program
        .lines
        .iter()
        .find_map(|l| match l.command.as_bytes() {
            [b'm', ..] => parse_cnc(&l.command).ok().and_then(|p| match p.value {
                CncCommand::MoveAbsolute(pairs) => Some(absolute(&pairs)),
                _ => None,
            }),
            _ => None,
        });
    let mut s = IselState {
        at: first_point.unwrap_or([0; 3]),
        three_d: false,
        plane: Plane::XY,
        direction: CircleDirection::Cw,
        known: first_point.is_some(),
        zero_known: false,
    };
    let mut out = Vec::with_capacity(program.commands);
    for (index, line) in program.lines.iter().enumerate() {
        if line.command.is_empty() {
            continue;
        }
        let mut e = Entry {
            line: u32::try_from(index).unwrap_or(u32::MAX),
            upload: narrow(line.command.len() + 1),
            ..Entry::default()
        };
        let Ok(parsed) = parse_cnc(&line.command) else {
            // The linter refuses such a program; the model counts its
            // bytes only.
            e.out = narrow(line.command.len() + 3);
            e.back = 1;
            out.push(e);
            continue;
        };
        let command = parsed.value;
        let dnc = |command: IselCommand| Frame::new(device, command).to_string().len() + 1;
        match &command {
            CncCommand::MoveAbsolute(pairs) => {
                let to = absolute(pairs);
                e.legs = s.line_legs(to, pairs);
                s.at = to;
            }
            CncCommand::MoveRelative(pairs) => {
                let mut to = s.at;
                for (k, v) in to.iter_mut().enumerate() {
                    *v += pairs.get(k).map_or(0, |p| i64::from(p.steps));
                }
                if let Some(z2) = pairs.get(3) {
                    to[2] += i64::from(z2.steps);
                }
                e.legs = s.line_legs(to, pairs);
                s.at = to;
            }
            CncCommand::Circle(params) => {
                e.legs[0] = s.arc(params, None);
            }
            CncCommand::Helix(h) => {
                e.legs[0] = s.arc(&h.circle, Some(h.s3));
            }
            CncCommand::Reference(mask) => {
                // Z, Y, X (manual 2.2.22; `docs/protocols.md` isel 4).
                for i in [2usize, 1, 0] {
                    let Some(axis) = crate::axis::Axis::from_index(i) else {
                        continue;
                    };
                    if !mask.contains(axis) {
                        continue;
                    }
                    let from = if s.known { s.at[i].unsigned_abs() } else { 0 };
                    e.fixed_s += reference_s(from as f64, c.reference_hz, start_hz, accel);
                    s.at[i] = 0;
                }
                s.three_d = false;
                s.zero_known = true;
            }
            CncCommand::Set3dInterpolation(on) => s.three_d = *on,
            CncCommand::SetPlane(p) => s.plane = *p,
            CncCommand::SetCircleDirection(d) => s.direction = *d,
            CncCommand::Delay(tenths) => {
                e.fixed_s = f64::from(*tenths) / 10.0;
                e.host_dwell = true;
            }
            CncCommand::End => e.upload = 0,
            _ => {}
        }
        let moves = e.legs.iter().any(|l| l.steps > 0.0) || e.fixed_s > 0.0;
        if !moves && !matches!(command, CncCommand::End | CncCommand::Delay(_)) {
            e.step_s = Controller::ISEL_PROGRAM_STEP_S;
        }
        // The stream's form of it (`program::checkout::Plan::step`).
        let sent = match &command {
            CncCommand::SetPort {
                port,
                bits: PortBits::Byte,
                value,
            } => Some(IselCommand::WritePort {
                port: *port,
                value: *value,
            }),
            CncCommand::BranchOnPort { port, .. } => Some(IselCommand::ReadPort(*port)),
            other => other.as_dnc(),
        };
        if let Some(command) = sent {
            e.out = narrow(match &command {
                // The common case without a String per move: `@0` + the
                // stored text with the DNC letter + CR.
                IselCommand::MoveAbsolute(_) => line.command.len() + 3,
                other => dnc(other.clone()),
            });
            e.back = match &command {
                // `0` and two hex digits.
                IselCommand::ReadPort(_) => 3,
                _ => 1,
            };
            e.trips = 1;
            // The driver reads where a move ended (`@0P` CR out, `0` and 18
            // hex digits back, 3 axes) unless it knows the end exactly: an
            // absolute move from a known virtual zero (a relative one from
            // the position known after the first read). A circle's end is
            // the controller's own walk, which jogterm does not take for
            // known: it is read after every circle (`device::isel` `RawOp`).
            let read_back = match command {
                IselCommand::MoveAbsolute(_) => !s.zero_known,
                IselCommand::Circle(_) | IselCommand::Helix(_) => true,
                _ => false,
            };
            if read_back {
                e.back += 4 + 19;
                e.trips = 2;
            }
        }
        out.push(e);
    }
    out
}

/// The X, Y, Z targets of `m`'s pairs (z2 is ignored, 3.2.16).
fn absolute(pairs: &[MovePair]) -> [i64; 3] {
    let at = |k: usize| pairs.get(k).map_or(0, |p| i64::from(p.steps));
    [at(0), at(1), at(2)]
}

impl IselState {
    /// The legs of a straight move from here to `to`.
    fn line_legs(&self, to: [i64; 3], pairs: &[MovePair]) -> [Leg; 2] {
        let d = [0, 1, 2].map(|i| (to[i] - self.at[i]) as f64);
        let speed = |k: usize| pairs.get(k).map_or(1.0, |p| f64::from(p.speed.max(1)));
        if self.three_d {
            // 2.2.29: along the path at the x pair's speed; the simulator
            // and the controller count whole steps of the path.
            let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().round();
            [
                Leg {
                    steps: length,
                    hz: speed(0),
                },
                Leg::default(),
            ]
        } else {
            // 2.2.2: X/Y linearly, the longer way leading at its own speed
            // (X on a tie), then Z.
            let lead = if d[1].abs() > d[0].abs() { 1 } else { 0 };
            [
                Leg {
                    steps: d[lead].abs(),
                    hz: speed(lead),
                },
                Leg {
                    steps: d[2].abs(),
                    hz: speed(2),
                },
            ]
        }
    }

    /// A circle's leg (`B` steps at `V`), the axes moved to where its walk
    /// ends.
    fn arc(&mut self, params: &CircleParams, s3: Option<i32>) -> Leg {
        let geometry = ArcGeometry::of(params, self.direction);
        let (a1, a2) = self.plane.axes();
        let (i1, i2) = (a1.index(), a2.index());
        if let (Some(_), Some(_)) = (self.at.get(i1), self.at.get(i2)) {
            self.at[i1] += geometry.walk_end.0 - i64::from(params.xs);
            self.at[i2] += geometry.walk_end.1 - i64::from(params.ys);
        }
        if let Some(steps) = s3
            && let Some(v) = self.at.get_mut(self.plane.third_axis().index())
        {
            *v += i64::from(steps);
        }
        Leg {
            steps: f64::from(params.arc_length),
            hz: f64::from(params.speed.max(1)),
        }
    }
}

/// One axis' reference run (manual 2.2.22, as the simulator runs it,
/// `docs/simulator.md`): to its switch from `steps` away at `hz`, ramped
/// up and stopped at the switch; out of it again at the start-stop
/// frequency. The switch's release and the offset `@0IF` after it are not
/// in the profile: left out (a few tenths of a second per axis at most).
fn reference_s(steps: f64, hz: f64, start_hz: f64, accel: f64) -> f64 {
    let f0 = start_hz.min(hz).max(1.0);
    if accel <= 0.0 || hz <= f0 {
        return steps / f0;
    }
    let ramp_steps = (hz * hz - f0 * f0) / (2.0 * accel);
    if steps >= ramp_steps {
        (hz - f0) / accel + (steps - ramp_steps) / hz
    } else {
        ((f0 * f0 + 2.0 * accel * steps).sqrt() - f0) / accel
    }
}

/// The EMCU's commands, as a job runs them from the ROM or as a stream.
fn emcu_entries(program: &Program, c: &Controller) -> Vec<Entry> {
    let Ramping::RampTime {
        start_hz: mut start,
        ramp_s: mut ramp,
        short,
    } = c.ramping
    else {
        return Vec::new();
    };
    let mut slots = [600.0f64; 10];
    let first_point = program
        .lines
        .iter()
        .find_map(|l| match l.command.parse::<EmcuCommand>() {
            Ok(EmcuCommand::Move(mv)) if mv.mode() == MoveMode::Absolute => {
                let mut at = [0i64; 3];
                for (axis, steps) in mv.targets() {
                    at[axis.index()] = i64::from(steps.get());
                }
                Some(at)
            }
            _ => None,
        });
    let mut at = first_point.unwrap_or([0; 3]);
    let mut out = Vec::with_capacity(program.commands);
    for (index, line) in program.lines.iter().enumerate() {
        if line.command.is_empty() {
            continue;
        }
        let mut e = Entry {
            line: u32::try_from(index).unwrap_or(u32::MAX),
            upload: narrow(line.command.len() + 1),
            // The line ended by 0x01; its CR, then 0x02 CR when it has run.
            out: narrow(line.command.len() + 1),
            back: 3,
            trips: 1,
            ..Entry::default()
        };
        match line.command.parse::<EmcuCommand>() {
            Ok(EmcuCommand::Move(mv)) => {
                let mut to = at;
                for (axis, steps) in mv.targets() {
                    let i = axis.index();
                    let v = i64::from(steps.get());
                    if let Some(t) = to.get_mut(i) {
                        *t = match mv.mode() {
                            MoveMode::Absolute => v,
                            MoveMode::Relative => *t + v,
                        };
                    }
                }
                let lead = (0..3)
                    .map(|i| (to[i] - at[i]).unsigned_abs())
                    .max()
                    .unwrap_or(0);
                let slot = usize::from(mv.slot().get()).min(9);
                // A slot's own start speed and ramp may have changed in
                // the job: the leg carries the ones in force.
                let hz = slots[slot];
                let this = Ramping::RampTime {
                    start_hz: start,
                    ramp_s: ramp,
                    short,
                };
                if this == c.ramping {
                    e.legs[0] = Leg {
                        steps: lead as f64,
                        hz,
                    };
                } else {
                    e.fixed_s = this.move_s(lead as f64, hz);
                }
                at = to;
            }
            Ok(EmcuCommand::EndSpeed { slot, speed }) => {
                if let Some(s) = slots.get_mut(usize::from(slot.get())) {
                    *s = f64::from(speed.get());
                }
            }
            Ok(EmcuCommand::StartSpeed(s)) => start = f64::from(s.get()),
            Ok(EmcuCommand::Ramp(ms)) => ramp = f64::from(ms.get()) / 1000.0,
            Ok(EmcuCommand::Reference(order)) => {
                e.fixed_s = emcu_reference_s(&order, &mut at, start);
            }
            Ok(EmcuCommand::Wait(ms)) => {
                e.fixed_s = f64::from(ms.get()) / 1000.0;
                e.host_dwell = true;
            }
            _ => {}
        }
        out.push(e);
    }
    out
}

/// `$H` (manual 1.5.8): each axis down to its switch and off it again at
/// the start speed, without a ramp.
fn emcu_reference_s(order: &ReferenceOrder, at: &mut [i64; 3], start_hz: f64) -> f64 {
    let mut s = 0.0;
    for axis in order.axes() {
        let i = axis.index();
        if let Some(v) = at.get_mut(i) {
            s += v.unsigned_abs() as f64 / start_hz.max(1.0);
            *v = 0;
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gcode::output::ProgramLine;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn a_long_move_is_a_trapezoid_computed_by_hand() {
        // 300 Hz to 5300 Hz at 100 Hz/ms: 50 ms and 140 steps each way;
        // 10 000 - 280 = 9720 steps at 5300 Hz = 1.833962 s.
        let t = trapezoid_s(10_000.0, 300.0, 5300.0, 100_000.0);
        assert!(close(t, 0.1 + 9720.0 / 5300.0), "{t}");
    }

    #[test]
    fn a_short_move_is_a_triangle_computed_by_hand() {
        // 100 steps: the peak where 300² + 100 000 x 100 = peak², 3176.48 Hz,
        // reached after (3176.48 - 300) / 100 000 s, twice.
        let t = trapezoid_s(100.0, 300.0, 5300.0, 100_000.0);
        let peak = (300.0f64 * 300.0 + 100_000.0 * 100.0).sqrt();
        assert!(close(t, 2.0 * (peak - 300.0) / 100_000.0), "{t}");
        assert!((t - 0.0575295).abs() < 1e-6, "{t}");
        // At or below the start-stop frequency: no ramp at all.
        assert!(close(trapezoid_s(600.0, 300.0, 200.0, 100_000.0), 3.0));
        assert!(close(trapezoid_s(0.0, 300.0, 5300.0, 100_000.0), 0.0));
    }

    #[test]
    fn an_emcu_ramp_takes_its_length_whatever_the_end_speed() {
        // #S200, #E600, #R500: 800 Hz/s; both ramps 2 x 200 steps in 1 s.
        let r = Ramping::RampTime {
            start_hz: 200.0,
            ramp_s: 0.5,
            short: ShortMoveRamp::Triangle,
        };
        assert!(close(r.move_s(1000.0, 600.0), 1.0 + 600.0 / 600.0));
        // 100 steps: a triangle at 800 Hz/s, or (assumed otherwise) the
        // start speed throughout.
        let peak = (200.0f64 * 200.0 + 800.0 * 100.0).sqrt();
        assert!(close(r.move_s(100.0, 600.0), 2.0 * (peak - 200.0) / 800.0));
        let flat = Ramping::RampTime {
            start_hz: 200.0,
            ramp_s: 0.5,
            short: ShortMoveRamp::StartSpeed,
        };
        assert!(close(flat.move_s(100.0, 600.0), 0.5));
    }

    fn program(lines: &[&str]) -> Program {
        let mut p = Program::default();
        for l in lines {
            p.lines.push(ProgramLine {
                command: (*l).to_owned(),
                comment: None,
                origin: None,
            });
            p.commands += 1;
        }
        p
    }

    fn isel() -> Controller {
        Controller {
            language: Language::Isel,
            ramping: Ramping::Accel {
                start_hz: 300.0,
                accel_hz_per_s: 100_000.0,
            },
            reference_hz: 2000.0,
            device: 0,
        }
    }

    #[test]
    fn an_isel_program_in_3d_runs_each_move_on_its_path() {
        // From the first point (3000, 4000, 0): 3D, then 5000 steps of
        // path (3-4-5) at 5300 Hz and back; a dwell of 0.5 s.
        let p = program(&[
            "z1",
            "m3000,5300,4000,5300,0,5300,0,5300",
            "m0,5300,0,5300,0,5300,0,5300",
            "55",
            "9",
        ]);
        let t = Timing::of(&p, &isel());
        let one = 0.1 + (5000.0 - 280.0) / 5300.0;
        // z1 and the first m, which goes nowhere: 1 ms each stored; then
        // the path.
        let run = t.stored_run_s(0..5);
        assert!(close(run, 0.002 + one + 0.5), "{run}");
        // The stream: z1 and the m's as `@0z1`, `@0M…`, each answered
        // with one byte; the dwell on the host; `9` sends nothing.
        let steps: Vec<StreamStep> = t.stream(0..5, 1.0).collect();
        assert_eq!(steps.len(), 5);
        assert_eq!(steps[0].bytes, "@0z1\r".len() + 1);
        // No reference run: the driver reads the position after each
        // move (`@0P` CR, `0` and 18 digits).
        assert_eq!(
            steps[1].bytes,
            "@0M3000,5300,4000,5300,0,5300,0,5300\r".len() + 1 + 4 + 19
        );
        assert_eq!((steps[0].trips, steps[1].trips, steps[3].trips), (1, 2, 0));
        assert!(close(steps[2].motion_s, one));
        assert_eq!((steps[3].bytes, steps[3].motion_s), (0, 0.5));
        assert_eq!(steps[4].bytes, 0);
        // Storing: every line and CR, one byte back (z1 4, the m's 36 and
        // 30, 55 4); `9` by the upload.
        assert_eq!(t.upload_bytes(0..5), 4 + 36 + 30 + 4);
    }

    #[test]
    fn in_2_5d_x_and_y_run_first_the_longer_way_leading_then_z() {
        let p = program(&[
            "m0,1000,0,1000,0,1000,0,1000",
            "m1000,2000,3000,1000,400,300,0,300",
        ]);
        let t = Timing::of(&p, &isel());
        // Y leads (3000 steps at 1000 Hz), then Z 400 steps at 300 Hz
        // (no ramp: at the start-stop frequency).
        let y = trapezoid_s(3000.0, 300.0, 1000.0, 100_000.0);
        let run = t.stored_run_s(1..2);
        assert!(close(run, y + 400.0 / 300.0), "{run}");
        // Half the speed: 500 Hz, 150 Hz.
        let half = t.motion_only_s(1..2, 0.5);
        assert!(
            close(
                half,
                trapezoid_s(3000.0, 300.0, 500.0, 100_000.0) + 400.0 / 150.0
            ),
            "{half}"
        );
    }

    #[test]
    fn a_circle_is_its_b_steps_at_v_and_ends_where_its_walk_does() {
        // The manual's circle (2.3.6): B = 400 at 1500 Hz, ramped; the `m`
        // after it to the walk's end moves nothing: 1 ms, as any stored
        // command that does not move.
        let p = program(&[
            "m141,1500,141,1500,0,1500,0,1500",
            "z1",
            "f-1",
            "y400,1500,119,-141,141,-1,-1",
            "m141,1500,-141,1500,0,1500,0,1500",
        ]);
        let t = Timing::of(&p, &isel());
        let arc = trapezoid_s(400.0, 300.0, 1500.0, 100_000.0);
        let run = t.stored_run_s(3..5);
        assert!(close(run, arc + 0.001), "{run}");
        // 12 ms of ramp each way, 400 - 2 x 10.8 steps at 1500 Hz.
        assert!(
            (arc - (0.024 + (400.0 - 21.6) / 1500.0)).abs() < 1e-9,
            "{arc}"
        );
        // Streamed, the driver reads where the circle ended (`@0P` CR, `0`
        // and 18 digits): its end is the controller's walk. `f` moves
        // nothing and is not read after.
        let steps: Vec<StreamStep> = t.stream(2..4, 1.0).collect();
        assert_eq!((steps[0].bytes, steps[0].trips), ("@0f-1\r".len() + 1, 1));
        assert_eq!(
            (steps[1].bytes, steps[1].trips),
            ("@0y400,1500,119,-141,141,-1,-1\r".len() + 1 + 4 + 19, 2)
        );
    }

    #[test]
    fn a_reference_run_seeks_each_axis_to_its_switch() {
        // From the first point (0, 0, 4000): Z 4000 steps at 2000 Hz:
        // 17 ms and 19.55 steps up, 3980.45 steps at 2000 Hz to the switch.
        let p = program(&["77", "m0,2000,0,2000,4000,2000,0,2000"]);
        let t = Timing::of(&p, &isel());
        let want = 0.017 + 3980.45 / 2000.0;
        let run = t.stored_run_s(0..1);
        assert!(close(run, want), "{run} {want}");
    }

    #[test]
    fn an_emcu_job_ramps_its_leading_axis_in_the_ramp_length() {
        let p = program(&["#E7,600", "L7,X1000,Y200,Z0", "L7,X1000,Y1200,Z0", "W250"]);
        let c = Controller {
            language: Language::Emcu,
            ramping: Ramping::RampTime {
                start_hz: 200.0,
                ramp_s: 0.5,
                short: ShortMoveRamp::Triangle,
            },
            reference_hz: 200.0,
            device: 0,
        };
        let t = Timing::of(&p, &c);
        // The first move goes nowhere (the first point); the second: Y 1000
        // steps, both ramps 400 steps in 1 s, 600 at 600 Hz.
        let run = t.stored_run_s(0..4);
        assert!(close(run, 2.0 + 0.25), "{run}");
        // The stream: each line and 0x01 out, CR and 0x02 CR back.
        let bytes: Vec<usize> = t.stream(0..4, 1.0).map(|s| s.bytes).collect();
        assert_eq!(bytes, [7 + 4, 16 + 4, 17 + 4, 0]);
    }
}
