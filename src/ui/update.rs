//! `update(&mut Model, Msg) -> Vec<Effect>`: the only place the model
//! changes, and the router between its components (`docs/architecture.md`,
//! "The other components and the router"): each gets its state, a context
//! built from the model and an input, and its outcome is applied here
//! ([`show`], `apply_jog`, `apply_editor`). Keys are routed safety first
//! (see [`route_key`]), then to the open popup, the focused panel and the
//! main screen, gitui-style: the first that consumes a key ends its journey.

use std::time::Instant;

use ratatui::crossterm::event::{KeyEvent, KeyEventKind};

use crate::device::api::{Event, JogEnd, LinkState, Request};
use crate::jog::{KeyPhase, Motion};

use super::console;
use super::editor;
use super::help::help_lines;
use super::io::Outputs;
use super::jog::axes::{AxisChoice, Purpose};
use super::jog::goto::GoToPrompt;
use super::jog::{self as keypad, component::Input as JogInput};
use super::key::KeyChord;
use super::keymap::{Action, Mode};
use super::macros::{self, MacroRun};
use super::model::{Message, Model, PanelId, Popup};
use super::msg::{Effect, Msg};
use super::outcome::{Outcome, Then};
use super::popups;
use super::timeline;
use super::traffic_log::{LineKind, NoteLevel};
use super::typing;
use super::view::{messages::max_back, timeline::lane_columns, timeline::lane_rows};

pub fn update(model: &mut Model, msg: Msg) -> Vec<Effect> {
    let effects = dispatch(model, msg);
    // Any stop ends a frame being traced: nothing resumes (`ui::frame`).
    if model.frame.is_some() && effects.contains(&Effect::Stop) {
        model.frame = None;
        say(model, NoteLevel::Info, "frame: stopped; nothing resumes");
    }
    // What Space in a text field must know: something may move although
    // no state report says so yet (`typing::may_move`).
    let moving = |e: &Effect| matches!(e, Effect::Request(r) if typing::may_start_motion(r));
    if effects.iter().any(moving) {
        model.motion_asked = Some(model.now);
    }
    effects
}

fn dispatch(model: &mut Model, msg: Msg) -> Vec<Effect> {
    match msg {
        Msg::Key(event) => key_event(model, event),
        Msg::KeyAt(event, at) => keys_at(model, vec![(event, at)]),
        Msg::KeysAt(batch) => keys_at(model, batch),
        Msg::Paste(text) => paste(model, &text),
        Msg::Tick(now) => {
            tick(model, now);
            // Toggle jogs live on the console's ticks.
            let mut effects = jog_update(model, JogInput::Tick);
            effects.extend(editor_update(model, editor::Input::Tick));
            effects
        }
        Msg::Device(event) => {
            let mut effects = editor_update(model, editor::Input::Device(&event));
            let after = macros::device_event(&mut model.macro_run, &model.machine, &event);
            let probed = super::probe::device_event(
                &mut model.probe,
                &model.setup,
                (&mut model.keypad.offsets, &mut model.tools),
                &event,
            );
            let framed = super::frame::device_event(&mut model.frame, &model.positions, &event);
            device_event(model, event);
            effects.extend(apply(model, after));
            if let Some((next, level, text)) = framed {
                say(model, level, text);
                effects.extend(next);
            }
            if let Some((level, text, saves)) = probed {
                say(model, level, text);
                effects.extend(saves);
            }
            model.dirty = true;
            effects
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
            let text = format!("not sent: {request}: {reason}");
            say(model, NoteLevel::Danger, text);
            model.dirty = true;
            Vec::new()
        }
        Msg::Terminate { reason } => {
            let text = format!("{reason}: stopping and closing");
            say(model, NoteLevel::Danger, text);
            model.quitting = true;
            model.dirty = true;
            jog_update(model, JogInput::Stopped);
            model.macro_run = None;
            // The last edits go to the recovery file before leaving.
            let mut effects = vec![Effect::Stop];
            effects.extend(editor_update(model, editor::Input::Terminate));
            effects.push(Effect::Quit);
            effects
        }
        Msg::Editor(msg) => {
            model.dirty = true;
            editor_update(model, editor::Input::Msg(msg))
        }
        // The job log's runs as notes, read in the message history.
        Msg::JobLog(lines) => {
            for line in lines {
                say(model, NoteLevel::Info, line);
            }
            model.dirty = true;
            open(model, Popup::Messages { back: 0 })
        }
        Msg::OffsetsSaved(what, saved) => {
            if let Some((level, text)) = keypad::offsets::saved(what, &saved) {
                say(model, level, text);
                model.dirty = true;
            }
            Vec::new()
        }
    }
}

