//! A stored program running in the controller (`docs/editor.md`, "Upload
//! and run", "What each family can do"): its elapsed time, always; its
//! progress where the controller lets positions be read while it runs
//! (EMCU: polled between the job's lines; isel answers nothing meanwhile,
//! manual 2.2.2); its pause and resume where the manual allows (EMCU `@A`
//! and `@C`, manual 1.5.13, 1.5.14).

use crate::device::api::{Activity, PositionSample, PositionSource, Request};
use crate::program::path::Segment;
use crate::ui::editor::component::Effect;
use crate::ui::traffic_log::NoteLevel;

use super::Step;

/// Segments looked at ahead of the last one matched: a position is taken
/// as progress along the program, never as a jump back to an earlier pass
/// of a loop.
const AHEAD: usize = 64;

impl Step<'_, '_> {
    /// The stored program's run: its start (and the path it follows, when
    /// the editor's text is what was uploaded from here), and its time when
    /// it ends.
    pub(super) fn run_clock(&mut self, activity: Activity) {
        let now = self.ctx.now;
        match (activity, self.e.run_started) {
            (Activity::RunningProgram, None) => {
                self.e.run_started = Some(now);
                self.e.run_paused = false;
                let uploaded = self.e.language().protocol() == self.ctx.setup.protocol
                    && self.e.upload.state == Some(self.e.buffer.state());
                self.e.run_path = self
                    .e
                    .checks
                    .path
                    .as_ref()
                    .filter(|_| uploaded)
                    .map(|p| p.segments.clone());
                self.e.run_segment = None;
                // The text as uploaded from here is what runs: its outputs
                // are the job's. A part of a job in parts is that job's.
                if uploaded && self.e.chunked.is_none() {
                    self.outputs_arm();
                    self.job_log_start(crate::gcode::ways::Way::Stored);
                }
            }
            (Activity::RunningProgram | Activity::Stopping, Some(_)) => {}
            (_, Some(started)) => {
                self.e.run_started = None;
                self.e.run_paused = false;
                self.e.run_path = None;
                self.e.run_segment = None;
                let secs = now.saturating_duration_since(started).as_secs_f64();
                // A part of a job in parts: the job's own progress is said.
                if self.e.chunked.is_none() {
                    // Ended without a stop or an error (those took the
                    // outputs already): as the program left them.
                    self.outputs_ended();
                    self.say(NoteLevel::Info, format!("the program ran {secs:.1} s"));
                }
            }
            (_, None) => {}
        }
    }

    /// A position measured while the stored program runs: the segment of
    /// its path nearest to it, from the last one on.
    pub(super) fn run_progress(&mut self, sample: &PositionSample) {
        if self.e.run_started.is_none() || sample.source != PositionSource::Measured {
            return;
        }
        let Some(segments) = self.e.run_path.as_ref() else {
            return;
        };
        let mut at = [0i64; 4];
        for (axis, v) in sample.steps.iter() {
            if let Some(slot) = at.get_mut(axis.index()) {
                *slot = v;
            }
        }
        let from = self.e.run_segment.unwrap_or(0);
        let best = segments
            .iter()
            .enumerate()
            .skip(from)
            .take(AHEAD)
            .map(|(i, s)| (i, distance(s, at)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i);
        if best.is_some() {
            self.e.run_segment = best;
        }
    }

    /// F6 while the stored program runs: pause or continue it where the
    /// manual allows (`docs/editor.md`, "What each family can do").
    pub(super) fn pause_stored(&mut self) {
        match self.ctx.setup.protocol {
            crate::proto::Protocol::Emcu => {
                // `@A` ramps down and keeps the rest, `@C` goes on (EMCU
                // manual 1.5.13, 1.5.14); both are master commands the
                // interface takes during a job.
                let (line, text) = if self.e.run_paused {
                    ("@C", "the job goes on (@C)".to_string())
                } else {
                    let kept = self.outputs_paused();
                    (
                        "@A",
                        format!("job PAUSED (@A): F6 continues, Space ends it{kept}"),
                    )
                };
                self.e.run_paused = !self.e.run_paused;
                self.out
                    .effects
                    .push(Effect::Device(Request::Raw { line: line.into() }));
                self.say(NoteLevel::Warning, text);
            }
            _ => self.say(
                NoteLevel::Warning,
                "a stored isel program cannot be paused and resumed: the manual describes the \
                 soft stop and @0S for DNC moves only (2.2.31); Space stops it (its rest is \
                 discarded)"
                    .into(),
            ),
        }
    }
}

/// How far `at` lies from the straight line of `s` (an arc by its chord:
/// enough to tell one line from the next).
fn distance(s: &Segment, at: [i64; 4]) -> f64 {
    let d: Vec<f64> = (0..4).map(|i| (s.to[i] - s.from[i]) as f64).collect();
    let p: Vec<f64> = (0..4).map(|i| (at[i] - s.from[i]) as f64).collect();
    let len2: f64 = d.iter().map(|v| v * v).sum();
    let t = if len2 > 0.0 {
        (d.iter().zip(&p).map(|(a, b)| a * b).sum::<f64>() / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    d.iter()
        .zip(&p)
        .map(|(a, b)| (b - a * t).powi(2))
        .sum::<f64>()
        .sqrt()
}
