//! What an operator of another console expects besides work offsets (issue
//! 16, second part), through `update()`: macros of the profile run line by
//! line through the device task, asked first when they move, stopped by
//! Space, ended by a refusal, their keys in `?`; the named outputs popup
//! (switched by name, asked first where hazardous); the message history
//! (long messages whole, the message line saying more is there); snapshots
//! at 80x24 and 160x48, in `mono16` too.

use crate::ui_support;

use std::time::{Duration, Instant};

use jogterm::config::{ConfigDirs, Source, load_profile_with_sources};
use jogterm::device::api::{
    ControllerFault, Event, IoSnapshot, OutputId, Recovery, Refusal, ReplyKind, Request,
};
use jogterm::device::common::io;
use jogterm::device::describe::describe;
use jogterm::proto::Protocol;
use jogterm::ui::help::{HelpLine, help_lines};
use jogterm::ui::io::Outputs;
use jogterm::ui::keymap::Keymap;
use jogterm::ui::model::{Popup, Setup};
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ui_support::{SIZES, State, model_in, render, send, text};

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
    \"f9\" = \"macro:where\"\n\
    [io.\"out0.1\"]\n\
    name = \"coolant\"\n\
    role = \"coolant\"\n\
    hazardous = false\n\
    [io.\"out0.2\"]\n\
    name = \"clamp\"\n\
    role = \"clamp\"\n\
    [io.\"out0.3\"]\n\
    name = \"vacuum table\"\n\
    role = \"vacuum\"\n\
    wired = false\n";

/// The isel console, ready, with the macros and outputs of [`MACROS`].
fn ready() -> Model {
    ready_in("dark")
}

fn ready_in(theme: &str) -> Model {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mill.toml");
    std::fs::write(&file, MACROS).unwrap();
    let (profile, sources) =
        load_profile_with_sources(&file.display().to_string(), &ConfigDirs::builtin_only())
            .unwrap();
    let refs: Vec<&Source> = sources.iter().collect();
    let names: Vec<&str> = profile.macros.keys().map(String::as_str).collect();
    let mut model = model_in(Protocol::Isel, theme, State::Idle, Instant::now());
    model.keymap = Keymap::builtin()
        .unwrap()
        .with_overrides(&profile.keys, &names, &refs)
        .unwrap();
    model.setup.macros = Setup::from_profile(&profile, None).macros;
    let now = model.now;
    send(&mut model, [Event::Io(outputs(&profile, now))]);
    model
}

