//! The keypad's main keys for work offsets, typed step and speed and the
//! speed override, and the popups they open ([`JogPopup`]): the choice of
//! G54-G59 (`O`), the work position set here (`s`), the typed step and
//! speed (`J`). What their keys do is the jog screen's (`component`).

use super::super::keymap::Mode;
use super::super::line_edit::LineEdit;
use super::offsets::OffsetsChoice;
use super::values::ValuesForm;

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
    pub fn line(&mut self) -> Option<&mut LineEdit> {
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
