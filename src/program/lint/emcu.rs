//! Lint rules for EMCU jobs (manual 1.4.2, 1.5; `docs/decisions.md`
//! EMCU 1-4; `docs/protocols.md` EMCU).

use crate::proto::emcu::{Command as EmcuCommand, JobError, Speed, job_problems};

use super::{Diagnostic, LintConfig, Rule, count, end_span, limits, statement_span};
use crate::program::model::{Command, Program, Statement};
use crate::program::source::Span;

pub(super) fn lint(program: &Program, config: &LintConfig) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    for (line, statement) in program.statements() {
        match &statement.command {
            Err(e) => out.push(Diagnostic::error(
                Rule::Syntax,
                Span::new(line, e.cols.clone()),
                e.message.clone(),
            )),
            Ok(Command::Emcu(c)) => {
                axes(line, statement, c, config, &mut out);
            }
            Ok(Command::Isel(_)) => {}
        }
    }
    job(program, config, &mut out);
    speeds(program, config, &mut out);
    limits::emcu(program, config, &mut out);
    out
}

/// Axes the machine does not have (decision 3: X, Y, Z at most).
fn axes(
    line: usize,
    statement: &Statement,
    command: &EmcuCommand,
    config: &LintConfig,
    out: &mut Vec<Diagnostic>,
) {
    let used = match command {
        EmcuCommand::Move(mv) => mv.axes(),
        EmcuCommand::Reference(order) => order.set(),
        EmcuCommand::Position(axis) => crate::axis::AxisSet::EMPTY.with(axis.axis()),
        _ => return,
    };
    for axis in used.iter().filter(|a| !config.axes.contains(*a)) {
        out.push(Diagnostic::error(
            Rule::Axis,
            Span::new(line, statement.code.clone()),
            format!(
                "the machine has no axis {axis} (its axes are {})",
                config.axes
            ),
        ));
    }
}

/// The job rules of the core ([`job_problems`]): not empty, no master
/// commands, at most the capacity.
fn job(program: &Program, config: &LintConfig, out: &mut Vec<Diagnostic>) {
    let commands: Vec<EmcuCommand> = program
        .statements()
        .filter_map(|(_, s)| s.command.as_ref().ok().and_then(Command::as_emcu).copied())
        .collect();
    // The core counts parsed commands; map its indices back to statements.
    let parsed: Vec<usize> = program
        .statements()
        .filter(|(_, s)| s.command.as_ref().ok().and_then(Command::as_emcu).is_some())
        .map(|(_, s)| s.index)
        .collect();
    let capacity = config.capacity_for(program.language());
    for problem in job_problems(&commands) {
        match problem {
            JobError::Empty if program.command_count() == 0 => {
                out.push(Diagnostic::error(
                    Rule::EmptyJob,
                    end_span(program),
                    "the job has no commands; a job stores at least one (manual 1.5.17)",
                ));
            }
            JobError::Empty => {}
            JobError::MasterCommand { index, command } => {
                let index = parsed.get(index).copied().unwrap_or(index);
                out.push(Diagnostic::error(
                    Rule::MasterCommand,
                    statement_span(program, index),
                    format!(
                        "`{command}` is a master command: the interface runs it at once and \
                         does not store it in a job (manual 1.4.2)"
                    ),
                ));
            }
            // The statement count decides (lines that do not parse are
            // lines the upload would send too).
            JobError::TooLong { .. } => {}
        }
    }
    let len = program.command_count();
    if len > capacity {
        out.push(Diagnostic::error(
            Rule::ProgramSize,
            statement_span(program, capacity),
            format!(
                "a job holds at most {}; this one has {len}, this is the first that does \
                 not fit",
                count(capacity, "command")
            ),
        ));
    }
}

/// Start and end speeds along the job (manual 1.5.5, 1.5.6): the interface's
/// power-up defaults are start 200 Hz and 600 Hz in every slot
/// (`docs/protocols.md` EMCU); a job that does not set a slot it moves with
/// depends on what ran before it.
fn speeds(program: &Program, config: &LintConfig, out: &mut Vec<Diagnostic>) {
    let mut start: (Speed, Option<usize>) = (Speed::DEFAULT_START, None);
    let mut ends: [(Speed, Option<usize>); 9] = [(Speed::DEFAULT_END, None); 9];
    for (line, statement) in program.statements() {
        let Some(command) = statement.command.as_ref().ok().and_then(Command::as_emcu) else {
            continue;
        };
        match command {
            EmcuCommand::StartSpeed(hz) => start = (*hz, Some(line)),
            EmcuCommand::EndSpeed { slot, speed } => {
                if let Some(cell) = ends.get_mut(usize::from(slot.get()).saturating_sub(1)) {
                    *cell = (*speed, Some(line));
                }
            }
            EmcuCommand::Move(mv) => {
                let slot = mv.slot();
                let slot_span = statement
                    .params
                    .first()
                    .map_or(Span::new(line, statement.code.clone()), |c| {
                        Span::new(line, c.clone())
                    });
                let Some(&(end, set_at)) = ends.get(usize::from(slot.get()).saturating_sub(1))
                else {
                    continue;
                };
                if set_at.is_none() {
                    out.push(Diagnostic::warning(
                        Rule::UnsetSlot,
                        slot_span,
                        format!(
                            "the job never sets end speed slot {slot} (`#E{slot},…`): the move \
                             runs at whatever it holds, {} Hz after power-up (manual 1.5.6)",
                            Speed::DEFAULT_END
                        ),
                    ));
                }
                if start.0 > end {
                    let from = |at: Option<usize>, what: &str| match at {
                        Some(l) => format!("{what} of line {}", l + 1),
                        None => format!("power-up {what}"),
                    };
                    out.push(Diagnostic::warning(
                        Rule::StartAboveEnd,
                        slot_span,
                        format!(
                            "the start speed {} Hz ({}) is above the end speed {end} Hz of slot \
                             {slot} ({}): there is no ramp up to run (manual 1.5.5-1.5.7)",
                            start.0,
                            from(start.1, "start speed"),
                            from(set_at, "end speed")
                        ),
                    ));
                }
                for (axis, _) in mv.targets() {
                    let max = config.limit(axis.axis()).and_then(|l| l.max_speed_hz);
                    if let Some(max) = max.filter(|m| f64::from(end.get()) > m + 1e-6) {
                        out.push(Diagnostic::warning(
                            Rule::MaxSpeed,
                            slot_span,
                            format!(
                                "slot {slot} runs at {end} Hz, above the highest speed of axis \
                                 {axis} in the machine profile, {} Hz",
                                super::trim_float(max)
                            ),
                        ));
                    }
                }
            }
            _ => {}
        }
    }
}