/// isel output port 0 as the driver reports it with the profile's wiring
/// (`out0.1` coolant on), and the spindle port.
fn outputs(profile: &jogterm::config::Profile, at: Instant) -> IoSnapshot {
    let wiring = profile.wiring().unwrap();
    let bits = (0..8)
        .map(|n| {
            let w = wiring.bit(&format!("out0.{n}")).unwrap();
            let id = OutputId {
                group: 0,
                bit: Some(n),
            };
            // The manual's table: user outputs may switch any load.
            io::wired_output(w, n == 1, id, true)
        })
        .collect();
    // The spindle port (a whole port of its own, isel manual 2.2.4).
    let spindle = wiring
        .bits()
        .iter()
        .find(|b| b.name == "spindle" && !b.address.contains('.'))
        .unwrap();
    let spindle_id = OutputId {
        group: 2,
        bit: None,
    };
    IoSnapshot {
        at,
        groups: vec![
            io::group("out 0: user outputs", Some(0x02), bits),
            io::group(
                format!("{}: spindle", spindle.address.replace("out", "out ")),
                Some(0),
                vec![io::wired_output(spindle, false, spindle_id, true)],
            ),
        ],
    }
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
    // While a macro runs, the command line does not send. (The key pressed
    // again a second later: at once it would be a held key's repeat.)
    model.now += Duration::from_secs(1);
    let effects = update(&mut model, key(KeyCode::F(9)));
    assert_eq!(raws(&effects), ["@0P"]);
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

fn set_outputs(effects: &[Effect]) -> Vec<(OutputId, u8)> {
    effects
        .iter()
        .filter_map(|e| match e {
            Effect::Request(Request::SetOutput { output, value }) => Some((*output, *value)),
            _ => None,
        })
        .collect()
}

#[test]
fn named_outputs_switch_by_name_and_the_hazardous_ones_ask_first() {
    let mut model = ready();
    update(&mut model, ch('x'));
    assert!(matches!(
        model.popup,
        Some(Popup::Outputs(Outputs { selected: 0 }))
    ));
    let whole = text(render(&model, 80, 24).backend().buffer());
    let screen = &whole[whole.find("Named outputs").expect("the popup")..];
    // The wired outputs with a role, in the panel's order; the unwired
    // vacuum table and the plain user outputs are not among them.
    let coolant = screen.find("coolant").expect("coolant listed");
    let clamp = screen.find("clamp").expect("clamp listed");
    let spindle = screen.rfind("spindle").expect("spindle");
    assert!(coolant < clamp && clamp < spindle, "{screen}");
    assert!(!screen.contains("vacuum table"), "{screen}");
    assert!(!screen.contains("user output"), "{screen}");
    // Coolant: the profile says not hazardous; it is on, Enter switches it off.
    let effects = update(&mut model, key(KeyCode::Enter));
    assert_eq!(
        set_outputs(&effects),
        [(
            OutputId {
                group: 0,
                bit: Some(1)
            },
            0
        )]
    );
    assert!(matches!(
        model.popup,
        Some(Popup::Outputs(Outputs { selected: 0 }))
    ));
    // Clamp: the manual's table calls user outputs hazardous: asks first.
    update(&mut model, key(KeyCode::Down));
    let effects = update(&mut model, key(KeyCode::Enter));
    assert!(set_outputs(&effects).is_empty());
    let Some(Popup::Confirm(q)) = &model.popup else {
        panic!("no question: {:?}", model.popup);
    };
    assert!(q.question.contains("Switch clamp on?"), "{}", q.question);
    let effects = update(&mut model, ch('y'));
    assert_eq!(
        set_outputs(&effects),
        [(
            OutputId {
                group: 0,
                bit: Some(2)
            },
            1
        )]
    );
    // Space still stops from the popup.
    update(&mut model, ch('x'));
    assert_eq!(update(&mut model, ch(' ')), [Effect::Stop]);
}

#[test]
fn without_named_outputs_x_says_how_to_get_them() {
    let mut model = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    update(&mut model, ch('x'));
    assert!(model.popup.is_none());
    assert!(
        message(&model).contains("give outputs a role"),
        "{}",
        message(&model)
    );
}

/// A message longer than any line: a refusal with its whole reason.
const LONG: &str = "macro park, line 2 of 3: refused: emergency stop active: release it, \
    then initialise (i) and reference (h); the last line was not sent, and this sentence \
    goes on so that it is longer than even a 160 column terminal can show in its one \
    message line: the end of it is WHOLE-AT-THE-END";

fn refused_long() -> Event {
    Event::Refused {
        request: describe(&Request::Raw {
            line: "@0P".to_string(),
        }),
        reason: Refusal::Invalid {
            reason: LONG.to_string(),
        },
    }
}

#[test]
fn long_messages_are_read_whole_in_the_history() {
    let mut model = ready();
    update(&mut model, key(KeyCode::F(9)));
    update(&mut model, Msg::Device(refused_long()));
    for (w, h) in SIZES {
        let screen = text(render(&model, w, h).backend().buffer());
        let line = screen.lines().nth(1).unwrap_or_default();
        assert!(line.ends_with("[M: all]"), "{w}x{h}:\n{screen}");
        assert!(!line.contains("WHOLE-AT-THE-END"), "{screen}");
    }
    update(
        &mut model,
        Msg::Resize {
            width: 80,
            height: 24,
        },
    );
    update(&mut model, ch('M'));
    let screen = text(render(&model, 80, 24).backend().buffer());
    assert!(screen.contains("WHOLE-AT-THE-END"), "{screen}");
    // Older messages above: scroll back to the first, then to the newest.
    update(&mut model, key(KeyCode::Esc));
    for i in 0..30 {
        update(&mut model, key(KeyCode::F(9)));
        update(&mut model, ch(' '));
        assert!(model.history.len() > i);
    }
    update(&mut model, Msg::Device(refused_long()));
    update(&mut model, ch('M'));
    update(&mut model, key(KeyCode::Home));
    let screen = text(render(&model, 80, 24).backend().buffer());
    assert!(screen.contains("lines back"), "{screen}");
    let first = model.history.iter().next().unwrap().text.clone();
    assert!(
        screen.contains(&first[..first.len().min(30)]),
        "{first}\n{screen}"
    );
    update(&mut model, key(KeyCode::End));
    let screen = text(render(&model, 80, 24).backend().buffer());
    assert!(screen.contains("WHOLE-AT-THE-END"), "{screen}");
    update(&mut model, key(KeyCode::Esc));
    assert!(model.popup.is_none());
}

#[test]
fn snapshots_of_outputs_and_the_message_history() {
    for theme in ["dark", "mono16"] {
        let mut model = ready_in(theme);
        update(&mut model, ch('x'));
        for (w, h) in SIZES {
            insta::assert_snapshot!(
                format!("operator_outputs_{theme}_{w}x{h}"),
                render(&model, w, h).backend()
            );
        }
        update(&mut model, key(KeyCode::Esc));
        let refused = Event::Refused {
            request: "raw @0P".to_string(),
            reason: Refusal::Invalid {
                reason: LONG.to_string(),
            },
        };
        update(&mut model, Msg::Device(refused));
        for (w, h) in SIZES {
            insta::assert_snapshot!(
                format!("operator_message_cut_{theme}_{w}x{h}"),
                render(&model, w, h).backend()
            );
        }
        update(&mut model, ch('M'));
        for (w, h) in SIZES {
            update(
                &mut model,
                Msg::Resize {
                    width: w,
                    height: h,
                },
            );
            insta::assert_snapshot!(
                format!("operator_messages_{theme}_{w}x{h}"),
                render(&model, w, h).backend()
            );
        }
    }
}

fn rows_of(screen: &str, needle: &str) -> usize {
    screen.lines().filter(|l| l.contains(needle)).count()
}

#[test]
fn the_large_position_display_is_readable_and_the_keys_still_work() {
    for theme in ["dark", "mono16"] {
        let mut model = ready_in(theme);
        update(&mut model, ch('D'));
        assert!(model.large_dro);
        let ink = if theme == "mono16" {
            "###"
        } else {
            "███"
        };
        for (w, h) in SIZES {
            let screen = text(render(&model, w, h).backend().buffer());
            assert!(rows_of(&screen, ink) >= 9, "{theme} {w}x{h}:\n{screen}");
            assert!(!screen.contains("Traffic"), "{screen}");
            assert!(screen.contains("machine 112.345"), "{screen}");
            insta::assert_snapshot!(
                format!("operator_large_dro_{theme}_{w}x{h}"),
                render(&model, w, h).backend()
            );
        }
        // The keypad jogs from here; Space stops.
        let effects = update(&mut model, key(KeyCode::Right));
        assert!(
            effects
                .iter()
                .any(|e| matches!(e, Effect::Request(Request::Step { .. }))),
            "{effects:?}"
        );
        assert_eq!(update(&mut model, ch(' ')), [Effect::Stop]);
        // Tab finds no hidden panel; `:` leaves for the command line.
        update(&mut model, key(KeyCode::Tab));
        assert_eq!(model.focus, jogterm::ui::model::PanelId::Jog);
        update(&mut model, ch(':'));
        assert!(!model.large_dro);
        update(&mut model, key(KeyCode::Tab));
        update(&mut model, ch('D'));
        update(&mut model, ch('D'));
        assert!(!model.large_dro);
    }
}

#[test]
fn the_program_screen_keeps_the_position_in_sight() {
    for theme in ["dark", "mono16"] {
        let mut model = ready_in(theme);
        update(&mut model, ch('e'));
        for (w, h) in SIZES {
            let screen = text(render(&model, w, h).backend().buffer());
            let line = screen.lines().nth(2).unwrap_or_default();
            assert!(line.contains("Position G54"), "{screen}");
            assert!(
                line.contains("102.345") && line.contains("-0.003"),
                "{line}"
            );
            // The machine's state stays in the status bar.
            assert!(screen.lines().next().unwrap().contains("READY"));
            insta::assert_snapshot!(
                format!("operator_program_screen_{theme}_{w}x{h}"),
                render(&model, w, h).backend()
            );
        }
    }
}

#[test]
fn at_160x48_the_room_goes_to_what_the_operator_watches() {
    let model = ready();
    let screen = text(render(&model, 160, 48).backend().buffer());
    let lines: Vec<&str> = screen.lines().collect();
    let traffic = lines
        .iter()
        .position(|l| l.contains(" Traffic"))
        .expect("the traffic console");
    // The console: a few lines at the bottom, not half the screen.
    assert!(lines.len() - traffic <= 12, "{screen}");
    // The position in large digits, the toolpath preview beside.
    assert!(rows_of(&screen, "███") >= 9, "{screen}");
    assert!(screen.contains("machine 112.345"), "{screen}");
    assert!(
        screen.contains("Toolpath"),
        "the toolpath preview:\n{screen}"
    );
}

#[test]
fn snapshots_of_a_macro_question_and_the_help() {
    let mut model = ready();
    update(&mut model, key(KeyCode::F(8)));
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("operator_macro_question_{w}x{h}"),
            render(&model, w, h).backend()
        );
    }
    update(&mut model, ch('n'));
    update(&mut model, ch('?'));
    // The end of the help: the macros with their keys.
    for _ in 0..400 {
        update(&mut model, key(KeyCode::Down));
    }
    for (w, h) in SIZES {
        insta::assert_snapshot!(
            format!("operator_help_macros_{w}x{h}"),
            render(&model, w, h).backend()
        );
    }
}

