//! The keymap as data: mode -> key -> action, with jogterm's defaults, the
//! profile's `[keys]` overrides (errors placed on the profile line that
//! caused them), and the listing the help overlay shows.
//!
//! One table each: the modes and the actions, with their names and texts,
//! are declared once below ([`named_enum!`]); which actions each mode has,
//! in the help's order, and their default keys are data, `config/keys.toml`,
//! compiled in ([`Keymap::builtin`]).
//!
//! Routing (see `update::route_key`): the `safety` mode is looked up first for
//! every key in every state, then the open popup's mode, then the focused
//! panel's mode, then `main`. So a stop key can never be swallowed.

use std::collections::BTreeMap;
use std::fmt;

use super::key::{KeyChord, KeyCode};
use crate::config::{ConfigError, Origin, Source, source};

/// An enum of names, declared once: the variants in order, each with the
/// name a profile (and `config/keys.toml`) uses and one text. Gives `ALL`
/// (declaration order), `name`, the text method, `from_name` and `Display`.
/// A name given twice is an unreachable pattern in `from_name`: a warning,
/// so an error under `clippy -D warnings`.
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        pub enum $ty:ident, $text:ident {
            $($(#[$vmeta:meta])* $variant:ident = $name:literal, $said:literal;)*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum $ty {
            $($(#[$vmeta])* $variant,)*
        }

        impl $ty {
            /// Every one, in the order declared.
            pub const ALL: [$ty; [$($name),*].len()] = [$($ty::$variant),*];

            /// The name in a profile and in `config/keys.toml`.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)*
                }
            }

            pub fn $text(self) -> &'static str {
                match self {
                    $($ty::$variant => $said,)*
                }
            }

            pub fn from_name(name: &str) -> Option<$ty> {
                match name {
                    $($name => Some($ty::$variant),)*
                    _ => None,
                }
            }
        }

        impl fmt::Display for $ty {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

named_enum! {
    /// A context in which keys mean something, in the order the help lists
    /// them; `title` heads its part of the help.
    pub enum Mode, title {
        /// Looked up before anything else, whatever has focus or is open.
        Safety = "safety", "Always (before anything else)";
        /// Everywhere, after the focused panel has passed on the key.
        Main = "main", "Main screen";
        /// The jog keypad has focus.
        Jog = "jog", "Jog keypad (focused)";
        /// The I/O panel has focus.
        Io = "io", "I/O panel (focused)";
        /// The traffic console's command line has focus (entered with `:`).
        Console = "console", "Console command line (entered with :, Tab leaves; other characters are typed)";
        /// The simulator panel has focus.
        Sim = "sim", "Simulator panel (focused)";
        /// The program editor has focus (the program screen is shown).
        Editor = "editor", "Program editor (focused; other characters are typed)";
        /// The help overlay.
        Help = "help", "This help";
        /// The confirmation popup.
        Confirm = "confirm", "Confirmation";
        /// A form of the editor (file name, find, go to, arc, taught dwell or
        /// output) is open.
        Form = "form", "Editor form (other characters are typed)";
        /// The question about unsaved changes is open.
        Unsaved = "unsaved", "Unsaved changes";
        /// The go-to prompt.
        GoTo = "goto", "Go-to prompt (other characters are typed)";
        /// The choice of an axis (reference run or work zero of one axis).
        Axes = "axes", "Choice of an axis";
        /// The choice of the active work offset (G54-G59).
        Offsets = "offsets", "Work offsets";
        /// A typed value of the keypad's: the work position here, the jog
        /// step and speed.
        Entry = "entry", "Set position, jog step and speed (other characters are typed)";
        /// The port timeline is shown.
        Timeline = "timeline", "Port timeline (shown)";
        /// The named outputs (spindle, coolant, clamp …) popup.
        Outputs = "outputs", "Named outputs";
        /// The message history is shown.
        Messages = "messages", "Message history";
        /// The program screen during a check-out (issue 15,
        /// `docs/editor.md`): the text is read-only.
        Checkout = "checkout", "Program check-out (program screen; the text is read-only)";
    }
}

named_enum! {
    /// Everything a key can do; `description` is its line in the help.
    pub enum Action, description {
        Stop = "stop", "stop all motion";
        Quit = "quit", "stop, close the port and quit";
        Help = "help", "show this help";
        FocusNext = "focus-next", "focus the next panel";
        FocusPrev = "focus-prev", "focus the previous panel";
        FocusConsole = "focus-console", "type a raw command";
        Initialise = "initialise", "initialise the controller";
        Home = "home", "reference run of all axes (asks first)";
        SetZero = "set-zero", "make the current position the work zero (active offset)";
        Reset = "reset", "reset the controller (asks first)";
        StepSmaller = "step-smaller", "smaller jog step";
        StepLarger = "step-larger", "larger jog step";
        SpeedSlower = "speed-slower", "slower jog speed";
        SpeedFaster = "speed-faster", "faster jog speed";
        TogglePolls = "toggle-polls", "show or hide poll traffic";
        SelectPrev = "select-prev", "previous item";
        SelectNext = "select-next", "next item";
        GroupPrev = "group-prev", "previous port";
        GroupNext = "group-next", "next port";
        ToggleOutput = "toggle-output", "switch the selected output (asks first if hazardous)";
        Submit = "submit", "check and send the command";
        HistoryPrev = "history-prev", "previous command from the history";
        HistoryNext = "history-next", "next command from the history";
        CursorLeft = "cursor-left", "cursor left";
        CursorRight = "cursor-right", "cursor right";
        CursorHome = "cursor-home", "cursor to the start";
        CursorEnd = "cursor-end", "cursor to the end";
        DeleteBack = "delete-back", "delete before the cursor";
        DeleteForward = "delete-forward", "delete at the cursor";
        ClearLine = "clear-line", "clear the line";
        SimToggle = "sim-toggle", "flip the selected simulator input";
        SimOn = "sim-on", "set the selected input on / closed";
        SimOff = "sim-off", "set the selected input off / open";
        SimPress = "sim-press", "press and release the selected button";
        SimStart = "sim-start", "press the start key a pause (M0, M1, M6) waits for";
        Confirm = "confirm", "yes, do it";
        Cancel = "cancel", "no, cancel";
        Close = "close", "close";
        ScrollUp = "scroll-up", "scroll up";
        ScrollDown = "scroll-down", "scroll down";
        PageUp = "page-up", "page up";
        PageDown = "page-down", "page down";
        EditProgram = "edit-program", "show or hide the program editor";
        TeachAbsolute = "teach-absolute", "teach: absolute move to the current position";
        TeachRelative = "teach-relative", "teach: relative move from the point taught before";
        TeachDwell = "teach-dwell", "teach: a dwell (asks for the time)";
        TeachOutput = "teach-output", "teach: set an output (asks which)";
        TeachSlower = "teach-slower", "slower speed for taught moves";
        TeachFaster = "teach-faster", "faster speed for taught moves";
        Upload = "upload", "upload the program (asks to erase a stored one)";
        RunProgram = "run-program", "start the program (asks); EMCU: pause/go on; WAIT: go on";
        CloseEditor = "close-editor", "back to the machine screen";
        CursorUp = "cursor-up", "cursor up";
        CursorDown = "cursor-down", "cursor down";
        WordLeft = "word-left", "cursor to the previous word";
        WordRight = "word-right", "cursor to the next word";
        CursorTop = "cursor-top", "cursor to the first line";
        CursorBottom = "cursor-bottom", "cursor to the last line";
        NewLine = "new-line", "split the line";
        TypeBlank = "type-blank", "type a blank (Space too, while the machine stands)";
        DeleteLine = "delete-line", "delete the line";
        Undo = "undo", "undo";
        Redo = "redo", "redo";
        Save = "save", "save the program";
        SaveAs = "save-as", "save the program under another name";
        Open = "open", "open a program file";
        Find = "find", "find text";
        FindNext = "find-next", "find the next match";
        FindPrev = "find-prev", "find the previous match";
        GoToLine = "go-to-line", "go to a line or (#N) a command";
        NextProblem = "next-problem", "next error or warning";
        PrevProblem = "prev-problem", "previous error or warning";
        ApplyFix = "apply-fix", "apply the suggested fix on the line";
        Format = "format", "format the program (canonical spelling)";
        Circle = "circle", "insert an arc or helix (f and y/w from radius and angles)";
        JumpTarget = "jump-target", "go to where the line's jump or loop leads";
        TogglePreview = "toggle-preview", "toolpath preview: XY and XZ, XY, XZ, off";
        NextField = "next-field", "next field";
        PrevField = "prev-field", "previous field";
        Discard = "discard", "discard the changes (kept aside in the recovery folder)";
        JogXPlus = "jog-x-plus", "jog X+ (step, or while held)";
        JogXMinus = "jog-x-minus", "jog X-";
        JogYPlus = "jog-y-plus", "jog Y+";
        JogYMinus = "jog-y-minus", "jog Y-";
        JogZPlus = "jog-z-plus", "jog Z+";
        JogZMinus = "jog-z-minus", "jog Z-";
        JogAPlus = "jog-a-plus", "jog A+";
        JogAMinus = "jog-a-minus", "jog A-";
        JogXPlusYPlus = "jog-x-plus-y-plus", "jog diagonally X+ Y+";
        JogXMinusYPlus = "jog-x-minus-y-plus", "jog diagonally X- Y+";
        JogXPlusYMinus = "jog-x-plus-y-minus", "jog diagonally X+ Y-";
        JogXMinusYMinus = "jog-x-minus-y-minus", "jog diagonally X- Y-";
        JogKind = "jog-kind", "switch between step and continuous jogging";
        GoTo = "go-to", "go to a typed position (work or machine coordinates)";
        GoZero = "go-zero", "go to the work zero (asks first)";
        JogOffLimit = "jog-off-limit", "jog the axis off its active limit switch (asks first)";
        ProbeZ = "probe-z", "touch off Z with the probe: Z 0 = surface - plate (asks)";
        FrameJob = "frame-job", "trace the G-code job's frame at its safe height (asks)";
        FrameHold = "frame-hold", "trace the job's frame while the key is held";
        HomeAxis = "home-axis", "reference run of one axis";
        ZeroAxis = "zero-axis", "make the current position the work zero of one axis";
        AxisAll = "axis-all", "all axes";
        AxisX = "axis-x", "axis X";
        AxisY = "axis-y", "axis Y";
        AxisZ = "axis-z", "axis Z";
        AxisA = "axis-a", "axis A";
        Timeline = "timeline", "show or hide the port timeline (every input change)";
        WorkOffsets = "work-offsets", "choose the work offset G54-G59 (shows their zeros)";
        SetPosition = "set-position", "set the work position here, typed (X10 Y0)";
        JogValues = "jog-values", "type a jog step and speed";
        OverrideSlower = "override-slower", "jog speed override -10 %";
        OverrideFaster = "override-faster", "jog speed override +10 %";
        OverrideReset = "override-reset", "jog speed override back to 100 %";
        ToggleFrame = "toggle-frame", "switch between work and machine coordinates";
        Activate = "activate", "make the selected work offset the active one";
        G54 = "g54", "make G54 the active work offset";
        G55 = "g55", "make G55 the active work offset";
        G56 = "g56", "make G56 the active work offset";
        G57 = "g57", "make G57 the active work offset";
        G58 = "g58", "make G58 the active work offset";
        G59 = "g59", "make G59 the active work offset";
        TimeEarlier = "earlier", "timeline: back in time";
        TimeLater = "later", "timeline: forward in time";
        TimeLive = "live", "timeline: follow the newest readings";
        ZoomIn = "zoom-in", "timeline: fewer milliseconds per column";
        ZoomOut = "zoom-out", "timeline: more milliseconds per column";
        // Operator screen (issue 16): named outputs, message history, large DRO.
        Outputs = "outputs", "switch the named outputs (spindle, coolant, clamp …)";
        Messages = "messages", "message history: every message whole, with scrollback";
        LargeDro = "large-dro", "large position display (readable from across the workshop)";
        JobLog = "job-log", "the job log: last runs, last line, how each ended";
        ScrollTop = "scroll-top", "to the oldest";
        ScrollBottom = "scroll-bottom", "to the newest";
        // Program check-out (issue 15, `docs/editor.md`, "Check-out").
        Checkout = "checkout", "check-out: run line by line while the key is held (asks)";
        CheckoutFromLine = "checkout-from-line", "check-out from the cursor's line (shows the start, asks)";
        CheckoutHold = "checkout-hold", "hold to run the check-out; let go: pause";
        CheckoutSingle = "checkout-single", "single step on/off: one line per press";
        CheckoutSlower = "checkout-slower", "check-out speed factor -10 %";
        CheckoutFaster = "checkout-faster", "check-out speed factor +10 %";
        CheckoutAbort = "checkout-abort", "end the check-out (stop; a paused rest is discarded, 0xFF)";
    }
}

/// The word that removes a binding in a profile.
pub const UNBIND: &str = "none";

/// What binds a key to a profile's macro: `"f8" = "macro:park"`.
pub const MACRO_PREFIX: &str = "macro:";

/// jogterm's default keys (`config/keys.toml`).
pub const DEFAULT_KEYS: &str = include_str!("../../config/keys.toml");

/// mode -> key -> action, and the actions each mode has.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keymap {
    modes: BTreeMap<Mode, ModeKeys>,
}

#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct ModeKeys {
    /// The actions a key may be bound to in this mode, in the help's order.
    actions: Vec<Action>,
    keys: BTreeMap<KeyChord, Action>,
    /// Keys bound to a profile's macros, by name (mode `main` only); a key
    /// is in `keys` or here, never in both.
    macros: BTreeMap<KeyChord, String>,
}

