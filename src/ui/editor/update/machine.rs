//! The editor and the machine: teach-in and the circle helper (lines from
//! `program::teach` and `program::circle`, inserted at the cursor), the
//! lint's start position, upload and run (requests to the device task), and
//! what the device's upload and state events do to the editor. The machine
//! is read from the context; requests go out as [`Effect::Device`].

use crate::device::api::{Activity, Event, PerAxis, PositionSource, ProgramState, Request};
use crate::program::circle::{self, CircleLines, TypedArc};
use crate::program::teach::{self, Machine, MoveKind, SlotContext};
use crate::program::{Language, Position, Severity, Start};
use crate::ui::editor::buffer::Cursor;
use crate::ui::editor::checks::LintJob;
use crate::ui::editor::component::Effect;
use crate::ui::editor::dialog::{Answer, Field, Form, FormKind};
use crate::ui::editor::unit_label;
use crate::ui::traffic_log::NoteLevel;

use super::Step;

// ---- teach-in ----

impl Step<'_, '_> {
    /// Where taught lines go: after the cursor's line, never after the end.
    fn insertion_point(&self) -> usize {
        teach::insertion_point(self.e.buffer.program(), self.e.buffer.cursor().line)
    }

    /// Whether the text and the machine allow teaching; says why not.
    fn teach_ready(&mut self) -> bool {
        if let Some(why) = self.e.read_only() {
            self.say(NoteLevel::Warning, why.to_string());
            return false;
        }
        if let Some(why) = self.e.language().wrong_machine(self.ctx.setup.protocol) {
            self.say(NoteLevel::Warning, format!("teach-in refused: {why}"));
            return false;
        }
        true
    }

    pub(super) fn insert_taught(&mut self, lines: Vec<String>) {
        let at = self.insertion_point();
        let shown = lines.join(" / ");
        self.edit(|b| b.insert_lines(at, lines));
        self.scroll_into_view();
        let line = self.e.buffer.cursor().line + 1;
        self.say(NoteLevel::Info, format!("taught `{shown}` (line {line})"));
    }

    pub(super) fn teach_move(&mut self, kind: MoveKind) {
        if !self.teach_ready() {
            return;
        }
        let ctx = self.ctx;
        if ctx.machine.activity != Activity::Idle {
            self.say(
                NoteLevel::Warning,
                "teach-in waits until the machine stands still".into(),
            );
            return;
        }
        // Only a measured position is taught, never an estimate.
        let mut position = PerAxis::new();
        for (axis, _) in &ctx.setup.axes {
            if let Some(r) = ctx.positions.get(*axis)
                && r.source == PositionSource::Measured
            {
                position.set(*axis, r.steps);
            }
        }
        let Some(speed) = self.e.teach_speed(ctx.setup) else {
            return;
        };
        let at = self.insertion_point();
        let machine = Machine {
            language: self.e.language(),
            axes: &ctx.setup.axes,
        };
        let slot = SlotContext::of(self.e.buffer.program(), at);
        let origin = teach::absolute_origin(machine.language, ctx.machine);
        let taught = teach::taught_move(
            &machine,
            kind,
            &position,
            &origin,
            self.e.teach.previous.as_ref(),
            speed,
            slot,
        );
        match taught {
            Ok(t) => {
                self.e.teach.previous = Some(t.point);
                self.insert_taught(t.lines);
            }
            Err(e) => self.say(NoteLevel::Warning, format!("teach-in: {e}")),
        }
    }

    pub(super) fn teach_form(&mut self, kind: FormKind) {
        if !self.teach_ready() {
            return;
        }
        let fields = match (kind, self.e.language()) {
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
        self.form(Form::new(kind, fields));
    }
}

// ---- the circle helper ----

impl Step<'_, '_> {
    pub(super) fn circle_form(&mut self) {
        if self.e.language() != Language::Isel {
            self.say(
                NoteLevel::Warning,
                "EMCU jobs have no circles (isel manual 2.3 only)".into(),
            );
            return;
        }
        let speed = self
            .e
            .teach_speed(self.ctx.setup)
            .map(crate::ui::position::format_amount);
        let unit = unit_label(self.ctx.setup);
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
        self.circle_note(&mut f);
        self.form(f);
    }

    /// The arc's lines from the form, in the plane at the insertion point.
    pub(super) fn circle_lines(&self, f: &Form) -> Result<CircleLines, String> {
        let typed = TypedArc {
            radius: f.field(0),
            start: f.field(1),
            end: f.field(2),
            direction: f.field(3),
            speed: f.field(4),
            helix: f.field(5),
        };
        let b = &self.e.buffer;
        circle::typed(b.program(), b.cursor().line, &self.ctx.setup.axes, &typed)
    }

