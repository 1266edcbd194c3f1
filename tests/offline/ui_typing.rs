//! Typing, pastes and bursts through `update()` (`docs/ui.md`, "Typing,
//! pastes and bursts"; issue 13): a paste is text and never motion, keys
//! that arrive together never move the machine, Space types a blank in a
//! text field only while the machine is known to stand still, the command
//! line is entered only with `:` and shows that it has the keys (marked
//! rule, reversed prompt, the terminal's cursor), snapshots of it at 80x24
//! and 160x48.

use crate::ui_support;

use std::time::{Duration, Instant};

use jogterm::device::api::{Activity, Event, LinkState, MachineState, Request};
use jogterm::proto::Protocol;
use jogterm::ui::model::{PanelId, Popup};
use jogterm::ui::typing::{BURST_GAP, MOTION_SETTLE};
use jogterm::ui::view::cursor;
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::{Position, Rect};
use ui_support::{State, find, model_in, render, text};

fn ready() -> Model {
    model_in(Protocol::Isel, "dark", State::Idle, Instant::now())
}

fn event(code: KeyCode) -> KeyEvent {
    KeyEvent::new(code, KeyModifiers::NONE)
}

fn ch(c: char) -> Msg {
    Msg::Key(event(KeyCode::Char(c)))
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(event(code))
}

fn ctrl(c: char) -> Msg {
    Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL))
}

/// Keys read together at `t` (a burst).
fn together(codes: impl IntoIterator<Item = KeyCode>, t: Instant) -> Msg {
    Msg::KeysAt(codes.into_iter().map(|c| (event(c), t)).collect())
}

fn press(model: &mut Model, msgs: impl IntoIterator<Item = Msg>) -> Vec<Effect> {
    msgs.into_iter().flat_map(|m| update(model, m)).collect()
}

fn typed(model: &mut Model, text: &str) -> Vec<Effect> {
    press(model, text.chars().map(ch))
}

fn motion(effects: &[Effect]) -> Vec<&Request> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Request(r @ (Request::Step { .. } | Request::Jog { .. })) => Some(r),
            _ => None,
        })
        .collect()
}

fn message(model: &Model) -> String {
    model
        .message
        .as_ref()
        .map(|m| m.text.clone())
        .unwrap_or_default()
}

fn moving(model: &mut Model, activity: Activity) {
    let state = MachineState {
        activity,
        ..model.machine.clone()
    };
    update(model, Msg::Device(Event::State(state)));
}

#[test]
fn a_paste_on_the_keypad_moves_nothing_and_says_so() {
    let mut m = ready();
    assert_eq!(m.focus, PanelId::Jog);
    let fx = update(&mut m, Msg::Paste("6666666666".into()));
    assert!(fx.is_empty(), "{fx:?}");
    assert_eq!(message(&m), "paste ignored: jogterm moves only on keys");
    // The same in the I/O panel: a paste is never a key.
    press(&mut m, [key(KeyCode::Tab)]);
    assert!(update(&mut m, Msg::Paste("\r".into())).is_empty());
}

#[test]
fn keys_read_together_ask_for_no_motion_and_say_so() {
    let mut m = ready();
    let t = m.now + Duration::from_millis(10);
    // Ten arrow keys in one write (tmux `send-keys`, a program).
    let fx = update(&mut m, together([KeyCode::Right; 10], t));
    assert!(motion(&fx).is_empty(), "{fx:?}");
    assert!(
        message(&m).starts_with("burst ignored: 10 keys"),
        "{}",
        message(&m)
    );
    // The rest of the burst read a moment later is part of it.
    let fx = update(
        &mut m,
        Msg::KeyAt(event(KeyCode::Right), t + Duration::from_millis(2)),
    );
    assert!(motion(&fx).is_empty(), "{fx:?}");
    // Its keys stay latched while they keep coming...
    let fx = update(
        &mut m,
        Msg::KeyAt(event(KeyCode::Right), t + Duration::from_millis(60)),
    );
    assert!(motion(&fx).is_empty(), "{fx:?}");
    // ... and a key typed after a pause steps, once.
    let later = t + Duration::from_millis(400);
    let fx = update(&mut m, Msg::KeyAt(event(KeyCode::Right), later));
    assert_eq!(motion(&fx).len(), 1, "{fx:?}");
    // Keys typed one by one, however quick a person is, are not a burst.
    let fx = update(
        &mut m,
        Msg::KeyAt(
            event(KeyCode::Left),
            later + BURST_GAP + Duration::from_millis(30),
        ),
    );
    assert_eq!(motion(&fx).len(), 1, "{fx:?}");
}