/// One line of the help: the keys bound to an action in a mode.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HelpEntry {
    pub keys: Vec<KeyChord>,
    pub action: Action,
}

/// The default keys as `config/keys.toml` writes them: mode -> action ->
/// keys. The spans keep the order of the lines, which TOML tables do not.
type DefaultTable = BTreeMap<String, BTreeMap<String, toml::Spanned<Vec<String>>>>;

impl Keymap {
    /// jogterm's default keys. An error here is a mistake in
    /// `config/keys.toml` (a test loads it), named with its line.
    pub fn builtin() -> Result<Keymap, ConfigError> {
        Keymap::from_defaults(&Source {
            origin: Origin::Embedded("keys"),
            text: DEFAULT_KEYS.to_string(),
        })
    }

    /// A keymap from a table in the form of `config/keys.toml`: every mode,
    /// each with every action it has and that action's keys.
    fn from_defaults(file: &Source) -> Result<Keymap, ConfigError> {
        let table: DefaultTable = source::deserialize_text(file)?;
        let fail = |path: &[&str], message: String| {
            let key: Vec<String> = path.iter().map(|s| s.to_string()).collect();
            ConfigError::at_key(file, &key, message)
        };
        let mut modes = BTreeMap::new();
        for (mode_name, actions) in &table {
            let mode = Mode::from_name(mode_name).ok_or_else(|| {
                fail(
                    &[mode_name],
                    format!("unknown key mode `{mode_name}`: expected {}", mode_names()),
                )
            })?;
            let mut lines: Vec<(&String, &toml::Spanned<Vec<String>>)> = actions.iter().collect();
            lines.sort_by_key(|(_, keys)| keys.span().start);
            let mut entry = ModeKeys::default();
            for (action_name, keys) in lines {
                let path = [mode_name.as_str(), action_name.as_str()];
                let action = Action::from_name(action_name)
                    .ok_or_else(|| fail(&path, format!("unknown action `{action_name}`")))?;
                entry.actions.push(action);
                for key_text in keys.get_ref() {
                    let chord =
                        KeyChord::parse(key_text).map_err(|e| fail(&path, e.to_string()))?;
                    if let Some(other) = entry.keys.insert(chord, action) {
                        return Err(fail(
                            &path,
                            format!(
                                "`{key_text}` is bound twice in mode `{mode}`: to `{other}` and `{action}`"
                            ),
                        ));
                    }
                }
            }
            modes.insert(mode, entry);
        }
        if let Some(missing) = Mode::ALL.into_iter().find(|m| !modes.contains_key(m)) {
            return Err(ConfigError::new(
                file.origin.clone(),
                format!("no table for key mode `{missing}`"),
            ));
        }
        let map = Keymap { modes };
        if map.lookup(Mode::Safety, &KeyChord::SPACE) != Some(Action::Stop) {
            return Err(fail(
                &["safety"],
                "Space must stop: `stop = [\"space\"]`".to_string(),
            ));
        }
        // A stop key is looked up before every mode: bound in another mode
        // too, that binding could never be reached.
        for (stop, _) in map.bindings(Mode::Safety) {
            for mode in Mode::ALL.into_iter().filter(|m| *m != Mode::Safety) {
                if let Some(action) = map.lookup(mode, &stop) {
                    return Err(fail(
                        &[mode.name(), action.name()],
                        format!(
                            "`{stop}` is a stop key ([safety]) and never reaches mode `{mode}`"
                        ),
                    ));
                }
            }
        }
        Ok(map)
    }