fn key_event(model: &mut Model, event: KeyEvent) -> Vec<Effect> {
    let phase = phase_of(event.kind);
    if phase == KeyPhase::Release {
        // Releases matter to the jog keypad only (kitty keyboard protocol).
        let mut pressed = event;
        pressed.kind = KeyEventKind::Press;
        let Some(chord) = KeyChord::from_event(&pressed) else {
            return Vec::new();
        };
        if model.popup.is_none()
            && model.panel_mode() == Mode::Checkout
            && let Some(action) = model.keymap.lookup(Mode::Checkout, &chord)
        {
            let effects = editor_update(model, editor::Input::Checkout(action, KeyPhase::Release));
            model.dirty = true;
            return effects;
        }
        let settings = model.keypad.settings();
        let (grace, timeout) = (settings.grace, settings.repeat_timeout);
        let now = model.now;
        (model.macro_key).arrival(chord, KeyPhase::Release, now, grace, timeout, true);
        // The hold-to-run frame's key let go: it stops at once.
        if model.keymap.lookup(Mode::Main, &chord) == Some(Action::FrameHold) {
            (model.frame_key).arrival(chord, KeyPhase::Release, now, grace, timeout, true);
            if model
                .frame
                .as_ref()
                .is_some_and(super::frame::FrameRun::held)
            {
                say(model, NoteLevel::Info, "frame stopped: the key was let go");
                return stop(model);
            }
        }
        let effects = jog_update(model, JogInput::Release(chord));
        model.dirty |= !effects.is_empty();
        return effects;
    }
    let Some(chord) = KeyChord::from_event(&event) else {
        return Vec::new();
    };
    model.dirty = true;
    let effects = route(model, chord, phase);
    model.keypad.issued(&effects, model.now);
    if effects.contains(&Effect::Quit) {
        model.quitting = true;
    }
    effects
}

/// Keys as the input thread read them, with their arrival times: one by
/// one as typed, or, for a burst (`typing::is_burst`), each through
/// [`burst_key`], which lets none of them move the machine.
fn keys_at(model: &mut Model, batch: Vec<(KeyEvent, Instant)>) -> Vec<Effect> {
    let burst = typing::is_burst(&batch, model.last_key_at);
    if let Some(last) = typing::last_press(&batch) {
        model.last_key_at = Some(model.last_key_at.map_or(last, |t| t.max(last)));
    }
    let mut effects = Vec::new();
    let mut ignored = Ignored::default();
    for (event, at) in batch {
        if at > model.now {
            model.now = at;
        }
        if burst {
            effects.extend(burst_key(model, event, &mut ignored));
        } else {
            effects.extend(key_event(model, event));
        }
        if model.quitting {
            break;
        }
    }
    ignored.say(model);
    effects
}

/// Keys of a burst that did nothing, for one message after the burst.
#[derive(Debug, Default)]
struct Ignored {
    keys: usize,
    /// One of them was Enter in a text field: nothing was sent or confirmed.
    enter_in_field: bool,
}

impl Ignored {
    fn note(&mut self, model: &Model, chord: KeyChord) {
        self.keys += 1;
        self.enter_in_field |= chord == KeyChord::plain(super::key::KeyCode::Enter)
            && typing::text_field(model).is_some();
    }

    fn say(self, model: &mut Model) {
        let text = if self.enter_in_field {
            "Enter came together with other keys (a paste?): nothing was sent; check the \
             line and press Enter again"
                .to_string()
        } else if self.keys > 0 {
            let keys = if self.keys == 1 { "key" } else { "keys" };
            format!(
                "burst ignored: {} {keys} came together with others (a paste?); jogterm \
                 moves only on keys typed one at a time",
                self.keys
            )
        } else {
            return;
        };
        say(model, NoteLevel::Warning, text);
    }
}

/// One key of a burst. Releases act as ever (they only stop). A press
/// goes on only where it cannot move the machine, answer a question or
/// send anything: a stop key (the Space rule included), a motion key of
/// the keypad as [`keypad::burst_key`] takes it (renewing the held jog it
/// belongs to, never starting one), and in a text field the characters it
/// types and the keys that edit it; a key that only closes a popup. The
/// rest is ignored and counted in `ignored`.
fn burst_key(model: &mut Model, event: KeyEvent, ignored: &mut Ignored) -> Vec<Effect> {
    let phase = phase_of(event.kind);
    if phase == KeyPhase::Release {
        return key_event(model, event);
    }
    let Some(chord) = KeyChord::from_event(&event) else {
        return Vec::new();
    };
    model.dirty = true;
    let effects = match burst_route(model, chord, phase) {
        Some(effects) => effects,
        None => {
            ignored.note(model, chord);
            Vec::new()
        }
    };
    model.keypad.issued(&effects, model.now);
    effects
}

fn burst_route(model: &mut Model, chord: KeyChord, phase: KeyPhase) -> Option<Vec<Effect>> {
    if model.keymap.lookup(Mode::Safety, &chord) == Some(Action::Stop) {
        return Some(route(model, chord, phase));
    }
    // A held macro key's repeats that arrive bunched (SSH) keep its hold.
    if model.keymap.lookup_macro(Mode::Main, &chord).is_some() {
        model.macro_key.seen(chord, model.now);
    }
    let focus = model.focus;
    if model.popup.is_none()
        && focus == PanelId::Jog
        && model
            .keymap
            .lookup(Mode::Jog, &chord)
            .and_then(keypad::vector_of)
            .is_some()
    {
        let outcome = jog_outcome(model, JogInput::Burst(chord, phase));
        return outcome.used.then(|| apply_jog(model, outcome));
    }
    if let Some(effects) = jog_any_key(model, chord, phase) {
        say(model, NoteLevel::Info, "jog stopped");
        return Some(effects);
    }
    // The hold-to-run frame's repeats that arrive bunched (SSH) keep its
    // hold; a burst never starts one.
    if model
        .frame
        .as_ref()
        .is_some_and(super::frame::FrameRun::held)
        && typing::text_field(model).is_none()
        && model.keymap.lookup(Mode::Main, &chord) == Some(Action::FrameHold)
    {
        return Some(frame_hold(model, chord, phase));
    }
    let field = typing::text_field(model);
    let mode = model.popup.as_ref().map_or(model.panel_mode(), Popup::mode);
    let passes = match model.keymap.lookup(mode, &chord) {
        Some(action) => {
            typing::only_stops_or_closes(action) || (field.is_some() && typing::edits_text(action))
        }
        None if field.is_some() && chord.typed_char().is_some() => true,
        None => {
            model.popup.is_none() && model.keymap.lookup(Mode::Main, &chord) == Some(Action::Stop)
        }
    };
    passes.then(|| route(model, chord, phase))
}

