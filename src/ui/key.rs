//! Keys as the keymap names them: parsed from profile text (`"ctrl-x"`),
//! shown in the help (`Ctrl-X`), and made from crossterm's key events with
//! the differences between terminals smoothed out (a character carries its
//! own shift; `Ctrl-Shift-A` and `Ctrl-A` are one key).

use std::fmt;

use ratatui::crossterm::event::{KeyCode as CtKey, KeyEvent, KeyEventKind, KeyModifiers};

/// A key without modifiers. Space is `Char(' ')`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum KeyCode {
    Char(char),
    Enter,
    Esc,
    Tab,
    BackTab,
    Backspace,
    Delete,
    Insert,
    Home,
    End,
    PageUp,
    PageDown,
    Up,
    Down,
    Left,
    Right,
    F(u8),
}

/// A key with its modifiers, as bound in the keymap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct KeyChord {
    pub code: KeyCode,
    pub ctrl: bool,
    pub alt: bool,
    /// Only for keys that are not characters: a character already says
    /// whether shift was held (`A`, `?`).
    pub shift: bool,
}

/// Why a key name in a profile is not a key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{text}` is not a key: {reason}")]
pub struct KeyParseError {
    pub text: String,
    pub reason: String,
}

/// Named keys as a profile may write them (lower case; the first name is the
/// one the help shows after capitalising).
const NAMED: &[(&str, KeyCode)] = &[
    ("space", KeyCode::Char(' ')),
    ("enter", KeyCode::Enter),
    ("return", KeyCode::Enter),
    ("esc", KeyCode::Esc),
    ("escape", KeyCode::Esc),
    ("tab", KeyCode::Tab),
    ("backtab", KeyCode::BackTab),
    ("backspace", KeyCode::Backspace),
    ("delete", KeyCode::Delete),
    ("del", KeyCode::Delete),
    ("insert", KeyCode::Insert),
    ("ins", KeyCode::Insert),
    ("home", KeyCode::Home),
    ("end", KeyCode::End),
    ("pageup", KeyCode::PageUp),
    ("pgup", KeyCode::PageUp),
    ("pagedown", KeyCode::PageDown),
    ("pgdn", KeyCode::PageDown),
    ("up", KeyCode::Up),
    ("down", KeyCode::Down),
    ("left", KeyCode::Left),
    ("right", KeyCode::Right),
];

impl KeyChord {
    pub const fn plain(code: KeyCode) -> Self {
        Self {
            code,
            ctrl: false,
            alt: false,
            shift: false,
        }
    }

    pub const fn char(c: char) -> Self {
        Self::plain(KeyCode::Char(c))
    }

    pub const fn ctrl(c: char) -> Self {
        Self {
            code: KeyCode::Char(c),
            ctrl: true,
            alt: false,
            shift: false,
        }
    }

    pub const SPACE: KeyChord = KeyChord::char(' ');

    /// The chord a key event stands for; `None` for releases (they matter
    /// only to the jog keypad's dead-man, not to the keymap) and for keys the
    /// keymap cannot name (media keys, lone modifiers).
    pub fn from_event(event: &KeyEvent) -> Option<KeyChord> {
        if event.kind == KeyEventKind::Release {
            return None;
        }
        let m = event.modifiers;
        let mut shift = m.contains(KeyModifiers::SHIFT);
        let code = match event.code {
            CtKey::Char(c) => {
                shift = false;
                KeyCode::Char(c)
            }
            CtKey::Enter => KeyCode::Enter,
            CtKey::Esc => KeyCode::Esc,
            CtKey::Tab if shift => {
                shift = false;
                KeyCode::BackTab
            }
            CtKey::Tab => KeyCode::Tab,
            CtKey::BackTab => {
                shift = false;
                KeyCode::BackTab
            }
            CtKey::Backspace => KeyCode::Backspace,
            CtKey::Delete => KeyCode::Delete,
            CtKey::Insert => KeyCode::Insert,
            CtKey::Home => KeyCode::Home,
            CtKey::End => KeyCode::End,
            CtKey::PageUp => KeyCode::PageUp,
            CtKey::PageDown => KeyCode::PageDown,
            CtKey::Up => KeyCode::Up,
            CtKey::Down => KeyCode::Down,
            CtKey::Left => KeyCode::Left,
            CtKey::Right => KeyCode::Right,
            CtKey::F(n) => KeyCode::F(n),
            _ => return None,
        };
        let ctrl = m.contains(KeyModifiers::CONTROL);
        // Terminals differ in whether Ctrl-A arrives as 'a' or 'A'; the
        // keymap knows only the lower-case one.
        let code = match code {
            KeyCode::Char(c) if ctrl => KeyCode::Char(c.to_ascii_lowercase()),
            other => other,
        };
        Some(KeyChord {
            code,
            ctrl,
            alt: m.contains(KeyModifiers::ALT),
            shift,
        })
    }

