//! The jog screen: its state ([`Keypad`]: the jog logic of `crate::jog`
//! with the keys it was pressed with, homing progress, the step and speed
//! selected, work offsets), its keys for motion, releases, ticks and device
//! events, and the go-to prompt ([`goto`]) and axis choice ([`axes`])
//! popups; work offsets ([`offsets`]), the typed step and speed and the
//! speed override ([`values`]) and their popups ([`popups`]). A component
//! as the editor is ([`component`]: `Keypad::update(&ctx, input) ->
//! outcome`, `docs/architecture.md`, "The jog screen component"). Drawing
//! is in [`view`].
//!
//! Nothing here sends anything or reads the model: it returns `Effect`s,
//! notes for the message line and a popup, which `update` carries out.

pub mod axes;
pub mod goto;
pub mod limit;
pub mod offsets;
pub mod popup_view;
pub mod popups;
pub mod values;
pub mod view;

use std::time::Instant;

use crate::axis::{Axis, AxisSet};
use crate::device::api::{Activity, Dir, Event, JogEnd, MachineState, Refusal, Request};
use crate::jog::{Gate, JogKind, JogSettings, Jogger, KeyPhase, LastOutcome, Selection, Vector};

use super::setup::{JogSelection, Setup};

use super::key::KeyChord;
use super::keymap::Action;
use super::msg::Effect;
use super::traffic_log::NoteLevel;

pub mod component;
pub mod context;

pub use context::{Context, Note};

/// A reference run the keypad has seen asked for, to show its progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Homing {
    pub axes: AxisSet,
    pub since: Instant,
    /// The device task has reported it running.
    pub seen: bool,
    /// The axes referenced when it was seen running: only axes referenced
    /// after that count as done (a run repeats a reference already held).
    pub before: AxisSet,
}

/// The keypad panel's state.
#[derive(Debug, Clone)]
pub struct Keypad {
    pub jogger: Jogger<KeyChord>,
    pub homing: Option<Homing>,
    /// The jog off a limit switch (`L`, [`limit`]).
    pub limit: limit::LimitState,
    /// A typed step and speed, the speed override ([`values`]).
    pub values: values::JogValues,
    /// The preset step and speed selected (indices into the profile's lists).
    pub selection: JogSelection,
    /// Work offsets G54-G59 ([`offsets`]): the position panel, go-to and
    /// the work zero count from the active one.
    pub offsets: offsets::OffsetsState,
}

impl Keypad {
    /// The keypad of a session on `setup`: its jog settings, the step and
    /// speed selected at start (within the profile's lists).
    pub fn new(setup: &Setup) -> Keypad {
        let start = setup.jog_start;
        Keypad {
            jogger: Jogger::new(setup.jog.clone()),
            homing: None,
            limit: limit::LimitState::default(),
            values: values::JogValues::default(),
            selection: JogSelection {
                step: start.step.min(setup.jog_steps.len().saturating_sub(1)),
                speed: start.speed.min(setup.jog_speeds.len().saturating_sub(1)),
            },
            offsets: offsets::OffsetsState::default(),
        }
    }

    /// The jog step in units: typed, else the preset selected.
    pub fn step(&self, setup: &Setup) -> Option<f64> {
        self.values
            .step
            .or_else(|| setup.jog_steps.get(self.selection.step).copied())
    }

    /// The speed chosen before the override: typed, else the preset.
    pub fn base_speed(&self, setup: &Setup) -> Option<f64> {
        self.values
            .speed
            .or_else(|| setup.jog_speeds.get(self.selection.speed).copied())
    }

    /// The jog speed in units per second: typed, else the preset selected,
    /// with the speed override (at most the fastest axis' top speed).
    pub fn speed(&self, setup: &Setup) -> Option<f64> {
        let base = self.base_speed(setup)?;
        Some(self.values.speed_with_override(base, self.settings()))
    }

    pub fn settings(&self) -> &JogSettings {
        self.jogger.settings()
    }

    /// Whether the terminal reports key releases (kitty keyboard protocol):
    /// then a release stops a held jog at once.
    pub fn set_releases(&mut self, releases: bool) {
        self.jogger.set_releases(releases);
    }

