//! Snapshots of the jog keypad panel in each state (idle in step mode,
//! continuous hold, toggle, moving with the jog's key lit, refused with its
//! reason, homing), for each family's shipped profile (their axes and
//! units differ), plus a style check that the moving key is lit.

use crate::ui_support;

use std::time::{Duration, Instant};

use jogterm::config::profile::JogMode;
use jogterm::device::api::{Activity, Event, MachineState, Request};
use jogterm::jog::Jogger;
use jogterm::proto::Protocol;
use jogterm::ui::jog::view::{KeypadView, height};
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::layout::Rect;
use ui_support::{State, find, model_in};

const WIDTH: u16 = 52;

fn key_at(model: &mut Model, code: KeyCode, t: Instant) -> Vec<Effect> {
    let mut event = KeyEvent::new(code, KeyModifiers::NONE);
    event.kind = KeyEventKind::Press;
    update(model, Msg::KeyAt(event, t))
}

fn draw(model: &Model) -> Terminal<TestBackend> {
    let h = height(model);
    let mut terminal = Terminal::new(TestBackend::new(WIDTH, h)).expect("backend");
    terminal
        .draw(|f| f.render_widget(KeypadView(model), Rect::new(0, 0, WIDTH, h)))
        .expect("draw");
    terminal
}

/// The keypad of `protocol` in the state called `state`.
fn keypad_in(protocol: Protocol, state: &str) -> Model {
    let t0 = Instant::now();
    let source = if state == "refused" {
        State::EStop
    } else {
        State::Idle
    };
    let mut m = model_in(protocol, "dark", source, t0);
    let t = m.now;
    match state {
        "step" => {}
        "hold" => {
            update(
                &mut m,
                Msg::Key(KeyEvent::new(KeyCode::Char('c'), KeyModifiers::NONE)),
            );
        }
        "toggle" => {
            let mut s = m.setup.jog.clone();
            s.mode = JogMode::Toggle;
            m.keypad.jogger = Jogger::new(s);
            update(
                &mut m,
                Msg::Key(KeyEvent::new(KeyCode::Char('c'), KeyModifiers::NONE)),
            );
        }
        "moving" => {
            update(
                &mut m,
                Msg::Key(KeyEvent::new(KeyCode::Char('c'), KeyModifiers::NONE)),
            );
            let fx = key_at(&mut m, KeyCode::Right, t);
            assert!(
                matches!(fx.as_slice(), [Effect::Request(Request::Jog { .. })]),
                "{fx:?}"
            );
        }
        "refused" => {
            let fx = key_at(&mut m, KeyCode::Right, t);
            assert!(fx.is_empty(), "{fx:?}");
        }
        "homing" => {
            update(
                &mut m,
                Msg::Key(KeyEvent::new(KeyCode::Char('H'), KeyModifiers::NONE)),
            );
            update(
                &mut m,
                Msg::Key(KeyEvent::new(KeyCode::Char('x'), KeyModifiers::NONE)),
            );
            let homing = MachineState {
                activity: Activity::Homing,
                ..m.machine.clone()
            };
            update(&mut m, Msg::Device(Event::State(homing)));
            update(&mut m, Msg::Tick(t + Duration::from_millis(1500)));
        }
        other => panic!("no state {other}"),
    }
    m
}

const STATES: [&str; 6] = ["step", "hold", "toggle", "moving", "refused", "homing"];

fn snapshot_family(protocol: Protocol) {
    for state in STATES {
        let m = keypad_in(protocol, state);
        let terminal = draw(&m);
        insta::assert_snapshot!(format!("keypad_{protocol}_{state}"), terminal.backend());
    }
}

#[test]
fn isel_keypad() {
    snapshot_family(Protocol::Isel);
}

#[test]
fn emcu_keypad() {
    snapshot_family(Protocol::Emcu);
}

#[test]
fn emp_keypad() {
    snapshot_family(Protocol::Emp);
}

#[test]
fn the_moving_key_is_lit_and_the_others_are_not() {
    let m = keypad_in(Protocol::Isel, "moving");
    let terminal = draw(&m);
    let buf = terminal.backend().buffer();
    let lit = m.palette.lit.patch(m.palette.selected);
    let (x, y) = *find(buf, "X+").first().expect("X+ shown");
    assert_eq!(buf[(x, y)].style().add_modifier, lit.add_modifier);
    assert_eq!(buf[(x, y)].style().fg, lit.fg);
    let (x, y) = *find(buf, "X-").first().expect("X- shown");
    assert_eq!(buf[(x, y)].style().fg, m.palette.key.fg);
}
