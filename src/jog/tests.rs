//! The keypad logic with synthetic time: what each mode sends for presses,
//! repeats and releases, with and without release events, and properties
//! over any sequence of keys, ticks, ends and stops.

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use proptest::prelude::*;

use crate::axis::{Axis, AxisSet};
use crate::config::profile::JogMode;
use crate::config::{ConfigDirs, load_profile};
use crate::device::api::{Dir, JogEnd, JogId, LinkState, MachineState, Refusal, Request};
use crate::motion::{Braking, speed_cap};

use super::*;

fn settings(mode: JogMode) -> JogSettings {
    let mut profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
    profile.jog.mode = mode;
    JogSettings::from_profile(&profile)
}

fn ready() -> MachineState {
    MachineState {
        link_up: true,
        initialised: AxisSet::XYZ,
        referenced: AxisSet::XYZ,
        ..MachineState::default()
    }
}

fn gate(m: &MachineState) -> Gate<'_> {
    Gate {
        link: &LinkState::Connected,
        machine: m,
        axes: AxisSet::XYZ,
        allow_unreferenced: false,
    }
}

const RIGHT: char = 'r';
const UP: char = 'u';

fn vector(key: char) -> Vector {
    match key {
        'r' => Vector::single(Axis::X, Dir::Plus),
        'l' => Vector::single(Axis::X, Dir::Minus),
        'u' => Vector::single(Axis::Y, Dir::Plus),
        _ => Vector::single(Axis::Z, Dir::Minus),
    }
}

const SLOW: Selection = Selection {
    step: 1.0,
    speed: 2.0,
};

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

struct Pad {
    jog: Jogger<char>,
    machine: MachineState,
    now: Instant,
}

impl Pad {
    fn new(mode: JogMode, kind: JogKind, releases: bool) -> Pad {
        let mut jog = Jogger::new(settings(mode));
        jog.set_releases(releases);
        let now = Instant::now();
        jog.set_kind(kind, now);
        Pad {
            jog,
            machine: ready(),
            now,
        }
    }

    fn at(&mut self, after: u64) -> &mut Self {
        self.now += ms(after);
        self
    }

    fn key(&mut self, key: char, phase: KeyPhase) -> Vec<Request> {
        self.key_at(key, phase, SLOW)
    }

    fn key_at(&mut self, key: char, phase: KeyPhase, sel: Selection) -> Vec<Request> {
        let machine = self.machine.clone();
        self.jog
            .key(&gate(&machine), key, vector(key), phase, sel, self.now)
    }

    fn press(&mut self, key: char) -> Vec<Request> {
        self.key(key, KeyPhase::Press)
    }
}

fn jog_id(r: &[Request]) -> JogId {
    match r {
        [Request::Jog { id, .. }] => *id,
        other => panic!("expected one jog, got {other:?}"),
    }
}

#[test]
fn hold_without_releases_starts_on_the_grace_lease_and_repeats_renew() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    let r = p.press(RIGHT);
    let [
        Request::Jog {
            id,
            axes,
            speed_hz,
            lease,
        },
    ] = r.as_slice()
    else {
        panic!("{r:?}")
    };
    assert_eq!(axes, &[(Axis::X, Dir::Plus)]);
    assert_eq!(*lease, ms(750));
    assert_eq!(speed_hz.get(Axis::X), Some(800.0));
    // Repeats arrive as presses of the same key.
    for _ in 0..5 {
        assert_eq!(
            p.at(33).press(RIGHT),
            [Request::JogRenew {
                id: *id,
                lease: ms(150)
            }]
        );
    }
    assert!(p.jog.active().is_some_and(|a| a.renewed));
    // Ticks do not keep a held jog alive: only the terminal's repeats do.
    let now = p.at(40).now;
    assert!(p.jog.tick(now).is_empty());
}

#[test]
fn a_tap_ends_by_the_dead_man_and_its_key_must_pause_before_it_jogs_again() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    let id = jog_id(&p.press(RIGHT));
    p.at(750);
    let now = p.now;
    p.jog.ended(id, &JogEnd::DeadMan, now);
    assert!(p.jog.active().is_none());
    // A repeat that was merely late does not restart it …
    assert!(p.at(100).press(RIGHT).is_empty());
    assert!(p.at(100).press(RIGHT).is_empty());
    // … a new press after a pause does.
    let again = p.at(200).press(RIGHT);
    assert!(jog_id(&again) > id);
}

