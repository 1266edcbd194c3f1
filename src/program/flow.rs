//! Control flow of an isel CNC program: where each command can go next,
//! the loops and how they nest (isel manual 3.2.4, 3.2.5, 3.2.19;
//! `docs/decisions.md` isel 11). Offsets are relative to the command that
//! carries them: `3 0,5` at index i jumps to i + 5.

use crate::proto::isel::CncCommand;

use super::model::{Command, Program};

/// What a command does to the command counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Flow {
    /// Go on with the next command.
    Next,
    /// `3 0,k`: always go to the target.
    Jump(i64),
    /// `2`, `o`: go to the target or on with the next command.
    Branch(i64),
    /// `3 n,-k` with n > 0: repeat the commands from `start` to here.
    Loop { start: i64 },
    /// `9`.
    End,
}

/// The flow of command `index`; commands that do not parse go on.
pub(crate) fn flow_of(command: Option<&CncCommand>, index: usize) -> Flow {
    let at = |offset: i16| index as i64 + i64::from(offset);
    match command {
        Some(CncCommand::Loop { count: 0, offset }) => Flow::Jump(at(*offset)),
        Some(CncCommand::Loop { offset, .. }) => Flow::Loop { start: at(*offset) },
        Some(CncCommand::WaitSync { offset, .. } | CncCommand::BranchOnPort { offset, .. }) => {
            Flow::Branch(at(*offset))
        }
        Some(CncCommand::End) => Flow::End,
        _ => Flow::Next,
    }
}

/// The isel command of statement `index`, if it parsed.
pub(crate) fn command(program: &Program, index: usize) -> Option<&CncCommand> {
    program
        .statement(index)
        .and_then(|(_, s)| s.command.as_ref().ok())
        .and_then(Command::as_isel)
}

/// The isel command of every statement (`None` where a line does not
/// parse), in index order: one pass over the lines, so that runs and data
/// flows index a flat list.
pub(crate) fn commands(program: &Program) -> Vec<Option<&CncCommand>> {
    program
        .statements()
        .map(|(_, s)| s.command.as_ref().ok().and_then(Command::as_isel))
        .collect()
}

/// The flow of every command, in index order.
pub(crate) fn flows(commands: &[Option<&CncCommand>]) -> Vec<Flow> {
    commands
        .iter()
        .enumerate()
        .map(|(index, command)| flow_of(*command, index))
        .collect()
}

/// A target inside a program of `len` commands.
pub(crate) fn inside(target: i64, len: usize) -> Option<usize> {
    usize::try_from(target).ok().filter(|t| *t < len)
}

/// Where command `index` can go next, inside the program (at most two places).
pub(crate) fn successors(flow: Flow, index: usize, len: usize) -> [Option<usize>; 2] {
    let next = inside(index as i64 + 1, len);
    match flow {
        Flow::Next => [next, None],
        Flow::Jump(t) => [inside(t, len), None],
        // A forward "loop" is refused by the check; as flow it goes on.
        Flow::Branch(t) | Flow::Loop { start: t } => [next, inside(t, len)],
        Flow::End => [None, None],
    }
}

/// A backward loop with its body inside the program: commands `start..=end`,
/// `end` being the `3` itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct LoopRange {
    pub start: usize,
    pub end: usize,
}

impl LoopRange {
    pub fn contains(&self, index: usize) -> bool {
        (self.start..=self.end).contains(&index)
    }
}

/// The loops whose bodies lie inside the program, ordered by start, outer
/// ones (longer) first.
pub(crate) fn loops(flows: &[Flow]) -> Vec<LoopRange> {
    let mut out: Vec<LoopRange> = flows
        .iter()
        .enumerate()
        .filter_map(|(end, f)| match f {
            Flow::Loop { start } => usize::try_from(*start)
                .ok()
                .filter(|s| *s < end)
                .map(|start| LoopRange { start, end }),
            _ => None,
        })
        .collect();
    out.sort_by(|a, b| a.start.cmp(&b.start).then(b.end.cmp(&a.end)));
    out
}

