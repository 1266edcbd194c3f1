//! The run key on a program converted from G-code (issue 27,
//! `docs/editor.md` "G-code"): the ways of running it and their estimates
//! in the question, the one chosen taken (the stream: `update::stream`),
//! and a job bigger than the memory run in parts, each
//! stored (erasing the one before), started and followed to its end in
//! turn. The parts are cut only where the tool stands retracted at the
//! safe height, so a pause between two parts (F6) leaves it above the
//! part; Space stops at once, and nothing resumes after a stop.

use crate::device::api::{
    Activity, Event, LinkState, PositionSource, ReplyKind, Request, UploadEvent,
};
use crate::device::describe::describe;
use crate::gcode::ways::Way;
use crate::ui::editor::component::Effect;
use crate::ui::editor::dialog::Answer;
use crate::ui::editor::job::{Chunked, Phase, is_converted};
use crate::ui::traffic_log::NoteLevel;

use super::Step;

/// Where the axes of the setup stand, machine steps as last read.
pub(super) fn standing(ctx: &crate::ui::editor::component::Context) -> Vec<Option<i64>> {
    ctx.setup
        .axes
        .iter()
        .map(|(axis, _)| ctx.positions.get(*axis).map(|r| r.steps))
        .collect()
}

/// The request the job waits on in its phase, as the device names it.
fn own_request(c: &Chunked) -> Request {
    match (c.phase, c.parts.get(c.part)) {
        (Phase::Uploading, Some(part)) => Request::Upload {
            lines: part.lines.clone(),
            erase_first: true,
        },
        (Phase::Waiting, _) => erase_request(),
        _ => Request::RunProgram,
    }
}

/// isel: the stored piece erased before a wait (`@0k`, manual 2.2.17).
pub(super) fn erase_request() -> Request {
    Request::Raw { line: "@0k".into() }
}

impl Step<'_, '_> {
    /// The converted job's ways, for the question of a job that fits (it
    /// runs as any stored program does); empty for other programs.
    pub(super) fn ways_said(&self) -> String {
        match self.e.gcode.as_ref() {
            Some(g) if g.state == self.e.buffer.state() => {
                let mut text = g.converted.ways.describe().join("\n");
                text.push('\n');
                text
            }
            Some(_) => String::new(),
            None if is_converted(&self.e.buffer.text()) => "Converted from G-code: opened \
                 from the G-code file (--program part.nc) the ways of running it are weighed \
                 here.\n"
                .into(),
            None => String::new(),
        }
    }

    /// F6 on a converted job that does not fit the memory: the ways, the
    /// one chosen, and the question. `false` when the job fits (or the
    /// text is no converted job): the stored program's run goes on.
    pub(super) fn gcode_run(&mut self) -> bool {
        let Some(g) = self.e.gcode.as_ref() else {
            return false;
        };
        let c = &g.converted;
        let program = &c.program;
        if g.state == self.e.buffer.state() && c.waits.is_some() {
            self.pieces_ask();
            return true;
        }
        if program.fits() {
            return false;
        }
        if g.state != self.e.buffer.state() {
            if self.e.buffer.program().command_count() <= program.capacity {
                return false;
            }
            let text = format!(
                "run refused: the text was edited since it was converted from {}, and its parts \
                 are cut from the converted program: open the G-code again, or run it with \
                 `jogterm run {} --chunked`",
                c.source, c.source
            );
            self.say(NoteLevel::Warning, text);
            return true;
        }
        let mut text = format!(
            "{}: {} commands, the controller stores {}.\n",
            c.header, program.commands, program.capacity
        );
        text.push_str(&c.ways.describe().join("\n"));
        text.push('\n');
        let parts = c.ways.chunked.as_ref().ok().map(|e| e.parts);
        let yes = match (c.ways.chosen, parts) {
            (Way::Chunked, Some(n)) => {
                text.push_str(&format!(
                    "Store and run it in {n} parts, each erasing the one before (@0k)? The \
                     machine moves; F6 pauses before the next part, Space stops."
                ));
                Answer::RunInParts
            }
            _ => {
                text.push_str(
                    "Stream it, each command sent when the one before has ended? The machine \
                     moves; F10 pauses and goes on, x ends the stream, Space stops.",
                );
                Answer::Stream
            }
        };
        let title = format!("Run {}", c.header);
        self.ask(&title, text, yes, Answer::Nothing);
        true
    }

