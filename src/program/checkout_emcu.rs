//! An EMCU job in the check-out (`docs/editor.md`, "Check-out"): its lines
//! as the commands the interface runs when they are sent, each ended by
//! 0x01 (manual 1.4.2: a buffered command runs when its line ends with
//! 0x01). A job runs top to bottom, so no flow is needed; what jogterm does
//! itself: `W` is a dwell counted while the key is held, and the end speed
//! of each slot (`#E`) goes out through the speed factor and the dead-man
//! cap, so every move runs at a known, capped speed.
//!
//! A paused EMCU move keeps no rest jogterm may rely on (the check-out
//! stops it with `@B`, which drops it, manual 1.5.11): the next hold sends
//! what is left of it from where the axes stand ([`EmcuPlan::rest_of_move`]),
//! which ends exactly where the line would have.
//!
//! Run from a line ([`EmcuPlan::skip_to`]): the job is walked from its top
//! to the line without moving; the counters the skipped moves would have
//! left, the settings in force there (`#E` per slot, `#S`, `#R`, `&V0`) and
//! the outputs the skipped lines switch come back, and the check-out sends
//! an absolute move to that position ([`go_to`]) and the settings before
//! the line.

use std::time::Duration;

use crate::axis::AxisSet;
use crate::proto::emcu::{
    Command, EmcuAxis, Move, MoveMode, values::Slot, values::Speed, values::Steps,
};

/// A job command, as the editor keeps it (the editor imports no protocol
/// module, `docs/architecture.md`).
pub use crate::proto::emcu::Command as JobCommand;

use super::checkout::Unexpressible;
use super::model::{Command as ProgramCommand, Program};

/// What one job line is in the check-out.
#[derive(Debug, Clone, PartialEq)]
pub enum EmcuStep {
    /// Send `line` (its text with the 0x01 that runs it); `moves`: it sets
    /// axes in motion, held by the check-out's lease.
    Send { line: String, moves: bool },
    /// `W`: wait, counted while the key is held.
    Dwell(Duration),
    /// A master command in the job (the linter refuses those): nothing.
    Nothing,
}

/// The job line by line.
#[derive(Debug, Clone, PartialEq)]
pub struct EmcuPlan {
    commands: Vec<Option<Command>>,
    lines: Vec<usize>,
    pc: usize,
}

const RUN: char = '\u{1}';

impl EmcuPlan {
    pub fn new(program: &Program) -> EmcuPlan {
        let mut commands = Vec::new();
        let mut lines = Vec::new();
        for (line, statement) in program.statements() {
            commands.push(
                statement
                    .command
                    .as_ref()
                    .ok()
                    .and_then(ProgramCommand::as_emcu)
                    .copied(),
            );
            lines.push(line);
        }
        EmcuPlan {
            commands,
            lines,
            pc: 0,
        }
    }

    /// The source line to run next; `None` at the end.
    pub fn line(&self) -> Option<usize> {
        self.lines.get(self.pc).copied()
    }

    /// The current line; slot speeds through `speed` (Hz the job asks →
    /// Hz on the wire).
    pub fn step(&self, speed: &dyn Fn(u32) -> u32) -> Option<EmcuStep> {
        self.line()?;
        let Some(command) = self.commands.get(self.pc).copied().flatten() else {
            return Some(EmcuStep::Nothing);
        };
        Some(step_of(command, speed))
    }

    /// Whether the current line is a move.
    pub fn is_move(&self) -> bool {
        matches!(
            self.commands.get(self.pc).copied().flatten(),
            Some(Command::Move(_))
        )
    }

    /// The current line is done.
    pub fn advance(&mut self) {
        if self.line().is_some() {
            self.pc += 1;
        }
    }

