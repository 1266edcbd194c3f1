//! Live validation: the linter and the toolpath, run on a snapshot of the
//! program off the UI thread ([`LintJob`] → [`LintResult`]), a moment after
//! the operator stops typing, so that no keystroke waits for them.
//!
//! Between an edit and the next result the diagnostics of untouched lines
//! are kept (shifted with the lines), and a line that was edited shows the
//! parser's verdict at once (every line parses on its own). A result is
//! applied only to the content it was computed for (the buffer's state);
//! a stale one is dropped and the lint runs again.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::program::{Diagnostic, LintConfig, Path, Program, Severity, Start, lint, path};

use super::buffer::Change;

/// Quiet time after an edit before the lint runs: short enough to feel
/// immediate, long enough that typing does not start a lint per key.
pub const LINT_DELAY: Duration = Duration::from_millis(150);
/// A new machine position starts a new lint (soft limits and the preview
/// depend on it) at most this often.
pub const START_REFRESH: Duration = Duration::from_secs(1);
/// Commands the soft-limit run may take per lint in the editor
/// (`docs/programs.md`: an editor may lower the budget).
pub const EDITOR_BUDGET: usize = 100_000;

/// What the lint worker is asked to do.
#[derive(Debug, Clone, PartialEq)]
pub struct LintJob {
    /// The buffer state the snapshot is of.
    pub state: u64,
    pub program: Arc<Program>,
    pub config: LintConfig,
    pub start: Start,
}

/// What it found.
#[derive(Debug, Clone, PartialEq)]
pub struct LintResult {
    pub state: u64,
    pub diagnostics: Vec<Diagnostic>,
    pub path: Path,
    pub start: Start,
}

impl LintJob {
    /// Lint and trace the path: CPU only, no I/O.
    pub fn run(&self) -> LintResult {
        LintResult {
            state: self.state,
            diagnostics: lint(&self.program, &self.config),
            path: path(&self.program, &self.start),
            start: self.start,
        }
    }
}

#[derive(Debug, Clone, Default)]
pub struct Checks {
    /// Sorted by line (the linter's order), shifted with edits.
    diagnostics: Vec<Diagnostic>,
    /// Per source line: the linter has seen its current text.
    checked: Vec<bool>,
    /// The toolpath of the last result.
    pub path: Option<Path>,
    /// The buffer state the diagnostics were computed for.
    linted: Option<u64>,
    /// When the next lint is due.
    due: Option<Instant>,
    /// The state being linted now.
    running: Option<u64>,
    /// The start the last lint was given.
    last_start: Option<Start>,
    start_checked_at: Option<Instant>,
}

impl Checks {
    /// Lint as soon as possible (a new buffer).
    pub fn reset(&mut self, lines: usize, now: Instant) {
        *self = Checks {
            checked: vec![false; lines],
            due: Some(now),
            ..Checks::default()
        };
    }

    /// The lines changed: keep what is known about the others.
    pub fn changed(&mut self, change: Change, now: Instant) {
        self.diagnostics
            .retain_mut(|d| match change.map_line(d.span.line) {
                Some(line) => {
                    d.span.line = line;
                    if let Some(fix) = &mut d.fix {
                        fix.span.line = line;
                    }
                    true
                }
                None => false,
            });
        let end = (change.at + change.removed).min(self.checked.len());
        let at = change.at.min(end);
        self.checked
            .splice(at..end, std::iter::repeat_n(false, change.inserted));
        self.due = Some(now + LINT_DELAY);
    }

    /// The machine's start position changed; lint again soon (not on every
    /// poll).
    pub fn start_moved(&mut self, start: Start, now: Instant) {
        if self.last_start == Some(start) {
            return;
        }
        let recent = self
            .start_checked_at
            .is_some_and(|t| now.saturating_duration_since(t) < START_REFRESH);
        if self.due.is_none() && !recent {
            self.due = Some(now);
        }
    }

    /// Whether a lint should start now.
    pub fn wants_lint(&self, now: Instant) -> bool {
        self.running.is_none() && self.due.is_some_and(|t| now >= t)
    }

    pub fn started(&mut self, state: u64, start: Start, now: Instant) {
        self.running = Some(state);
        self.due = None;
        self.last_start = Some(start);
        self.start_checked_at = Some(now);
    }

    /// A result arrived; applied when it is of the current content
    /// (`true`), else dropped and the lint is due again.
    pub fn finished(&mut self, result: LintResult, state: u64, lines: usize, now: Instant) -> bool {
        self.running = None;
        if result.state != state {
            self.due.get_or_insert(now);
            return false;
        }
        self.diagnostics = result.diagnostics;
        self.path = Some(result.path);
        self.linted = Some(state);
        self.checked = vec![true; lines];
        true
    }

