//! Soft limits: run the program (every outcome of its branches, loops
//! unrolled, within a budget) and compare what each motion reaches with the
//! machine profile's limits.

use std::collections::HashMap;

use crate::axis::Axis;
use crate::proto::isel::AxisConfig;

use super::{AxisLimit, Diagnostic, LintConfig, Rule, statement_span};
use crate::program::model::{Language, Program};
use crate::program::run::{self, Mode, Motion, MotionKind, Observer};
use crate::program::source::Span;

pub(super) fn isel(
    program: &Program,
    axes: AxisConfig,
    config: &LintConfig,
    out: &mut Vec<Diagnostic>,
) {
    if !has_limits(config) {
        return;
    }
    let mut watch = Watch::new(config);
    let runner = run::isel::Runner::new(program, axes, Mode::Explore, config.budget);
    let outcome = runner.run(run::isel::State::start(config.start), &mut watch);
    watch.report(program, out);
    if let Some(index) = outcome.bound {
        out.push(bound(program, index, config.budget));
    }
}

pub(super) fn emcu(program: &Program, config: &LintConfig, out: &mut Vec<Diagnostic>) {
    if !has_limits(config) {
        return;
    }
    let mut watch = Watch::new(config);
    let outcome = run::emcu::run(program, config.start, config.budget, &mut watch);
    watch.report(program, out);
    if let Some(index) = outcome.bound {
        out.push(bound(program, index, config.budget));
    }
}

fn has_limits(config: &LintConfig) -> bool {
    config.axes.iter().any(|a| config.limit(a).is_some())
}

fn bound(program: &Program, index: usize, budget: usize) -> Diagnostic {
    Diagnostic::warning(
        Rule::SimulationBound,
        statement_span(program, index),
        format!(
            "the soft-limit check stopped here after {budget} simulated commands (loops and \
             both ways of every branch); what runs from here on is not checked"
        ),
    )
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Side {
    Above,
    Below,
}

/// The worst excursion found at one command, for one axis and side.
#[derive(Debug, Clone, Copy)]
struct Excursion {
    /// Some run surely goes this far (else it only may).
    certain: bool,
    /// The farthest coordinate beyond the limit.
    reached: i64,
}

struct Watch<'c> {
    config: &'c LintConfig,
    found: HashMap<(usize, Axis, Side), Excursion>,
}

impl<'c> Watch<'c> {
    fn new(config: &'c LintConfig) -> Watch<'c> {
        Watch {
            config,
            found: HashMap::new(),
        }
    }

    fn note(&mut self, key: (usize, Axis, Side), certain: bool, reached: i64) {
        let entry = self
            .found
            .entry(key)
            .or_insert(Excursion { certain, reached });
        entry.certain |= certain;
        entry.reached = match key.2 {
            Side::Above => entry.reached.max(reached),
            Side::Below => entry.reached.min(reached),
        };
    }

    fn report(self, program: &Program, out: &mut Vec<Diagnostic>) {
        let mut found: Vec<_> = self.found.into_iter().collect();
        found.sort_by_key(|((index, axis, side), _)| (*index, *axis, *side == Side::Below));
        for ((index, axis, side), e) in found {
            let Some(limit) = self.config.limit(axis) else {
                continue;
            };
            let (verb, relation, edge) = match (e.certain, side) {
                (true, Side::Above) => ("goes", "above", limit.max),
                (true, Side::Below) => ("goes", "below", limit.min),
                (false, Side::Above) => ("may go", "above", limit.max),
                (false, Side::Below) => ("may go", "below", limit.min),
            };
            let why = if e.certain {
                ""
            } else {
                " (where a move with a port condition `6` stopped is not known)"
            };
            let message = format!(
                "axis {axis} {verb} to {}, {relation} its soft limit {}{why}",
                limit.describe(e.reached),
                limit.describe(edge)
            );
            let span = axis_span(program, index, axis);
            out.push(if e.certain {
                Diagnostic::error(Rule::SoftLimit, span, message)
            } else {
                Diagnostic::warning(Rule::SoftLimit, span, message)
            });
        }
    }
}

impl Observer for Watch<'_> {
    fn motion(&mut self, m: &Motion) {
        if matches!(
            m.kind,
            MotionKind::Reference(_) | MotionKind::SimulatedReference(_)
        ) {
            return;
        }
        for axis in Axis::ALL {
            let (Some(reach), Some(limit)) = (
                m.reach.get(axis.index()).copied().flatten(),
                self.config.limit(axis).copied(),
            ) else {
                continue;
            };
            let AxisLimit { min, max, .. } = limit;
            if reach.max.hi > max {
                let certain = reach.max.lo > max;
                let reached = if certain { reach.max.lo } else { reach.max.hi };
                self.note((m.index, axis, Side::Above), certain, reached);
            }
            if reach.min.lo < min {
                let certain = reach.min.hi < min;
                let reached = if certain { reach.min.hi } else { reach.min.lo };
                self.note((m.index, axis, Side::Below), certain, reached);
            }
        }
    }
}

/// The parameter that moves `axis` in command `index`, else the command.
fn axis_span(program: &Program, index: usize, axis: Axis) -> Span {
    let Some((line, statement)) = program.statement(index) else {
        return statement_span(program, index);
    };
    let whole = Span::new(line, statement.code.clone());
    let text = program.line(line).map(|l| l.text()).unwrap_or_default();
    let param = match program.language() {
        // The steps of the axis' first pair (manual 3.2.2); circles as a whole.
        Language::Isel => match program.statement(index).and_then(|(_, s)| {
            s.command
                .as_ref()
                .ok()
                .and_then(|c| c.as_isel())
                .map(|c| c.code())
        }) {
            Some('0' | 'm') => statement.params.get(2 * axis.index()),
            _ => None,
        },
        // `L1,x500,y1000`: the parameter that starts with the axis letter.
        Language::Emcu => statement.params.iter().skip(1).find(|cols| {
            text.get((*cols).clone())
                .and_then(|p| p.chars().next())
                .is_some_and(|c| c.eq_ignore_ascii_case(&axis.letter()))
        }),
    };
    param.map_or(whole, |cols| Span::new(line, cols.clone()))
}
