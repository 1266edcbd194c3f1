//! `update()` driven with message sequences, no terminal: what the operator
//! does, what the UI asks the device for, and what the screen then says.

use crate::ui_support;

use std::time::{Duration, Instant};

use jogterm::axis::{Axis, AxisSet};
use jogterm::device::api::{
    Activity, Event, IoBit, IoGroup, IoSnapshot, JogEnd, JogId, LinkState, MachineState, OutputId,
    Refusal, Request, UploadEvent,
};
use jogterm::proto::Protocol;
use jogterm::sim::InputControl;
use jogterm::ui::help::{HelpLine, help_lines};
use jogterm::ui::io::HIGHLIGHT;
use jogterm::ui::keymap::Mode;
use jogterm::ui::model::{PanelId, Popup};
use jogterm::ui::{Effect, Model, Msg, update};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ui_support::{State, fresh, model_in, render, text};

fn key(code: KeyCode) -> Msg {
    Msg::Key(KeyEvent::new(code, KeyModifiers::NONE))
}

fn ch(c: char) -> Msg {
    key(KeyCode::Char(c))
}

fn ctrl(c: char) -> Msg {
    Msg::Key(KeyEvent::new(KeyCode::Char(c), KeyModifiers::CONTROL))
}

fn press(model: &mut Model, msgs: impl IntoIterator<Item = Msg>) -> Vec<Effect> {
    msgs.into_iter().flat_map(|m| update(model, m)).collect()
}

fn typed(model: &mut Model, text: &str) -> Vec<Effect> {
    press(model, text.chars().map(ch))
}

fn screen(model: &Model, w: u16, h: u16) -> String {
    text(render(model, w, h).backend().buffer())
}

fn ready(protocol: Protocol) -> Model {
    model_in(protocol, "dark", State::Idle, Instant::now())
}

/// An I/O snapshot with one input, a plain output and a hazardous one.
fn outputs_snapshot(at: Instant, spindle_on: bool) -> IoSnapshot {
    IoSnapshot {
        at,
        groups: vec![
            IoGroup {
                name: "in3".into(),
                raw: Some(0),
                bits: vec![IoBit {
                    name: "limit X1".into(),
                    value: false,
                    output: None,
                    hazardous: false,
                    wiring: None,
                }],
                read: None,
            },
            IoGroup {
                name: "out".into(),
                raw: None,
                bits: vec![
                    IoBit {
                        name: "start lamp".into(),
                        value: false,
                        output: Some(OutputId {
                            group: 101,
                            bit: Some(6),
                        }),
                        hazardous: false,
                        wiring: None,
                    },
                    IoBit {
                        name: "spindle".into(),
                        value: spindle_on,
                        output: Some(OutputId {
                            group: 2,
                            bit: None,
                        }),
                        hazardous: true,
                        wiring: None,
                    },
                ],
                read: None,
            },
        ],
    }
}

#[test]
fn refusals_are_shown_with_their_reason() {
    let mut m = ready(Protocol::Isel);
    let reason = Refusal::NotReferenced {
        axes: AxisSet::EMPTY.with(Axis::X),
    };
    update(
        &mut m,
        Msg::Device(Event::Refused {
            request: "jog X+".into(),
            reason: reason.clone(),
        }),
    );
    let shown = screen(&m, 80, 24);
    assert!(
        shown.contains("refused jog X+: axes X not referenced"),
        "{shown}"
    );
    let message = m.message.as_ref().expect("message");
    assert!(message.text.contains(&reason.to_string()));
    // It stays in the console after the message line has moved on.
    let later = m.now + Duration::from_secs(30);
    update(&mut m, Msg::Tick(later));
    let later = screen(&m, 80, 24);
    assert!(
        later.lines().skip(2).any(|l| l.contains("refused jog X+")),
        "{later}"
    );

    update(
        &mut m,
        Msg::Device(Event::JogEnded {
            id: JogId(3),
            end: JogEnd::Refused(Refusal::EmergencyStop),
        }),
    );
    assert!(screen(&m, 80, 24).contains("jog refused: emergency stop active"));
}