    /// The diagnostics reflect the content of state `state`.
    pub fn fresh(&self, state: u64) -> bool {
        self.linted == Some(state) && self.due.is_none() && self.running.is_none()
    }

    /// Take a result computed right here (an upload must know the truth).
    pub fn apply_now(&mut self, job: &LintJob, lines: usize, now: Instant) {
        self.started(job.state, job.start, now);
        self.finished(job.run(), job.state, lines, now);
    }

    pub fn all(&self) -> &[Diagnostic] {
        &self.diagnostics
    }

    /// The diagnostics of `line`, in column order.
    pub fn on_line(&self, line: usize) -> &[Diagnostic] {
        let start = self.diagnostics.partition_point(|d| d.span.line < line);
        let end = self.diagnostics.partition_point(|d| d.span.line <= line);
        self.diagnostics.get(start..end).unwrap_or_default()
    }

    /// Whether the linter has seen line `line` as it is now.
    pub fn is_checked(&self, line: usize) -> bool {
        self.checked.get(line).copied().unwrap_or(false)
    }

    /// Errors and warnings.
    pub fn counts(&self) -> (usize, usize) {
        let errors = self
            .diagnostics
            .iter()
            .filter(|d| d.severity == Severity::Error)
            .count();
        (errors, self.diagnostics.len() - errors)
    }

    /// The first diagnostic after (`forward`) or before `line`, wrapping
    /// around.
    pub fn next_problem(&self, line: usize, forward: bool) -> Option<&Diagnostic> {
        if forward {
            self.diagnostics
                .iter()
                .find(|d| d.span.line > line)
                .or_else(|| self.diagnostics.first())
        } else {
            self.diagnostics
                .iter()
                .rev()
                .find(|d| d.span.line < line)
                .or_else(|| self.diagnostics.last())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::AxisSet;
    use crate::program::Language;

    fn job(text: &str, state: u64) -> LintJob {
        LintJob {
            state,
            program: Arc::new(Program::parse(Language::Isel, text)),
            config: LintConfig::new(AxisSet::XYZ),
            start: Start::at_zero(AxisSet::XYZ),
        }
    }

    #[test]
    fn diagnostics_shift_with_edits_and_edited_lines_are_unchecked() {
        let t0 = Instant::now();
        let mut checks = Checks::default();
        checks.reset(4, t0);
        assert!(checks.wants_lint(t0));
        let j = job(
            "M1,900,0,900,0,900,0,900\n; c\nM1,900,0,900,0,900,0,900\n9\n",
            0,
        );
        checks.started(0, j.start, t0);
        assert!(!checks.wants_lint(t0), "one at a time");
        assert!(checks.finished(j.run(), 0, 4, t0));
        assert!(checks.fresh(0));
        let lines: Vec<usize> = checks.all().iter().map(|d| d.span.line).collect();
        assert_eq!(lines, [0, 2], "table spelling `M` on both moves");
        // Two lines inserted before line 1.
        checks.changed(
            Change {
                at: 1,
                removed: 0,
                inserted: 2,
            },
            t0,
        );
        let lines: Vec<usize> = checks.all().iter().map(|d| d.span.line).collect();
        assert_eq!(lines, [0, 4]);
        assert!(checks.is_checked(0) && !checks.is_checked(1) && checks.is_checked(4));
        assert_eq!(checks.on_line(4).len(), 1);
        assert!(!checks.wants_lint(t0), "waits for the typing to pause");
        assert!(checks.wants_lint(t0 + LINT_DELAY));
        // Line 0 replaced: its diagnostic goes until the next lint.
        checks.changed(
            Change {
                at: 0,
                removed: 1,
                inserted: 1,
            },
            t0,
        );
        assert_eq!(checks.all().len(), 1);
    }

    #[test]
    fn a_stale_result_is_dropped_and_the_lint_runs_again() {
        let t0 = Instant::now();
        let mut checks = Checks::default();
        checks.reset(1, t0);
        let j = job("9\n", 3);
        checks.started(3, j.start, t0);
        assert!(!checks.finished(j.run(), 4, 1, t0));
        assert!(checks.wants_lint(t0));
        assert!(!checks.fresh(4));
    }

    #[test]
    fn problems_are_found_forwards_and_backwards_around_the_end() {
        let t0 = Instant::now();
        let mut checks = Checks::default();
        let j = job(
            "M1,900,0,900,0,900,0,900\n; c\nM1,900,0,900,0,900,0,900\n9\n",
            0,
        );
        checks.apply_now(&j, 4, t0);
        assert_eq!(checks.next_problem(0, true).map(|d| d.span.line), Some(2));
        assert_eq!(checks.next_problem(2, true).map(|d| d.span.line), Some(0));
        assert_eq!(checks.next_problem(0, false).map(|d| d.span.line), Some(2));
        assert_eq!(checks.counts(), (0, 2));
    }
}
