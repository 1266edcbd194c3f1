//! What keys, device events, ticks and results of the editor's effects do
//! to the model: the editor's part of `ui::update` (which calls in here).
//! Pure like the rest of `update`: files and lint go out as
//! [`Effect::Editor`], their results come back as [`Msg::Editor`].

use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use crate::device::api::{Activity, Event, PerAxis, PositionSource, ProgramState, Request};
use crate::program::store::{Origin, Recovery};
use crate::program::{Command, Language, Position, Severity, Start, format};
use crate::proto::isel::{CircleDirection, CncCommand, Plane, circle, helix};
use crate::ui::keymap::Action;
use crate::ui::model::{Model, PanelId, Popup};
use crate::ui::msg::Effect;
use crate::ui::traffic_log::NoteLevel;
use crate::ui::update::say;

use super::buffer::{Buffer, Cursor};
use super::checks::LintJob;
use super::dialog::{Answer, Dialog, Field, Form, FormKind, Question, Then};
use super::io::{EditorIo, EditorMsg, SaveFailure};
use super::teach::{self, Machine, MoveKind, SlotContext};
use super::upload::Report;
use super::{AUTOSAVE_EVERY, layout, search};

// ---- opening and closing the program screen ----

/// Show the program screen (the editor takes the focus).
pub fn open(model: &mut Model) {
    if model.focus != PanelId::Editor {
        model.editor.came_from = Some(model.focus);
        model.focus = PanelId::Editor;
    }
    scroll_into_view(model);
}

/// Back to the machine screen.
pub fn close(model: &mut Model) {
    if model.focus == PanelId::Editor {
        model.focus = model.editor.came_from.take().unwrap_or(PanelId::Io);
    }
}

// ---- main-screen actions the editor owns ----

/// The main screen's editor actions (teach-in, upload, run, the program
/// screen); `None` for other actions.
pub fn main_action(model: &mut Model, action: Action) -> Option<Vec<Effect>> {
    Some(match action {
        Action::EditProgram => {
            if model.focus == PanelId::Editor {
                close(model);
            } else {
                open(model);
            }
            Vec::new()
        }
        Action::TeachAbsolute => teach_move(model, MoveKind::Absolute),
        Action::TeachRelative => teach_move(model, MoveKind::Relative),
        Action::TeachDwell => teach_form(model, FormKind::Dwell),
        Action::TeachOutput => teach_form(model, FormKind::Output),
        Action::TeachSlower => {
            model.editor.teach.speed = model.editor.teach.speed.saturating_sub(1);
            say_teach_speed(model);
            Vec::new()
        }
        Action::TeachFaster => {
            let last = model.setup.jog_speeds.len().saturating_sub(1);
            model.editor.teach.speed = (model.editor.teach.speed + 1).min(last);
            say_teach_speed(model);
            Vec::new()
        }
        Action::Upload => upload(model),
        Action::RunProgram => run(model),
        _ => return None,
    })
}

/// The speed taught moves get, in units per second.
pub fn teach_speed(model: &Model) -> Option<f64> {
    model
        .setup
        .jog_speeds
        .get(model.editor.teach.speed)
        .copied()
}

/// The unit all axes share (`mm`), else `units`.
pub fn unit_label(model: &Model) -> String {
    crate::ui::position::common_unit(model.setup.axes.iter().map(|(_, p)| p))
        .map_or_else(|| "units".to_string(), |u| u.symbol().to_string())
}

fn say_teach_speed(model: &mut Model) {
    if let Some(speed) = teach_speed(model) {
        let text = format!(
            "teach speed {} {}/s",
            crate::ui::position::format_amount(speed),
            unit_label(model)
        );
        say(model, NoteLevel::Info, text);
    }
}

/// `Quit` with unsaved changes asks first: `Some(effects)` when it does.
pub fn before_quit(model: &mut Model) -> Option<Vec<Effect>> {
    if !model.editor.modified() {
        return None;
    }
    model.popup = Some(Popup::Editor(Dialog::Unsaved(Then::Quit)));
    Some(Vec::new())
}

/// The session ends without asking (signal, hang-up): the last edits go to
/// the recovery file now.
pub fn terminate(model: &mut Model) -> Vec<Effect> {
    let e = &model.editor;
    let current = (e.buffer.state(), e.origin());
    if e.modified() && e.file.recovered.as_ref() != Some(&current) {
        recovery_write(model).into_iter().collect()
    } else {
        Vec::new()
    }
}

// ---- the editor panel's keys ----

/// An action of the editor panel (it has the focus).
pub fn action(model: &mut Model, action: Action) -> Vec<Effect> {
    let rows = layout::text_rows(model).max(2) as isize;
    let mut effects = Vec::new();
    let b = &mut model.editor.buffer;
    match action {
        Action::CloseEditor => {
            close(model);
            return effects;
        }
        Action::CursorUp => b.vertical(-1),
        Action::CursorDown => b.vertical(1),
        Action::CursorLeft => b.left(),
        Action::CursorRight => b.right(),
        Action::CursorHome => b.home(),
        Action::CursorEnd => b.end(),
        Action::WordLeft => b.word(-1),
        Action::WordRight => b.word(1),
        Action::PageUp => b.vertical(-(rows - 1)),
        Action::PageDown => b.vertical(rows - 1),
        Action::CursorTop => b.top(),
        Action::CursorBottom => b.bottom(),
        Action::NewLine => edit(model, Buffer::newline),
        Action::DeleteBack => edit(model, Buffer::delete_back),
        Action::DeleteForward => edit(model, Buffer::delete_forward),
        Action::TypeBlank => edit(model, |b| b.insert_char(' ')),
        Action::DeleteLine => edit(model, Buffer::delete_line),
        Action::Undo => edit(model, |b| {
            b.undo();
        }),
        Action::Redo => edit(model, |b| {
            b.redo();
        }),
        Action::Save => effects = save(model, None, None, false),
        Action::SaveAs => form(model, save_as_form(model, None)),
        Action::Open => {
            let value = model
                .editor
                .file
                .path
                .as_deref()
                .and_then(Path::parent)
                .map(|d| format!("{}/", d.display()))
                .unwrap_or_default();
            form(
                model,
                Form::new(FormKind::Open, vec![Field::new("file", &value)]),
            );
        }
        Action::Find => {
            let last = model.editor.query.clone().unwrap_or_default();
            form(
                model,
                Form::new(FormKind::Find, vec![Field::new("find", &last)]),
            );
        }
        Action::FindNext => find(model, true),
        Action::FindPrev => find(model, false),
        Action::GoToLine => form(
            model,
            Form::new(
                FormKind::GoTo,
                vec![Field::new("line (12) or command (#12)", "")],
            ),
        ),
        Action::NextProblem => problem(model, true),
        Action::PrevProblem => problem(model, false),
        Action::ApplyFix => apply_fix(model),
        Action::Format => {
            let formatted = format(model.editor.buffer.program());
            if formatted == model.editor.buffer.text() {
                say(
                    model,
                    NoteLevel::Info,
                    "the program is formatted already".into(),
                );
            } else {
                edit(model, |b| b.replace_all(&formatted));
            }
        }
        Action::Circle => circle_form(model),
        Action::JumpTarget => jump_target(model),
        Action::TogglePreview => model.editor.planes = model.editor.planes.next(),
        _ => {}
    }
    scroll_into_view(model);
    effects
}