#[test]
fn a_burst_answers_no_question_and_starts_nothing() {
    let mut m = ready();
    let t = m.now + Duration::from_millis(10);
    // `h` asks for a reference run; a `y` in the same burst must not answer.
    let fx = update(
        &mut m,
        together([KeyCode::Char('h'), KeyCode::Char('y')], t),
    );
    assert!(fx.is_empty(), "{fx:?}");
    assert!(m.popup.is_none(), "{:?}", m.popup);
    // Space in a burst still stops.
    let later = t + Duration::from_millis(500);
    let fx = update(
        &mut m,
        together([KeyCode::Right, KeyCode::Char(' ')], later),
    );
    assert_eq!(fx, [Effect::Stop]);
}

#[test]
fn bunched_repeats_renew_a_held_jog_and_start_none() {
    let mut m = ready();
    press(&mut m, [ch('c')]);
    let t = m.now + Duration::from_millis(10);
    let fx = update(&mut m, Msg::KeyAt(event(KeyCode::Right), t));
    assert!(
        matches!(motion(&fx).as_slice(), [Request::Jog { .. }]),
        "{fx:?}"
    );
    // Over SSH two repeats arrive in one read: they keep the jog alive.
    let t2 = t + Duration::from_millis(520);
    let fx = update(&mut m, together([KeyCode::Right, KeyCode::Right], t2));
    assert!(motion(&fx).is_empty(), "{fx:?}");
    assert!(
        fx.iter()
            .all(|e| matches!(e, Effect::Request(Request::JogRenew { .. }))),
        "{fx:?}"
    );
    assert!(!fx.is_empty());
    assert!(!message(&m).contains("burst"), "{}", message(&m));
}

#[test]
fn pasted_text_goes_into_the_command_line_and_is_never_sent() {
    let mut m = ready();
    press(&mut m, [ch(':')]);
    let fx = update(&mut m, Msg::Paste("@0P\r\n".into()));
    assert!(fx.is_empty(), "{fx:?}");
    assert_eq!(m.console.command.text(), "@0P");
    // More than one line is refused whole, and says so.
    let fx = update(&mut m, Msg::Paste("@0A100,900\n@0A-100,900\n".into()));
    assert!(fx.is_empty());
    assert_eq!(m.console.command.text(), "@0P");
    assert!(message(&m).contains("takes one line"), "{}", message(&m));
    // Enter sends what stands on the line.
    assert_eq!(
        press(&mut m, [key(KeyCode::Enter)]),
        [Effect::Request(Request::Raw { line: "@0P".into() })]
    );
}

#[test]
fn a_burst_types_on_the_command_line_but_its_enter_sends_nothing() {
    let mut m = ready();
    press(&mut m, [ch(':')]);
    let t = m.now + Duration::from_millis(10);
    let codes = "@0P".chars().map(KeyCode::Char).chain([KeyCode::Enter]);
    let fx = update(&mut m, together(codes, t));
    assert!(fx.is_empty(), "{fx:?}");
    assert_eq!(m.console.command.text(), "@0P");
    assert!(message(&m).contains("nothing was sent"), "{}", message(&m));
    let fx = update(
        &mut m,
        Msg::KeyAt(event(KeyCode::Enter), t + Duration::from_millis(300)),
    );
    assert_eq!(fx, [Effect::Request(Request::Raw { line: "@0P".into() })]);
}

