//! What a client sees of a program upload, the same for every family:
//! `Started`, `Progress` at most every 100 ms (lines per second), then
//! `Finished`, `Failed { line }` or `Aborted { done, reason }`.

use std::time::{Duration, Instant};

use crate::device::api::{ControllerFault, Event, UploadEvent};

use super::op::Abandon;
use super::sink::Sink;

/// Progress events at most this often.
pub const PROGRESS_EVERY: Duration = Duration::from_millis(100);

#[derive(Debug, Clone, PartialEq)]
pub struct UploadProgress {
    /// Lines the client gave.
    pub total: usize,
    /// Client lines the controller has acknowledged.
    pub done: usize,
    started: Option<Instant>,
    last_progress: Option<Instant>,
}

impl UploadProgress {
    pub fn new(total: usize) -> UploadProgress {
        UploadProgress {
            total,
            done: 0,
            started: None,
            last_progress: None,
        }
    }

    /// The first line goes out.
    pub fn start(&mut self, now: Instant, sink: &mut impl Sink) {
        if self.started.is_none() {
            self.started = Some(now);
            sink.emit(Event::Upload(UploadEvent::Started { total: self.total }));
        }
    }

    fn rate(&self, done: usize, now: Instant) -> f64 {
        let secs = self
            .started
            .map_or(0.0, |s| now.saturating_duration_since(s).as_secs_f64());
        if secs > 0.0 { done as f64 / secs } else { 0.0 }
    }

    /// `done` client lines are acknowledged.
    pub fn line_done(&mut self, done: usize, now: Instant, sink: &mut impl Sink) {
        self.done = done.min(self.total);
        if self.last_progress.is_none_or(|t| now >= t + PROGRESS_EVERY) {
            self.last_progress = Some(now);
            sink.emit(Event::Upload(UploadEvent::Progress {
                done: self.done,
                total: self.total,
                lines_per_second: self.rate(self.done, now),
            }));
        }
    }

    /// The program is stored: a last progress event and `Finished`.
    pub fn finished(&mut self, now: Instant, sink: &mut impl Sink) {
        self.done = self.total;
        let elapsed = self
            .started
            .map_or(Duration::ZERO, |s| now.saturating_duration_since(s));
        sink.emit(Event::Upload(UploadEvent::Progress {
            done: self.total,
            total: self.total,
            lines_per_second: self.rate(self.total, now),
        }));
        sink.emit(Event::Upload(UploadEvent::Finished {
            total: self.total,
            elapsed,
        }));
    }

    /// The controller refused client line `line` (0-based).
    pub fn failed(&self, line: usize, fault: ControllerFault, sink: &mut impl Sink) {
        sink.emit(Event::Upload(UploadEvent::Failed { line, fault }));
    }

    /// Stopped by the operator or the controller.
    pub fn aborted(&self, reason: String, sink: &mut impl Sink) {
        self.ended(reason, false, sink);
    }

    /// Abandoned by the driver: the link went or the controller was reset.
    pub fn abandoned(&self, cause: &Abandon, device: &str, sink: &mut impl Sink) {
        let lost = matches!(cause, Abandon::LinkLost(_));
        self.ended(cause.reason(device), lost, sink);
    }

    fn ended(&self, reason: String, link_lost: bool, sink: &mut impl Sink) {
        sink.emit(Event::Upload(UploadEvent::Aborted {
            done: self.done,
            reason,
            link_lost,
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    #[test]
    fn progress_is_rate_limited_and_ends_finished() {
        let t = Instant::now();
        let mut events = VecDeque::new();
        let mut p = UploadProgress::new(10);
        p.start(t, &mut events);
        p.start(t, &mut events);
        for i in 1..=5 {
            p.line_done(i, t + Duration::from_millis(10 * i as u64), &mut events);
        }
        p.line_done(6, t + Duration::from_millis(200), &mut events);
        p.finished(t + Duration::from_secs(1), &mut events);
        let kinds: Vec<String> = events
            .iter()
            .map(|e| match e {
                Event::Upload(UploadEvent::Started { .. }) => "started".into(),
                Event::Upload(UploadEvent::Progress { done, .. }) => format!("p{done}"),
                Event::Upload(UploadEvent::Finished { total, .. }) => format!("f{total}"),
                other => format!("{other:?}"),
            })
            .collect();
        assert_eq!(kinds, ["started", "p1", "p6", "p10", "f10"]);
    }
}
