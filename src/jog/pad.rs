//! The jog keypad's logic: key presses, repeats and releases in, device
//! requests out (`Jog`, `JogRenew`, `JogRelease`, `Step`). Sans-IO: time
//! comes in as an argument, nothing here sleeps or keeps a timer.
//!
//! The dead-man is not here. The device task holds every jog on a lease and
//! stops it when the lease runs out; this only turns what the terminal
//! reports into leases (`docs/jogging.md`):
//!
//! - **hold** (continuous): a press starts a jog with a lease long enough for
//!   the terminal's first repeat (`jog.first_repeat_grace_ms`); each repeat
//!   renews it for `jog.repeat_timeout_ms`. Where the terminal reports
//!   releases, a release stops it at once; otherwise the missing repeat does.
//! - **toggle** (continuous, opt-in): a press starts, the next key stops;
//!   the console's own tick renews the lease while it runs.
//! - **step**: every press (and every repeat of a held key) is one step; the
//!   driver runs one and coalesces what comes meanwhile up to
//!   `jog.step_queue`, dropping the rest, so a held key never leaves a queue.
//!
//! - **a burst** (keys that came together, `burst_key`): never motion; it
//!   may renew the held jog it belongs to, and latches its other keys.
//!
//! A key whose jog ended other than by its release (dead-man, soft limit,
//! refusal, stop) is *latched*: its repeats do nothing until it has been let
//! go (a release event, or a pause in its repeats longer than the repeat
//! timeout). So a key still held never restarts motion behind the
//! operator's back, and a refused key says so once, not 30 times a second.

use std::fmt::Debug;
use std::time::{Duration, Instant};

use crate::config::profile::JogMode;
use crate::device::api::{JogEnd, JogId, PerAxis, Refusal, Request};

use super::gate::{Gate, Motion};
use super::settings::JogSettings;
use super::vector::Vector;

/// What the terminal reported about a key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyPhase {
    Press,
    /// An auto-repeat. Only terminals with the kitty keyboard protocol tell
    /// a repeat from a press; elsewhere every repeat arrives as a press.
    Repeat,
    Release,
}

/// Step or continuous jogging.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JogKind {
    Step,
    Continuous,
}

/// The step and speed the operator has selected, in units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Selection {
    /// Step distance, units.
    pub step: f64,
    /// Path speed, units per second.
    pub speed: f64,
}

/// Bound on how long the keypad believes in a jog the device task never
/// reported ended (a request that could not be handed over, an event
/// missed): past its lease by this much, the jog is forgotten.
const STALE_AFTER: Duration = Duration::from_secs(2);

/// The continuous jog the keypad started and has not seen end.
#[derive(Debug, Clone, PartialEq)]
pub struct ActiveJog<K> {
    pub id: JogId,
    pub vector: Vector,
    /// The keys that keep it alive (several where releases are reported
    /// and keys are held together).
    pub keys: Vec<K>,
    pub toggle: bool,
    pub started: Instant,
    pub lease_until: Instant,
    /// A repeat (or a toggle tick) has renewed it: its speed cap is the
    /// short lease's now.
    pub renewed: bool,
    /// The last event of the key that started a toggle jog: its own
    /// repeats (presses, without release events) must not stop it.
    pub last_seen: Instant,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Latch<K> {
    key: K,
    last_seen: Instant,
}

/// What the panel shows about the last thing a motion key did.
#[derive(Debug, Clone, PartialEq)]
pub enum LastOutcome {
    /// A step went out along this vector.
    Stepped { vector: Vector, at: Instant },
    /// The key was refused, locally or by the device task.
    Refused { reason: Refusal, at: Instant },
    /// The jog ended for this reason (not by its release).
    Ended { end: JogEnd, at: Instant },
}

/// The keypad's state machine; `K` is whatever identifies a key.
#[derive(Debug, Clone)]
pub struct Jogger<K> {
    settings: JogSettings,
    releases: bool,
    kind: JogKind,
    next_id: u64,
    active: Option<ActiveJog<K>>,
    /// Keys held, oldest first (only with release events).
    held: Vec<(K, Vector)>,
    latched: Vec<Latch<K>>,
    last: Option<LastOutcome>,
    /// Step presses the driver dropped because its queue was full, since
    /// the last step that went out after a pause.
    dropped_steps: u32,
    last_step_press: Option<Instant>,
}

impl<K: Copy + Eq + Debug> Jogger<K> {
    /// Starts in step mode: the least a stray key can do.
    pub fn new(settings: JogSettings) -> Jogger<K> {
        Jogger {
            settings,
            releases: false,
            kind: JogKind::Step,
            next_id: 0,
            active: None,
            held: Vec::new(),
            latched: Vec::new(),
            last: None,
            dropped_steps: 0,
            last_step_press: None,
        }
    }

