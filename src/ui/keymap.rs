//! The keymap as data: mode -> key -> action, with jogterm's defaults, the
//! profile's `[keys]` overrides (errors placed on the profile line that
//! caused them), and the listing the help overlay shows.
//!
//! Routing (see `update::route_key`): the `safety` mode is looked up first for
//! every key in every state, then the open popup's mode, then the focused
//! panel's mode, then `main`. So a stop key can never be swallowed.

use std::collections::BTreeMap;
use std::fmt;

use super::key::{KeyChord, KeyCode};
use crate::config::{ConfigError, Source, source};

/// A context in which keys mean something.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Mode {
    /// Looked up before anything else, whatever has focus or is open.
    Safety,
    /// The confirmation popup.
    Confirm,
    /// The help overlay.
    Help,
    /// The I/O panel has focus.
    Io,
    /// The traffic console's command line has focus.
    Console,
    /// The simulator panel has focus.
    Sim,
    /// The program editor has focus (the program screen is shown).
    Editor,
    /// A form of the editor (file name, find, go to, arc, taught dwell or
    /// output) is open.
    Form,
    /// The question about unsaved changes is open.
    Unsaved,
    /// The jog keypad has focus.
    Jog,
    /// The go-to prompt.
    GoTo,
    /// The choice of an axis (reference run or work zero of one axis).
    Axes,
    /// The port timeline is shown.
    Timeline,
    /// Everywhere, after the focused panel has passed on the key.
    Main,
}

impl Mode {
    /// In the order the help lists them.
    pub const ALL: [Mode; 14] = [
        Mode::Safety,
        Mode::Main,
        Mode::Jog,
        Mode::Io,
        Mode::Console,
        Mode::Sim,
        Mode::Editor,
        Mode::Help,
        Mode::Confirm,
        Mode::Form,
        Mode::Unsaved,
        Mode::GoTo,
        Mode::Axes,
        Mode::Timeline,
    ];