    /// Effects `update` is about to carry out: a reference run starts its
    /// progress display.
    pub fn issued(&mut self, effects: &[Effect], now: Instant) {
        for effect in effects {
            match effect {
                Effect::Request(Request::Home { axes }) => {
                    self.homing = Some(Homing {
                        axes: *axes,
                        since: now,
                        seen: false,
                        before: AxisSet::EMPTY,
                    });
                }
                Effect::Request(r @ Request::LimitJog { .. }) => self.limit.issued(r, now),
                _ => {}
            }
        }
    }

    fn machine_state(&mut self, state: &MachineState) {
        if let Some(h) = self.homing.as_mut() {
            if state.activity == Activity::Homing {
                if !h.seen {
                    h.before = state.referenced;
                }
                h.seen = true;
            } else if h.seen {
                self.homing = None;
            }
        }
    }
}

/// The direction a keymap action jogs in.
pub fn vector_of(action: Action) -> Option<Vector> {
    use Axis::{A, X, Y, Z};
    use Dir::{Minus, Plus};
    let pairs: &[(Axis, Dir)] = match action {
        Action::JogXPlus => &[(X, Plus)],
        Action::JogXMinus => &[(X, Minus)],
        Action::JogYPlus => &[(Y, Plus)],
        Action::JogYMinus => &[(Y, Minus)],
        Action::JogZPlus => &[(Z, Plus)],
        Action::JogZMinus => &[(Z, Minus)],
        Action::JogAPlus => &[(A, Plus)],
        Action::JogAMinus => &[(A, Minus)],
        Action::JogXPlusYPlus => &[(X, Plus), (Y, Plus)],
        Action::JogXMinusYPlus => &[(X, Minus), (Y, Plus)],
        Action::JogXPlusYMinus => &[(X, Plus), (Y, Minus)],
        Action::JogXMinusYMinus => &[(X, Minus), (Y, Minus)],
        _ => return None,
    };
    Some(Vector::new(pairs))
}

/// The motion gate for the machine's state and the profile.
pub fn gate<'a>(kp: &Keypad, ctx: &Context<'a>) -> Gate<'a> {
    let settings = kp.settings();
    Gate {
        link: ctx.link,
        machine: ctx.machine,
        axes: settings.axis_set(),
        allow_unreferenced: settings.allow_unreferenced,
    }
}

/// The step and speed selected, in units.
pub fn selection(kp: &Keypad, setup: &Setup) -> Selection {
    Selection {
        step: kp.step(setup).unwrap_or(0.0),
        speed: kp.speed(setup).unwrap_or(0.0),
    }
}

fn requests(list: Vec<Request>) -> Vec<Effect> {
    list.into_iter().map(Effect::Request).collect()
}

impl Keypad {
    /// A motion key of the keypad (`action` one of the jog actions).
    fn motion_key(
        &mut self,
        ctx: &Context,
        action: Action,
        chord: KeyChord,
        phase: KeyPhase,
    ) -> (Vec<Effect>, Option<Note>) {
        let Some(vector) = vector_of(action) else {
            return (Vec::new(), None);
        };
        let now = ctx.now;
        let machine_axes = self.settings().axis_set();
        if let Some(axis) = vector.axes().iter().find(|a| !machine_axes.contains(*a)) {
            if phase != KeyPhase::Press {
                return (Vec::new(), None);
            }
            let reason = Refusal::Invalid {
                reason: format!("the machine has no {axis} axis (axes {machine_axes})"),
            };
            let text = format!("jog refused: {reason}");
            self.jogger.refused(reason, now);
            return (Vec::new(), Some((NoteLevel::Warning, text)));
        }
        let sel = selection(self, ctx.setup);
        let before = self.jogger.last().cloned();
        let gate = Gate {
            link: ctx.link,
            machine: ctx.machine,
            axes: machine_axes,
            allow_unreferenced: self.settings().allow_unreferenced,
        };
        let out = self.jogger.key(&gate, chord, vector, phase, sel, now);
        // A refusal is said once, when it is new (the key is latched after it).
        let note = match self.jogger.last() {
            Some(LastOutcome::Refused { reason, at })
                if *at == now && before.as_ref() != self.jogger.last() =>
            {
                Some((NoteLevel::Danger, format!("jog refused: {reason}")))
            }
            _ => None,
        };
        (requests(out), note)
    }