    /// The current line, a move, as the move that goes on from the counters
    /// `now` to where the line ends, having started at `start`: an absolute
    /// move as it is, a relative one with what is left of it.
    pub fn rest_of_move(&self, start: [i64; 4], now: [i64; 4]) -> Option<String> {
        let Some(Command::Move(mv)) = self.commands.get(self.pc).copied().flatten() else {
            return None;
        };
        let rest = match mv.mode() {
            MoveMode::Absolute => mv,
            MoveMode::Relative => {
                let targets: Vec<_> = mv
                    .targets()
                    .filter_map(|(axis, steps)| {
                        let i = axis.axis().index();
                        let left = start.get(i)? + i64::from(steps.get()) - now.get(i)?;
                        // An axis already there moves no more.
                        (left != 0).then_some(())?;
                        Some((axis, Steps::new(i32::try_from(left).ok()?).ok()?))
                    })
                    .collect();
                Move::new(mv.slot(), MoveMode::Relative, &targets).ok()?
            }
        };
        Some(format!("{}{RUN}", Command::Move(rest)))
    }
}

/// `command` as a check-out line: slot speeds through `speed` (Hz the job
/// asks → Hz on the wire), ended by 0x01.
pub fn step_of(command: Command, speed: &dyn Fn(u32) -> u32) -> EmcuStep {
    let send = |command: Command| EmcuStep::Send {
        line: format!("{command}{RUN}"),
        moves: command.may_move(),
    };
    match command {
        _ if command.is_master() => EmcuStep::Nothing,
        Command::Wait(ms) => EmcuStep::Dwell(Duration::from_millis(u64::from(ms.get()))),
        Command::EndSpeed { slot, speed: hz } => {
            let wire = speed(u32::from(hz.get()));
            let wire = Speed::new(u16::try_from(wire).unwrap_or(Speed::MAX)).unwrap_or(hz);
            send(Command::EndSpeed { slot, speed: wire })
        }
        other => send(other),
    }
}

/// What skipping to a line of a job implies: where the counters would
/// stand, the settings in force there and the outputs the skipped lines
/// switch, each with its source line.
#[derive(Debug, Clone, PartialEq)]
pub struct EmcuSkipped {
    pub position: [i64; 4],
    /// `#E` of each slot, `#S`, `#R`, `&V`: the last of each kind.
    pub settings: Vec<(Command, usize)>,
    /// `A` lines: named to the operator, not sent (they switch things).
    pub outputs: Vec<(Command, usize)>,
    pub skipped_moves: usize,
}

impl EmcuPlan {
    /// Walk from the top to source line `line` without moving, the counters
    /// starting at `position` (a job runs top to bottom: the line is
    /// reached once). Errors name why the line cannot be started from.
    pub fn skip_to(&mut self, line: usize, position: [i64; 4]) -> Result<EmcuSkipped, String> {
        let Some(target) = self.lines.iter().position(|l| *l == line) else {
            return Err(format!("line {} is no command of the job", line + 1));
        };
        let mut s = EmcuSkipped {
            position,
            settings: Vec::new(),
            outputs: Vec::new(),
            skipped_moves: 0,
        };
        for (command, at) in self
            .commands
            .iter()
            .zip(&self.lines)
            .take(target)
            .filter_map(|(c, l)| c.map(|c| (c, *l)))
        {
            match command {
                _ if command.is_master() => {}
                Command::Move(mv) => {
                    for (axis, steps) in mv.targets() {
                        if let Some(v) = s.position.get_mut(axis.index()) {
                            let steps = i64::from(steps.get());
                            *v = match mv.mode() {
                                MoveMode::Absolute => steps,
                                MoveMode::Relative => *v + steps,
                            };
                        }
                    }
                    s.skipped_moves += 1;
                }
                Command::Reference(order) => {
                    // The reference point is counter 0 (manual 1.5.9).
                    for axis in order.axes() {
                        if let Some(v) = s.position.get_mut(axis.index()) {
                            *v = 0;
                        }
                    }
                    s.skipped_moves += 1;
                }
                Command::SetOutput { .. } => s.outputs.push((command, at)),
                Command::Wait(_) => {}
                _ => {
                    // The last setting of each kind (and slot) counts.
                    let same = |c: &Command| match (c, &command) {
                        (Command::EndSpeed { slot: a, .. }, Command::EndSpeed { slot: b, .. }) => {
                            a == b
                        }
                        (c, command) => {
                            std::mem::discriminant(c) == std::mem::discriminant(command)
                        }
                    };
                    s.settings.retain(|(c, _)| !same(c));
                    s.settings.push((command, at));
                }
            }
        }
        self.pc = target;
        Ok(s)
    }
}