    /// Yes to the run in parts: checked as an upload is, then part 1.
    pub(super) fn chunked_begin(&mut self) {
        let language = self.e.language();
        if let Some(why) = self.job_refused() {
            self.say(NoteLevel::Danger, format!("run refused: {why}"));
            return;
        }
        let Some(g) = self.e.gcode.as_ref() else {
            return;
        };
        // The model knows the parts of the text as converted only.
        let model_s = &g.converted.ways.part_s;
        let eta = (g.state == self.e.buffer.state())
            .then(|| crate::gcode::eta::PartsEta::new(model_s.clone()));
        match g.converted.part_uploads(language) {
            Ok(parts) => {
                let eta = eta.filter(|_| parts.len() == model_s.len());
                self.chunked_start(parts, None, Way::Chunked);
                if let Some(c) = self.e.chunked.as_mut() {
                    c.eta = eta;
                }
                self.chunked_upload();
            }
            Err(why) => self.say(NoteLevel::Danger, format!("run refused: {why}")),
        }
    }

    /// A job in parts (or in pieces) begins: the outputs armed, the job
    /// log's record opened as `way`; the caller stores its first part (or
    /// streams its first piece).
    pub(super) fn chunked_start(
        &mut self,
        parts: Vec<crate::ui::editor::job::PartUpload>,
        pieces: Option<Box<crate::ui::editor::job::Pieces>>,
        way: Way,
    ) {
        self.e.chunked = Some(Chunked {
            parts,
            part: 0,
            phase: Phase::Uploading,
            pause_next: false,
            started: self.ctx.now,
            paused_at: Vec::new(),
            paused_read: false,
            pieces,
            part_began: self.ctx.now,
            eta: None,
        });
        self.outputs_arm();
        self.job_log_start(way);
    }

    /// Why a job may not start from the editor now, if it may not.
    pub(super) fn job_refused(&mut self) -> Option<String> {
        let ctx = self.ctx;
        let language = self.e.language();
        if let Some(why) = language.wrong_machine(ctx.setup.protocol) {
            Some(why.to_string())
        } else if self.e.upload.busy() || self.e.chunked.is_some() {
            Some("an upload or a job is running already".into())
        } else if self.e.checkout.is_some() {
            Some("a check-out or a stream is open: x leaves it".into())
        } else if !ctx.machine.link_up {
            Some("the controller is not connected".into())
        } else if ctx.machine.activity != Activity::Idle {
            Some("the machine must stand still".into())
        } else {
            self.first_error()
        }
    }

    /// The part under way stored, erasing the one before: `@0i` finds it
    /// and the driver erases it first (`@0k`, isel manual 2.2.17).
    pub(super) fn chunked_upload(&mut self) {
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        c.phase = Phase::Uploading;
        c.part_began = self.ctx.now;
        let label = c.label();
        let Some(part) = c.parts.get(c.part).cloned() else {
            return;
        };
        let language = self.e.language();
        self.e
            .upload
            .start(language, part.lines_of, self.e.buffer.state());
        // The controller holds a part, not the text: the stored run's
        // progress and the run question must not take it for the text.
        self.e.upload.state = None;
        self.say(
            NoteLevel::Info,
            format!("{label}: storing {} commands", part.lines.len()),
        );
        self.out.effects.push(Effect::Device(Request::Upload {
            lines: part.lines,
            erase_first: true,
        }));
    }