/// Pasted text (bracketed paste): into the text field that has the input,
/// never anywhere else. Multi-line text goes into the program editor as it
/// is; a one-line field takes one line (`line_edit::one_line`).
fn paste(model: &mut Model, text: &str) -> Vec<Effect> {
    model.dirty = true;
    let refused = match (typing::text_field(model), model.popup.as_mut()) {
        (Some(typing::TextField::Editor), _) => {
            return editor_update(model, editor::Input::Paste(text));
        }
        (Some(typing::TextField::Form), Some(Popup::Editor(_))) => {
            let Some(Popup::Editor(dialog)) = model.popup.take() else {
                return Vec::new();
            };
            return editor_update(model, editor::Input::DialogPaste(dialog, text));
        }
        (Some(typing::TextField::CommandLine), _) => {
            return console_update(model, console::Input::Paste(text));
        }
        (Some(typing::TextField::Prompt), Some(popup)) => {
            let line = popup.line();
            line.and_then(|l| l.paste(text).err())
                .map(|e| e.to_string())
        }
        (None, _) => Some("paste ignored: jogterm moves only on keys".to_string()),
        _ => None,
    };
    if let Some(refused) = refused {
        say(model, NoteLevel::Warning, refused);
    }
    Vec::new()
}

fn phase_of(kind: KeyEventKind) -> KeyPhase {
    match kind {
        KeyEventKind::Press => KeyPhase::Press,
        KeyEventKind::Repeat => KeyPhase::Repeat,
        KeyEventKind::Release => KeyPhase::Release,
    }
}

/// Safety keys first, whatever is open or focused; then the popup (modal:
/// it takes every other key), the focused panel, typing, the main screen.
pub fn route_key(model: &mut Model, chord: KeyChord) -> Vec<Effect> {
    route(model, chord, KeyPhase::Press)
}

fn route(model: &mut Model, chord: KeyChord, phase: KeyPhase) -> Vec<Effect> {
    if model.keymap.lookup(Mode::Safety, &chord) == Some(Action::Stop) {
        return safety_stop(model, chord);
    }
    let focus = model.focus;
    let panel_mode = model.panel_mode();
    let motion_key = model.popup.is_none()
        && model
            .keymap
            .lookup(panel_mode, &chord)
            .and_then(keypad::vector_of)
            .is_some();
    // Toggle jogging: any key stops the jog and does nothing else (the
    // keypad's own keys know their repeats from a new press).
    if !motion_key && let Some(effects) = jog_any_key(model, chord, phase) {
        say(model, NoteLevel::Info, "jog stopped");
        return effects;
    }
    let field = typing::text_field(model);
    if let Some(popup) = &model.popup {
        let mode = popup.mode();
        return match (model.keymap.lookup(mode, &chord), chord.typed_char(), field) {
            (Some(action), _, _) => popup_action(model, action),
            (None, Some(c), Some(field)) => type_into(model, field, c),
            (None, _, _) => Vec::new(),
        };
    }
    if field.is_none() && model.keymap.lookup(Mode::Main, &chord) == Some(Action::FrameHold) {
        return frame_hold(model, chord, phase);
    }
    if let Some(action) = model.keymap.lookup(panel_mode, &chord) {
        if panel_mode == Mode::Checkout {
            return editor_update(model, editor::Input::Checkout(action, phase));
        }
        if focus == PanelId::Jog {
            let (action, chord) = (action, chord);
            return jog_update(
                model,
                JogInput::Motion {
                    action,
                    chord,
                    phase,
                },
            );
        }
        return panel_action(model, focus, action);
    }
    if let (Some(field), Some(c)) = (field, chord.typed_char()) {
        return type_into(model, field, c);
    }
    if let Some(name) = model.keymap.lookup_macro(Mode::Main, &chord) {
        // A held key runs its macro once: a repeat is not a new request,
        // reported as one (kitty keyboard protocol) or, where repeats come
        // as presses, told by their arrival times as the jog tells them
        // (`jog::held`, `docs/ui.md`, Macros).
        let settings = model.keypad.settings();
        let (grace, timeout) = (settings.grace, settings.repeat_timeout);
        let releases = model.keypad.jogger.releases();
        if model
            .macro_key
            .arrival(chord, phase, model.now, grace, timeout, releases)
            == crate::jog::Arrival::Held
        {
            return Vec::new();
        }
        let name = name.to_string();
        let (run, ctx) = model.macro_parts();
        let out = macros::key(run, &ctx, &name);
        return apply(model, out);
    }
    match model.keymap.lookup(Mode::Main, &chord) {
        Some(action) => main_action(model, action),
        None => Vec::new(),
    }
}

