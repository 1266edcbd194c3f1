//! What the editor asks the outside world for ([`EditorIo`], an effect) and
//! what comes back ([`EditorMsg`], a message): files through
//! [`crate::program::store`], and the lint on its own thread. `update`
//! stays pure; [`perform`] is what the runtime's worker runs.

use std::path::PathBuf;
use std::time::SystemTime;

use crate::program::store::{
    self, Fingerprint, Loaded, Origin, Recovery, RecoveryStore, StoreError,
};

use super::checks::{LintJob, LintResult};
use super::dialog::Then;

#[derive(Debug, Clone, PartialEq)]
pub enum EditorIo {
    /// Read a program file, and the recovery of its unsaved edits if any.
    Load {
        path: PathBuf,
        store: Option<RecoveryStore>,
    },
    /// Save atomically; `expect` is what the file held when it was opened;
    /// `fresh`: a new name, which must not be taken yet.
    Save {
        path: PathBuf,
        text: String,
        state: u64,
        expect: Option<Fingerprint>,
        fresh: bool,
        then: Option<Then>,
    },
    WriteRecovery {
        store: RecoveryStore,
        recovery: Recovery,
        state: u64,
    },
    RemoveRecovery {
        store: RecoveryStore,
        origin: Origin,
    },
    DiscardRecovery {
        store: RecoveryStore,
        origin: Origin,
    },
    ScanRecoveries {
        store: RecoveryStore,
    },
    /// Lint and trace a snapshot (CPU only; the lint thread, latest wins).
    Lint(Box<LintJob>),
    /// Import a G-code file (or check its text again) for the console's
    /// profile and work offsets (`gcode_open`).
    ImportGcode(Box<super::gcode_open::GcodeJob>),
    /// Keep the list of files opened last (`program::recent`) in `dir`.
    KeepRecent {
        dir: PathBuf,
        list: Vec<PathBuf>,
    },
    /// A G-code job run from the console, for the job log (`joblog`): the
    /// file worker keeps the run's log open between these.
    JobLog(JobLogEvent),
}

/// What the console's run of a G-code job tells the job log.
#[derive(Debug, Clone, PartialEq)]
pub enum JobLogEvent {
    /// The job starts; the worker stamps the time and hashes the text.
    Start(Box<JobLogStart>),
    /// G-code line `line` ran to its end.
    Line(u32),
    /// The run ended.
    End(crate::joblog::How),
}

#[derive(Debug, Clone, PartialEq)]
pub struct JobLogStart {
    pub file: PathBuf,
    /// The G-code text as read: its hash is the log's content hash.
    pub source: std::sync::Arc<str>,
    pub profile: String,
    pub port: String,
    /// `G54 X50.000 Y50.000 Z60.000 mm`
    pub offset: String,
    pub way: crate::gcode::ways::Way,
    pub estimate_s: Option<f64>,
}

impl JobLogStart {
    fn record(&self) -> crate::joblog::Start {
        let at = crate::joblog::file::now_utc();
        let file = std::path::absolute(&self.file).unwrap_or_else(|_| self.file.clone());
        crate::joblog::Start {
            run: crate::joblog::file::run_id(&at),
            at,
            file: file.display().to_string(),
            hash: Fingerprint::of(self.source.as_bytes()).to_string(),
            profile: self.profile.clone(),
            port: self.port.clone(),
            offset: self.offset.clone(),
            way: self.way.to_string(),
            estimate_s: self.estimate_s.map(crate::joblog::record::seconds),
            from_line: None,
            by: "console".into(),
            pid: std::process::id(),
            boot: crate::joblog::file::boot_id(),
        }
    }
}

/// The job log of the console's run under way, on the file worker: one
/// event at a time; a note for the console when the log cannot be written.
pub fn job_log(log: &mut Option<crate::joblog::JobLog>, event: JobLogEvent) -> Option<String> {
    match event {
        JobLogEvent::Start(start) => {
            // A run not ended (the console never leaves one so) is closed
            // as broken off rather than left open under the new one.
            if let Some(old) = log.take() {
                let _ = old.end(crate::joblog::How::Error);
            }
            let dir = crate::joblog::file::dir()?;
            match crate::joblog::JobLog::start(&dir, &start.record()) {
                Ok(opened) => {
                    *log = Some(opened);
                    None
                }
                Err(e) => Some(format!(
                    "the job log in {} could not be written ({e}); the job runs without it",
                    dir.display()
                )),
            }
        }
        JobLogEvent::Line(line) => {
            if let Some(l) = log.as_ref() {
                l.line(line);
            }
            None
        }
        JobLogEvent::End(how) => log.take().and_then(|l| l.end(how)),
    }
}

/// Why a save did not happen.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SaveFailure {
    /// The file changed on disk since it was opened.
    Changed,
    /// A new name was given and a file has it already.
    Exists,
    Failed(String),
}

