//! The editor's job and its outputs (issue 37, `docs/editor.md` "The
//! job's outputs"): a job run from here (a stored program uploaded from the
//! text, a job in parts, a check-out or a stream) that ends by a stop, a
//! controller error or a lost line has its spindle and the outputs it
//! switched on switched off once the axes stand, and says so; a pause keeps
//! them and says so. Which outputs, which are left on and the words are the
//! CLI's (`program::outputs`); here they go out as requests from the tick.

use crate::device::api::{Activity, Event, LinkState, Request};
use crate::device::describe::describe;
use crate::program::outputs::{
    STAND_WITHIN, left_on_text, link_lost_text, not_standing_text, paused_text, still_on_text,
    switched_on,
};
use crate::ui::editor::component::Effect;
use crate::ui::traffic_log::NoteLevel;

use super::Step;

/// How the console's operator switches an output off that is left on.
const SWITCH_IT_OFF: &str = "switch it off at the machine or with the named outputs (x)";

impl Step<'_, '_> {
    /// A job of the editor starts: the outputs its text switches on are
    /// the job's, whatever it has reached when it ends.
    pub(super) fn outputs_arm(&mut self) {
        self.e.outputs.armed = switched_on(self.e.buffer.program());
        self.e.outputs.sent.clear();
    }

    /// The job ran to its end: its outputs are as the program left them.
    pub(super) fn outputs_ended(&mut self) {
        self.e.outputs.armed.clear();
        self.job_log_end(crate::joblog::How::Done);
    }

    /// The job ended before its end (a stop, a controller error, a part
    /// not stored): its outputs are switched off once the axes stand.
    pub(super) fn outputs_early(&mut self) {
        // A fault or a lost line said so before (the first end counts).
        self.job_log_end(crate::joblog::How::Stopped);
        let armed = std::mem::take(&mut self.e.outputs.armed);
        if !armed.is_empty() {
            self.e.outputs.pending = Some((armed, self.ctx.now));
        }
    }

    /// What a pause of the job says about its outputs: appended to the
    /// pause's own words.
    pub(super) fn outputs_paused(&self) -> String {
        paused_text(&self.e.outputs.armed).map_or_else(String::new, |t| format!("; {t}"))
    }

    /// A device event, before the job's own handling: a lost link can send
    /// nothing and says the outputs may still be on; a controller error
    /// during a stored program's run ends it early; a refused switch-off
    /// says so.
    pub(super) fn outputs_event(&mut self, event: &Event) {
        match event {
            Event::Link(LinkState::Lost { .. } | LinkState::Closed) => {
                self.job_log_end(crate::joblog::How::Lost);
                let mut outputs = std::mem::take(&mut self.e.outputs.armed);
                if let Some((pending, _)) = self.e.outputs.pending.take() {
                    outputs.extend(pending);
                }
                self.e.outputs.sent.clear();
                if !outputs.is_empty() {
                    self.say(NoteLevel::Danger, link_lost_text(&outputs));
                }
            }
            // The parts, check-outs and streams end early by their own
            // events (`job`, `checkout`); a stored program only so.
            Event::Fault(_) if self.e.run_started.is_some() && self.e.chunked.is_none() => {
                self.job_log_end(crate::joblog::How::Error);
                self.outputs_early();
            }
            Event::Refused { request, reason } => {
                if let Some(k) = self.e.outputs.sent.iter().position(|(r, _)| r == request) {
                    let (_, output) = self.e.outputs.sent.remove(k);
                    let text = still_on_text(&output, &format!("refused: {reason}"));
                    self.say(NoteLevel::Danger, text);
                }
            }
            _ => {}
        }
    }

    /// The tick: the switch-offs go once the machine stands.
    pub(super) fn outputs_tick(&mut self) {
        let machine = self.ctx.machine;
        self.outputs_off(machine.activity, machine.link_up);
    }

    /// Once the machine stands (`activity`), the waiting outputs are
    /// switched off, those [`JobOutput::left`] keeps are said; after
    /// [`STAND_WITHIN`] without standing they are left and that is said.
    pub(super) fn outputs_off(&mut self, activity: Activity, link_up: bool) {
        let Some((outputs, since)) = self.e.outputs.pending.as_ref() else {
            return;
        };
        if !(link_up && activity == Activity::Idle) {
            if self.ctx.now.saturating_duration_since(*since) > STAND_WITHIN {
                let text = not_standing_text(outputs);
                self.e.outputs.pending = None;
                self.say(NoteLevel::Danger, text);
            }
            return;
        }
        let Some((outputs, _)) = self.e.outputs.pending.take() else {
            return;
        };
        let mut off = Vec::new();
        for o in outputs {
            if let Some(why) = &o.left {
                self.say(NoteLevel::Warning, left_on_text(&o, why, SWITCH_IT_OFF));
                continue;
            }
            let request = Request::SetOutput {
                output: o.id,
                value: 0,
            };
            self.e.outputs.sent.push((describe(&request), o.clone()));
            self.out.effects.push(Effect::Device(request));
            off.push(o);
        }
        if !off.is_empty() {
            // The switch-offs are on their way behind the stop; a refusal
            // of one is said when it comes (`outputs_event`).
            let text = format!(
                "the job ended early: {}",
                crate::program::outputs::switched_off_text(&off)
            );
            self.say(NoteLevel::Warning, text);
        }
    }
}
