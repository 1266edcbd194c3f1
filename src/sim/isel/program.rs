//! Stored CNC programs (isel manual chapter 3, `docs/decisions.md`
//! isel 9-11): checking lines as they are stored, and the program counter
//! and loop stack of a run.

use crate::proto::isel::{AxisConfig, CncCommand, ReplyCode, check_cnc};

use super::flash::StoredProgram;
use super::io::PortCondition;

/// Loops nest at most this deep (manual 3.2.5).
pub const MAX_LOOP_DEPTH: usize = 7;

/// What storing a line did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stored {
    /// The line is in; more may follow.
    More,
    /// `9` closed a valid program.
    Closed,
}

/// Store one received line in `program` (which is being transferred), or
/// say which code the controller answers instead. The line is checked for
/// the axes it was sent with (`check_cnc`); a jump before the first command
/// answers `1` at once, one behind the closing `9` when the `9` arrives
/// (manual 3.2.5: "Es darf nicht vor den Anfang oder hinter das Ende des
/// Datenfeldes verzweigt werden"). `capacity` counts the commands before
/// the `9`.
pub fn store_line(
    program: &mut StoredProgram,
    command: CncCommand,
    config: Option<AxisConfig>,
    capacity: usize,
) -> Result<Stored, ReplyCode> {
    let config = config.ok_or(ReplyCode::NoAxes)?;
    check_cnc(&command, config).map_err(|e| e.code)?;
    let index = program.lines.len();
    if let Some(offset) = command.jump_offset()
        && index as i64 + i64::from(offset) < 0
    {
        return Err(ReplyCode::BadNumber);
    }
    if command == CncCommand::End {
        let leaves = program.lines.iter().enumerate().any(|(i, line)| {
            line.jump_offset()
                .is_some_and(|o| i as i64 + i64::from(o) > index as i64)
        });
        if leaves {
            return Err(ReplyCode::BadNumber);
        }
        program.lines.push(command);
        program.valid = true;
        return Ok(Stored::Closed);
    }
    if index >= capacity {
        return Err(ReplyCode::MemoryFull);
    }
    program.lines.push(command);
    Ok(Stored::More)
}

/// Where a run stands.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ProgramRun {
    /// Index of the next command.
    pub pc: usize,
    /// Active loops: the index of their `3` and the runs still to come.
    loops: Vec<(usize, u16)>,
    /// The condition of a `6` for the next move (manual 3.2.7).
    pub condition: Option<PortCondition>,
}

impl ProgramRun {
    pub fn new() -> ProgramRun {
        ProgramRun::default()
    }

    /// The index `offset` away from `pc`, if it is inside a program of `len`
    /// commands (decision 11: offsets count from the command carrying them).
    pub fn target(pc: usize, offset: i16, len: usize) -> Result<usize, ReplyCode> {
        usize::try_from(pc as i64 + i64::from(offset))
            .ok()
            .filter(|t| *t < len)
            .ok_or(ReplyCode::BadNumber)
    }

    /// Run the `3 count,offset` at `pc`: the index to go on with. A loop
    /// (`count` > 0) runs the commands before it `count` more times
    /// (decision 11); a loop found deeper in the stack (left by a jump)
    /// drops the loops above it. Deeper than 7 levels ends the run with `6`:
    /// the loop stack is memory too (`docs/protocols.md`, isel).
    pub fn take_loop(
        &mut self,
        pc: usize,
        count: u16,
        offset: i16,
        len: usize,
    ) -> Result<usize, ReplyCode> {
        if count == 0 {
            return ProgramRun::target(pc, offset, len);
        }
        if let Some(k) = self.loops.iter().position(|(at, _)| *at == pc) {
            self.loops.truncate(k + 1);
            let remaining = self.loops.last().map_or(0, |(_, r)| r.saturating_sub(1));
            if remaining == 0 {
                self.loops.pop();
                return Ok(pc + 1);
            }
            if let Some(top) = self.loops.last_mut() {
                top.1 = remaining;
            }
            return ProgramRun::target(pc, offset, len);
        }
        if self.loops.len() >= MAX_LOOP_DEPTH {
            return Err(ReplyCode::MemoryFull);
        }
        let next = ProgramRun::target(pc, offset, len)?;
        self.loops.push((pc, count));
        Ok(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::isel::parse_cnc;

    fn line(text: &str) -> CncCommand {
        parse_cnc(text).expect("line").value
    }

    fn empty() -> StoredProgram {
        StoredProgram {
            lines: Vec::new(),
            valid: false,
            reference_speeds: [0; 4],
        }
    }

    #[test]
    fn lines_are_checked_and_nine_closes() {
        let mut p = empty();
        let xy = Some(AxisConfig::XY);
        assert_eq!(
            store_line(&mut p, line("010,900,0,900"), xy, 3),
            Ok(Stored::More)
        );
        assert_eq!(
            store_line(&mut p, line("010,900"), xy, 3),
            Err(ReplyCode::ParameterCount)
        );
        assert_eq!(
            store_line(&mut p, line("3 2,-5"), xy, 3),
            Err(ReplyCode::BadNumber),
            "before the first command"
        );
        assert_eq!(store_line(&mut p, line("3 0,4"), xy, 3), Ok(Stored::More));
        assert_eq!(
            store_line(&mut p, line("9"), xy, 3),
            Err(ReplyCode::BadNumber),
            "behind the end"
        );
        assert_eq!(store_line(&mut p, line("3 0,-1"), xy, 3), Ok(Stored::More));
        assert_eq!(
            store_line(&mut p, line("5 1"), xy, 3),
            Err(ReplyCode::MemoryFull)
        );
        assert_eq!(
            store_line(&mut p, line("9"), None, 3),
            Err(ReplyCode::NoAxes)
        );
        let mut q = empty();
        assert_eq!(store_line(&mut q, line("3 0,1"), xy, 3), Ok(Stored::More));
        assert_eq!(store_line(&mut q, line("9"), xy, 3), Ok(Stored::Closed));
        assert!(q.valid);
    }

    #[test]
    fn loops_run_n_plus_one_times_and_nest() {
        // 0: move  1: 3 2,-1 (3 runs of 0)  2: 3 1,-2 (twice 0..=1)  3: end
        let mut run = ProgramRun::new();
        let mut trace = Vec::new();
        let mut pc = 0;
        while pc < 3 {
            trace.push(pc);
            pc = match pc {
                1 => run.take_loop(1, 2, -1, 4).expect("loop"),
                2 => run.take_loop(2, 1, -2, 4).expect("loop"),
                _ => pc + 1,
            };
        }
        assert_eq!(trace.iter().filter(|&&p| p == 0).count(), 6);
        assert_eq!(trace.iter().filter(|&&p| p == 2).count(), 2);
    }

    #[test]
    fn nesting_deeper_than_seven_is_refused() {
        let mut run = ProgramRun::new();
        for pc in (1..=7).rev() {
            assert!(run.take_loop(pc + 10, 1, -1, 30).is_ok());
        }
        assert_eq!(run.take_loop(5, 1, -1, 30), Err(ReplyCode::MemoryFull));
        assert_eq!(ProgramRun::target(3, -4, 10), Err(ReplyCode::BadNumber));
        assert_eq!(ProgramRun::target(3, 6, 10), Ok(9));
    }
}