#[test]
fn hazardous_outputs_ask_first_plain_ones_do_not() {
    let mut m = ready(Protocol::Isel);
    let t = m.now;
    update(&mut m, Msg::Device(Event::Io(outputs_snapshot(t, false))));
    // The jog keypad has focus at start; the port bits are next.
    assert_eq!(m.focus, PanelId::Jog);
    press(&mut m, [key(KeyCode::Tab)]);
    assert_eq!(m.focus, PanelId::Io);
    // The selection starts on the input: Enter only explains.
    assert!(press(&mut m, [key(KeyCode::Enter)]).is_empty());
    assert!(m.message.as_ref().expect("why").text.contains("input"));

    // The start lamp switches at once.
    let fx = press(&mut m, [key(KeyCode::Right), key(KeyCode::Enter)]);
    assert_eq!(
        fx,
        [Effect::Request(Request::SetOutput {
            output: OutputId {
                group: 101,
                bit: Some(6)
            },
            value: 1
        })]
    );
    assert!(m.popup.is_none());

    // The spindle asks; `n` cancels, nothing is sent.
    let fx = press(&mut m, [key(KeyCode::Right), key(KeyCode::Enter)]);
    assert!(fx.is_empty());
    assert!(matches!(m.popup, Some(Popup::Confirm(_))));
    let shown = screen(&m, 80, 24);
    assert!(shown.contains("Switch spindle on?"), "{shown}");
    assert!(press(&mut m, [ch('n')]).is_empty());
    assert!(m.popup.is_none());

    // Asked again; Space (stop) is not swallowed by the popup, which stays.
    press(&mut m, [key(KeyCode::Enter)]);
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
    assert!(matches!(m.popup, Some(Popup::Confirm(_))));
    // Other keys are: the popup is modal.
    assert!(press(&mut m, [ch('q'), ch('h')]).is_empty());
    let fx = press(&mut m, [ch('y')]);
    assert_eq!(
        fx,
        [Effect::Request(Request::SetOutput {
            output: OutputId {
                group: 2,
                bit: None
            },
            value: 1
        })]
    );

    // Switching off asks too, and says so.
    update(&mut m, Msg::Device(Event::Io(outputs_snapshot(t, true))));
    press(&mut m, [key(KeyCode::Enter)]);
    assert!(screen(&m, 80, 24).contains("Switch spindle off?"));
}

#[test]
fn raw_commands_are_checked_before_they_are_sent() {
    let mut m = ready(Protocol::Isel);
    press(&mut m, [ch(':')]);
    assert_eq!(m.focus, PanelId::Console);
    // Letters are typed, not taken as keys (q would quit, h would home).
    assert!(typed(&mut m, "@0A5000,900").is_empty());
    assert!(press(&mut m, [key(KeyCode::Enter)]).is_empty());
    let error = m.console.command.error.clone().expect("refused");
    assert!(error.message.contains("4 steps,speed pairs"), "{error:?}");
    let shown = screen(&m, 80, 24);
    assert!(shown.contains("^ `A` with XYZ takes 4"), "{shown}");
    assert!(shown.contains("> @0A5000,900"), "{shown}");

    // The machine stands still: Space types a blank.
    assert!(press(&mut m, [ch(' ')]).is_empty());
    assert_eq!(m.console.command.text(), "@0A5000,900 ");
    // While it moves Space stops, and the line is unchanged.
    let moving = MachineState {
        activity: Activity::Jogging,
        ..m.machine.clone()
    };
    update(&mut m, Msg::Device(Event::State(moving)));
    assert_eq!(press(&mut m, [ch(' ')]), [Effect::Stop]);
    assert_eq!(m.console.command.text(), "@0A5000,900 ");

    press(&mut m, [ctrl('u')]);
    typed(&mut m, "@0P");
    assert!(
        m.console.command.error.is_none(),
        "editing clears the error"
    );
    let fx = press(&mut m, [key(KeyCode::Enter)]);
    assert_eq!(fx, [Effect::Request(Request::Raw { line: "@0P".into() })]);
    assert_eq!(m.console.command.text(), "");

    // EMCU and EMP lines are checked with their own parsers.
    let mut emcu = ready(Protocol::Emcu);
    press(&mut emcu, [ch(':')]);
    typed(&mut emcu, "@LQ");
    assert!(press(&mut emcu, [key(KeyCode::Enter)]).is_empty());
    assert!(emcu.console.command.error.is_some());
    let mut emp = ready(Protocol::Emp);
    press(&mut emp, [ch(':')]);
    typed(&mut emp, "2C11000000000000");
    assert_eq!(press(&mut emp, [key(KeyCode::Enter)]).len(), 1);
}