/// A character typed into the editor.
pub fn type_char(model: &mut Model, c: char) -> Vec<Effect> {
    edit(model, |b| b.insert_char(c));
    scroll_into_view(model);
    Vec::new()
}

/// Pasted text (bracketed paste), the one way a paste reaches the editor:
/// into the program at the cursor, its lines as they are (one undo step),
/// or into the open form's field, which takes one line
/// (`line_edit::one_line`).
pub fn paste(model: &mut Model, text: &str) -> Vec<Effect> {
    if let Some(Popup::Editor(Dialog::Form(mut f))) = model.popup.take() {
        let refused = f.focused().and_then(|edit| edit.paste(text).err());
        form_changed(model, &mut f);
        model.popup = Some(Popup::Editor(Dialog::Form(f)));
        if let Some(refused) = refused {
            say(model, NoteLevel::Warning, refused.to_string());
        }
        return Vec::new();
    }
    let text = crate::ui::typing::editor_text(text);
    edit(model, |b| b.insert_text(&text));
    scroll_into_view(model);
    Vec::new()
}

/// Change the text, unless it is being uploaded (then say why not).
fn edit(model: &mut Model, f: impl FnOnce(&mut Buffer)) {
    if let Some(why) = model.editor.read_only() {
        say(model, NoteLevel::Warning, why.to_string());
        return;
    }
    f(&mut model.editor.buffer);
    model.editor.after_edit(model.now);
}

/// Keep the cursor within the rows and columns shown.
pub fn scroll_into_view(model: &mut Model) {
    let rows = layout::text_rows(model).max(1);
    let cols = layout::text_cols(model).max(1);
    let c = model.editor.buffer.cursor();
    let e = &mut model.editor;
    if c.line < e.top {
        e.top = c.line;
    } else if c.line >= e.top + rows {
        e.top = c.line + 1 - rows;
    }
    // A little context to the left when scrolling sideways.
    if c.col < e.left {
        e.left = c.col.saturating_sub(cols / 4);
    } else if c.col >= e.left + cols {
        e.left = c.col + 1 - cols;
    }
}

fn form(model: &mut Model, form: Form) {
    model.popup = Some(Popup::Editor(Dialog::Form(form)));
}

fn ask(model: &mut Model, title: &str, text: String, yes: Answer, no: Answer) {
    model.popup = Some(Popup::Editor(Dialog::Ask(Question {
        title: title.to_string(),
        text,
        yes,
        no,
    })));
}

fn find(model: &mut Model, forward: bool) {
    let Some(query) = model.editor.query.clone() else {
        let form_ = Form::new(FormKind::Find, vec![Field::new("find", "")]);
        form(model, form_);
        return;
    };
    let b = &mut model.editor.buffer;
    match search::find(b.program(), &query, b.cursor(), forward) {
        Some(at) => b.move_to(at),
        None => say(
            model,
            NoteLevel::Warning,
            format!("`{query}` is not in the program"),
        ),
    }
}

fn problem(model: &mut Model, forward: bool) {
    let line = model.editor.buffer.cursor().line;
    let found = model
        .editor
        .checks
        .next_problem(line, forward)
        .map(|d| (d.span, d.message.clone()));
    match found {
        Some((span, message)) => {
            let text = model.editor.buffer.line(span.line).to_string();
            let col = super::buffer::col_of(&text, span.start);
            model.editor.buffer.move_to(Cursor::new(span.line, col));
            say(model, NoteLevel::Info, message);
        }
        None => say(model, NoteLevel::Info, "no problems found".into()),
    }
}

fn apply_fix(model: &mut Model) {
    let c = model.editor.buffer.cursor();
    if !model.editor.checks.is_checked(c.line) {
        say(
            model,
            NoteLevel::Info,
            "this line is still being checked: try again in a moment".into(),
        );
        return;
    }
    let text = model.editor.buffer.line(c.line).to_string();
    let byte = super::buffer::byte_of(&text, c.col);
    let fixes: Vec<_> = model
        .editor
        .checks
        .on_line(c.line)
        .iter()
        .filter_map(|d| d.fix.clone().map(|f| (d.span, f)))
        .collect();
    // The fix under the cursor, else the line's first.
    let chosen = fixes
        .iter()
        .find(|(span, _)| span.start <= byte && byte <= span.end)
        .or(fixes.first())
        .map(|(_, f)| f.clone());
    match chosen {
        Some(fix) => edit(model, |b| {
            b.replace_in_line(fix.span.line, fix.span.cols(), &fix.replacement)
        }),
        None => say(
            model,
            NoteLevel::Info,
            "no fix is known for this line".into(),
        ),
    }
}

