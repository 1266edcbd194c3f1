//! An isel CNC program in DNC form, for the editor's hold-to-run check-out
//! (`docs/editor.md`, "Check-out"): each stored command as the DNC command
//! that does the same (manual chapter 3 against chapter 2), loops, jumps and
//! port branches executed here, and the lines the DNC form cannot do
//! exactly named before anything moves.
//!
//! Sans-IO: [`Plan`] says what line comes next and what to send for it;
//! the editor sends it, and tells the plan when the line is done
//! ([`Plan::advance`], with the port byte an `o` asked for).
//!
//! CNC → DNC (manual 3.2.x → 2.2.x): `0` → `@0A`, `m` → `@0M`, `y` → `@0y`,
//! `w` → `@0w`, `7` → `@0R`, `e` `f` `z` `j` `J` `d` `g` `n` `N` `T` → the
//! same letter, `p` of a whole port → `@0B`, `o` → `@0b` and the branch
//! taken here, `3` loops and jumps here (3.2.5: `3 n,-k` runs the k lines n
//! more times), `5` a dwell timed here, `1` (a sync character to the host,
//! which the check-out is) nothing. Not expressible: `2` (waits for a
//! character the host sends: the host is jogterm, which has none to send),
//! `6` (its move in DNC is `@0Z`, one straight line of every axis, not the
//! 2.5D phases of `0`/`m`), `p` of one bit (`@0B` writes whole ports).

use std::time::Duration;

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{
    ArcGeometry, AxisConfig, CircleDirection, CncCommand, Command, MovePair, PortBits,
};

use super::flow::{self, Flow};
use super::model::{Command as ProgramCommand, Program};

/// A DNC command of the plan, as the editor keeps it (the editor imports
/// no protocol module, `docs/architecture.md`).
pub use crate::proto::isel::Command as DncCommand;

/// The DNC line of `command` for the controller with device number
/// `device` (`@0A…`), without its CR.
pub fn line_text(device: u8, command: &Command) -> String {
    let device = crate::proto::isel::DeviceNumber::new(device)
        .unwrap_or(crate::proto::isel::DeviceNumber::DEFAULT);
    crate::proto::isel::Frame::new(device, command.clone()).to_string()
}

/// An `@0M` to the controller counters `target`, counted from the virtual
/// zero `zero` (manual 2.2.18), each axis at `hz(axis)`; with 3 axes the
/// z2 pair is 0 (`docs/decisions.md` isel 5).
pub fn go_to(
    config: AxisConfig,
    target: [i64; 4],
    zero: [i64; 4],
    hz: &dyn Fn(Axis) -> u32,
) -> Command {
    let pairs = pair_axes(config)
        .iter()
        .enumerate()
        .map(|(i, axis)| {
            let z2 = config == AxisConfig::XYZ && i == 3;
            let k = axis.index();
            let steps = if z2 {
                0
            } else {
                target.get(k).copied().unwrap_or(0) - zero.get(k).copied().unwrap_or(0)
            };
            MovePair::new(
                i32::try_from(steps).unwrap_or(if steps < 0 { i32::MIN } else { i32::MAX }),
                hz(*axis),
            )
        })
        .collect();
    Command::MoveAbsolute(pairs)
}

/// `command` with the speeds of its pairs through `speed` (axis, Hz asked →
/// Hz on the wire); other commands as they are.
pub fn with_speeds(
    command: Command,
    config: AxisConfig,
    speed: &dyn Fn(Axis, u32) -> u32,
) -> Command {
    let scale = |pairs: Vec<MovePair>| -> Vec<MovePair> {
        pairs
            .iter()
            .zip(pair_axes(config))
            .map(|(p, a)| MovePair::new(p.steps, speed(*a, p.speed)))
            .collect()
    };
    match command {
        Command::MoveAbsolute(p) => Command::MoveAbsolute(scale(p)),
        Command::MoveRelative(p) => Command::MoveRelative(scale(p)),
        other => other,
    }
}

/// Loop counters the controller has (manual 3.2.5).
const LOOP_SLOTS: usize = 7;

/// A line the DNC form cannot run as the stored program would.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unexpressible {
    /// Source line (0-based).
    pub line: usize,
    pub reason: String,
}