    pub fn settings(&self) -> &JogSettings {
        &self.settings
    }

    /// Whether the terminal reports key releases (kitty keyboard protocol).
    pub fn set_releases(&mut self, releases: bool) {
        self.releases = releases;
    }

    pub fn releases(&self) -> bool {
        self.releases
    }

    pub fn kind(&self) -> JogKind {
        self.kind
    }

    pub fn mode(&self) -> JogMode {
        self.settings.mode
    }

    pub fn active(&self) -> Option<&ActiveJog<K>> {
        self.active.as_ref()
    }

    pub fn last(&self) -> Option<&LastOutcome> {
        self.last.as_ref()
    }

    pub fn dropped_steps(&self) -> u32 {
        self.dropped_steps
    }

    /// Switch between step and continuous jogging; a jog that runs stops,
    /// and a key still held does nothing in the new mode until let go.
    pub fn set_kind(&mut self, kind: JogKind, now: Instant) -> Vec<Request> {
        self.kind = kind;
        let keys: Vec<K> = self
            .active
            .iter()
            .flat_map(|a| a.keys.iter().copied())
            .chain(self.held.iter().map(|(k, _)| *k))
            .collect();
        let out = self.release_active(now);
        for key in keys {
            self.latch(key, now);
        }
        out
    }

    /// A motion key (`vector` is what it is bound to).
    pub fn key(
        &mut self,
        gate: &Gate<'_>,
        key: K,
        vector: Vector,
        phase: KeyPhase,
        selection: Selection,
        now: Instant,
    ) -> Vec<Request> {
        if phase == KeyPhase::Release {
            return self.released(key, now);
        }
        if self.is_latched(key, phase, now) {
            return Vec::new();
        }
        match (self.kind, self.settings.mode) {
            (JogKind::Step, _) => self.step(gate, key, vector, selection, now),
            (JogKind::Continuous, JogMode::Hold) => {
                self.hold(gate, key, vector, phase, selection, now)
            }
            (JogKind::Continuous, JogMode::Toggle) => {
                self.toggle(gate, key, vector, phase, selection, now)
            }
        }
    }

    /// A motion key that came in a burst: with other keys in one read of the
    /// terminal, or faster than a person or a key repeat types (a paste
    /// without bracketed paste, keys a program sent; `ui::typing`). It never
    /// starts motion or steps. The keys of a held jog that runs renew it:
    /// over SSH a held key's repeats can arrive bunched, and a renewal is no
    /// new motion. A toggle jog's own key is its repeat; another key stops
    /// it, as a press would. Any other key is latched, so the rest of the
    /// burst, read a moment later, does nothing either until the key has
    /// been let go (its repeats pause longer than the repeat timeout).
    pub fn burst_key(&mut self, key: K, phase: KeyPhase, now: Instant) -> Vec<Request> {
        if phase == KeyPhase::Release {
            return self.released(key, now);
        }
        if let Some(a) = self.active.as_mut()
            && a.keys.contains(&key)
        {
            if a.toggle {
                a.last_seen = now;
                return Vec::new();
            }
            return self.renew(now);
        }
        let out = if self.active.as_ref().is_some_and(|a| a.toggle) {
            self.release_active(now)
        } else {
            Vec::new()
        };
        self.latch(key, now);
        out
    }

    /// Any key that is not a motion key. In toggle mode, while a jog runs, it
    /// stops the jog and is used up (`Some`); otherwise `None`: the key goes
    /// on to do what it does.
    pub fn other_key(&mut self, key: K, phase: KeyPhase, now: Instant) -> Option<Vec<Request>> {
        let toggle = self.active.as_ref().is_some_and(|a| a.toggle);
        if !toggle || phase != KeyPhase::Press {
            return None;
        }
        let out = self.release_active(now);
        self.latch(key, now);
        Some(out)
    }

    /// Time passes (the console's tick, a few times a second): toggle jogs
    /// are renewed, forgotten jogs and let-go keys are cleared.
    pub fn tick(&mut self, now: Instant) -> Vec<Request> {
        let timeout = self.settings.repeat_timeout;
        self.latched
            .retain(|l| now.saturating_duration_since(l.last_seen) <= timeout);
        let mut out = Vec::new();
        if let Some(a) = self.active.as_mut() {
            if a.toggle {
                // The toggle jog lives as long as the console does: a stuck
                // or dead console stops renewing and the lease stops it.
                a.lease_until = now + timeout;
                a.renewed = true;
                out.push(Request::JogRenew {
                    id: a.id,
                    lease: timeout,
                });
            } else if now > a.lease_until + STALE_AFTER {
                self.active = None;
            }
        }
        out
    }