fn jump_target(model: &mut Model) {
    let b = &model.editor.buffer;
    let line = b.cursor().line;
    let target = b
        .program()
        .index_of(line)
        .and_then(|i| b.program().jump_target(i))
        .and_then(|t| b.program().line_of(t));
    match target {
        Some(l) => model.editor.buffer.move_to(Cursor::new(l, 0)),
        None => say(
            model,
            NoteLevel::Info,
            "no jump, branch or loop on this line (or it leads out of the program)".into(),
        ),
    }
}

// ---- teach-in ----

/// The machine as teach-in needs it, or why it cannot teach.
fn teach_ready(model: &mut Model) -> bool {
    if let Some(why) = model.editor.read_only() {
        say(model, NoteLevel::Warning, why.to_string());
        return false;
    }
    if let Some(why) = wrong_machine(model.editor.language(), model.setup.protocol) {
        say(
            model,
            NoteLevel::Warning,
            format!("teach-in refused: {why}"),
        );
        return false;
    }
    true
}

/// Why a program in `language` cannot be taught on or stored into a
/// `protocol` controller, if it cannot.
fn wrong_machine(language: Language, protocol: crate::proto::Protocol) -> Option<String> {
    use crate::proto::Protocol;
    if language.protocol() == protocol {
        return None;
    }
    Some(match protocol {
        // The editor has no EMP language: there is nothing to store.
        Protocol::Emp => {
            "EMP drives store no programs (EMP manual: every command runs at once)".to_string()
        }
        // Both families' names take "an".
        Protocol::Isel | Protocol::Emcu => format!(
            "the program is an {language} program and the machine has an {protocol} controller"
        ),
    })
}

/// Where taught lines go: after the cursor's line, but never after the
/// program's end `9` (they would be refused as commands after the end).
fn insertion_point(model: &Model) -> usize {
    let b = &model.editor.buffer;
    let at = b.cursor().line + 1;
    let end = b.program().statements().find_map(|(line, s)| {
        matches!(&s.command, Ok(Command::Isel(CncCommand::End))).then_some(line)
    });
    end.map_or(at, |e| at.min(e))
}

fn insert_taught(model: &mut Model, lines: Vec<String>) {
    let at = insertion_point(model);
    let shown = lines.join(" / ");
    edit(model, |b| b.insert_lines(at, lines));
    scroll_into_view(model);
    let line = model.editor.buffer.cursor().line + 1;
    say(
        model,
        NoteLevel::Info,
        format!("taught `{shown}` (line {line})"),
    );
}

fn teach_move(model: &mut Model, kind: MoveKind) -> Vec<Effect> {
    if !teach_ready(model) {
        return Vec::new();
    }
    if model.machine.activity != Activity::Idle {
        say(
            model,
            NoteLevel::Warning,
            "teach-in waits until the machine stands still".into(),
        );
        return Vec::new();
    }
    let mut position = PerAxis::new();
    for (axis, _) in &model.setup.axes {
        if let Some(r) = model.positions.get(*axis)
            && r.source == PositionSource::Measured
        {
            position.set(*axis, r.steps);
        }
    }
    let Some(speed) = teach_speed(model) else {
        return Vec::new();
    };
    let at = insertion_point(model);
    let machine = Machine {
        language: model.editor.language(),
        axes: &model.setup.axes,
    };
    let slot = SlotContext::of(model.editor.buffer.program(), at);
    let origin = teach::absolute_origin(machine.language, &model.machine);
    let taught = teach::taught_move(
        &machine,
        kind,
        &position,
        &origin,
        model.editor.teach.previous.as_ref(),
        speed,
        slot,
    );
    match taught {
        Ok(t) => {
            model.editor.teach.previous = Some(t.point);
            insert_taught(model, t.lines);
        }
        Err(e) => say(model, NoteLevel::Warning, format!("teach-in: {e}")),
    }
    Vec::new()
}

fn teach_form(model: &mut Model, kind: FormKind) -> Vec<Effect> {
    if !teach_ready(model) {
        return Vec::new();
    }
    let fields = match (kind, model.editor.language()) {
        (FormKind::Dwell, _) => vec![Field::new("seconds", "1")],
        (_, Language::Isel) => vec![
            Field::new("port (0 user, 1-6, 100, 101)", "0"),
            Field::new("bit (0-7, 128 = the byte)", "0"),
            Field::new("value", "1"),
        ],
        (_, Language::Emcu) => vec![
            Field::new("output (1-2)", "1"),
            Field::new("on (1) or off (0)", "1"),
        ],
    };
    form(model, Form::new(kind, fields));
    Vec::new()
}

// ---- the circle helper ----

/// The plane circles run in at line `at`: the last `e` before it (XY
/// before any, manual 3.2.11).
fn plane_at(model: &Model, at: usize) -> Plane {
    model
        .editor
        .buffer
        .program()
        .statements()
        .take_while(|(line, _)| *line < at)
        .filter_map(|(_, s)| match &s.command {
            Ok(Command::Isel(CncCommand::SetPlane(p))) => Some(*p),
            _ => None,
        })
        .last()
        .unwrap_or_default()
}

fn circle_form(model: &mut Model) {
    if model.editor.language() != Language::Isel {
        say(
            model,
            NoteLevel::Warning,
            "EMCU jobs have no circles (isel manual 2.3 only)".into(),
        );
        return;
    }
    let speed = teach_speed(model).map(crate::ui::position::format_amount);
    let unit = unit_label(model);
    let mut f = Form::new(
        FormKind::Circle,
        vec![
            Field::new(format!("radius ({unit})"), ""),
            Field::new("start angle (°, CCW from axis 1)", "0"),
            Field::new("end angle (°, = start: full circle)", "90"),
            Field::new("direction (cw, ccw)", "ccw"),
            Field::new(format!("speed ({unit}/s)"), speed.as_deref().unwrap_or("1")),
            Field::new(format!("helix: third axis ({unit}, empty: none)"), ""),
        ],
    );
    circle_note(model, &mut f);
    form(model, f);
}

