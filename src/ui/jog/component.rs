//! The jog screen as a component (`docs/architecture.md`, "The jog screen
//! component"), as the editor is one: its state is the [`Keypad`] (the
//! jogging, homing progress, the jog off a limit switch, the step and
//! speed selected and typed, the work offsets), and everything else
//! crosses one boundary. [`Keypad::update`] takes a read-only [`Context`]
//! (the setup, the link, the machine, the positions, the time) and an
//! [`Input`], changes nothing but the keypad, and returns an [`Outcome`]:
//! effects for the device, notes for the message line, a popup of the
//! keypad's to show. `ui::update` builds the context (`Model::jog_parts`)
//! and applies the outcome in one place (`apply_jog`).

use crate::axis::AxisSet;
use crate::device::api::Event;
use crate::jog::{KeyPhase, Motion};
use crate::offsets::System;

use super::super::key::KeyChord;
use super::super::keymap::Action;
use super::super::line_edit::{LineEdit, LineError, edit_line};
use super::super::msg::Effect;
use super::super::outcome;
use super::super::traffic_log::NoteLevel;
use super::context::{Context, Note};
use super::offsets::{self, OffsetsChoice};
use super::popups::JogPopup;
use super::values::{self, ValuesForm};
use super::{Keypad, gate, goto, limit};

/// What reaches the jog screen.
#[derive(Debug, Clone, PartialEq)]
pub enum Input<'a> {
    /// A motion key of the focused keypad (a jog action), with its phase.
    Motion {
        action: Action,
        chord: KeyChord,
        phase: KeyPhase,
    },
    /// A key was let go (kitty keyboard protocol).
    Release(KeyChord),
    /// A motion key of the focused keypad that came in a burst: never
    /// motion. `Outcome::used` says whether it did something.
    Burst(KeyChord, KeyPhase),
    /// Any other key before it is routed: in toggle mode it stops the jog
    /// and is used up (`Outcome::used`).
    AnyKey(KeyChord, KeyPhase),
    /// A main-screen action the keypad owns (work offsets, set position,
    /// step and speed, the override); `Outcome::used` is false for others.
    Main(Action),
    /// The axes chosen in the `Z` popup: their work zero here.
    ZeroAxes(AxisSet),
    /// A key action while a keypad popup is open; the caller took it out
    /// of the popup slot, the outcome gives it back if it stays open.
    Popup(Box<JogPopup>, Action),
    /// `c`: step or continuous jogging.
    SwitchKind,
    /// The operator stopped everything.
    Stopped,
    /// Time passes: toggle jogs are renewed, let-go keys cleared.
    Tick,
    /// A device event (before the model takes it). `Outcome::quiet` marks a
    /// refusal the keypad accounts for itself.
    Device(&'a Event),
}

/// What the rest of the console is to do after an input.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Outcome {
    /// Effects for the device task and notes for the message line, in
    /// order; a popup of the keypad's to show (in place of any other).
    pub shown: outcome::Outcome<JogPopup>,
    /// The input was the keypad's (see [`Input`]).
    pub used: bool,
    /// A device event the message line should not repeat.
    pub quiet: bool,
}

impl Outcome {
    pub fn said(effects: Vec<Effect>, notes: Vec<Note>) -> Outcome {
        let mut shown = outcome::Outcome::effects(effects);
        shown.notes = notes;
        Outcome::used(shown)
    }

    fn used(shown: outcome::Outcome<JogPopup>) -> Outcome {
        let mut out = Outcome::default();
        (out.shown, out.used) = (shown, true);
        out
    }
}

impl Keypad {
    /// `L`: the question before the jog off a limit switch, or why not.
    pub fn limit_question(&mut self, ctx: &Context) -> Result<limit::Question, String> {
        let g = gate(self, ctx);
        let settings = self.jogger.settings().clone();
        limit::ask(&mut self.limit, &settings, &g, ctx.setup)
    }