    /// F6 while the job runs in parts: pause before the next part, or go
    /// on (from a pause, or taking back the pause asked for).
    pub(super) fn chunked_key(&mut self) {
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        if c.phase == Phase::Waiting {
            self.wait_key();
            return;
        }
        if c.phase == Phase::Streaming {
            let text = format!(
                "{} streams: F10 pauses and goes on, x ends the job, Space stops",
                c.label()
            );
            self.say(NoteLevel::Info, text);
            return;
        }
        if c.phase == Phase::Measuring {
            self.say(
                NoteLevel::Info,
                "the new tool is being measured; the job goes on by itself (Space ends it)".into(),
            );
            return;
        }
        if c.phase == Phase::Paused {
            if !c.paused_read {
                let text = format!(
                    "the position after {} is being read: F6 again in a moment",
                    c.label()
                );
                self.say(NoteLevel::Info, text);
                return;
            }
            if c.paused_at != standing(self.ctx) {
                let text = format!(
                    "the axes moved since the pause: {} begins with a straight move from where \
                     the tool stands; put them back where the job paused, or Space ends the job",
                    c.label()
                );
                self.say(NoteLevel::Danger, text);
                return;
            }
            let text = format!("the job goes on with {}", c.label());
            self.say(NoteLevel::Info, text);
            self.chunked_upload();
            return;
        }
        if c.part + 1 == c.parts.len()
            && let Some(p) = c.pieces.as_ref()
            && p.piece < p.sequence.plan().waits.len()
        {
            let text = format!(
                "the job waits after {} anyway (line {}: F6 there goes on; Space stops)",
                p.label(),
                p.sequence
                    .plan()
                    .waits
                    .get(p.piece)
                    .map_or(0, |w| w.origin.line)
            );
            self.say(NoteLevel::Info, text);
            return;
        }
        if c.part + 1 == c.parts.len() {
            self.say(
                NoteLevel::Info,
                "this is the last part: there is no part to pause before (Space stops)".into(),
            );
            return;
        }
        c.pause_next = !c.pause_next;
        let text = if c.pause_next {
            format!(
                "the job pauses before part {}/{}, once this part has ended with the tool \
                 retracted (F6 again: no pause)",
                c.part + 2,
                c.parts.len()
            )
        } else {
            "no pause: the job goes on with the next part".into()
        };
        self.say(NoteLevel::Warning, text);
    }

    /// A device event while the job runs in parts: a part stored is
    /// started, a part ended is followed by the next (or the pause), and
    /// anything that went wrong ends the job.
    pub(super) fn chunked_event(&mut self, event: &Event) {
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        if c.phase == Phase::Measuring && !matches!(event, Event::Link(_)) {
            self.measure_event(event);
            return;
        }
        let label = c.label();
        match (event, c.phase) {
            (Event::Upload(UploadEvent::Finished { .. }), Phase::Uploading) => {
                c.phase = Phase::Starting;
                self.out.effects.push(Effect::Device(Request::RunProgram));
            }
            (Event::Upload(UploadEvent::Failed { .. } | UploadEvent::Aborted { .. }), _) => {
                self.job_log_end(crate::joblog::How::Error);
                self.chunked_end(format!("{label} was not stored: the job ends here"));
            }
            (Event::State(s), Phase::Starting) if s.activity == Activity::RunningProgram => {
                c.phase = Phase::Running;
            }
            (Event::State(s), Phase::Running)
                if !matches!(s.activity, Activity::RunningProgram | Activity::Stopping) =>
            {
                self.part_ended();
            }
            // Only the refusal of the job's own request: a key refused
            // meanwhile (a jog while the part runs) changes nothing.
            (Event::Refused { request, reason }, Phase::Starting | Phase::Uploading)
                if *request == describe(&own_request(c)) =>
            {
                self.job_log_end(crate::joblog::How::Error);
                self.chunked_end(format!("{label} did not start: {reason}"));
            }
            (Event::Refused { request, reason }, Phase::Waiting)
                if c.pieces
                    .as_ref()
                    .is_some_and(|p| p.wait.as_ref().is_some_and(|w| w.erasing))
                    && *request == describe(&erase_request()) =>
            {
                self.job_log_end(crate::joblog::How::Error);
                self.chunked_end(format!(
                    "the piece that ran was not erased before the wait ({reason}): the job ends \
                     here; the controller's start key would run it again"
                ));
            }
            (
                Event::Reply {
                    kind: ReplyKind::Answer,
                    command,
                    ..
                },
                Phase::Waiting,
            ) if command.trim() == "@0k" => {
                self.wait_erased();
            }
            (Event::Fault(f), Phase::Starting | Phase::Running | Phase::Waiting) => {
                let text = format!("{label} ended with `{}`: {}", f.code, f.meaning);
                self.job_log_end(crate::joblog::How::Error);
                self.chunked_end(text);
            }
            (Event::Position(p), Phase::Paused | Phase::Waiting)
                if !c.paused_read && p.source == PositionSource::Measured =>
            {
                c.paused_at = self
                    .ctx
                    .setup
                    .axes
                    .iter()
                    .map(|(axis, _)| p.steps.get(*axis))
                    .collect();
                c.paused_read = true;
            }
            (Event::Io(io), Phase::Waiting) => {
                if let Some(pressed) = io.start_key()
                    && let Some(at) = c.pieces.as_mut().and_then(|p| p.wait.as_mut())
                {
                    if !pressed {
                        at.start_released = true;
                    } else if at.start_released {
                        at.start_released = false;
                        self.say(NoteLevel::Info, "the start key was pressed".into());
                        self.wait_key();
                    }
                }
            }
            (Event::Link(LinkState::Lost { .. } | LinkState::Closed), _) => {
                self.chunked_end(format!("the link went in {label}: nothing resumes"));
            }
            _ => {}
        }
    }