fn number(text: &str, what: &str) -> Result<f64, String> {
    text.trim()
        .replace(',', ".")
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("the {what} is no number: `{}`", text.trim()))
}

/// The arc's lines from the form, in the plane at the insertion point.
fn circle_lines(model: &Model, f: &Form) -> Result<(Vec<String>, String), String> {
    let at = insertion_point(model);
    let plane = plane_at(model, at);
    let (a1, _) = plane.axes();
    let spu = |axis| {
        model
            .setup
            .axis(axis)
            .map(|p| p.steps_per_unit)
            .ok_or_else(|| format!("the machine has no {axis} axis for the {plane:?} plane"))
    };
    let spu1 = spu(a1)?;
    let radius = number(f.field(0), "radius")? * spu1;
    let start = number(f.field(1), "start angle")?;
    let end = number(f.field(2), "end angle")?;
    let direction = match f.field(3).trim().to_ascii_lowercase().as_str() {
        "cw" => CircleDirection::Cw,
        "ccw" => CircleDirection::Ccw,
        other => return Err(format!("the direction is cw or ccw, not `{other}`")),
    };
    let speed = number(f.field(4), "speed")? * spu1;
    let radius = u32::try_from(radius.round() as i64)
        .map_err(|_| "the radius must be positive".to_string())?;
    let speed = u32::try_from(speed.round() as i64)
        .map_err(|_| "the speed must be positive".to_string())?;
    let lines: [CncCommand; 2] = if f.field(5).trim().is_empty() {
        circle(radius, start, end, direction, speed)
            .map_err(|e| e.to_string())?
            .cnc_lines()
    } else {
        let third = plane.third_axis();
        let s3 = (number(f.field(5), "helix height")? * spu(third)?).round() as i64;
        let s3 = i32::try_from(s3).map_err(|_| "the helix height is too large".to_string())?;
        helix(radius, start, end, direction, speed, s3)
            .map_err(|e| e.to_string())?
            .cnc_lines()
    };
    let text: Vec<String> = lines.iter().map(ToString::to_string).collect();
    let note = format!(
        "{:?} plane, R {radius} steps, {speed} Hz: {}",
        plane,
        text.join("  ")
    );
    Ok((text, note))
}

fn circle_note(model: &Model, f: &mut Form) {
    match circle_lines(model, f) {
        Ok((_, note)) => {
            f.note = Some(note);
            f.error = None;
        }
        Err(e) => {
            f.note = None;
            f.error = (!f.field(0).trim().is_empty()).then_some(e);
        }
    }
}

// ---- upload and run ----

/// The start of a run for the linter (known only when every axis is
/// referenced and reported) and for the path (unknown counters as 0).
fn starts(model: &Model) -> (Option<Position>, Start) {
    let axes = model.setup.axis_set();
    let mut position = [0i64; 4];
    let mut known = true;
    for axis in axes.iter() {
        match model.positions.get(axis) {
            Some(r) => {
                if let Some(slot) = position.get_mut(axis.index()) {
                    *slot = r.steps;
                }
            }
            None => known = false,
        }
    }
    let referenced = axes.iter().all(|a| model.machine.referenced.contains(a));
    let mut zero = [0i64; 4];
    for (axis, z) in model.machine.work_zero.iter() {
        if let Some(slot) = zero.get_mut(axis.index()) {
            *slot = z;
        }
    }
    let lint_start = (known && referenced).then_some(position);
    (lint_start, Start::new(axes, position).with_zero(zero))
}

fn lint_job(model: &Model) -> LintJob {
    let (lint_start, start) = starts(model);
    let mut config = model.editor.lint_config.clone();
    config.start = lint_start;
    LintJob {
        state: model.editor.buffer.state(),
        program: model.editor.buffer.snapshot(),
        config,
        start,
    }
}

fn upload(model: &mut Model) -> Vec<Effect> {
    if model.editor.upload.busy() {
        say(
            model,
            NoteLevel::Warning,
            "an upload is running already".into(),
        );
        return Vec::new();
    }
    let language = model.editor.language();
    if let Some(why) = wrong_machine(language, model.setup.protocol) {
        say(model, NoteLevel::Danger, format!("upload refused: {why}"));
        return Vec::new();
    }
    // The verdict must be of this very text.
    let state = model.editor.buffer.state();
    if !model.editor.checks.fresh(state) {
        let job = lint_job(model);
        let lines = model.editor.buffer.line_count();
        model.editor.checks.apply_now(&job, lines, model.now);
    }
    let first_error = model
        .editor
        .checks
        .all()
        .iter()
        .find(|d| d.severity == Severity::Error)
        .map(|d| (d.span, d.message.clone()));
    if let Some((span, message)) = first_error {
        let (errors, _) = model.editor.checks.counts();
        let text = model.editor.buffer.line(span.line).to_string();
        let col = super::buffer::col_of(&text, span.start);
        model.editor.buffer.move_to(Cursor::new(span.line, col));
        open(model);
        let text = format!(
            "upload refused: {errors} error{} to fix first; line {}: {message}",
            if errors == 1 { "" } else { "s" },
            span.line + 1
        );
        say(model, NoteLevel::Danger, text);
        return Vec::new();
    }
    match model.machine.program {
        ProgramState::Stored => {
            let text = match language {
                Language::Isel => {
                    "A program is stored in the controller. Erase it (@0k) and store this one?"
                }
                // `@F` replaces the stored job (decision 2).
                Language::Emcu => {
                    "A job is stored in the controller. Replace it with this one (@F)?"
                }
            };
            ask(
                model,
                "Upload",
                text.into(),
                Answer::Upload { erase: true },
                Answer::Nothing,
            );
            Vec::new()
        }
        ProgramState::Invalid => {
            let text = match language {
                Language::Isel => {
                    "The controller holds an invalid program (an upload failed or was stopped). \
                     Erase it and store this one?"
                }
                // The interface discarded the broken transfer (the bare 0x01
                // that ends it, `docs/protocols.md`, EMCU).
                Language::Emcu => {
                    "The last upload failed or was stopped, so the interface holds no job. \
                     Store this one?"
                }
            };
            ask(
                model,
                "Upload",
                text.into(),
                Answer::Upload { erase: true },
                Answer::Nothing,
            );
            Vec::new()
        }
        ProgramState::None | ProgramState::Unknown => start_upload(model, false),
    }
}