/// The frame's question (`F`) or plan (`f`), or why there is none.
fn frame_question(model: &Model) -> Result<super::frame::Question, String> {
    let job = model.editor.job.as_ref();
    let figures = job.and_then(|j| j.report.figures.as_ref());
    let ctx = super::frame::Context {
        job: job
            .zip(figures)
            .map(|(j, f)| (j.report.file.as_str(), &f.frame)),
        checking: job.is_some_and(|j| j.checking),
        gate: keypad::gate(&model.keypad, &model.jog_context()),
        settings: model.keypad.settings(),
        offsets: &model.keypad.offsets.table,
        speed: keypad::selection(&model.keypad, &model.setup).speed,
        positions: &model.positions,
    };
    super::frame::question(&ctx)
}

/// `f`, held: the frame without a question, the device task's hold renewed
/// by every repeat (`ui::frame`, hold-to-run). A key still held after the
/// frame ended starts nothing; only a new press starts one.
fn frame_hold(model: &mut Model, chord: KeyChord, phase: KeyPhase) -> Vec<Effect> {
    let settings = model.keypad.settings();
    let (grace, timeout) = (settings.grace, settings.repeat_timeout);
    let releases = model.keypad.jogger.releases();
    let arrival = model
        .frame_key
        .arrival(chord, phase, model.now, grace, timeout, releases);
    let held = model.frame.as_ref().map(super::frame::FrameRun::held);
    match (held, arrival) {
        // The first repeat may take the terminal's delay again after a
        // new press; the ones that follow come within the timeout.
        (Some(true), crate::jog::Arrival::Press) => {
            vec![Effect::Request(Request::Hold { lease: grace })]
        }
        (Some(true), crate::jog::Arrival::Held) => {
            vec![Effect::Request(Request::Hold { lease: timeout })]
        }
        (Some(false), _) => {
            say(
                model,
                NoteLevel::Info,
                "a frame runs to its end: Space stops it",
            );
            Vec::new()
        }
        (None, crate::jog::Arrival::Held) => Vec::new(),
        (None, crate::jog::Arrival::Press) => match frame_question(model) {
            Ok(q) => {
                let (effects, level, text) =
                    super::frame::start(&mut model.frame, q.plan, &model.positions, Some(grace));
                let text = if effects.is_empty() {
                    text
                } else {
                    format!("{text} (while f is held)")
                };
                say(model, level, text);
                effects
            }
            Err(text) => apply(model, Outcome::note(NoteLevel::Danger, text)),
        },
    }
}

/// A character into the text field that has the input.
fn type_into(model: &mut Model, field: typing::TextField, c: char) -> Vec<Effect> {
    match field {
        typing::TextField::Editor => editor_update(model, editor::Input::Char(c)),
        typing::TextField::Form => match model.popup.take() {
            Some(Popup::Editor(dialog)) => {
                editor_update(model, editor::Input::DialogChar(dialog, c))
            }
            other => {
                model.popup = other;
                Vec::new()
            }
        },
        typing::TextField::CommandLine => console_update(model, console::Input::Char(c)),
        typing::TextField::Prompt => {
            if let Some(line) = model.popup.as_mut().and_then(Popup::line) {
                line.insert(c);
            }
            Vec::new()
        }
    }
}

/// A stop key. Space in a text field types a blank while the machine is
/// known to stand still, and stops otherwise, saying why it did not type
/// (`typing::may_move`); every other stop key always stops.
fn safety_stop(model: &mut Model, chord: KeyChord) -> Vec<Effect> {
    let Some(field) = typing::text_field(model).filter(|_| chord == KeyChord::SPACE) else {
        return stop(model);
    };
    let Some(reason) = typing::may_move(model) else {
        return type_into(model, field, ' ');
    };
    let effects = stop(model);
    let mode = model.popup.as_ref().map_or(model.panel_mode(), Popup::mode);
    let blank = model
        .keymap
        .key_for(mode, Action::TypeBlank)
        .map(|k| format!("; {k} types a blank"))
        .unwrap_or_default();
    let text = format!("stop: all motion stopped (Space stops, not types, while {reason}{blank})");
    say(model, NoteLevel::Info, text);
    effects
}

fn stop(model: &mut Model) -> Vec<Effect> {
    jog_update(model, JogInput::Stopped);
    say(model, NoteLevel::Info, "stop: all motion stopped");
    if let Some((level, text)) = macros::stopped(&mut model.macro_run) {
        say(model, level, text);
    }
    let mut effects = vec![Effect::Stop];
    effects.extend(editor_update(model, editor::Input::Stopped));
    effects
}