    /// The name in a profile's `[keys.<mode>]` table.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Safety => "safety",
            Mode::Confirm => "confirm",
            Mode::Help => "help",
            Mode::Io => "io",
            Mode::Console => "console",
            Mode::Sim => "sim",
            Mode::Editor => "editor",
            Mode::Form => "form",
            Mode::Unsaved => "unsaved",
            Mode::Jog => "jog",
            Mode::GoTo => "goto",
            Mode::Axes => "axes",
            Mode::Timeline => "timeline",
            Mode::Main => "main",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Mode::Safety => "Always (before anything else)",
            Mode::Confirm => "Confirmation",
            Mode::Help => "This help",
            Mode::Io => "I/O panel (focused)",
            Mode::Console => "Console command line (focused; other characters are typed)",
            Mode::Sim => "Simulator panel (focused)",
            Mode::Editor => "Program editor (focused; other characters are typed)",
            Mode::Form => "Editor form (other characters are typed)",
            Mode::Unsaved => "Unsaved changes",
            Mode::Jog => "Jog keypad (focused)",
            Mode::GoTo => "Go-to prompt (other characters are typed)",
            Mode::Axes => "Choice of an axis",
            Mode::Timeline => "Port timeline (shown)",
            Mode::Main => "Main screen",
        }
    }

    pub fn from_name(name: &str) -> Option<Mode> {
        Mode::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The actions a key may be bound to in this mode.
    pub fn actions(self) -> &'static [Action] {
        use Action::*;
        match self {
            Mode::Safety => &[Stop],
            Mode::Confirm => &[Confirm, Cancel],
            Mode::Help => &[Close, ScrollUp, ScrollDown, PageUp, PageDown],
            Mode::Io => &[SelectPrev, SelectNext, GroupPrev, GroupNext, ToggleOutput],
            Mode::Console => &[
                Submit,
                HistoryPrev,
                HistoryNext,
                CursorLeft,
                CursorRight,
                CursorHome,
                CursorEnd,
                DeleteBack,
                DeleteForward,
                ClearLine,
            ],
            Mode::Sim => &[SelectPrev, SelectNext, SimToggle, SimOn, SimOff, SimPress],
            Mode::Editor => &[
                CloseEditor,
                CursorUp,
                CursorDown,
                CursorLeft,
                CursorRight,
                WordLeft,
                WordRight,
                CursorHome,
                CursorEnd,
                PageUp,
                PageDown,
                CursorTop,
                CursorBottom,
                NewLine,
                TypeBlank,
                DeleteBack,
                DeleteForward,
                DeleteLine,
                Undo,
                Redo,
                Save,
                SaveAs,
                Open,
                Find,
                FindNext,
                FindPrev,
                GoToLine,
                NextProblem,
                PrevProblem,
                ApplyFix,
                Format,
                Circle,
                JumpTarget,
                TogglePreview,
            ],
            Mode::Form => &[
                Submit,
                Cancel,
                NextField,
                PrevField,
                CursorLeft,
                CursorRight,
                CursorHome,
                CursorEnd,
                DeleteBack,
                DeleteForward,
                ClearLine,
                TypeBlank,
            ],
            Mode::Unsaved => &[Save, Discard, Cancel],
            Mode::Jog => &[
                JogXPlus,
                JogXMinus,
                JogYPlus,
                JogYMinus,
                JogZPlus,
                JogZMinus,
                JogAPlus,
                JogAMinus,
                JogXPlusYPlus,
                JogXMinusYPlus,
                JogXPlusYMinus,
                JogXMinusYMinus,
            ],
            Mode::GoTo => &[
                Submit,
                Cancel,
                CursorLeft,
                CursorRight,
                CursorHome,
                CursorEnd,
                DeleteBack,
                DeleteForward,
                ClearLine,
            ],
            Mode::Axes => &[AxisAll, AxisX, AxisY, AxisZ, AxisA, Cancel],
            Mode::Timeline => &[
                Timeline,
                TimeEarlier,
                TimeLater,
                TimeLive,
                ZoomIn,
                ZoomOut,
                ScrollUp,
                ScrollDown,
            ],
            Mode::Main => &[
                Stop,
                Quit,
                Help,
                FocusNext,
                FocusPrev,
                FocusConsole,
                Initialise,
                Home,
                HomeAxis,
                SetZero,
                ZeroAxis,
                GoTo,
                GoZero,
                Reset,
                JogKind,
                StepSmaller,
                StepLarger,
                SpeedSlower,
                SpeedFaster,
                TogglePolls,
                EditProgram,
                TeachAbsolute,
                TeachRelative,
                TeachDwell,
                TeachOutput,
                TeachSlower,
                TeachFaster,
                Upload,
                RunProgram,
                Timeline,
            ],
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Everything a key can do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Action {
    Stop,
    Quit,
    Help,
    FocusNext,
    FocusPrev,
    FocusConsole,
    Initialise,
    Home,
    SetZero,
    Reset,
    StepSmaller,
    StepLarger,
    SpeedSlower,
    SpeedFaster,
    TogglePolls,
    SelectPrev,
    SelectNext,
    GroupPrev,
    GroupNext,
    ToggleOutput,
    Submit,
    HistoryPrev,
    HistoryNext,
    CursorLeft,
    CursorRight,
    CursorHome,
    CursorEnd,
    DeleteBack,
    DeleteForward,
    ClearLine,
    SimToggle,
    SimOn,
    SimOff,
    SimPress,
    Confirm,
    Cancel,
    Close,
    ScrollUp,
    ScrollDown,
    PageUp,
    PageDown,
    EditProgram,
    TeachAbsolute,
    TeachRelative,
    TeachDwell,
    TeachOutput,
    TeachSlower,
    TeachFaster,
    Upload,
    RunProgram,
    CloseEditor,
    CursorUp,
    CursorDown,
    WordLeft,
    WordRight,
    CursorTop,
    CursorBottom,
    NewLine,
    TypeBlank,
    DeleteLine,
    Undo,
    Redo,
    Save,
    SaveAs,
    Open,
    Find,
    FindNext,
    FindPrev,
    GoToLine,
    NextProblem,
    PrevProblem,
    ApplyFix,
    Format,
    Circle,
    JumpTarget,
    TogglePreview,
    NextField,
    PrevField,
    Discard,
    JogXPlus,
    JogXMinus,
    JogYPlus,
    JogYMinus,
    JogZPlus,
    JogZMinus,
    JogAPlus,
    JogAMinus,
    JogXPlusYPlus,
    JogXMinusYPlus,
    JogXPlusYMinus,
    JogXMinusYMinus,
    JogKind,
    GoTo,
    GoZero,
    HomeAxis,
    ZeroAxis,
    AxisAll,
    AxisX,
    AxisY,
    AxisZ,
    AxisA,
    Timeline,
    TimeEarlier,
    TimeLater,
    TimeLive,
    ZoomIn,
    ZoomOut,
}

impl Action {
    pub const ALL: [Action; 107] = [
        Action::Stop,
        Action::Quit,
        Action::Help,
        Action::FocusNext,
        Action::FocusPrev,
        Action::FocusConsole,
        Action::Initialise,
        Action::Home,
        Action::SetZero,
        Action::Reset,
        Action::StepSmaller,
        Action::StepLarger,
        Action::SpeedSlower,
        Action::SpeedFaster,
        Action::TogglePolls,
        Action::SelectPrev,
        Action::SelectNext,
        Action::GroupPrev,
        Action::GroupNext,
        Action::ToggleOutput,
        Action::Submit,
        Action::HistoryPrev,
        Action::HistoryNext,
        Action::CursorLeft,
        Action::CursorRight,
        Action::CursorHome,
        Action::CursorEnd,
        Action::DeleteBack,
        Action::DeleteForward,
        Action::ClearLine,
        Action::SimToggle,
        Action::SimOn,
        Action::SimOff,
        Action::SimPress,
        Action::Confirm,
        Action::Cancel,
        Action::Close,
        Action::ScrollUp,
        Action::ScrollDown,
        Action::PageUp,
        Action::PageDown,
        Action::EditProgram,
        Action::TeachAbsolute,
        Action::TeachRelative,
        Action::TeachDwell,
        Action::TeachOutput,
        Action::TeachSlower,
        Action::TeachFaster,
        Action::Upload,
        Action::RunProgram,
        Action::CloseEditor,
        Action::CursorUp,
        Action::CursorDown,
        Action::WordLeft,
        Action::WordRight,
        Action::CursorTop,
        Action::CursorBottom,
        Action::NewLine,
        Action::TypeBlank,
        Action::DeleteLine,
        Action::Undo,
        Action::Redo,
        Action::Save,
        Action::SaveAs,
        Action::Open,
        Action::Find,
        Action::FindNext,
        Action::FindPrev,
        Action::GoToLine,
        Action::NextProblem,
        Action::PrevProblem,
        Action::ApplyFix,
        Action::Format,
        Action::Circle,
        Action::JumpTarget,
        Action::TogglePreview,
        Action::NextField,
        Action::PrevField,
        Action::Discard,
        Action::JogXPlus,
        Action::JogXMinus,
        Action::JogYPlus,
        Action::JogYMinus,
        Action::JogZPlus,
        Action::JogZMinus,
        Action::JogAPlus,
        Action::JogAMinus,
        Action::JogXPlusYPlus,
        Action::JogXMinusYPlus,
        Action::JogXPlusYMinus,
        Action::JogXMinusYMinus,
        Action::JogKind,
        Action::GoTo,
        Action::GoZero,
        Action::HomeAxis,
        Action::ZeroAxis,
        Action::AxisAll,
        Action::AxisX,
        Action::AxisY,
        Action::AxisZ,
        Action::AxisA,
        Action::Timeline,
        Action::TimeEarlier,
        Action::TimeLater,
        Action::TimeLive,
        Action::ZoomIn,
        Action::ZoomOut,
    ];

    /// The name a profile binds it by.
    pub fn name(self) -> &'static str {
        match self {
            Action::Stop => "stop",
            Action::Quit => "quit",
            Action::Help => "help",
            Action::FocusNext => "focus-next",
            Action::FocusPrev => "focus-prev",
            Action::FocusConsole => "focus-console",
            Action::Initialise => "initialise",
            Action::Home => "home",
            Action::SetZero => "set-zero",
            Action::Reset => "reset",
            Action::StepSmaller => "step-smaller",
            Action::StepLarger => "step-larger",
            Action::SpeedSlower => "speed-slower",
            Action::SpeedFaster => "speed-faster",
            Action::TogglePolls => "toggle-polls",
            Action::SelectPrev => "select-prev",
            Action::SelectNext => "select-next",
            Action::GroupPrev => "group-prev",
            Action::GroupNext => "group-next",
            Action::ToggleOutput => "toggle-output",
            Action::Submit => "submit",
            Action::HistoryPrev => "history-prev",
            Action::HistoryNext => "history-next",
            Action::CursorLeft => "cursor-left",
            Action::CursorRight => "cursor-right",
            Action::CursorHome => "cursor-home",
            Action::CursorEnd => "cursor-end",
            Action::DeleteBack => "delete-back",
            Action::DeleteForward => "delete-forward",
            Action::ClearLine => "clear-line",
            Action::SimToggle => "sim-toggle",
            Action::SimOn => "sim-on",
            Action::SimOff => "sim-off",
            Action::SimPress => "sim-press",
            Action::Confirm => "confirm",
            Action::Cancel => "cancel",
            Action::Close => "close",
            Action::ScrollUp => "scroll-up",
            Action::ScrollDown => "scroll-down",
            Action::PageUp => "page-up",
            Action::PageDown => "page-down",
            Action::EditProgram => "edit-program",
            Action::TeachAbsolute => "teach-absolute",
            Action::TeachRelative => "teach-relative",
            Action::TeachDwell => "teach-dwell",
            Action::TeachOutput => "teach-output",
            Action::TeachSlower => "teach-slower",
            Action::TeachFaster => "teach-faster",
            Action::Upload => "upload",
            Action::RunProgram => "run-program",
            Action::CloseEditor => "close-editor",
            Action::CursorUp => "cursor-up",
            Action::CursorDown => "cursor-down",
            Action::WordLeft => "word-left",
            Action::WordRight => "word-right",
            Action::CursorTop => "cursor-top",
            Action::CursorBottom => "cursor-bottom",
            Action::NewLine => "new-line",
            Action::TypeBlank => "type-blank",
            Action::DeleteLine => "delete-line",
            Action::Undo => "undo",
            Action::Redo => "redo",
            Action::Save => "save",
            Action::SaveAs => "save-as",
            Action::Open => "open",
            Action::Find => "find",
            Action::FindNext => "find-next",
            Action::FindPrev => "find-prev",
            Action::GoToLine => "go-to-line",
            Action::NextProblem => "next-problem",
            Action::PrevProblem => "prev-problem",
            Action::ApplyFix => "apply-fix",
            Action::Format => "format",
            Action::Circle => "circle",
            Action::JumpTarget => "jump-target",
            Action::TogglePreview => "toggle-preview",
            Action::NextField => "next-field",
            Action::PrevField => "prev-field",
            Action::Discard => "discard",
            Action::JogXPlus => "jog-x-plus",
            Action::JogXMinus => "jog-x-minus",
            Action::JogYPlus => "jog-y-plus",
            Action::JogYMinus => "jog-y-minus",
            Action::JogZPlus => "jog-z-plus",
            Action::JogZMinus => "jog-z-minus",
            Action::JogAPlus => "jog-a-plus",
            Action::JogAMinus => "jog-a-minus",
            Action::JogXPlusYPlus => "jog-x-plus-y-plus",
            Action::JogXMinusYPlus => "jog-x-minus-y-plus",
            Action::JogXPlusYMinus => "jog-x-plus-y-minus",
            Action::JogXMinusYMinus => "jog-x-minus-y-minus",
            Action::JogKind => "jog-kind",
            Action::GoTo => "go-to",
            Action::GoZero => "go-zero",
            Action::HomeAxis => "home-axis",
            Action::ZeroAxis => "zero-axis",
            Action::AxisAll => "axis-all",
            Action::AxisX => "axis-x",
            Action::AxisY => "axis-y",
            Action::AxisZ => "axis-z",
            Action::AxisA => "axis-a",
            Action::Timeline => "timeline",
            Action::TimeEarlier => "earlier",
            Action::TimeLater => "later",
            Action::TimeLive => "live",
            Action::ZoomIn => "zoom-in",
            Action::ZoomOut => "zoom-out",
        }
    }

    /// What it does, for the help.
    pub fn description(self) -> &'static str {
        match self {
            Action::Stop => "stop all motion",
            Action::Quit => "stop, close the port and quit",
            Action::Help => "show this help",
            Action::FocusNext => "focus the next panel",
            Action::FocusPrev => "focus the previous panel",
            Action::FocusConsole => "type a raw command",
            Action::Initialise => "initialise the controller",
            Action::Home => "reference run of all axes (asks first)",
            Action::SetZero => "make the current position the work zero",
            Action::Reset => "reset the controller (asks first)",
            Action::StepSmaller => "smaller jog step",
            Action::StepLarger => "larger jog step",
            Action::SpeedSlower => "slower jog speed",
            Action::SpeedFaster => "faster jog speed",
            Action::TogglePolls => "show or hide poll traffic",
            Action::SelectPrev => "previous item",
            Action::SelectNext => "next item",
            Action::GroupPrev => "previous port",
            Action::GroupNext => "next port",
            Action::ToggleOutput => "switch the selected output (asks first if hazardous)",
            Action::Submit => "check and send the command",
            Action::HistoryPrev => "previous command from the history",
            Action::HistoryNext => "next command from the history",
            Action::CursorLeft => "cursor left",
            Action::CursorRight => "cursor right",
            Action::CursorHome => "cursor to the start",
            Action::CursorEnd => "cursor to the end",
            Action::DeleteBack => "delete before the cursor",
            Action::DeleteForward => "delete at the cursor",
            Action::ClearLine => "clear the line",
            Action::SimToggle => "flip the selected simulator input",
            Action::SimOn => "set the selected input on / closed",
            Action::SimOff => "set the selected input off / open",
            Action::SimPress => "press and release the selected button",
            Action::Confirm => "yes, do it",
            Action::Cancel => "no, cancel",
            Action::Close => "close",
            Action::ScrollUp => "scroll up",
            Action::ScrollDown => "scroll down",
            Action::PageUp => "page up",
            Action::PageDown => "page down",
            Action::EditProgram => "show or hide the program editor",
            Action::TeachAbsolute => "teach: absolute move to the current position",
            Action::TeachRelative => "teach: relative move from the point taught before",
            Action::TeachDwell => "teach: a dwell (asks for the time)",
            Action::TeachOutput => "teach: set an output (asks which)",
            Action::TeachSlower => "slower speed for taught moves",
            Action::TeachFaster => "faster speed for taught moves",
            Action::Upload => "upload the program (asks to erase a stored one)",
            Action::RunProgram => "start the stored program (asks first)",
            Action::CloseEditor => "back to the machine screen",
            Action::CursorUp => "cursor up",
            Action::CursorDown => "cursor down",
            Action::WordLeft => "cursor to the previous word",
            Action::WordRight => "cursor to the next word",
            Action::CursorTop => "cursor to the first line",
            Action::CursorBottom => "cursor to the last line",
            Action::NewLine => "split the line",
            Action::TypeBlank => "type a blank (Space stops and never types)",
            Action::DeleteLine => "delete the line",
            Action::Undo => "undo",
            Action::Redo => "redo",
            Action::Save => "save the program",
            Action::SaveAs => "save the program under another name",
            Action::Open => "open a program file",
            Action::Find => "find text",
            Action::FindNext => "find the next match",
            Action::FindPrev => "find the previous match",
            Action::GoToLine => "go to a line or (#N) a command",
            Action::NextProblem => "next error or warning",
            Action::PrevProblem => "previous error or warning",
            Action::ApplyFix => "apply the suggested fix on the line",
            Action::Format => "format the program (canonical spelling)",
            Action::Circle => "insert an arc or helix (f and y/w from radius and angles)",
            Action::JumpTarget => "go to where the line's jump or loop leads",
            Action::TogglePreview => "toolpath preview: XY and XZ, XY, XZ, off",
            Action::NextField => "next field",
            Action::PrevField => "previous field",
            Action::Discard => "discard the changes (kept aside in the recovery folder)",
            Action::JogXPlus => "jog X+ (step, or while held)",
            Action::JogXMinus => "jog X-",
            Action::JogYPlus => "jog Y+",
            Action::JogYMinus => "jog Y-",
            Action::JogZPlus => "jog Z+",
            Action::JogZMinus => "jog Z-",
            Action::JogAPlus => "jog A+",
            Action::JogAMinus => "jog A-",
            Action::JogXPlusYPlus => "jog diagonally X+ Y+",
            Action::JogXMinusYPlus => "jog diagonally X- Y+",
            Action::JogXPlusYMinus => "jog diagonally X+ Y-",
            Action::JogXMinusYMinus => "jog diagonally X- Y-",
            Action::JogKind => "switch between step and continuous jogging",
            Action::GoTo => "go to a typed position (work coordinates)",
            Action::GoZero => "go to the work zero (asks first)",
            Action::HomeAxis => "reference run of one axis",
            Action::ZeroAxis => "make the current position the work zero of one axis",
            Action::AxisAll => "all axes",
            Action::AxisX => "axis X",
            Action::AxisY => "axis Y",
            Action::AxisZ => "axis Z",
            Action::AxisA => "axis A",
            Action::Timeline => "show or hide the port timeline (every input change)",
            Action::TimeEarlier => "timeline: back in time",
            Action::TimeLater => "timeline: forward in time",
            Action::TimeLive => "timeline: follow the newest readings",
            Action::ZoomIn => "timeline: fewer milliseconds per column",
            Action::ZoomOut => "timeline: more milliseconds per column",
        }
    }

    pub fn from_name(name: &str) -> Option<Action> {
        Action::ALL.into_iter().find(|a| a.name() == name)
    }
}