/// The slot [`go_to`] moves in: its end speed is sent just before, and the
/// job's own `#E` of it (if any) after, with the other settings in force.
pub const GO_TO_SLOT: Slot = Slot::FIRST;

/// The lines that take the axes of `axes` (X, Y, Z) to the counters
/// `target` at `hz`: the end speed of [`GO_TO_SLOT`], then an absolute
/// move in it. `None` when a target is beyond the `L` command's range.
pub fn go_to(axes: AxisSet, target: [i64; 4], hz: u32) -> Option<[Command; 2]> {
    let targets = EmcuAxis::ALL
        .into_iter()
        .filter(|a| axes.contains(a.axis()))
        .map(|a| {
            let v = i32::try_from(*target.get(a.index())?).ok()?;
            Some((a, Steps::new(v).ok()?))
        })
        .collect::<Option<Vec<_>>>()?;
    let mv = Move::new(GO_TO_SLOT, MoveMode::Absolute, &targets).ok()?;
    let speed = Speed::new(u16::try_from(hz).unwrap_or(Speed::MAX).max(1)).ok()?;
    Some([
        Command::EndSpeed {
            slot: GO_TO_SLOT,
            speed,
        },
        Command::Move(mv),
    ])
}

/// The job's lines the check-out cannot run as the job would: a move in a
/// slot whose end speed the job does not set before it (the speed factor
/// and the dead-man cap could not be applied), `&V1` (moves that wait for
/// input E1: the hold cannot tell a wait from a move).
pub fn unexpressible(program: &Program) -> Vec<Unexpressible> {
    let mut set = [false; 10];
    let mut out = Vec::new();
    for (line, statement) in program.statements() {
        let Some(command) = statement
            .command
            .as_ref()
            .ok()
            .and_then(ProgramCommand::as_emcu)
        else {
            continue;
        };
        match command {
            Command::EndSpeed { slot, .. } => {
                if let Some(s) = set.get_mut(usize::from(slot.get())) {
                    *s = true;
                }
            }
            Command::Move(mv)
                if !set
                    .get(usize::from(mv.slot().get()))
                    .copied()
                    .unwrap_or(false) =>
            {
                out.push(Unexpressible {
                    line,
                    reason: format!(
                        "the move runs at the end speed of slot {}, which the job does not set \
                         before it (#E): the speed factor and the dead-man cap cannot be applied",
                        mv.slot().get()
                    ),
                });
            }
            Command::LinkE1(true) => out.push(Unexpressible {
                line,
                reason: "`&V1` makes the moves wait for input E1: a held key cannot tell the \
                         wait from a move"
                    .into(),
            }),
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::Language;

    fn job(text: &str) -> Program {
        Program::parse(Language::Emcu, text)
    }

    #[test]
    fn job_lines_go_out_with_0x01_and_slot_speeds_through_the_factor() {
        let p = EmcuPlan::new(&job("#E1,1000\nL1,x4000\nW500\nA1,1\n"));
        let mut p = p;
        let mut out = Vec::new();
        while let Some(step) = p.step(&|hz| hz / 2) {
            out.push(step);
            p.advance();
        }
        assert_eq!(
            out,
            [
                EmcuStep::Send {
                    line: "#E1,500\u{1}".into(),
                    moves: false
                },
                EmcuStep::Send {
                    line: "L1,x4000\u{1}".into(),
                    moves: true
                },
                EmcuStep::Dwell(Duration::from_millis(500)),
                EmcuStep::Send {
                    line: "A1,1\u{1}".into(),
                    moves: false
                },
            ]
        );
    }

    #[test]
    fn the_rest_of_a_paused_relative_move_ends_where_the_line_would() {
        let mut p = EmcuPlan::new(&job("#E1,1000\nL1,x4000,y-100\nL1,X10\n"));
        p.advance();
        let rest = p.rest_of_move([1000, 0, 0, 0], [2500, -40, 0, 0]);
        assert_eq!(rest.as_deref(), Some("L1,x2500,y-60\u{1}"));
        p.advance();
        // Absolute: as it is.
        assert_eq!(
            p.rest_of_move([0; 4], [5, 0, 0, 0]).as_deref(),
            Some("L1,X10\u{1}")
        );
    }

    #[test]
    fn skipping_to_a_job_line_gives_the_counters_settings_and_outputs_it_implies() {
        let text = "#S300\n#E1,1000\n#E2,500\nL1,x4000\nA1,1\n#E1,800\nL2,Y-200\nW500\n\
                    #R200\nL1,x100,z30\nL2,X0\n";
        let mut p = EmcuPlan::new(&job(text));
        let s = p.skip_to(9, [10, 20, 30, 0]).unwrap();
        assert_eq!(
            s.position,
            [4010, -200, 30, 0],
            "relative adds, absolute sets"
        );
        assert_eq!(s.skipped_moves, 2);
        let settings: Vec<String> = s
            .settings
            .iter()
            .map(|(c, l)| format!("{c}@{}", l + 1))
            .collect();
        assert_eq!(
            settings,
            ["#S300@1", "#E2,500@3", "#E1,800@6", "#R200@9"],
            "the last of each kind, per slot"
        );
        let outputs: Vec<String> = s.outputs.iter().map(|(c, _)| c.to_string()).collect();
        assert_eq!(outputs, ["A1,1"]);
        assert_eq!(p.line(), Some(9));
        let mut rest = Vec::new();
        while let Some(step) = p.step(&|hz| hz) {
            rest.push(step);
            p.advance();
        }
        assert_eq!(
            rest,
            [
                EmcuStep::Send {
                    line: "L1,x100,z30\u{1}".into(),
                    moves: true
                },
                EmcuStep::Send {
                    line: "L2,X0\u{1}".into(),
                    moves: true
                },
            ]
        );
        // A reference run before the line puts its axes at counter 0.
        let mut p = EmcuPlan::new(&job("$HZX\n#E1,900\nL1,y5\nL1,x1\n"));
        let s = p.skip_to(3, [7, 7, 7, 0]).unwrap();
        assert_eq!(s.position, [0, 12, 0, 0]);
        assert_eq!(s.skipped_moves, 2);
        // A comment or a line past the end is no command to start from.
        let mut p = EmcuPlan::new(&job("; c\n#E1,900\nL1,y5\n"));
        assert!(p.skip_to(0, [0; 4]).unwrap_err().contains("line 1"));
        assert!(p.skip_to(7, [0; 4]).is_err());
    }

    #[test]
    fn the_go_to_sets_its_slot_speed_then_moves_absolute_on_the_machines_axes() {
        let xz = AxisSet::EMPTY
            .with(crate::axis::Axis::X)
            .with(crate::axis::Axis::Z);
        let [speed, mv] = go_to(xz, [4000, 99, -30, 0], 1200).unwrap();
        assert_eq!(speed.to_string(), "#E1,1200");
        assert_eq!(mv.to_string(), "L1,X4000,Z-30");
        assert!(go_to(xz, [5_000_000, 0, 0, 0], 1200).is_none());
    }

    #[test]
    fn moves_in_slots_the_job_does_not_set_and_e1_waits_are_named() {
        let named: Vec<usize> = unexpressible(&job("L2,x10\n#E2,500\nL2,x10\n&V1\n"))
            .iter()
            .map(|u| u.line)
            .collect();
        assert_eq!(named, [0, 3]);
    }
}
