//! The step-queue bound over arrival schedules: the console (`update`, the
//! keypad, the burst rule) in front of the real isel driver and the isel
//! simulator on synthetic time, the wire modelled at 19200 baud both ways
//! (`device::common::testing::Bench`). Keys come lone or read together
//! (bursts), pasted, with any gap between them, across switches between
//! step and continuous jogging; the travel the controller makes is counted
//! from its own step counters.
//!
//! - a burst (keys read together, or within `BURST_GAP` of the key before)
//!   and a paste never ask for a step or a jog;
//! - after the last key, the axis travels at most what `docs/jogging.md`
//!   promises: `2 · step_queue` steps (the move running, up to `step_queue`
//!   presses merged, and `step_queue` presses waiting), or a jog's overrun
//!   bound, whichever the last keys left running;
//! - the driver alone, fed step presses at any gaps (no console in front to
//!   catch bursts): the same bound, and `1 + step_queue` steps for presses
//!   that all arrive at once from rest.

use std::time::{Duration, Instant};

use proptest::prelude::*;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

use crate::axis::Axis;
use crate::config::{ConfigDirs, Profile, load_profile, load_theme};
use crate::device::api::{Event, LinkState, PerAxis, Request};
use crate::device::common::testing::Bench;
use crate::device::isel::{IselDriver, IselSettings, PollRate};
use crate::sim::isel::IselSim;
use crate::ui::keymap::Keymap;
use crate::ui::model::{Model, Setup};
use crate::ui::palette::Palette;
use crate::ui::{Effect, Msg, update};
use crate::wire::LineSettings;

use super::BURST_GAP;

type IselBench = Bench<IselDriver, IselSim>;

fn profile() -> Profile {
    load_profile("default", &ConfigDirs::builtin_only()).expect("default profile")
}

/// The driver and the simulator, connected, initialised and referenced
/// where the axes stand (`@0N7`), polling as `rate` says.
fn bench(profile: &Profile, rate: PollRate) -> IselBench {
    let mut settings = IselSettings::from_profile(profile).expect("settings");
    settings.poll.rate = rate;
    let sim = IselSim::from_profile(profile).expect("simulator");
    let mut b = Bench::new(IselDriver::new(settings), sim, LineSettings::new(19200));
    b.run(Duration::from_millis(500));
    b.request(Request::Initialise);
    b.run(Duration::from_millis(500));
    b.request(Request::Raw {
        line: "@0N7".into(),
    });
    b.run(Duration::from_millis(500));
    assert!(
        !b.driver.state().referenced.is_empty(),
        "{:?}",
        b.driver.state()
    );
    b
}

fn x_mm(b: &IselBench, profile: &Profile) -> f64 {
    let spu = profile.axis(Axis::X).map_or(1.0, |a| a.steps_per_unit);
    b.sim.counters_at(b.now)[0] / spu
}

/// A key the schedule presses: all move X+ (so travel adds up).
#[derive(Debug, Clone, Copy)]
enum Key {
    Right,
    /// `6` on the numeric keypad.
    Six,
    /// `u`: X+ Y+.
    Diagonal,
}

impl Key {
    fn event(self) -> KeyEvent {
        let code = match self {
            Key::Right => KeyCode::Right,
            Key::Six => KeyCode::Char('6'),
            Key::Diagonal => KeyCode::Char('u'),
        };
        KeyEvent::new(code, KeyModifiers::NONE)
    }
}

#[derive(Debug, Clone)]
enum Arrival {
    /// Keys read together (one key: read alone).
    Keys(Vec<Key>),
    /// `n` jog keys as a bracketed paste.
    Paste(usize),
    /// `c`: step <-> continuous.
    Switch,
}

fn key() -> impl Strategy<Value = Key> {
    prop_oneof![Just(Key::Right), Just(Key::Six), Just(Key::Diagonal)]
}

fn arrival() -> impl Strategy<Value = Arrival> {
    prop_oneof![
        6 => prop::collection::vec(key(), 1..2).prop_map(Arrival::Keys),
        3 => prop::collection::vec(key(), 2..12).prop_map(Arrival::Keys),
        1 => (1usize..12).prop_map(Arrival::Paste),
        1 => Just(Arrival::Switch),
    ]
}

