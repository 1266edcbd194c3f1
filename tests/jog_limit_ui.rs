//! The jog off a limit switch (`L`) through `update()`: which switch reads
//! active (the I/O snapshot as the profile wires it), the question, the
//! request a yes sends, the keypad's status line while it runs, and the
//! reference run asked for once the axis is off the switch; refusals and
//! the EMCU, which cannot do it.

// Test code: a failed unwrap, expect or panic is the test failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod ui_support;

use std::time::Instant;

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, load_profile};
use jogterm::device::api::{
    Activity, ControllerFault, Dir, Event, IoSnapshot, JogEnd, MachineState, Recovery, Refusal,
    Request,
};
use jogterm::device::isel::input_group;
use jogterm::proto::Protocol;
use jogterm::proto::isel::InputPort;
use jogterm::ui::model::Popup;
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ui_support::{State, model_in, render, send, text};

fn ch(c: char) -> Msg {
    let modifiers = if c.is_ascii_uppercase() {
        KeyModifiers::SHIFT
    } else {
        KeyModifiers::NONE
    };
    Msg::Key(KeyEvent::new(KeyCode::Char(c), modifiers))
}

fn enter() -> Msg {
    Msg::Key(KeyEvent::new(KeyCode::Enter, KeyModifiers::NONE))
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

fn message(model: &Model) -> String {
    model
        .message
        .as_ref()
        .map(|m| m.text.clone())
        .unwrap_or_default()
}

/// Port 3 of the default profile's isel controller reading `raw`.
fn port3(raw: u8) -> IoSnapshot {
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
    let wiring = profile.wiring().expect("wiring");
    IoSnapshot {
        at: Instant::now(),
        groups: vec![input_group(InputPort::LimitSwitches, raw, &wiring)],
    }
}

/// After a `2` in limit X1 and a new initialisation: the reference is what
/// the fault asks for, the switch still reads active.
fn after_a_2(model: &mut Model) {
    let state = MachineState {
        link_up: true,
        initialised: AxisSet::XYZ,
        limit: true,
        fault: Some(ControllerFault {
            command: "@0A-2000,2000,0,300,0,300,0,300".into(),
            code: "2".into(),
            meaning: "limit switch".into(),
            recovery: Recovery::Reference,
        }),
        ..MachineState::default()
    };
    send(model, [Event::State(state), Event::Io(port3(0b01))]);
}

#[test]
fn l_asks_then_jogs_the_axis_off_its_switch_and_asks_for_a_reference_run() {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    after_a_2(&mut m);
    // The keypad's own jogs stay refused.
    let fx = update(
        &mut m,
        Msg::Key(KeyEvent::new(KeyCode::Right, KeyModifiers::NONE)),
    );
    assert!(requests(&fx).is_empty());
    let fx = update(&mut m, ch('L'));
    assert!(requests(&fx).is_empty(), "asks first");
    let Some(Popup::Confirm(c)) = &m.popup else {
        panic!("{:?}", m.popup)
    };
    assert_eq!(c.title, "Jog X off its limit switch");
    for needle in [
        "X stands in its min limit switch limit X1 (in3.0)",
        "in X+ (0.5 mm/s)",
        "at most 2 mm",
        "Then a reference run",
    ] {
        assert!(c.question.contains(needle), "{needle}: {}", c.question);
    }
    let s = screen(&m);
    assert!(s.contains("Jog X off its limit switch"), "{s}");
    let fx = update(&mut m, enter());
    let rs = requests(&fx);
    let [Request::LimitJog { id, axis, dir }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    assert_eq!((*axis, *dir), (Axis::X, Dir::Plus));
    let id = *id;
    // Running: the keypad says what and how it stops.
    let running = MachineState {
        activity: Activity::Jogging,
        ..m.machine.clone()
    };
    send(&mut m, [Event::State(running)]);
    let s = screen(&m);
    assert!(s.contains("» off limit X1: X+ at most 2 mm"), "{s}");
    // Off the switch: the reference run is asked for.
    let idle = MachineState {
        activity: Activity::Idle,
        limit: false,
        ..m.machine.clone()
    };
    send(
        &mut m,
        [
            Event::Io(port3(0)),
            Event::JogEnded {
                id,
                end: JogEnd::OffLimit,
            },
            Event::State(idle),
        ],
    );
    let Some(Popup::Confirm(c)) = &m.popup else {
        panic!("{:?}", m.popup)
    };
    assert_eq!(c.title, "Reference run");
    assert!(!screen(&m).contains("off limit X1"));
    let fx = update(&mut m, enter());
    assert_eq!(requests(&fx), [Request::Home { axes: AxisSet::XYZ }]);
}

#[test]
fn a_switch_that_stays_active_is_said_and_no_reference_is_asked() {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    after_a_2(&mut m);
    update(&mut m, ch('L'));
    let fx = update(&mut m, enter());
    let Some(Request::LimitJog { id, .. }) = requests(&fx).first().cloned() else {
        panic!("{fx:?}")
    };
    send(
        &mut m,
        [Event::JogEnded {
            id,
            end: JogEnd::StillOnLimit,
        }],
    );
    assert!(m.popup.is_none());
    assert!(
        message(&m).contains("limit X1 still reads active"),
        "{}",
        message(&m)
    );
}

#[test]
fn l_says_why_not_without_a_switch_before_initialising_and_on_an_emcu() {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    send(&mut m, [Event::Io(port3(0))]);
    update(&mut m, ch('L'));
    assert!(m.popup.is_none());
    assert!(
        message(&m).contains("no limit switch reads active"),
        "{}",
        message(&m)
    );

    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    after_a_2(&mut m);
    let uninitialised = MachineState {
        initialised: AxisSet::EMPTY,
        ..m.machine.clone()
    };
    send(&mut m, [Event::State(uninitialised)]);
    update(&mut m, ch('L'));
    assert!(m.popup.is_none());
    assert!(
        message(&m).contains(&Refusal::NotInitialised.to_string()),
        "{}",
        message(&m)
    );

    // Both switches of X: which end is unknown.
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    after_a_2(&mut m);
    send(&mut m, [Event::Io(port3(0b11))]);
    update(&mut m, ch('L'));
    assert!(
        message(&m).contains("both limit switches of X"),
        "{}",
        message(&m)
    );

    let mut m = model_in(Protocol::Emcu, "dark", State::Idle, Instant::now());
    update(&mut m, ch('L'));
    assert!(m.popup.is_none());
    assert!(message(&m).contains("the EMCU reports no limit switches"));
}

#[test]
fn space_stops_it_and_the_driver_says_stopped() {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    after_a_2(&mut m);
    update(&mut m, ch('L'));
    let fx = update(&mut m, enter());
    let Some(Request::LimitJog { id, .. }) = requests(&fx).first().cloned() else {
        panic!("{fx:?}")
    };
    let fx = update(&mut m, ch(' '));
    assert!(fx.contains(&Effect::Stop), "{fx:?}");
    send(
        &mut m,
        [Event::JogEnded {
            id,
            end: JogEnd::Stopped,
        }],
    );
    assert!(m.popup.is_none());
    assert!(
        message(&m).contains("off its limit switch stopped"),
        "{}",
        message(&m)
    );
}

#[test]
fn help_lists_the_key() {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    update(&mut m, ch('?'));
    let lines = jogterm::ui::help::help_lines(&m.keymap, &m.setup.macros);
    assert!(
        lines.iter().any(|l| matches!(
            l,
            jogterm::ui::help::HelpLine::Entry { keys, description }
                if keys == "L" && description.contains("limit switch")
        )),
        "{lines:?}"
    );
}

/// The question and the running jog on screen, at 80x24 and at a large
/// size.
#[test]
fn the_question_and_the_running_jog_on_screen() {
    let t0 = Instant::now();
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, t0);
    after_a_2(&mut m);
    update(&mut m, ch('L'));
    for (w, h) in ui_support::SIZES {
        insta::assert_snapshot!(
            format!("limit_jog_question_{w}x{h}"),
            render(&m, w, h).backend()
        );
    }
    update(&mut m, enter());
    let running = MachineState {
        activity: Activity::Jogging,
        ..m.machine.clone()
    };
    send(&mut m, [Event::State(running)]);
    for (w, h) in ui_support::SIZES {
        insta::assert_snapshot!(
            format!("limit_jog_running_{w}x{h}"),
            render(&m, w, h).backend()
        );
    }
}