#[test]
fn a_line_answered_while_the_machine_still_runs_waits_for_it_to_stand() {
    let mut model = ready();
    update(&mut model, key(KeyCode::F(8)));
    update(&mut model, ch('y'));
    update(&mut model, Msg::Device(answer("@0P")));
    // The move runs; its answer comes before the state says it stands
    // (an EMCU batch runs on after its acknowledgement).
    let mut moving = model.machine.clone();
    moving.activity = jogterm::device::api::Activity::Moving;
    send(&mut model, [Event::State(moving.clone())]);
    let effects = update(&mut model, Msg::Device(answer(PARK)));
    assert!(raws(&effects).is_empty(), "{effects:?}");
    let effects = update(&mut model, Msg::Device(Event::State(moving.clone())));
    assert!(raws(&effects).is_empty(), "{effects:?}");
    let mut idle = moving;
    idle.activity = jogterm::device::api::Activity::Idle;
    let effects = update(&mut model, Msg::Device(Event::State(idle)));
    assert_eq!(raws(&effects), ["@0P"]);
}

#[test]
fn a_held_macro_key_runs_its_macro_once() {
    let mut model = ready();
    let effects = update(&mut model, key(KeyCode::F(9)));
    assert_eq!(raws(&effects), ["@0P"]);
    let effects = update(&mut model, Msg::Device(answer("@0P")));
    assert_eq!(raws(&effects), ["@0b1"]);
    update(&mut model, Msg::Device(answer("@0b1")));
    assert!(model.macro_run.is_none());
    // The key is still held: its repeats (kitty keyboard protocol) start
    // nothing.
    let mut repeat = KeyEvent::new(KeyCode::F(9), KeyModifiers::NONE);
    repeat.kind = KeyEventKind::Repeat;
    let effects = update(&mut model, Msg::Key(repeat));
    assert!(raws(&effects).is_empty(), "{effects:?}");
    assert!(model.macro_run.is_none());
}