/// What one line is in DNC form.
#[derive(Debug, Clone, PartialEq)]
pub enum DncStep {
    /// Send the command; `moves`: it sets axes in motion, held by the
    /// check-out's lease.
    Send { command: Command, moves: bool },
    /// `o`: read the port, then [`Plan::advance`] with its byte.
    ReadPort { command: Command },
    /// `5`: wait, counted while the key is held.
    Dwell(Duration),
    /// Nothing goes to the controller (jumps, loops, `1`, `9`).
    Nothing,
}

/// Why the plan has ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Finish {
    /// At `9`, or past the last line.
    End,
    /// A loop needs an eighth counter (the controller answers `6`).
    LoopStack { line: usize },
    /// A jump leads out of the program.
    OutOfProgram { line: usize },
    /// A line that does not parse (the linter refuses the program before).
    Broken { line: usize },
}

/// The axis each steps,speed pair of a `0`/`m`/`@0A`/`@0M` moves.
pub fn pair_axes(config: AxisConfig) -> &'static [Axis] {
    match config {
        AxisConfig::X => &[Axis::X],
        AxisConfig::XY => &[Axis::X, Axis::Y],
        AxisConfig::XYZ => &[Axis::X, Axis::Y, Axis::Z, Axis::Z],
        AxisConfig::XYZA => &[Axis::X, Axis::Y, Axis::Z, Axis::A],
    }
}

/// The controller's axis setting for a machine's axes.
pub fn config_of(axes: AxisSet) -> Option<AxisConfig> {
    AxisConfig::ALL.into_iter().find(|c| c.axes() == axes)
}

/// The program run by jogterm line by line: where it is, its loop counters.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    commands: Vec<Option<CncCommand>>,
    lines: Vec<usize>,
    config: AxisConfig,
    pc: usize,
    loops: Vec<(usize, u16)>,
    finish: Option<Finish>,
    /// The circle direction in force (`f`), for the arcs' end points.
    direction: Option<CircleDirection>,
}

impl Plan {
    /// The plan at the program's first command.
    pub fn new(program: &Program, config: AxisConfig) -> Plan {
        let mut commands = Vec::new();
        let mut lines = Vec::new();
        for (line, statement) in program.statements() {
            commands.push(
                statement
                    .command
                    .as_ref()
                    .ok()
                    .and_then(ProgramCommand::as_isel)
                    .cloned(),
            );
            lines.push(line);
        }
        let mut plan = Plan {
            commands,
            lines,
            config,
            pc: 0,
            loops: Vec::new(),
            finish: None,
            direction: None,
        };
        plan.settle();
        plan
    }

    /// The source line of the command to run next; `None` once ended.
    pub fn line(&self) -> Option<usize> {
        self.finish
            .is_none()
            .then(|| self.lines.get(self.pc).copied())
            .flatten()
    }

    /// The controller's axis setting the plan was made for.
    pub fn config(&self) -> AxisConfig {
        self.config
    }

    pub fn finish(&self) -> Option<&Finish> {
        self.finish.as_ref()
    }

    fn current(&self) -> Option<&CncCommand> {
        self.commands.get(self.pc).and_then(Option::as_ref)
    }

