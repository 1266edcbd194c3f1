//! A G-code file opened as a job (issue 40, `gcode_open`): imported on
//! the worker with the console's work offsets, its job panel kept, and
//! checked again whenever the work offsets change, so that setting the
//! zero in the console (`O`, `s`, a probe) is all a job outside the soft
//! limits needs.

use std::path::PathBuf;
use std::sync::Arc;

use crate::device::api::Activity;
use crate::gcode::HeightMapFile;
use crate::ui::editor::gcode_open::{GcodeChecked, GcodeJob, OpenJob};
use crate::ui::editor::io::EditorIo;
use crate::ui::editor::job::Gcode;
use crate::ui::editor::{FileState, NEVER_SAVED, Planes};
use crate::ui::traffic_log::NoteLevel;

use super::Step;

impl Step<'_, '_> {
    /// Import `path` for the session's profile and work offsets.
    pub(super) fn open_gcode(&mut self, path: PathBuf, height_map: Option<Arc<HeightMapFile>>) {
        self.say(NoteLevel::Info, format!("importing {} …", path.display()));
        self.io(EditorIo::ImportGcode(Box::new(GcodeJob {
            path,
            source: None,
            profile: Arc::clone(&self.ctx.setup.profile),
            offsets: self.ctx.offsets.clone(),
            tool: self.ctx.tools.active(),
            height_map,
            now_unix: 0,
        })));
    }

    /// From the tick: the work offsets are not the ones the open job was
    /// checked with: check it again, unless something of it runs (a job
    /// under way keeps the program it started with).
    pub(super) fn recheck_gcode(&mut self) {
        let busy = self.e.job_under_way().is_some()
            || self.e.upload.busy()
            || self.ctx.machine.activity != Activity::Idle;
        let Some(job) = self.e.job.as_mut() else {
            return;
        };
        // Compared in place: this runs on every tick.
        let same_tool = self.ctx.tools.is_active(job.tool.as_ref());
        if job.checking || busy || (job.offsets == *self.ctx.offsets && same_tool) {
            return;
        }
        let tool = self.ctx.tools.active();
        job.checking = true;
        let request = GcodeJob {
            path: job.path.clone(),
            source: Some(Arc::clone(&job.source)),
            profile: Arc::clone(&self.ctx.setup.profile),
            offsets: self.ctx.offsets.clone(),
            tool,
            height_map: job.height_map.clone(),
            now_unix: 0,
        };
        self.io(EditorIo::ImportGcode(Box::new(request)));
    }

    pub(super) fn gcode_checked(&mut self, checked: GcodeChecked) {
        let now = self.ctx.now;
        let GcodeChecked {
            job,
            unreadable,
            report,
            opened,
            notes,
        } = checked;
        let again =
            self.e.job.as_ref().is_some_and(|open| {
                open.path == job.path && Some(&open.source) == job.source.as_ref()
            });
        if let Some(open) = self.e.job.as_mut().filter(|_| again) {
            open.checking = false;
        }
        let (Some(report), Some(source)) = (report, job.source.clone()) else {
            let why = unreadable.unwrap_or_else(|| format!("{}: not read", job.path.display()));
            self.say(NoteLevel::Danger, format!("cannot open: {why}"));
            return;
        };
        // A check again replaces the converted text only where the
        // operator has not edited it since it was converted.
        let untouched = match self.e.gcode.as_ref() {
            Some(g) => g.state == self.e.buffer.state(),
            None => !self.e.modified() || self.e.buffer.text().trim().is_empty(),
        };
        let errors = report.errors.len();
        if again {
            let system = job.offsets.active().to_string();
            // What was checked for: the new zero, or the tool in the spindle
            // (measured or touched off since).
            let offsets_changed = self
                .e
                .job
                .as_ref()
                .is_none_or(|open| open.offsets != job.offsets);
            let changed = if offsets_changed {
                "the work offset changed".to_owned()
            } else {
                match &job.tool {
                    Some(t) => format!(
                        "the tool in the spindle changed ({} {:+.3} mm)",
                        t.tool, t.offset_mm
                    ),
                    None => "the tool offset was reset".to_owned(),
                }
            };
            if let Some(open) = self.e.job.as_mut() {
                open.offsets = job.offsets.clone();
                open.tool = job.tool.clone();
                open.report = report.clone();
            }
            match (&opened, untouched) {
                (Some(_), false) => {
                    self.say(
                        NoteLevel::Warning,
                        format!(
                            "{changed}: {} was checked again for {system} and fits; your edits \
                             of the converted program are kept as they are: open the G-code \
                             again (Ctrl-O) to convert it again",
                            job.path.display()
                        ),
                    );
                    return;
                }
                (Some(_), true) => self.say(
                    NoteLevel::Info,
                    format!(
                        "{changed}: {} checked again for {system}: it fits",
                        job.path.display()
                    ),
                ),
                (None, _) => {
                    self.say(
                        NoteLevel::Danger,
                        format!(
                            "{changed}: {} checked again for {system}: {errors} error{} (job \
                             panel)",
                            job.path.display(),
                            if errors == 1 { "" } else { "s" }
                        ),
                    );
                    if untouched {
                        self.e.replace(self.e.language(), "", now);
                        self.e.job = Some(self.open_job(&job, source, report));
                        self.e.file = FileState::default();
                    }
                    return;
                }
            }
        } else {
            self.remember(&job.path);
            for (level, text) in notes {
                self.say(level, text);
            }
        }
        if !again {
            self.open();
        }
        match opened {
            Some(o) => {
                self.e.replace(o.language, &o.text, now);
                self.e.gcode = Some(Gcode {
                    converted: o.converted,
                    state: self.e.buffer.state(),
                });
                // Unsaved: the recovery file keeps it until it is saved.
                self.e.file = FileState {
                    path: Some(o.path),
                    saved: NEVER_SAVED,
                    ..FileState::default()
                };
            }
            None => {
                // Nothing to run: an empty, untitled program, so that no
                // earlier text passes for this job.
                self.e.replace(self.e.language(), "", now);
                self.e.file = FileState::default();
            }
        }
        self.e.job = Some(self.open_job(&job, source, report));
        if !again {
            self.e.planes = Planes::Job;
        }
    }

    fn open_job(
        &self,
        job: &GcodeJob,
        source: Arc<str>,
        report: crate::ui::editor::job_report::JobReport,
    ) -> OpenJob {
        OpenJob {
            path: job.path.clone(),
            source,
            height_map: job.height_map.clone(),
            offsets: job.offsets.clone(),
            tool: job.tool.clone(),
            report,
            checking: false,
        }
    }
}