/// The console on the bench's time line, fed the driver's events.
struct Console {
    model: Model,
    bench: IselBench,
    /// Requests that may move: how many steps and jogs were asked for.
    steps: usize,
}

impl Console {
    fn new(profile: &Profile, rate: PollRate) -> Console {
        let bench = bench(profile, rate);
        let theme = load_theme("dark", &ConfigDirs::builtin_only()).expect("theme");
        let mut model = Model::new(
            Setup::from_profile(profile, None),
            Keymap::builtin().expect("keys"),
            Palette::from(&theme),
            bench.now,
        );
        update(&mut model, Msg::Device(Event::Link(LinkState::Connected)));
        let mut console = Console {
            model,
            bench,
            steps: 0,
        };
        console.feed();
        console
    }

    /// The driver's events into the model.
    fn feed(&mut self) {
        for e in std::mem::take(&mut self.bench.events) {
            update(&mut self.model, Msg::Device(e));
        }
    }

    /// Carry out what `update` asked for; the motion requests it made.
    fn effects(&mut self, effects: Vec<Effect>) -> Vec<Request> {
        let mut motion = Vec::new();
        for effect in effects {
            match effect {
                Effect::Stop => self.bench.stop(),
                Effect::Request(r) => {
                    if matches!(r, Request::Step { .. } | Request::Jog { .. }) {
                        motion.push(r.clone());
                    }
                    self.steps += usize::from(matches!(r, Request::Step { .. }));
                    self.bench.request(r);
                }
                _ => {}
            }
        }
        self.feed();
        motion
    }

    /// Time passes on the bench, the console ticking every 50 ms.
    fn run(&mut self, d: Duration) {
        let end = self.bench.now + d;
        while self.bench.now < end {
            let step = (end - self.bench.now).min(Duration::from_millis(50));
            self.bench.run(step);
            self.feed();
            let fx = update(&mut self.model, Msg::Tick(self.bench.now));
            self.effects(fx);
        }
    }
}

/// The whole console: bursts and pastes ask for no motion; after the last
/// key the axis travels at most the documented bound.
fn console_keeps_the_bound(
    rate: PollRate,
    schedule: &[(u64, Arrival)],
) -> Result<(), TestCaseError> {
    let profile = profile();
    let mut c = Console::new(&profile, rate);
    let q = c.model.keypad.settings().step_queue as f64;
    let step = c.model.jog_step().unwrap_or(0.0);
    let overrun = profile.jog.max_overrun;
    let mut last_key: Option<Instant> = None;
    let mut continuous = false;
    for (gap, arrival) in schedule {
        c.run(Duration::from_millis(*gap));
        let now = c.bench.now;
        let (msg, burst) = match arrival {
            Arrival::Keys(keys) => {
                let batch: Vec<(KeyEvent, Instant)> = keys
                    .iter()
                    .enumerate()
                    .map(|(i, k)| (k.event(), now + Duration::from_micros(20 * i as u64)))
                    .collect();
                let burst = batch.len() > 1
                    || last_key.is_some_and(|t| now.saturating_duration_since(t) < BURST_GAP);
                last_key = batch.last().map(|(_, t)| *t);
                let msg = match batch.as_slice() {
                    [(k, at)] => Msg::KeyAt(*k, *at),
                    _ => Msg::KeysAt(batch),
                };
                (msg, burst)
            }
            Arrival::Paste(n) => (Msg::Paste("6".repeat(*n)), true),
            Arrival::Switch => {
                let burst = last_key.is_some_and(|t| now.saturating_duration_since(t) < BURST_GAP);
                last_key = Some(now);
                continuous ^= !burst;
                let c_key = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::NONE);
                (Msg::KeyAt(c_key, now), false)
            }
        };
        let fx = update(&mut c.model, msg);
        let motion = c.effects(fx);
        prop_assert!(
            !burst || motion.is_empty(),
            "{arrival:?} after {gap} ms (a burst or paste) asked for {motion:?}"
        );
    }
    let at_last = x_mm(&c.bench, &profile);
    c.run(Duration::from_secs(6));
    let after = x_mm(&c.bench, &profile) - at_last;
    let bound = (2.0 * q * step).max(if continuous { overrun } else { 0.0 });
    prop_assert!(
        after <= bound + 1e-6,
        "{after:.3} mm after the last key (bound {bound} mm, {} steps asked for)",
        c.steps
    );
    Ok(())
}

