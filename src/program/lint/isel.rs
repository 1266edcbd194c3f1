//! Lint rules for isel CNC programs (manual chapter 3, `../shared/protocols.md`
//! isel 9-13).

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{
    AxisConfig, CncCommand, HelixParams, NoteKind, Plane, ReplyCode, check_cnc,
};

use super::super::flow::{self, Flow, LoopRange};
use super::super::model::{Command, Program, Statement};
use super::super::path::covering_config;
use super::super::source::Span;
use super::{Diagnostic, LintConfig, Rule, count, end_span, limits, statement_span};

/// Loops nest at most this deep (manual 3.2.5).
pub const MAX_LOOP_DEPTH: usize = 7;

pub(super) fn lint(program: &Program, config: &LintConfig) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let axes = match exact_config(config.axes) {
        Some(axes) => axes,
        None => {
            out.push(Diagnostic::error(
                Rule::Axis,
                Span::new(0, 0..0),
                format!(
                    "the axes `{}` are no isel configuration: X, XY, XYZ or XYZA (manual 2.2.1); \
                     checking for {}",
                    config.axes,
                    covering_config(config.axes)
                ),
            ));
            covering_config(config.axes)
        }
    };
    let commands = flow::commands(program);
    let flows = flow::flows(&commands);
    let modal = modal_states(&commands, &flows);
    for (line, statement) in program.statements() {
        let here = modal.get(statement.index).copied().flatten();
        lines(line, statement, axes, config, here, &mut out);
    }
    structure(program, &flows, &mut out);
    end(program, &flows, &mut out);
    size(program, &flows, config, &mut out);
    limits::isel(program, axes, config, &mut out);
    out
}

/// The isel configuration with exactly these axes (manual 2.2.1).
fn exact_config(axes: AxisSet) -> Option<AxisConfig> {
    AxisConfig::ALL.into_iter().find(|c| c.axes() == axes)
}

/// The rule for a reply code of the parser or the check.
fn rule_for(code: Option<ReplyCode>) -> Rule {
    match code {
        Some(ReplyCode::NotStorable) => Rule::NotStorable,
        Some(ReplyCode::ParameterCount) => Rule::ParameterCount,
        Some(ReplyCode::BadNumber) => Rule::NumberRange,
        Some(ReplyCode::BadSpeed) => Rule::Speed,
        Some(ReplyCode::BadAxis | ReplyCode::NoAxes) => Rule::Axis,
        _ => Rule::Syntax,
    }
}

/// The section of chapter 3 that describes a CNC code.
pub(crate) fn section(code: char) -> &'static str {
    match code {
        '0' => "3.2.2",
        '1' => "3.2.3",
        '2' => "3.2.4",
        '3' => "3.2.5",
        '5' => "3.2.6",
        '6' => "3.2.7",
        '7' => "3.2.8",
        '9' => "3.2.9",
        'd' => "3.2.10",
        'e' => "3.2.11",
        'f' => "3.2.12",
        'g' => "3.2.13",
        'j' => "3.2.14",
        'J' => "3.2.15",
        'm' => "3.2.16",
        'n' => "3.2.17",
        'N' => "3.2.18",
        'o' => "3.2.19",
        'p' => "3.2.20",
        'T' => "3.2.21",
        'w' => "3.2.22",
        'y' => "3.2.23",
        'z' => "3.2.24",
        _ => "3.2",
    }
}

fn param_span(line: usize, statement: &Statement, param: usize) -> Span {
    match statement.params.get(param) {
        Some(cols) => Span::new(line, cols.clone()),
        None => Span::new(line, statement.code.clone()),
    }
}

