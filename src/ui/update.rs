//! `update(&mut Model, Msg) -> Vec<Effect>`: the only place the model
//! changes. Keys are routed safety first (see [`route_key`]), then to the
//! open popup, the focused panel and the main screen, gitui-style: the first
//! that consumes a key ends its journey.

use std::time::Instant;

use ratatui::crossterm::event::{KeyEvent, KeyEventKind};

use crate::device::api::{Event, Frame, JogEnd, LinkState, Request};
use crate::jog::{KeyPhase, Motion};

use super::editor;
use super::help::help_lines;
use super::io::OutputToggle;
use super::jog::axes::{AxisChoice, Purpose};
use super::jog::goto::{self, GoToPrompt};
use super::jog::{self as keypad};
use super::key::KeyChord;
use super::keymap::{Action, Mode};
use super::line_edit::LineError;
use super::macros;
use super::model::{Confirmation, Message, Model, PanelId, Popup};
use super::msg::{Effect, Msg};
use super::raw;
use super::traffic_log::{LineKind, NoteLevel};
use super::typing;

pub fn update(model: &mut Model, msg: Msg) -> Vec<Effect> {
    let effects = dispatch(model, msg);
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
            let mut effects = jog_update(model, keypad::component::Input::Tick);
            effects.extend(editor_update(model, editor::Input::Tick));
            effects
        }
        Msg::Device(event) => {
            let mut effects = editor_update(model, editor::Input::Device(&event));
            let (next, notes) = macros::device_event(&mut model.macro_run, &model.machine, &event);
            effects.extend(next);
            device_event(model, event);
            for (level, text) in notes {
                say(model, level, text);
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
            jog_update(model, keypad::component::Input::Stopped);
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
        Msg::OffsetsSaved(saved) => {
            if let Some((level, text)) = keypad::offsets::saved(&saved) {
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
        let (grace, timeout) = (
            model.keypad.settings().grace,
            model.keypad.settings().repeat_timeout,
        );
        model
            .macro_key
            .arrival(chord, KeyPhase::Release, model.now, grace, timeout, true);
        let effects = jog_update(model, keypad::component::Input::Release(chord));
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
        if self.enter_in_field {
            say(
                model,
                NoteLevel::Warning,
                "Enter came together with other keys (a paste?): nothing was sent; \
                 check the line and press Enter again"
                    .to_string(),
            );
        } else if self.keys > 0 {
            let keys = if self.keys == 1 { "key" } else { "keys" };
            say(
                model,
                NoteLevel::Warning,
                format!(
                    "burst ignored: {} {keys} came together with others (a paste?); \
                     jogterm moves only on keys typed one at a time",
                    self.keys
                ),
            );
        }
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
        let outcome = jog_outcome(model, keypad::component::Input::Burst(chord, phase));
        return outcome.used.then(|| apply_jog(model, outcome));
    }
    if let Some(effects) = jog_any_key(model, chord, phase) {
        say(model, NoteLevel::Info, "jog stopped".to_string());
        return Some(effects);
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
    let refused = match typing::text_field(model) {
        Some(typing::TextField::Editor) => {
            return editor_update(model, editor::Input::Paste(text));
        }
        Some(typing::TextField::Form) => {
            return match model.popup.take() {
                Some(Popup::Editor(dialog)) => {
                    editor_update(model, editor::Input::DialogPaste(dialog, text))
                }
                other => {
                    model.popup = other;
                    Vec::new()
                }
            };
        }
        Some(typing::TextField::CommandLine) => model.command.paste(text).err(),
        Some(typing::TextField::GoTo) => match model.popup.as_mut() {
            Some(Popup::GoTo(prompt)) => prompt.line.paste(text).err(),
            _ => None,
        },
        Some(typing::TextField::Prompt) => {
            let refused = match model.popup.as_mut() {
                Some(Popup::Jog(p)) => keypad::popups::paste(p, text),
                _ => None,
            };
            if let Some(refused) = refused {
                say(model, NoteLevel::Warning, refused);
            }
            return Vec::new();
        }
        None => {
            say(
                model,
                NoteLevel::Warning,
                "paste ignored: jogterm moves only on keys".to_string(),
            );
            return Vec::new();
        }
    };
    if let Some(refused) = refused {
        say(model, NoteLevel::Warning, refused.to_string());
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
        say(model, NoteLevel::Info, "jog stopped".to_string());
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
    if let Some(action) = model.keymap.lookup(panel_mode, &chord) {
        if panel_mode == Mode::Checkout {
            return editor_update(model, editor::Input::Checkout(action, phase));
        }
        if focus == PanelId::Jog {
            return jog_action(model, action, chord, phase);
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
        let macros::Outcome {
            effects,
            notes,
            confirm,
        } = macros::key(run, &ctx, &name);
        if let Some(confirm) = confirm {
            model.popup = Some(Popup::Confirm(confirm));
        }
        for (level, text) in notes {
            say(model, level, text);
        }
        return effects;
    }
    match model.keymap.lookup(Mode::Main, &chord) {
        Some(action) => main_action(model, action),
        None => Vec::new(),
    }
}

/// A character into the text field that has the input.
fn type_into(model: &mut Model, field: typing::TextField, c: char) -> Vec<Effect> {
    match field {
        typing::TextField::Editor => editor_update(model, editor::Input::Char(c)),
        typing::TextField::Form => editor_dialog_char(model, c),
        typing::TextField::CommandLine => {
            model.command.insert(c);
            Vec::new()
        }
        typing::TextField::GoTo => {
            if let Some(Popup::GoTo(prompt)) = model.popup.as_mut() {
                prompt.line.insert(c);
            }
            Vec::new()
        }
        typing::TextField::Prompt => {
            if let Some(Popup::Jog(p)) = model.popup.as_mut() {
                keypad::popups::type_char(p, c);
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
    say(
        model,
        NoteLevel::Info,
        format!("stop: all motion stopped (Space stops, not types, while {reason}{blank})"),
    );
    effects
}

fn stop(model: &mut Model) -> Vec<Effect> {
    jog_update(model, keypad::component::Input::Stopped);
    say(
        model,
        NoteLevel::Info,
        "stop: all motion stopped".to_string(),
    );
    if let Some((level, text)) = macros::stopped(&mut model.macro_run) {
        say(model, level, text);
    }
    let mut effects = vec![Effect::Stop];
    effects.extend(editor_update(model, editor::Input::Stopped));
    effects
}

fn main_action(model: &mut Model, action: Action) -> Vec<Effect> {
    // Work offsets, the step and speed (typed, presets, override).
    let outcome = jog_outcome(model, keypad::component::Input::Main(action));
    if outcome.used {
        return apply_jog(model, outcome);
    }
    match action {
        Action::Stop => stop(model),
        Action::Outputs => {
            if model.io.named_outputs().is_empty() {
                say(
                    model,
                    NoteLevel::Info,
                    "no named outputs: give outputs a role in the profile's [io] (spindle, \
                     coolant, clamp, vacuum, lamp; docs/profiles.md)"
                        .to_string(),
                );
            } else {
                model.popup = Some(Popup::Outputs { selected: 0 });
            }
            Vec::new()
        }
        Action::Messages => {
            model.popup = Some(Popup::Messages { back: 0 });
            Vec::new()
        }
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
                ask(
                    model,
                    QUIT_WHILE_MOVING,
                    quit_question(model),
                    vec![Effect::Stop, Effect::Quit],
                );
                return Vec::new();
            }
            model.quitting = true;
            vec![Effect::Stop, Effect::Quit]
        }
        Action::JogKind => jog_update(model, keypad::component::Input::SwitchKind),
        Action::GoTo => {
            if let Err(reason) =
                keypad::gate(&model.keypad, &model.jog_context()).check(Motion::GoTo)
            {
                say(model, NoteLevel::Danger, format!("go to refused: {reason}"));
                return Vec::new();
            }
            model.popup = Some(Popup::GoTo(GoToPrompt::default()));
            Vec::new()
        }
        Action::GoZero => {
            if let Err(reason) =
                keypad::gate(&model.keypad, &model.jog_context()).check(Motion::GoTo)
            {
                say(
                    model,
                    NoteLevel::Danger,
                    format!("go to zero refused: {reason}"),
                );
                return Vec::new();
            }
            let settings = model.keypad.settings();
            let target = goto::zero_target(settings);
            let speed = keypad::selection(&model.keypad, &model.setup).speed;
            let offsets = &model.keypad.offsets.table;
            match goto::request(&target, Frame::Work, settings, offsets, speed) {
                Ok(planned) => {
                    let axes = settings.axis_set();
                    let speed = crate::ui::position::format_amount(speed);
                    let system = offsets.active();
                    ask(
                        model,
                        "Go to the work zero",
                        format!(
                            "Axes {axes} will move to the work zero of {system} ({}) at {speed} \
                             per second. Keep clear of the machine. Go?",
                            goto::describe(&target)
                        ),
                        vec![Effect::Request(planned.request)],
                    );
                }
                Err(e) => say(model, NoteLevel::Danger, format!("go to zero refused: {e}")),
            }
            Vec::new()
        }
        Action::JogOffLimit => {
            let (kp, ctx) = model.jog_parts();
            match kp.limit_question(&ctx) {
                Ok(q) => ask(
                    model,
                    &q.title,
                    q.question,
                    vec![Effect::Request(q.request)],
                ),
                Err(text) => say(model, NoteLevel::Danger, text),
            }
            Vec::new()
        }
        Action::HomeAxis | Action::ZeroAxis => {
            let (purpose, motion) = if action == Action::HomeAxis {
                (Purpose::Home, Motion::Home)
            } else {
                (Purpose::Zero, Motion::SetZero)
            };
            if let Err(reason) = keypad::gate(&model.keypad, &model.jog_context()).check(motion) {
                say(model, NoteLevel::Danger, format!("refused: {reason}"));
                return Vec::new();
            }
            model.popup = Some(Popup::Axes(AxisChoice {
                purpose,
                axes: model.setup.axis_set(),
            }));
            Vec::new()
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
        Action::TogglePolls => {
            model.traffic.show_polls = !model.traffic.show_polls;
            Vec::new()
        }
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

fn cycle_focus(model: &mut Model, delta: isize) {
    let ring = model.focus_ring();
    if model.focus == PanelId::Console {
        // Tab leaves the command line for the panel it was opened from.
        model.focus = if ring.contains(&model.before_console) {
            model.before_console
        } else {
            PanelId::Jog
        };
        return;
    }
    let len = ring.len() as isize;
    let at = ring.iter().position(|p| *p == model.focus).unwrap_or(0) as isize;
    if let Some(next) = ring.get((at + delta).rem_euclid(len.max(1)) as usize) {
        model.focus = *next;
    }
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

fn ask(model: &mut Model, title: &str, question: String, effects: Vec<Effect>) {
    model.popup = Some(Popup::Confirm(Confirmation {
        title: title.to_string(),
        question,
        effects,
        run_macro: None,
    }));
}

fn popup_action(model: &mut Model, action: Action) -> Vec<Effect> {
    match (model.popup.take(), action) {
        (Some(Popup::Confirm(c)), Action::Confirm) => {
            let mut effects = c.effects;
            if let Some(name) = c.run_macro {
                let (run, ctx) = model.macro_parts();
                let (started, notes) = macros::start(run, &ctx, &name);
                effects.extend(started);
                for (level, text) in notes {
                    say(model, level, text);
                }
            }
            effects
        }
        (Some(Popup::Confirm(c)), Action::Cancel) => {
            say(model, NoteLevel::Info, format!("{}: cancelled", c.title));
            Vec::new()
        }
        (Some(Popup::Editor(dialog)), action) => {
            editor_update(model, editor::Input::Dialog(dialog, action))
        }
        (Some(Popup::Help { .. }), Action::Close) => Vec::new(),
        (Some(Popup::GoTo(prompt)), action) => goto_action(model, prompt, action),
        (Some(Popup::Jog(popup)), action) => jog_update(
            model,
            keypad::component::Input::Popup(Box::new(popup), action),
        ),
        (Some(Popup::Axes(choice)), Action::Cancel) => {
            say(
                model,
                NoteLevel::Info,
                format!("{}: cancelled", choice.title()),
            );
            Vec::new()
        }
        (Some(Popup::Axes(choice)), action) => match choice.chosen(action) {
            Some(axes) if choice.purpose == Purpose::Zero => {
                jog_update(model, keypad::component::Input::ZeroAxes(axes))
            }
            Some(axes) => vec![Effect::Request(choice.request(axes))],
            None => {
                say(
                    model,
                    NoteLevel::Warning,
                    format!("the machine has axes {} only", choice.axes),
                );
                model.popup = Some(Popup::Axes(choice));
                Vec::new()
            }
        },
        (Some(Popup::Outputs { selected }), action) => outputs_action(model, selected, action),
        (Some(Popup::Messages { back }), action) => {
            model.popup = messages_scroll(model, back, action).map(|back| Popup::Messages { back });
            Vec::new()
        }
        (Some(Popup::Help { scroll }), scroll_action) => {
            let page = usize::from(model.size.1.saturating_sub(6)).max(1);
            let last = help_lines(&model.keymap, &model.setup.macros)
                .len()
                .saturating_sub(1);
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

/// The named outputs popup: choose one, Enter switches it (through the
/// same toggle as the I/O panel's, asked first when hazardous); the popup
/// stays open for the next unless a question took its place.
fn outputs_action(model: &mut Model, selected: usize, action: Action) -> Vec<Effect> {
    let entries = model.io.named_outputs();
    let last = entries.len().saturating_sub(1);
    let selected = selected.min(last);
    let keep = |model: &mut Model, selected| model.popup = Some(Popup::Outputs { selected });
    match action {
        Action::Close => Vec::new(),
        Action::SelectPrev => {
            keep(model, selected.saturating_sub(1));
            Vec::new()
        }
        Action::SelectNext => {
            keep(model, (selected + 1).min(last));
            Vec::new()
        }
        Action::ToggleOutput => {
            let toggle = entries
                .get(selected)
                .ok_or_else(|| "no named outputs yet".to_string())
                .and_then(|s| model.io.toggle_at(*s));
            match toggle {
                Ok(t) => {
                    keep(model, selected);
                    toggle_output(model, t)
                }
                Err(reason) => {
                    keep(model, selected);
                    say(model, NoteLevel::Warning, reason);
                    Vec::new()
                }
            }
        }
        _ => {
            keep(model, selected);
            Vec::new()
        }
    }
}

/// The message history scrolled by `action`, `None` to close it.
fn messages_scroll(model: &Model, back: usize, action: Action) -> Option<usize> {
    let page = usize::from(model.size.1.saturating_sub(8)).max(1);
    let oldest = super::view::messages::max_back(model);
    let back = match action {
        Action::Close => return None,
        Action::ScrollUp => back + 1,
        Action::ScrollDown => back.saturating_sub(1),
        Action::PageUp => back + page,
        Action::PageDown => back.saturating_sub(page),
        Action::ScrollTop => oldest,
        Action::ScrollBottom => 0,
        _ => back,
    };
    Some(back.min(oldest))
}

/// A typed go-to prompt: editing keys, Enter checks and goes, Esc cancels.
fn goto_action(model: &mut Model, mut prompt: GoToPrompt, action: Action) -> Vec<Effect> {
    let frame = prompt.frame;
    let line = &mut prompt.line;
    match action {
        Action::Cancel => {
            say(model, NoteLevel::Info, "go to: cancelled".to_string());
            return Vec::new();
        }
        Action::ToggleFrame => {
            prompt.toggle_frame();
            model.popup = Some(Popup::GoTo(prompt));
            return Vec::new();
        }
        Action::Submit => {
            let settings = model.keypad.settings();
            let speed = keypad::selection(&model.keypad, &model.setup).speed;
            let checked = keypad::gate(&model.keypad, &model.jog_context())
                .check(Motion::GoTo)
                .map_err(|r| r.to_string())
                .and_then(|()| {
                    goto::parse(line.text(), settings)
                        .and_then(|t| {
                            goto::request(&t, frame, settings, &model.keypad.offsets.table, speed)
                                .map(|r| (t, r))
                        })
                        .map_err(|e| e.to_string())
                });
            match checked {
                Ok((target, planned)) => {
                    let frame = match planned.frame {
                        Frame::Work => {
                            format!("{} work coordinates", model.keypad.offsets.table.active())
                        }
                        Frame::Machine => "machine coordinates".to_string(),
                    };
                    let speed = crate::ui::position::format_amount(planned.speed);
                    say(
                        model,
                        NoteLevel::Info,
                        format!(
                            "go to {} ({frame}) at {speed} per second",
                            goto::describe(&target)
                        ),
                    );
                    return vec![Effect::Request(planned.request)];
                }
                Err(message) => {
                    line.error = Some(LineError {
                        message,
                        span: None,
                    });
                }
            }
        }
        other => super::line_edit::edit_line(line, other),
    }
    model.popup = Some(Popup::GoTo(prompt));
    Vec::new()
}

/// A key of the focused jog keypad.
fn jog_action(model: &mut Model, action: Action, chord: KeyChord, phase: KeyPhase) -> Vec<Effect> {
    jog_update(
        model,
        keypad::component::Input::Motion {
            action,
            chord,
            phase,
        },
    )
}

fn panel_action(model: &mut Model, panel: PanelId, action: Action) -> Vec<Effect> {
    match panel {
        PanelId::Jog => Vec::new(),
        PanelId::Io => io_action(model, action),
        PanelId::Console => console_action(model, action),
        PanelId::Sim => sim_action(model, action),
        PanelId::Editor => editor_update(model, editor::Input::Key(action)),
        PanelId::Timeline => timeline_action(model, action),
    }
}

/// A character typed while an editor form is open.
fn editor_dialog_char(model: &mut Model, c: char) -> Vec<Effect> {
    match model.popup.take() {
        Some(Popup::Editor(dialog)) => editor_update(model, editor::Input::DialogChar(dialog, c)),
        other => {
            model.popup = other;
            Vec::new()
        }
    }
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
    let mut effects: Vec<Effect> = effects.into_iter().map(Effect::from).collect();
    if quit {
        model.quitting = true;
        effects.extend([Effect::Stop, Effect::Quit]);
    }
    effects
}

/// Lanes the timeline shows at the terminal's size.
fn timeline_lanes(model: &Model) -> usize {
    let lanes = model.timeline.shown().len();
    usize::from(crate::ui::view::timeline::lane_rows(
        model.size.0,
        model.size.1,
        lanes,
    ))
}

fn timeline_action(model: &mut Model, action: Action) -> Vec<Effect> {
    // A quarter of the picture per key.
    let step = crate::ui::view::timeline::lane_columns(model.size.0) / 4;
    let shown = timeline_lanes(model);
    let (t, now) = (&mut model.timeline, model.now);
    match action {
        Action::Timeline => model.focus = model.before_timeline,
        Action::TimeEarlier => t.earlier(step, now),
        Action::TimeLater => t.later(step, now),
        Action::TimeLive => t.live(),
        Action::ZoomIn => t.zoom(-1),
        Action::ZoomOut => t.zoom(1),
        Action::ScrollUp => t.scroll(-1, shown),
        Action::ScrollDown => t.scroll(1, shown),
        _ => {}
    }
    Vec::new()
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
    if let Some(byte) = &t.byte {
        // One confirm for the whole byte: outputs cannot be read back, so
        // the other bits are written too (off), each named.
        let lines: Vec<String> = byte
            .bits
            .iter()
            .map(|b| {
                let now = match b.now {
                    None => "?",
                    Some(true) => "on",
                    Some(false) => "off",
                };
                let then = if b.then { "ON" } else { "off" };
                format!("{} {}: {now} -> {then}", b.bit, b.name)
            })
            .collect();
        ask(
            model,
            "Switch an output",
            format!(
                "Write {} = {:02X}? Outputs cannot be read back and jogterm has not written this \
                 port yet (? = unknown), so every bit is set:\n{}",
                byte.port,
                t.value,
                lines.join("\n")
            ),
            effects,
        );
        return Vec::new();
    }
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
            if let Some(run) = &model.macro_run {
                // Its answers would be taken for the macro's.
                let text = format!("not sent: {} is running (Space stops it)", run.place());
                say(model, NoteLevel::Warning, text);
                return Vec::new();
            }
            return match raw::validate(&model.raw_context(), model.command.text()) {
                Ok(checked) => {
                    model.command.accept();
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
        Action::TypeBlank => line.insert(' '),
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
        model.keypad.clock_shown(model.now),
    );
    model.now = now;
    let flushed = model.traffic.flush_idle(now);
    let after = (
        model.io.highlight_count(now),
        model.fresh_message().is_some(),
        model.keypad.clock_shown(model.now),
    );
    // A timeline that follows the readings moves with the clock.
    let timeline_moves = model.focus == PanelId::Timeline && model.timeline.end.is_none();
    if flushed || before != after || timeline_moves {
        model.dirty = true;
    }
    refresh_quit_question(model);
}

fn device_event(model: &mut Model, event: Event) {
    if jog_outcome(model, keypad::component::Input::Device(&event)).quiet {
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
        Event::Refused { request, reason } => say(
            model,
            NoteLevel::Danger,
            format!("refused {request}: {reason}"),
        ),
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
        Event::Traffic(record) => model.traffic.record(&record, model.now),
        Event::Reply { command, text, .. } => {
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
        // The editor's check-out took it (`editor::update::checkout`).
        Event::Checkout { .. } => {}
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
        // The driver's notice says where it stopped and what to do.
        JogEnd::OffLimit | JogEnd::StillOnLimit => None,
    };
    if let Some((level, text)) = note {
        say(model, level, text);
    }
}

/// The jog off a limit switch has ended: off the switch, the reference run
/// is asked for (as `h` asks), unless another question is open.
fn limit_jog_ended(model: &mut Model, run: &keypad::limit::LimitRun, end: &JogEnd) {
    match keypad::limit::after(run, end) {
        keypad::limit::AfterEnd::Reference if model.popup.is_none() => {
            main_action(model, Action::Home);
        }
        keypad::limit::AfterEnd::Reference => say(
            model,
            NoteLevel::Warning,
            format!(
                "{} is off its limit switch: reference the axes (h)",
                run.limit.axis
            ),
        ),
        keypad::limit::AfterEnd::Say { danger, text } => {
            let level = if danger {
                NoteLevel::Danger
            } else {
                NoteLevel::Info
            };
            say(model, level, text);
        }
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

/// The jog screen's outcome of `input`, not applied yet.
fn jog_outcome(model: &mut Model, input: keypad::component::Input) -> keypad::component::Outcome {
    let (kp, ctx) = model.jog_parts();
    kp.update(&ctx, input)
}

/// Everything the jog screen's outcome asks of the rest of the console, in
/// one place: notes, its popup (in place of any other), the effects.
fn apply_jog(model: &mut Model, outcome: keypad::component::Outcome) -> Vec<Effect> {
    let keypad::component::Outcome {
        effects,
        notes,
        popup,
        ..
    } = outcome;
    for (level, text) in notes {
        say(model, level, text);
    }
    if let Some(popup) = popup {
        model.popup = Some(Popup::Jog(popup));
    }
    effects
}

/// `input` to the jog screen, its outcome applied.
fn jog_update(model: &mut Model, input: keypad::component::Input) -> Vec<Effect> {
    let outcome = jog_outcome(model, input);
    apply_jog(model, outcome)
}

/// Any key, in toggle mode, stops a running jog and is used up.
fn jog_any_key(model: &mut Model, chord: KeyChord, phase: KeyPhase) -> Option<Vec<Effect>> {
    let outcome = jog_outcome(model, keypad::component::Input::AnyKey(chord, phase));
    outcome.used.then(|| apply_jog(model, outcome))
}

/// Show a message in the message line and keep it in the console.
pub(crate) fn say(model: &mut Model, level: NoteLevel, text: String) {
    model.traffic.note(LineKind::Note(level), text.clone());
    let message = Message {
        at: model.now,
        level,
        text,
    };
    model.history.push(message.clone());
    model.message = Some(message);
}