    /// The operator stopped everything (the device task does the stopping):
    /// forget the jog, and let no held key start another.
    pub fn stopped(&mut self, now: Instant) {
        if let Some(a) = self.active.take() {
            for key in a.keys {
                self.latch(key, now);
            }
        }
        let held: Vec<K> = self.held.iter().map(|(k, _)| *k).collect();
        for key in held {
            self.latch(key, now);
        }
    }

    /// The device task reports how jog `id` ended.
    pub fn ended(&mut self, id: JogId, end: &JogEnd, now: Instant) {
        let Some(a) = self.active.as_ref().filter(|a| a.id == id) else {
            return;
        };
        let keys = a.keys.clone();
        self.active = None;
        if *end != JogEnd::Released {
            // A key still held must not start the jog again.
            for key in keys {
                self.latch(key, now);
            }
        }
        self.last = Some(match end {
            JogEnd::Refused(reason) => LastOutcome::Refused {
                reason: reason.clone(),
                at: now,
            },
            end => LastOutcome::Ended {
                end: end.clone(),
                at: now,
            },
        });
    }

    /// The driver dropped a step press (its queue was full).
    pub fn step_dropped(&mut self) {
        self.dropped_steps = self.dropped_steps.saturating_add(1);
    }

    /// A refusal from the device task for a step or another motion request.
    pub fn refused(&mut self, reason: Refusal, now: Instant) {
        self.last = Some(LastOutcome::Refused { reason, at: now });
    }

    // ----- the modes ------------------------------------------------------

    fn step(
        &mut self,
        gate: &Gate<'_>,
        key: K,
        vector: Vector,
        selection: Selection,
        now: Instant,
    ) -> Vec<Request> {
        if let Err(reason) = gate.check(Motion::Step) {
            return self.refuse(key, reason, now);
        }
        let paused = self
            .last_step_press
            .is_none_or(|t| now.saturating_duration_since(t) > self.settings.repeat_timeout);
        if paused {
            self.dropped_steps = 0;
        }
        self.last_step_press = Some(now);
        let pairs = vector.pairs();
        self.last = Some(LastOutcome::Stepped { vector, at: now });
        vec![Request::Step {
            delta: self.settings.step_delta(&pairs, selection.step),
            speed_hz: self.settings.speeds_hz(&pairs, selection.speed),
        }]
    }

    fn hold(
        &mut self,
        gate: &Gate<'_>,
        key: K,
        vector: Vector,
        phase: KeyPhase,
        selection: Selection,
        now: Instant,
    ) -> Vec<Request> {
        if self.releases {
            if phase == KeyPhase::Press || !self.held.iter().any(|(k, _)| *k == key) {
                self.held.retain(|(k, _)| *k != key);
                self.held.push((key, vector));
            }
            let combined = self
                .held
                .iter()
                .fold(Vector::default(), |v, (_, k)| v.combine(k));
            let keys: Vec<K> = self.held.iter().map(|(k, _)| *k).collect();
            if let Some(a) = self.active.as_ref()
                && a.vector == combined
                && a.keys.contains(&key)
            {
                return self.renew(now);
            }
            let mut out = self.release_active(now);
            out.extend(self.start(gate, keys, combined, false, selection, now));
            return out;
        }
        // Without release events a repeat is a press of the same key.
        if self.active.as_ref().is_some_and(|a| a.keys.contains(&key)) {
            return self.renew(now);
        }
        // Another key: the terminal repeats only the key pressed last, so
        // the previous one cannot be told held from let go. Its jog ends
        // and its stray repeats are ignored.
        let previous: Vec<K> = self
            .active
            .as_ref()
            .map(|a| a.keys.clone())
            .unwrap_or_default();
        let mut out = self.release_active(now);
        for k in previous {
            self.latch(k, now);
        }
        out.extend(self.start(gate, vec![key], vector, false, selection, now));
        out
    }

    fn toggle(
        &mut self,
        gate: &Gate<'_>,
        key: K,
        vector: Vector,
        phase: KeyPhase,
        selection: Selection,
        now: Instant,
    ) -> Vec<Request> {
        if phase == KeyPhase::Repeat {
            return Vec::new();
        }
        let timeout = self.settings.repeat_timeout;
        if let Some(a) = self.active.as_mut() {
            let own_repeat = !self.releases
                && a.keys.contains(&key)
                && now.saturating_duration_since(a.last_seen) <= timeout;
            if own_repeat {
                a.last_seen = now;
                return Vec::new();
            }
            let out = self.release_active(now);
            self.latch(key, now);
            return out;
        }
        self.start(gate, vec![key], vector, true, selection, now)
    }