    /// The actions a key may be bound to in `mode`, in the help's order.
    pub fn actions(&self, mode: Mode) -> &[Action] {
        self.modes.get(&mode).map_or(&[], |m| m.actions.as_slice())
    }

    /// The action `key` is bound to in `mode`.
    pub fn lookup(&self, mode: Mode, key: &KeyChord) -> Option<Action> {
        self.modes.get(&mode).and_then(|m| m.keys.get(key)).copied()
    }

    /// The macro `key` is bound to in `mode` (`"macro:park"` in a
    /// profile's `[keys.main]`).
    pub fn lookup_macro(&self, mode: Mode, key: &KeyChord) -> Option<&str> {
        self.modes
            .get(&mode)
            .and_then(|m| m.macros.get(key))
            .map(String::as_str)
    }

    /// The keys bound to the macro `name` in `mode`, in key order.
    pub fn keys_for_macro(&self, mode: Mode, name: &str) -> Vec<KeyChord> {
        self.modes.get(&mode).map_or(Vec::new(), |m| {
            m.macros
                .iter()
                .filter(|(_, n)| n.as_str() == name)
                .map(|(k, _)| *k)
                .collect()
        })
    }

    /// Every binding of `mode`, by key.
    pub fn bindings(&self, mode: Mode) -> impl Iterator<Item = (KeyChord, Action)> + '_ {
        self.modes
            .get(&mode)
            .into_iter()
            .flat_map(|m| m.keys.iter().map(|(k, a)| (*k, *a)))
    }

    /// The keys bound to `action` in `mode`, in key order.
    pub fn keys_for(&self, mode: Mode, action: Action) -> Vec<KeyChord> {
        self.bindings(mode)
            .filter(|(_, a)| *a == action)
            .map(|(k, _)| k)
            .collect()
    }

    /// The first key for `action` in `mode`, for hints (`Space stop`).
    pub fn key_for(&self, mode: Mode, action: Action) -> Option<KeyChord> {
        // Prefer a plain key (what an operator types first), and among
        // those one that is not a letter (`Down` over `j`, `?` over nothing).
        let keys = self.keys_for(mode, action);
        let plain = |k: &&KeyChord| !k.ctrl && !k.alt;
        let letter = |k: &&KeyChord| matches!(k.code, KeyCode::Char(c) if c.is_ascii_alphabetic());
        keys.iter()
            .filter(plain)
            .find(|k| !letter(k))
            .or_else(|| keys.iter().find(plain))
            .or(keys.first())
            .copied()
    }

    /// The help for `mode`: one entry per action bound, in the mode's action
    /// order.
    pub fn help(&self, mode: Mode) -> Vec<HelpEntry> {
        self.actions(mode)
            .iter()
            .filter_map(|&action| {
                let keys = self.keys_for(mode, action);
                (!keys.is_empty()).then_some(HelpEntry { keys, action })
            })
            .collect()
    }

    /// Apply a profile's `[keys]` table: `mode -> key -> action` (or
    /// `"none"` to unbind, or in mode `main` `"macro:NAME"` for one of
    /// `macros`, the profile's macro names). `sources` are the profile's
    /// files, most specific first, so an error names the line that caused
    /// it.
    pub fn with_overrides(
        mut self,
        table: &BTreeMap<String, BTreeMap<String, String>>,
        macros: &[&str],
        sources: &[&Source],
    ) -> Result<Keymap, ConfigError> {
        let fail = |path: &[&str], message: String| {
            let key: Vec<String> = path.iter().map(|s| s.to_string()).collect();
            source::error_for_key(sources, &key, message)
        };
        // Parse everything first, so the safety keys are known before other
        // modes are checked against them.
        let mut parsed: Vec<(Mode, &str, KeyChord, Option<Action>)> = Vec::new();
        let mut macro_keys: Vec<(&str, KeyChord, &str)> = Vec::new();
        for (mode_name, keys) in table {
            let mode = Mode::from_name(mode_name).ok_or_else(|| {
                fail(
                    &["keys", mode_name],
                    format!("unknown key mode `{mode_name}`: expected {}", mode_names()),
                )
            })?;
            for (key_text, action_name) in keys {
                let path = ["keys", mode_name.as_str(), key_text.as_str()];
                let chord = KeyChord::parse(key_text).map_err(|e| fail(&path, e.to_string()))?;
                if let Some(name) = action_name.strip_prefix(MACRO_PREFIX) {
                    if mode != Mode::Main {
                        return Err(fail(
                            &path,
                            format!(
                                "macros are bound in [keys.main], not in mode `{mode}` \
                                 (they run from the machine screen)"
                            ),
                        ));
                    }
                    if !macros.contains(&name) {
                        let known = if macros.is_empty() {
                            "the profile has no [macros]".to_string()
                        } else {
                            format!("expected one of {}", macros.join(", "))
                        };
                        return Err(fail(&path, format!("no macro `{name}`: {known}")));
                    }
                    macro_keys.push((key_text, chord, name));
                    continue;
                }
                let action = if action_name == UNBIND {
                    None
                } else {
                    let action = Action::from_name(action_name).ok_or_else(|| {
                        fail(
                            &path,
                            format!(
                                "unknown action `{action_name}` in mode `{mode}`: expected {}, \
                                 or `{UNBIND}` to unbind",
                                self.action_list(mode)
                            ),
                        )
                    })?;
                    if !self.actions(mode).contains(&action) {
                        return Err(fail(
                            &path,
                            format!(
                                "action `{action}` does not exist in mode `{mode}`: expected {}",
                                self.action_list(mode)
                            ),
                        ));
                    }
                    Some(action)
                };
                if mode == Mode::Safety && chord == KeyChord::SPACE && action != Some(Action::Stop)
                {
                    return Err(fail(
                        &path,
                        "Space is the stop key and stays one; add other stop keys beside it"
                            .to_string(),
                    ));
                }
                parsed.push((mode, key_text, chord, action));
            }
        }
        for (mode, _, chord, action) in &parsed {
            let entry = self.modes.entry(*mode).or_default();
            entry.macros.remove(chord);
            match action {
                Some(a) => entry.keys.insert(*chord, *a),
                None => entry.keys.remove(chord),
            };
        }
        for (_, chord, name) in &macro_keys {
            let entry = self.modes.entry(Mode::Main).or_default();
            entry.keys.remove(chord);
            entry.macros.insert(*chord, (*name).to_string());
        }
        // A stop key reaches no other mode: a binding the user wrote there
        // is a mistake; a default one simply gives way.
        let safety: Vec<KeyChord> = self.bindings(Mode::Safety).map(|(k, _)| k).collect();
        for (mode, key_text, chord, action) in &parsed {
            if *mode != Mode::Safety && action.is_some() && safety.contains(chord) {
                return Err(fail(
                    &["keys", mode.name(), key_text],
                    format!(
                        "`{key_text}` is a stop key ([keys.safety]) and never reaches mode `{mode}`"
                    ),
                ));
            }
        }
        for (key_text, chord, _) in &macro_keys {
            if safety.contains(chord) {
                return Err(fail(
                    &["keys", Mode::Main.name(), key_text],
                    format!("`{key_text}` is a stop key ([keys.safety]) and runs no macro"),
                ));
            }
        }
        for (mode, map) in self.modes.iter_mut() {
            if *mode != Mode::Safety {
                map.keys.retain(|k, _| !safety.contains(k));
            }
        }
        Ok(self)
    }

    fn action_list(&self, mode: Mode) -> String {
        self.actions(mode)
            .iter()
            .map(|a| a.name())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

fn mode_names() -> String {
    Mode::ALL
        .iter()
        .map(|m| m.name())
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Origin;

    fn source(text: &str) -> Source {
        Source {
            origin: Origin::File("mill.toml".into()),
            text: text.to_string(),
        }
    }

    fn builtin() -> Keymap {
        Keymap::builtin().expect("config/keys.toml")
    }

    fn apply(text: &str) -> Result<Keymap, ConfigError> {
        let src = source(text);
        let table: toml::Table = toml::from_str(text).expect("toml");
        let keys: BTreeMap<String, BTreeMap<String, String>> = table
            .get("keys")
            .cloned()
            .map(|v| v.try_into().expect("keys table"))
            .unwrap_or_default();
        Keymap::builtin()
            .expect("built-in keys")
            .with_overrides(&keys, &["park", "probe"], &[&src])
    }

    #[test]
    fn macros_are_bound_in_the_main_mode_by_name() {
        let map =
            apply("[keys.main]\n\"f8\" = \"macro:park\"\n\"h\" = \"macro:probe\"\n").expect("ok");
        let f8 = KeyChord::parse("f8").expect("key");
        assert_eq!(map.lookup_macro(Mode::Main, &f8), Some("park"));
        // A key runs a macro or an action, never both.
        assert_eq!(map.lookup(Mode::Main, &KeyChord::char('h')), None);
        assert_eq!(
            map.lookup_macro(Mode::Main, &KeyChord::char('h')),
            Some("probe")
        );
        assert_eq!(map.keys_for_macro(Mode::Main, "park"), [f8]);
        let cases = [
            (
                "[keys.main]\n\"f8\" = \"macro:fly\"\n",
                2,
                "no macro `fly`: expected one of park, probe",
            ),
            (
                "[keys.jog]\n\"f8\" = \"macro:park\"\n",
                2,
                "macros are bound in [keys.main]",
            ),
            (
                "[keys.main]\n\"esc\" = \"macro:park\"\n[keys.safety]\n\"esc\" = \"stop\"\n",
                2,
                "runs no macro",
            ),
        ];
        for (text, line, needle) in cases {
            let err = apply(text).expect_err(text);
            assert_eq!(err.line, Some(line), "{text}: {err}");
            assert!(err.message.contains(needle), "{text}: {err}");
        }
    }

    #[test]
    fn every_default_binding_is_an_action_of_its_mode() {
        let map = builtin();
        for mode in Mode::ALL {
            for (key, action) in map.bindings(mode) {
                assert!(
                    map.actions(mode).contains(&action),
                    "{mode}: {key} -> {action}"
                );
            }
        }
        assert_eq!(
            map.lookup(Mode::Safety, &KeyChord::SPACE),
            Some(Action::Stop)
        );
        assert_eq!(
            map.lookup(Mode::Main, &KeyChord::plain(KeyCode::Esc)),
            Some(Action::Stop)
        );
    }

    #[test]
    fn names_are_unique_and_round_trip() {
        for action in Action::ALL {
            assert_eq!(Action::from_name(action.name()), Some(action));
        }
        for mode in Mode::ALL {
            assert_eq!(Mode::from_name(mode.name()), Some(mode));
        }
    }

    #[test]
    fn overrides_bind_and_unbind() {
        let map = apply("[keys.main]\n\"x\" = \"home\"\n\"h\" = \"none\"\n").expect("ok");
        assert_eq!(
            map.lookup(Mode::Main, &KeyChord::char('x')),
            Some(Action::Home)
        );
        assert_eq!(map.lookup(Mode::Main, &KeyChord::char('h')), None);
    }

    #[test]
    fn a_new_stop_key_takes_the_key_from_every_other_mode() {
        let map = apply("[keys.safety]\n\"ctrl-c\" = \"stop\"\n").expect("ok");
        assert_eq!(
            map.lookup(Mode::Safety, &KeyChord::ctrl('c')),
            Some(Action::Stop)
        );
        assert_eq!(map.lookup(Mode::Main, &KeyChord::ctrl('c')), None);
        let err = apply("[keys.safety]\n\"x\" = \"stop\"\n[keys.main]\n\"x\" = \"home\"\n")
            .expect_err("conflict");
        assert_eq!(err.line, Some(4), "{err}");
        assert!(err.message.contains("stop key"), "{err}");
    }

    #[test]
    fn errors_name_the_profile_line() {
        let cases = [
            ("[keys.jogg]\n\"x\" = \"stop\"\n", 1, "unknown key mode"),
            (
                "[keys.main]\n\"x\" = \"stop\"\n\"ctrl-\" = \"home\"\n",
                3,
                "not a key",
            ),
            ("[keys.main]\n\"x\" = \"fly\"\n", 2, "unknown action `fly`"),
            (
                "\n[keys.io]\n\"x\" = \"home\"\n",
                3,
                "does not exist in mode `io`",
            ),
            (
                "[keys.safety]\n\"space\" = \"none\"\n",
                2,
                "Space is the stop key",
            ),
        ];
        for (text, line, needle) in cases {
            let err = apply(text).expect_err(text);
            assert_eq!(err.line, Some(line), "{text}: {err}");
            assert!(err.message.contains(needle), "{text}: {err}");
            assert!(err.to_string().starts_with("mill.toml:"), "{err}");
        }
    }

    /// `docs/ui.md` has a table of the default keys; it must match them
    /// both ways.
    #[test]
    fn the_documented_key_table_is_the_default_keymap() {
        let doc = include_str!("../../docs/ui.md");
        let mut documented = Vec::new();
        for row in doc.lines().filter(|l| l.starts_with("| ")) {
            let cells: Vec<&str> = row.trim_matches('|').split(" | ").map(str::trim).collect();
            let (Some(mode), Some(keys), Some(action)) = (
                cells.first().and_then(|m| Mode::from_name(m)),
                cells.get(1),
                cells
                    .get(2)
                    .and_then(|a| Action::from_name(a.trim_matches('`'))),
            ) else {
                continue;
            };
            for key in keys.split(", ") {
                documented.push((mode, key.to_string(), action));
            }
        }
        let map = builtin();
        let mut actual = Vec::new();
        for mode in Mode::ALL {
            for (key, action) in map.bindings(mode) {
                actual.push((mode, key.to_string(), action));
            }
        }
        for binding in &actual {
            assert!(
                documented.contains(binding),
                "not in docs/ui.md: {binding:?}"
            );
        }
        for binding in &documented {
            assert!(
                actual.contains(binding),
                "docs/ui.md lists a key that is not bound: {binding:?}"
            );
        }
    }

    #[test]
    fn help_lists_every_binding() {
        let map = builtin();
        for mode in Mode::ALL {
            let help = map.help(mode);
            for (key, action) in map.bindings(mode) {
                assert!(
                    help.iter()
                        .any(|e| e.action == action && e.keys.contains(&key)),
                    "{mode}: {key} -> {action} missing"
                );
            }
        }
    }

    fn defaults(text: &str) -> Result<Keymap, ConfigError> {
        Keymap::from_defaults(&source(text))
    }

    /// Every mode's table with one made-up line per mode, so a test can
    /// change one table and keep the others valid.
    fn all_modes_but(skip: Mode, extra: &str) -> String {
        let mut text = String::new();
        for mode in Mode::ALL.into_iter().filter(|m| *m != skip) {
            let line = if mode == Mode::Safety {
                "stop = [\"space\"]"
            } else {
                "cancel = []"
            };
            text += &format!("[{mode}]\n{line}\n");
        }
        text + extra
    }

    #[test]
    fn the_order_of_the_lines_is_the_order_of_the_help() {
        let text = all_modes_but(
            Mode::Confirm,
            "[confirm]\ncancel = [\"n\"]\nconfirm = [\"y\", \"enter\"]\n",
        );
        let map = defaults(&text).expect("valid");
        assert_eq!(
            map.actions(Mode::Confirm),
            [Action::Cancel, Action::Confirm]
        );
        let help: Vec<Action> = map.help(Mode::Confirm).iter().map(|e| e.action).collect();
        assert_eq!(help, [Action::Cancel, Action::Confirm]);
        // An action without keys is still one of the mode's: a profile may
        // bind it.
        assert_eq!(map.actions(Mode::Axes), [Action::Cancel]);
        assert!(map.help(Mode::Axes).is_empty());
    }

    #[test]
    fn the_built_in_table_lists_the_modes_in_the_help_order_and_uses_every_action() {
        let starts: Vec<usize> = Mode::ALL
            .iter()
            .map(|m| {
                DEFAULT_KEYS
                    .find(&format!("\n[{m}]\n"))
                    .unwrap_or_else(|| panic!("no [{m}] in config/keys.toml"))
            })
            .collect();
        assert!(starts.is_sorted(), "config/keys.toml: modes out of order");
        let map = builtin();
        for action in Action::ALL {
            assert!(
                Mode::ALL.iter().any(|m| map.actions(*m).contains(&action)),
                "`{action}` is in no mode of config/keys.toml"
            );
        }
    }

    #[test]
    fn mistakes_in_the_default_table_name_their_line() {
        let with_main = |main: &str| all_modes_but(Mode::Main, &format!("[main]\n{main}"));
        let lines_before_main = 2 * (Mode::ALL.len() - 1);
        let cases = [
            (
                with_main("quit = [\"q\"]\nfly = [\"f\"]\n"),
                3,
                "unknown action `fly`",
            ),
            (with_main("quit = [\"ctrl-\"]\n"), 2, "not a key"),
            (
                with_main("quit = [\"q\"]\nhelp = [\"?\", \"q\"]\n"),
                3,
                "bound twice in mode `main`: to `quit` and `help`",
            ),
            (
                with_main("quit = [\"space\"]\n"),
                2,
                "stop key ([safety]) and never reaches mode `main`",
            ),
        ];
        for (text, line, needle) in cases {
            let err = defaults(&text).expect_err(&text);
            assert_eq!(err.line, Some(lines_before_main + line), "{text}: {err}");
            assert!(err.message.contains(needle), "{text}: {err}");
        }
        let err = defaults(&all_modes_but(Mode::Io, "[jogg]\nstop = []\n")).expect_err("mode");
        assert_eq!(err.line, Some(lines_before_main + 1), "{err}");
        assert!(err.message.contains("unknown key mode `jogg`"), "{err}");
        let err = defaults(&all_modes_but(Mode::Io, "")).expect_err("missing");
        assert!(err.message.contains("no table for key mode `io`"), "{err}");
        let text = all_modes_but(Mode::Safety, "[safety]\nstop = [\"esc\"]\n");
        let err = defaults(&text).expect_err("space");
        assert!(err.message.contains("Space must stop"), "{err}");
        let err = defaults("[main\n").expect_err("syntax");
        assert_eq!(err.line, Some(1), "{err}");
    }
}