#[test]
fn without_releases_another_key_ends_the_jog_and_the_old_keys_strays_are_ignored() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    let first = jog_id(&p.press(RIGHT));
    let r = p.at(100).press(UP);
    assert_eq!(r.first(), Some(&Request::JogRelease { id: first }));
    let Some(Request::Jog {
        id: second, axes, ..
    }) = r.get(1)
    else {
        panic!("{r:?}")
    };
    assert_eq!(axes, &[(Axis::Y, Dir::Plus)]);
    assert!(
        p.at(5).press(RIGHT).is_empty(),
        "a stray repeat of the old key"
    );
    assert_eq!(
        p.at(30).press(UP),
        [Request::JogRenew {
            id: *second,
            lease: ms(150)
        }]
    );
}

#[test]
fn with_releases_keys_held_together_jog_diagonally_and_a_release_stops_at_once() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, true);
    let first = jog_id(&p.press(RIGHT));
    assert_eq!(
        p.at(500).key(RIGHT, KeyPhase::Repeat),
        [Request::JogRenew {
            id: first,
            lease: ms(150)
        }]
    );
    let r = p.at(100).press(UP);
    assert_eq!(r.first(), Some(&Request::JogRelease { id: first }));
    let Some(Request::Jog {
        id: both,
        axes,
        lease,
        ..
    }) = r.get(1)
    else {
        panic!("{r:?}")
    };
    assert_eq!(axes, &[(Axis::X, Dir::Plus), (Axis::Y, Dir::Plus)]);
    assert_eq!(*lease, ms(750));
    // Letting go of either key stops the diagonal at once …
    assert_eq!(
        p.at(200).key(UP, KeyPhase::Release),
        [Request::JogRelease { id: *both }]
    );
    // … and the key still held does not start anything by itself.
    assert!(p.at(10).key(RIGHT, KeyPhase::Repeat).is_empty());
    assert!(p.at(10).key(RIGHT, KeyPhase::Release).is_empty());
    assert!(p.jog.active().is_none());
    // A fresh press jogs again.
    jog_id(&p.at(10).press(RIGHT));
}

#[test]
fn toggle_starts_on_a_press_lives_on_ticks_and_stops_on_any_key() {
    let mut p = Pad::new(JogMode::Toggle, JogKind::Continuous, false);
    let r = p.press(RIGHT);
    let [Request::Jog { id, lease, .. }] = r.as_slice() else {
        panic!("{r:?}")
    };
    assert_eq!(*lease, ms(150), "the tick renews it from the start");
    let id = *id;
    let now = p.at(50).now;
    assert_eq!(p.jog.tick(now), [Request::JogRenew { id, lease: ms(150) }]);
    // Its own key repeating (presses, without release events) is no stop.
    assert!(p.at(33).press(RIGHT).is_empty());
    assert!(p.at(33).press(RIGHT).is_empty());
    // Any other key stops it and is used up.
    let now = p.at(300).now;
    assert_eq!(
        p.jog.other_key('x', KeyPhase::Press, now),
        Some(vec![Request::JogRelease { id }])
    );
    assert!(p.jog.tick(now).is_empty());
    assert_eq!(p.jog.other_key('x', KeyPhase::Press, now), None);
    // The same key after a pause stops it too.
    let second = jog_id(&p.at(300).press(RIGHT));
    assert_eq!(p.at(500).press(RIGHT), [Request::JogRelease { id: second }]);
    assert!(p.at(20).press(RIGHT).is_empty(), "latched until let go");
}

#[test]
fn each_step_press_is_one_step_of_the_selected_size() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Step, false);
    let r = p.key_at(
        UP,
        KeyPhase::Press,
        Selection {
            step: 0.1,
            speed: 2.0,
        },
    );
    let [Request::Step { delta, speed_hz }] = r.as_slice() else {
        panic!("{r:?}")
    };
    assert_eq!(delta.get(Axis::Y), Some(40));
    assert_eq!(speed_hz.get(Axis::Y), Some(800.0));
    // Every repeat is a press; the driver bounds what piles up.
    for _ in 0..3 {
        assert_eq!(p.at(33).key(UP, KeyPhase::Repeat).len(), 1);
    }
    assert!(p.at(33).key(UP, KeyPhase::Release).is_empty());
    p.jog.step_dropped();
    assert_eq!(p.jog.dropped_steps(), 1);
    p.at(500).press(UP);
    assert_eq!(p.jog.dropped_steps(), 0, "counted per hold");
}

#[test]
fn a_refused_key_says_why_once_and_sends_nothing() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    p.machine.referenced = AxisSet::EMPTY;
    assert!(p.press(RIGHT).is_empty());
    assert!(matches!(
        p.jog.last(),
        Some(LastOutcome::Refused {
            reason: Refusal::NotReferenced { .. },
            ..
        })
    ));
    // The repeats are latched: nothing, not even a new refusal time.
    let at = p.now;
    for _ in 0..10 {
        assert!(p.at(33).press(RIGHT).is_empty());
    }
    assert!(matches!(p.jog.last(), Some(LastOutcome::Refused { at: t, .. }) if *t == at));
}