    /// The character this key types into a text field, if it types one.
    pub fn typed_char(&self) -> Option<char> {
        match self.code {
            KeyCode::Char(c) if !self.ctrl && !self.alt && !c.is_control() => Some(c),
            _ => None,
        }
    }

    /// Parse a profile's key name: `q`, `?`, `space`, `ctrl-x`, `alt-enter`,
    /// `shift-tab`, `f2`. Modifiers are `ctrl-`, `alt-` and `shift-` (also
    /// with `+`); names are case-insensitive, single characters are not.
    pub fn parse(text: &str) -> Result<KeyChord, KeyParseError> {
        let fail = |reason: &str| KeyParseError {
            text: text.to_string(),
            reason: reason.to_string(),
        };
        let mut rest = text;
        let (mut ctrl, mut alt, mut shift) = (false, false, false);
        loop {
            // A single remaining character is the key itself, even `-`.
            if rest.chars().count() <= 1 {
                break;
            }
            let lower = rest.to_ascii_lowercase();
            let prefix = ["ctrl", "alt", "shift"].into_iter().find(|p| {
                lower.starts_with(p)
                    && matches!(lower.as_bytes().get(p.len()), Some(b'-') | Some(b'+'))
            });
            let Some(prefix) = prefix else { break };
            match prefix {
                "ctrl" => ctrl = true,
                "alt" => alt = true,
                _ => shift = true,
            }
            rest = rest.get(prefix.len() + 1..).unwrap_or_default();
        }
        let mut chars = rest.chars();
        let code = match (chars.next(), chars.next()) {
            (None, _) => return Err(fail("the key itself is missing")),
            (Some(c), None) if c.is_control() => {
                return Err(fail("control characters cannot be named"));
            }
            (Some(c), None) => KeyCode::Char(if ctrl { c.to_ascii_lowercase() } else { c }),
            _ => {
                let lower = rest.to_ascii_lowercase();
                if let Some((_, code)) = NAMED.iter().find(|(name, _)| *name == lower) {
                    *code
                } else if let Some(n) = lower
                    .strip_prefix('f')
                    .and_then(|n| n.parse::<u8>().ok())
                    .filter(|n| (1..=24).contains(n))
                {
                    KeyCode::F(n)
                } else {
                    return Err(fail(
                        "expected a character, space, enter, esc, tab, backtab, backspace, \
                         delete, insert, home, end, pageup, pagedown, up, down, left, right \
                         or f1-f24, with optional ctrl-, alt-, shift- in front",
                    ));
                }
            }
        };
        if shift && matches!(code, KeyCode::Char(c) if c != ' ') {
            return Err(fail(
                "shift- goes only with named keys; write the shifted character itself (`A`, `?`)",
            ));
        }
        let (code, shift) = match code {
            KeyCode::Tab if shift => (KeyCode::BackTab, false),
            KeyCode::Char(' ') => (code, false),
            _ => (code, shift),
        };
        Ok(KeyChord {
            code,
            ctrl,
            alt,
            shift,
        })
    }
}