    /// A key was let go (only terminals with the kitty keyboard protocol say).
    fn released(&mut self, ctx: &Context, chord: KeyChord) -> Vec<Effect> {
        let gate_free = Gate {
            link: ctx.link,
            machine: ctx.machine,
            axes: AxisSet::EMPTY,
            allow_unreferenced: false,
        };
        // A release never starts motion; the gate and selection are not used.
        let out = self.jogger.key(
            &gate_free,
            chord,
            Vector::default(),
            KeyPhase::Release,
            Selection {
                step: 0.0,
                speed: 0.0,
            },
            ctx.now,
        );
        requests(out)
    }

    /// A motion key of the focused keypad that came in a burst: never motion
    /// (`Jogger::burst_key`). `None` when it did nothing but latch the key (the
    /// burst's message counts it); renewing the held jog it belongs to, or
    /// stopping a toggle jog, is something.
    fn burst_key(&mut self, now: Instant, chord: KeyChord, phase: KeyPhase) -> Option<Vec<Effect>> {
        let out = self.jogger.burst_key(chord, phase, now);
        let own = self
            .jogger
            .active()
            .is_some_and(|a| a.keys.contains(&chord));
        (own || !out.is_empty()).then(|| requests(out))
    }

    /// Any key other than a stop key, before it is routed: in toggle mode a
    /// running jog stops and the key is used up.
    fn any_key(&mut self, now: Instant, chord: KeyChord, phase: KeyPhase) -> Option<Vec<Effect>> {
        self.jogger.other_key(chord, phase, now).map(requests)
    }

    /// What the keypad shows that changes with the clock alone: the tenths of
    /// a second a reference run has taken. Nothing else may redraw the screen
    /// meanwhile (an isel controller is not polled during a reference run).
    pub fn clock_shown(&self, now: Instant) -> Option<u64> {
        self.homing.map(|h| {
            let tenths = now.saturating_duration_since(h.since).as_millis() / 100;
            u64::try_from(tenths).unwrap_or(u64::MAX)
        })
    }

    /// The operator stopped everything.
    fn stopped(&mut self, now: Instant) {
        self.jogger.stopped(now);
        self.homing = None;
    }

    /// Switch between step and continuous jogging.
    fn switch_kind(&mut self, now: Instant) -> (Vec<Effect>, Note) {
        let kind = match self.jogger.kind() {
            JogKind::Step => JogKind::Continuous,
            JogKind::Continuous => JogKind::Step,
        };
        let out = self.jogger.set_kind(kind, now);
        let text = match kind {
            JogKind::Step => "step jogging: one press, one step".to_string(),
            JogKind::Continuous => match self.jogger.mode() {
                crate::config::profile::JogMode::Hold => {
                    "continuous jogging: the axis moves while the key is held".to_string()
                }
                crate::config::profile::JogMode::Toggle => {
                    "continuous jogging, TOGGLE: a key starts the axis, any key stops it"
                        .to_string()
                }
            },
        };
        (requests(out), (NoteLevel::Info, text))
    }

    /// A device event the keypad cares about. Returns `false` for a refusal
    /// the keypad accounts for itself (a step press dropped because the
    /// driver's queue is full: expected while a key repeats), which the
    /// message line should not repeat.
    fn device_event(&mut self, now: Instant, event: &Event) -> bool {
        self.limit.device_event(event);
        match event {
            Event::JogEnded { id, end } => {
                self.jogger.ended(*id, end, now);
                true
            }
            Event::Refused {
                reason: Refusal::StepQueueFull,
                ..
            } => {
                self.jogger.step_dropped();
                false
            }
            Event::Refused { request, reason } => {
                if request.starts_with("step") || request.starts_with("move to") {
                    self.jogger.refused(reason.clone(), now);
                }
                if request.starts_with("home") {
                    self.homing = None;
                }
                true
            }
            Event::State(state) => {
                self.machine_state(state);
                true
            }
            _ => true,
        }
    }

    /// Whether a jog's end is worth a message: a dead-man end is the normal
    /// way a held jog ends where the terminal reports no releases.
    pub fn end_is_news(&self, end: &JogEnd) -> bool {
        *end != JogEnd::DeadMan || self.jogger.releases()
    }

    /// Whether anything moves, as far as the console knows.
    pub fn moving(&self, machine: &MachineState) -> bool {
        machine.activity != Activity::Idle || self.jogger.active().is_some()
    }
}