fn main_action(model: &mut Model, action: Action) -> Vec<Effect> {
    // Work offsets, the step and speed (typed, presets, override).
    let outcome = jog_outcome(model, JogInput::Main(action));
    if outcome.used {
        return apply_jog(model, outcome);
    }
    match action {
        Action::Stop => stop(model),
        Action::Outputs => {
            let out = Outputs::open(&model.io);
            show(model, out, Popup::Outputs)
        }
        Action::Messages => open(model, Popup::Messages { back: 0 }),
        Action::JobLog => vec![Effect::ReadJobLog],
        Action::LargeDro => {
            model.large_dro = !model.large_dro;
            // The panels it hides cannot keep the focus: keys must not
            // switch outputs or type commands nobody sees.
            if model.large_dro
                && matches!(model.focus, PanelId::Io | PanelId::Console | PanelId::Sim)
            {
                model.focus = PanelId::Jog;
            }
            Vec::new()
        }
        Action::Quit => {
            // Unsaved edits ask first.
            let held = editor_outcome(model, editor::Input::Quit);
            if held.dialog.is_some() {
                return apply_editor(model, held);
            }
            if model.keypad.moving(&model.machine) {
                // Quitting stops the machine; a slip of the finger must not
                // end a program run or a reference run (`docs/jogging.md`).
                let question = quit_question(model);
                let effects = vec![Effect::Stop, Effect::Quit];
                return ask(model, QUIT_WHILE_MOVING, question, effects);
            }
            model.quitting = true;
            vec![Effect::Stop, Effect::Quit]
        }
        Action::JogKind => jog_update(model, JogInput::SwitchKind),
        Action::GoTo => {
            let out = GoToPrompt::open(&model.goto_context());
            show(model, out, Popup::GoTo)
        }
        Action::GoZero => {
            let out = GoToPrompt::zero(&model.goto_context());
            show(model, out, Popup::GoTo)
        }
        Action::JogOffLimit => {
            let (kp, ctx) = model.jog_parts();
            match kp.limit_question(&ctx) {
                Ok(q) => {
                    let effects = vec![Effect::Request(q.request)];
                    ask(model, &q.title, q.question, effects)
                }
                Err(text) => apply(model, Outcome::note(NoteLevel::Danger, text)),
            }
        }
        Action::FrameJob => match frame_question(model) {
            Ok(q) => {
                let mut out = Outcome::ask(&q.title, q.question, Vec::new());
                if let Some(c) = out.confirm.as_mut() {
                    c.then = Some(Then::Frame(q.plan));
                }
                apply(model, out)
            }
            Err(text) => apply(model, Outcome::note(NoteLevel::Danger, text)),
        },
        Action::ProbeZ => {
            let asked = super::probe::question(
                &mut model.probe,
                &model.setup,
                &model.keypad.values,
                &model.keypad.offsets,
            );
            match asked {
                Ok(q) => ask(
                    model,
                    &q.title,
                    q.question,
                    vec![Effect::Request(q.request)],
                ),
                Err(text) => apply(model, Outcome::note(NoteLevel::Danger, text)),
            }
        }
        Action::HomeAxis | Action::ZeroAxis => {
            let (purpose, motion) = if action == Action::HomeAxis {
                (Purpose::Home, Motion::Home)
            } else {
                (Purpose::Zero, Motion::SetZero)
            };
            if let Err(reason) = keypad::gate(&model.keypad, &model.jog_context()).check(motion) {
                let text = format!("refused: {reason}");
                return apply(model, Outcome::note(NoteLevel::Danger, text));
            }
            let axes = model.setup.axis_set();
            open(model, Popup::Axes(AxisChoice { purpose, axes }))
        }
        Action::Help => open(model, Popup::Help { scroll: 0 }),
        Action::FocusNext => cycle_focus(model, 1),
        Action::FocusPrev => cycle_focus(model, -1),
        Action::FocusConsole => {
            // The command line is typed where it can be seen.
            model.large_dro = false;
            if model.focus != PanelId::Console {
                model.before_console = model.focus;
            }
            model.focus = PanelId::Console;
            Vec::new()
        }
        Action::Initialise => vec![Effect::Request(Request::Initialise)],
        Action::Home => {
            let axes = model.setup.axis_set();
            let question = format!(
                "Axes {axes} will move to their reference switches. \
                 Keep clear of the machine. Start the reference run?"
            );
            let home = vec![Effect::Request(Request::Home { axes })];
            ask(model, "Reference run", question, home)
        }
        Action::Reset => {
            let question = "The controller stops at once and forgets its axes and reference \
                            point; initialise (i) and reference (h) again afterwards. Reset?";
            let reset = vec![Effect::Request(Request::Reset)];
            ask(model, "Reset the controller", question.to_string(), reset)
        }
        Action::TogglePolls => console_update(model, console::Input::Key(action)),
        Action::Timeline => {
            if model.focus != PanelId::Timeline {
                model.before_timeline = model.focus;
                model.focus = PanelId::Timeline;
            }
            Vec::new()
        }
        // The program editor's actions on the main screen (teach-in,
        // upload, run); actions of other modes never reach here (the
        // keymap refuses them).
        other => editor_update(model, editor::Input::Main(other)),
    }
}

