//! The job run from the editor as the status line shows it (issue 40): a
//! word, its progress in a few columns (G-code line, share, elapsed, time
//! left, speed factor), and while it waits for the operator why and what
//! ends the wait, shown on the message line until it goes on. One place,
//! so that the status bar at 80 columns and the tests read the same words.

use std::time::{Duration, Instant};

use super::Editor;
use super::checkout::RunState;
use super::job::{Phase, wait_short, wait_text};

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JobStatus {
    /// One upper-case word: `STREAM`, `RUNNING`, `STORING`, `PAUSED`, …
    pub word: &'static str,
    /// Compact progress, most important first (it is cut from the right).
    pub progress: String,
    /// While the job waits for the operator: why, and the key that goes on.
    pub waiting: Option<String>,
}

/// `2:05` (minutes and seconds), `1:02:05` past an hour.
pub fn clock(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

impl Editor {
    /// A stream's time left (`left`), with the model's time of the pieces
    /// after it where it streams a piece of a job with waits, and the
    /// waits to come (` +2 waits`), which it does not count.
    pub fn stream_left(&self, left: Option<Duration>) -> Option<(Duration, String)> {
        let left = left?;
        let Some(job) = &self.chunked else {
            return Some((left, String::new()));
        };
        let later = match &job.pieces {
            Some(p) => p.after().0?,
            None => 0.0,
        };
        Some((left + Duration::from_secs_f64(later), job.waits_ahead()))
    }

    /// What the status line says of the job this editor runs, if any.
    pub fn job_status(&self, now: Instant, running_stored: bool) -> Option<JobStatus> {
        if let Some(c) = &self.checkout {
            let paused = matches!(c.state, RunState::Paused { .. });
            if let Some((gcode, share, elapsed, left)) =
                c.stream_progress(c.program(self.buffer.program()), now)
            {
                // A streamed piece of a job with waits: which one.
                let piece = self
                    .chunked
                    .as_ref()
                    .and_then(|j| j.pieces.as_ref())
                    .map(|p| format!("{} ", p.label()))
                    .unwrap_or_default();
                let line = gcode.map(|l| format!("{piece}L{l} ")).unwrap_or(piece);
                let left = self
                    .stream_left(left)
                    .map(|(l, waits)| format!(" left {}{waits}", clock(l)))
                    .unwrap_or_default();
                return Some(JobStatus {
                    word: if paused { "PAUSED" } else { "STREAM" },
                    progress: format!(
                        "{line}{:.0}% {}{left} x{}%",
                        share * 100.0,
                        clock(elapsed),
                        c.factor
                    ),
                    waiting: paused.then(|| {
                        format!(
                            "stream PAUSED{}: F10 goes on, x ends the stream, Space stops",
                            gcode
                                .map(|l| format!(" at G-code line {l}"))
                                .unwrap_or_default()
                        )
                    }),
                });
            }
            let line = c
                .buffer_line()
                .map(|l| format!("line {} ", l + 1))
                .unwrap_or_default();
            return Some(JobStatus {
                word: c.label(),
                progress: format!(
                    "{line}{} x{}%",
                    clock(now.saturating_duration_since(c.started)),
                    c.factor
                ),
                waiting: paused.then(|| {
                    "check-out PAUSED: hold the key to go on, x ends the check-out".to_owned()
                }),
            });
        }
        if let Some(c) = &self.chunked {
            let elapsed = clock(now.saturating_duration_since(c.started));
            // A job with waits at one: what for and what ends it.
            if let Some(p) = c.pieces.as_ref().filter(|_| c.phase == Phase::Waiting)
                && let (Some(at), Some(w)) = (p.wait.as_ref(), p.current_wait())
            {
                let ends = if at.erasing {
                    "erasing (@0k)"
                } else {
                    "F6 goes on, Space ends"
                };
                return Some(JobStatus {
                    word: "WAIT",
                    progress: format!("{}: {ends}", wait_short(w)),
                    waiting: Some(wait_text(w, at.erasing)),
                });
            }
            if let Some(m) = c.pieces.as_ref().and_then(|p| p.measure.as_ref()) {
                return Some(JobStatus {
                    word: "MEASURE",
                    progress: format!("{} on the tool sensor: Space ends", m.tool),
                    waiting: None,
                });
            }
            let (word, waiting) = match c.phase {
                Phase::Uploading => ("STORING", None),
                Phase::Starting | Phase::Running => ("RUNNING", None),
                // The stream's own status comes first (`checkout`).
                Phase::Streaming => ("STREAM", None),
                Phase::Waiting => ("WAIT", None),
                Phase::Measuring => ("MEASURE", None),
                Phase::Paused => (
                    "PAUSED",
                    Some(format!(
                        "PAUSED before {}, the tool retracted: F6 goes on, Space ends the job",
                        c.label()
                    )),
                ),
            };
            let next = if c.pause_next { " pause next" } else { "" };
            let left = c
                .time_left(now)
                .map(|l| format!(" left {}{}", clock(l), c.waits_ahead()))
                .unwrap_or_default();
            return Some(JobStatus {
                word,
                progress: format!("{} {elapsed}{left}{next}", c.label()),
                waiting,
            });
        }
        if running_stored {
            let elapsed = self
                .run_started
                .map(|t| clock(now.saturating_duration_since(t)))
                .unwrap_or_default();
            let line = match (&self.run_path, self.run_segment) {
                (Some(path), Some(k)) => path
                    .get(k)
                    .map(|s| format!("line {} ", s.line + 1))
                    .unwrap_or_default(),
                _ => String::new(),
            };
            return Some(JobStatus {
                word: if self.run_paused { "PAUSED" } else { "RUNNING" },
                progress: format!("{line}{elapsed}"),
                waiting: self
                    .run_paused
                    .then(|| "job PAUSED (@A): F6 continues, Space ends it".to_owned()),
            });
        }
        None
    }
}
