//! Typing, pastes and bursts: which field typed text goes into, what a key
//! that arrived together with others may do, and when Space types a blank
//! rather than stopping (`docs/ui.md`, "Typing, pastes and bursts";
//! `docs/jogging.md`, "Pastes and bursts").
//!
//! - **A paste is text, never keys.** With bracketed paste on
//!   (`ui::terminal`), a terminal hands pasted text over as one
//!   `Msg::Paste`: it goes into the text field that has the input, and is
//!   ignored everywhere else.
//! - **A burst is never motion.** Without bracketed paste (a terminal that
//!   lacks it, tmux without `paste-buffer -p`) a paste arrives as keys, many
//!   in one read. Key presses read together, or less than [`BURST_GAP`]
//!   after the previous one, are a burst: they type where text is typed and
//!   edit that text, and do nothing else; no motion, no confirmation, no
//!   command sent (`update`'s burst routing).
//! - **Space stops whenever anything moves or may move.** In a text field it
//!   types a blank only while the machine is known to stand still
//!   ([`may_move`] says why not otherwise).
//!
//! Pure: the model and the keys in, decisions out.

use std::time::{Duration, Instant};

use ratatui::crossterm::event::{KeyEvent, KeyEventKind};

use crate::device::api::{Activity, LinkState, Request};

use super::editor::dialog::Dialog;
use super::keymap::Action;
use super::model::{Model, PanelId, Popup};

/// Keys closer together than this were not typed one by one: a person
/// types at most ~15 keys a second (70 ms apart) and key repeat runs at
/// 25-40 Hz (25-40 ms apart), so 5 ms leaves a wide margin on both sides,
/// while a terminal writing a paste or a program's burst delivers its keys
/// microseconds apart (one read, or reads back to back).
pub const BURST_GAP: Duration = Duration::from_millis(5);

/// How long after a request that may move the machine Space still stops in
/// a text field, although the machine reports it stands still: the request
/// may wait in the device task behind a poll, or its state report may be
/// on its way.
pub const MOTION_SETTLE: Duration = Duration::from_secs(1);

/// A field that typed text goes into.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextField {
    /// The program editor's text (the program screen, no popup).
    Editor,
    /// The console's command line (entered with `:`).
    CommandLine,
    /// A form of the editor (file name, find, go to line, arc, …).
    Form,
    /// The line of a popup: the go-to prompt, a typed value of the
    /// keypad's (set position, jog step and speed); `Popup::line`.
    Prompt,
}

/// The text field that has the input now, if any.
pub fn text_field(model: &Model) -> Option<TextField> {
    match &model.popup {
        Some(Popup::GoTo(_)) => Some(TextField::Prompt),
        Some(Popup::Editor(Dialog::Form(_))) => Some(TextField::Form),
        Some(Popup::Jog(p)) if p.types() => Some(TextField::Prompt),
        Some(_) => None,
        None => match model.focus {
            PanelId::Editor if model.editor.checkout.is_some() => None,
            PanelId::Editor => Some(TextField::Editor),
            PanelId::Console => Some(TextField::CommandLine),
            _ => None,
        },
    }
}

/// Whether a batch of keys read together is a burst: more than one key
/// press (or auto-repeat) in it, or its first press less than
/// [`BURST_GAP`] after the last one read before it. Releases do not count:
/// a release only ever stops (kitty keyboard protocol).
pub fn is_burst(batch: &[(KeyEvent, Instant)], last_key: Option<Instant>) -> bool {
    let mut presses = batch
        .iter()
        .filter(|(k, _)| k.kind != KeyEventKind::Release)
        .map(|(_, at)| *at);
    let Some(first) = presses.next() else {
        return false;
    };
    presses.next().is_some()
        || last_key.is_some_and(|last| first.saturating_duration_since(last) < BURST_GAP)
}

/// The arrival of the last press or repeat of a batch, if it has one.
pub fn last_press(batch: &[(KeyEvent, Instant)]) -> Option<Instant> {
    batch
        .iter()
        .filter(|(k, _)| k.kind != KeyEventKind::Release)
        .map(|(_, at)| *at)
        .max()
}

