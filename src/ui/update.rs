//! `update(&mut Model, Msg) -> Vec<Effect>`: the only place the model
//! changes. Keys are routed safety first (see [`route_key`]), then to the
//! open popup, the focused panel and the main screen, gitui-style: the first
//! that consumes a key ends its journey.

use std::time::Instant;

use crate::device::api::{ControllerFault, Event, JogEnd, LinkState, Request};

use super::editor;
use super::help::help_lines;
use super::io::OutputToggle;
use super::key::KeyChord;
use super::keymap::{Action, Mode};
use super::model::{Confirmation, Message, Model, PanelId, Popup};
use super::msg::{Effect, Msg};
use super::raw;
use super::traffic_log::{LineKind, NoteLevel};

pub fn update(model: &mut Model, msg: Msg) -> Vec<Effect> {
    match msg {
        Msg::Key(event) => match KeyChord::from_event(&event) {
            Some(chord) => {
                model.dirty = true;
                route_key(model, chord)
            }
            None => Vec::new(),
        },
        Msg::Tick(now) => {
            tick(model, now);
            editor::update::tick(model, now)
        }
        Msg::Device(event) => {
            editor::update::device_event(model, &event);
            device_event(model, event);
            model.dirty = true;
            Vec::new()
        }
        Msg::Resize { width, height } => {
            model.size = (width, height);
            model.dirty = true;
            Vec::new()
        }
        Msg::Simulator { control, result } => {
            if let Some(sim) = model.sim.as_mut() {
                sim.done(&control, result.is_ok());
            }
            if let Err(e) = result {
                say(model, NoteLevel::Warning, format!("simulator: {e}"));
            }
            model.dirty = true;
            Vec::new()
        }
        Msg::NotSent { request, reason } => {
            say(
                model,
                NoteLevel::Danger,
                format!("not sent: {request}: {reason}"),
            );
            model.dirty = true;
            Vec::new()
        }
        Msg::Terminate { reason } => {
            say(
                model,
                NoteLevel::Danger,
                format!("{reason}: stopping and closing"),
            );
            model.quitting = true;
            model.dirty = true;
            // The last edits go to the recovery file before leaving.
            let mut effects = vec![Effect::Stop];
            effects.extend(editor::update::terminate(model));
            effects.push(Effect::Quit);
            effects
        }
        Msg::Editor(msg) => {
            model.dirty = true;
            editor::update::message(model, msg)
        }
    }
}

/// Safety keys first, whatever is open or focused; then the popup (modal:
/// it takes every other key), the focused panel, typing, the main screen.
pub fn route_key(model: &mut Model, chord: KeyChord) -> Vec<Effect> {
    if model.keymap.lookup(Mode::Safety, &chord) == Some(Action::Stop) {
        return stop(model);
    }
    if let Some(popup) = &model.popup {
        return match (model.keymap.lookup(popup.mode(), &chord), popup) {
            (Some(action), _) => popup_action(model, action),
            (None, Popup::Editor(editor::dialog::Dialog::Form(_))) => match chord.typed_char() {
                Some(c) => editor::update::form_char(model, c),
                None => Vec::new(),
            },
            (None, _) => Vec::new(),
        };
    }
    let focus = model.focus;
    if let Some(action) = model.keymap.lookup(focus.mode(), &chord) {
        return panel_action(model, focus, action);
    }
    if focus == PanelId::Console
        && let Some(c) = chord.typed_char()
    {
        model.command.insert(c);
        return Vec::new();
    }
    if focus == PanelId::Editor
        && let Some(c) = chord.typed_char()
    {
        return editor::update::type_char(model, c);
    }
    match model.keymap.lookup(Mode::Main, &chord) {
        Some(action) => main_action(model, action),
        None => Vec::new(),
    }
}

fn stop(model: &mut Model) -> Vec<Effect> {
    say(
        model,
        NoteLevel::Info,
        "stop: all motion stopped".to_string(),
    );
    vec![Effect::Stop]
}

