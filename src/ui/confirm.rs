//! A question the operator answers before its effects are carried out (the
//! `Confirm` popup): below the model, so that what the model holds (the
//! macros) can ask one.

use super::msg::Effect;

/// A question that must be answered before its effects are carried out.
#[derive(Debug, Clone, PartialEq)]
pub struct Confirmation {
    pub title: String,
    pub question: String,
    pub effects: Vec<Effect>,
    /// The profile's macro to run once confirmed (`ui::macros`), after
    /// `effects`.
    pub run_macro: Option<String>,
}