#[test]
fn history_recalls_sent_commands_and_the_draft() {
    let mut m = ready(Protocol::Emcu);
    press(&mut m, [ch(':')]);
    for line in ["@LX", "@LY", "@X"] {
        typed(&mut m, line);
        assert_eq!(press(&mut m, [key(KeyCode::Enter)]).len(), 1, "{line}");
    }
    typed(&mut m, "@L");
    press(&mut m, [key(KeyCode::Up)]);
    assert_eq!(m.console.command.text(), "@X");
    press(
        &mut m,
        [key(KeyCode::Up), key(KeyCode::Up), key(KeyCode::Up)],
    );
    assert_eq!(m.console.command.text(), "@LX");
    press(&mut m, [key(KeyCode::Down)]);
    assert_eq!(m.console.command.text(), "@LY");
    press(&mut m, [key(KeyCode::Down), key(KeyCode::Down)]);
    assert_eq!(m.console.command.text(), "@L");
    // A recalled line is sent as it stands.
    press(&mut m, [ctrl('u'), key(KeyCode::Up)]);
    assert_eq!(
        press(&mut m, [key(KeyCode::Enter)]),
        [Effect::Request(Request::Raw { line: "@X".into() })]
    );
}

#[test]
fn help_lists_every_key_of_every_mode() {
    let mut m = ready(Protocol::Isel);
    press(&mut m, [ch('?')]);
    assert!(matches!(m.popup, Some(Popup::Help { .. })));
    let lines = help_lines(&m.keymap, &m.setup.macros);
    for mode in Mode::ALL {
        for (key, action) in m.keymap.bindings(mode) {
            let listed = lines.iter().any(|l| match l {
                HelpLine::Entry { keys, description } => {
                    *description == action.description()
                        && keys.split(' ').any(|k| k == key.to_string())
                }
                _ => false,
            });
            assert!(listed, "{mode}: {key} ({action}) is not in the help");
        }
    }
    // Everything the help lists reaches the screen, page by page.
    let mut seen = String::new();
    for _ in 0..lines.len() {
        seen.push_str(&screen(&m, 80, 24));
        press(&mut m, [key(KeyCode::Down)]);
    }
    for line in &lines {
        if let HelpLine::Entry { description, .. } = line {
            assert!(
                seen.contains(description.as_ref()),
                "{description} never shown"
            );
        }
    }
    // Esc closes the help without stopping anything.
    assert!(press(&mut m, [key(KeyCode::Esc)]).is_empty());
    assert!(m.popup.is_none());
    // Without a popup Esc stops.
    assert_eq!(press(&mut m, [key(KeyCode::Esc)]), [Effect::Stop]);
}

#[test]
fn reference_run_and_reset_ask_first_quit_stops() {
    let mut m = ready(Protocol::Isel);
    assert!(press(&mut m, [ch('h')]).is_empty());
    assert_eq!(
        press(&mut m, [key(KeyCode::Enter)]),
        [Effect::Request(Request::Home { axes: AxisSet::XYZ })]
    );
    press(&mut m, [ctrl('r')]);
    assert!(screen(&m, 80, 24).contains("Reset the controller"));
    assert!(press(&mut m, [key(KeyCode::Esc)]).is_empty());
    assert_eq!(
        press(&mut m, [ch('i')]),
        [Effect::Request(Request::Initialise)]
    );
    assert_eq!(press(&mut m, [ch('q')]), [Effect::Stop, Effect::Quit]);
    assert!(m.quitting);

    let mut m = ready(Protocol::Emp);
    let fx = update(
        &mut m,
        Msg::Terminate {
            reason: "the terminal hung up".into(),
        },
    );
    assert_eq!(fx, [Effect::Stop, Effect::Quit]);
}

