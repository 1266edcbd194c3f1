//! A job converted from G-code streamed from the editor (issue 27,
//! `docs/editor.md` "G-code"): the check-out's lines (`update::checkout`:
//! the DNC form, `Request::Checkout`, the pause without step loss and its
//! resume) with no key held. Each line is held by a lease the tick renews,
//! so a console that stalls lets it run out and the driver pauses the
//! machine; F10 pauses and goes on, x ends the stream, Space stops.

use crate::device::api::Request;
use crate::jog::KeyPhase;
use crate::ui::editor::checkout::{Checkout, RunState, STREAM_LEASE, Stream};
use crate::ui::editor::component::Effect;
use crate::ui::keymap::Action;
use crate::ui::traffic_log::NoteLevel;

use super::Step;

impl Step<'_, '_> {
    /// Yes to the stream: the check-out's plan, sent at once.
    pub(super) fn stream_begin(&mut self) {
        let ctx = self.ctx;
        let (origins, eta): (Vec<Option<u32>>, _) = match self.e.gcode.as_ref() {
            Some(g) if g.state == self.e.buffer.state() => {
                let lines = &g.converted.program.lines;
                (
                    lines.iter().map(|l| l.origin.map(|o| o.line)).collect(),
                    crate::gcode::eta::Eta::new(
                        std::sync::Arc::new(g.converted.ways.clone()),
                        lines.len(),
                    ),
                )
            }
            _ => return,
        };
        match self.checkout_prepare(None, true) {
            Ok(p) => {
                let mut c = Checkout::new(p.plan, p.preamble, ctx.now);
                c.stream = Some(Stream::new(origins, Some(eta), ctx.now));
                self.e.checkout = Some(c);
                self.outputs_arm();
                self.job_log_start(crate::gcode::ways::Way::Stream);
                self.say(
                    NoteLevel::Info,
                    "streaming: F10 pauses and goes on, x ends the stream, Space stops".into(),
                );
                self.checkout_next();
            }
            Err(why) => self.say(NoteLevel::Danger, format!("stream refused: {why}")),
        }
    }

    /// The running line's lease renewed from the tick, a third of it
    /// before it would run out.
    pub(super) fn stream_renew(&mut self) {
        let now = self.ctx.now;
        let Some(c) = self.e.checkout.as_mut() else {
            return;
        };
        let (Some(s), Some(id), RunState::Running) = (c.stream.as_mut(), c.line_id, &c.state)
        else {
            return;
        };
        if now.saturating_duration_since(s.renewed) >= STREAM_LEASE / 3 {
            s.renewed = now;
            self.out.effects.push(Effect::Device(Request::JogRenew {
                id,
                lease: STREAM_LEASE,
            }));
        }
    }

    /// F10 (a press, not its repeats) pauses the stream or takes it on;
    /// single step is the check-out's alone.
    pub(super) fn stream_key(&mut self, action: Action, phase: KeyPhase) {
        let now = self.ctx.now;
        let grace = self.ctx.setup.jog.grace;
        let Some(c) = self.e.checkout.as_mut() else {
            return;
        };
        if action == Action::CheckoutSingle {
            self.say(
                NoteLevel::Info,
                "a stream has no single step: F10 pauses it".into(),
            );
            return;
        }
        if phase == KeyPhase::Release {
            c.last_key = None;
            return;
        }
        // A held key repeats: only a new press counts.
        let repeat = c
            .last_key
            .is_some_and(|t| now.saturating_duration_since(t) <= grace);
        c.last_key = Some(now);
        let Some(s) = c.stream.as_mut() else {
            return;
        };
        if repeat {
            return;
        }
        match (&c.state, c.line_id) {
            (RunState::Running, Some(id)) if !s.paused => {
                s.set_paused(true, now);
                self.out
                    .effects
                    .push(Effect::Device(Request::JogRelease { id }));
                self.say(
                    NoteLevel::Warning,
                    "pausing: the move ramps down without losing steps".into(),
                );
            }
            (RunState::Paused { .. } | RunState::Ready, _) => {
                s.set_paused(false, now);
                self.say(NoteLevel::Info, "the stream goes on".into());
                self.checkout_next();
            }
            (RunState::Dwelling { .. }, _) => {
                s.set_paused(!s.paused, now);
                let text = if s.paused {
                    "the stream pauses in the dwell"
                } else {
                    "the stream goes on"
                };
                self.say(NoteLevel::Info, text.into());
            }
            (RunState::Stopped { why }, _) => {
                let text = format!("the stream stopped ({why}): x leaves it; nothing resumes");
                self.say(NoteLevel::Warning, text);
            }
            (RunState::Finished, _) => {
                self.say(NoteLevel::Info, "the stream has ended: x leaves it".into())
            }
            _ => {}
        }
    }
}
