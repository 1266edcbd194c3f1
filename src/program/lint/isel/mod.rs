//! Lint rules for isel CNC programs (manual chapter 3, `docs/decisions.md`
//! isel 9-13): each line on its own here, the jump and loop structure in
//! [`structure`], the controller's modal state along the jumps in [`modal`],
//! soft limits in `lint::limits`.

mod modal;
mod structure;

use crate::axis::{Axis, AxisSet};
use crate::proto::isel::{
    AxisConfig, CncCommand, HelixParams, NoteKind, Plane, ReplyCode, check_cnc,
};

use super::{Diagnostic, LintConfig, Rule, limits};
use crate::program::flow;
use crate::program::model::{Command, Program, Statement};
use crate::program::path::covering_config;
use crate::program::source::Span;
use modal::{Modal, circle_state, modal_states};

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
    structure::jumps_and_loops(program, &flows, &mut out);
    structure::end(program, &flows, &mut out);
    structure::size(program, &flows, config, &mut out);
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
fn section(code: char) -> &'static str {
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

pub(super) fn param_span(line: usize, statement: &Statement, param: usize) -> Span {
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

pub(super) fn is_arc(command: &CncCommand) -> bool {
    matches!(command, CncCommand::Circle(_) | CncCommand::Helix(_))
}