#[test]
fn key_releases_do_nothing_and_repeats_act() {
    let mut m = ready(Protocol::Isel);
    let mut release = KeyEvent::new(KeyCode::Char(' '), KeyModifiers::NONE);
    release.kind = KeyEventKind::Release;
    assert!(update(&mut m, Msg::Key(release)).is_empty());
    let mut repeat = release;
    repeat.kind = KeyEventKind::Repeat;
    assert_eq!(update(&mut m, Msg::Key(repeat)), [Effect::Stop]);
}

#[test]
fn jog_step_and_speed_move_within_the_profile_lists() {
    let mut m = ready(Protocol::Isel);
    assert_eq!((m.jog_step(), m.jog_speed()), (Some(1.0), Some(2.0)));
    press(&mut m, [ch(']'), ch(']'), ch(']'), ch('+')]);
    assert_eq!((m.jog_step(), m.jog_speed()), (Some(10.0), Some(5.0)));
    let shown = screen(&m, 80, 24);
    assert!(shown.contains("STEP 10 mm"), "{shown}");
    assert!(shown.contains("5 mm/s"), "{shown}");
    press(
        &mut m,
        [
            ch('['),
            ch('['),
            ch('['),
            ch('['),
            ch('-'),
            ch('-'),
            ch('-'),
        ],
    );
    assert_eq!((m.jog_step(), m.jog_speed()), (Some(0.01), Some(0.5)));
}

#[test]
fn a_changed_bit_is_highlighted_then_fades_with_a_redraw() {
    let t0 = Instant::now();
    let mut m = fresh(Protocol::Isel, "dark", t0);
    update(&mut m, Msg::Device(Event::Io(outputs_snapshot(t0, false))));
    let t1 = t0 + Duration::from_millis(100);
    update(&mut m, Msg::Device(Event::Io(outputs_snapshot(t1, true))));
    assert_eq!(m.io.highlight_count(t1), 1);
    m.dirty = false;
    update(&mut m, Msg::Tick(t1 + Duration::from_millis(10)));
    assert!(!m.dirty, "nothing visible changed");
    update(&mut m, Msg::Tick(t1 + HIGHLIGHT));
    assert!(m.dirty, "the highlight has faded: redraw");
}

#[test]
fn simulator_inputs_are_flipped_through_effects() {
    let mut m = ready(Protocol::Isel);
    // Tab passes the command line by: keypad, I/O, simulator.
    press(&mut m, [key(KeyCode::Tab), key(KeyCode::Tab)]);
    assert_eq!(m.focus, PanelId::Sim);
    // The simulator reported the circuit closed at start: Enter opens it.
    assert!(screen(&m, 80, 24).contains("estop1=1"));
    let open = InputControl::Set {
        name: "estop1".into(),
        level: false,
    };
    assert_eq!(
        press(&mut m, [key(KeyCode::Enter)]),
        [Effect::Simulator(open.clone())]
    );
    assert!(
        screen(&m, 80, 24).contains("estop1=…"),
        "pending until the simulator took it"
    );
    update(
        &mut m,
        Msg::Simulator {
            control: open,
            result: Ok(()),
        },
    );
    assert!(screen(&m, 80, 24).contains("estop1=0"));
    let fx = press(&mut m, [ch('1')]);
    assert_eq!(
        fx,
        [Effect::Simulator(InputControl::Set {
            name: "estop1".into(),
            level: true
        })]
    );
    update(
        &mut m,
        Msg::Simulator {
            control: InputControl::Press {
                name: "nope".into(),
            },
            result: Err("unknown input `nope`".into()),
        },
    );
    assert!(screen(&m, 80, 24).contains("simulator: unknown input `nope`"));
}

