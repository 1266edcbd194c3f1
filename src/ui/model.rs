//! All UI state in one place (The Elm Architecture): what the device last
//! reported, what the operator selected and typed, what is open and focused.
//! `update` is the only thing that changes it; the view only reads it.

use std::time::{Duration, Instant};

use crate::device::api::{LinkState, MachineState, PollStats, UploadEvent};

use super::console::Console;
use super::editor::{self, Editor};
use super::io::IoPanel;
use super::jog::{self, Keypad, goto};
use super::keymap::{Keymap, Mode};
use super::macros::MacroRun;
pub use super::messages::Message;
use super::messages::MessageHistory;
pub use super::outcome::Confirmation;
use super::palette::Palette;
pub use super::popups::Popup;
use super::position::Positions;
use super::raw::RawContext;
pub use super::setup::{JogSelection, Setup};
use super::sim_panel::SimPanel;
use super::timeline::Timeline;

/// How long a message stays in the message line before the machine's own
/// state (and its recovery) takes the line back.
pub const MESSAGE_FRESH: Duration = Duration::from_secs(10);

/// The panels that can have focus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PanelId {
    /// The jog keypad; focused at start.
    Jog,
    Io,
    Console,
    Sim,
    /// The program editor: while it has focus the program screen is shown
    /// (not in the Tab ring; `e`/F4 opens and closes it).
    Editor,
    /// The port timeline: while it has focus it takes the machine screen's
    /// place (not in the Tab ring; `w`/F7 opens and closes it).
    Timeline,
}

impl PanelId {
    /// The keymap mode while the panel has focus.
    pub fn mode(self) -> Mode {
        match self {
            PanelId::Jog => Mode::Jog,
            PanelId::Io => Mode::Io,
            PanelId::Console => Mode::Console,
            PanelId::Sim => Mode::Sim,
            PanelId::Editor => Mode::Editor,
            PanelId::Timeline => Mode::Timeline,
        }
    }
}

/// The jog screen's context from a model's fields: a macro, not a method,
/// so that [`Model::jog_parts`] can borrow the keypad mutably beside it.
macro_rules! jog_context {
    ($model:expr) => {
        jog::Context {
            setup: &$model.setup,
            link: &$model.link,
            machine: &$model.machine,
            positions: &$model.positions,
            now: $model.now,
        }
    };
}

/// The editor's context from a model's fields: a macro, not a method, so
/// that [`Model::editor_parts`] can borrow the editor mutably beside it.
macro_rules! editor_context {
    ($model:expr) => {
        editor::Context {
            setup: &$model.setup,
            machine: &$model.machine,
            positions: &$model.positions,
            offsets: &$model.keypad.offsets.table,
            tools: &$model.tools,
            now: $model.now,
            palette: &$model.palette,
            keymap: &$model.keymap,
            size: $model.size,
            focused: $model.focus == PanelId::Editor,
            popup_open: $model.popup.is_some(),
        }
    };
}

#[derive(Debug, Clone)]
pub struct Model {
    pub setup: Setup,
    pub keymap: Keymap,
    pub palette: Palette,
    /// The time of the last tick; what "a moment ago" is measured against.
    pub now: Instant,
    pub link: LinkState,
    pub machine: MachineState,
    pub positions: Positions,
    pub io: IoPanel,
    /// The traffic log and the command line (`ui::console`).
    pub console: Console,
    pub sim: Option<SimPanel>,
    pub stats: Option<PollStats>,
    pub message: Option<Message>,
    pub upload: Option<UploadEvent>,
    /// The jog screen's state (`ui::jog`): the keypad's jogging, homing
    /// progress, the step and speed selected and typed, the work offsets.
    pub keypad: Keypad,
    pub focus: PanelId,
    pub popup: Option<Popup>,
    /// The program being edited (`docs/editor.md`).
    pub editor: Editor,
    /// Every input change since the link came up (`docs/ui.md`, "Port
    /// timeline").
    pub timeline: Timeline,
    /// Where the focus goes back to when the timeline closes.
    pub before_timeline: PanelId,
    /// Where the focus goes back to when the program screen closes.
    pub before_editor: Option<PanelId>,
    /// Where the focus goes back to when the command line is left (it is
    /// entered only with `:`, never by Tab: `ui::typing`).
    pub before_console: PanelId,
    /// When the last key press (or repeat) was read: a key within
    /// `typing::BURST_GAP` of it belongs to the same burst.
    pub last_key_at: Option<Instant>,
    /// When a request that may move the machine was last handed on: Space
    /// types in a text field only a while after it (`typing::may_move`).
    pub motion_asked: Option<Instant>,
    pub size: (u16, u16),
    /// Something the view shows has changed since the last frame.
    pub dirty: bool,
    /// `Quit` has been given; the runtime is closing down.
    pub quitting: bool,
    /// The profile's macro being run, line by line (`ui::macros`).
    pub macro_run: Option<MacroRun>,
    /// The touch-off the console sent (`ui::probe`).
    pub probe: super::probe::ProbeState,
    /// The job's frame being traced (`ui::frame`).
    pub frame: Option<super::frame::FrameRun>,
    /// The tool table (`ui::tools`).
    pub tools: super::tools::ToolsState,
    /// The macro key last pressed, to tell its auto-repeats (presses on
    /// terminals without release events) from a new press.
    pub macro_key: crate::jog::HeldKey<super::key::KeyChord>,
    /// The hold-to-run frame's key last pressed (`f`): a repeat renews the
    /// hold, only a new press starts a frame.
    pub frame_key: crate::jog::HeldKey<super::key::KeyChord>,
    /// Every message of the session, newest last (`M` shows them whole).
    pub history: MessageHistory,
    /// The machine screen shows the large position display (`D`).
    pub large_dro: bool,
}

