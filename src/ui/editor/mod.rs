//! The program editor (`docs/editor.md`): isel CNC programs and EMCU jobs
//! written and fixed at the machine, taught by jogging, previewed as a
//! toolpath, uploaded and run.
//!
//! A component: [`Editor`] is its state, [`Editor::update`] takes a
//! read-only [`Context`] and an [`Input`] and returns an [`Outcome`]
//! (effects, notes, a dialog, a focus change, a quit) that `ui::update`
//! applies; the view draws from the editor and the same context
//! ([`component`], `docs/architecture.md`).
//!
//! - [`buffer`]: the text (the parsed program itself), cursor, undo/redo.
//! - [`checks`]: live lint and toolpath on a snapshot, off the UI thread.
//! - [`upload`]: an upload's progress and the line the controller refused.
//! - [`job`]: a program converted from G-code, its ways, a run in parts.
//! - [`search`], [`dialog`]: find, go to, forms and questions.
//! - [`update`]: what keys, device events and results do to the editor.
//!   Taught lines and circle lines come from `program::teach` and
//!   `program::circle`; the editor writes no command text itself.
//! - [`io`], [`worker`]: files and lint as effects, carried out on threads.
//! - [`layout`], [`highlight`], [`view`]: the program screen.
//!
//! Why no editor widget crate: the parsed program is the buffer (spans,
//! diagnostics and command indices come from it, re-parsed per edited
//! line), and every key goes through jogterm's keymap, where Space is the
//! stop key and never types. `ratatui-textarea` and `edtui` keep their own
//! text and key handling, which would have to be mirrored on every edit.

pub mod buffer;
pub mod checkout;
pub mod checks;
pub mod component;
pub mod dialog;
pub mod gcode_open;
pub mod highlight;
pub mod io;
pub mod job;
pub mod job_report;
pub mod layout;
pub mod progress;
pub mod search;
pub mod update;
pub mod upload;
pub mod view;
pub mod worker;

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::device::api::PerAxis;
use crate::program::store::{Fingerprint, Origin, Recovery, RecoveryStore};
use crate::program::{AxisLimit, Language, LintConfig};

use buffer::Buffer;
use checks::{Checks, EDITOR_BUDGET};
use upload::Upload;

use super::setup::Setup;

pub use component::{Context, Effect, Focus, Input, Note, Outcome};

/// Unsaved edits are written to the recovery file at most this often while
/// they keep changing (and within this time of the first change).
pub const AUTOSAVE_EVERY: Duration = Duration::from_secs(2);

/// What the panel beside the editor shows: the toolpath preview's planes,
/// or the job panel of a G-code job (`job_report`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Planes {
    /// XY, and XZ below it when there is room and a Z axis.
    #[default]
    Both,
    Xy,
    Xz,
    Off,
    /// The job panel (only while a G-code job is open; else as `Both`).
    Job,
}

impl Planes {
    /// The next view of the toggle key; the job panel is in the round
    /// only while there is a job to show.
    pub fn next(self, has_job: bool) -> Planes {
        match self {
            Planes::Job => Planes::Both,
            Planes::Both => Planes::Xy,
            Planes::Xy => Planes::Xz,
            Planes::Xz => Planes::Off,
            Planes::Off if has_job => Planes::Job,
            Planes::Off => Planes::Both,
        }
    }
}

/// `FileState::saved` of a text that was never saved as it is (a converted
/// G-code job, recovered edits): no buffer state ever equals it, since a
/// buffer counts its states up from 0. (The state after the next one would
/// not do: the first edit reaches it, and the edited text would pass for
/// saved.)
pub const NEVER_SAVED: u64 = u64::MAX;

/// The program file behind the buffer and what is known about saving it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FileState {
    /// Absolute; `None` for a program never saved.
    pub path: Option<PathBuf>,
    /// The buffer state last loaded or saved.
    pub saved: u64,
    /// What the file held when it was last read or written.
    pub fingerprint: Option<Fingerprint>,
    /// Bytes that were not UTF-8 were replaced when it was read.
    pub lossy: bool,
    /// A save is on its way.
    pub saving: bool,
    /// The buffer state in the recovery file, and whose file that is.
    pub recovered: Option<(u64, Origin)>,
    pub recovery_due: Option<Instant>,
    pub recovery_failed: bool,
}

