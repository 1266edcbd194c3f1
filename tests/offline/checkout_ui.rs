//! The check-out through the console's `update` and view (issue 15,
//! `docs/editor.md`, "Check-out"): F10 on the program screen asks, the keys
//! of the `checkout` mode reach it with their phase (typing is off: `s` is
//! single step, not a letter in the text), a pause is shown in the panel's
//! title with the current line marked, Space stops it. Snapshots at 80x24
//! and 160x48.

use crate::ui_support;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyEventState, KeyModifiers};
use jogterm::device::api::{CheckoutEnd, Event, Request};
use jogterm::program::store::Fingerprint;
use jogterm::proto::Protocol;
use jogterm::ui::editor::io::{EditorIo, EditorMsg, perform};
use jogterm::ui::{Effect, Model, Msg, update};
use ui_support::{SIZES, State, model_in, render, text};

const PROGRAM: &str = "; check-out\n\
    0 8000,2000,0,2000,0,2000,0,2000\n\
    0 0,2000,800,2000,0,2000,0,2000\n\
    9\n";

fn key_at(code: KeyCode, kind: KeyEventKind) -> Msg {
    Msg::Key(KeyEvent {
        code,
        modifiers: KeyModifiers::NONE,
        kind,
        state: KeyEventState::NONE,
    })
}

fn carry_out(m: &mut Model, effects: Vec<Effect>) -> Vec<Effect> {
    let mut rest = Vec::new();
    for effect in effects {
        match effect {
            Effect::Editor(io) => {
                let msg = match io {
                    EditorIo::Lint(job) => EditorMsg::Linted(Box::new(job.run())),
                    other => perform(other),
                };
                let more = update(m, Msg::Editor(msg));
                rest.extend(carry_out(m, more));
            }
            other => rest.push(other),
        }
    }
    rest
}

/// A ready isel machine, `PROGRAM` in the editor, the program screen shown.
fn editing(t0: Instant) -> Model {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, t0);
    let loaded = jogterm::program::store::Loaded {
        path: PathBuf::from("/work/part.isel"),
        text: PROGRAM.to_string(),
        fingerprint: Fingerprint::of(PROGRAM.as_bytes()),
        lossy: false,
    };
    update(
        &mut m,
        Msg::Editor(EditorMsg::Open("/work/part.isel".into())),
    );
    let effects = update(
        &mut m,
        Msg::Editor(EditorMsg::Loaded {
            path: "/work/part.isel".into(),
            result: Ok(Some(loaded)),
            recovery: None,
        }),
    );
    carry_out(&mut m, effects);
    for i in 1..=5 {
        let effects = update(&mut m, Msg::Tick(t0 + Duration::from_secs(3 + i)));
        carry_out(&mut m, effects);
    }
    m
}

fn press(m: &mut Model, code: KeyCode, at: Instant) -> Vec<Effect> {
    let _ = update(m, Msg::Tick(at));
    let effects = update(m, key_at(code, KeyEventKind::Press));
    carry_out(m, effects)
}

fn checkout_request(effects: &[Effect]) -> Option<(jogterm::device::api::JogId, String)> {
    effects.iter().find_map(|e| match e {
        Effect::Request(Request::Checkout { id, line, .. }) => Some((*id, line.clone())),
        _ => None,
    })
}

#[test]
fn a_paused_check_out_is_shown_with_its_line_and_space_stops_it() {
    let t0 = Instant::now();
    let mut m = editing(t0);
    let mut t = t0 + Duration::from_secs(10);
    press(&mut m, KeyCode::F(10), t);
    let shown = text(render(&m, 80, 24).backend().buffer());
    assert!(shown.contains("Check-out"), "{shown}");
    t += Duration::from_millis(100);
    press(&mut m, KeyCode::Char('y'), t);
    // `s` is single step in the check-out, not a letter typed.
    t += Duration::from_millis(100);
    press(&mut m, KeyCode::Char('s'), t);
    assert_eq!(m.editor.buffer.program().text(), PROGRAM);
    press(&mut m, KeyCode::Char('s'), t + Duration::from_millis(100));
    press(&mut m, KeyCode::Char('-'), t + Duration::from_millis(200));
    // A hold: the press arms, the first repeat runs line 2 at 90 %.
    t += Duration::from_secs(1);
    assert!(checkout_request(&press(&mut m, KeyCode::F(10), t)).is_none());
    t += Duration::from_millis(500);
    let (id, line) = checkout_request(&press(&mut m, KeyCode::F(10), t)).expect("a line");
    assert_eq!(line, "@0A8000,1800,0,1800,0,1800,0,1800");
    t += Duration::from_millis(300);
    update(&mut m, Msg::Tick(t));
    update(
        &mut m,
        Msg::Device(Event::Checkout {
            id,
            end: CheckoutEnd::Paused {
                dead_man: true,
                rest: true,
            },
        }),
    );
    for (w, h) in SIZES {
        let shown = text(render(&m, w, h).backend().buffer());
        assert!(shown.contains("CHECK-OUT PAUSED line 2 90 %"), "{shown}");
        insta::assert_snapshot!(format!("checkout_paused_{w}x{h}"), shown);
    }
    // Space stops, whatever the check-out does.
    let effects = press(&mut m, KeyCode::Char(' '), t + Duration::from_secs(1));
    assert!(effects.contains(&Effect::Stop), "{effects:?}");
    // `x` ends the check-out; the paused rest is discarded (0xFF).
    let effects = press(&mut m, KeyCode::Char('x'), t + Duration::from_secs(2));
    assert!(
        effects.contains(&Effect::Request(Request::Raw {
            line: "\u{ff}".into()
        })),
        "{effects:?}"
    );
    assert!(m.editor.checkout.is_none());
}