fn cycle_focus(model: &mut Model, delta: isize) -> Vec<Effect> {
    let ring = model.focus_ring();
    if model.focus == PanelId::Console {
        // Tab leaves the command line for the panel it was opened from.
        model.focus = if ring.contains(&model.before_console) {
            model.before_console
        } else {
            PanelId::Jog
        };
        return Vec::new();
    }
    let len = ring.len() as isize;
    let at = ring.iter().position(|p| *p == model.focus).unwrap_or(0) as isize;
    if let Some(next) = ring.get((at + delta).rem_euclid(len.max(1)) as usize) {
        model.focus = *next;
    }
    Vec::new()
}

/// The title of the question `q` asks while something moves.
const QUIT_WHILE_MOVING: &str = "Quit while moving";

/// What `q` asks while something moves, in words; once everything stands
/// (the dead-man stopped the jog meanwhile, a reference run ended), that it
/// has stopped: the question must not go on claiming motion.
fn quit_question(model: &Model) -> String {
    let what = match typing::doing(model.machine.activity) {
        Some(what) => what,
        None if model.keypad.moving(&model.machine) => "jogging",
        None => return "The machine has stopped. Close the port and quit?".to_string(),
    };
    format!("The machine is {what}. Stop all motion, close the port and quit?")
}

/// Keep the quit question true to what the machine does now.
fn refresh_quit_question(model: &mut Model) {
    let question = quit_question(model);
    if let Some(Popup::Confirm(c)) = model.popup.as_mut()
        && c.title == QUIT_WHILE_MOVING
        && c.question != question
    {
        c.question = question;
        model.dirty = true;
    }
}

/// Ask `question` before `effects` go out: nothing goes out now.
fn ask(model: &mut Model, title: &str, question: String, effects: Vec<Effect>) -> Vec<Effect> {
    apply(model, Outcome::ask(title, question, effects))
}

fn open(model: &mut Model, popup: Popup) -> Vec<Effect> {
    model.popup = Some(popup);
    Vec::new()
}

/// A key of the open popup, taken out of the popup slot for its component
/// (whose outcome gives it back while it stays open).
fn popup_action(model: &mut Model, action: Action) -> Vec<Effect> {
    let Some(popup) = model.popup.take() else {
        return Vec::new();
    };
    match popup {
        Popup::Editor(dialog) => editor_update(model, editor::Input::Dialog(dialog, action)),
        Popup::Jog(popup) => jog_update(model, JogInput::Popup(Box::new(popup), action)),
        Popup::GoTo(prompt) => {
            let out = prompt.update(&model.goto_context(), action);
            show(model, out, Popup::GoTo)
        }
        Popup::Outputs(outputs) => {
            let out = outputs.update(&model.io, action);
            show(model, out, Popup::Outputs)
        }
        // Answers that go on to another component: the macro a question
        // starts, the work zero of the axes chosen (the keypad's).
        Popup::Confirm(c) if action == Action::Confirm => {
            let mut effects = c.effects;
            match c.then {
                Some(Then::Macro(name)) => {
                    let (run, ctx) = model.macro_parts();
                    let started = macros::start(run, &ctx, &name);
                    effects.extend(apply(model, started));
                }
                Some(Then::Frame(plan)) => {
                    let (started, level, text) =
                        super::frame::start(&mut model.frame, plan, &model.positions, None);
                    say(model, level, text);
                    effects.extend(started);
                }
                None => {}
            }
            effects
        }
        Popup::Axes(choice)
            if choice.purpose == Purpose::Zero
                && let Some(axes) = choice.chosen(action) =>
        {
            jog_update(model, JogInput::ZeroAxes(axes))
        }
        popup => {
            let ctx = popups::Context {
                rows: model.size.1,
                help_lines: help_lines(&model.keymap, &model.setup.macros).len(),
                oldest: max_back(model),
            };
            let out = popup.update(&ctx, action);
            show(model, out, |popup| popup)
        }
    }
}

fn panel_action(model: &mut Model, panel: PanelId, action: Action) -> Vec<Effect> {
    match panel {
        PanelId::Jog => Vec::new(),
        PanelId::Io => {
            let out = model.io.update(model.now, action);
            apply(model, out)
        }
        PanelId::Console => console_update(model, console::Input::Key(action)),
        PanelId::Sim => {
            let out = model.sim.as_mut().map(|s| s.update(action));
            apply(model, out.unwrap_or_default())
        }
        PanelId::Editor => editor_update(model, editor::Input::Key(action)),
        PanelId::Timeline => {
            let (w, h) = model.size;
            let ctx = timeline::Context {
                now: model.now,
                columns: lane_columns(w),
                rows: usize::from(lane_rows(w, h, model.timeline.shown().len())),
            };
            if model.timeline.update(&ctx, action) {
                model.focus = model.before_timeline;
            }
            Vec::new()
        }
    }
}

/// The console's update: `input` in its context, the outcome applied.
fn console_update(model: &mut Model, input: console::Input) -> Vec<Effect> {
    let ctx = console::Context {
        raw: model.raw_context(),
        macro_running: model.macro_run.as_ref().map(MacroRun::place),
    };
    let out = model.console.update(&ctx, input);
    apply(model, out)
}

/// What the outcome of a component without a popup asks (see [`show`]).
fn apply(model: &mut Model, outcome: Outcome) -> Vec<Effect> {
    show(model, outcome, |never| match never {})
}