    fn part_ended(&mut self) {
        let now = self.ctx.now;
        // A job with waits logs each part's last G-code line as run, as
        // `jogterm run` does: a stop at a wait can be resumed after it.
        let last = self
            .e
            .chunked
            .as_ref()
            .filter(|c| c.pieces.is_some())
            .and_then(|c| {
                let program = &self.e.gcode.as_ref()?.converted.program;
                c.parts
                    .get(c.part)?
                    .lines_of
                    .iter()
                    .filter_map(|&l| program.lines.get(l)?.origin.map(|o| o.line))
                    .max()
            });
        if let Some(line) = last {
            self.job_log_done(line);
        }
        let Some(c) = self.e.chunked.as_mut() else {
            return;
        };
        if c.part + 1 >= c.parts.len() && c.pieces.is_some() {
            self.piece_ended();
            return;
        }
        if c.part + 1 >= c.parts.len() {
            let secs = now.saturating_duration_since(c.started).as_secs_f64();
            let text = format!("the job ended: {} parts in {secs:.1} s", c.parts.len());
            self.e.chunked = None;
            self.outputs_ended();
            self.say(NoteLevel::Info, text);
            return;
        }
        let took = now.saturating_duration_since(c.part_began).as_secs_f64();
        if let Some(eta) = c.eta.as_mut() {
            eta.part_done(c.part, took);
        }
        c.part += 1;
        if std::mem::take(&mut c.pause_next) {
            c.phase = Phase::Paused;
            c.paused_at = standing(self.ctx);
            c.paused_read = false;
            let label = c.label();
            let text = format!(
                "PAUSED before {label}, the tool retracted: F6 goes on, Space ends the job{}",
                self.outputs_paused()
            );
            self.say(NoteLevel::Warning, text);
        } else {
            self.chunked_upload();
        }
    }

    pub(super) fn chunked_end(&mut self, why: String) {
        if self.e.chunked.take().is_some() {
            self.say(NoteLevel::Danger, why);
            self.outputs_early();
        }
    }

    /// The stop key (Space, Esc) or any other stop: a job in parts ends;
    /// no later part is stored or started.
    pub(super) fn stopped(&mut self) {
        if let Some(c) = self.e.chunked.as_ref() {
            // A stop while the piece before a wait is erased may leave it
            // stored, and the iMC's start key would run it.
            let erasing = c
                .pieces
                .as_ref()
                .and_then(|p| p.wait.as_ref())
                .is_some_and(|w| w.erasing);
            let text = format!(
                "the job stopped in {}; nothing resumes (F6 asks to run it again from its start){}",
                c.label(),
                if erasing {
                    "; the erase of the piece that ran was cut short: it may still be stored, and the \
                     controller's start key would run it"
                } else {
                    ""
                }
            );
            self.chunked_end(text);
        }
        // Any job of the editor (a stored run, a check-out, a stream).
        self.outputs_early();
    }
}