/// Why the machine may move, in words; `None` while it is known to stand
/// still: connected, its state read, nothing running (jog, step, move,
/// reference run, program, upload, stop under way), no jog of the keypad
/// alive, and no request that may move it handed on in the last
/// [`MOTION_SETTLE`].
pub fn may_move(model: &Model) -> Option<String> {
    if model.link != LinkState::Connected || !model.machine.link_up {
        return Some("the link is down, so the machine's state is unknown".into());
    }
    if let Some(what) = doing(model.machine.activity) {
        return Some(format!("the machine is {what}"));
    }
    if model.keypad.jogger.active().is_some() {
        return Some("a jog runs".into());
    }
    if model.keypad.homing.is_some() {
        return Some("a reference run was asked for".into());
    }
    if let Some(job) = model.editor.job_under_way() {
        return Some(job.into());
    }
    if model
        .motion_asked
        .is_some_and(|t| model.now.saturating_duration_since(t) < MOTION_SETTLE)
    {
        return Some("a move was asked for a moment ago".into());
    }
    None
}

/// What the machine is doing, in words ("the machine is …"); `None` idle.
pub fn doing(activity: Activity) -> Option<&'static str> {
    match activity {
        Activity::Idle => None,
        Activity::Jogging => Some("jogging"),
        Activity::Stepping => Some("stepping"),
        Activity::Moving => Some("moving to a position"),
        Activity::Homing => Some("running a reference run"),
        Activity::Probing => Some("probing"),
        Activity::RunningProgram => Some("running a program"),
        Activity::Uploading => Some("storing a program"),
        Activity::Stopping => Some("stopping"),
    }
}

/// Whether handing `request` on may keep or set the machine moving (raw
/// lines count: a typed command may be a move; a renewal keeps a jog going).
pub fn may_start_motion(request: &Request) -> bool {
    request.may_move() || matches!(request, Request::JogRenew { .. })
}

/// Actions that only edit the text of the field that has the input, or
/// move its cursor: what a burst may do there.
pub fn edits_text(action: Action) -> bool {
    matches!(
        action,
        Action::CursorLeft
            | Action::CursorRight
            | Action::CursorHome
            | Action::CursorEnd
            | Action::CursorUp
            | Action::CursorDown
            | Action::WordLeft
            | Action::WordRight
            | Action::CursorTop
            | Action::CursorBottom
            | Action::PageUp
            | Action::PageDown
            | Action::NewLine
            | Action::TypeBlank
            | Action::DeleteBack
            | Action::DeleteForward
            | Action::DeleteLine
            | Action::ClearLine
            | Action::NextField
            | Action::PrevField
    )
}

/// Actions a burst may carry out anywhere: they only stop or close.
pub fn only_stops_or_closes(action: Action) -> bool {
    matches!(action, Action::Stop | Action::Cancel | Action::Close)
}

/// Pasted text for the program editor: line ends as `\n` (terminals send
/// CR for a pasted line end), a tab as a blank (as Tab types one), other
/// control characters dropped.
pub fn editor_text(text: &str) -> String {
    text.replace("\r\n", "\n")
        .chars()
        .filter_map(|c| match c {
            '\r' | '\n' => Some('\n'),
            '\t' => Some(' '),
            c if c.is_control() => None,
            c => Some(c),
        })
        .collect()
}

#[cfg(test)]
mod arrivals;

#[cfg(test)]
mod tests {
    use super::*;
    use ratatui::crossterm::event::{KeyCode, KeyModifiers};

    fn key(kind: KeyEventKind) -> KeyEvent {
        let mut k = KeyEvent::new(KeyCode::Char('6'), KeyModifiers::NONE);
        k.kind = kind;
        k
    }

    #[test]
    fn more_than_one_press_or_a_press_right_behind_another_is_a_burst() {
        let t = Instant::now();
        let press = key(KeyEventKind::Press);
        let release = key(KeyEventKind::Release);
        let ms = Duration::from_millis;
        assert!(!is_burst(&[(press, t)], None));
        assert!(is_burst(&[(press, t), (press, t)], None));
        // A press with its own release (a quick tap over SSH) is one key.
        assert!(!is_burst(&[(press, t), (release, t)], None));
        assert!(!is_burst(&[(release, t), (release, t)], None));
        // 3 ms after the last key: the rest of a burst read apart.
        assert!(is_burst(&[(press, t + ms(3))], Some(t)));
        // Key repeat at 40 Hz and quick typing are far apart.
        assert!(!is_burst(&[(press, t + ms(25))], Some(t)));
        assert!(!is_burst(&[(press, t + BURST_GAP)], Some(t)));
        assert_eq!(
            last_press(&[(press, t), (press, t + ms(1)), (release, t + ms(2))]),
            Some(t + ms(1))
        );
    }

    #[test]
    fn pasted_text_for_the_editor_keeps_its_lines_and_drops_control_characters() {
        assert_eq!(editor_text("a\r\nb\rc\n\td\u{1b}e"), "a\nb\nc\n de");
    }
}