    /// The current line in DNC form, speeds through `speed` (Hz asked by
    /// the program, axis → Hz on the wire; an arc passes each of its
    /// plane's axes and takes the lowest).
    pub fn step(&self, speed: &dyn Fn(Axis, u32) -> u32) -> Option<DncStep> {
        self.line()?;
        let Some(command) = self.current() else {
            return Some(DncStep::Nothing);
        };
        let send = |command: Command, moves: bool| Some(DncStep::Send { command, moves });
        let pairs = |p: &[MovePair]| -> Vec<MovePair> {
            p.iter()
                .zip(pair_axes(self.config))
                .map(|(pair, axis)| MovePair::new(pair.steps, speed(*axis, pair.speed)))
                .collect()
        };
        let arc_speed = |v: u32| {
            let (a, b) = self.plane().axes();
            speed(a, v).min(speed(b, v)).max(1)
        };
        match command {
            CncCommand::MoveRelative(p) => send(Command::MoveRelative(pairs(p)), true),
            CncCommand::MoveAbsolute(p) => send(Command::MoveAbsolute(pairs(p)), true),
            CncCommand::Circle(c) => {
                let mut c = *c;
                c.speed = arc_speed(c.speed);
                send(Command::Circle(c), true)
            }
            CncCommand::Helix(h) => {
                let mut h = *h;
                h.circle.speed = arc_speed(h.circle.speed);
                send(Command::Helix(h), true)
            }
            CncCommand::Reference(mask) => send(Command::Reference(*mask), true),
            CncCommand::SetPlane(p) => send(Command::SetPlane(*p), false),
            CncCommand::SetCircleDirection(d) => send(Command::SetCircleDirection(*d), false),
            CncCommand::Set3dInterpolation(on) => send(Command::Set3dInterpolation(*on), false),
            CncCommand::SetStartStop(hz) => send(Command::SetStartStop(*hz), false),
            CncCommand::SetAcceleration(a) => send(Command::SetAcceleration(*a), false),
            CncCommand::SetReferenceSpeeds(s) => {
                send(Command::SetReferenceSpeeds(s.clone()), false)
            }
            CncCommand::SetBrake(on) => send(Command::SetBrake(*on), false),
            CncCommand::SetZero(mask) => send(Command::SetZero(*mask), false),
            CncCommand::SimulateReference(mask) => send(Command::SimulateReference(*mask), false),
            CncCommand::SetTestMode(on) => send(Command::SetTestMode(*on), false),
            CncCommand::SetPort {
                port,
                bits: PortBits::Byte,
                value,
            } => send(
                Command::WritePort {
                    port: *port,
                    value: *value,
                },
                false,
            ),
            CncCommand::BranchOnPort { port, .. } => Some(DncStep::ReadPort {
                command: Command::ReadPort(*port),
            }),
            CncCommand::Delay(tenths) => Some(DncStep::Dwell(Duration::from_millis(
                u64::from(*tenths) * 100,
            ))),
            // Not expressible: named before the start (`unexpressible`),
            // and a check-out does not start while there are any.
            CncCommand::SetPort { .. }
            | CncCommand::WaitSync { .. }
            | CncCommand::PortCondition { .. }
            | CncCommand::SendSync(_)
            | CncCommand::Loop { .. }
            | CncCommand::End => Some(DncStep::Nothing),
        }
    }

    /// The plane of the circles to come: the last `e` before the current
    /// line on the way the plan went is not tracked; the controller's plane
    /// is what counts, and it is the same for every axis' cap but the
    /// arc's own, so the lowest of all axes would do too. XY unless an `e`
    /// was passed.
    fn plane(&self) -> crate::proto::isel::Plane {
        self.commands
            .get(..self.pc)
            .into_iter()
            .flatten()
            .rev()
            .find_map(|c| match c {
                Some(CncCommand::SetPlane(p)) => Some(*p),
                _ => None,
            })
            .unwrap_or(crate::proto::isel::Plane::XY)
    }

    /// The current line is done; `port`: the byte an `o` read. Goes on to
    /// the next line to run (jumps and loops followed).
    pub fn advance(&mut self, port: Option<u8>) {
        if self.finish.is_some() {
            return;
        }
        let command = self.current().cloned();
        if let Some(CncCommand::SetCircleDirection(d)) = &command {
            self.direction = Some(*d);
        }
        let next = match &command {
            Some(CncCommand::BranchOnPort {
                bits,
                value,
                offset,
                ..
            }) => {
                let read = port.unwrap_or(0);
                let taken = match bits {
                    PortBits::Byte => read == *value,
                    PortBits::Bit(b) => (read >> b) & 1 == *value,
                };
                if taken {
                    self.pc as i64 + i64::from(*offset)
                } else {
                    self.pc as i64 + 1
                }
            }
            other => match flow::flow_of(other.as_ref(), self.pc) {
                Flow::End => {
                    self.finish = Some(Finish::End);
                    return;
                }
                Flow::Next | Flow::Branch(_) => self.pc as i64 + 1,
                Flow::Jump(t) => t,
                Flow::Loop { start } => {
                    let count = match other {
                        Some(CncCommand::Loop { count, .. }) => *count,
                        _ => 0,
                    };
                    match self.repeat(count) {
                        Ok(true) => start,
                        Ok(false) => self.pc as i64 + 1,
                        Err(()) => {
                            self.finish = Some(Finish::LoopStack {
                                line: self.lines.get(self.pc).copied().unwrap_or(0),
                            });
                            return;
                        }
                    }
                }
            },
        };
        self.go(next);
    }