impl fmt::Display for Action {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The word that removes a binding in a profile.
pub const UNBIND: &str = "none";

/// mode -> key -> action.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Keymap {
    modes: BTreeMap<Mode, BTreeMap<KeyChord, Action>>,
}

impl Default for Keymap {
    fn default() -> Self {
        use Action::*;
        use KeyCode as K;
        let p = KeyChord::plain;
        let c = KeyChord::char;
        let ctrl_key = |code| KeyChord {
            ctrl: true,
            ..KeyChord::plain(code)
        };
        let alt_key = |code| KeyChord {
            alt: true,
            ..KeyChord::plain(code)
        };
        let alt = |ch| alt_key(KeyCode::Char(ch));
        let shift = |code| KeyChord {
            shift: true,
            ..KeyChord::plain(code)
        };
        let defaults: &[(Mode, &[(KeyChord, Action)])] = &[
            (Mode::Safety, &[(KeyChord::SPACE, Stop)]),
            (
                Mode::Main,
                &[
                    (p(K::Esc), Stop),
                    (c('q'), Quit),
                    (KeyChord::ctrl('c'), Quit),
                    (c('?'), Help),
                    (p(K::F(1)), Help),
                    (p(K::Tab), FocusNext),
                    (p(K::BackTab), FocusPrev),
                    (c(':'), FocusConsole),
                    (c('i'), Initialise),
                    (c('h'), Home),
                    (c('H'), HomeAxis),
                    (c('z'), SetZero),
                    (c('Z'), ZeroAxis),
                    (c('g'), GoTo),
                    (c('G'), GoZero),
                    (KeyChord::ctrl('r'), Reset),
                    (c('c'), JogKind),
                    (c('['), StepSmaller),
                    (c(']'), StepLarger),
                    (c('-'), SpeedSlower),
                    (c('+'), SpeedFaster),
                    (c('='), SpeedFaster),
                    (c('p'), TogglePolls),
                    (p(K::F(2)), TogglePolls),
                    (c('e'), EditProgram),
                    (p(K::F(4)), EditProgram),
                    (c('t'), TeachAbsolute),
                    (c('T'), TeachRelative),
                    (c('d'), TeachDwell),
                    (c('o'), TeachOutput),
                    (c('<'), TeachSlower),
                    (c('>'), TeachFaster),
                    (p(K::F(5)), Upload),
                    (p(K::F(6)), RunProgram),
                    (c('w'), Timeline),
                    (p(K::F(7)), Timeline),
                ],
            ),
            (
                // Arrows X/Y, PgUp/PgDn Z, Home/End A: the keys the numeric
                // keypad sends with NumLock off, and its digits in the same
                // places with NumLock on (8 up, 4 left, 9 PgUp, 7 Home …),
                // so the keypad means the same either way. Diagonals on the
                // vi/roguelike corner keys y u b n.
                Mode::Jog,
                &[
                    (p(K::Right), JogXPlus),
                    (p(K::Left), JogXMinus),
                    (p(K::Up), JogYPlus),
                    (p(K::Down), JogYMinus),
                    (p(K::PageUp), JogZPlus),
                    (p(K::PageDown), JogZMinus),
                    (p(K::Home), JogAPlus),
                    (p(K::End), JogAMinus),
                    (c('6'), JogXPlus),
                    (c('4'), JogXMinus),
                    (c('8'), JogYPlus),
                    (c('2'), JogYMinus),
                    (c('9'), JogZPlus),
                    (c('3'), JogZMinus),
                    (c('7'), JogAPlus),
                    (c('1'), JogAMinus),
                    (c('u'), JogXPlusYPlus),
                    (c('y'), JogXMinusYPlus),
                    (c('n'), JogXPlusYMinus),
                    (c('b'), JogXMinusYMinus),
                ],
            ),
            (
                Mode::Io,
                &[
                    (p(K::Left), SelectPrev),
                    (p(K::Right), SelectNext),
                    (c('k'), GroupPrev),
                    (c('j'), GroupNext),
                    (p(K::Up), GroupPrev),
                    (p(K::Down), GroupNext),
                    (p(K::Enter), ToggleOutput),
                ],
            ),
            (
                Mode::Console,
                &[
                    (p(K::Enter), Submit),
                    (p(K::Up), HistoryPrev),
                    (p(K::Down), HistoryNext),
                    (p(K::Left), CursorLeft),
                    (p(K::Right), CursorRight),
                    (p(K::Home), CursorHome),
                    (p(K::End), CursorEnd),
                    (p(K::Backspace), DeleteBack),
                    (p(K::Delete), DeleteForward),
                    (KeyChord::ctrl('u'), ClearLine),
                ],
            ),
            (
                Mode::Sim,
                &[
                    (p(K::Up), SelectPrev),
                    (p(K::Left), SelectPrev),
                    (p(K::Down), SelectNext),
                    (p(K::Right), SelectNext),
                    (p(K::Enter), SimToggle),
                    (c('1'), SimOn),
                    (c('0'), SimOff),
                    (c('p'), SimPress),
                ],
            ),
            (
                Mode::Editor,
                &[
                    (p(K::F(4)), CloseEditor),
                    (p(K::BackTab), CloseEditor),
                    (p(K::Up), CursorUp),
                    (p(K::Down), CursorDown),
                    (p(K::Left), CursorLeft),
                    (p(K::Right), CursorRight),
                    (ctrl_key(K::Left), WordLeft),
                    (ctrl_key(K::Right), WordRight),
                    (p(K::Home), CursorHome),
                    (p(K::End), CursorEnd),
                    (p(K::PageUp), PageUp),
                    (p(K::PageDown), PageDown),
                    (ctrl_key(K::Home), CursorTop),
                    (ctrl_key(K::End), CursorBottom),
                    (p(K::Enter), NewLine),
                    (p(K::Tab), TypeBlank),
                    (KeyChord::ctrl(' '), TypeBlank),
                    (p(K::Backspace), DeleteBack),
                    (p(K::Delete), DeleteForward),
                    (KeyChord::ctrl('k'), DeleteLine),
                    (KeyChord::ctrl('z'), Undo),
                    (KeyChord::ctrl('y'), Redo),
                    (KeyChord::ctrl('s'), Save),
                    (alt('s'), SaveAs),
                    (KeyChord::ctrl('o'), Open),
                    (KeyChord::ctrl('f'), Find),
                    (p(K::F(3)), FindNext),
                    (shift(K::F(3)), FindPrev),
                    (KeyChord::ctrl('g'), GoToLine),
                    (p(K::F(8)), NextProblem),
                    (shift(K::F(8)), PrevProblem),
                    (alt_key(K::Enter), ApplyFix),
                    (alt('f'), Format),
                    (KeyChord::ctrl('a'), Circle),
                    (p(K::F(12)), JumpTarget),
                    (p(K::F(9)), TogglePreview),
                ],
            ),
            (
                Mode::Form,
                &[
                    (p(K::Enter), Submit),
                    (p(K::Esc), Cancel),
                    (p(K::Tab), NextField),
                    (p(K::Down), NextField),
                    (p(K::BackTab), PrevField),
                    (p(K::Up), PrevField),
                    (p(K::Left), CursorLeft),
                    (p(K::Right), CursorRight),
                    (p(K::Home), CursorHome),
                    (p(K::End), CursorEnd),
                    (p(K::Backspace), DeleteBack),
                    (p(K::Delete), DeleteForward),
                    (KeyChord::ctrl('u'), ClearLine),
                    (KeyChord::ctrl(' '), TypeBlank),
                ],
            ),
            (
                Mode::Unsaved,
                &[
                    (c('s'), Save),
                    (p(K::Enter), Save),
                    (c('d'), Discard),
                    (c('n'), Cancel),
                    (p(K::Esc), Cancel),
                ],
            ),
            (
                Mode::Help,
                &[
                    (p(K::Esc), Close),
                    (c('?'), Close),
                    (c('q'), Close),
                    (p(K::F(1)), Close),
                    (p(K::Up), ScrollUp),
                    (c('k'), ScrollUp),
                    (p(K::Down), ScrollDown),
                    (c('j'), ScrollDown),
                    (p(K::PageUp), PageUp),
                    (p(K::PageDown), PageDown),
                ],
            ),
            (
                Mode::Confirm,
                &[
                    (c('y'), Confirm),
                    (p(K::Enter), Confirm),
                    (c('n'), Cancel),
                    (p(K::Esc), Cancel),
                ],
            ),
            (
                Mode::GoTo,
                &[
                    (p(K::Enter), Submit),
                    (p(K::Esc), Cancel),
                    (p(K::Left), CursorLeft),
                    (p(K::Right), CursorRight),
                    (p(K::Home), CursorHome),
                    (p(K::End), CursorEnd),
                    (p(K::Backspace), DeleteBack),
                    (p(K::Delete), DeleteForward),
                    (KeyChord::ctrl('u'), ClearLine),
                ],
            ),
            (
                Mode::Timeline,
                &[
                    (c('w'), Timeline),
                    (p(K::F(7)), Timeline),
                    (p(K::Left), TimeEarlier),
                    (p(K::Right), TimeLater),
                    (p(K::End), TimeLive),
                    (c('+'), ZoomIn),
                    (c('='), ZoomIn),
                    (c('-'), ZoomOut),
                    (p(K::Up), ScrollUp),
                    (p(K::Down), ScrollDown),
                ],
            ),
            (
                Mode::Axes,
                &[
                    (p(K::Enter), AxisAll),
                    (c('x'), AxisX),
                    (c('y'), AxisY),
                    (c('z'), AxisZ),
                    (c('a'), AxisA),
                    (p(K::Esc), Cancel),
                    (c('n'), Cancel),
                ],
            ),
        ];
        let modes = defaults
            .iter()
            .map(|(mode, keys)| (*mode, keys.iter().copied().collect()))
            .collect();
        Keymap { modes }
    }
}