/// A component's outcome applied, in one place: notes, its popup as
/// `popup` wraps it (a question in place of it), the effects.
fn show<P>(model: &mut Model, outcome: Outcome<P>, popup: impl Fn(P) -> Popup) -> Vec<Effect> {
    for (level, text) in outcome.notes {
        say(model, level, text);
    }
    if let Some(shown) = outcome.popup {
        model.popup = Some(popup(shown));
    }
    if let Some(question) = outcome.confirm {
        model.popup = Some(Popup::Confirm(question));
    }
    outcome.effects
}

/// The program editor's update: `input` in its context, the outcome
/// applied.
fn editor_update(model: &mut Model, input: editor::Input) -> Vec<Effect> {
    let outcome = editor_outcome(model, input);
    apply_editor(model, outcome)
}

/// The program editor's outcome of `input`, not applied yet.
fn editor_outcome(model: &mut Model, input: editor::Input) -> editor::Outcome {
    let (editor, context) = model.editor_parts();
    editor.update(&context, input)
}

/// Everything the editor's outcome asks of the rest of the console, in one
/// place: focus, notes, its dialog (in place of any popup), the effects in
/// order, a quit last.
fn apply_editor(model: &mut Model, outcome: editor::Outcome) -> Vec<Effect> {
    let editor::Outcome {
        effects,
        notes,
        dialog,
        focus,
        quit,
    } = outcome;
    match focus {
        Some(editor::Focus::Editor) if model.focus != PanelId::Editor => {
            model.before_editor = Some(model.focus);
            model.focus = PanelId::Editor;
        }
        Some(editor::Focus::Back) if model.focus == PanelId::Editor => {
            model.focus = model.before_editor.take().unwrap_or(PanelId::Io);
        }
        _ => {}
    }
    for note in notes {
        say(model, note.level, note.text);
    }
    if let Some(dialog) = dialog {
        model.popup = Some(Popup::Editor(dialog));
        model.dirty = true;
    }
    let mut console = Vec::with_capacity(effects.len());
    for effect in effects {
        match effect.console() {
            Ok(effect) => console.push(effect),
            Err((tool, z)) => {
                let save = model.tools.measured(&tool, z);
                console.extend(save.map(Effect::SaveOffsets));
            }
        }
    }
    let mut effects = console;
    if quit {
        model.quitting = true;
        effects.extend([Effect::Stop, Effect::Quit]);
    }
    effects
}

fn tick(model: &mut Model, now: Instant) {
    let before = (
        model.io.highlight_count(model.now),
        model.fresh_message().is_some(),
        model.keypad.clock_shown(model.now),
        job_shown(model),
    );
    model.now = now;
    let flushed = model.console.traffic.flush_idle(now);
    let after = (
        model.io.highlight_count(now),
        model.fresh_message().is_some(),
        model.keypad.clock_shown(model.now),
        job_shown(model),
    );
    // A timeline that follows the readings moves with the clock.
    let timeline_moves = model.focus == PanelId::Timeline && model.timeline.end.is_none();
    if flushed || before != after || timeline_moves {
        model.dirty = true;
    }
    refresh_quit_question(model);
}

/// The job's progress as the status line shows it now: its clocks
/// (elapsed, time left) move with the time, while a stored part runs
/// with no event from the controller.
fn job_shown(model: &Model) -> Option<String> {
    model.job_status().map(|status| status.progress)
}

fn device_event(model: &mut Model, event: Event) {
    if jog_outcome(model, JogInput::Device(&event)).quiet {
        return;
    }
    match event {
        Event::Link(state) => link_changed(model, state),
        Event::Position(sample) => model.positions.apply(&sample),
        Event::Io(snapshot) => {
            model.timeline.observe(&snapshot);
            model.io.apply(&snapshot);
        }
        Event::Input(change) => model.timeline.record(&change),
        Event::State(state) => {
            let released = model.machine.estop && !state.estop && state.link_up;
            model.machine = state;
            if released {
                estop_released(model);
            }
        }
        Event::Fault(fault) => say(model, NoteLevel::Danger, fault_text(&fault)),
        // The hold-to-run frame that held the motion says it stopped.
        Event::HoldLapsed => {}
        Event::Refused { request, reason } => {
            say(
                model,
                NoteLevel::Danger,
                format!("refused {request}: {reason}"),
            );
        }
        Event::JogEnded { id, end } => {
            if let Some(run) = model.keypad.limit.ended(id) {
                limit_jog_ended(model, &run, &end);
            } else if model.keypad.end_is_news(&end) {
                jog_ended(model, end);
            }
        }
        // The editor has said how it went (it knows which line each
        // uploaded command came from).
        Event::Upload(upload) => model.upload = Some(upload),
        Event::Traffic(record) => model.console.traffic.record(&record, model.now),
        Event::Reply { command, text, .. } => {
            // Text replies (isel `@0V`, `@0H`) come in several lines.
            let lines: Vec<&str> = text
                .lines()
                .map(|l| l.trim_end_matches('\r'))
                .filter(|l| !l.is_empty())
                .collect();
            let mut notes = lines.iter();
            let first = notes.next().copied().unwrap_or_default();
            let traffic = &mut model.console.traffic;
            traffic.note(LineKind::Reply, format!("{command} = {first}"));
            for line in notes {
                traffic.note(LineKind::Reply, format!("  {line}"));
            }
            model.message = Some(Message {
                at: model.now,
                level: NoteLevel::Info,
                text: format!("{command} = {}", lines.join(" / ")),
            });
        }
        Event::Stats(stats) => model.stats = Some(stats),
        Event::Notice(text) => say(model, NoteLevel::Info, text),
        // The editor's check-out took it (`editor::update::checkout`).
        Event::Checkout { .. } => {}
        // The touch-off took it (`ui::probe`, in `dispatch`).
        Event::ProbeEnded { .. } => {}
    }
    refresh_quit_question(model);
}