    /// The loop at `pc` with `count` more runs: whether it jumps back
    /// (manual 3.2.5, `docs/protocols.md` isel "Running stored programs").
    fn repeat(&mut self, count: u16) -> Result<bool, ()> {
        let pc = self.pc;
        match self.loops.iter().rposition(|(i, _)| *i == pc) {
            Some(pos) => {
                // Counters of inner loops left by a jump are dropped.
                self.loops.truncate(pos + 1);
                match self.loops.get_mut(pos) {
                    Some(entry) if entry.1 > 0 => {
                        entry.1 -= 1;
                        Ok(true)
                    }
                    _ => {
                        self.loops.truncate(pos);
                        Ok(false)
                    }
                }
            }
            None if self.loops.len() >= LOOP_SLOTS => Err(()),
            None => {
                self.loops.push((pc, count.saturating_sub(1)));
                Ok(true)
            }
        }
    }

    fn go(&mut self, target: i64) {
        let len = self.commands.len();
        match usize::try_from(target).ok() {
            Some(t) if t < len => {
                self.pc = t;
                self.settle();
            }
            Some(t) if t == len => self.finish = Some(Finish::End),
            _ => {
                self.finish = Some(Finish::OutOfProgram {
                    line: self.lines.get(self.pc).copied().unwrap_or(0),
                })
            }
        }
    }

    /// An empty program, or a line that does not parse, ends the plan.
    fn settle(&mut self) {
        match self.commands.get(self.pc) {
            None => self.finish = Some(Finish::End),
            Some(None) => {
                self.finish = Some(Finish::Broken {
                    line: self.lines.get(self.pc).copied().unwrap_or(0),
                })
            }
            Some(Some(_)) => {}
        }
    }

    /// The plan walked without moving up to the first time it reaches
    /// source line `line` (run from a line), from the controller counters
    /// `position` and virtual zero `zero`: where the skipped moves would
    /// have left the axes, and the settings the skipped lines made.
    /// `o` branches are taken as not taken (their port cannot be read
    /// ahead). Errors name why the line cannot be started from.
    pub fn skip_to(
        &mut self,
        line: usize,
        position: [i64; 4],
        zero: [i64; 4],
    ) -> Result<Skipped, String> {
        let mut s = Skipped {
            position,
            settings: Vec::new(),
            outputs: Vec::new(),
            skipped_moves: 0,
        };
        let mut budget = 1_000_000usize;
        while self.line() != Some(line) {
            let Some(at) = self.line() else {
                return Err(format!(
                    "the program does not reach line {} from its start",
                    line + 1
                ));
            };
            budget = budget.saturating_sub(1);
            if budget == 0 {
                return Err(format!(
                    "line {} is not reached within a million commands",
                    line + 1
                ));
            }
            let command = self.current().cloned();
            match &command {
                Some(CncCommand::MoveRelative(p)) => {
                    for (pair, axis) in p.iter().zip(pair_axes(self.config)) {
                        let i = axis.index();
                        if let Some(v) = s.position.get_mut(i) {
                            *v += i64::from(pair.steps);
                        }
                    }
                    s.skipped_moves += 1;
                }
                Some(CncCommand::MoveAbsolute(p)) => {
                    // 3 axes: the z2 pair of `m` is ignored (3.2.16).
                    for (pair, axis) in p
                        .iter()
                        .zip(pair_axes(self.config))
                        .take(if self.config == AxisConfig::XYZ { 3 } else { 4 })
                    {
                        let i = axis.index();
                        if let (Some(v), Some(z)) = (s.position.get_mut(i), zero.get(i)) {
                            *v = z + i64::from(pair.steps);
                        }
                    }
                    s.skipped_moves += 1;
                }
                Some(CncCommand::Circle(c)) => {
                    self.skip_arc(&mut s, c, None)?;
                }
                Some(CncCommand::Helix(h)) => {
                    self.skip_arc(&mut s, &h.circle, Some(h.s3))?;
                }
                Some(CncCommand::Reference(mask)) => {
                    for a in mask.iter() {
                        if let Some(v) = s.position.get_mut(a.index()) {
                            *v = 0;
                        }
                    }
                    s.skipped_moves += 1;
                    s.settings
                        .retain(|(c, _)| !matches!(c, Command::Set3dInterpolation(_)));
                }
                Some(CncCommand::SetZero(_)) => {
                    return Err(format!(
                        "line {} sets the zero (n) where the machine stands then: run from it or \
                         a line before it",
                        at + 1
                    ));
                }
                Some(CncCommand::SimulateReference(_)) => {
                    return Err(format!(
                        "line {} makes the position there the reference point (N): run from it \
                         or a line before it",
                        at + 1
                    ));
                }
                Some(CncCommand::SetPort { .. }) => {
                    // Outputs switch things (a spindle): named, not sent.
                    if let Some(DncStep::Send { command, .. }) = self.step(&|_, hz| hz) {
                        s.outputs.push((command, at));
                    }
                }
                _ => {
                    if let Some(DncStep::Send {
                        command,
                        moves: false,
                    }) = self.step(&|_, hz| hz)
                    {
                        // The last setting of each kind counts.
                        s.settings.retain(|(c, _)| {
                            std::mem::discriminant(c) != std::mem::discriminant(&command)
                        });
                        s.settings.push((command, at));
                    }
                }
            }
            self.advance(None);
        }
        Ok(s)
    }