/// The checks of one line on its own.
fn lines(
    line: usize,
    statement: &Statement,
    axes: AxisConfig,
    config: &LintConfig,
    modal: Option<Modal>,
    out: &mut Vec<Diagnostic>,
) {
    let command = match &statement.command {
        Err(e) => {
            let reply = e
                .reply
                .map(|c| format!(" (the controller answers `{}`)", c.char()))
                .unwrap_or_default();
            out.push(Diagnostic::error(
                rule_for(e.reply),
                Span::new(line, e.cols.clone()),
                format!("{}{reply}", e.message),
            ));
            return;
        }
        Ok(Command::Isel(command)) => command,
        Ok(Command::Emcu(_)) => return,
    };
    let code = command.code();
    if let Err(e) = check_cnc(command, axes) {
        let forward =
            matches!(command, CncCommand::Loop { count, offset } if *count > 0 && *offset >= 0);
        let span = match e.param {
            Some(p) => param_span(line, statement, p),
            None => Span::new(line, statement.code.clone()),
        };
        out.push(Diagnostic::error(
            if forward {
                Rule::ForwardLoop
            } else {
                rule_for(Some(e.code))
            },
            span,
            format!(
                "{} (manual {}; the controller answers `{}`)",
                e.message,
                section(code),
                e.code.char()
            ),
        ));
    }
    for note in &statement.notes {
        let span = Span::new(line, note.cols.clone());
        match note.kind {
            NoteKind::TableSpelling {
                written,
                section: letter,
            } => out.push(
                Diagnostic::warning(
                    Rule::TableSpelling,
                    span,
                    format!(
                        "`{written}` is the spelling of the manual's command table; \
                         its section {} writes `{letter}`",
                        section(letter)
                    ),
                )
                .with_fix(span, letter.to_string()),
            ),
            NoteKind::CcwWrittenAsOne => out.push(
                Diagnostic::warning(
                    Rule::CcwAsOne,
                    span,
                    "`f1` means counter-clockwise, which the manual writes `f-1`; \
                     clockwise is `f0` (manual 3.2.12)",
                )
                .with_fix(span, "-1"),
            ),
            NoteKind::SpaceAfterCode | NoteKind::AlternateLetter { .. } => {}
        }
    }
    match command {
        CncCommand::SendSync(sync) if sync.collides_with_reply_code() => {
            out.push(Diagnostic::warning(
                Rule::SyncCollision,
                param_span(line, statement, 0),
                format!(
                    "the sync character `{sync}` ({}) is also a reply code: while the program \
                     runs, the console takes it for the end of the run (manual 3.2.3, chapter 5)",
                    sync.byte()
                ),
            ));
        }
        CncCommand::Loop {
            count: 0,
            offset: 0,
        } => out.push(Diagnostic::warning(
            Rule::EndlessJump,
            param_span(line, statement, 1),
            "`3 0,0` jumps to itself: the program hangs here until it is stopped (manual 3.2.5)",
        )),
        _ => {}
    }
    if let Some(modal) = modal.filter(|_| is_arc(command)) {
        circle_state(line, statement, command, axes, modal, out);
    }
    max_speeds(line, statement, command, axes, modal, config, out);
}

/// The axis each steps,speed pair of `0`/`m` moves (manual 3.2.2).
fn pair_axes(axes: AxisConfig) -> &'static [Axis] {
    match axes {
        AxisConfig::X => &[Axis::X],
        AxisConfig::XY => &[Axis::X, Axis::Y],
        AxisConfig::XYZ => &[Axis::X, Axis::Y, Axis::Z, Axis::Z],
        AxisConfig::XYZA => &[Axis::X, Axis::Y, Axis::Z, Axis::A],
    }
}

/// Speeds above the profile's highest speed of an axis; a circle's speed
/// for the axes of every plane it may run in.
fn max_speeds(
    line: usize,
    statement: &Statement,
    command: &CncCommand,
    axes: AxisConfig,
    modal: Option<Modal>,
    config: &LintConfig,
    out: &mut Vec<Diagnostic>,
) {
    // One diagnostic per parameter: a circle's speed serves two axes.
    let mut reported: Option<usize> = None;
    let mut check = |param: usize, axis: Axis, speed: u32| {
        let max = config.limit(axis).and_then(|l| l.max_speed_hz);
        let Some(max) = max.filter(|m| f64::from(speed) > m + 1e-6) else {
            return;
        };
        if reported == Some(param) {
            return;
        }
        reported = Some(param);
        out.push(Diagnostic::warning(
            Rule::MaxSpeed,
            param_span(line, statement, param),
            format!(
                "{speed} Hz is above the highest speed of axis {axis} in the machine profile, \
                 {} Hz",
                super::trim_float(max)
            ),
        ));
    };
    match command {
        CncCommand::MoveRelative(pairs) | CncCommand::MoveAbsolute(pairs) => {
            let absolute = matches!(command, CncCommand::MoveAbsolute(_));
            for (i, (pair, axis)) in pairs.iter().zip(pair_axes(axes)).enumerate() {
                // z2 of an absolute move with 3 axes is ignored (3.2.16).
                let ignored = absolute && axes == AxisConfig::XYZ && i == 3;
                let moves = absolute || pair.steps != 0;
                if moves && !ignored {
                    check(2 * i + 1, *axis, pair.speed);
                }
            }
        }
        CncCommand::SetReferenceSpeeds(list) => {
            for (i, (speed, axis)) in list.iter().zip(axes.axes().iter()).enumerate() {
                check(i, axis, *speed);
            }
        }
        CncCommand::Circle(c) | CncCommand::Helix(HelixParams { circle: c, .. }) => {
            for plane in Plane::ALL {
                if modal.is_some_and(|m| m.has(plane)) {
                    let (a1, a2) = plane.axes();
                    check(1, a1, c.speed);
                    check(1, a2, c.speed);
                }
            }
        }
        _ => {}
    }
}