fn start_upload(model: &mut Model, erase: bool) -> Vec<Effect> {
    let program = model.editor.buffer.program();
    let lines = match program.upload_lines() {
        Ok(lines) => lines,
        Err((span, e)) => {
            let text = format!("upload refused: line {}: {}", span.line + 1, e.message);
            say(model, NoteLevel::Danger, text);
            return Vec::new();
        }
    };
    let lines_of: Vec<usize> = program.statements().map(|(line, _)| line).collect();
    let state = model.editor.buffer.state();
    model
        .editor
        .upload
        .start(program.language(), lines_of, state);
    let text = format!(
        "uploading {} commands{}",
        lines.len(),
        if erase {
            " after erasing the stored program"
        } else {
            ""
        }
    );
    say(model, NoteLevel::Info, text);
    vec![Effect::Request(Request::Upload {
        lines,
        erase_first: erase,
    })]
}

fn run(model: &mut Model) -> Vec<Effect> {
    let language = model.editor.language();
    if Language::of_protocol(model.setup.protocol).is_none() {
        say(
            model,
            NoteLevel::Warning,
            format!("{} controllers store no programs", model.setup.protocol),
        );
        return Vec::new();
    }
    match model.machine.program {
        ProgramState::None => {
            say(
                model,
                NoteLevel::Warning,
                "no program is stored: upload one first".into(),
            );
            return Vec::new();
        }
        ProgramState::Invalid => {
            say(
                model,
                NoteLevel::Warning,
                "the stored program is invalid (a failed upload): upload it again".into(),
            );
            return Vec::new();
        }
        ProgramState::Stored | ProgramState::Unknown => {}
    }
    let mut text = "Start the program stored in the controller? The machine moves; Space stops it."
        .to_string();
    let same = language.protocol() == model.setup.protocol
        && model.editor.upload.state == Some(model.editor.buffer.state());
    if !same {
        text.push_str(
            " The editor's program is not the one uploaded from here: the controller runs \
             what it stores.",
        );
    }
    ask(model, "Run the program", text, Answer::Run, Answer::Nothing);
    Vec::new()
}

/// An upload event: the editor's progress, mark and report (said by the
/// caller instead of its own words when `Some`).
pub fn upload_event(model: &mut Model, event: &crate::device::api::UploadEvent) -> Option<Report> {
    let report = model.editor.upload.event(event);
    let program = model.machine.program;
    offer_erase(model, program);
    report
}

/// A device event the editor cares about, before the model takes it.
pub fn device_event(model: &mut Model, event: &Event) {
    if let Event::State(state) = event {
        offer_erase(model, state.program);
    }
}

/// `@0i` answered `G`: once the controller's state says a program is
/// stored, offer to erase it and upload again.
fn offer_erase(model: &mut Model, program: ProgramState) {
    let stored = matches!(program, ProgramState::Stored | ProgramState::Invalid);
    if model.editor.upload.offer_erase && stored && model.popup.is_none() {
        model.editor.upload.offer_erase = false;
        ask(
            model,
            "Upload",
            "A program is already stored in the controller, so nothing was uploaded. \
             Erase it (@0k) and upload this one?"
                .into(),
            Answer::Upload { erase: true },
            Answer::Nothing,
        );
    }
}

// ---- dialogs ----

/// A key action while one of the editor's dialogs is open (it was taken
/// out of `model.popup`; put back unless the action closes it).
pub fn dialog_action(model: &mut Model, dialog: Dialog, action: Action) -> Vec<Effect> {
    match dialog {
        Dialog::Ask(q) => match action {
            Action::Confirm => answer(model, q.yes),
            Action::Cancel => answer(model, q.no),
            _ => {
                model.popup = Some(Popup::Editor(Dialog::Ask(q)));
                Vec::new()
            }
        },
        Dialog::Unsaved(then) => match action {
            Action::Save => save(model, None, Some(then), false),
            Action::Discard => {
                let mut effects: Vec<Effect> = Vec::new();
                if let Some(store) = model.editor.store.clone() {
                    // The latest edits, then aside: even a wrong `d` loses nothing.
                    effects.extend(recovery_write(model));
                    effects.push(Effect::Editor(EditorIo::DiscardRecovery {
                        store,
                        origin: model.editor.origin(),
                    }));
                }
                model.editor.file.saved = model.editor.buffer.state();
                model.editor.file.recovered = None;
                effects.extend(continue_with(model, then));
                effects
            }
            Action::Cancel => Vec::new(),
            _ => {
                model.popup = Some(Popup::Editor(Dialog::Unsaved(then)));
                Vec::new()
            }
        },
        Dialog::Form(mut f) => {
            match action {
                Action::Submit => return submit(model, f),
                Action::Cancel => return Vec::new(),
                Action::NextField => f.step(1),
                Action::PrevField => f.step(-1),
                other => {
                    if let Some(edit) = f.focused() {
                        match other {
                            Action::CursorLeft => edit.left(),
                            Action::CursorRight => edit.right(),
                            Action::CursorHome => edit.home(),
                            Action::CursorEnd => edit.end(),
                            Action::DeleteBack => edit.delete_back(),
                            Action::DeleteForward => edit.delete_forward(),
                            Action::ClearLine => edit.clear(),
                            Action::TypeBlank => edit.insert(' '),
                            _ => {}
                        }
                    }
                    form_changed(model, &mut f);
                }
            }
            model.popup = Some(Popup::Editor(Dialog::Form(f)));
            Vec::new()
        }
    }
}