#[test]
fn fast_speeds_are_asked_for_at_most_the_repeat_phase_cap() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    let r = p.key_at(
        RIGHT,
        KeyPhase::Press,
        Selection {
            step: 1.0,
            speed: 15.0,
        },
    );
    let [Request::Jog { speed_hz, .. }] = r.as_slice() else {
        panic!("{r:?}")
    };
    let hz = speed_hz.get(Axis::X).unwrap_or(0.0);
    let cap = speed_cap(
        &Braking::Ramp {
            start_hz: 300.0,
            accel_hz_per_s: 100_000.0,
        },
        ms(150),
        1200.0,
    );
    assert!(hz <= cap + 1e-6 && hz > 0.95 * cap, "{hz} vs {cap}");
}

#[test]
fn stop_and_mode_changes_latch_the_keys_in_use() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    let id = jog_id(&p.press(RIGHT));
    let now = p.at(100).now;
    p.jog.stopped(now);
    assert!(p.jog.active().is_none());
    assert!(p.at(33).press(RIGHT).is_empty());
    // The stop's own end report changes nothing.
    let now = p.now;
    p.jog.ended(id, &JogEnd::Stopped, now);
    let id = jog_id(&p.at(200).press(RIGHT));
    let now = p.at(50).now;
    assert_eq!(
        p.jog.set_kind(JogKind::Step, now),
        [Request::JogRelease { id }]
    );
    assert!(
        p.at(33).press(RIGHT).is_empty(),
        "no step from the old hold"
    );
    assert_eq!(p.at(200).press(RIGHT).len(), 1);
}

#[test]
fn a_jog_never_reported_ended_is_forgotten_after_its_lease() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    jog_id(&p.press(RIGHT));
    let now = p.at(750 + 2_001).now;
    p.jog.tick(now);
    assert!(p.jog.active().is_none());
}

// ----- properties ---------------------------------------------------------

#[derive(Debug, Clone)]
enum Step {
    Key(char, KeyPhase),
    Other,
    Tick,
    /// The device task ends the active jog (index into the ends).
    End(usize),
    Stop,
    Kind(bool),
}

fn step() -> impl Strategy<Value = (u64, Step)> {
    let key = prop::sample::select(vec!['r', 'l', 'u', 'd']);
    let phase = prop::sample::select(vec![KeyPhase::Press, KeyPhase::Repeat, KeyPhase::Release]);
    let step = prop_oneof![
        6 => (key, phase).prop_map(|(k, p)| Step::Key(k, p)),
        1 => Just(Step::Other),
        2 => Just(Step::Tick),
        1 => (0usize..5).prop_map(Step::End),
        1 => Just(Step::Stop),
        1 => any::<bool>().prop_map(Step::Kind),
    ];
    (0u64..400, step)
}

fn ends() -> [JogEnd; 5] {
    [
        JogEnd::Released,
        JogEnd::DeadMan,
        JogEnd::SoftLimit,
        JogEnd::Stopped,
        JogEnd::Refused(Refusal::NotConnected),
    ]
}

#[test]
fn a_burst_never_moves_and_its_keys_stay_latched_until_let_go() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Step, false);
    let now = p.now;
    for _ in 0..10 {
        assert!(p.jog.burst_key(RIGHT, KeyPhase::Press, now).is_empty());
    }
    // The rest of a paste, read a moment later, as a lone key: latched.
    assert!(p.at(3).press(RIGHT).is_empty());
    assert!(p.at(100).press(RIGHT).is_empty());
    // Let go (no key for longer than the repeat timeout): a press steps.
    assert!(matches!(
        p.at(200).press(RIGHT).as_slice(),
        [Request::Step { .. }]
    ));
}

#[test]
fn a_burst_renews_the_held_jog_it_belongs_to_and_starts_no_other() {
    let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, false);
    let id = jog_id(&p.press(RIGHT));
    let now = p.at(500).now;
    // Repeats bunched by the network: each renews, nothing new starts.
    for _ in 0..3 {
        assert_eq!(
            p.jog.burst_key(RIGHT, KeyPhase::Press, now),
            [Request::JogRenew { id, lease: ms(150) }]
        );
    }
    assert!(p.jog.burst_key(UP, KeyPhase::Press, now).is_empty());
    assert_eq!(p.jog.active().map(|a| a.id), Some(id));
    // Up stays latched while it repeats.
    assert!(p.at(30).press(UP).is_empty());
}