impl Model {
    pub fn new(setup: Setup, keymap: Keymap, palette: Palette, now: Instant) -> Self {
        let sim = setup
            .simulator_inputs
            .as_ref()
            .map(|inputs| SimPanel::new(inputs).with_start_key(setup.sim_start_key.clone()));
        Model {
            editor: Editor::new(&setup, now),
            timeline: Timeline::new(&setup.inputs),
            before_timeline: PanelId::Jog,
            before_editor: None,
            before_console: PanelId::Jog,
            last_key_at: None,
            motion_asked: None,
            keypad: Keypad::new(&setup),
            setup,
            keymap,
            palette,
            now,
            link: LinkState::Connecting,
            machine: MachineState::default(),
            positions: Positions::default(),
            io: IoPanel::default(),
            console: Console::default(),
            sim,
            stats: None,
            message: None,
            upload: None,
            focus: PanelId::Jog,
            popup: None,
            size: (80, 24),
            dirty: true,
            quitting: false,
            macro_run: None,
            probe: super::probe::ProbeState::default(),
            frame: None,
            tools: super::tools::ToolsState::default(),
            macro_key: crate::jog::HeldKey::default(),
            frame_key: crate::jog::HeldKey::default(),
            history: MessageHistory::default(),
            large_dro: false,
        }
    }

    /// The key mode of the focused panel: the program screen during a
    /// check-out has keys of its own (its text is read-only then).
    pub fn panel_mode(&self) -> Mode {
        match self.focus {
            PanelId::Editor if self.editor.checkout.is_some() => Mode::Checkout,
            focus => focus.mode(),
        }
    }

    pub fn editor_context(&self) -> editor::Context<'_> {
        editor_context!(self)
    }

    /// The program editor and its context, borrowed together (disjoint
    /// fields) for `Editor::update`.
    pub fn editor_parts(&mut self) -> (&mut Editor, editor::Context<'_>) {
        let context = editor_context!(self);
        (&mut self.editor, context)
    }

    /// The panels Tab cycles through, in order. Not the command line: it
    /// takes every printable key, so it is entered deliberately with `:`
    /// (and Tab leaves it), never reached by cycling past it.
    pub fn focus_ring(&self) -> Vec<PanelId> {
        // The large position display shows no other panel.
        if self.large_dro {
            return vec![PanelId::Jog];
        }
        let mut ring = vec![PanelId::Jog, PanelId::Io];
        if self.sim.is_some() {
            ring.push(PanelId::Sim);
        }
        ring
    }

    pub fn raw_context(&self) -> RawContext {
        RawContext {
            protocol: self.setup.protocol,
            isel_device: self.setup.isel_device,
            initialised: self.machine.initialised,
        }
    }

    /// The message to show at `now`, while it is fresh.
    pub fn fresh_message(&self) -> Option<&Message> {
        self.message
            .as_ref()
            .filter(|m| self.now.saturating_duration_since(m.at) < MESSAGE_FRESH)
    }

    /// What the status line says now of the job the editor runs (a
    /// stored program running is the controller's activity).
    pub fn job_status(&self) -> Option<super::editor::progress::JobStatus> {
        self.editor.job_status(
            self.now,
            self.machine.activity == crate::device::api::Activity::RunningProgram,
        )
    }

    /// The macros' state and context (`ui::macros`), borrowed side by side.
    pub fn macro_parts(&mut self) -> (&mut Option<MacroRun>, super::macros::Context<'_>) {
        let raw = self.raw_context();
        (
            &mut self.macro_run,
            super::macros::Context {
                macros: &self.setup.macros,
                machine: &self.machine,
                raw,
            },
        )
    }

    /// The jog screen's context (`ui::jog::Context`), read-only.
    pub fn jog_context(&self) -> jog::Context<'_> {
        jog_context!(self)
    }

    /// The jog screen's state and its context, borrowed side by side for
    /// `Keypad::update`.
    pub fn jog_parts(&mut self) -> (&mut Keypad, jog::Context<'_>) {
        (&mut self.keypad, jog_context!(self))
    }

    /// The go-to prompt's context (`ui::jog::goto::Context`).
    pub fn goto_context(&self) -> goto::Context<'_> {
        let kp = &self.keypad;
        goto::Context {
            settings: kp.settings(),
            gate: jog::gate(kp, &self.jog_context()),
            speed: jog::selection(kp, &self.setup).speed,
            offsets: &kp.offsets.table,
        }
    }

    /// The jog step in units: typed, else the preset selected.
    pub fn jog_step(&self) -> Option<f64> {
        self.keypad.step(&self.setup)
    }

    /// The jog speed in units per second: typed, else the preset selected,
    /// with the speed override (at most the fastest axis' top speed).
    pub fn jog_speed(&self) -> Option<f64> {
        self.keypad.speed(&self.setup)
    }
}
