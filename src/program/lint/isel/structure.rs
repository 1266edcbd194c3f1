//! The structure of an isel program: jump targets, loops (nesting, overlap,
//! left by a jump), the end `9` and the program memory (manual 3.2.5, 3.2.9;
//! `docs/decisions.md` isel 9, 11).

use crate::proto::isel::CncCommand;

use super::param_span;
use crate::program::flow::{self, Flow, LoopRange};
use crate::program::lint::{Diagnostic, LintConfig, Rule, count, end_span, statement_span};
use crate::program::model::Program;
use crate::program::source::Span;

/// Loops nest at most this deep (manual 3.2.5).
pub(crate) const MAX_LOOP_DEPTH: usize = 7;

/// The offset parameter of a jumping command.
fn offset_param(command: Option<&CncCommand>) -> usize {
    match command {
        Some(CncCommand::BranchOnPort { .. }) => 3,
        _ => 1,
    }
}

fn offset_span(program: &Program, index: usize) -> Span {
    match program.statement(index) {
        Some((line, s)) => param_span(line, s, offset_param(flow::command(program, index))),
        None => end_span(program),
    }
}

/// Jump targets, loop nesting and loops left by jumps (manual 3.2.5: "Es
/// darf nicht vor den Anfang oder hinter das Ende des Datenfeldes verzweigt
/// werden"; the end is the `9`, `docs/protocols.md` isel).
pub(super) fn jumps_and_loops(program: &Program, flows: &[Flow], out: &mut Vec<Diagnostic>) {
    let len = flows.len();
    let end = flows.iter().position(|f| *f == Flow::End);
    let bound = end.map_or(len, |e| e + 1);
    for (index, f) in flows.iter().enumerate() {
        let (target, what) = match *f {
            Flow::Jump(t) | Flow::Branch(t) => (t, "jump target"),
            // Forward loops are reported by the check.
            Flow::Loop { start } if start <= index as i64 => (start, "loop start"),
            _ => continue,
        };
        if flow::inside(target, bound).is_some() {
            continue;
        }
        let place = if target < 0 {
            format!(
                "{} before the first command",
                count(target.unsigned_abs() as usize, "command")
            )
        } else {
            let beyond = count((target - bound as i64 + 1) as usize, "command");
            match end {
                Some(e) => format!(
                    "{beyond} behind the end `9` of line {}",
                    line_number(program, e)
                ),
                None => format!("{beyond} after the last command"),
            }
        };
        out.push(Diagnostic::error(
            Rule::JumpTarget,
            offset_span(program, index),
            format!(
                "the {what} lies {place} of the program; jumps may not leave it (manual 3.2.5)"
            ),
        ));
    }
    let loops = flow::loops(flows);
    let nesting = flow::nesting(&loops);
    for (lp, depth) in &nesting.depths {
        if *depth > MAX_LOOP_DEPTH {
            out.push(Diagnostic::error(
                Rule::LoopDepth,
                statement_span(program, lp.end),
                format!(
                    "this loop is nested {depth} deep; loops nest at most {MAX_LOOP_DEPTH} deep \
                     (manual 3.2.5)"
                ),
            ));
        }
    }
    for (earlier, later) in &nesting.overlaps {
        out.push(Diagnostic::warning(
            Rule::LoopOverlap,
            statement_span(program, later.end),
            format!(
                "this loop repeats {} and overlaps the loop in line {} without containing it; \
                 loops should nest (manual 3.2.5)",
                body(program, *later),
                line_number(program, earlier.end)
            ),
        ));
    }
    let innermost = flow::innermost_loops(&loops, len);
    for (index, f) in flows.iter().enumerate() {
        let target = match *f {
            Flow::Jump(t) | Flow::Branch(t) => t,
            _ => continue,
        };
        let (Some(target), Some(Some(lp))) = (flow::inside(target, len), innermost.get(index))
        else {
            continue;
        };
        if !lp.contains(target) {
            out.push(Diagnostic::error(
                Rule::LoopExit,
                offset_span(program, index),
                format!(
                    "this jump leaves the loop of line {} ({}); a loop may not be left by a jump \
                     (manual 3.2.5)",
                    line_number(program, lp.end),
                    body(program, *lp)
                ),
            ));
        }
    }
}

/// 1-based line number of a command, for messages.
fn line_number(program: &Program, index: usize) -> usize {
    program.line_of(index).map_or(0, |l| l + 1)
}

fn body(program: &Program, lp: LoopRange) -> String {
    format!(
        "lines {}-{}",
        line_number(program, lp.start),
        line_number(program, lp.end.saturating_sub(1))
    )
}

/// The end `9`, and nothing after it (manual 3.2.9, `docs/decisions.md`
/// isel 9).
pub(super) fn end(program: &Program, flows: &[Flow], out: &mut Vec<Diagnostic>) {
    match flows.iter().position(|f| *f == Flow::End) {
        None => {
            let at = end_span(program);
            let insert = if program.lines().last().is_some_and(|l| !l.text().is_empty()) {
                "\n9"
            } else {
                "9"
            };
            out.push(
                Diagnostic::error(
                    Rule::MissingEnd,
                    at,
                    "the program has no end `9`: without it the controller keeps the program \
                     invalid and cannot run it (manual 3.2.9)",
                )
                .with_fix(at, insert),
            );
        }
        Some(end) => {
            for index in end + 1..flows.len() {
                out.push(Diagnostic::error(
                    Rule::AfterEnd,
                    statement_span(program, index),
                    format!(
                        "nothing may follow the end `9` of line {}: the controller is back in \
                         DNC mode after it and refuses this line (manual 3.2.9)",
                        line_number(program, end)
                    ),
                ));
            }
        }
    }
}

/// Program memory (`docs/decisions.md` isel 9: 2000 commands, `6`
/// beyond; the closing `9` does not count, `docs/protocols.md` isel).
pub(super) fn size(
    program: &Program,
    flows: &[Flow],
    config: &LintConfig,
    out: &mut Vec<Diagnostic>,
) {
    let capacity = config.capacity_for(program.language());
    let stored = flows
        .iter()
        .position(|f| *f == Flow::End)
        .unwrap_or(flows.len());
    if stored > capacity {
        out.push(Diagnostic::error(
            Rule::ProgramSize,
            statement_span(program, capacity),
            format!(
                "the controller stores {} before the end `9`; this program has {stored}, and \
                 this one answers `6` (memory full)",
                count(capacity, "command")
            ),
        ));
    }
}
