//! The help overlay's content, generated from the keymap so it lists every
//! key that is bound, and nothing that is not.

use std::borrow::Cow;

use crate::config::macros::Macro;

use super::key::{KeyChord, KeyCode};
use super::keymap::{Action, Keymap, Mode};

#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HelpLine {
    Heading(&'static str),
    Entry {
        keys: String,
        description: Cow<'static, str>,
    },
    Text(&'static str),
    Blank,
}

/// Notes shown under a mode's keys.
fn notes(keymap: &Keymap, mode: Mode) -> &'static [&'static str] {
    let esc_stops = keymap.lookup(Mode::Main, &KeyChord::plain(KeyCode::Esc)) == Some(Action::Stop);
    match mode {
        Mode::Safety => &[
            "Space stops whenever anything moves or may move, in every mode and popup.",
            "In the editor, the command line and typed prompts Space types a blank only",
            "while the machine is known to stand still (connected, idle, no move asked",
            "for in the last second); otherwise it stops and says why.",
        ],
        Mode::Main if esc_stops => &[
            "Esc stops too, unless a popup is open (Esc then closes it).",
            "A paste is text: typed into the editor or a typed line, ignored elsewhere.",
            "Keys that arrive together (a paste, a burst) never move the machine.",
        ],
        Mode::Main => &[
            "A paste is text: typed into the editor or a typed line, ignored elsewhere.",
            "Keys that arrive together (a paste, a burst) never move the machine.",
        ],
        Mode::Console => &[
            "Only : enters the command line (Tab passes it by), so keys meant for the",
            "keypad never land here. Commands are checked with the controller's own",
            "rules before they are sent; a paste goes in but is never sent by itself.",
        ],
        Mode::Sim => &["Simulator inputs exist only on the built-in simulator."],
        Mode::GoTo => &[
            "Typed in the active work offset's coordinates; Tab or a typed G53: machine",
            "coordinates. F is the path speed in units per minute (as in G-code), else the",
            "jog speed (with its override).",
        ],
        Mode::Offsets => &[
            "Each zero is a machine position; the active offset (G54 at first) is shown in",
            "the position panel's title. Offsets are saved per profile and port and come",
            "back at the next start, unless the file is another machine's (then refused).",
        ],
        Mode::Entry => &[
            "Set position: X0 or X10 Y-2.5 makes where the machine stands read that in the",
            "active offset. Step and speed: checked against the axes; ( ) override +-10 %.",
        ],
        Mode::Editor => &[
            "Gutter numbers are the controller's command numbers; #N in go-to finds command N.",
            "Unsaved edits are kept in a recovery file every few seconds (docs/editor.md).",
        ],
        _ => &[],
    }
}

/// The help: every mode's keys, then the profile's macros.
pub fn help_lines(keymap: &Keymap, macros: &[Macro]) -> Vec<HelpLine> {
    let mut out = Vec::new();
    for mode in Mode::ALL {
        let entries = keymap.help(mode);
        if entries.is_empty() {
            continue;
        }
        if !out.is_empty() {
            out.push(HelpLine::Blank);
        }
        out.push(HelpLine::Heading(mode.title()));
        for entry in entries {
            let keys = entry
                .keys
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(" ");
            out.push(HelpLine::Entry {
                keys,
                description: Cow::Borrowed(entry.action.description()),
            });
        }
        for note in notes(keymap, mode) {
            out.push(HelpLine::Text(note));
        }
    }
    if !macros.is_empty() {
        out.push(HelpLine::Blank);
        out.push(HelpLine::Heading(
            "Macros of the profile (machine screen; Space stops one)",
        ));
        for m in macros {
            let keys = keymap
                .keys_for_macro(Mode::Main, &m.name)
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(" ");
            let asks = if m.confirm { ", asks first" } else { "" };
            let what = m.description.as_deref().unwrap_or("");
            let sep = if what.is_empty() { "" } else { ": " };
            let lines = m.lines.len();
            out.push(HelpLine::Entry {
                keys,
                description: Cow::Owned(format!("{}{sep}{what} ({lines} lines{asks})", m.name)),
            });
        }
        out.push(HelpLine::Text(
            "Bound in the profile: [keys.main] \"f8\" = \"macro:NAME\" (docs/ui.md).",
        ));
    }
    out
}
