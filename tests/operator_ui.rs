//! What an operator of another console expects besides work offsets (issue
//! 16, second part), through `update()`: macros of the profile run line by
//! line through the device task, asked first when they move, stopped by
//! Space, ended by a refusal; their keys in `?`.

// Test code: a failed unwrap, expect or panic is the run failing, with its
// message (Cargo.toml [lints] denies them in the crate itself).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod ui_support;

use std::time::Instant;

use jogterm::config::{ConfigDirs, Source, load_profile_with_sources};
use jogterm::device::api::{ControllerFault, Event, Recovery, Refusal, ReplyKind, Request};
use jogterm::device::describe::describe;
use jogterm::proto::Protocol;
use jogterm::ui::help::{HelpLine, help_lines};
use jogterm::ui::keymap::Keymap;
use jogterm::ui::model::{Popup, Setup};
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ui_support::{State, model_in, send};

fn ch(c: char) -> Msg {
    Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

fn raws(effects: &[Effect]) -> Vec<String> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Request(Request::Raw { line }) => Some(line.clone()),
            _ => None,
        })
        .collect()
}

const PARK: &str = "@0M 0,900,0,900,8000,900,0,900";

/// The profile of the tests: `park` moves (F8, asks first), `where` only
/// reads (F9, runs at once).
const MACROS: &str = "base = \"default\"\n\
    [macros.park]\n\
    description = \"Z up, then to the park position\"\n\
    lines = [\"@0P\", \"@0M 0,900,0,900,8000,900,0,900\", \"@0P\"]\n\
    [macros.where]\n\
    lines = [\"@0P\", \"@0b1\"]\n\
    [keys.main]\n\
    \"f8\" = \"macro:park\"\n\
    \"f9\" = \"macro:where\"\n";

/// The isel console, ready, with the macros of [`MACROS`].
fn ready() -> Model {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mill.toml");
    std::fs::write(&file, MACROS).unwrap();
    let (profile, sources) =
        load_profile_with_sources(&file.display().to_string(), &ConfigDirs::builtin_only())
            .unwrap();
    let refs: Vec<&Source> = sources.iter().collect();
    let names: Vec<&str> = profile.macros.keys().map(String::as_str).collect();
    let mut model = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    model.keymap = Keymap::builtin()
        .unwrap()
        .with_overrides(&profile.keys, &names, &refs)
        .unwrap();
    model.setup.macros = Setup::from_profile(&profile, None).macros;
    model
}

fn answer(line: &str) -> Event {
    Event::Reply {
        command: line.to_string(),
        text: "0 ok".to_string(),
        kind: ReplyKind::Answer,
    }
}

fn message(model: &Model) -> String {
    model
        .message
        .as_ref()
        .map(|m| m.text.clone())
        .unwrap_or_default()
}

#[test]
fn a_macro_that_moves_asks_first_then_sends_its_lines_one_after_the_other() {
    let mut model = ready();
    let effects = update(&mut model, key(KeyCode::F(8)));
    assert!(raws(&effects).is_empty(), "nothing before the answer");
    let Some(Popup::Confirm(question)) = &model.popup else {
        panic!("no question: {:?}", model.popup);
    };
    assert!(question.title.contains("park"), "{}", question.title);
    assert!(
        question.question.contains("moves the machine"),
        "{}",
        question.question
    );
    let effects = update(&mut model, ch('y'));
    assert_eq!(raws(&effects), ["@0P"]);
    assert!(message(&model).contains("macro park, line 1 of 3"));
    // The next line only after the answer to the one before.
    let mut effects = Vec::new();
    effects.extend(update(&mut model, Msg::Device(answer("@0P"))));
    assert_eq!(raws(&effects), [PARK]);
    let effects = update(&mut model, Msg::Device(answer(PARK)));
    assert_eq!(raws(&effects), ["@0P"]);
    let effects = update(&mut model, Msg::Device(answer("@0P")));
    assert!(raws(&effects).is_empty());
    assert!(model.macro_run.is_none());
    assert_eq!(message(&model), "macro park done (3 lines)");
}

