//! Work offsets, the typed step and speed, the speed override and go-to in
//! machine coordinates or at a feed, through `update()` (issue 16): what
//! the keys ask of the device, what the position panel and the keypad
//! show, what is refused and why; snapshots at 80x24 and 160x48.

use crate::ui_support;

use std::time::Instant;

use jogterm::axis::{Axis, AxisSet};
use jogterm::config::{ConfigDirs, load_profile};
use jogterm::device::api::{
    Activity, Event, Frame, MachineState, PerAxis, PositionSample, PositionSource, Request,
};
use jogterm::offsets::store::OffsetsFile;
use jogterm::offsets::{Identity, System};
use jogterm::proto::Protocol;
use jogterm::ui::model::Popup;
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ui_support::{State, model_in, render, send, text};

fn ch(c: char) -> Msg {
    Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE))
}

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

fn typed(text: &str) -> Vec<Msg> {
    text.chars().map(ch).collect()
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

fn saves(effects: &[Effect]) -> usize {
    effects
        .iter()
        .filter(|e| matches!(e, Effect::SaveOffsets(_)))
        .count()
}

fn screen(model: &Model) -> String {
    text(render(model, 100, 30).backend().buffer())
}

/// The isel console, ready, X at machine 112.345 mm (44938 steps), G54's
/// zero and the controller's at X 10 mm (4000 steps); its offsets kept in
/// a file (in a directory nobody writes to: only the effects are looked at).
fn ready() -> Model {
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
    let file = OffsetsFile::in_dir(
        std::path::Path::new("/nonexistent/offsets"),
        Identity::of("default", &profile),
    );
    m.keypad.offsets.file = Some(file);
    m
}

/// The X line of the position panel: its work value.
fn x_work(model: &Model) -> String {
    screen(model)
        .lines()
        .find(|l| l.starts_with('X'))
        .and_then(|l| l.split_whitespace().nth(1).map(str::to_string))
        .unwrap_or_default()
}

#[test]
fn another_offset_is_chosen_shown_and_saved() {
    let mut m = ready();
    assert!(screen(&m).contains("Position G54"), "{}", screen(&m));
    assert_eq!(x_work(&m), "102.345");
    press(&mut m, [ch('O')]);
    assert!(matches!(m.popup, Some(Popup::Jog(_))));
    let s = screen(&m);
    assert!(s.contains("Work offsets"), "{s}");
    assert!(s.contains("1 G54 ●"), "{s}");
    let fx = press(&mut m, [ch('2')]);
    assert_eq!(saves(&fx), 1);
    assert!(requests(&fx).is_empty(), "choosing moves nothing: {fx:?}");
    assert!(m.popup.is_none());
    assert_eq!(m.keypad.offsets.table.active(), System::ALL[1]);
    // G55 untouched: machine coordinates; isel's zero is G54's.
    let s = screen(&m);
    assert!(s.contains("Position G55 programs ≠ G55"), "{s}");
    assert_eq!(x_work(&m), "112.345");
    assert!(s.contains("G55 active"), "{s}");
    // Arrows and Enter choose too; Esc closes without a change.
    press(&mut m, [ch('O'), key(KeyCode::Up), key(KeyCode::Enter)]);
    assert_eq!(m.keypad.offsets.table.active(), System::G54);
    let fx = press(&mut m, [ch('O'), ch('5'), ch('O'), key(KeyCode::Esc)]);
    assert_eq!(saves(&fx), 1);
    assert_eq!(m.keypad.offsets.table.active(), System::ALL[4]);
    // The EMCU and EMP have no zero of their own: nothing to differ from,
    // and go-to goes in machine steps there too.
    for protocol in [Protocol::Emcu, Protocol::Emp] {
        let mut m = model_in(protocol, "dark", State::Idle, Instant::now());
        press(&mut m, [ch('O'), ch('2')]);
        let s = screen(&m);
        assert!(s.contains("Position G55 ─"), "{protocol}: {s}");
        let fx = press(
            &mut m,
            [ch('g')]
                .into_iter()
                .chain(typed("X1"))
                .chain([key(KeyCode::Enter)]),
        );
        let rs = requests(&fx);
        let [Request::MoveTo { target, frame, .. }] = rs.as_slice() else {
            panic!("{protocol}: {fx:?}")
        };
        let spu = m.setup.axis(Axis::X).map_or(0.0, |a| a.steps_per_unit);
        assert_eq!(*frame, Frame::Machine);
        assert_eq!(target.get(Axis::X), Some(spu as i64), "{protocol}");
    }
}

#[test]
fn set_x_to_a_value_here_moves_the_zero_and_only_zero_sends_at_0n() {
    let mut m = ready();
    press(&mut m, [ch('O'), ch('2')]);
    press(&mut m, [ch('s')]);
    assert!(screen(&m).contains("Set the work position here (G55)"));
    let fx = press(
        &mut m,
        typed("X10").into_iter().chain([key(KeyCode::Enter)]),
    );
    // The zero 10 mm below the machine's X: 44938 - 4000 steps.
    assert_eq!(m.keypad.offsets.table.zero(System::ALL[1], Axis::X), 40_938);
    assert_eq!(x_work(&m), "10.000");
    assert_eq!(saves(&fx), 1);
    // The controller's zero goes only where the axis stands: not sent.
    assert!(requests(&fx).is_empty(), "{fx:?}");
    let s = screen(&m);
    assert!(
        s.contains("G55: X = 10 (zero at machine 102.345) here"),
        "{s}"
    );
    // Y = 0 here: the controller's zero of Y too.
    let fx = press(
        &mut m,
        [ch('s')]
            .into_iter()
            .chain(typed("y0"))
            .chain([key(KeyCode::Enter)]),
    );
    assert_eq!(
        requests(&fx),
        [Request::SetZero {
            axes: AxisSet::EMPTY.with(Axis::Y)
        }]
    );
    // z: every axis where it stands, and @0n of all (the controller follows).
    let fx = press(&mut m, [ch('z')]);
    assert_eq!(
        requests(&fx),
        [Request::SetZero {
            axes: m.setup.axis_set()
        }]
    );
    assert_eq!(m.keypad.offsets.table.zero(System::ALL[1], Axis::X), 44_938);
    assert!(screen(&m).contains("G55: work zero of XYZ set to the current position"));
}

#[test]
fn bad_typed_positions_and_states_are_refused_with_the_reason() {
    let mut m = ready();
    let cases = [
        ("X", "`X` is not an axis and a position"),
        ("Q5", "`Q5` is not an axis and a position"),
        ("A1", "the machine has no A axis"),
        ("X1 F100", "F and G53 mean nothing here"),
        ("G53 X1", "F and G53 mean nothing here"),
        ("X1e300000", "is not an axis and a position"),
        ("X1e15", "beyond any controller's count"),
    ];
    for (text, needle) in cases {
        press(&mut m, [ch('s')]);
        let fx = press(&mut m, typed(text).into_iter().chain([key(KeyCode::Enter)]));
        assert!(fx.is_empty(), "{text}: {fx:?}");
        assert!(matches!(m.popup, Some(Popup::Jog(_))), "{text}");
        let s = screen(&m);
        assert!(s.contains(needle), "{text}: {needle}\n{s}");
        press(&mut m, [key(KeyCode::Esc)]);
    }
    assert_eq!(m.keypad.offsets.table.zero(System::G54, Axis::X), 4000);
    // Not referenced: refused, nothing changes.
    let unreferenced = MachineState {
        referenced: AxisSet::EMPTY.with(Axis::Y),
        ..m.machine.clone()
    };
    send(&mut m, [Event::State(unreferenced)]);
    let fx = press(&mut m, [ch('z')]);
    assert!(fx.is_empty(), "{fx:?}");
    assert!(screen(&m).contains("XZ not referenced"), "{}", screen(&m));
    // Moving (an estimated position): refused.
    let mut m = ready();
    let now = m.now;
    send(
        &mut m,
        [Event::Position(PositionSample {
            at: now,
            steps: PerAxis::new().with(Axis::X, 45_000),
            source: PositionSource::Estimated,
        })],
    );
    let fx = press(&mut m, [ch('z')]);
    assert!(fx.is_empty(), "{fx:?}");
    assert!(screen(&m).contains("X is moving"), "{}", screen(&m));
    // Busy: refused by the gate.
    let moving = MachineState {
        activity: Activity::Moving,
        ..m.machine.clone()
    };
    send(&mut m, [Event::State(moving)]);
    let fx = press(&mut m, [ch('s')]);
    assert!(fx.is_empty() && m.popup.is_none(), "{fx:?}");
    assert!(
        screen(&m).contains("set position refused: busy"),
        "{}",
        screen(&m)
    );
}

#[test]
fn go_to_in_machine_coordinates_and_at_a_typed_feed() {
    let mut m = ready();
    press(&mut m, [ch('g'), key(KeyCode::Tab)]);
    assert!(
        screen(&m).contains("Go to (machine coordinates)"),
        "{}",
        screen(&m)
    );
    let fx = press(
        &mut m,
        typed("X50").into_iter().chain([key(KeyCode::Enter)]),
    );
    let rs = requests(&fx);
    let [
        Request::MoveTo {
            target,
            frame,
            speed_hz,
        },
    ] = rs.as_slice()
    else {
        panic!("{fx:?}")
    };
    assert_eq!(
        (*frame, target.get(Axis::X)),
        (Frame::Machine, Some(20_000))
    );
    // At the jog speed, 2 mm/s.
    assert_eq!(speed_hz.get(Axis::X), Some(800.0));
    assert!(screen(&m).contains("go to X50 (machine coordinates) at 2 per second"));
    // Work coordinates (G54, zero at X 10 mm) at F30: 0.5 mm/s. (No
    // blanks: right after a move was asked for Space stops, not types.)
    let fx = press(
        &mut m,
        [ch('g')]
            .into_iter()
            .chain(typed("X5F30"))
            .chain([key(KeyCode::Enter)]),
    );
    let rs = requests(&fx);
    let [
        Request::MoveTo {
            target, speed_hz, ..
        },
    ] = rs.as_slice()
    else {
        panic!("{fx:?}")
    };
    assert_eq!(target.get(Axis::X), Some(6000));
    assert_eq!(speed_hz.get(Axis::X), Some(200.0));
    // Faster than the axis may run: refused, the prompt stays.
    let fx = press(
        &mut m,
        [ch('g')]
            .into_iter()
            .chain(typed("Z5F1000"))
            .chain([key(KeyCode::Enter)]),
    );
    assert!(fx.is_empty(), "{fx:?}");
    assert!(
        screen(&m).contains("F1000 is faster than Z may run"),
        "{}",
        screen(&m)
    );
    press(&mut m, [key(KeyCode::Esc)]);
    // G53 typed: machine coordinates whatever the prompt says.
    let fx = press(
        &mut m,
        [ch('g')]
            .into_iter()
            .chain(typed("G53X0"))
            .chain([key(KeyCode::Enter)]),
    );
    let rs = requests(&fx);
    let [Request::MoveTo { target, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    assert_eq!(target.get(Axis::X), Some(0));
    // G goes to the active offset's zero, in machine steps.
    press(&mut m, [ch('O'), ch('3')]);
    m.keypad.offsets.table.set(System::ALL[2], Axis::X, 12_000);
    press(&mut m, [ch('G')]);
    assert!(screen(&m).contains("work zero of G56"), "{}", screen(&m));
    let fx = press(&mut m, [ch('y')]);
    let rs = requests(&fx);
    let [Request::MoveTo { target, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    assert_eq!(
        (target.get(Axis::X), target.get(Axis::Y)),
        (Some(12_000), Some(0))
    );
}

fn step_right(m: &mut Model) -> (i64, f64) {
    let fx = press(m, [key(KeyCode::Right)]);
    let rs = requests(&fx);
    let [Request::Step { delta, speed_hz }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    (
        delta.get(Axis::X).unwrap_or(0),
        speed_hz.get(Axis::X).unwrap_or(0.0),
    )
}

#[test]
fn a_typed_step_and_speed_and_the_override_reach_the_requests() {
    let mut m = ready();
    assert_eq!(step_right(&mut m), (400, 800.0));
    press(&mut m, [ch('J')]);
    press(&mut m, typed("0.25"));
    press(&mut m, [key(KeyCode::Tab)]);
    press(&mut m, typed("3"));
    press(&mut m, [key(KeyCode::Enter)]);
    assert!(m.popup.is_none());
    assert_eq!((m.jog_step(), m.jog_speed()), (Some(0.25), Some(3.0)));
    assert!(
        screen(&m).contains("STEP 0.25 mm  3 mm/s"),
        "{}",
        screen(&m)
    );
    assert_eq!(step_right(&mut m), (100, 1200.0));
    // +10 % five times: 150 %, shown in the title, on every request.
    press(&mut m, typed(")))))"));
    assert_eq!(m.keypad.values.override_pct, 150);
    assert!(screen(&m).contains("4.5 mm/s  150%"), "{}", screen(&m));
    assert_eq!(step_right(&mut m), (100, 1800.0));
    // Back to 100 %, and `[` to the preset below the typed step.
    press(&mut m, [ch('%'), ch('[')]);
    assert_eq!((m.jog_step(), m.jog_speed()), (Some(0.1), Some(3.0)));
    press(&mut m, [ch('-')]);
    assert_eq!(m.jog_speed(), Some(2.0));
    // The go-to's speed is the jog speed with the override.
    press(&mut m, [ch('(')]);
    let fx = press(
        &mut m,
        [ch('g')]
            .into_iter()
            .chain(typed("X20"))
            .chain([key(KeyCode::Enter)]),
    );
    let rs = requests(&fx);
    let [Request::MoveTo { speed_hz, .. }] = rs.as_slice() else {
        panic!("{fx:?}")
    };
    assert_eq!(speed_hz.get(Axis::X), Some(720.0));
}

#[test]
fn typed_values_out_of_the_axes_limits_are_refused_with_the_limit() {
    let mut m = ready();
    let cases = [
        ("abc", "", "`abc` is not a number"),
        ("0.001", "", "less than one step of X (0.0025 mm)"),
        ("100", "", "more than the travel of Z (80 mm)"),
        ("", "30", "faster than any axis may run (top speed: X 25"),
        ("", "-1", "the speed must be more than 0"),
    ];
    for (step, speed, needle) in cases {
        press(&mut m, [ch('J')]);
        press(&mut m, typed(step));
        press(&mut m, [key(KeyCode::Tab)]);
        press(&mut m, typed(speed));
        press(&mut m, [key(KeyCode::Enter)]);
        assert!(matches!(m.popup, Some(Popup::Jog(_))), "{step}/{speed}");
        let s = screen(&m);
        assert!(s.contains(needle), "{needle}\n{s}");
        press(&mut m, [key(KeyCode::Esc)]);
        assert_eq!((m.jog_step(), m.jog_speed()), (Some(1.0), Some(2.0)));
    }
    // 15 mm/s: the override stops where X's top speed is reached.
    press(&mut m, [ch('+'), ch('+')]);
    press(&mut m, typed(&")".repeat(12)));
    assert_eq!(m.keypad.values.override_pct, 170);
    assert_eq!(m.jog_speed(), Some(25.0));
    assert!(screen(&m).contains("top speed of X"), "{}", screen(&m));
}

#[test]
fn the_offsets_popup_prompts_and_marks_on_screen() {
    let mut m = ready();
    press(&mut m, [ch('O'), ch('2'), ch('s')]);
    press(&mut m, typed("X10 Y-2.5"));
    press(&mut m, [key(KeyCode::Enter)]);
    press(&mut m, [ch(')'), ch(')')]);
    for (w, h) in ui_support::SIZES {
        insta::assert_snapshot!(format!("offsets_g55_{w}x{h}"), render(&m, w, h).backend());
    }
    press(&mut m, [ch('O'), key(KeyCode::Down)]);
    for (w, h) in ui_support::SIZES {
        insta::assert_snapshot!(format!("offsets_popup_{w}x{h}"), render(&m, w, h).backend());
    }
    press(&mut m, [key(KeyCode::Esc), ch('s')]);
    press(&mut m, typed("X1 F2"));
    press(&mut m, [key(KeyCode::Enter)]);
    for (w, h) in ui_support::SIZES {
        insta::assert_snapshot!(
            format!("offsets_set_position_{w}x{h}"),
            render(&m, w, h).backend()
        );
    }
    press(&mut m, [key(KeyCode::Esc), ch('J')]);
    press(&mut m, typed("0.001"));
    press(&mut m, [key(KeyCode::Enter)]);
    for (w, h) in ui_support::SIZES {
        insta::assert_snapshot!(
            format!("offsets_jog_values_{w}x{h}"),
            render(&m, w, h).backend()
        );
    }
    press(&mut m, [key(KeyCode::Esc), ch('g'), key(KeyCode::Tab)]);
    press(&mut m, typed("X50 F600"));
    for (w, h) in ui_support::SIZES {
        insta::assert_snapshot!(
            format!("offsets_go_to_machine_{w}x{h}"),
            render(&m, w, h).backend()
        );
    }
}

#[test]
fn a_refused_file_is_marked_and_its_reason_shown_in_the_popup() {
    let dir = tempfile::tempdir().expect("tempdir");
    let profile = load_profile("default", &ConfigDirs::builtin_only()).expect("profile");
    let file = OffsetsFile::in_dir(dir.path(), Identity::of("default", &profile));
    std::fs::write(&file.path, "format = 1\nprofile = [\n").expect("write");
    let mut m = model_in(Protocol::Isel, "dark", State::Idle, Instant::now());
    let startup = file.load();
    jogterm::ui::update::start_offsets(&mut m, Some((startup, file.clone())));
    let s = screen(&m);
    assert!(s.contains("Position G54!"), "{s}");
    assert!(s.contains("work offsets refused"), "{s}");
    press(&mut m, [ch('O')]);
    let s = text(render(&m, 160, 48).backend().buffer());
    assert!(s.contains(":2:"), "{s}");
    // The first write puts the refused file aside and the mark goes.
    let fx = press(&mut m, [ch('2')]);
    let [Effect::SaveOffsets(job)] = fx.as_slice() else {
        panic!("{fx:?}")
    };
    assert!(job.put_aside);
    assert!(!m.keypad.offsets.refused);
    assert!(screen(&m).contains("Position G55"), "{}", screen(&m));
    // Said when a write fails.
    update(
        &mut m,
        Msg::OffsetsSaved("work offsets", Err("/x: disk full".into())),
    );
    assert!(screen(&m).contains("work offsets not saved: /x: disk full"));
}
