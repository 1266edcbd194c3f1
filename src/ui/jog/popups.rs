//! The keypad's main keys for work offsets, typed step and speed and the
//! speed override, and the popups they open ([`JogPopup`]): the choice of
//! G54-G59 (`O`), the work position set here (`s`), the typed step and
//! speed (`J`). Each returns effects and notes; `update` says the notes
//! and carries the effects out.

use crate::axis::AxisSet;
use crate::jog::Motion;

use super::super::keymap::{Action, Mode};
use super::super::line_edit::{LineEdit, LineError, edit_line};
use super::super::model::{Model, Popup};
use super::super::msg::Effect;
use super::super::traffic_log::NoteLevel;
use super::offsets::{self, OffsetsChoice};
use super::values::{self, ValuesForm};
use super::{Note, goto};
use crate::offsets::System;

/// A popup of the keypad's.
#[derive(Debug, Clone, PartialEq)]
pub enum JogPopup {
    /// `O`: which work offset is active.
    Offsets(OffsetsChoice),
    /// `s`: the work position here, typed (`X10 Y0`).
    SetPosition(LineEdit),
    /// `J`: the jog step and speed, typed.
    Values(ValuesForm),
}

impl JogPopup {
    pub fn mode(&self) -> Mode {
        match self {
            JogPopup::Offsets(_) => Mode::Offsets,
            JogPopup::SetPosition(_) | JogPopup::Values(_) => Mode::Entry,
        }
    }

    /// The line that has the input, if the popup types.
    fn line(&mut self) -> Option<&mut LineEdit> {
        match self {
            JogPopup::Offsets(_) => None,
            JogPopup::SetPosition(line) => Some(line),
            JogPopup::Values(form) => Some(form.line()),
        }
    }

    /// Whether the popup takes typed text (`typing::text_field`).
    pub fn types(&self) -> bool {
        !matches!(self, JogPopup::Offsets(_))
    }
}

/// What a key did: effects to carry out, notes to say.
pub type Outcome = (Vec<Effect>, Vec<Note>);

fn note(level: NoteLevel, text: String) -> Outcome {
    (Vec::new(), vec![(level, text)])
}

/// A main key of the keypad's (`None`: not one of these).
pub fn main_action(model: &mut Model, action: Action) -> Option<Outcome> {
    let out = match action {
        Action::WorkOffsets => {
            let choice = OffsetsChoice::new(model);
            model.popup = Some(Popup::Jog(JogPopup::Offsets(choice)));
            (Vec::new(), Vec::new())
        }
        Action::SetPosition => {
            if let Err(reason) = super::gate(model).check(Motion::SetZero) {
                return Some(note(
                    NoteLevel::Danger,
                    format!("set position refused: {reason}"),
                ));
            }
            model.popup = Some(Popup::Jog(JogPopup::SetPosition(LineEdit::default())));
            (Vec::new(), Vec::new())
        }
        Action::JogValues => {
            model.popup = Some(Popup::Jog(JogPopup::Values(ValuesForm::default())));
            (Vec::new(), Vec::new())
        }
        Action::SetZero => {
            let axes = model.setup.axis_set();
            let (effects, n) = offsets::zero_here(model, axes);
            (effects, vec![n])
        }
        Action::OverrideSlower | Action::OverrideFaster => {
            let base = base_speed(model);
            let settings = model.keypad.settings().clone();
            let up = action == Action::OverrideFaster;
            match model.keypad.values.change_override(up, base, &settings) {
                Ok(text) => note(NoteLevel::Info, text),
                Err(text) => note(NoteLevel::Warning, text),
            }
        }
        Action::OverrideReset => {
            model.keypad.values.override_pct = 100;
            note(NoteLevel::Info, "jog speed override 100 %".into())
        }
        Action::StepSmaller | Action::StepLarger => {
            let typed = model.keypad.values.step.take();
            let up = action == Action::StepLarger;
            model.keypad.selection.step = values::next_preset(
                &model.setup.jog_steps,
                model.keypad.selection.step,
                typed,
                up,
            );
            (Vec::new(), Vec::new())
        }
        Action::SpeedSlower | Action::SpeedFaster => {
            let typed = model.keypad.values.speed.take();
            let up = action == Action::SpeedFaster;
            model.keypad.selection.speed = values::next_preset(
                &model.setup.jog_speeds,
                model.keypad.selection.speed,
                typed,
                up,
            );
            (Vec::new(), Vec::new())
        }
        _ => return None,
    };
    Some(out)
}

/// The speed chosen before the override: typed, else the preset.
pub fn base_speed(model: &Model) -> f64 {
    model
        .keypad
        .values
        .speed
        .or_else(|| {
            model
                .setup
                .jog_speeds
                .get(model.keypad.selection.speed)
                .copied()
        })
        .unwrap_or(0.0)
}

/// The axes chosen in the `Z` popup: their work zero here.
pub fn zero_axes(model: &mut Model, axes: AxisSet) -> Outcome {
    let (effects, n) = offsets::zero_here(model, axes);
    (effects, vec![n])
}

/// A key of an open keypad popup (taken out of the model's popup slot;
/// put back unless the key closes it).
pub fn popup_action(model: &mut Model, mut popup: JogPopup, action: Action) -> Outcome {
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
            let (effects, n) = offsets::activate(model, choice.selected);
            Some((effects, vec![n]))
        }
        (JogPopup::Offsets(_), a) => match system_of(a) {
            Some(system) => {
                let (effects, n) = offsets::activate(model, system);
                Some((effects, vec![n]))
            }
            None => None,
        },
        (JogPopup::SetPosition(line), Action::Submit) => submit_position(model, line),
        (JogPopup::Values(form), Action::Submit) => submit_values(model, form),
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
    match out {
        Some(done) => done,
        None => {
            model.popup = Some(Popup::Jog(popup));
            (Vec::new(), Vec::new())
        }
    }
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
fn submit_position(model: &mut Model, line: &mut LineEdit) -> Option<Outcome> {
    let settings = model.keypad.settings();
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
        .and_then(|t| offsets::set_here(model, &t));
    match checked {
        Ok((effects, n)) => Some((effects, vec![n])),
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
fn submit_values(model: &mut Model, form: &mut ValuesForm) -> Option<Outcome> {
    let settings = model.keypad.settings().clone();
    let values::Typed { step, speed } = form.check(&settings)?;
    let mut notes = Vec::new();
    let mut said = Vec::new();
    if let Some((step, inexact)) = step {
        model.keypad.values.step = Some(step);
        said.push(format!(
            "step {}",
            super::super::position::format_amount(step)
        ));
        if let Some(n) = inexact {
            notes.push((NoteLevel::Warning, n));
        }
    }
    if let Some(speed) = speed {
        model.keypad.values.speed = Some(speed);
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
    Some((Vec::new(), notes))
}

/// A character typed while a keypad popup that types is open.
pub fn type_char(model: &mut Model, c: char) {
    if let Some(Popup::Jog(p)) = model.popup.as_mut()
        && let Some(line) = p.line()
    {
        line.insert(c);
    }
}

/// Pasted text into the open keypad popup's line; the refusal in words.
pub fn paste(model: &mut Model, text: &str) -> Option<String> {
    match model.popup.as_mut() {
        Some(Popup::Jog(p)) => p.line()?.paste(text).err().map(|e| e.to_string()),
        _ => None,
    }
}