#[test]
fn pasted_text_goes_into_the_editor_as_lines_and_undoes_in_one_step() {
    let mut m = ready();
    press(&mut m, [ch('e')]);
    assert_eq!(m.focus, PanelId::Editor);
    let before = m.editor.buffer.text();
    let fx = update(&mut m, Msg::Paste("7 7\r\nj300\r\n0 400,900".into()));
    assert!(
        fx.iter().all(|e| !matches!(e, Effect::Request(_))),
        "{fx:?}"
    );
    let text = m.editor.buffer.text();
    assert!(text.starts_with("7 7\nj300\n0 400,900"), "{text:?}");
    let cursor = m.editor.buffer.cursor();
    assert_eq!((cursor.line, cursor.col), (2, 9));
    press(&mut m, [ctrl('z')]);
    assert_eq!(m.editor.buffer.text(), before);
}

#[test]
fn pasted_text_goes_into_the_go_to_prompt_and_only_enter_goes() {
    let mut m = ready();
    press(&mut m, [ch('g')]);
    let fx = update(&mut m, Msg::Paste("X10\n".into()));
    assert!(fx.is_empty(), "{fx:?}");
    let Some(Popup::GoTo(prompt)) = &m.popup else {
        panic!("{:?}", m.popup)
    };
    assert_eq!(prompt.line.text(), "X10");
    let fx = press(&mut m, [key(KeyCode::Enter)]);
    assert!(
        matches!(fx.as_slice(), [Effect::Request(Request::MoveTo { .. })]),
        "{fx:?}"
    );
}

#[test]
fn space_types_in_text_fields_only_while_the_machine_stands_still() {
    // The command line.
    let mut m = ready();
    press(&mut m, [ch(':')]);
    assert!(typed(&mut m, "2C 11").is_empty());
    assert_eq!(m.console.command.text(), "2C 11");
    moving(&mut m, Activity::Stepping);
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
    assert_eq!(m.console.command.text(), "2C 11");
    assert!(
        message(&m).contains("the machine is stepping"),
        "{}",
        message(&m)
    );
    assert!(
        message(&m).contains("Ctrl-Space types a blank"),
        "{}",
        message(&m)
    );
    // Ctrl-Space types a blank whatever moves.
    assert!(press(&mut m, [ctrl(' ')]).is_empty());
    assert_eq!(m.console.command.text(), "2C 11 ");
    moving(&mut m, Activity::Idle);
    assert!(press(&mut m, [ch(' ')]).is_empty());
    assert_eq!(m.console.command.text(), "2C 11  ");

    // The editor: while the link is down the state is unknown.
    let mut m = ready();
    press(&mut m, [ch('e')]);
    assert!(typed(&mut m, "7 7").is_empty());
    update(
        &mut m,
        Msg::Device(Event::Link(LinkState::Lost {
            reason: "gone".into(),
        })),
    );
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
    assert!(message(&m).contains("link is down"), "{}", message(&m));
    assert!(m.editor.buffer.text().starts_with("7 7\n") || m.editor.buffer.text() == "7 7");

    // The go-to prompt, right after a move was asked for: it may be on its
    // way, so Space stops; once it has settled, Space types.
    let mut m = ready();
    press(&mut m, [ch('g')]);
    typed(&mut m, "X1");
    let fx = press(&mut m, [key(KeyCode::Enter)]);
    assert!(matches!(
        fx.as_slice(),
        [Effect::Request(Request::MoveTo { .. })]
    ));
    press(&mut m, [ch('g')]);
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
    assert!(
        message(&m).contains("asked for a moment ago"),
        "{}",
        message(&m)
    );
    let settled = m.now + MOTION_SETTLE + Duration::from_millis(1);
    update(&mut m, Msg::Tick(settled));
    // The prompt stayed open (a stop closes no popup).
    typed(&mut m, "X2");
    assert!(press(&mut m, [ch(' ')]).is_empty());
    let Some(Popup::GoTo(prompt)) = &m.popup else {
        panic!("{:?}", m.popup)
    };
    assert_eq!(prompt.line.text(), "X2 ");
}