/// How the loops nest: each loop's depth (1 = outermost) and the pairs that
/// overlap without one containing the other.
#[derive(Debug, Default)]
pub(crate) struct Nesting {
    /// (loop, depth), for every loop of [`loops`].
    pub depths: Vec<(LoopRange, usize)>,
    /// (earlier loop, later loop) that overlap partially.
    pub overlaps: Vec<(LoopRange, LoopRange)>,
}

/// One sweep over the loops in [`loops`] order with a stack of the loops
/// that contain the current one.
pub(crate) fn nesting(loops: &[LoopRange]) -> Nesting {
    let mut out = Nesting::default();
    let mut open: Vec<LoopRange> = Vec::new();
    for &lp in loops {
        while open.last().is_some_and(|top| top.end < lp.start) {
            open.pop();
        }
        // Loops still open that end inside this one overlap it partially.
        while let Some(top) = open.last().copied().filter(|top| top.end < lp.end) {
            out.overlaps.push((top, lp));
            open.pop();
        }
        open.push(lp);
        out.depths.push((lp, open.len()));
    }
    out
}

/// For each command, the innermost loop whose body holds it (the loop
/// command itself included), by a sweep in index order.
pub(crate) fn innermost_loops(loops: &[LoopRange], len: usize) -> Vec<Option<LoopRange>> {
    let mut out = vec![None; len];
    let mut open: Vec<LoopRange> = Vec::new();
    let mut next = loops.iter().peekable();
    for (index, slot) in out.iter_mut().enumerate() {
        while open.last().is_some_and(|top| top.end < index) {
            open.pop();
        }
        while let Some(lp) = next.next_if(|lp| lp.start == index) {
            open.push(*lp);
        }
        *slot = open.last().copied();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::Language;

    fn program(text: &str) -> Program {
        Program::parse(Language::Isel, text)
    }

    #[test]
    fn offsets_count_from_the_command_that_carries_them() {
        // The manual's examples (3.2.5) at index 10.
        let flow = |line: &str| flow_of(command(&program(line), 0), 10);
        assert_eq!(flow("3 25,-1"), Flow::Loop { start: 9 });
        assert_eq!(flow("3 0,-5"), Flow::Jump(5));
        assert_eq!(flow("3 0,5"), Flow::Jump(15));
        assert_eq!(flow("3 6,-5"), Flow::Loop { start: 5 });
        assert_eq!(flow("o0,0,1,3"), Flow::Branch(13));
        assert_eq!(flow("233,-10"), Flow::Branch(0));
        assert_eq!(flow("9"), Flow::End);
        assert_eq!(flow("5 50"), Flow::Next);
        assert_eq!(flow("bogus"), Flow::Next);
    }

    #[test]
    fn successors_stay_inside_the_program() {
        assert_eq!(successors(Flow::Next, 4, 5), [None, None]);
        assert_eq!(successors(Flow::Jump(9), 2, 5), [None, None]);
        assert_eq!(successors(Flow::Branch(0), 2, 5), [Some(3), Some(0)]);
        assert_eq!(
            successors(Flow::Loop { start: 1 }, 2, 5),
            [Some(3), Some(1)]
        );
        assert_eq!(successors(Flow::End, 2, 5), [None, None]);
    }

    #[test]
    fn nesting_depths_and_overlaps() {
        let r = |start, end| LoopRange { start, end };
        let loops = vec![r(0, 9), r(1, 5), r(2, 4), r(6, 8), r(7, 12)];
        let n = nesting(&loops);
        let depths: Vec<usize> = n.depths.iter().map(|(_, d)| *d).collect();
        assert_eq!(depths, [1, 2, 3, 2, 1]);
        assert_eq!(n.overlaps, vec![(r(6, 8), r(7, 12)), (r(0, 9), r(7, 12))]);
        let inner = innermost_loops(&loops[..4], 11);
        assert_eq!(inner[3], Some(r(2, 4)));
        assert_eq!(inner[5], Some(r(1, 5)));
        assert_eq!(inner[7], Some(r(6, 8)));
        assert_eq!(inner[9], Some(r(0, 9)));
        assert_eq!(inner[10], None);
    }
}
