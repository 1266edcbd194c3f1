//! A G-code file opened in the console (issue 40): Ctrl-O or `--program`
//! on a `.nc .ngc .gcode .tap .gc` file imports it for the session's
//! profile with the console's own work offsets, on the worker thread
//! ([`check`]), and the editor keeps the G-code ([`OpenJob`]) so that the
//! job is checked again whenever the work offset changes (`O`, `s`, a
//! probe): a job outside the soft limits opens with its errors in the job
//! panel and runs once the zero is set where it fits.

use std::path::PathBuf;
use std::sync::Arc;

use crate::config::profile::Profile;
use crate::gcode::waits::ToolOffset;
use crate::gcode::{HeightMapFile, Target};
use crate::offsets::WorkOffsets;
use crate::program::Language;
use crate::ui::traffic_log::NoteLevel;

use super::job::Converted;
use super::job_report::JobReport;

/// What the worker is asked: import this G-code.
#[derive(Debug, Clone, PartialEq)]
pub struct GcodeJob {
    /// The G-code file as the operator named it.
    pub path: PathBuf,
    /// Its text when it was read already (a check again after the work
    /// offset changed checks the text that was opened, not a file that
    /// may have changed since).
    pub source: Option<Arc<str>>,
    pub profile: Arc<Profile>,
    pub offsets: WorkOffsets,
    /// The tool in the spindle and its offset: every Z shifts by it.
    pub tool: Option<ToolOffset>,
    pub height_map: Option<Arc<HeightMapFile>>,
    /// Seconds since 1970 (the worker's clock): how old a height map is.
    pub now_unix: i64,
}

/// The controller program a G-code job became.
#[derive(Debug, Clone, PartialEq)]
pub struct Opened {
    /// The name it is opened (unsaved) under: the G-code's, with the
    /// family's extension.
    pub path: PathBuf,
    pub language: Language,
    pub text: String,
    pub converted: Converted,
}

/// What the worker found.
#[derive(Debug, Clone, PartialEq)]
pub struct GcodeChecked {
    pub job: GcodeJob,
    /// The file could not be read (its text is then not known).
    pub unreadable: Option<String>,
    pub report: Option<JobReport>,
    /// `None` when the G-code did not import (the report says why).
    pub opened: Option<Opened>,
    /// What to say once: the summary line, the height map's.
    pub notes: Vec<(NoteLevel, String)>,
}

/// The G-code job the editor holds: its text and what it was last
/// checked with.
#[derive(Debug, Clone, PartialEq)]
pub struct OpenJob {
    pub path: PathBuf,
    pub source: Arc<str>,
    pub height_map: Option<Arc<HeightMapFile>>,
    /// The work offsets of the last check; another table checks again.
    pub offsets: WorkOffsets,
    /// The tool offset of the last check; another one checks again.
    pub tool: Option<ToolOffset>,
    pub report: JobReport,
    /// A check is on the worker now.
    pub checking: bool,
}

pub use crate::gcode::import::header_name;

/// Read (unless given) and import `job`: CPU and one file read, run on the
/// editor's worker.
pub fn check(mut job: GcodeJob) -> GcodeChecked {
    let name = job.path.display().to_string();
    let rechecked = job.source.is_some();
    let source = match job.source.clone() {
        Some(text) => text,
        None => match crate::program::store::load(&job.path) {
            Ok(Some(loaded)) => Arc::from(loaded.text),
            Ok(None) => {
                return GcodeChecked::unreadable(job, format!("{name}: no such file"));
            }
            Err(e) => return GcodeChecked::unreadable(job, e.to_string()),
        },
    };
    job.source = Some(source.clone());
    let target = match Target::of(job.profile.connection.protocol) {
        Ok(t) => t,
        Err(why) => return GcodeChecked::unreadable(job, format!("{name}: {why}")),
    };
    let (language, extension) = match target {
        Target::Isel => (Language::Isel, "isel"),
        Target::Emcu => (Language::Emcu, "emcu"),
    };
    let header = header_name(&job.path);
    let imported = crate::gcode::import::import_with_tool(
        &source,
        &header,
        &job.profile,
        &job.offsets,
        target,
        job.height_map.as_deref(),
        job.tool.as_ref(),
    );
    match imported {
        Err(diagnostics) => {
            let report = JobReport::refused(&name, &source, &diagnostics);
            let errors = report.errors.len();
            GcodeChecked {
                notes: vec![(
                    NoteLevel::Danger,
                    format!(
                        "{name}: {errors} error{} (the job panel lists them at their lines): it does not run until they are fixed",
                        if errors == 1 { "" } else { "s" }
                    ),
                )],
                job,
                unreadable: None,
                report: Some(report),
                opened: None,
            }
        }
        Ok(import) => {
            let converted = Converted::new(
                name.clone(),
                header.clone(),
                import.program.clone(),
                import.summary.estimated_s,
                &job.profile,
                language,
            )
            .with_waits(
                &import.plan,
                &import.toolpath,
                crate::gcode::output::Header {
                    file: header.clone(),
                    profile: job.profile.name.clone(),
                    system: import.summary.system.to_string(),
                    zero: import.summary.zero,
                },
            )
            .with_tool_shift(import.tool.as_ref().map_or(0.0, |t| t.offset_mm));
            let report = JobReport::imported(&name, &source, &import, &converted.ways);
            let mut notes = vec![(
                NoteLevel::Info,
                format!(
                    "{name}: imported for work offset {}; the job panel beside the program shows it (F9: the toolpath instead); unsaved until you save it",
                    import.summary.system
                ),
            )];
            if let Some(m) = &import.height_map {
                notes.push((NoteLevel::Info, m.describe(job.now_unix).trim().to_owned()));
            }
            // The job log's offer (docs/gcode.md, "Resume"), said once, when
            // the file is opened rather than checked again.
            if !rechecked && let Some(note) = crate::joblog::resume::console_note(&job.path) {
                notes.push((NoteLevel::Warning, note));
            }
            GcodeChecked {
                opened: Some(Opened {
                    path: job.path.with_extension(extension),
                    language,
                    text: import.program.text(&header),
                    converted,
                }),
                notes,
                job,
                unreadable: None,
                report: Some(report),
            }
        }
    }
}

impl GcodeChecked {
    fn unreadable(job: GcodeJob, why: String) -> GcodeChecked {
        GcodeChecked {
            job,
            unreadable: Some(why),
            report: None,
            opened: None,
            notes: Vec::new(),
        }
    }
}