/// The emergency stop circuits are closed again: the message that said to
/// release them is out of date; say what is left to do.
fn estop_released(model: &mut Model) {
    let text = match &model.machine.fault {
        Some(f) => format!("emergency stop released: {}", f.recovery.instruction()),
        None => "emergency stop released".to_string(),
    };
    say(model, NoteLevel::Warning, text);
}

fn link_changed(model: &mut Model, state: LinkState) {
    if model.link == state {
        return;
    }
    if state == LinkState::Connected {
        model.timeline.connected(model.now);
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
    let (level, text) = match end {
        JogEnd::DeadMan => (
            NoteLevel::Warning,
            "jog stopped: key repeats stopped arriving (dead-man)".to_string(),
        ),
        JogEnd::SoftLimit => (NoteLevel::Warning, "jog stopped at the soft limit".into()),
        JogEnd::Refused(reason) => (NoteLevel::Danger, format!("jog refused: {reason}")),
        JogEnd::Fault(f) => (NoteLevel::Danger, format!("jog ended: {}", fault_text(&f))),
        JogEnd::LinkLost => (NoteLevel::Danger, "jog ended: link lost".into()),
        // The driver's notice says where it stopped and what to do.
        JogEnd::Released | JogEnd::Stopped | JogEnd::OffLimit | JogEnd::StillOnLimit => return,
    };
    say(model, level, text);
}

/// The jog off a limit switch has ended: off the switch, the reference run
/// is asked for (as `h` asks), unless another question is open.
fn limit_jog_ended(model: &mut Model, run: &keypad::limit::LimitRun, end: &JogEnd) {
    match keypad::limit::after(run, end) {
        keypad::limit::AfterEnd::Reference if model.popup.is_none() => {
            main_action(model, Action::Home);
        }
        keypad::limit::AfterEnd::Reference => {
            let axis = run.limit.axis;
            let text = format!("{axis} is off its limit switch: reference the axes (h)");
            say(model, NoteLevel::Warning, text);
        }
        keypad::limit::AfterEnd::Say { danger: true, text } => say(model, NoteLevel::Danger, text),
        keypad::limit::AfterEnd::Say { text, .. } => say(model, NoteLevel::Info, text),
    }
}

pub use super::messages::fault_text;

/// The session's work offsets start with `startup` (read from their file;
/// `None` without a state directory), and what there is to say about them
/// is said.
pub fn start_offsets(
    model: &mut Model,
    startup: Option<(
        crate::offsets::store::Startup,
        crate::offsets::store::OffsetsFile,
    )>,
) {
    if let Some((level, text)) = keypad::offsets::start(&mut model.keypad.offsets, startup) {
        say(model, level, text);
    }
}

/// The tool table starts as read from `path` (`read`; `None` without a
/// state directory); a file that cannot be read is said.
pub fn start_tools(
    model: &mut Model,
    path: Option<std::path::PathBuf>,
    read: Option<Result<crate::offsets::tools::ToolTable, String>>,
) {
    model.tools = super::tools::ToolsState::start(path, read);
    if let Some(why) = model.tools.refused() {
        say(model, NoteLevel::Danger, why);
    }
}

/// The jog screen's outcome of `input`, not applied yet.
fn jog_outcome(model: &mut Model, input: JogInput) -> keypad::component::Outcome {
    let (kp, ctx) = model.jog_parts();
    kp.update(&ctx, input)
}

/// Everything the jog screen's outcome asks of the rest of the console:
/// notes, its popup (in place of any other), the effects.
fn apply_jog(model: &mut Model, outcome: keypad::component::Outcome) -> Vec<Effect> {
    show(model, outcome.shown, Popup::Jog)
}

/// `input` to the jog screen, its outcome applied.
fn jog_update(model: &mut Model, input: JogInput) -> Vec<Effect> {
    let outcome = jog_outcome(model, input);
    apply_jog(model, outcome)
}

/// Any key, in toggle mode, stops a running jog and is used up.
fn jog_any_key(model: &mut Model, chord: KeyChord, phase: KeyPhase) -> Option<Vec<Effect>> {
    let outcome = jog_outcome(model, JogInput::AnyKey(chord, phase));
    outcome.used.then(|| apply_jog(model, outcome))
}

/// Show a message in the message line and keep it in the console.
pub(crate) fn say(model: &mut Model, level: NoteLevel, text: impl Into<String>) {
    let text = text.into();
    model
        .console
        .traffic
        .note(LineKind::Note(level), text.clone());
    let message = Message {
        at: model.now,
        level,
        text,
    };
    model.history.push(message.clone());
    model.message = Some(message);
}