#[test]
fn link_loss_says_the_state_is_unknown() {
    let mut m = ready(Protocol::Emcu);
    update(
        &mut m,
        Msg::Device(Event::Link(LinkState::Reconnecting {
            attempt: 2,
            retry_in: Duration::from_millis(500),
        })),
    );
    let shown = screen(&m, 80, 24);
    assert!(shown.contains("reconnecting"), "{shown}");
    assert!(shown.contains("UNKNOWN"), "{shown}");
}

#[test]
fn an_upload_shows_its_progress_and_its_end() {
    let mut m = ready(Protocol::Isel);
    update(
        &mut m,
        Msg::Device(Event::Upload(UploadEvent::Progress {
            done: 12,
            total: 40,
            lines_per_second: 30.0,
        })),
    );
    assert!(
        screen(&m, 80, 24)
            .lines()
            .next()
            .is_some_and(|l| l.contains("upload 12/40"))
    );
    update(
        &mut m,
        Msg::Device(Event::Upload(UploadEvent::Finished {
            total: 40,
            elapsed: Duration::from_millis(1500),
        })),
    );
    let shown = screen(&m, 80, 24);
    assert!(
        !shown.lines().next().is_some_and(|l| l.contains("upload")),
        "{shown}"
    );
    assert!(
        shown.contains("upload finished: 40 commands stored in 1.5 s"),
        "{shown}"
    );
}

#[test]
fn a_text_reply_is_shown_line_by_line() {
    let mut m = ready(Protocol::Isel);
    update(
        &mut m,
        Msg::Device(Event::Reply {
            kind: jogterm::device::api::ReplyKind::Answer,
            command: "@0V".into(),
            text: "iMC-S8 V2.0\r\nserial 42\r\n".into(),
        }),
    );
    let shown = screen(&m, 80, 24);
    assert!(shown.contains("=  @0V = iMC-S8 V2.0"), "{shown}");
    assert!(shown.contains("=    serial 42"), "{shown}");
    assert!(shown.contains("@0V = iMC-S8 V2.0 / serial 42"), "{shown}");
}

/// The ports of an isel controller as the driver names them with the
/// shipped `isel-rewired` profile (`config/isel-rewired.toml`): user inputs
/// and outputs (none written yet), the hood's port.
fn rewired_snapshot(at: Instant) -> IoSnapshot {
    use jogterm::config::{ConfigDirs, load_profile};
    use jogterm::device::isel::{input_group, output_group};
    use jogterm::proto::isel::{InputPort, OutputPort};
    let profile = load_profile("isel-rewired", &ConfigDirs::builtin_only()).expect("profile");
    let wiring = profile.wiring().expect("wiring");
    IoSnapshot {
        at,
        groups: vec![
            input_group(InputPort::User, 0x00, &wiring),
            input_group(InputPort::Status2, 0x02, &wiring),
            output_group(OutputPort::User, None, &wiring),
        ],
    }
}

#[test]
fn the_io_panel_names_bits_as_the_profile_wires_them() {
    let mut m = ready(Protocol::Isel);
    let t = m.now;
    update(&mut m, Msg::Device(Event::Io(rewired_snapshot(t))));
    press(&mut m, [key(KeyCode::Tab)]);
    assert_eq!(m.focus, PanelId::Io);
    // In 0: user input 0, 1, 2, then the tool setter.
    press(&mut m, (0..3).map(|_| key(KeyCode::Right)));
    let shown = screen(&m, 220, 30);
    assert!(
        shown.contains("> in 0: user inputs tool setter = 0 (input, in0.3 probe"),
        "{shown}"
    );
    // The hood bits are there, marked as not wired; the key switch, unused
    // on this machine, is left out.
    press(&mut m, [key(KeyCode::Down)]);
    let shown = screen(&m, 220, 30);
    assert!(
        shown.contains("hood closed or setup = 0 (input, in2.6 hood, not wired"),
        "{shown}"
    );
    assert!(!shown.contains("key switch"), "{shown}");
    press(&mut m, [key(KeyCode::Left), key(KeyCode::Left)]);
    let shown = screen(&m, 220, 30);
    assert!(
        shown.contains("power ok = 1 (input, in2.1 power"),
        "{shown}"
    );
}