    /// The jog screen's one entry: `input` in the context `ctx`.
    pub fn update(&mut self, ctx: &Context, input: Input) -> Outcome {
        match input {
            Input::Motion {
                action,
                chord,
                phase,
            } => {
                let (effects, note) = self.motion_key(ctx, action, chord, phase);
                Outcome::said(effects, note.into_iter().collect())
            }
            Input::Release(chord) => Outcome::said(self.released(ctx, chord), Vec::new()),
            Input::Burst(chord, phase) => match self.burst_key(ctx.now, chord, phase) {
                Some(effects) => Outcome::said(effects, Vec::new()),
                None => Outcome::default(),
            },
            Input::AnyKey(chord, phase) => match self.any_key(ctx.now, chord, phase) {
                Some(effects) => Outcome::said(effects, Vec::new()),
                None => Outcome::default(),
            },
            Input::Main(action) => main_action(self, ctx, action).unwrap_or_default(),
            Input::ZeroAxes(axes) => zero_axes(self, ctx, axes),
            Input::Popup(popup, action) => popup_action(self, ctx, *popup, action),
            Input::SwitchKind => {
                let (effects, note) = self.switch_kind(ctx.now);
                Outcome::said(effects, vec![note])
            }
            Input::Stopped => {
                self.stopped(ctx.now);
                Outcome::default()
            }
            Input::Tick => Outcome::said(
                self.jogger
                    .tick(ctx.now)
                    .into_iter()
                    .map(Effect::Request)
                    .collect(),
                Vec::new(),
            ),
            Input::Device(event) => Outcome {
                quiet: !self.device_event(ctx.now, event),
                ..Outcome::default()
            },
        }
    }
}

// ----- the keypad's popups and main keys (`popups::JogPopup`) ----------------

fn note(level: NoteLevel, text: String) -> Outcome {
    Outcome::used(outcome::Outcome::note(level, text))
}

fn open(popup: JogPopup) -> Outcome {
    Outcome::used(outcome::Outcome::popup(popup))
}

/// A main key of the keypad's (`None`: not one of these).
fn main_action(kp: &mut Keypad, ctx: &Context, action: Action) -> Option<Outcome> {
    let out = match action {
        Action::WorkOffsets => open(JogPopup::Offsets(OffsetsChoice::new(&kp.offsets))),
        Action::SetPosition => {
            if let Err(reason) = gate(kp, ctx).check(Motion::SetZero) {
                return Some(note(
                    NoteLevel::Danger,
                    format!("set position refused: {reason}"),
                ));
            }
            open(JogPopup::SetPosition(LineEdit::default()))
        }
        Action::JogValues => open(JogPopup::Values(ValuesForm::default())),
        Action::SetZero => zero_axes(kp, ctx, ctx.setup.axis_set()),
        Action::OverrideSlower | Action::OverrideFaster => {
            let base = kp.base_speed(ctx.setup).unwrap_or(0.0);
            let settings = kp.settings().clone();
            let up = action == Action::OverrideFaster;
            match kp.values.change_override(up, base, &settings) {
                Ok(text) => note(NoteLevel::Info, text),
                Err(text) => note(NoteLevel::Warning, text),
            }
        }
        Action::OverrideReset => {
            kp.values.override_pct = 100;
            note(NoteLevel::Info, "jog speed override 100 %".into())
        }
        Action::StepSmaller | Action::StepLarger => {
            let typed = kp.values.step.take();
            let up = action == Action::StepLarger;
            kp.selection.step =
                values::next_preset(&ctx.setup.jog_steps, kp.selection.step, typed, up);
            Outcome::said(Vec::new(), Vec::new())
        }
        Action::SpeedSlower | Action::SpeedFaster => {
            let typed = kp.values.speed.take();
            let up = action == Action::SpeedFaster;
            kp.selection.speed =
                values::next_preset(&ctx.setup.jog_speeds, kp.selection.speed, typed, up);
            Outcome::said(Vec::new(), Vec::new())
        }
        _ => return None,
    };
    Some(out)
}

/// The axes chosen in the `Z` popup: their work zero here.
fn zero_axes(kp: &mut Keypad, ctx: &Context, axes: AxisSet) -> Outcome {
    let g = gate(kp, ctx);
    let (effects, n) = offsets::zero_here(&mut kp.offsets, &g, ctx, axes);
    Outcome::said(effects, vec![n])
}

