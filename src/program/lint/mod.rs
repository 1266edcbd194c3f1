//! The linter: everything a controller would refuse while storing the
//! program, everything that would go wrong while running it, and what is
//! merely unusual, each with a span and, where the change is clear, a fix.
//!
//! Single lines are checked by the protocol cores (`parse_cnc`, `check_cnc`,
//! EMCU `parse_line`); this module adds what needs the whole program: jump
//! and loop structure, the end, memory size, flow-dependent state (circle
//! direction, EMCU speeds), and the soft limits of the machine profile,
//! found by running the program ([`LintConfig`] says from where).

mod emcu;
mod isel;
mod limits;

use std::fmt;

use crate::axis::{Axis, AxisSet};
use crate::config::Profile;
use crate::config::profile::Unit;

use super::model::{Language, Program};
use super::path::Position;
use super::source::Span;

/// Commands the soft-limit check runs at most, over all explored outcomes.
pub const DEFAULT_BUDGET: usize = 1_000_000;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Severity {
    /// The controller refuses the program, or running it would do harm
    /// (a move beyond a soft limit).
    Error,
    /// Allowed, but probably not what was meant.
    Warning,
}

impl Severity {
    pub fn name(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
        }
    }
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a diagnostic is about; stable names for filtering and tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Rule {
    /// A line the controller cannot read (isel `5`, any EMCU parse error).
    Syntax,
    /// isel `8`: a DNC command or a letter that cannot be stored.
    NotStorable,
    /// isel `7`: wrong number of parameters for the axis configuration.
    ParameterCount,
    /// isel `1`: a number outside its range (bits, ports, steps, counts).
    NumberRange,
    /// isel `D`: a speed outside 1-40000 Hz, start-stop or acceleration.
    Speed,
    /// isel `3`: an axis that is not initialised; EMCU: an axis the machine
    /// does not have.
    Axis,
    /// `3 n,k` with n > 0 and k >= 0 (manual 3.2.5).
    ForwardLoop,
    /// More than 7 nested loops (manual 3.2.5).
    LoopDepth,
    /// Two loops overlap without one containing the other.
    LoopOverlap,
    /// A jump from inside a loop to outside it (manual 3.2.5).
    LoopExit,
    /// A jump or loop start outside the program (manual 3.2.5).
    JumpTarget,
    /// `3 0,0`: a jump to itself, the program hangs.
    EndlessJump,
    /// No `9` (manual 3.2.9).
    MissingEnd,
    /// Commands after the `9`.
    AfterEnd,
    /// More commands than the controller stores.
    ProgramSize,
    /// An EMCU job without commands.
    EmptyJob,
    /// `F M O P W Y Z` for `f m o p w y z` (`docs/decisions.md` isel 10).
    TableSpelling,
    /// `f1` for counter-clockwise, which is written `f-1`.
    CcwAsOne,
    /// A sync character of `1` that is also a reply code (manual 3.2.3).
    SyncCollision,
    /// A circle before any `f` set its direction (manual 3.2.12).
    CircleDirection,
    /// A move beyond a soft limit of the machine profile.
    SoftLimit,
    /// The soft-limit check ran out of budget.
    SimulationBound,
    /// A speed above the profile's highest speed for the axis.
    MaxSpeed,
    /// An EMCU master command (`@…`) in a job (manual 1.4.2).
    MasterCommand,
    /// An EMCU move with an end-speed slot the job never sets.
    UnsetSlot,
    /// An EMCU move whose start speed is above its end speed.
    StartAboveEnd,
}

impl Rule {
    pub fn name(self) -> &'static str {
        match self {
            Rule::Syntax => "syntax",
            Rule::NotStorable => "not-storable",
            Rule::ParameterCount => "parameter-count",
            Rule::NumberRange => "number-range",
            Rule::Speed => "speed",
            Rule::Axis => "axis",
            Rule::ForwardLoop => "forward-loop",
            Rule::LoopDepth => "loop-depth",
            Rule::LoopOverlap => "loop-overlap",
            Rule::LoopExit => "loop-exit",
            Rule::JumpTarget => "jump-target",
            Rule::EndlessJump => "endless-jump",
            Rule::MissingEnd => "missing-end",
            Rule::AfterEnd => "after-end",
            Rule::ProgramSize => "program-size",
            Rule::EmptyJob => "empty-job",
            Rule::TableSpelling => "table-spelling",
            Rule::CcwAsOne => "ccw-as-one",
            Rule::SyncCollision => "sync-collision",
            Rule::CircleDirection => "circle-direction",
            Rule::SoftLimit => "soft-limit",
            Rule::SimulationBound => "simulation-bound",
            Rule::MaxSpeed => "max-speed",
            Rule::MasterCommand => "master-command",
            Rule::UnsetSlot => "unset-slot",
            Rule::StartAboveEnd => "start-above-end",
        }
    }
}

impl fmt::Display for Rule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A replacement of the text at `span` that resolves a diagnostic.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Fix {
    pub span: Span,
    pub replacement: String,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Diagnostic {
    pub severity: Severity,
    pub rule: Rule,
    pub span: Span,
    pub message: String,
    pub fix: Option<Fix>,
}

impl Diagnostic {
    pub(crate) fn error(rule: Rule, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            rule,
            span,
            message: message.into(),
            fix: None,
        }
    }

