//! What keys, device events, ticks and results of the editor's effects do
//! to the editor: [`Editor::update`], the component's one entry point
//! (`component.rs`: its context, input and outcome). Pure: files and lint
//! go out as [`Effect::Io`], device requests as [`Effect::Device`]; their
//! results come back as [`Input::Msg`] and [`Input::Device`].
//!
//! - this file: the dispatch, the editor panel's keys, dialogs and forms;
//! - [`files`]: open, save, recovery files, offers of recovered edits;
//! - [`machine`]: teach-in, the circle helper, upload and run;
//! - [`job`]: the run key on a program converted from G-code, a run in parts.

mod checkout;
mod files;
mod gcode;
mod job;
mod joblog;
mod machine;
mod measure;
mod outputs;
mod pieces;
mod run;
mod stream;

use std::path::{Path, PathBuf};

use crate::device::api::Request;
use crate::program::teach::{self, Machine, MoveKind};
use crate::program::{Language, format};
use crate::ui::keymap::Action;
use crate::ui::traffic_log::NoteLevel;

use super::buffer::{Buffer, Cursor};
use super::component::{Context, Effect, Focus, Input, Note, Outcome};
use super::dialog::{Answer, Dialog, Field, Form, FormKind, Question, Then};
use super::io::EditorIo;
use super::{Editor, layout, search};

impl Editor {
    /// The component's update: `input` in the read-only `ctx`; the editor
    /// changes, everything else it wants done comes out in the
    /// [`Outcome`].
    pub fn update(&mut self, ctx: &Context, input: Input) -> Outcome {
        let mut step = Step {
            e: self,
            ctx,
            out: Outcome::default(),
        };
        match input {
            Input::Key(action) => step.action(action),
            Input::Checkout(action, phase) => step.checkout_key(action, phase),
            Input::Char(c) => step.type_char(c),
            Input::Main(action) => step.main_action(action),
            Input::Dialog(dialog, action) => step.dialog_action(dialog, action),
            Input::DialogChar(dialog, c) => step.dialog_char(dialog, c),
            Input::Paste(text) => step.paste(text),
            Input::DialogPaste(dialog, text) => step.dialog_paste(dialog, text),
            Input::Msg(msg) => step.message(msg),
            Input::Tick => step.tick(),
            Input::Device(event) => step.device_event(event),
            Input::Quit => step.before_quit(),
            Input::Terminate => step.terminate(),
            Input::Stopped => step.stopped(),
        }
        step.out
    }
}

/// One run of [`Editor::update`]: the editor, what it may read, and the
/// outcome so far.
struct Step<'s, 'c> {
    e: &'s mut Editor,
    ctx: &'s Context<'c>,
    out: Outcome,
}

// ---- what the outcome carries ----

impl Step<'_, '_> {
    /// A line for the message line and the console.
    fn say(&mut self, level: NoteLevel, text: String) {
        self.out.notes.push(Note { level, text });
    }

    fn io(&mut self, io: EditorIo) {
        self.out.effects.push(Effect::Io(io));
    }

    fn show(&mut self, dialog: Dialog) {
        self.out.dialog = Some(dialog);
    }

    fn form(&mut self, form: Form) {
        self.show(Dialog::Form(form));
    }

    fn ask(&mut self, title: &str, text: String, yes: Answer, no: Answer) {
        self.show(Dialog::Ask(Question {
            title: title.to_string(),
            text,
            yes,
            no,
        }));
    }

    /// Nothing is open that a new question would push aside.
    fn dialog_free(&self) -> bool {
        !self.ctx.popup_open && self.out.dialog.is_none()
    }

    /// Whether the program screen is shown (after this update's changes).
    fn focused(&self) -> bool {
        match self.out.focus {
            Some(Focus::Editor) => true,
            Some(Focus::Back) => false,
            None => self.ctx.focused,
        }
    }

    /// Show the program screen (the editor takes the focus).
    fn open(&mut self) {
        if !self.focused() {
            self.out.focus = (!self.ctx.focused).then_some(Focus::Editor);
        }
        self.scroll_into_view();
    }

    /// Back to the machine screen.
    fn close(&mut self) {
        if self.focused() {
            self.out.focus = self.ctx.focused.then_some(Focus::Back);
        }
    }

    fn scroll_into_view(&mut self) {
        self.e.scroll_into_view(self.ctx.size);
    }
}

// ---- main-screen actions the editor owns ----