/// One line of the help: the keys bound to an action in a mode.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HelpEntry {
    pub keys: Vec<KeyChord>,
    pub action: Action,
}

impl Keymap {
    /// The action `key` is bound to in `mode`.
    pub fn lookup(&self, mode: Mode, key: &KeyChord) -> Option<Action> {
        self.modes.get(&mode).and_then(|m| m.get(key)).copied()
    }

    /// Every binding of `mode`, by key.
    pub fn bindings(&self, mode: Mode) -> impl Iterator<Item = (KeyChord, Action)> + '_ {
        self.modes
            .get(&mode)
            .into_iter()
            .flat_map(|m| m.iter().map(|(k, a)| (*k, *a)))
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
        mode.actions()
            .iter()
            .filter_map(|&action| {
                let keys = self.keys_for(mode, action);
                (!keys.is_empty()).then_some(HelpEntry { keys, action })
            })
            .collect()
    }

    /// Apply a profile's `[keys]` table: `mode -> key -> action` (or
    /// `"none"` to unbind). `sources` are the profile's files, most specific
    /// first, so an error names the line that caused it.
    pub fn with_overrides(
        mut self,
        table: &BTreeMap<String, BTreeMap<String, String>>,
        sources: &[&Source],
    ) -> Result<Keymap, ConfigError> {
        let fail = |path: &[&str], message: String| {
            let key: Vec<String> = path.iter().map(|s| s.to_string()).collect();
            source::error_for_key(sources, &key, message)
        };
        let mode_names = || {
            Mode::ALL
                .iter()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(", ")
        };
        // Parse everything first, so the safety keys are known before other
        // modes are checked against them.
        let mut parsed: Vec<(Mode, &str, KeyChord, Option<Action>)> = Vec::new();
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
                let action = if action_name == UNBIND {
                    None
                } else {
                    let action = Action::from_name(action_name).ok_or_else(|| {
                        fail(
                            &path,
                            format!(
                                "unknown action `{action_name}` in mode `{mode}`: expected {}, \
                                 or `{UNBIND}` to unbind",
                                action_list(mode)
                            ),
                        )
                    })?;
                    if !mode.actions().contains(&action) {
                        return Err(fail(
                            &path,
                            format!(
                                "action `{action}` does not exist in mode `{mode}`: expected {}",
                                action_list(mode)
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
            let map = self.modes.entry(*mode).or_default();
            match action {
                Some(a) => map.insert(*chord, *a),
                None => map.remove(chord),
            };
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
        for (mode, map) in self.modes.iter_mut() {
            if *mode != Mode::Safety {
                map.retain(|k, _| !safety.contains(k));
            }
        }
        Ok(self)
    }
}

fn action_list(mode: Mode) -> String {
    mode.actions()
        .iter()
        .map(|a| a.name())
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

    fn apply(text: &str) -> Result<Keymap, ConfigError> {
        let src = source(text);
        let table: toml::Table = toml::from_str(text).expect("toml");
        let keys: BTreeMap<String, BTreeMap<String, String>> = table
            .get("keys")
            .cloned()
            .map(|v| v.try_into().expect("keys table"))
            .unwrap_or_default();
        Keymap::default().with_overrides(&keys, &[&src])
    }

    #[test]
    fn every_default_binding_is_an_action_of_its_mode() {
        let map = Keymap::default();
        for mode in Mode::ALL {
            for (key, action) in map.bindings(mode) {
                assert!(
                    mode.actions().contains(&action),
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
        let map = Keymap::default();
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
        let map = Keymap::default();
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
}