/// A key of an open keypad popup (taken out of the model's popup slot;
/// given back in the outcome unless the key closes it).
fn popup_action(kp: &mut Keypad, ctx: &Context, mut popup: JogPopup, action: Action) -> Outcome {
    if action == Action::Cancel {
        let what = match popup {
            JogPopup::Offsets(_) => "work offsets",
            JogPopup::SetPosition(_) => "set position",
            JogPopup::Values(_) => "jog step and speed",
        };
        return note(NoteLevel::Info, format!("{what}: cancelled"));
    }
    let out = match (&mut popup, action) {
        (JogPopup::Offsets(choice), Action::SelectPrev) => {
            choice.step(-1);
            None
        }
        (JogPopup::Offsets(choice), Action::SelectNext) => {
            choice.step(1);
            None
        }
        (JogPopup::Offsets(choice), Action::Activate) => {
            let (effects, n) = offsets::activate(&mut kp.offsets, ctx, choice.selected);
            Some(Outcome::said(effects, vec![n]))
        }
        (JogPopup::Offsets(_), a) => system_of(a).map(|system| {
            let (effects, n) = offsets::activate(&mut kp.offsets, ctx, system);
            Outcome::said(effects, vec![n])
        }),
        (JogPopup::SetPosition(line), Action::Submit) => submit_position(kp, ctx, line),
        (JogPopup::Values(form), Action::Submit) => submit_values(kp, form),
        (JogPopup::Values(form), Action::NextField | Action::PrevField) => {
            form.other_field();
            None
        }
        (p, a) => {
            if let Some(line) = p.line() {
                edit_line(line, a);
            }
            None
        }
    };
    out.unwrap_or_else(|| open(popup))
}

/// The system a digit key of the `O` popup names.
fn system_of(action: Action) -> Option<System> {
    let index = match action {
        Action::G54 => 0,
        Action::G55 => 1,
        Action::G56 => 2,
        Action::G57 => 3,
        Action::G58 => 4,
        Action::G59 => 5,
        _ => return None,
    };
    System::from_index(index)
}

/// Enter in the set-position prompt: `None` keeps it open (with the
/// reason on its line).
fn submit_position(kp: &mut Keypad, ctx: &Context, line: &mut LineEdit) -> Option<Outcome> {
    let settings = kp.settings();
    let checked = goto::parse(line.text(), settings)
        .map_err(|e| e.to_string())
        .and_then(|t| {
            if t.feed.is_some() || t.machine {
                Err(
                    "F and G53 mean nothing here: type axes and their values, such as X10 Y0"
                        .to_string(),
                )
            } else {
                Ok(t)
            }
        })
        .and_then(|t| {
            let g = gate(kp, ctx);
            offsets::set_here(&mut kp.offsets, &g, ctx, &t)
        });
    match checked {
        Ok((effects, n)) => Some(Outcome::said(effects, vec![n])),
        Err(message) => {
            line.error = Some(LineError {
                message,
                span: None,
            });
            None
        }
    }
}

/// Enter in the step-and-speed popup.
fn submit_values(kp: &mut Keypad, form: &mut ValuesForm) -> Option<Outcome> {
    let settings = kp.settings().clone();
    let values::Typed { step, speed } = form.check(&settings)?;
    let mut notes = Vec::new();
    let mut said = Vec::new();
    if let Some((step, inexact)) = step {
        kp.values.step = Some(step);
        said.push(format!(
            "step {}",
            super::super::position::format_amount(step)
        ));
        if let Some(n) = inexact {
            notes.push((NoteLevel::Warning, n));
        }
    }
    if let Some(speed) = speed {
        kp.values.speed = Some(speed);
        said.push(format!(
            "speed {} per second",
            super::super::position::format_amount(speed)
        ));
    }
    if said.is_empty() {
        said.push("unchanged".into());
    }
    notes.insert(
        0,
        (
            NoteLevel::Info,
            format!(
                "jog {} (typed; the step and speed keys go back to the presets)",
                said.join(", ")
            ),
        ),
    );
    Some(Outcome::said(Vec::new(), notes))
}