fn main_action(model: &mut Model, action: Action) -> Vec<Effect> {
    match action {
        Action::Stop => stop(model),
        Action::Quit => {
            // Unsaved edits ask first.
            if let Some(effects) = editor::update::before_quit(model) {
                return effects;
            }
            model.quitting = true;
            vec![Effect::Stop, Effect::Quit]
        }
        Action::Help => {
            model.popup = Some(Popup::Help { scroll: 0 });
            Vec::new()
        }
        Action::FocusNext => {
            cycle_focus(model, 1);
            Vec::new()
        }
        Action::FocusPrev => {
            cycle_focus(model, -1);
            Vec::new()
        }
        Action::FocusConsole => {
            model.focus = PanelId::Console;
            Vec::new()
        }
        Action::Initialise => vec![Effect::Request(Request::Initialise)],
        Action::Home => {
            let axes = model.setup.axis_set();
            ask(
                model,
                "Reference run",
                format!(
                    "Axes {axes} will move to their reference switches. \
                     Keep clear of the machine. Start the reference run?"
                ),
                vec![Effect::Request(Request::Home { axes })],
            );
            Vec::new()
        }
        Action::SetZero => {
            let axes = model.setup.axis_set();
            say(
                model,
                NoteLevel::Info,
                format!("work zero of {axes} set to the current position"),
            );
            vec![Effect::Request(Request::SetZero { axes })]
        }
        Action::Reset => {
            ask(
                model,
                "Reset the controller",
                "The controller stops at once and forgets its axes and reference \
                 point; initialise (i) and reference (h) again afterwards. Reset?"
                    .to_string(),
                vec![Effect::Request(Request::Reset)],
            );
            Vec::new()
        }
        Action::StepSmaller => {
            model.jog.step = model.jog.step.saturating_sub(1);
            Vec::new()
        }
        Action::StepLarger => {
            let last = model.setup.jog_steps.len().saturating_sub(1);
            model.jog.step = (model.jog.step + 1).min(last);
            Vec::new()
        }
        Action::SpeedSlower => {
            model.jog.speed = model.jog.speed.saturating_sub(1);
            Vec::new()
        }
        Action::SpeedFaster => {
            let last = model.setup.jog_speeds.len().saturating_sub(1);
            model.jog.speed = (model.jog.speed + 1).min(last);
            Vec::new()
        }
        Action::TogglePolls => {
            model.traffic.show_polls = !model.traffic.show_polls;
            Vec::new()
        }
        // The program editor's actions on the main screen (teach-in,
        // upload, run); actions of other modes never reach here (the
        // keymap refuses them).
        other => editor::update::main_action(model, other).unwrap_or_default(),
    }
}

fn cycle_focus(model: &mut Model, delta: isize) {
    let ring = model.focus_ring();
    let len = ring.len() as isize;
    let at = ring.iter().position(|p| *p == model.focus).unwrap_or(0) as isize;
    if let Some(next) = ring.get((at + delta).rem_euclid(len.max(1)) as usize) {
        model.focus = *next;
    }
}

fn ask(model: &mut Model, title: &str, question: String, effects: Vec<Effect>) {
    model.popup = Some(Popup::Confirm(Confirmation {
        title: title.to_string(),
        question,
        effects,
    }));
}

fn popup_action(model: &mut Model, action: Action) -> Vec<Effect> {
    match (model.popup.take(), action) {
        (Some(Popup::Confirm(c)), Action::Confirm) => c.effects,
        (Some(Popup::Confirm(c)), Action::Cancel) => {
            say(model, NoteLevel::Info, format!("{}: cancelled", c.title));
            Vec::new()
        }
        (Some(Popup::Editor(dialog)), action) => {
            editor::update::dialog_action(model, dialog, action)
        }
        (Some(Popup::Help { .. }), Action::Close) => Vec::new(),
        (Some(Popup::Help { scroll }), scroll_action) => {
            let page = usize::from(model.size.1.saturating_sub(6)).max(1);
            let last = help_lines(&model.keymap).len().saturating_sub(1);
            let scroll = match scroll_action {
                Action::ScrollUp => scroll.saturating_sub(1),
                Action::ScrollDown => scroll + 1,
                Action::PageUp => scroll.saturating_sub(page),
                Action::PageDown => scroll + page,
                _ => scroll,
            };
            model.popup = Some(Popup::Help {
                scroll: scroll.min(last),
            });
            Vec::new()
        }
        (popup, _) => {
            model.popup = popup;
            Vec::new()
        }
    }
}