fn is_arc(command: &CncCommand) -> bool {
    matches!(command, CncCommand::Circle(_) | CncCommand::Helix(_))
}

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
fn structure(program: &Program, flows: &[Flow], out: &mut Vec<Diagnostic>) {
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

/// The end `9`, and nothing after it (manual 3.2.9, `../shared/protocols.md`
/// isel 9).
fn end(program: &Program, flows: &[Flow], out: &mut Vec<Diagnostic>) {
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

/// Program memory (`../shared/protocols.md` isel 9: 2000 commands, `6`
/// beyond; the closing `9` does not count, `docs/protocols.md` isel).
fn size(program: &Program, flows: &[Flow], config: &LintConfig, out: &mut Vec<Diagnostic>) {
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

/// The modal state of the controller when a command runs, over every way
/// that reaches it: whether an `f` has surely set the circle direction
/// (manual 3.2.12), and the planes (`e`, manual 3.2.11; XY at the start) it
/// may be in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Modal {
    direction_set: bool,
    /// Bit `Plane::value()` for each plane possible.
    plane_bits: u8,
}

impl Modal {
    fn has(self, plane: Plane) -> bool {
        self.plane_bits & (1 << plane.value()) != 0
    }

    fn join(self, other: Modal) -> Modal {
        Modal {
            direction_set: self.direction_set && other.direction_set,
            plane_bits: self.plane_bits | other.plane_bits,
        }
    }
}

/// A forward data-flow over the jumps: `None` for commands no way reaches.
fn modal_states(commands: &[Option<&CncCommand>], flows: &[Flow]) -> Vec<Option<Modal>> {
    let len = flows.len();
    let mut states: Vec<Option<Modal>> = vec![None; len];
    let Some(first) = states.first_mut() else {
        return states;
    };
    *first = Some(Modal {
        direction_set: false,
        plane_bits: 1 << Plane::XY.value(),
    });
    let mut work = vec![0usize];
    while let Some(i) = work.pop() {
        let Some(mut after) = states.get(i).copied().flatten() else {
            continue;
        };
        match commands.get(i).copied().flatten() {
            Some(CncCommand::SetCircleDirection(_)) => after.direction_set = true,
            Some(CncCommand::SetPlane(p)) => after.plane_bits = 1 << p.value(),
            _ => {}
        }
        let Some(f) = flows.get(i) else {
            continue;
        };
        for next in flow::successors(*f, i, len).into_iter().flatten() {
            let Some(slot) = states.get_mut(next) else {
                continue;
            };
            let new = slot.map_or(after, |old| old.join(after));
            if *slot != Some(new) {
                *slot = Some(new);
                work.push(next);
            }
        }
    }
    states
}

/// A circle or helix: its direction set before it (manual 3.2.12: "Die
/// Richtung für die Kreisinterpolation ist prinzipiell vor jeder
/// Kreisbewegung zu programmieren"), and the axes of every plane it may run
/// in initialised (the controller answers `3` when it runs it otherwise).
fn circle_state(
    line: usize,
    statement: &Statement,
    command: &CncCommand,
    axes: AxisConfig,
    modal: Modal,
    out: &mut Vec<Diagnostic>,
) {
    let span = Span::new(line, statement.code.clone());
    let letter = command.code();
    if !modal.direction_set {
        out.push(Diagnostic::warning(
            Rule::CircleDirection,
            span,
            format!(
                "no `f` sets the circle direction before this `{letter}` (on some way here): \
                 it runs in whatever direction was set last; write `f0` (CW) or `f-1` (CCW) \
                 before it (manual 3.2.12)"
            ),
        ));
    }
    for plane in Plane::ALL.into_iter().filter(|p| modal.has(*p)) {
        let (a1, a2) = plane.axes();
        let mut needed = vec![a1, a2];
        if letter == 'w' {
            needed.push(plane.third_axis());
        }
        if let Some(missing) = needed.into_iter().find(|a| !axes.axes().contains(*a)) {
            out.push(Diagnostic::error(
                Rule::Axis,
                span,
                format!(
                    "this `{letter}` runs in the {plane:?} plane (manual 3.2.11), which needs \
                     axis {missing}; the controller has {axes} and answers `3` when it gets here"
                ),
            ));
        }
    }
}