    fn skip_arc(
        &self,
        s: &mut Skipped,
        params: &crate::proto::isel::CircleParams,
        helix: Option<i32>,
    ) -> Result<(), String> {
        let direction = self.direction.ok_or_else(|| {
            format!(
                "an arc before it (line {}) has no circle direction (f) before it",
                self.lines.get(self.pc).map_or(0, |l| l + 1)
            )
        })?;
        let plane = self.plane();
        let (a, b) = plane.axes();
        let (dx, dy) = ArcGeometry::of(params, direction).end().from_start;
        if let Some(v) = s.position.get_mut(a.index()) {
            *v += i64::from(dx);
        }
        if let Some(v) = s.position.get_mut(b.index()) {
            *v += i64::from(dy);
        }
        if let (Some(steps), Some(v)) = (helix, s.position.get_mut(plane.third_axis().index())) {
            *v += i64::from(steps);
        }
        s.skipped_moves += 1;
        Ok(())
    }
}

/// What skipping to a line implies: where the axes would stand (the
/// controller's counters) and the settings in force, each with its source
/// line, to send before the line runs.
#[derive(Debug, Clone, PartialEq)]
pub struct Skipped {
    pub position: [i64; 4],
    pub settings: Vec<(Command, usize)>,
    /// Outputs the skipped lines write: named to the operator, not sent
    /// (they switch things, a spindle; the operator decides).
    pub outputs: Vec<(Command, usize)>,
    pub skipped_moves: usize,
}

/// The lines of `program` the DNC form cannot run as the stored program
/// would, with the reason; a check-out starts only without any.
pub fn unexpressible(program: &Program) -> Vec<Unexpressible> {
    let mut out = Vec::new();
    for (line, statement) in program.statements() {
        let Some(command) = statement
            .command
            .as_ref()
            .ok()
            .and_then(ProgramCommand::as_isel)
        else {
            continue;
        };
        let reason = match command {
            CncCommand::WaitSync { .. } => {
                "`2` waits for a character from the host; in a check-out jogterm is the host \
                 and sends none"
            }
            CncCommand::PortCondition { .. } => {
                "`6` ends the next move on a port event; in DNC that is `@0Z`, one straight \
                 line of all axes, not the phases of `0`/`m`"
            }
            CncCommand::SetPort {
                bits: PortBits::Bit(_),
                ..
            } => "`p` of one bit: DNC `@0B` writes whole ports only",
            _ => continue,
        };
        out.push(Unexpressible {
            line,
            reason: reason.to_owned(),
        });
    }
    out
}