/// Teach-in: the point taught last and the speed chosen.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TeachState {
    /// Machine steps of the last taught point.
    pub previous: Option<PerAxis<i64>>,
    /// Index into the profile's speed list.
    pub speed: usize,
}

#[derive(Debug, Clone)]
pub struct Editor {
    pub buffer: Buffer,
    pub file: FileState,
    pub checks: Checks,
    pub upload: Upload,
    pub teach: TeachState,
    pub planes: Planes,
    /// The last text searched for.
    pub query: Option<String>,
    /// First line and column shown (kept so the cursor stays in view).
    pub top: usize,
    pub left: usize,
    /// Recovered edits waiting to be offered.
    pub offers: VecDeque<Recovery>,
    /// Where unsaved edits are written; `None` switches that off.
    pub store: Option<RecoveryStore>,
    /// Tells this session's unsaved new programs from another's.
    pub session: String,
    /// The machine as the linter sees it (start position added per lint).
    pub lint_config: LintConfig,
    /// A program check-out under way (`checkout`).
    pub checkout: Option<checkout::Checkout>,
    /// When the stored program's run began, while it runs (its elapsed
    /// time is shown; `docs/editor.md`, "Upload and run").
    pub run_started: Option<Instant>,
    /// The running stored job was paused from here (EMCU `@A`).
    pub run_paused: bool,
    /// The toolpath of the running program (when it is the editor's text
    /// as uploaded from here) and the segment the last position read lies
    /// on: its progress.
    pub run_path: Option<Vec<crate::program::Segment>>,
    pub run_segment: Option<usize>,
    /// The G-code the text was converted from (`--program part.nc`).
    pub gcode: Option<job::Gcode>,
    /// The G-code file opened as a job, with its job panel (`gcode_open`):
    /// kept when it did not import, so that it is checked again when the
    /// work offset changes.
    pub job: Option<gcode_open::OpenJob>,
    /// A job running in parts from here (`docs/editor.md`, "G-code").
    pub chunked: Option<job::Chunked>,
    /// The outputs of the job run from here, switched off when it ends
    /// early (`docs/editor.md`, "The job's outputs").
    pub outputs: job::JobOutputs,
    /// The files opened last, newest first (`program::recent`), and the
    /// state directory that keeps them (`None`: this session only).
    pub recent: Vec<PathBuf>,
    pub recent_dir: Option<PathBuf>,
    /// The G-code job run from here is in the job log (`update::joblog`):
    /// the G-code line it runs (a stream's), told once it has run.
    pub job_logged: Option<Option<u32>>,
}

/// The unit all axes of `setup` share (`mm`), else `units`.
pub fn unit_label(setup: &Setup) -> String {
    crate::ui::position::common_unit(setup.axes.iter().map(|(_, p)| p))
        .map_or_else(|| "units".to_string(), |u| u.symbol().to_string())
}

/// The linter's view of the machine of `setup`: its axes, soft limits and
/// highest speeds (as `LintConfig::from_profile`), with the editor's budget.
pub fn lint_config(setup: &Setup) -> LintConfig {
    let mut config = LintConfig::new(setup.axis_set());
    for (axis, p) in &setup.axes {
        if let Some(slot) = config.limits.get_mut(axis.index()) {
            *slot = Some(AxisLimit {
                min: p.min_steps(),
                max: p.max_steps(),
                max_speed_hz: Some(p.speed_hz(p.max_speed)),
                unit: p.unit,
                steps_per_unit: p.steps_per_unit,
            });
        }
    }
    config.budget = EDITOR_BUDGET;
    config.capacity = setup.program_memory;
    config
}