fn panel_action(model: &mut Model, panel: PanelId, action: Action) -> Vec<Effect> {
    match panel {
        PanelId::Io => io_action(model, action),
        PanelId::Console => console_action(model, action),
        PanelId::Sim => sim_action(model, action),
        PanelId::Editor => editor::update::action(model, action),
    }
}

fn io_action(model: &mut Model, action: Action) -> Vec<Effect> {
    match action {
        Action::SelectPrev => model.io.step_bit(-1, model.now),
        Action::SelectNext => model.io.step_bit(1, model.now),
        Action::GroupPrev => model.io.step_group(-1, model.now),
        Action::GroupNext => model.io.step_group(1, model.now),
        Action::ToggleOutput => {
            return match model.io.toggle_selected() {
                Ok(toggle) => toggle_output(model, toggle),
                Err(why) => {
                    say(model, NoteLevel::Warning, why);
                    Vec::new()
                }
            };
        }
        _ => {}
    }
    Vec::new()
}

fn toggle_output(model: &mut Model, t: OutputToggle) -> Vec<Effect> {
    let effects = vec![Effect::Request(Request::SetOutput {
        output: t.output,
        value: t.value,
    })];
    let state = if t.value == 0 { "off" } else { "on" };
    if t.hazardous {
        ask(
            model,
            "Switch an output",
            format!(
                "Switch {} {state}? It moves or powers something on the machine.",
                t.name
            ),
            effects,
        );
        Vec::new()
    } else {
        effects
    }
}

fn console_action(model: &mut Model, action: Action) -> Vec<Effect> {
    let line = &mut model.command;
    match action {
        Action::Submit => {
            return match raw::validate(&model.raw_context(), model.command.text()) {
                Ok(checked) => {
                    model.command.accept();
                    model.traffic.typed(&checked);
                    vec![Effect::Request(Request::Raw { line: checked })]
                }
                Err(e) => {
                    model.command.error = Some(e);
                    Vec::new()
                }
            };
        }
        Action::HistoryPrev => line.history_prev(),
        Action::HistoryNext => line.history_next(),
        Action::CursorLeft => line.left(),
        Action::CursorRight => line.right(),
        Action::CursorHome => line.home(),
        Action::CursorEnd => line.end(),
        Action::DeleteBack => line.delete_back(),
        Action::DeleteForward => line.delete_forward(),
        Action::ClearLine => line.clear(),
        _ => {}
    }
    Vec::new()
}

fn sim_action(model: &mut Model, action: Action) -> Vec<Effect> {
    let Some(sim) = model.sim.as_mut() else {
        return Vec::new();
    };
    let control = match action {
        Action::SelectPrev => {
            sim.step(-1);
            None
        }
        Action::SelectNext => {
            sim.step(1);
            None
        }
        Action::SimOn => sim.set_selected(true),
        Action::SimOff => sim.set_selected(false),
        Action::SimPress => sim.press_selected(),
        Action::SimToggle => match sim.toggle_selected() {
            Ok(c) => Some(c),
            Err(why) => {
                say(model, NoteLevel::Warning, why);
                None
            }
        },
        _ => None,
    };
    control.map(Effect::Simulator).into_iter().collect()
}

fn tick(model: &mut Model, now: Instant) {
    let before = (
        model.io.highlight_count(model.now),
        model.fresh_message().is_some(),
    );
    model.now = now;
    let flushed = model.traffic.flush_idle(now);
    let after = (
        model.io.highlight_count(now),
        model.fresh_message().is_some(),
    );
    if flushed || before != after {
        model.dirty = true;
    }
}