#[test]
fn space_outside_text_fields_always_stops_and_esc_stops_on_the_command_line() {
    let mut m = ready();
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
    press(&mut m, [key(KeyCode::Tab)]);
    assert_eq!(m.focus, PanelId::Io);
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
    press(&mut m, [ch(':')]);
    assert_eq!(press(&mut m, [key(KeyCode::Esc)]), [Effect::Stop]);
    // In a question Space still stops.
    press(&mut m, [key(KeyCode::Tab), ch('h')]);
    assert!(matches!(m.popup, Some(Popup::Confirm(_))));
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
}

#[test]
fn tab_passes_the_command_line_by_and_leaves_it_for_where_colon_was_pressed() {
    let mut m = ready();
    let ring: Vec<PanelId> = (0..4)
        .map(|_| {
            press(&mut m, [key(KeyCode::Tab)]);
            m.focus
        })
        .collect();
    assert_eq!(
        ring,
        [PanelId::Io, PanelId::Sim, PanelId::Jog, PanelId::Io],
        "the built-in simulator's panel is in the ring, the command line never"
    );
    press(&mut m, [ch(':')]);
    assert_eq!(m.focus, PanelId::Console);
    press(&mut m, [key(KeyCode::Tab)]);
    assert_eq!(m.focus, PanelId::Io);
    press(&mut m, [ch(':'), key(KeyCode::BackTab)]);
    assert_eq!(m.focus, PanelId::Io);
}

/// The main keys reach the machine after any number of Tabs: `h` asks for
/// a reference run, `i` initialises; none is typed into the command line.
#[test]
fn main_keys_never_land_in_the_command_line_after_tabs() {
    for tabs in 0..6 {
        let mut m = ready();
        press(&mut m, (0..tabs).map(|_| key(KeyCode::Tab)));
        let fx = press(&mut m, [ch('i')]);
        assert_eq!(fx, [Effect::Request(Request::Initialise)], "{tabs} tabs");
        press(&mut m, [ch('h')]);
        assert!(matches!(m.popup, Some(Popup::Confirm(_))), "{tabs} tabs");
        assert_eq!(m.console.command.text(), "", "{tabs} tabs");
    }
}

fn typing_model(theme: &str) -> Model {
    let mut m = model_in(Protocol::Isel, theme, State::Idle, Instant::now());
    press(&mut m, [ch(':')]);
    typed(&mut m, "@0P");
    m
}

/// The command line with the keys: the console's rule drawn heavy, its
/// title saying so, the prompt reversed, the terminal's cursor after the
/// text; the keypad's rule thin again.
#[test]
fn the_command_line_shows_it_has_the_keys() {
    for theme in ["dark", "mono16"] {
        let m = typing_model(theme);
        for (w, h) in [(80u16, 24u16), (160, 48)] {
            let terminal = render(&m, w, h);
            let buf = terminal.backend().buffer();
            let screen = text(buf);
            let rule = m.palette.symbols.focus_rule;
            let title = screen
                .lines()
                .find(|l| l.contains("Traffic"))
                .expect("the traffic panel");
            assert!(title.contains("TYPING, Tab leaves"), "{title}");
            assert!(title.contains(rule), "{theme}: {title}");
            let jog = screen
                .lines()
                .find(|l| l.contains(" Jog "))
                .expect("keypad");
            assert!(!jog.contains(rule), "{theme}: {jog}");
            let (x, y) = *find(buf, "> @0P").first().expect("the command line");
            assert!(
                buf[(x, y)]
                    .style()
                    .add_modifier
                    .contains(ratatui::style::Modifier::REVERSED),
                "{theme}: the prompt is reversed"
            );
            assert_eq!(
                cursor(&m, Rect::new(0, 0, w, h)),
                Some(Position::new(x + 5, y)),
                "{theme} {w}x{h}: the cursor after `@0P`"
            );
            insta::assert_snapshot!(
                format!("command_line_typing_{w}x{h}_{theme}"),
                terminal.backend()
            );
        }
        // Elsewhere the terminal's cursor is hidden.
        let mut m = m;
        press(&mut m, [key(KeyCode::Tab)]);
        assert_eq!(cursor(&m, Rect::new(0, 0, 80, 24)), None);
    }
}
