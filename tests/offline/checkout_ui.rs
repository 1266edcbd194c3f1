//! The check-out through the console's `update` and view (issue 15,
//! `docs/editor.md`, "Check-out"): F10 on the program screen asks, the keys
//! of the `checkout` mode reach it with their phase (typing is off: `s` is
//! single step, not a letter in the text), a pause is shown in the panel's
//! title with the current line marked, Space stops it. Snapshots at 80x24
//! and 160x48.

use crate::ui_support;

use std::time::{Duration, Instant};

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyEventState, KeyModifiers};
use jogterm::device::api::{CheckoutEnd, Event, Request};
use jogterm::ui::{Effect, Model, Msg, update};
use ui_support::{SIZES, carry_out, render, text};

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

/// A ready isel machine, `PROGRAM` in the editor, the program screen shown.
fn editing(t0: Instant) -> Model {
    ui_support::editing_isel(PROGRAM, t0)
}