fn device_event(model: &mut Model, event: Event) {
    match event {
        Event::Link(state) => link_changed(model, state),
        Event::Position(sample) => model.positions.apply(&sample),
        Event::Io(snapshot) => model.io.apply(&snapshot),
        Event::State(state) => model.machine = state,
        Event::Fault(fault) => say(model, NoteLevel::Danger, fault_text(&fault)),
        Event::Refused { request, reason } => say(
            model,
            NoteLevel::Danger,
            format!("refused {request}: {reason}"),
        ),
        Event::JogEnded { end, .. } => jog_ended(model, end),
        Event::Upload(upload) => {
            // The editor knows which line each uploaded command came from.
            if let Some(report) = editor::update::upload_event(model, &upload) {
                let level = if report.danger {
                    NoteLevel::Danger
                } else {
                    NoteLevel::Info
                };
                say(model, level, report.text);
            }
            model.upload = Some(upload);
        }
        Event::Traffic(record) => model.traffic.record(&record, model.now),
        Event::Reply { command, text } => {
            // Text replies (isel `@0V`, `@0H`) come in several lines.
            let lines: Vec<&str> = text
                .lines()
                .map(|l| l.trim_end_matches('\r'))
                .filter(|l| !l.is_empty())
                .collect();
            let mut notes = lines.iter();
            let first = notes.next().copied().unwrap_or_default();
            model
                .traffic
                .note(LineKind::Reply, format!("{command} = {first}"));
            for line in notes {
                model.traffic.note(LineKind::Reply, format!("  {line}"));
            }
            model.message = Some(Message {
                at: model.now,
                level: NoteLevel::Info,
                text: format!("{command} = {}", lines.join(" / ")),
            });
        }
        Event::Stats(stats) => model.stats = Some(stats),
        Event::Notice(text) => say(model, NoteLevel::Info, text),
    }
}

fn link_changed(model: &mut Model, state: LinkState) {
    if model.link == state {
        return;
    }
    let note = match &state {
        LinkState::Connecting => None,
        LinkState::Connected => Some((NoteLevel::Info, "link up".to_string())),
        LinkState::Lost { reason } => Some((
            NoteLevel::Danger,
            format!("link lost: {reason}; motion state unknown until the controller is read again"),
        )),
        LinkState::Reconnecting { attempt, retry_in } => Some((
            NoteLevel::Warning,
            format!(
                "reconnecting (attempt {attempt}) in {:.1} s",
                retry_in.as_secs_f64()
            ),
        )),
        LinkState::Closed => Some((NoteLevel::Info, "port closed".to_string())),
    };
    model.link = state;
    if let Some((level, text)) = note {
        say(model, level, text);
    }
}

fn jog_ended(model: &mut Model, end: JogEnd) {
    let note = match end {
        JogEnd::Released => None,
        JogEnd::DeadMan => Some((
            NoteLevel::Warning,
            "jog stopped: key repeats stopped arriving (dead-man)".to_string(),
        )),
        JogEnd::Stopped => None,
        JogEnd::SoftLimit => Some((
            NoteLevel::Warning,
            "jog stopped at the soft limit".to_string(),
        )),
        JogEnd::Refused(reason) => Some((NoteLevel::Danger, format!("jog refused: {reason}"))),
        JogEnd::Fault(f) => Some((NoteLevel::Danger, format!("jog ended: {}", fault_text(&f)))),
        JogEnd::LinkLost => Some((NoteLevel::Danger, "jog ended: link lost".to_string())),
    };
    if let Some((level, text)) = note {
        say(model, level, text);
    }
}

/// A controller's error for the operator: what it means and what to do
/// first (the message line may cut the rest), then the answer and command.
pub fn fault_text(f: &ControllerFault) -> String {
    format!(
        "{}: {} (answer {} to {})",
        f.meaning,
        f.recovery.instruction(),
        f.code,
        f.command
    )
}

/// Show a message in the message line and keep it in the console.
pub(crate) fn say(model: &mut Model, level: NoteLevel, text: String) {
    model.traffic.note(LineKind::Note(level), text.clone());
    model.message = Some(Message {
        at: model.now,
        level,
        text,
    });
}