impl Step<'_, '_> {
    /// The main screen's editor actions (teach-in, upload, run, the program
    /// screen); other actions do nothing.
    fn main_action(&mut self, action: Action) {
        match action {
            Action::EditProgram => {
                if self.focused() {
                    self.close();
                } else {
                    self.open();
                }
            }
            Action::TeachAbsolute => self.teach_move(MoveKind::Absolute),
            Action::TeachRelative => self.teach_move(MoveKind::Relative),
            Action::TeachDwell => self.teach_form(FormKind::Dwell),
            Action::TeachOutput => self.teach_form(FormKind::Output),
            Action::TeachSlower => {
                self.e.teach.speed = self.e.teach.speed.saturating_sub(1);
                self.say_teach_speed();
            }
            Action::TeachFaster => {
                let last = self.ctx.setup.jog_speeds.len().saturating_sub(1);
                self.e.teach.speed = (self.e.teach.speed + 1).min(last);
                self.say_teach_speed();
            }
            Action::Upload => self.upload(),
            Action::RunProgram => self.run(),
            _ => {}
        }
    }

    fn say_teach_speed(&mut self) {
        if let Some(speed) = self.e.teach_speed(self.ctx.setup) {
            let text = format!(
                "teach speed {} {}/s",
                crate::ui::position::format_amount(speed),
                super::unit_label(self.ctx.setup)
            );
            self.say(NoteLevel::Info, text);
        }
    }

    /// `Quit` with unsaved changes asks first.
    fn before_quit(&mut self) {
        if self.e.modified() {
            self.show(Dialog::Unsaved(Then::Quit));
        }
    }

    /// The session ends without asking (signal, hang-up): the last edits
    /// go to the recovery file now.
    fn terminate(&mut self) {
        let e = &self.e;
        let current = (e.buffer.state(), e.origin());
        if e.modified() && e.file.recovered.as_ref() != Some(&current) {
            self.recovery_write();
        }
    }
}

// ---- the editor panel's keys ----

impl Step<'_, '_> {
    /// An action of the editor panel (it has the focus).
    fn action(&mut self, action: Action) {
        let rows = layout::text_rows(self.e, self.ctx.size).max(2) as isize;
        let b = &mut self.e.buffer;
        match action {
            Action::CloseEditor => {
                self.close();
                return;
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
            Action::NewLine => self.edit(Buffer::newline),
            Action::DeleteBack => self.edit(Buffer::delete_back),
            Action::DeleteForward => self.edit(Buffer::delete_forward),
            Action::TypeBlank => self.edit(|b| b.insert_char(' ')),
            Action::DeleteLine => self.edit(Buffer::delete_line),
            Action::Undo => self.edit(|b| {
                b.undo();
            }),
            Action::Redo => self.edit(|b| {
                b.redo();
            }),
            Action::Save => self.save(None, None, false),
            Action::SaveAs => {
                let form = self.save_as_form(None);
                self.form(form);
            }
            Action::Open => {
                let value = self
                    .e
                    .file
                    .path
                    .as_deref()
                    .and_then(Path::parent)
                    .map(|d| format!("{}/", d.display()))
                    .unwrap_or_default();
                let mut form = Form::new(FormKind::Open, vec![Field::new("file", &value)]);
                if !self.e.recent.is_empty() {
                    form.note = Some(format!(
                        "Up/Down: the {} files opened last",
                        self.e.recent.len()
                    ));
                }
                self.form(form);
            }
            Action::Find => {
                let last = self.e.query.clone().unwrap_or_default();
                self.form(Form::new(FormKind::Find, vec![Field::new("find", &last)]));
            }
            Action::FindNext => self.find(true),
            Action::FindPrev => self.find(false),
            Action::GoToLine => self.form(Form::new(
                FormKind::GoTo,
                vec![Field::new("line (12) or command (#12)", "")],
            )),
            Action::NextProblem => self.problem(true),
            Action::PrevProblem => self.problem(false),
            Action::ApplyFix => self.apply_fix(),
            Action::Format => {
                let formatted = format(self.e.buffer.program());
                if formatted == self.e.buffer.text() {
                    self.say(NoteLevel::Info, "the program is formatted already".into());
                } else {
                    self.edit(|b| b.replace_all(&formatted));
                }
            }
            Action::Circle => self.circle_form(),
            Action::JumpTarget => self.jump_target(),
            Action::TogglePreview => self.e.planes = self.e.planes.next(self.e.job.is_some()),
            Action::Checkout => self.checkout_ask(false),
            Action::CheckoutFromLine => self.checkout_ask(true),
            _ => {}
        }
        self.scroll_into_view();
    }

    /// A character typed into the editor.
    fn type_char(&mut self, c: char) {
        self.edit(|b| b.insert_char(c));
        self.scroll_into_view();
    }

    /// Pasted text into the program at the cursor, one undo step.
    fn paste(&mut self, text: &str) {
        let text = crate::ui::typing::editor_text(text);
        self.edit(|b| b.insert_text(&text));
        self.scroll_into_view();
    }

    /// Change the text, unless it is being uploaded (then say why not).
    fn edit(&mut self, f: impl FnOnce(&mut Buffer)) {
        if let Some(why) = self.e.read_only() {
            self.say(NoteLevel::Warning, why.to_string());
            return;
        }
        f(&mut self.e.buffer);
        self.e.after_edit(self.ctx.now);
    }

    fn find(&mut self, forward: bool) {
        let Some(query) = self.e.query.clone() else {
            self.form(Form::new(FormKind::Find, vec![Field::new("find", "")]));
            return;
        };
        let b = &mut self.e.buffer;
        match search::find(b.program(), &query, b.cursor(), forward) {
            Some(at) => b.move_to(at),
            None => self.say(
                NoteLevel::Warning,
                format!("`{query}` is not in the program"),
            ),
        }
    }

    fn problem(&mut self, forward: bool) {
        let line = self.e.buffer.cursor().line;
        let found = self
            .e
            .checks
            .next_problem(line, forward)
            .map(|d| (d.span, d.message.clone()));
        match found {
            Some((span, message)) => {
                let text = self.e.buffer.line(span.line).to_string();
                let col = super::buffer::col_of(&text, span.start);
                self.e.buffer.move_to(Cursor::new(span.line, col));
                self.say(NoteLevel::Info, message);
            }
            None => self.say(NoteLevel::Info, "no problems found".into()),
        }
    }

    fn apply_fix(&mut self) {
        let c = self.e.buffer.cursor();
        if !self.e.checks.is_checked(c.line) {
            self.say(
                NoteLevel::Info,
                "this line is still being checked: try again in a moment".into(),
            );
            return;
        }
        let text = self.e.buffer.line(c.line).to_string();
        let byte = super::buffer::byte_of(&text, c.col);
        let fixes: Vec<_> = self
            .e
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
            Some(fix) => {
                self.edit(|b| b.replace_in_line(fix.span.line, fix.span.cols(), &fix.replacement))
            }
            None => self.say(NoteLevel::Info, "no fix is known for this line".into()),
        }
    }