#[test]
fn a_burst_in_toggle_mode_is_the_jogs_own_repeat_or_stops_it() {
    let mut p = Pad::new(JogMode::Toggle, JogKind::Continuous, false);
    let id = jog_id(&p.press(RIGHT));
    let now = p.at(20).now;
    assert!(p.jog.burst_key(RIGHT, KeyPhase::Press, now).is_empty());
    assert!(p.jog.active().is_some());
    assert_eq!(
        p.jog.burst_key(UP, KeyPhase::Press, now),
        [Request::JogRelease { id }]
    );
    assert!(p.jog.active().is_none());
    // With nothing running a burst starts nothing.
    assert!(p.jog.burst_key(UP, KeyPhase::Press, now).is_empty());
    assert!(p.jog.active().is_none());
}

proptest! {
    /// Whatever the keys do: every renewal and release names a jog the pad
    /// started and has not let go of; at most one of its jogs is alive at
    /// a time; leases are the grace (held, first), the repeat timeout
    /// (renewals, toggle); held jogs are renewed only by keys, never by time;
    /// one key event asks for at most one step; a machine that may not move
    /// gets no motion requests at all.
    #[test]
    fn requests_follow_the_keys(
        releases: bool,
        toggle: bool,
        may_move: bool,
        steps in prop::collection::vec(step(), 0..200),
    ) {
        let mode = if toggle { JogMode::Toggle } else { JogMode::Hold };
        let mut p = Pad::new(mode, JogKind::Continuous, releases);
        if !may_move {
            p.machine.estop = true;
        }
        let mut alive: BTreeSet<u64> = BTreeSet::new();
        let mut finished: BTreeSet<u64> = BTreeSet::new();
        for (dt, s) in steps {
            p.at(dt);
            let now = p.now;
            let (out, from_key) = match &s {
                Step::Key(k, phase) => (p.key(*k, *phase), true),
                Step::Other => (p.jog.other_key('x', KeyPhase::Press, now).unwrap_or_default(), true),
                Step::Tick => {
                    let before = p.jog.active().map(|a| a.id.0);
                    let out = p.jog.tick(now);
                    if let Some(id) = before
                        && p.jog.active().is_none()
                    {
                        // Forgotten long after its lease ran out: the device
                        // task has ended it by then.
                        alive.remove(&id);
                        finished.insert(id);
                    }
                    (out, false)
                }
                Step::End(i) => {
                    if let Some(a) = p.jog.active().map(|a| a.id) {
                        let end = ends()[*i].clone();
                        p.jog.ended(a, &end, now);
                        alive.remove(&a.0);
                        finished.insert(a.0);
                    }
                    (Vec::new(), false)
                }
                Step::Stop => {
                    p.jog.stopped(now);
                    // The device stops everything.
                    finished.extend(alive.iter().copied());
                    alive.clear();
                    (Vec::new(), false)
                }
                Step::Kind(cont) => {
                    let kind = if *cont { JogKind::Continuous } else { JogKind::Step };
                    (p.jog.set_kind(kind, now), false)
                }
            };
            let steps_asked = out.iter().filter(|r| matches!(r, Request::Step { .. })).count();
            prop_assert!(steps_asked <= 1);
            for r in &out {
                match r {
                    Request::Jog { id, lease, .. } => {
                        prop_assert!(may_move, "{r:?} while the machine may not move");
                        prop_assert!(from_key);
                        prop_assert!(alive.is_empty(), "{id:?} while {alive:?} alive");
                        prop_assert!(!finished.contains(&id.0));
                        let expected = if toggle { ms(150) } else { ms(750) };
                        prop_assert_eq!(*lease, expected);
                        alive.insert(id.0);
                    }
                    Request::JogRenew { id, lease } => {
                        prop_assert!(alive.contains(&id.0), "renewal of {id:?}");
                        prop_assert_eq!(*lease, ms(150));
                        prop_assert!(from_key || toggle, "a held jog renewed by time");
                    }
                    Request::JogRelease { id } => {
                        prop_assert!(alive.remove(&id.0), "release of {id:?}");
                        finished.insert(id.0);
                    }
                    Request::Step { .. } => prop_assert!(may_move && from_key),
                    other => prop_assert!(false, "unexpected {other:?}"),
                }
            }
            prop_assert!(alive.len() <= 1);
            prop_assert_eq!(p.jog.active().map(|a| a.id.0), alive.iter().next().copied());
        }
    }

    /// With release events, letting go of a key of the held jog stops it in
    /// the same breath.
    #[test]
    fn a_release_of_a_held_jogs_key_releases_it(
        keys in prop::collection::vec((prop::sample::select(vec!['r', 'u', 'd']), 0u64..100), 1..20),
    ) {
        let mut p = Pad::new(JogMode::Hold, JogKind::Continuous, true);
        for (k, dt) in keys {
            p.at(dt);
            p.press(k);
        }
        if let Some(active) = p.jog.active().cloned() {
            let key = active.keys[0];
            let out = p.at(1).key(key, KeyPhase::Release);
            prop_assert_eq!(out, vec![Request::JogRelease { id: active.id }]);
        }
    }
}