/// Issue 24: on terminals without the kitty keyboard protocol a held key's
/// repeats arrive as presses (~30-40 ms apart after the repeat delay). They
/// are timed as the jog times them: presses at repeat intervals after the
/// macro key start nothing, also once the macro has ended; a deliberate
/// press after a pause starts it again.
#[test]
fn a_held_macro_key_whose_repeats_come_as_presses_runs_its_macro_once() {
    let mut model = ready();
    let t0 = model.now;
    let f9_at = |ms: u64| {
        Msg::KeysAt(vec![(
            KeyEvent::new(KeyCode::F(9), KeyModifiers::NONE),
            t0 + Duration::from_millis(ms),
        )])
    };
    let effects = update(&mut model, f9_at(0));
    assert_eq!(raws(&effects), ["@0P"]);
    let effects = update(&mut model, Msg::Device(answer("@0P")));
    assert_eq!(raws(&effects), ["@0b1"]);
    update(&mut model, Msg::Device(answer("@0b1")));
    assert!(model.macro_run.is_none(), "the macro has ended");
    // Still held: the first repeat after a 500 ms repeat delay, then one
    // every 33 ms for two seconds, all as presses.
    let mut at = 500;
    while at < 2500 {
        let effects = update(&mut model, f9_at(at));
        assert!(raws(&effects).is_empty(), "at {at} ms: {effects:?}");
        assert!(model.macro_run.is_none(), "started again at {at} ms");
        at += 33;
    }
    // Let go; pressed again 400 ms after the last repeat: a new press.
    let effects = update(&mut model, f9_at(at - 33 + 400));
    assert_eq!(raws(&effects), ["@0P"], "a deliberate second press runs it");
}

#[test]
fn r_reads_the_job_log_and_its_runs_open_in_the_message_history() {
    let mut m = ready();
    // The key asks the runtime to read the file (no I/O in `update`).
    assert_eq!(update(&mut m, ch('R')), vec![Effect::ReadJobLog]);
    assert!(m.popup.is_none());
    let table = vec![
        "started (UTC)    file               way      line      took  estimate ended".to_owned(),
        "2026-12-07 11:05 slow.nc            stream       5     3.0 s     4.9 s crash".to_owned(),
    ];
    assert!(update(&mut m, Msg::JobLog(table)).is_empty());
    assert!(matches!(m.popup, Some(Popup::Messages { back: 0 })));
    assert!(message(&m).ends_with("stream       5     3.0 s     4.9 s crash"));
    let shown = text(render(&m, 80, 24).backend().buffer());
    assert!(shown.contains("slow.nc"), "{shown}");
}
