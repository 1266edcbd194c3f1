//! The jog keypad through `update()`, no terminal: which requests keys turn
//! into in step, hold and toggle jogging, with and without key releases;
//! the stop key; refusals with their reason on the keypad; the axis choice
//! for homing and zeroing; the go-to prompt; quitting while moving.

use crate::ui_support;

use std::time::{Duration, Instant};

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::profile::JogMode;
use jogterm::device::api::{Activity, Dir, Event, Frame, JogEnd, MachineState, Request};
use jogterm::jog::Jogger;
use jogterm::proto::Protocol;
use jogterm::ui::model::{PanelId, Popup};
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ui_support::{State, fresh, model_in, render, text};

fn at(code: KeyCode, kind: KeyEventKind, t: Instant) -> Msg {
    let mut event = KeyEvent::new(code, KeyModifiers::NONE);
    event.kind = kind;
    Msg::KeyAt(event, t)
}

fn down(code: KeyCode, t: Instant) -> Vec<Msg> {
    vec![at(code, KeyEventKind::Press, t)]
}

fn ch(c: char) -> Msg {
    Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

fn press(model: &mut Model, msgs: impl IntoIterator<Item = Msg>) -> Vec<Effect> {
    msgs.into_iter().flat_map(|m| update(model, m)).collect()
}

fn requests(effects: &[Effect]) -> Vec<Request> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Request(r) => Some(r.clone()),
            _ => None,
        })
        .collect()
}

fn screen(model: &Model) -> String {
    text(render(model, 100, 30).backend().buffer())
}

fn ready() -> Model {
    model_in(Protocol::Isel, "dark", State::Idle, Instant::now())
}

fn continuous(model: &mut Model) {
    press(model, [ch('c')]);
}

fn with_mode(model: &mut Model, mode: JogMode) {
    let mut settings = model.setup.jog.clone();
    settings.mode = mode;
    model.keypad.jogger = Jogger::new(settings);
}

#[test]
fn the_keypad_has_focus_at_start_and_shows_its_keys() {
    let m = ready();
    assert_eq!(m.focus, PanelId::Jog);
    let s = screen(&m);
    for needle in [
        "→X+",
        "←X-",
        "↑Y+",
        "↓Y-",
        "PgUp Z+",
        "PgDn Z-",
        "STEP 1 mm",
    ] {
        assert!(s.contains(needle), "{needle}:\n{s}");
    }
}