impl Editor {
    /// An empty program in the machine's language (isel for a machine that
    /// stores none).
    pub fn new(setup: &Setup, now: Instant) -> Editor {
        let language = Language::of_protocol(setup.protocol).unwrap_or(Language::Isel);
        let buffer = Buffer::new(language, "");
        let mut checks = Checks::default();
        checks.reset(buffer.line_count(), now);
        Editor {
            file: FileState {
                saved: buffer.state(),
                ..FileState::default()
            },
            buffer,
            checks,
            upload: Upload::default(),
            teach: TeachState {
                previous: None,
                speed: setup.jog_speeds.len().saturating_sub(1),
            },
            planes: Planes::default(),
            query: None,
            top: 0,
            left: 0,
            offers: VecDeque::new(),
            store: None,
            session: "session".into(),
            lint_config: lint_config(setup),
            checkout: None,
            run_started: None,
            run_paused: false,
            run_path: None,
            run_segment: None,
            gcode: None,
            job: None,
            chunked: None,
            outputs: job::JobOutputs::default(),
            recent: Vec::new(),
            recent_dir: None,
            job_logged: None,
        }
    }

    /// Keep the files opened last in `dir`, starting from `list` (read
    /// from it at start, `program::recent::read`).
    pub fn keep_recent(&mut self, dir: PathBuf, list: Vec<PathBuf>) {
        self.recent = list;
        self.recent_dir = Some(dir);
    }

    /// Write unsaved edits to `store`; `session` tells this session's new
    /// programs from those of another (`jogterm` uses its pid and start).
    pub fn keep_recoveries(&mut self, store: RecoveryStore, session: impl Into<String>) {
        self.store = Some(store);
        self.session = session.into();
    }

    pub fn language(&self) -> Language {
        self.buffer.language()
    }

    pub fn modified(&self) -> bool {
        self.buffer.state() != self.file.saved
    }

    /// The program's name as shown: the file name, or `untitled`.
    pub fn name(&self) -> String {
        self.file
            .path
            .as_deref()
            .and_then(Path::file_name)
            .map_or_else(
                || "untitled".to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
    }

    /// Whose edits the recovery file holds.
    pub fn origin(&self) -> Origin {
        match &self.file.path {
            Some(path) => Origin::File(path.clone()),
            None => Origin::Untitled {
                tag: self.session.clone(),
            },
        }
    }

    /// The speed taught moves get, in units per second: the profile's jog
    /// speed chosen with `<`/`>`.
    pub fn teach_speed(&self, setup: &Setup) -> Option<f64> {
        setup.jog_speeds.get(self.teach.speed).copied()
    }

    /// A job of the editor that goes on moving the machine by itself, also
    /// while the axes stand between its steps (a job paused between its
    /// parts, a check-out between lines): Space stops it, never types.
    pub fn job_under_way(&self) -> Option<&'static str> {
        if self.chunked.is_some() {
            return Some("a job runs in parts");
        }
        self.checkout
            .is_some()
            .then_some("a check-out is under way")
    }

    /// Why the text cannot be changed now, if it cannot.
    pub fn read_only(&self) -> Option<&'static str> {
        if self.checkout.is_some() {
            return Some("a check-out is under way: edits wait until it ends (x)");
        }
        if self.chunked.is_some() {
            return Some("the job runs in parts: edits wait until it ends (Space stops it)");
        }
        self.upload
            .busy()
            .then_some("the program is being uploaded: edits wait until the upload ends")
    }

    /// After the buffer changed: shift what depends on line numbers and
    /// schedule the lint and the recovery file.
    pub fn after_edit(&mut self, now: Instant) {
        while let Some(change) = self.buffer.take_change() {
            self.checks.changed(change, now);
            self.upload.changed(change);
        }
        if self.modified() && self.file.recovery_due.is_none() {
            self.file.recovery_due = Some(now);
        }
    }

    /// Put a new text in the buffer (a file opened, edits recovered).
    pub fn replace(&mut self, language: Language, text: &str, now: Instant) {
        self.buffer = Buffer::new(language, text);
        self.checks.reset(self.buffer.line_count(), now);
        self.upload.clear();
        self.gcode = None;
        self.job = None;
        self.top = 0;
        self.left = 0;
        self.teach.previous = None;
    }
}