    // ----- the pieces -------------------------------------------------------

    fn start(
        &mut self,
        gate: &Gate<'_>,
        keys: Vec<K>,
        vector: Vector,
        toggle: bool,
        selection: Selection,
        now: Instant,
    ) -> Vec<Request> {
        if vector.is_empty() {
            return Vec::new();
        }
        if let Err(reason) = gate.check(Motion::Jog) {
            for key in keys {
                self.latch(key, now);
            }
            self.last = Some(LastOutcome::Refused { reason, at: now });
            return Vec::new();
        }
        self.next_id += 1;
        let id = JogId(self.next_id);
        // A toggle jog is renewed by the console's tick from the start; a
        // held one waits for the terminal's first repeat.
        let lease = if toggle {
            self.settings.repeat_timeout
        } else {
            self.settings.grace
        };
        let pairs = vector.pairs();
        let speed = match self
            .settings
            .speed_cap(&pairs, self.settings.repeat_timeout)
        {
            Some(cap) => selection.speed.min(cap),
            None => selection.speed,
        };
        let speed_hz: PerAxis<f64> = self.settings.speeds_hz(&pairs, speed);
        self.active = Some(ActiveJog {
            id,
            vector,
            keys,
            toggle,
            started: now,
            lease_until: now + lease,
            renewed: false,
            last_seen: now,
        });
        self.last = None;
        vec![Request::Jog {
            id,
            axes: pairs,
            speed_hz,
            lease,
        }]
    }

    fn renew(&mut self, now: Instant) -> Vec<Request> {
        let timeout = self.settings.repeat_timeout;
        match self.active.as_mut() {
            Some(a) => {
                a.lease_until = now + timeout;
                a.renewed = true;
                a.last_seen = now;
                vec![Request::JogRenew {
                    id: a.id,
                    lease: timeout,
                }]
            }
            None => Vec::new(),
        }
    }

    fn released(&mut self, key: K, now: Instant) -> Vec<Request> {
        self.held.retain(|(k, _)| *k != key);
        if let Some(i) = self.latched.iter().position(|l| l.key == key) {
            self.latched.remove(i);
            return Vec::new();
        }
        let hold = self.active.as_ref().is_some_and(|a| !a.toggle);
        if hold && self.active.as_ref().is_some_and(|a| a.keys.contains(&key)) {
            // Letting go of any key of a held jog stops it; the keys still
            // held repeat no more (terminals repeat the last key only), so
            // they are latched until they are let go too.
            let out = self.release_active(now);
            let held: Vec<K> = self.held.iter().map(|(k, _)| *k).collect();
            for k in held {
                self.latch(k, now);
            }
            return out;
        }
        Vec::new()
    }

    fn release_active(&mut self, _now: Instant) -> Vec<Request> {
        match self.active.take() {
            Some(a) => vec![Request::JogRelease { id: a.id }],
            None => Vec::new(),
        }
    }

    fn refuse(&mut self, key: K, reason: Refusal, now: Instant) -> Vec<Request> {
        self.latch(key, now);
        self.last = Some(LastOutcome::Refused { reason, at: now });
        Vec::new()
    }

    fn latch(&mut self, key: K, now: Instant) {
        match self.latched.iter_mut().find(|l| l.key == key) {
            Some(l) => l.last_seen = now,
            None => self.latched.push(Latch {
                key,
                last_seen: now,
            }),
        }
    }

    /// Whether `key` is latched; keeps the latch fresh while it repeats.
    /// Without release events a pause longer than the repeat timeout means
    /// the key was let go and pressed again; with them only the release
    /// (or a fresh press, should a release have been lost) unlatches.
    fn is_latched(&mut self, key: K, phase: KeyPhase, now: Instant) -> bool {
        let timeout = self.settings.repeat_timeout;
        let releases = self.releases;
        let Some(i) = self.latched.iter().position(|l| l.key == key) else {
            return false;
        };
        let Some(latch) = self.latched.get_mut(i) else {
            return false;
        };
        let let_go = if releases {
            phase == KeyPhase::Press
        } else {
            now.saturating_duration_since(latch.last_seen) > timeout
        };
        if let_go {
            self.latched.remove(i);
            false
        } else {
            latch.last_seen = now;
            true
        }
    }
}