#[test]
fn a_step_press_is_one_step_of_the_selected_size() {
    let mut m = ready();
    let t = m.now;
    let fx = press(&mut m, down(KeyCode::Right, t));
    let rs = requests(&fx);
    let [Request::Step { delta, speed_hz }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    // 1 mm at 400 steps/mm (the default profile), X only.
    assert_eq!(delta.get(Axis::X), Some(400));
    assert_eq!(delta.get(Axis::Y), None);
    assert_eq!(speed_hz.get(Axis::X), Some(800.0));
    // Every press or repeat is one step request; the driver coalesces.
    let fx = press(&mut m, down(KeyCode::Right, t + Duration::from_millis(33)));
    assert_eq!(requests(&fx).len(), 1);
    // A diagonal key steps both axes.
    let fx = press(&mut m, [ch('u')]);
    let rs = requests(&fx);
    let [Request::Step { delta, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    assert_eq!(
        (delta.get(Axis::X), delta.get(Axis::Y)),
        (Some(400), Some(400))
    );
}

#[test]
fn a_held_key_jogs_on_leases_and_space_stops_it_for_good() {
    let mut m = ready();
    continuous(&mut m);
    let t = m.now;
    let settings = m.setup.jog.clone();
    let fx = press(&mut m, down(KeyCode::Up, t));
    let rs = requests(&fx);
    let [
        Request::Jog {
            id, axes, lease, ..
        },
    ] = rs.as_slice()
    else {
        panic!("{fx:?}")
    };
    assert_eq!(axes.as_slice(), [(Axis::Y, Dir::Plus)]);
    assert_eq!(
        *lease, settings.grace,
        "the first lease covers the repeat delay"
    );
    let id = *id;
    assert!(screen(&m).contains("jog Y+"), "{}", screen(&m));
    // Without release events the repeats arrive as presses: renewals.
    for i in 1..=5u64 {
        let fx = press(
            &mut m,
            down(KeyCode::Up, t + Duration::from_millis(500 + 33 * i)),
        );
        assert_eq!(
            requests(&fx),
            [Request::JogRenew {
                id,
                lease: settings.repeat_timeout
            }]
        );
    }
    // Space stops everything at once; the key still repeating does not
    // start the jog again.
    let fx = press(&mut m, [ch(' ')]);
    assert_eq!(fx, [Effect::Stop]);
    for i in 6..=10u64 {
        let fx = press(
            &mut m,
            down(KeyCode::Up, t + Duration::from_millis(500 + 33 * i)),
        );
        assert!(fx.is_empty(), "{fx:?}");
    }
    // Let go (a pause longer than the timeout), press again: a new jog.
    let fx = press(&mut m, down(KeyCode::Up, t + Duration::from_secs(3)));
    assert!(matches!(requests(&fx).as_slice(), [Request::Jog { id: new, .. }] if *new != id));
}

#[test]
fn with_key_releases_the_release_ends_the_jog() {
    let mut m = ready();
    m.keypad.set_releases(true);
    continuous(&mut m);
    let t = m.now;
    let fx = press(&mut m, down(KeyCode::Right, t));
    let rs = requests(&fx);
    let [Request::Jog { id, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    let id = *id;
    let fx = press(
        &mut m,
        [at(
            KeyCode::Right,
            KeyEventKind::Repeat,
            t + Duration::from_millis(600),
        )],
    );
    assert!(matches!(
        requests(&fx).as_slice(),
        [Request::JogRenew { .. }]
    ));
    let fx = press(
        &mut m,
        [at(
            KeyCode::Right,
            KeyEventKind::Release,
            t + Duration::from_millis(620),
        )],
    );
    assert_eq!(requests(&fx), [Request::JogRelease { id }]);
    assert!(screen(&m).contains("release stops") || !screen(&m).contains("jog X+"));
}

#[test]
fn a_jog_ended_by_the_dead_man_does_not_restart_while_the_key_repeats() {
    let mut m = ready();
    continuous(&mut m);
    let t = m.now;
    let fx = press(&mut m, down(KeyCode::Left, t));
    let rs = requests(&fx);
    let [Request::Jog { id, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    let id = *id;
    // The first repeat is late (a stalled link, say): the lease ran out.
    update(&mut m, Msg::Tick(t + Duration::from_millis(760)));
    update(
        &mut m,
        Msg::Device(Event::JogEnded {
            id,
            end: JogEnd::DeadMan,
        }),
    );
    // The late repeats of the same key: nothing, until it is let go (its
    // repeats pause for longer than the repeat timeout).
    for ms in [800, 833, 866, 900] {
        let fx = press(&mut m, down(KeyCode::Left, t + Duration::from_millis(ms)));
        assert!(fx.is_empty(), "{ms}: {fx:?}");
    }
    let fx = press(&mut m, down(KeyCode::Left, t + Duration::from_millis(1300)));
    assert!(matches!(requests(&fx).as_slice(), [Request::Jog { id: new, .. }] if *new != id));
}

#[test]
fn toggle_mode_is_shown_renewed_by_ticks_and_any_key_stops_it() {
    let mut m = ready();
    with_mode(&mut m, JogMode::Toggle);
    continuous(&mut m);
    let s = screen(&m);
    assert!(s.contains("TOGGLE: any key stops"), "{s}");
    let t = m.now;
    let fx = press(&mut m, down(KeyCode::Right, t));
    let rs = requests(&fx);
    let [Request::Jog { id, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    let id = *id;
    let fx = update(&mut m, Msg::Tick(t + Duration::from_millis(100)));
    assert!(matches!(requests(&fx).as_slice(), [Request::JogRenew { id: i, .. }] if *i == id));
    // `h` would ask for a reference run: here it only stops the jog.
    let fx = press(&mut m, [ch('h')]);
    assert_eq!(requests(&fx), [Request::JogRelease { id }]);
    assert!(m.popup.is_none(), "the key was used up");
}

#[test]
fn motion_is_refused_with_the_reason_on_the_keypad() {
    let mut m = fresh(Protocol::Isel, "dark", Instant::now());
    let fx = press(&mut m, [key(KeyCode::Right)]);
    assert!(fx.is_empty(), "{fx:?}");
    let s = screen(&m);
    assert!(s.contains("not connected"), "{s}");

    let mut m = model_in(Protocol::Isel, "dark", State::EStop, Instant::now());
    continuous(&mut m);
    let fx = press(&mut m, [key(KeyCode::Right)]);
    assert!(fx.is_empty(), "{fx:?}");
    let s = screen(&m);
    assert!(
        s.to_lowercase().contains("e-stop") || s.contains("emergency"),
        "{s}"
    );
}

#[test]
fn one_axis_is_homed_or_zeroed_through_the_axis_choice() {
    let mut m = ready();
    press(&mut m, [ch('H')]);
    assert!(matches!(m.popup, Some(Popup::Axes(_))));
    assert!(screen(&m).contains("Reference run"));
    // The default machine has no A axis: the popup stays and says so.
    assert!(press(&mut m, [ch('a')]).is_empty());
    assert!(matches!(m.popup, Some(Popup::Axes(_))));
    let fx = press(&mut m, [ch('y')]);
    assert_eq!(
        requests(&fx),
        [Request::Home {
            axes: AxisSet::EMPTY.with(Axis::Y)
        }]
    );
    assert!(m.popup.is_none());
    // The keypad shows the run's progress.
    let homing = MachineState {
        activity: Activity::Homing,
        ..m.machine.clone()
    };
    update(&mut m, Msg::Device(Event::State(homing)));
    assert!(screen(&m).contains("homing Y"), "{}", screen(&m));

    let mut m = ready();
    press(&mut m, [ch('Z')]);
    let fx = press(&mut m, [key(KeyCode::Enter)]);
    assert_eq!(
        requests(&fx),
        [Request::SetZero {
            axes: m.setup.axis_set()
        }]
    );
    // Esc closes the choice and does nothing else.
    press(&mut m, [ch('Z')]);
    let fx = press(&mut m, [key(KeyCode::Esc)]);
    assert!(fx.is_empty() && m.popup.is_none(), "{fx:?}");
}

#[test]
fn go_to_checks_the_soft_limits_then_moves_in_work_coordinates() {
    let mut m = ready();
    press(&mut m, [ch('g')]);
    assert!(matches!(m.popup, Some(Popup::GoTo(_))));
    // Work zero at X = 10 mm; the X soft limits are 0..300 mm.
    let fx = press(&mut m, "X-20".chars().map(ch).chain([key(KeyCode::Enter)]));
    assert!(fx.is_empty(), "{fx:?}");
    let s = screen(&m);
    assert!(s.contains("outside the soft limits"), "{s}");
    press(
        &mut m,
        [Msg::Key(KeyEvent::new(
            KeyCode::Char('u'),
            KeyModifiers::CONTROL,
        ))],
    );
    let fx = press(
        &mut m,
        "x5,y=2".chars().map(ch).chain([key(KeyCode::Enter)]),
    );
    let rs = requests(&fx);
    let [Request::MoveTo { target, frame, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    // Sent in machine coordinates: the work offsets are jogterm's.
    assert_eq!(*frame, Frame::Machine);
    assert_eq!(
        (target.get(Axis::X), target.get(Axis::Y)),
        (Some(6000), Some(800))
    );
    assert!(m.popup.is_none());

    // Go to zero asks first.
    let fx = press(&mut m, [ch('G')]);
    assert!(fx.is_empty());
    assert!(matches!(m.popup, Some(Popup::Confirm(_))));
    let fx = press(&mut m, [ch('y')]);
    assert!(matches!(requests(&fx).as_slice(), [Request::MoveTo { .. }]));
}

#[test]
fn quitting_while_a_jog_runs_asks_and_then_stops_first() {
    let mut m = ready();
    continuous(&mut m);
    let t = m.now;
    press(&mut m, down(KeyCode::Right, t));
    let fx = press(&mut m, [ch('q')]);
    assert!(!fx.contains(&Effect::Quit), "{fx:?}");
    assert!(matches!(m.popup, Some(Popup::Confirm(_))));
    let fx = press(&mut m, [ch('y')]);
    assert_eq!(fx, [Effect::Stop, Effect::Quit]);

    // Idle: q quits at once, still stopping first.
    let mut m = ready();
    assert_eq!(press(&mut m, [ch('q')]), [Effect::Stop, Effect::Quit]);
}

/// Issue 20, finding 6: pressing `q` mid-jog ends the key repeats, so the
/// dead-man stops the jog while the question is open; it went on saying
/// "The machine is moving (Jogging)".
#[test]
fn the_quit_question_says_when_the_dead_man_has_stopped_the_jog() {
    let mut m = ready();
    continuous(&mut m);
    let t = m.now;
    let fx = press(&mut m, down(KeyCode::Right, t));
    let rs = requests(&fx);
    let [Request::Jog { id, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    let id = *id;
    let jogging = MachineState {
        activity: Activity::Jogging,
        ..m.machine.clone()
    };
    update(&mut m, Msg::Device(Event::State(jogging.clone())));
    press(&mut m, [ch('q')]);
    let question = |m: &Model| match &m.popup {
        Some(Popup::Confirm(c)) => c.question.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(
        question(&m),
        "The machine is jogging. Stop all motion, close the port and quit?"
    );
    update(
        &mut m,
        Msg::Device(Event::JogEnded {
            id,
            end: JogEnd::DeadMan,
        }),
    );
    update(
        &mut m,
        Msg::Device(Event::State(MachineState {
            activity: Activity::Idle,
            ..jogging
        })),
    );
    assert_eq!(
        question(&m),
        "The machine has stopped. Close the port and quit?"
    );
    assert!(screen(&m).contains("The machine has stopped"));
    // The answer still stops first.
    assert_eq!(press(&mut m, [ch('y')]), [Effect::Stop, Effect::Quit]);
}

/// Issue 20, finding 6: an isel controller is not polled during a reference
/// run, so nothing redrew the screen and the homing timer stood still.
#[test]
fn the_homing_timer_redraws_on_the_clock_alone() {
    let mut m = ready();
    let fx = press(&mut m, [ch('h'), ch('y')]);
    assert!(
        matches!(requests(&fx).as_slice(), [Request::Home { .. }]),
        "{fx:?}"
    );
    let homing = MachineState {
        activity: Activity::Homing,
        ..m.machine.clone()
    };
    update(&mut m, Msg::Device(Event::State(homing)));
    let t = m.now;
    for tenths in 1..=20u64 {
        m.dirty = false;
        update(&mut m, Msg::Tick(t + Duration::from_millis(100 * tenths)));
        assert!(m.dirty, "no redraw at {tenths} tenths");
    }
    assert!(screen(&m).contains("homing XYZ 2.0 s"), "{}", screen(&m));
}

#[test]
fn a_terminating_message_stops_and_forgets_the_jog() {
    let mut m = ready();
    continuous(&mut m);
    let t = m.now;
    press(&mut m, down(KeyCode::Right, t));
    let fx = update(
        &mut m,
        Msg::Terminate {
            reason: "hang-up signal".into(),
        },
    );
    assert_eq!(fx, [Effect::Stop, Effect::Quit]);
    assert!(m.keypad.jogger.active().is_none());
}