#[test]
fn a_bit_of_an_output_byte_nobody_wrote_asks_once_for_the_whole_byte() {
    let mut m = ready(Protocol::Isel);
    let t = m.now;
    update(&mut m, Msg::Device(Event::Io(rewired_snapshot(t))));
    press(
        &mut m,
        [key(KeyCode::Tab), key(KeyCode::Down), key(KeyCode::Down)],
    );
    // out 0, bit 1: the coolant pump; its state and the others' unknown.
    press(&mut m, [key(KeyCode::Right)]);
    let shown = screen(&m, 120, 30);
    assert!(
        shown.contains("> out 0: user outputs coolant = ?"),
        "{shown}"
    );
    let fx = press(&mut m, [key(KeyCode::Enter)]);
    assert!(fx.is_empty(), "asks first: {fx:?}");
    assert!(matches!(m.popup, Some(Popup::Confirm(_))));
    let shown = screen(&m, 120, 40);
    assert!(shown.contains("Write out 0: user outputs = 02?"), "{shown}");
    assert!(shown.contains("1 coolant: ? -> ON"), "{shown}");
    for n in [0, 2, 3, 4, 5, 6, 7] {
        let line = format!("{n} user output {n}: ? -> off");
        assert!(shown.contains(&line), "{line}:\n{shown}");
    }
    let fx = press(&mut m, [ch('y')]);
    assert_eq!(
        fx,
        [Effect::Request(Request::SetOutput {
            output: OutputId {
                group: 0,
                bit: None
            },
            value: 0x02
        })]
    );
}

/// Issue 20, finding 6: once the E-stop circuits were closed again, the
/// message line kept asking to release the emergency stop, and read
/// "… E-stop.: release …".
#[test]
fn the_estop_message_follows_the_circuits_and_reads_as_a_sentence() {
    use jogterm::device::api::{ControllerFault, MachineState, Recovery};
    let mut m = ready(Protocol::Isel);
    let t = m.now;
    let fault = ControllerFault {
        command: "@0A5000,900,0,900,0,900,0,900".into(),
        code: "9".into(),
        meaning: jogterm::proto::isel::ReplyCode::MachineFault
            .meaning()
            .into(),
        recovery: Recovery::ClearEmergencyStop,
    };
    let open = MachineState {
        estop: true,
        referenced: AxisSet::EMPTY,
        fault: Some(fault.clone()),
        ..m.machine.clone()
    };
    update(&mut m, Msg::Device(Event::Fault(fault.clone())));
    update(&mut m, Msg::Device(Event::State(open.clone())));
    // What the message line says: the fresh message, else the state's
    // detail (the screen cuts long ones).
    let message = |m: &Model| match m.fresh_message() {
        Some(note) => note.text.clone(),
        None => jogterm::ui::summary::summarise(m)
            .detail
            .unwrap_or_default(),
    };
    let line = message(&m);
    assert!(
        line.contains("or an E-stop occurred: release the emergency stop"),
        "{line}"
    );
    assert!(!line.contains(".:"), "{line}");
    // Closed again: the driver now asks for initialising and referencing.
    let closed = MachineState {
        estop: false,
        fault: Some(ControllerFault {
            recovery: Recovery::ReinitialiseAndReference,
            ..fault
        }),
        ..open
    };
    update(&mut m, Msg::Device(Event::State(closed)));
    let line = message(&m);
    assert!(
        line.contains("emergency stop released: initialise (i) and reference (h) the axes"),
        "{line}"
    );
    // Once that message is old, the state's own words: no circuit to release.
    update(&mut m, Msg::Tick(t + Duration::from_secs(30)));
    let line = message(&m);
    assert!(line.contains("initialise (i) and reference (h)"), "{line}");
    assert!(!line.contains("release"), "{line}");
    assert!(!line.contains(".:"), "{line}");
}