    pub(crate) fn warning(rule: Rule, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity: Severity::Warning,
            ..Diagnostic::error(rule, span, message)
        }
    }

    pub(crate) fn with_fix(mut self, span: Span, replacement: impl Into<String>) -> Diagnostic {
        self.fix = Some(Fix {
            span,
            replacement: replacement.into(),
        });
        self
    }
}

/// The soft limits of one axis, in steps of the machine coordinates
/// (from the reference point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisLimit {
    pub min: i64,
    pub max: i64,
    /// The highest step frequency a move of this axis may be given.
    pub max_speed_hz: Option<f64>,
    /// For messages: the profile's unit and steps per unit.
    pub unit: Unit,
    pub steps_per_unit: f64,
}

impl AxisLimit {
    /// Limits in steps, shown in steps.
    pub fn steps(min: i64, max: i64) -> AxisLimit {
        AxisLimit {
            min,
            max,
            max_speed_hz: None,
            unit: Unit::Steps,
            steps_per_unit: 1.0,
        }
    }

    /// `steps` steps, and in the profile's unit when it is not steps.
    pub(crate) fn describe(&self, steps: i64) -> String {
        if self.unit == Unit::Steps || self.steps_per_unit <= 0.0 {
            format!("{steps} steps")
        } else {
            let units = steps as f64 / self.steps_per_unit;
            format!(
                "{steps} steps ({} {})",
                trim_float(units),
                self.unit.symbol()
            )
        }
    }
}

fn trim_float(v: f64) -> String {
    let text = format!("{v:.3}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// What the linter knows about the machine.
#[derive(Debug, Clone, PartialEq)]
pub struct LintConfig {
    /// The axes the controller is initialised with (isel: X, XY, XYZ or
    /// XYZA; EMCU: any of X, Y, Z).
    pub axes: AxisSet,
    /// Soft limits per axis (X Y Z A); `None` = not checked.
    pub limits: [Option<AxisLimit>; 4],
    /// The controller's counters when the program starts, when known (the
    /// console knows them; a file on its own does not). When unknown, an
    /// axis' position is known from its first reference run (isel `7`, EMCU
    /// `$H`) or absolute move on; before that its moves are not checked
    /// against the soft limits (`docs/programs.md`).
    pub start: Option<Position>,
    /// Commands the controller stores; `None` = the language's default
    /// ([`Language::capacity`]).
    pub capacity: Option<usize>,
    /// Commands the soft-limit check runs at most (loops unrolled, both
    /// outcomes of every branch); an editor linting on every keystroke may
    /// lower it.
    pub budget: usize,
}

impl LintConfig {
    /// No limits, start unknown, default memory and budget.
    pub fn new(axes: AxisSet) -> LintConfig {
        LintConfig {
            axes,
            limits: [None; 4],
            start: None,
            capacity: None,
            budget: DEFAULT_BUDGET,
        }
    }

    /// The axes, soft limits and highest speeds of a machine profile
    /// (soft limits in units × steps per unit = steps).
    pub fn from_profile(profile: &Profile) -> LintConfig {
        let mut config = LintConfig::new(profile.axis_set());
        // The one memory setting: the import, `check`, `upload`, `run` and
        // the console count against it alike (issue 37).
        config.capacity = profile.gcode.memory;
        for (axis, p) in &profile.axes {
            if let Some(slot) = config.limits.get_mut(axis.index()) {
                *slot = Some(AxisLimit {
                    min: p.min_steps(),
                    max: p.max_steps(),
                    max_speed_hz: Some(p.speed_hz(p.max_speed)),
                    unit: p.unit,
                    steps_per_unit: p.steps_per_unit,
                });
            }
        }
        config
    }

    pub fn limit(&self, axis: Axis) -> Option<&AxisLimit> {
        self.limits.get(axis.index()).and_then(Option::as_ref)
    }

    pub fn capacity_for(&self, language: Language) -> usize {
        self.capacity.unwrap_or(language.capacity())
    }
}

/// Lint a program for a machine. The diagnostics are sorted by position.
pub fn lint(program: &Program, config: &LintConfig) -> Vec<Diagnostic> {
    let mut out = match program.language() {
        Language::Isel => isel::lint(program, config),
        Language::Emcu => emcu::lint(program, config),
    };
    out.sort_by(|a, b| {
        (a.span.line, a.span.start, a.severity).cmp(&(b.span.line, b.span.start, b.severity))
    });
    out
}

/// The span of the whole command text of statement `index`, or the end of
/// the program when there is none.
pub(crate) fn statement_span(program: &Program, index: usize) -> Span {
    program.span_of(index).unwrap_or_else(|| end_span(program))
}

/// An empty span after the last line, for what is missing at the end.
pub(crate) fn end_span(program: &Program) -> Span {
    let lines = program.lines();
    match lines.last() {
        Some(last) => Span::new(lines.len() - 1, last.text().len()..last.text().len()),
        None => Span::new(0, 0..0),
    }
}

/// "1 command" / "3 commands".
pub(crate) fn count(n: usize, what: &str) -> String {
    if n == 1 {
        format!("1 {what}")
    } else {
        format!("{n} {what}s")
    }
}