    /// What the form will insert, or what is wrong with it (once a radius
    /// is typed).
    pub(super) fn circle_note(&self, f: &mut Form) {
        match self.circle_lines(f) {
            Ok(lines) => {
                f.note = Some(lines.note);
                f.error = None;
            }
            Err(e) => {
                f.note = None;
                f.error = (!f.field(0).trim().is_empty()).then_some(e);
            }
        }
    }
}

// ---- upload and run ----

impl Step<'_, '_> {
    /// The start of a run for the linter (known only when every axis is
    /// referenced and reported) and for the path (unknown counters as 0).
    pub(super) fn starts(&self) -> (Option<Position>, Start) {
        let ctx = self.ctx;
        let axes = ctx.setup.axis_set();
        let mut position = [0i64; 4];
        let mut known = true;
        for axis in axes.iter() {
            match ctx.positions.get(axis) {
                Some(r) => {
                    if let Some(slot) = position.get_mut(axis.index()) {
                        *slot = r.steps;
                    }
                }
                None => known = false,
            }
        }
        let referenced = axes.iter().all(|a| ctx.machine.referenced.contains(a));
        let mut zero = [0i64; 4];
        for (axis, z) in ctx.machine.work_zero.iter() {
            if let Some(slot) = zero.get_mut(axis.index()) {
                *slot = z;
            }
        }
        let lint_start = (known && referenced).then_some(position);
        (lint_start, Start::new(axes, position).with_zero(zero))
    }

    pub(super) fn lint_job(&self) -> LintJob {
        let (lint_start, start) = self.starts();
        let mut config = self.e.lint_config.clone();
        config.start = lint_start;
        // A converted job bigger than the memory runs in parts (each of
        // them fits) or as a stream: its whole text is not one stored
        // program, so the memory is no limit to it (as `jogterm run`).
        if let Some(g) = self.e.gcode.as_ref()
            && g.state == self.e.buffer.state()
            && !g.converted.program.fits()
        {
            config.capacity = Some(usize::MAX);
        }
        LintJob {
            state: self.e.buffer.state(),
            program: self.e.buffer.snapshot(),
            config,
            start,
        }
    }

    /// The linter's verdict of this very text (a pending lint runs
    /// first): the first error, with the cursor put on it, in words; `None`
    /// when there is none. Upload and check-out start only without one.
    pub(super) fn first_error(&mut self) -> Option<String> {
        let state = self.e.buffer.state();
        if !self.e.checks.fresh(state) {
            let job = self.lint_job();
            let lines = self.e.buffer.line_count();
            self.e.checks.apply_now(&job, lines, self.ctx.now);
        }
        let (span, message) = self
            .e
            .checks
            .all()
            .iter()
            .find(|d| d.severity == Severity::Error)
            .map(|d| (d.span, d.message.clone()))?;
        let (errors, _) = self.e.checks.counts();
        let text = self.e.buffer.line(span.line).to_string();
        let col = crate::ui::editor::buffer::col_of(&text, span.start);
        self.e.buffer.move_to(Cursor::new(span.line, col));
        self.scroll_into_view();
        Some(format!(
            "{errors} error{} to fix first; line {}: {message}",
            if errors == 1 { "" } else { "s" },
            span.line + 1
        ))
    }

    pub(super) fn upload(&mut self) {
        if self.e.upload.busy() {
            self.say(NoteLevel::Warning, "an upload is running already".into());
            return;
        }
        let language = self.e.language();
        if let Some(why) = language.wrong_machine(self.ctx.setup.protocol) {
            self.say(NoteLevel::Danger, format!("upload refused: {why}"));
            return;
        }
        if let Some(why) = self.first_error() {
            self.open();
            self.say(NoteLevel::Danger, format!("upload refused: {why}"));
            return;
        }
        match self.ctx.machine.program {
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
                self.ask(
                    "Upload",
                    text.into(),
                    Answer::Upload { erase: true },
                    Answer::Nothing,
                );
            }
            ProgramState::Invalid => {
                let text = match language {
                    Language::Isel => {
                        "The controller holds an invalid program (an upload failed or was \
                         stopped). Erase it and store this one?"
                    }
                    // The interface discarded the broken transfer (the bare
                    // 0x01 that ends it, `docs/protocols.md`, EMCU).
                    Language::Emcu => {
                        "The last upload failed or was stopped, so the interface holds no job. \
                         Store this one?"
                    }
                };
                self.ask(
                    "Upload",
                    text.into(),
                    Answer::Upload { erase: true },
                    Answer::Nothing,
                );
            }
            ProgramState::None | ProgramState::Unknown => self.start_upload(false),
        }
    }