/// A character typed into a form.
pub fn form_char(model: &mut Model, c: char) -> Vec<Effect> {
    if let Some(Popup::Editor(Dialog::Form(mut f))) = model.popup.take() {
        if let Some(edit) = f.focused() {
            edit.insert(c);
        }
        form_changed(model, &mut f);
        model.popup = Some(Popup::Editor(Dialog::Form(f)));
    }
    Vec::new()
}

fn form_changed(model: &Model, f: &mut Form) {
    f.error = None;
    if f.kind == FormKind::Circle {
        circle_note(model, f);
    }
}

fn save_as_form(model: &Model, then: Option<Then>) -> Form {
    let value = model
        .editor
        .file
        .path
        .as_deref()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    let mut f = Form::new(FormKind::SaveAs, vec![Field::new("file", &value)]);
    f.then = then;
    f
}

fn submit(model: &mut Model, mut f: Form) -> Vec<Effect> {
    let result: Result<Vec<Effect>, String> = match f.kind {
        FormKind::Open => {
            let path = typed_path(f.field(0));
            if path.as_os_str().is_empty() {
                Err("name a file".into())
            } else if model.editor.modified() {
                model.popup = Some(Popup::Editor(Dialog::Unsaved(Then::Open(path))));
                return Vec::new();
            } else {
                Ok(load(model, path))
            }
        }
        FormKind::SaveAs => {
            let path = PathBuf::from(f.field(0).trim());
            if path.as_os_str().is_empty() {
                Err("name a file".into())
            } else {
                let same = model.editor.file.path.as_deref() == Some(path.as_path());
                Ok(save(model, Some(path), f.then.take(), !same))
            }
        }
        FormKind::GoTo => search::go_to(model.editor.buffer.program(), f.field(0)).map(|line| {
            model.editor.buffer.move_to(Cursor::new(line, 0));
            Vec::new()
        }),
        FormKind::Find => {
            let query = f.field(0).to_string();
            if query.is_empty() {
                Err("type what to find".into())
            } else {
                model.editor.query = Some(query);
                find(model, true);
                Ok(Vec::new())
            }
        }
        FormKind::Circle => circle_lines(model, &f).map(|(lines, _)| {
            insert_taught(model, lines);
            Vec::new()
        }),
        FormKind::Dwell => {
            let machine = Machine {
                language: model.editor.language(),
                axes: &model.setup.axes,
            };
            number(f.field(0), "time")
                .and_then(|s| teach::dwell(&machine, s))
                .map(|line| {
                    insert_taught(model, vec![line]);
                    Vec::new()
                })
        }
        FormKind::Output => {
            let machine = Machine {
                language: model.editor.language(),
                axes: &model.setup.axes,
            };
            let int = |i: usize, what: &str| {
                f.field(i)
                    .trim()
                    .parse::<u32>()
                    .map_err(|_| format!("the {what} is no whole number: `{}`", f.field(i).trim()))
            };
            let line = match machine.language {
                Language::Isel => int(0, "port").and_then(|p| {
                    let bit = int(1, "bit")?;
                    let value = int(2, "value")?;
                    teach::output(&machine, p, bit, value)
                }),
                Language::Emcu => int(0, "output").and_then(|o| {
                    let value = int(1, "value")?;
                    teach::output(&machine, o, 0, value)
                }),
            };
            line.map(|line| {
                insert_taught(model, vec![line]);
                Vec::new()
            })
        }
    };
    match result {
        Ok(effects) => {
            scroll_into_view(model);
            effects
        }
        Err(e) => {
            f.error = Some(e);
            model.popup = Some(Popup::Editor(Dialog::Form(f)));
            Vec::new()
        }
    }
}

fn answer(model: &mut Model, answer: Answer) -> Vec<Effect> {
    match answer {
        Answer::Nothing => Vec::new(),
        Answer::Upload { erase } => start_upload(model, erase),
        Answer::Run => vec![Effect::Request(Request::RunProgram)],
        Answer::Overwrite { path, then } => save_to(model, path, then, None, false),
        Answer::Restore(recovery) => restore(model, *recovery),
        Answer::Discard(origin) => match model.editor.store.clone() {
            Some(store) => vec![Effect::Editor(EditorIo::DiscardRecovery { store, origin })],
            None => Vec::new(),
        },
    }
}

/// The path typed into the open form. The form starts with the folder of
/// the file open now; an absolute path typed after it (`/work//tmp/a.isel`)
/// starts again at the root, as in Emacs' file prompts, instead of being
/// looked for inside that folder.
fn typed_path(text: &str) -> PathBuf {
    let text = text.trim();
    let from = text.rfind("//").map_or(0, |i| i + 1);
    PathBuf::from(&text[from..])
}

fn continue_with(model: &mut Model, then: Then) -> Vec<Effect> {
    match then {
        Then::Quit => {
            model.quitting = true;
            vec![Effect::Stop, Effect::Quit]
        }
        Then::Open(path) => load(model, path),
        Then::Restore(recovery) => restore(model, *recovery),
    }
}

// ---- files ----

fn load(model: &mut Model, path: PathBuf) -> Vec<Effect> {
    vec![Effect::Editor(EditorIo::Load {
        path,
        store: model.editor.store.clone(),
    })]
}

/// Save to `path` (else the file's own path; an untitled program asks for
/// one), then `then`. `fresh`: `path` is a new name.
fn save(model: &mut Model, path: Option<PathBuf>, then: Option<Then>, fresh: bool) -> Vec<Effect> {
    let Some(path) = path.or_else(|| model.editor.file.path.clone()) else {
        let f = save_as_form(model, then);
        form(model, f);
        return Vec::new();
    };
    if model.editor.file.lossy {
        ask(
            model,
            "Save",
            format!(
                "{} held bytes that are not UTF-8; they show as \u{fffd} and would be saved so. \
                 Save anyway?",
                path.display()
            ),
            Answer::Overwrite { path, then },
            Answer::Nothing,
        );
        return Vec::new();
    }
    let same = model.editor.file.path.as_deref() == Some(path.as_path());
    let expect = if same {
        model.editor.file.fingerprint
    } else {
        None
    };
    save_to(model, path, then, expect, fresh)
}