impl fmt::Display for KeyChord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.ctrl {
            f.write_str("Ctrl-")?;
        }
        if self.alt {
            f.write_str("Alt-")?;
        }
        if self.shift {
            f.write_str("Shift-")?;
        }
        match self.code {
            KeyCode::Char(' ') => f.write_str("Space"),
            // Control chords are case-blind (see `from_event`); show them the
            // way keyboards label them.
            KeyCode::Char(c) if self.ctrl => write!(f, "{}", c.to_ascii_uppercase()),
            KeyCode::Char(c) => write!(f, "{c}"),
            KeyCode::Enter => f.write_str("Enter"),
            KeyCode::Esc => f.write_str("Esc"),
            KeyCode::Tab => f.write_str("Tab"),
            KeyCode::BackTab => f.write_str("Shift-Tab"),
            KeyCode::Backspace => f.write_str("Backspace"),
            KeyCode::Delete => f.write_str("Del"),
            KeyCode::Insert => f.write_str("Ins"),
            KeyCode::Home => f.write_str("Home"),
            KeyCode::End => f.write_str("End"),
            KeyCode::PageUp => f.write_str("PgUp"),
            KeyCode::PageDown => f.write_str("PgDn"),
            KeyCode::Up => f.write_str("Up"),
            KeyCode::Down => f.write_str("Down"),
            KeyCode::Left => f.write_str("Left"),
            KeyCode::Right => f.write_str("Right"),
            KeyCode::F(n) => write!(f, "F{n}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn event(code: CtKey, modifiers: KeyModifiers) -> KeyEvent {
        KeyEvent::new(code, modifiers)
    }

    #[test]
    fn names_parse_case_insensitively_and_print_for_the_help() {
        for (text, shown) in [
            ("q", "q"),
            ("Q", "Q"),
            ("?", "?"),
            ("-", "-"),
            ("space", "Space"),
            ("SPACE", "Space"),
            ("ctrl-x", "Ctrl-X"),
            ("Ctrl+X", "Ctrl-X"),
            ("ctrl--", "Ctrl--"),
            ("alt-enter", "Alt-Enter"),
            ("shift-tab", "Shift-Tab"),
            ("backtab", "Shift-Tab"),
            ("shift-up", "Shift-Up"),
            ("pgdn", "PgDn"),
            ("F12", "F12"),
        ] {
            let chord = KeyChord::parse(text).unwrap_or_else(|e| panic!("{text}: {e}"));
            assert_eq!(chord.to_string(), shown, "{text}");
        }
    }

    #[test]
    fn bad_names_say_what_was_expected() {
        for text in ["", "ctrl-", "shift-a", "f0", "f25", "spcae", "ctrl-shift-?"] {
            let err = KeyChord::parse(text).expect_err(text);
            assert!(!err.reason.is_empty(), "{text}");
        }
        assert!(
            KeyChord::parse("shift-a")
                .unwrap_err()
                .reason
                .contains("shifted character")
        );
    }

    #[test]
    fn events_normalise_shift_and_control_case() {
        // Shifted characters carry the shift themselves.
        let q = event(CtKey::Char('?'), KeyModifiers::SHIFT);
        assert_eq!(KeyChord::from_event(&q), Some(KeyChord::char('?')));
        // Ctrl-Shift-C from some terminals is Ctrl-C.
        let c = event(
            CtKey::Char('C'),
            KeyModifiers::CONTROL | KeyModifiers::SHIFT,
        );
        assert_eq!(KeyChord::from_event(&c), Some(KeyChord::ctrl('c')));
        let tab = event(CtKey::Tab, KeyModifiers::SHIFT);
        assert_eq!(
            KeyChord::from_event(&tab),
            Some(KeyChord::plain(KeyCode::BackTab))
        );
        let mut release = event(CtKey::Char(' '), KeyModifiers::NONE);
        release.kind = KeyEventKind::Release;
        assert_eq!(KeyChord::from_event(&release), None);
        let mut repeat = event(CtKey::Char(' '), KeyModifiers::NONE);
        repeat.kind = KeyEventKind::Repeat;
        assert_eq!(KeyChord::from_event(&repeat), Some(KeyChord::SPACE));
    }

    #[test]
    fn only_plain_printable_characters_type() {
        assert_eq!(KeyChord::char('a').typed_char(), Some('a'));
        assert_eq!(KeyChord::ctrl('a').typed_char(), None);
        assert_eq!(KeyChord::plain(KeyCode::Enter).typed_char(), None);
    }

    proptest! {
        #[test]
        fn parse_never_panics_and_printed_keys_parse_back(text in "\\PC{0,12}") {
            if let Ok(chord) = KeyChord::parse(&text) {
                let shown = chord.to_string();
                let again = KeyChord::parse(&shown.replace("Shift-Tab", "backtab"));
                prop_assert_eq!(again, Ok(chord), "{} -> {}", text, shown);
            }
        }
    }
}