    pub(super) fn start_upload(&mut self, erase: bool) {
        let program = self.e.buffer.program();
        let lines = match program.upload_lines() {
            Ok(lines) => lines,
            Err((span, e)) => {
                let text = format!("upload refused: line {}: {}", span.line + 1, e.message);
                self.say(NoteLevel::Danger, text);
                return;
            }
        };
        let lines_of: Vec<usize> = program.statements().map(|(line, _)| line).collect();
        let language = program.language();
        let state = self.e.buffer.state();
        self.e.upload.start(language, lines_of, state);
        let text = format!(
            "uploading {} commands{}",
            lines.len(),
            if erase {
                " after erasing the stored program"
            } else {
                ""
            }
        );
        self.say(NoteLevel::Info, text);
        self.out.effects.push(Effect::Device(Request::Upload {
            lines,
            erase_first: erase,
        }));
    }

    pub(super) fn run(&mut self) {
        let ctx = self.ctx;
        if self.e.chunked.is_some() {
            self.chunked_key();
            return;
        }
        if ctx.machine.activity == Activity::RunningProgram {
            self.pause_stored();
            return;
        }
        let language = self.e.language();
        if Language::of_protocol(ctx.setup.protocol).is_none() {
            self.say(
                NoteLevel::Warning,
                format!("{} controllers store no programs", ctx.setup.protocol),
            );
            return;
        }
        if self.gcode_run() {
            return;
        }
        match ctx.machine.program {
            ProgramState::None => {
                self.say(
                    NoteLevel::Warning,
                    "no program is stored: upload one first".into(),
                );
                return;
            }
            ProgramState::Invalid => {
                self.say(
                    NoteLevel::Warning,
                    "the stored program is invalid (a failed upload): upload it again".into(),
                );
                return;
            }
            ProgramState::Stored | ProgramState::Unknown => {}
        }
        let mut text = self.ways_said();
        text.push_str(
            "Start the program stored in the controller? The machine moves; Space stops it.",
        );
        let same = language.protocol() == ctx.setup.protocol
            && self.e.upload.state == Some(self.e.buffer.state());
        if !same {
            text.push_str(
                " The editor's program is not the one uploaded from here: the controller runs \
                 what it stores.",
            );
        }
        self.ask("Run the program", text, Answer::Run, Answer::Nothing);
    }

    /// A device event, before the model takes it: an upload's progress,
    /// mark and report; a stored program the erase offer waited for; a
    /// check-out line's end; a stored program's run and its progress.
    pub(super) fn device_event(&mut self, event: &Event) {
        // First: a lost link says the job's outputs before the job's own
        // handling ends it (which would switch them off, as after a stop).
        self.outputs_event(event);
        self.checkout_event(event);
        match event {
            Event::State(state) => {
                self.run_clock(state.activity);
                self.offer_erase(state.program);
            }
            Event::Position(sample) => self.run_progress(sample),
            Event::Upload(upload) => {
                // The editor knows which line each uploaded command came
                // from: its report is said instead of the device's words.
                if let Some(report) = self.e.upload.event(upload) {
                    let level = if report.danger {
                        NoteLevel::Danger
                    } else {
                        NoteLevel::Info
                    };
                    self.say(level, report.text);
                }
                self.offer_erase(self.ctx.machine.program);
            }
            _ => {}
        }
        self.chunked_event(event);
        // Last: the machine that stands lets a job's switch-offs go, said
        // after how the job ended.
        if let Event::State(s) = event {
            self.outputs_off(s.activity, s.link_up);
        }
    }

    /// `@0i` answered `G`: once the controller's state says a program is
    /// stored, offer to erase it and upload again.
    fn offer_erase(&mut self, program: ProgramState) {
        let stored = matches!(program, ProgramState::Stored | ProgramState::Invalid);
        if self.e.upload.offer_erase && stored && self.dialog_free() {
            self.e.upload.offer_erase = false;
            self.ask(
                "Upload",
                "A program is already stored in the controller, so nothing was uploaded. \
                 Erase it (@0k) and upload this one?"
                    .into(),
                Answer::Upload { erase: true },
                Answer::Nothing,
            );
        }
    }
}