fn save_to(
    model: &mut Model,
    path: PathBuf,
    then: Option<Then>,
    expect: Option<crate::program::store::Fingerprint>,
    fresh: bool,
) -> Vec<Effect> {
    model.editor.file.saving = true;
    vec![Effect::Editor(EditorIo::Save {
        path,
        text: model.editor.buffer.text(),
        state: model.editor.buffer.state(),
        expect,
        fresh,
        then,
    })]
}

/// The recovery file write for the edits as they are now.
fn recovery_write(model: &mut Model) -> Option<Effect> {
    let e = &model.editor;
    let store = e.store.clone()?;
    let recovery = Recovery {
        origin: e.origin(),
        language: e.language(),
        // Stamped by the worker.
        written: UNIX_EPOCH,
        base: e.file.fingerprint,
        text: e.buffer.text(),
    };
    Some(Effect::Editor(EditorIo::WriteRecovery {
        store,
        recovery,
        state: e.buffer.state(),
    }))
}

fn restore(model: &mut Model, recovery: Recovery) -> Vec<Effect> {
    let same_origin = recovery.origin == model.editor.origin();
    if model.editor.modified() && !same_origin {
        model.popup = Some(Popup::Editor(Dialog::Unsaved(Then::Restore(Box::new(
            recovery,
        )))));
        return Vec::new();
    }
    let now = model.now;
    let e = &mut model.editor;
    e.replace(recovery.language, &recovery.text, now);
    e.file = super::FileState {
        path: match &recovery.origin {
            Origin::File(path) => Some(path.clone()),
            Origin::Untitled { .. } => None,
        },
        // Never saved as it is now.
        saved: u64::MAX,
        fingerprint: recovery.base,
        ..super::FileState::default()
    };
    open(model);
    let text = format!(
        "recovered edits of {} opened: save them (Ctrl-S) to keep them in the file",
        recovery.origin.describe()
    );
    say(model, NoteLevel::Info, text);
    // Kept under this session's name at once, then the old file goes.
    let mut effects: Vec<Effect> = recovery_write(model).into_iter().collect();
    if let (Some(store), false) = (
        model.editor.store.clone(),
        recovery.origin == model.editor.origin(),
    ) {
        effects.push(Effect::Editor(EditorIo::RemoveRecovery {
            store,
            origin: recovery.origin,
        }));
    }
    effects
}

/// Show the next recovered program on offer, when nothing else is open.
fn offer_next(model: &mut Model) {
    if model.popup.is_some() {
        return;
    }
    let Some(recovery) = model.editor.offers.pop_front() else {
        return;
    };
    let lines = recovery.text.lines().count();
    let text = format!(
        "Unsaved edits of {} ({lines} lines, written {}) were kept when jogterm last ended. \
         Open them in the editor? No puts them aside (….discarded).",
        recovery.origin.describe(),
        utc(recovery.written)
    );
    let origin = recovery.origin.clone();
    model.dirty = true;
    ask(
        model,
        "Recovered edits",
        text,
        Answer::Restore(Box::new(recovery)),
        Answer::Discard(origin),
    );
}

/// `2026-11-22 14:02 UTC`.
pub fn utc(time: SystemTime) -> String {
    let secs = time.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    // Civil from days (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02} UTC",
        rem / 3600,
        rem % 3600 / 60
    )
}

// ---- messages and ticks ----

/// A result of the editor's effects, or a request from outside.
pub fn message(model: &mut Model, msg: EditorMsg) -> Vec<Effect> {
    let now = model.now;
    match msg {
        EditorMsg::Open(path) => {
            open(model);
            load(model, path)
        }
        EditorMsg::Scan => match model.editor.store.clone() {
            Some(store) => vec![Effect::Editor(EditorIo::ScanRecoveries { store })],
            None => Vec::new(),
        },
        EditorMsg::Loaded {
            path,
            result,
            recovery,
        } => loaded(model, path, result, recovery),
        EditorMsg::Saved {
            path,
            state,
            result,
            then,
        } => saved(model, path, state, result, then),
        EditorMsg::RecoveryWritten {
            state,
            origin,
            result,
        } => {
            match result {
                Ok(()) => {
                    model.editor.file.recovered = Some((state, origin));
                    model.editor.file.recovery_failed = false;
                }
                Err(e) => {
                    if !model.editor.file.recovery_failed {
                        say(
                            model,
                            NoteLevel::Warning,
                            format!("unsaved edits cannot be kept in a recovery file: {e}"),
                        );
                    }
                    model.editor.file.recovery_failed = true;
                }
            }
            Vec::new()
        }
        EditorMsg::RecoveryGone { result } => {
            if let Err(e) = result {
                say(model, NoteLevel::Warning, format!("recovery file: {e}"));
            }
            Vec::new()
        }
        EditorMsg::Recoveries(found) => {
            let own = model.editor.origin();
            for r in found {
                match r {
                    Ok(rec) if rec.origin == own => {}
                    Ok(rec) => {
                        if !model.editor.offers.iter().any(|o| o.origin == rec.origin) {
                            model.editor.offers.push_back(rec);
                        }
                    }
                    Err(e) => say(
                        model,
                        NoteLevel::Warning,
                        format!("a recovery file is unreadable: {e}"),
                    ),
                }
            }
            offer_next(model);
            Vec::new()
        }
        EditorMsg::Linted(result) => {
            let state = model.editor.buffer.state();
            let lines = model.editor.buffer.line_count();
            model.editor.checks.finished(*result, state, lines, now);
            Vec::new()
        }
    }
}