    fn jump_target(&mut self) {
        let b = &self.e.buffer;
        let line = b.cursor().line;
        let target = b
            .program()
            .index_of(line)
            .and_then(|i| b.program().jump_target(i))
            .and_then(|t| b.program().line_of(t));
        match target {
            Some(l) => self.e.buffer.move_to(Cursor::new(l, 0)),
            None => self.say(
                NoteLevel::Info,
                "no jump, branch or loop on this line (or it leads out of the program)".into(),
            ),
        }
    }
}

// ---- dialogs ----

impl Step<'_, '_> {
    /// A key action while one of the editor's dialogs is open (it was taken
    /// out of the popup slot; given back unless the action closes it).
    fn dialog_action(&mut self, dialog: Dialog, action: Action) {
        match dialog {
            Dialog::Ask(q) => match action {
                Action::Confirm => self.answer(q.yes),
                Action::Cancel => self.answer(q.no),
                _ => self.show(Dialog::Ask(q)),
            },
            Dialog::Unsaved(then) => match action {
                Action::Save => self.save(None, Some(then), false),
                Action::Discard => {
                    if let Some(store) = self.e.store.clone() {
                        // The latest edits, then aside: even a wrong `d` loses nothing.
                        self.recovery_write();
                        self.io(EditorIo::DiscardRecovery {
                            store,
                            origin: self.e.origin(),
                        });
                    }
                    self.e.file.saved = self.e.buffer.state();
                    self.e.file.recovered = None;
                    self.continue_with(then);
                }
                Action::Cancel => {}
                _ => self.show(Dialog::Unsaved(then)),
            },
            Dialog::Form(mut f) => {
                match action {
                    Action::Submit => return self.submit(f),
                    Action::Cancel => return,
                    Action::NextField | Action::PrevField if f.kind == FormKind::Open => {
                        let step = if action == Action::NextField { 1 } else { -1 };
                        self.recent_in(&mut f, step);
                    }
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
                        self.form_changed(&mut f);
                    }
                }
                self.form(f);
            }
        }
    }

    /// A character typed while a dialog is open: into a form's focused
    /// field; questions take no characters.
    fn dialog_char(&mut self, dialog: Dialog, c: char) {
        let Dialog::Form(mut f) = dialog else {
            self.show(dialog);
            return;
        };
        if let Some(edit) = f.focused() {
            edit.insert(c);
        }
        self.form_changed(&mut f);
        self.form(f);
    }

    /// Text pasted while a dialog is open: into a form's focused field,
    /// which takes one line; questions take no text.
    fn dialog_paste(&mut self, dialog: Dialog, text: &str) {
        let Dialog::Form(mut f) = dialog else {
            self.show(dialog);
            return;
        };
        let refused = f.focused().and_then(|edit| edit.paste(text).err());
        self.form_changed(&mut f);
        self.form(f);
        if let Some(refused) = refused {
            self.say(NoteLevel::Warning, refused.to_string());
        }
    }

    fn form_changed(&self, f: &mut Form) {
        f.error = None;
        if f.kind == FormKind::Circle {
            self.circle_note(f);
        }
    }

    /// Up and Down in the open form: the files opened last, in turn.
    fn recent_in(&self, f: &mut Form, step: isize) {
        let Some(path) = crate::program::recent::step(&self.e.recent, f.field(0), step) else {
            f.note = Some("no files opened yet: type a path".into());
            return;
        };
        let at = self.e.recent.iter().position(|p| *p == path).unwrap_or(0);
        if let Some(edit) = f.focused() {
            edit.clear();
            path.display()
                .to_string()
                .chars()
                .for_each(|c| edit.insert(c));
        }
        f.error = None;
        f.note = Some(format!(
            "opened last {}/{} (Up/Down)",
            at + 1,
            self.e.recent.len()
        ));
    }

    fn save_as_form(&self, then: Option<Then>) -> Form {
        let value = self
            .e
            .file
            .path
            .as_deref()
            .map(|p| p.display().to_string())
            .unwrap_or_default();
        let mut f = Form::new(FormKind::SaveAs, vec![Field::new("file", &value)]);
        f.then = then;
        f
    }

    fn submit(&mut self, mut f: Form) {
        let result: Result<(), String> = match f.kind {
            FormKind::Open => {
                let path = typed_path(f.field(0));
                if path.as_os_str().is_empty() {
                    Err("name a file".into())
                } else if self.e.modified() {
                    self.show(Dialog::Unsaved(Then::Open(path)));
                    return;
                } else {
                    self.load(path);
                    Ok(())
                }
            }
            FormKind::SaveAs => {
                let path = PathBuf::from(f.field(0).trim());
                if path.as_os_str().is_empty() {
                    Err("name a file".into())
                } else {
                    let same = self.e.file.path.as_deref() == Some(path.as_path());
                    self.save(Some(path), f.then.take(), !same);
                    Ok(())
                }
            }
            FormKind::GoTo => search::go_to(self.e.buffer.program(), f.field(0)).map(|line| {
                self.e.buffer.move_to(Cursor::new(line, 0));
            }),
            FormKind::Find => {
                let query = f.field(0).to_string();
                if query.is_empty() {
                    Err("type what to find".into())
                } else {
                    self.e.query = Some(query);
                    self.find(true);
                    Ok(())
                }
            }
            FormKind::Circle => self
                .circle_lines(&f)
                .map(|circle| self.insert_taught(circle.lines)),
            FormKind::Dwell => {
                let ctx = self.ctx;
                let machine = Machine {
                    language: self.e.language(),
                    axes: &ctx.setup.axes,
                };
                teach::number(f.field(0), "time")
                    .and_then(|s| teach::dwell(&machine, s))
                    .map(|line| self.insert_taught(vec![line]))
            }
            FormKind::Output => {
                let ctx = self.ctx;
                let machine = Machine {
                    language: self.e.language(),
                    axes: &ctx.setup.axes,
                };
                let int = |i: usize, what: &str| {
                    f.field(i).trim().parse::<u32>().map_err(|_| {
                        format!("the {what} is no whole number: `{}`", f.field(i).trim())
                    })
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
                line.map(|line| self.insert_taught(vec![line]))
            }
        };
        match result {
            Ok(()) => self.scroll_into_view(),
            Err(e) => {
                f.error = Some(e);
                self.form(f);
            }
        }
    }

    fn answer(&mut self, answer: Answer) {
        match answer {
            Answer::Nothing => {}
            Answer::Upload { erase } => self.start_upload(erase),
            Answer::Run => self.out.effects.push(Effect::Device(Request::RunProgram)),
            Answer::RunInParts => self.chunked_begin(),
            Answer::RunPieces => self.pieces_begin(),
            Answer::Stream => self.stream_begin(),
            Answer::Checkout { from } => self.checkout_begin(from),
            Answer::Overwrite { path, then } => self.save_to(path, then, None, false),
            Answer::Restore(recovery) => self.restore(*recovery),
            Answer::Discard(origin) => {
                if let Some(store) = self.e.store.clone() {
                    self.io(EditorIo::DiscardRecovery { store, origin });
                }
            }
        }
    }

    fn continue_with(&mut self, then: Then) {
        match then {
            Then::Quit => self.out.quit = true,
            Then::Open(path) => self.load(path),
            Then::Restore(recovery) => self.restore(*recovery),
        }
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

#[cfg(test)]
mod tests;