#[derive(Debug, Clone, PartialEq)]
pub enum EditorMsg {
    /// Open this program (the command line's `--program`).
    Open(PathBuf),
    /// Open this G-code file as a job (the command line's `--program
    /// part.nc`, with its `--height-map`): imported with the console's
    /// work offsets.
    OpenGcode {
        path: PathBuf,
        height_map: Option<std::sync::Arc<crate::gcode::HeightMapFile>>,
    },
    /// A G-code job imported or checked again (`gcode_open::check`).
    GcodeChecked(Box<super::gcode_open::GcodeChecked>),
    /// A program converted from G-code (the command line's `--program
    /// part.nc`, `docs/gcode.md`): opened unsaved under `path`, with what
    /// the import said of the G-code.
    Imported {
        path: PathBuf,
        language: crate::program::Language,
        text: String,
        /// Level and text, said in order.
        notes: Vec<(crate::ui::traffic_log::NoteLevel, String)>,
        /// The converted program and its ways: what the run key needs
        /// to run a job bigger than the memory.
        gcode: Option<Box<super::job::Converted>>,
    },
    /// Look for unsaved edits of an earlier session (at start).
    Scan,
    Loaded {
        path: PathBuf,
        result: Result<Option<Loaded>, String>,
        recovery: Option<Recovery>,
    },
    Saved {
        path: PathBuf,
        state: u64,
        result: Result<Fingerprint, SaveFailure>,
        then: Option<Then>,
    },
    RecoveryWritten {
        state: u64,
        origin: Origin,
        result: Result<(), String>,
    },
    /// A recovery was removed or put aside.
    RecoveryGone {
        result: Result<(), String>,
    },
    Recoveries(Vec<Result<Recovery, String>>),
    Linted(Box<LintResult>),
    /// The list of files opened last was kept, or why not.
    RecentKept(Result<(), String>),
    /// What the job log said, if anything (it could not be written).
    JobLogged(Option<String>),
}

/// Carry out a file request (blocking) and say how it went.
pub fn perform(io: EditorIo) -> EditorMsg {
    match io {
        EditorIo::Load { path, store } => {
            let result = store::load(&path).map_err(|e| e.to_string());
            let absolute = match &result {
                Ok(Some(loaded)) => loaded.path.clone(),
                _ => store::absolute(&path).unwrap_or(path),
            };
            let recovery =
                store.and_then(|s| s.read(&Origin::File(absolute.clone())).ok().flatten());
            EditorMsg::Loaded {
                path: absolute,
                result,
                recovery,
            }
        }
        EditorIo::Save {
            path,
            text,
            state,
            expect,
            fresh,
            then,
        } => {
            let result = if fresh && std::fs::symlink_metadata(&path).is_ok() {
                Err(SaveFailure::Exists)
            } else {
                store::save(&path, &text, expect).map_err(|e| match e {
                    StoreError::Changed { .. } => SaveFailure::Changed,
                    other => SaveFailure::Failed(other.to_string()),
                })
            };
            EditorMsg::Saved {
                path: store::absolute(&path).unwrap_or(path),
                state,
                result,
                then,
            }
        }
        EditorIo::WriteRecovery {
            store,
            mut recovery,
            state,
        } => {
            // Stamped here: the model reads no clocks.
            recovery.written = SystemTime::now();
            EditorMsg::RecoveryWritten {
                state,
                origin: recovery.origin.clone(),
                result: store
                    .write(&recovery)
                    .map(|_| ())
                    .map_err(|e| e.to_string()),
            }
        }
        EditorIo::RemoveRecovery { store, origin } => EditorMsg::RecoveryGone {
            result: store.remove(&origin).map_err(|e| e.to_string()),
        },
        EditorIo::DiscardRecovery { store, origin } => EditorMsg::RecoveryGone {
            result: store.discard(&origin).map_err(|e| e.to_string()),
        },
        EditorIo::ScanRecoveries { store } => EditorMsg::Recoveries(
            store
                .scan()
                .into_iter()
                .map(|r| r.map_err(|e| e.to_string()))
                .collect(),
        ),
        EditorIo::Lint(job) => EditorMsg::Linted(Box::new(job.run())),
        // Stateful: the file worker's loop keeps the log between events
        // (`job_log`); outside it there is no run to write to.
        EditorIo::JobLog(event) => EditorMsg::JobLogged(job_log(&mut None, event)),
        EditorIo::KeepRecent { dir, list } => EditorMsg::RecentKept(
            crate::program::recent::write(&dir, &list).map_err(|e| e.to_string()),
        ),
        EditorIo::ImportGcode(job) => {
            let mut job = *job;
            // Stamped here: the model reads no clocks.
            job.now_unix = SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| i64::try_from(d.as_secs()).unwrap_or(i64::MAX));
            EditorMsg::GcodeChecked(Box::new(super::gcode_open::check(job)))
        }
    }
}