fn loaded(
    model: &mut Model,
    path: PathBuf,
    result: Result<Option<crate::program::store::Loaded>, String>,
    recovery: Option<Recovery>,
) -> Vec<Effect> {
    let now = model.now;
    let language = Language::from_path(&path).unwrap_or_else(|| model.editor.language());
    let name = path.display().to_string();
    let text = match result {
        Err(e) => {
            say(model, NoteLevel::Danger, format!("cannot open: {e}"));
            return Vec::new();
        }
        Ok(Some(l)) => {
            model.editor.replace(language, &l.text, now);
            model.editor.file = super::FileState {
                path: Some(l.path),
                saved: model.editor.buffer.state(),
                fingerprint: Some(l.fingerprint),
                lossy: l.lossy,
                ..super::FileState::default()
            };
            if l.lossy {
                say(
                    model,
                    NoteLevel::Warning,
                    format!("{name}: bytes that are not UTF-8 are shown as \u{fffd}"),
                );
            } else {
                let lines = model.editor.buffer.line_count();
                say(
                    model,
                    NoteLevel::Info,
                    format!("opened {name} ({lines} lines, {language})"),
                );
            }
            l.text
        }
        Ok(None) => {
            model.editor.replace(language, "", now);
            model.editor.file = super::FileState {
                path: Some(path),
                saved: model.editor.buffer.state(),
                ..super::FileState::default()
            };
            // A warning, not news: a mistyped name also ends here.
            say(
                model,
                NoteLevel::Warning,
                format!(
                    "{name} does not exist: a new, empty {language} program, written when you save"
                ),
            );
            String::new()
        }
    };
    let Some(rec) = recovery else {
        return Vec::new();
    };
    if rec.text != text {
        model.editor.offers.retain(|o| o.origin != rec.origin);
        model.editor.offers.push_front(rec);
        offer_next(model);
        return Vec::new();
    }
    // The file holds what the recovery does: nothing to recover.
    match model.editor.store.clone() {
        Some(store) => vec![Effect::Editor(EditorIo::RemoveRecovery {
            store,
            origin: rec.origin,
        })],
        None => Vec::new(),
    }
}

fn saved(
    model: &mut Model,
    path: PathBuf,
    state: u64,
    result: Result<crate::program::store::Fingerprint, SaveFailure>,
    then: Option<Then>,
) -> Vec<Effect> {
    model.editor.file.saving = false;
    let name = path.display().to_string();
    match result {
        Ok(fingerprint) => {
            let old_origin = model.editor.origin();
            let f = &mut model.editor.file;
            f.path = Some(path);
            f.saved = state;
            f.fingerprint = Some(fingerprint);
            f.lossy = false;
            let mut effects = Vec::new();
            // A recovery under another name (untitled, or the old file of a
            // save-as) is not needed any more.
            if let Some(store) = model.editor.store.clone()
                && old_origin != model.editor.origin()
            {
                effects.push(Effect::Editor(EditorIo::RemoveRecovery {
                    store,
                    origin: old_origin,
                }));
            }
            // Saved as it stands: its recovery goes now, not at the next
            // tick (a quit may follow at once).
            if !model.editor.modified()
                && let Some(store) = model.editor.store.clone()
                && let Some((_, origin)) = model.editor.file.recovered.take()
            {
                model.editor.file.recovery_due = None;
                effects.push(Effect::Editor(EditorIo::RemoveRecovery { store, origin }));
            }
            let lines = model.editor.buffer.line_count();
            say(
                model,
                NoteLevel::Info,
                format!("saved {name} ({lines} lines)"),
            );
            if let Some(then) = then {
                effects.extend(continue_with(model, then));
            }
            effects
        }
        Err(SaveFailure::Changed) => {
            ask(
                model,
                "Save",
                format!(
                    "{name} changed on disk since it was opened. Overwrite it with the editor's \
                     program?"
                ),
                Answer::Overwrite { path, then },
                Answer::Nothing,
            );
            Vec::new()
        }
        Err(SaveFailure::Exists) => {
            ask(
                model,
                "Save as",
                format!("{name} exists. Replace it?"),
                Answer::Overwrite { path, then },
                Answer::Nothing,
            );
            Vec::new()
        }
        Err(SaveFailure::Failed(e)) => {
            say(
                model,
                NoteLevel::Danger,
                format!("not saved: {e}; the edits stay in the editor and the recovery file"),
            );
            Vec::new()
        }
    }
}

/// Time passes: start the lint when it is due, keep the recovery file up to
/// date, offer recovered edits.
pub fn tick(model: &mut Model, now: Instant) -> Vec<Effect> {
    let mut effects = Vec::new();
    let (_, start) = starts(model);
    model.editor.checks.start_moved(start, now);
    if model.editor.checks.wants_lint(now) {
        let job = lint_job(model);
        model.editor.checks.started(job.state, job.start, now);
        effects.push(Effect::Editor(EditorIo::Lint(Box::new(job))));
    }
    effects.extend(keep_recovery(model, now));
    offer_next(model);
    effects
}

fn keep_recovery(model: &mut Model, now: Instant) -> Option<Effect> {
    let store = model.editor.store.clone()?;
    let state = model.editor.buffer.state();
    let origin = model.editor.origin();
    let modified = model.editor.modified();
    let f = &mut model.editor.file;
    if !modified {
        // Saved, or undone back to the file: no recovery is needed.
        f.recovery_due = None;
        let (_, gone) = f.recovered.take()?;
        return Some(Effect::Editor(EditorIo::RemoveRecovery {
            store,
            origin: gone,
        }));
    }
    if f.recovered.as_ref() == Some(&(state, origin)) {
        f.recovery_due = None;
        return None;
    }
    let due = f.recovery_due.unwrap_or(now);
    if now < due || f.saving {
        return None;
    }
    f.recovery_due = Some(now + AUTOSAVE_EVERY);
    recovery_write(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_times_read_like_a_calendar() {
        let t = UNIX_EPOCH + std::time::Duration::from_secs(1_763_820_120);
        assert_eq!(utc(t), "2025-11-22 14:02 UTC");
        assert_eq!(utc(UNIX_EPOCH), "1970-01-01 00:00 UTC");
        let leap = UNIX_EPOCH + std::time::Duration::from_secs(951_782_400);
        assert_eq!(utc(leap), "2000-02-29 00:00 UTC");
    }
}