/// Lines where a pause resumes with a promise the manual does not give:
/// 0xFD and `@0S` are described for positioning moves (manual 2.2.31), not
/// for arcs and reference runs. A reference run paused is run again whole.
pub fn pause_caveat(command: &Command) -> Option<&'static str> {
    match command {
        Command::Circle(_) | Command::Helix(_) => Some(
            "a pause inside an arc resumes with @0S, which manual 2.2.31 promises for linear moves only",
        ),
        Command::Reference(_) => Some("a paused reference run starts again from its beginning"),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::Language;

    fn plan(text: &str) -> Plan {
        Plan::new(&Program::parse(Language::Isel, text), AxisConfig::XYZ)
    }

    fn half(_: Axis, hz: u32) -> u32 {
        hz / 2
    }

    /// The DNC text of every line the plan runs, in order, `o` reading
    /// `port`.
    fn run(text: &str, port: u8) -> Vec<String> {
        let mut p = plan(text);
        let mut out = Vec::new();
        while let Some(step) = p.step(&|_, hz| hz) {
            let mut read = None;
            match step {
                DncStep::Send { command, .. } => out.push(command.to_string()),
                DncStep::ReadPort { command } => {
                    out.push(command.to_string());
                    read = Some(port);
                }
                DncStep::Dwell(d) => out.push(format!("dwell {}", d.as_millis())),
                DncStep::Nothing => {}
            }
            p.advance(read);
            assert!(out.len() < 1000, "runs away: {out:?}");
        }
        out
    }

    #[test]
    fn cnc_lines_become_the_dnc_commands_that_do_the_same() {
        let text = "e1\nf-1\nz1\nj400\nJ200\n0 100,900,200,900,0,900,0,900\n\
                    m 5,800,6,800,7,800,0,800\ny400,1500,119,-141,141,-1,-1\n\
                    7 7\np 100,128,3\n550\nT1\nN 1\nn 2\n9\n";
        assert_eq!(
            run(text, 0),
            [
                "e1",
                "f-1",
                "z1",
                "j400",
                "J200",
                "A100,900,200,900,0,900,0,900",
                "M5,800,6,800,7,800,0,800",
                "y400,1500,119,-141,141,-1,-1",
                "R7",
                "B100,3",
                "dwell 5000",
                "T1",
                "N1",
                "n2",
            ]
        );
    }

    #[test]
    fn speeds_go_through_the_factor_per_axis_and_arcs_take_the_lowest() {
        let p = plan("0 100,900,200,800,0,700,0,600\n9\n");
        let Some(DncStep::Send { command, moves }) = p.step(&half) else {
            panic!("a move");
        };
        assert!(moves);
        assert_eq!(command.to_string(), "A100,450,200,400,0,350,0,300");
        let p = plan("y400,1500,119,-141,141,-1,-1\n9\n");
        let slow_y = |a: Axis, hz: u32| if a == Axis::Y { hz / 3 } else { hz };
        let Some(DncStep::Send { command, .. }) = p.step(&slow_y) else {
            panic!("an arc");
        };
        assert_eq!(command.to_string(), "y400,500,119,-141,141,-1,-1");
    }

    #[test]
    fn loops_run_their_body_n_more_times_and_jumps_are_followed() {
        // `3 2,-1`: the move runs 3 times; `3 0,2` jumps over the next line.
        let text = "0 1,900,0,900,0,900,0,900\n3 2,-1\n3 0,2\n0 99,900,0,900,0,900,0,900\n9\n";
        assert_eq!(
            run(text, 0),
            [
                "A1,900,0,900,0,900,0,900",
                "A1,900,0,900,0,900,0,900",
                "A1,900,0,900,0,900,0,900"
            ]
        );
        // Nested: inner body twice per outer pass, outer twice.
        let text = "0 1,900,0,900,0,900,0,900\n3 1,-1\n3 1,-2\n9\n";
        assert_eq!(run(text, 0).len(), 4);
    }

    #[test]
    fn a_port_branch_reads_the_port_and_takes_the_jump_on_its_value() {
        let text = "o 1,128,5,2\n0 1,900,0,900,0,900,0,900\n0 2,900,0,900,0,900,0,900\n9\n";
        assert_eq!(
            run(text, 5),
            ["b1", "A2,900,0,900,0,900,0,900"],
            "taken: over the first move"
        );
        assert_eq!(
            run(text, 4),
            ["b1", "A1,900,0,900,0,900,0,900", "A2,900,0,900,0,900,0,900"]
        );
        // One bit (numbered 0-7 for `o`).
        let text = "o 1,2,1,2\n0 1,900,0,900,0,900,0,900\n9\n";
        assert_eq!(run(text, 0b100), ["b1"]);
    }

    #[test]
    fn eight_nested_loops_end_the_plan_as_the_controller_would() {
        // `3 1,-k` at index k, each jumping back to the move: in the repeat
        // pass of every outer loop the inner one takes its own counter, so
        // the innermost needs an eighth (manual 3.2.5: seven).
        let mut text = String::from("0 1,900,0,900,0,900,0,900\n");
        for k in 1..=8 {
            text.push_str(&format!("3 1,-{k}\n"));
        }
        text.push_str("9\n");
        let mut p = plan(&text);
        for _ in 0..100_000 {
            if p.finish().is_some() {
                break;
            }
            p.advance(None);
        }
        assert!(
            matches!(p.finish(), Some(Finish::LoopStack { line: 1 })),
            "{:?}",
            p.finish()
        );
        // Seven are allowed.
        let mut text = String::from("0 1,900,0,900,0,900,0,900\n");
        for k in 1..=7 {
            text.push_str(&format!("3 1,-{k}\n"));
        }
        text.push_str("9\n");
        let mut p = plan(&text);
        for _ in 0..100_000 {
            if p.finish().is_some() {
                break;
            }
            p.advance(None);
        }
        assert_eq!(p.finish(), Some(&Finish::End));
    }

    #[test]
    fn lines_without_an_exact_dnc_form_are_named() {
        let program = Program::parse(
            Language::Isel,
            "; wait\n2 65,2\n6 1,128,1\n0 1,900,0,900,0,900,0,900\np 100,2,1\np 100,128,1\n9\n",
        );
        let named: Vec<usize> = unexpressible(&program).iter().map(|u| u.line).collect();
        assert_eq!(named, [1, 2, 4]);
    }

    #[test]
    fn skipping_to_a_line_gives_the_position_and_settings_it_implies() {
        let text = "e1\nf0\n0 100,900,50,900,0,900,0,900\nf-1\nm 10,900,20,900,30,900,0,900\n\
                    p 100,128,3\n0 1,900,1,900,1,900,0,900\n9\n";
        let program = Program::parse(Language::Isel, text);
        let mut p = Plan::new(&program, AxisConfig::XYZ);
        let s = p.skip_to(6, [0, 0, 0, 0], [1000, 0, 0, 0]).unwrap();
        assert_eq!(s.position, [1010, 20, 30, 0]);
        assert_eq!(s.skipped_moves, 2);
        let settings: Vec<String> = s.settings.iter().map(|(c, _)| c.to_string()).collect();
        assert_eq!(settings, ["e1", "f-1"]);
        let outputs: Vec<String> = s.outputs.iter().map(|(c, _)| c.to_string()).collect();
        assert_eq!(outputs, ["B100,3"]);
        assert_eq!(p.line(), Some(6));
        // Inside a loop: the counter it would hold comes along.
        let text = "0 1,900,0,900,0,900,0,900\n0 2,900,0,900,0,900,0,900\n3 1,-2\n9\n";
        let program = Program::parse(Language::Isel, text);
        let mut p = Plan::new(&program, AxisConfig::XYZ);
        let s = p.skip_to(1, [0; 4], [0; 4]).unwrap();
        assert_eq!(s.position[0], 1);
        let mut rest = 0;
        while p.line().is_some() {
            p.advance(None);
            rest += 1;
        }
        assert_eq!(
            rest, 6,
            "line 2, the loop, lines 1 and 2 again, the loop, the end"
        );
        // A zero set before the line cannot be reproduced from elsewhere.
        let program = Program::parse(Language::Isel, "n 7\n0 1,900,0,900,0,900,0,900\n9\n");
        let mut p = Plan::new(&program, AxisConfig::XYZ);
        assert!(p.skip_to(1, [0; 4], [0; 4]).unwrap_err().contains("line 1"));
    }
}