/// Step presses straight into the driver at the given gaps (ms): nothing in
/// front catches a burst. After the last press at most `2 · step_queue`
/// steps; presses that all arrive at once from rest, `1 + step_queue`.
fn driver_keeps_the_bound(rate: PollRate, gaps: &[u64]) -> Result<(), TestCaseError> {
    let profile = profile();
    let mut b = bench(&profile, rate);
    let settings = crate::jog::JogSettings::from_profile(&profile);
    let pairs = [(Axis::X, crate::device::api::Dir::Plus)];
    let step = 1.0;
    let delta: PerAxis<i64> = settings.step_delta(&pairs, step);
    let speed_hz = settings.speeds_hz(&pairs, 2.0);
    let start = x_mm(&b, &profile);
    for gap in gaps {
        b.run(Duration::from_millis(*gap));
        b.request(Request::Step { delta, speed_hz });
    }
    let at_last = x_mm(&b, &profile);
    b.run(Duration::from_secs(6));
    let end = x_mm(&b, &profile);
    let q = settings.step_queue as f64;
    prop_assert!(
        end - at_last <= 2.0 * q * step + 1e-6,
        "{:.3} mm after the last press",
        end - at_last
    );
    if gaps.iter().all(|g| *g == 0) {
        prop_assert!(
            end - start <= (1.0 + q) * step + 1e-6,
            "{} presses at once from rest: {:.3} mm",
            gaps.len(),
            end - start
        );
    }
    Ok(())
}

fn rate() -> impl Strategy<Value = PollRate> {
    prop_oneof![Just(PollRate::LineSpeed), Just(PollRate::Off)]
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 24,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn bursts_and_pastes_never_move_and_the_step_bound_holds(
        rate in rate(),
        schedule in prop::collection::vec((0u64..150, arrival()), 1..24),
    ) {
        console_keeps_the_bound(rate, &schedule)?;
    }

    #[test]
    fn the_driver_keeps_the_step_bound_for_any_gaps(
        rate in rate(),
        gaps in prop::collection::vec(prop_oneof![3 => Just(0u64), 2 => 0u64..40, 1 => 0u64..400], 1..20),
    ) {
        driver_keeps_the_bound(rate, &gaps)?;
    }
}

/// The cases issue 13 reported, by hand: ten `6` read together, and ten
/// pasted, in step jogging with polling at line speed, move nothing.
#[test]
fn ten_keys_together_or_pasted_move_nothing() {
    let profile = profile();
    for arrival in [Arrival::Keys(vec![Key::Six; 10]), Arrival::Paste(10)] {
        let mut c = Console::new(&profile, PollRate::LineSpeed);
        let x0 = x_mm(&c.bench, &profile);
        let now = c.bench.now;
        let msg = match &arrival {
            Arrival::Keys(keys) => Msg::KeysAt(keys.iter().map(|k| (k.event(), now)).collect()),
            _ => Msg::Paste("6666666666".into()),
        };
        let fx = update(&mut c.model, msg);
        assert!(c.effects(fx).is_empty(), "{arrival:?}");
        c.run(Duration::from_secs(3));
        assert_eq!(x_mm(&c.bench, &profile), x0, "{arrival:?}");
        let said = c.model.message.as_ref().map(|m| m.text.clone());
        assert!(
            said.as_deref().is_some_and(|t| t.contains("ignored")),
            "{said:?}"
        );
        // A key typed alone afterwards (the burst's latch let go) steps.
        c.run(Duration::from_millis(200));
        let now = c.bench.now;
        let fx = update(&mut c.model, Msg::KeyAt(Key::Right.event(), now));
        assert_eq!(c.effects(fx).len(), 1);
        c.run(Duration::from_secs(2));
        assert!((x_mm(&c.bench, &profile) - x0 - 1.0).abs() < 1e-6);
    }
}