#[test]
fn a_macro_that_only_reads_runs_at_once_and_cancel_runs_nothing() {
    let mut model = ready();
    let effects = update(&mut model, key(KeyCode::F(9)));
    assert!(model.popup.is_none());
    assert_eq!(raws(&effects), ["@0P"]);
    let effects = update(&mut model, Msg::Device(answer("@0P")));
    assert_eq!(raws(&effects), ["@0b1"]);
    update(&mut model, Msg::Device(answer("@0b1")));
    assert!(model.macro_run.is_none());

    update(&mut model, key(KeyCode::F(8)));
    let effects = update(&mut model, ch('n'));
    assert!(raws(&effects).is_empty());
    assert!(model.macro_run.is_none());
}

#[test]
fn space_stops_a_macro_and_nothing_more_is_sent() {
    let mut model = ready();
    update(&mut model, key(KeyCode::F(8)));
    update(&mut model, ch('y'));
    let effects = update(&mut model, Msg::Device(answer("@0P")));
    assert_eq!(raws(&effects), [PARK]);
    let effects = update(&mut model, ch(' '));
    assert!(effects.contains(&Effect::Stop), "{effects:?}");
    assert!(model.macro_run.is_none());
    assert!(
        message(&model)
            .contains("macro park, line 2 of 3 stopped by the operator; 1 more not sent"),
        "{}",
        message(&model)
    );
    // The stopped move's answer sends nothing.
    let effects = update(&mut model, Msg::Device(answer(PARK)));
    assert!(raws(&effects).is_empty(), "{effects:?}");
}

#[test]
fn a_refusal_or_an_error_ends_the_macro_there() {
    let mut model = ready();
    update(&mut model, key(KeyCode::F(8)));
    update(&mut model, ch('y'));
    update(&mut model, Msg::Device(answer("@0P")));
    let refused = Event::Refused {
        request: describe(&Request::Raw {
            line: PARK.to_string(),
        }),
        reason: Refusal::EmergencyStop,
    };
    let effects = update(&mut model, Msg::Device(refused));
    assert!(raws(&effects).is_empty());
    assert!(model.macro_run.is_none());
    let said = message(&model);
    assert!(
        said.contains("line 2 of 3: refused: emergency stop"),
        "{said}"
    );
    assert!(said.contains("the last line was not sent"), "{said}");

    // A controller error on the first line.
    update(&mut model, key(KeyCode::F(9)));
    let fault = ControllerFault {
        command: "@0P".into(),
        code: "2".into(),
        meaning: "limit switch".into(),
        recovery: Recovery::Reference,
    };
    let effects = update(&mut model, Msg::Device(Event::Fault(fault)));
    assert!(raws(&effects).is_empty());
    assert!(model.macro_run.is_none());
    assert!(
        message(&model).contains("answered `2`"),
        "{}",
        message(&model)
    );
}

#[test]
fn a_macro_waits_for_a_busy_machine_and_typed_lines_wait_for_a_macro() {
    let mut model = ready();
    // Busy: refused before anything is sent.
    let mut busy = model.machine.clone();
    busy.activity = jogterm::device::api::Activity::Homing;
    send(&mut model, [Event::State(busy)]);
    let effects = update(&mut model, key(KeyCode::F(9)));
    assert!(raws(&effects).is_empty());
    assert!(message(&model).contains("busy"), "{}", message(&model));
    let mut idle = model.machine.clone();
    idle.activity = jogterm::device::api::Activity::Idle;
    send(&mut model, [Event::State(idle)]);
    // While a macro runs, the command line does not send.
    update(&mut model, key(KeyCode::F(9)));
    update(&mut model, ch(':'));
    for c in "@0P".chars() {
        update(&mut model, ch(c));
    }
    let effects = update(&mut model, key(KeyCode::Enter));
    assert!(raws(&effects).is_empty(), "{effects:?}");
    assert!(
        message(&model).contains("is running"),
        "{}",
        message(&model)
    );
}

#[test]
fn the_help_lists_the_macros_with_their_keys() {
    let model = ready();
    let help = help_lines(&model.keymap, &model.setup.macros);
    let entry = |needle: &str| {
        help.iter().find_map(|l| match l {
            HelpLine::Entry { keys, description } if description.contains(needle) => {
                Some(keys.clone())
            }
            _ => None,
        })
    };
    assert_eq!(entry("park: Z up").as_deref(), Some("F8"));
    assert_eq!(entry("where (2 lines)").as_deref(), Some("F9"));
}
