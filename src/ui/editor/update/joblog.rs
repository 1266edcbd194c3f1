//! The console's runs of a G-code job in the job log (issue 41 item 4,
//! `docs/gcode.md` "Job log"), as `jogterm run` writes them: a start when
//! the job starts (stored, in parts or streamed), each G-code line a stream
//! has run to its end, and how it ended. Only the converted G-code as it
//! was converted is logged: an edited text is no longer that file's job.
//! The writing is the file worker's (`io::job_log`); here the events go out
//! as effects.

use crate::gcode::ways::Way;
use crate::joblog::How;
use crate::ui::editor::component::Effect;
use crate::ui::editor::io::{EditorIo, JobLogEvent, JobLogStart};

use super::Step;

impl Step<'_, '_> {
    /// A job of the editor starts `way`: logged when it is the opened
    /// G-code's converted program, untouched.
    pub(super) fn job_log_start(&mut self, way: Way) {
        let Some(g) = self
            .e
            .gcode
            .as_ref()
            .filter(|g| g.state == self.e.buffer.state())
        else {
            return;
        };
        let Some(job) = self.e.job.as_ref() else {
            return;
        };
        let Some(figures) = job.report.figures.as_ref() else {
            return;
        };
        let [x, y, z] = figures.zero;
        let start = JobLogStart {
            file: job.path.clone(),
            source: job.source.clone(),
            profile: self.ctx.setup.profile.name.clone(),
            port: self.ctx.setup.profile.connection.port.clone(),
            offset: format!("{} X{x:.3} Y{y:.3} Z{z:.3} mm", figures.system),
            way,
            estimate_s: g.converted.ways.estimate(way).map(|e| e.total_s),
        };
        self.e.job_logged = Some(None);
        self.log(JobLogEvent::Start(Box::new(start)));
    }

    /// A stream's command of G-code line `line` starts: the line before,
    /// if another, has run to its end.
    pub(super) fn job_log_line(&mut self, line: u32) {
        let Some(running) = self.e.job_logged.as_mut() else {
            return;
        };
        let before = running.replace(line);
        if let Some(done) = before.filter(|b| *b != line) {
            self.log(JobLogEvent::Line(done));
        }
    }

    /// G-code line `line` has run to its end (a stored part of a job with
    /// waits ended): logged at once, nothing running after it.
    pub(super) fn job_log_done(&mut self, line: u32) {
        let Some(running) = self.e.job_logged.as_mut() else {
            return;
        };
        *running = None;
        self.log(JobLogEvent::Line(line));
    }

    /// The logged job ended `how` (the first end said counts).
    pub(super) fn job_log_end(&mut self, how: How) {
        let Some(running) = self.e.job_logged.take() else {
            return;
        };
        if let (How::Done, Some(last)) = (how, running) {
            self.log(JobLogEvent::Line(last));
        }
        self.log(JobLogEvent::End(how));
    }

    fn log(&mut self, event: JobLogEvent) {
        self.out.effects.push(Effect::Io(EditorIo::JobLog(event)));
    }
}
