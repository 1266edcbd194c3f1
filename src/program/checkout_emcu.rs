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

use std::time::Duration;

use crate::proto::emcu::{Command, Move, MoveMode, values::Speed, values::Steps};

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
        let send = |command: Command| EmcuStep::Send {
            line: format!("{command}{RUN}"),
            moves: command.may_move(),
        };
        Some(match command {
            _ if command.is_master() => EmcuStep::Nothing,
            Command::Wait(ms) => EmcuStep::Dwell(Duration::from_millis(u64::from(ms.get()))),
            Command::EndSpeed { slot, speed: hz } => {
                let wire = speed(u32::from(hz.get()));
                let wire = Speed::new(u16::try_from(wire).unwrap_or(Speed::MAX)).unwrap_or(hz);
                send(Command::EndSpeed { slot, speed: wire })
            }
            other => send(other),
        })
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
    fn moves_in_slots_the_job_does_not_set_and_e1_waits_are_named() {
        let named: Vec<usize> = unexpressible(&job("L2,x10\n#E2,500\nL2,x10\n&V1\n"))
            .iter()
            .map(|u| u.line)
            .collect();
        assert_eq!(named, [0, 3]);
    }
}
